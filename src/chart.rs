//! The solved chart: chosen from the constraints, checked, hole-filled, with
//! constraints and corners in chart-local ids; and the final per-primitive UVs.

use crate::constraints::ConstraintSource;
use crate::domain::Domain;
use crate::error::Error;
use crate::guard::{self, OrientationCounts};
use crate::io::SourceAsset;
use crate::mesh::topology::Topology;
use crate::mesh::weld::{Chart, WeldedMesh, weld};
use crate::param::bar_net::{FilledChart, fill_holes};
use crate::param::boundary::{BoundaryMap, TrapCandidates};
use crate::param::{uv_to_xy, xy_to_uv};
use crate::pins::ResolvedConstraint;
use crate::rbf::stepping::{StepProblem, pick_anchors};
use glam::DVec2;
use std::sync::Arc;

/// Everything about the chart being solved that does not depend on the layout.
#[derive(Debug, Clone)]
///
/// The geometry (weld, chart, topology, trap candidates, hole fill) is shared
/// behind `Arc`s, so a constraint edit on the same asset reuses it
/// ([`PreparedChart::retargeted`]).
pub struct PreparedChart {
    pub welded: Arc<WeldedMesh>,
    pub chart: Arc<Chart>,
    pub topology: Arc<Topology>,
    pub traps: Arc<TrapCandidates>,
    pub filled: Arc<FilledChart>,
    pub constraints: Vec<ResolvedConstraint>,
    /// Chart-local vertex of each constraint (same order as `constraints`).
    pub constraint_vertices: Vec<u32>,
    /// Given corners, chart-local.
    pub corners: Option<[u32; 4]>,
    /// Where it is laid out: the outer boundary on the square, or free inside a region.
    pub domain: Domain,
    pub warnings: Vec<String>,
}

/// Welds the asset's mesh, resolves the constraints, picks the chart that
/// holds them (the largest chart when there are none), and checks its topology.
///
/// # Errors
/// Constraint errors against the asset (with line:column for a file),
/// constraints in several charts, corners outside the chart, topology
/// errors of the chart (closed, non-manifold, not a disk).
pub fn prepare(source: &ConstraintSource, asset: &SourceAsset) -> Result<PreparedChart, Error> {
    prepare_on(source, asset, Arc::new(weld(&asset.primitives)), None)
}

impl PreparedChart {
    /// The same asset's chart for new constraints `source`: this weld, and
    /// this chart's topology, trap candidates and hole fill when the
    /// constraints fall in the same chart (shared, see
    /// [`Self::same_geometry`]); only the constraints and corners are
    /// resolved again.
    ///
    /// # Errors
    /// As [`prepare`].
    pub fn retargeted(&self, source: &ConstraintSource, asset: &SourceAsset) -> Result<PreparedChart, Error> {
        prepare_on(source, asset, self.welded.clone(), Some(self))
    }
}

fn prepare_on(
    source: &ConstraintSource,
    asset: &SourceAsset,
    welded: Arc<WeldedMesh>,
    previous: Option<&PreparedChart>,
) -> Result<PreparedChart, Error> {
    let (constraints, welded_corners) = source.resolve(&asset.primitives, &welded)?;
    let chart_id = choose_chart(&constraints, &welded, source, asset)?;
    let geometry = match previous.filter(|p| p.chart.id == chart_id) {
        Some(p) => (p.chart.clone(), p.topology.clone(), p.traps.clone(), p.filled.clone()),
        None => chart_geometry(&welded, chart_id, asset)?,
    };
    let (chart, topology, traps, filled) = geometry;
    let constraint_vertices = constraints
        .iter()
        .map(|c| chart.local_of(c.welded).expect("constraint in the chart"))
        .collect();
    let corners = welded_corners.map(|w| local_corners(w, &chart, source)).transpose()?;
    let mut warnings: Vec<String> = missing_uv_warning(asset, &welded, chart_id).into_iter().collect();
    let domain = crate::domain::setup::decide(source, asset, &welded, &chart, &constraints)?;
    if corners.is_some() && matches!(domain, Domain::Free(_)) {
        warnings.push("corners are ignored: the boundary is free".into());
    }
    Ok(PreparedChart {
        welded,
        chart,
        topology,
        traps,
        filled,
        constraints,
        constraint_vertices,
        corners,
        domain,
        warnings,
    })
}

/// The chart holding every constraint, or the largest chart without any.
fn choose_chart(
    constraints: &[ResolvedConstraint],
    welded: &WeldedMesh,
    source: &ConstraintSource,
    asset: &SourceAsset,
) -> Result<u32, Error> {
    let chart_of =
        |c: &ResolvedConstraint| welded.chart_of_vertex[c.welded as usize].expect("resolved vertices are used");
    let Some(first) = constraints.first() else {
        let sizes = welded.chart_sizes();
        let largest = (0..sizes.len()).max_by_key(|&c| (sizes[c].1, std::cmp::Reverse(c)));
        return largest.map(|c| c as u32).ok_or_else(|| {
            Error::Asset(crate::io::AssetError::MeshSelection {
                path: asset.path.clone(),
                message: "the mesh has no triangles".into(),
            })
        });
    };
    let id = chart_of(first);
    match constraints.iter().find(|c| chart_of(c) != id) {
        None => Ok(id),
        Some(other) => Err(source.error_at(
            other.index,
            "vertex",
            format!(
                "vertex {} is in chart {} but constraints[{}] (vertex {}) is in chart {id}: all constraints must be in one chart \
                 (the mesh has {} charts: connected pieces after welding equal positions{})",
                other.vertex,
                chart_of(other),
                first.index,
                first.vertex,
                welded.n_charts,
                if asset.primitives.iter().any(|p| p.uvs.is_some()) { " and UVs" } else { "" }
            ),
        )
        .into()),
    }
}

/// Chart `chart_id` of `welded`, its checked topology, trap candidates and hole fill.
type ChartGeometry = (Arc<Chart>, Arc<Topology>, Arc<TrapCandidates>, Arc<FilledChart>);

fn chart_geometry(welded: &WeldedMesh, chart_id: u32, asset: &SourceAsset) -> Result<ChartGeometry, Error> {
    let chart = welded.chart(chart_id);
    let topology = Topology::build(&chart.mesh).map_err(|source| Error::Topology {
        path: asset.path.clone(),
        mesh: asset.mesh_index,
        chart: chart_id,
        n_vertices: chart.mesh.n_vertices(),
        n_triangles: chart.mesh.n_triangles(),
        source,
    })?;
    let traps = TrapCandidates::find(&chart.mesh, &topology);
    let filled = fill_holes(&chart.mesh, &topology);
    Ok((Arc::new(chart), Arc::new(topology), Arc::new(traps), Arc::new(filled)))
}

/// The corners (welded ids) as chart-local ids.
fn local_corners(welded: [u32; 4], chart: &Chart, source: &ConstraintSource) -> Result<[u32; 4], Error> {
    let mut local = [0u32; 4];
    for k in 0..4 {
        local[k] = chart.local_of(welded[k]).ok_or_else(|| {
            source.corners_error(format!(
                "{} is not in the solved chart {}",
                crate::param::boundary::CORNER_NAMES[k],
                chart.id
            ))
        })?;
    }
    Ok(local)
}

/// A warning when vertices outside the solved chart have no UVs to keep.
fn missing_uv_warning(asset: &SourceAsset, welded: &WeldedMesh, chart_id: u32) -> Option<String> {
    let without_uvs: usize = asset
        .primitives
        .iter()
        .zip(&welded.vertex_of)
        .filter(|(p, _)| p.uvs.is_none())
        .map(|(_, map)| {
            map.iter()
                .filter(|w| welded.chart_of_vertex[**w as usize] != Some(chart_id))
                .count()
        })
        .sum();
    (without_uvs > 0).then(|| {
        format!(
            "{without_uvs} vertices outside the solved chart had no TEXCOORD_{} and are written as (0, 0)",
            asset.uv_set
        )
    })
}

impl PreparedChart {
    /// Whether `other` shares this chart's geometry (so its boundary map,
    /// bar-net factor and step-1 layout apply here too).
    pub fn same_geometry(&self, other: &PreparedChart) -> bool {
        Arc::ptr_eq(&self.filled, &other.filled)
    }
}

/// Tolerance for a constraint on the outer boundary to agree with the boundary map.
pub const BOUNDARY_TOLERANCE: f64 = 1e-6;

/// Splits the constraints into those the spline moves and those on the outer
/// boundary, which must already sit on their targets.
///
/// # Errors
/// A constraint on the outer boundary whose target differs from where the
/// boundary map puts it.
pub fn step_problem(
    prepared: &PreparedChart,
    source: &ConstraintSource,
    boundary: &BoundaryMap,
    max_boundary_centres: usize,
) -> Result<StepProblem, Error> {
    let n = prepared.filled.mesh.n_vertices();
    let mut on_outer = vec![None; n];
    for (i, &v) in boundary.loop_vertices.iter().enumerate() {
        on_outer[v as usize] = Some(i);
    }
    let mut problem = StepProblem::default();
    if prepared.domain.free().is_some() {
        // A free boundary moves: every constraint is the spline's and every
        // vertex movable (hole centres too); the spline path first holds a
        // sample of the outer loop (as the square does), so its field stays
        // tame there, and lets it go if it stalls so (`ChartSolver`).
        for (c, &v) in prepared.constraints.iter().zip(&prepared.constraint_vertices) {
            problem.constraint_vertices.push(v);
            problem.targets.push(uv_to_xy(c.target_uv));
        }
        let anchors = pick_anchors(prepared.topology.outer_loop(), max_boundary_centres, &[]);
        problem.anchors = anchors
            .into_iter()
            .filter(|v| !problem.constraint_vertices.contains(v))
            .collect();
        problem.movable = (0..n as u32).collect();
        return Ok(problem);
    }
    for (c, &v) in prepared.constraints.iter().zip(&prepared.constraint_vertices) {
        let target = uv_to_xy(c.target_uv);
        match on_outer[v as usize] {
            Some(i) => {
                let at = boundary.positions[i];
                if at.distance(target) > BOUNDARY_TOLERANCE {
                    let uv = xy_to_uv(at);
                    return Err(source.error_at(
                        c.index,
                        source.target_field(c.index),
                        format!(
                            "vertex {} is on the outer boundary, which the boundary mapping places at ({:.6}, {:.6}); \
                             the target ({}, {}) contradicts it. Constrain an interior vertex, or make this vertex a corner",
                            c.vertex, uv.x, uv.y, c.target_uv.x, c.target_uv.y
                        ),
                    )
                    .into());
                }
            }
            None => {
                problem.constraint_vertices.push(v);
                problem.targets.push(target);
            }
        }
    }
    problem.anchors = pick_anchors(
        &boundary.loop_vertices,
        max_boundary_centres,
        &boundary.corner_vertices(),
    );
    problem.movable = (0..n as u32).filter(|&v| on_outer[v as usize].is_none()).collect();
    Ok(problem)
}

/// Texture coordinates per primitive of an asset (glTF's `TEXCOORD_0`, one per vertex).
pub type PrimitiveUvs = Vec<Vec<[f32; 2]>>;

/// Final per-primitive UVs (glTF texture coordinates, f32): the solved chart's
/// from `layout`, every other vertex's as it was (or (0, 0) without UVs).
pub fn assemble_uvs(asset: &SourceAsset, prepared: &PreparedChart, layout: &[DVec2]) -> PrimitiveUvs {
    asset
        .primitives
        .iter()
        .zip(&prepared.welded.vertex_of)
        .map(|(prim, map)| {
            map.iter()
                .enumerate()
                .map(|(i, w)| match prepared.chart.local_of(*w) {
                    Some(local) => guard::stored_uv(layout[local as usize]),
                    None => prim.uvs.as_ref().map_or([0.0, 0.0], |u| u[i]),
                })
                .collect()
        })
        .collect()
}

/// The solved chart's OBJ texture coordinates as stored (`vt`, f32, v up),
/// one per vertex of the single OBJ primitive; vertices outside the chart
/// get (0, 1), glTF's (0, 0).
pub fn assemble_obj_vt(asset: &SourceAsset, prepared: &PreparedChart, layout: &[DVec2]) -> Vec<[f32; 2]> {
    prepared.welded.vertex_of[0]
        .iter()
        .enumerate()
        .map(|(i, w)| match prepared.chart.local_of(*w) {
            Some(local) => guard::stored_vt(layout[local as usize]),
            None => asset.primitives[0]
                .uvs
                .as_ref()
                .map_or([0.0, 1.0], |u| [u[i][0], 1.0 - u[i][1]]),
        })
        .collect()
}

/// Orientation of the solved chart exactly as it will be stored, real and
/// virtual hole triangles: the worse of glTF's f32 texture coordinates and
/// OBJ's f32 `vt` (every accepted layout is clean in both).
pub fn written_orientation(prepared: &PreparedChart, layout: &[DVec2]) -> OrientationCounts {
    let triangles = &prepared.filled.mesh.triangles;
    let gltf: Vec<[f32; 2]> = layout.iter().map(|p| guard::stored_uv(*p)).collect();
    let obj: Vec<[f32; 2]> = layout.iter().map(|p| guard::stored_vt(*p)).collect();
    let a = guard::count_stored_orientations(&gltf, triangles, guard::VAxis::Down);
    let b = guard::count_stored_orientations(&obj, triangles, guard::VAxis::Up);
    if a.flipped + a.zero_area >= b.flipped + b.zero_area {
        a
    } else {
        b
    }
}
