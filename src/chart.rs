//! The solved chart: chosen from the constraints, checked, hole-filled, with
//! constraints and corners in chart-local ids; and the final per-primitive UVs.

use crate::constraints::ConstraintSource;
use crate::cut::prepare::make_solvable;
use crate::cut::{SeamRules, SeamSpec};
use crate::domain::Domain;
use crate::error::Error;
use crate::guard::{self, OrientationCounts};
use crate::io::SourceAsset;
use crate::io::corners::CornerUvs;
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
    /// How the chart was made solvable: seams, repairs, repeated triangles.
    pub opening: Arc<Opening>,
}

/// What was done to a chart so it could be solved: where it was cut open
/// and what was repaired (chart-local ids of `PreparedChart::chart`).
#[derive(Debug, Clone, Default)]
pub struct Opening {
    /// The seams it was cut along (`None`: it was a disk).
    pub seam: Option<crate::cut::Seam>,
    /// Whether the seams were given in the constraint file (else automatic).
    pub seam_given: bool,
    /// How many vertices the seam split off.
    pub seam_copies: usize,
    /// What was split apart to repair it.
    pub repairs: crate::mesh::wedges::Repairs,
    /// Triangles given twice: (welded triangle left out, chart triangle
    /// whose UVs it takes).
    pub duplicates: Vec<(u32, u32)>,
    /// What the geometry was made for: the seams asked for and, for a
    /// chart that was cut automatically, its landmarks (welded ids, sorted).
    key: GeometryKey,
}

/// What a chart's geometry depends on beyond the chart itself.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct GeometryKey {
    seams: crate::pins::SeamsChoice,
    landmarks: Option<Vec<u32>>,
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
    let seams = source.seams(&asset.primitives, &welded)?;
    let landmarks: Vec<u32> = constraints.iter().map(|c| c.welded).collect();
    let reusable = previous.filter(|p| p.chart.id == chart_id && p.opening.key.fits(&seams, &landmarks));
    let geometry = match reusable {
        Some(p) => (
            p.chart.clone(),
            p.topology.clone(),
            p.traps.clone(),
            p.filled.clone(),
            p.opening.clone(),
        ),
        None => chart_geometry(&welded, chart_id, asset, source, &seams, &landmarks)?,
    };
    let (chart, topology, traps, filled, opening) = geometry;
    let constraint_vertices = constraints
        .iter()
        .map(|c| chart.local_of(c.welded).expect("constraint in the chart"))
        .collect();
    let corners = welded_corners.map(|w| local_corners(w, &chart, source)).transpose()?;
    let mut warnings: Vec<String> = missing_uv_warning(asset, &welded, chart_id).into_iter().collect();
    warnings.extend(repair_warnings(&opening));
    let cut = opening.seam.is_some();
    let domain = crate::domain::setup::decide(source, asset, &welded, &chart, &constraints, cut)?;
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
        opening,
    })
}

impl GeometryKey {
    /// Whether geometry made for this key serves `seams` and `landmarks`
    /// (welded ids): the same seams asked for and, if the chart was cut
    /// automatically, the same landmark vertices.
    fn fits(&self, seams: &crate::pins::SeamsChoice, landmarks: &[u32]) -> bool {
        self.seams == *seams && self.landmarks.as_ref().is_none_or(|l| *l == sorted(landmarks))
    }
}

fn sorted(ids: &[u32]) -> Vec<u32> {
    let mut v = ids.to_vec();
    v.sort_unstable();
    v.dedup();
    v
}

/// What the report says about repairs.
fn repair_warnings(opening: &Opening) -> Vec<String> {
    let r = &opening.repairs;
    let mut out = Vec::new();
    if !r.pinches.is_empty() {
        out.push(format!(
            "{} pinched vertices (where separate fans meet, e.g. chart vertex {}) were split for the solve",
            r.pinches.len(),
            r.pinches[0]
        ));
    }
    if let Some((edge, triangles)) = r.non_manifold_edges.first() {
        out.push(format!(
            "{} edges shared by more than two triangles (e.g. edge ({}, {}) of triangles {triangles:?}) were split for the solve",
            r.non_manifold_edges.len(),
            edge[0],
            edge[1]
        ));
    }
    if let Some((edge, t)) = r.inconsistent_edges.first() {
        out.push(format!(
            "{} edges whose two triangles are wound opposite ways (e.g. edge ({}, {}) of triangles {} and {}) were split for the solve",
            r.inconsistent_edges.len(),
            edge[0],
            edge[1],
            t[0],
            t[1]
        ));
    }
    if !opening.duplicates.is_empty() {
        out.push(format!(
            "{} triangles repeat another's vertices and take its UVs (e.g. welded triangle {})",
            opening.duplicates.len(),
            opening.duplicates[0].0
        ));
    }
    out
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

/// Chart `chart_id` of `welded` made solvable (repaired, cut open where it
/// must be), its topology, trap candidates, hole fill and how it was opened.
type ChartGeometry = (
    Arc<Chart>,
    Arc<Topology>,
    Arc<TrapCandidates>,
    Arc<FilledChart>,
    Arc<Opening>,
);

fn chart_geometry(
    welded: &WeldedMesh,
    chart_id: u32,
    asset: &SourceAsset,
    source: &ConstraintSource,
    seams: &crate::pins::SeamsChoice,
    landmarks: &[u32],
) -> Result<ChartGeometry, Error> {
    let chart = welded.chart(chart_id);
    let local = |w: &u32| chart.local_of(*w);
    let spec = match seams {
        crate::pins::SeamsChoice::Auto => SeamSpec::Auto,
        crate::pins::SeamsChoice::Edges(paths) => {
            let mut local_paths = Vec::with_capacity(paths.len());
            for (k, path) in paths.iter().enumerate() {
                let ids: Option<Vec<u32>> = path.iter().map(local).collect();
                local_paths.push(
                    ids.ok_or_else(|| source.seams_error(format!("seams[{k}] leaves the solved chart {chart_id}")))?,
                );
            }
            SeamSpec::Edges(local_paths)
        }
    };
    let landmark_ids: Vec<u32> = landmarks.iter().filter_map(local).collect();
    let diagonals = polygon_diagonals(asset, welded, &chart);
    let solvable = make_solvable(&chart, &spec, &landmark_ids, &diagonals, &SeamRules::DEFAULT).map_err(|source| {
        Error::Topology {
            path: asset.path.clone(),
            mesh: asset.mesh_index,
            chart: chart_id,
            n_vertices: chart.mesh.n_vertices(),
            n_triangles: chart.mesh.n_triangles(),
            source,
        }
    })?;
    let auto_cut = solvable.seam.is_some() && matches!(spec, SeamSpec::Auto);
    let opening = Opening {
        seam: solvable.seam,
        seam_given: matches!(spec, SeamSpec::Edges(_)),
        seam_copies: solvable.seam_copies,
        repairs: solvable.repairs,
        duplicates: solvable.duplicates,
        key: GeometryKey {
            seams: seams.clone(),
            landmarks: auto_cut.then(|| sorted(landmarks)),
        },
    };
    let (chart, topology) = (solvable.chart, solvable.topology);
    let traps = TrapCandidates::find(&chart.mesh, &topology);
    let filled = fill_holes(&chart.mesh, &topology);
    Ok((
        Arc::new(chart),
        Arc::new(topology),
        Arc::new(traps),
        Arc::new(filled),
        Arc::new(opening),
    ))
}

/// The edges an OBJ's triangulation added inside its polygons, as
/// chart-local pairs: a seam along one would split a polygon's corner.
fn polygon_diagonals(asset: &SourceAsset, welded: &WeldedMesh, chart: &Chart) -> Vec<[u32; 2]> {
    let crate::io::Container::Obj { faces, .. } = &asset.container else {
        return Vec::new();
    };
    let map = &welded.vertex_of[0];
    let mut out: Vec<[u32; 2]> = faces
        .diagonals
        .iter()
        .filter_map(|d| {
            let (a, b) = (chart.local_of(map[d[0] as usize])?, chart.local_of(map[d[1] as usize])?);
            Some([a.min(b), a.max(b)])
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
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

/// How one layout point is stored, and what a vertex outside the chart keeps.
#[derive(Debug, Clone, Copy)]
struct Storage {
    /// A layout point as stored.
    store: fn(DVec2) -> [f32; 2],
    /// A vertex's old UV (glTF convention) as stored.
    keep: fn([f32; 2]) -> [f32; 2],
    /// A vertex outside the chart without UVs.
    missing: [f32; 2],
    /// OBJ's `vt` (an OBJ atlas's own values are kept as read).
    vt: bool,
}

const GLTF: Storage = Storage {
    store: guard::stored_uv,
    keep: |uv| uv,
    missing: [0.0, 0.0],
    vt: false,
};

const OBJ: Storage = Storage {
    store: guard::stored_vt,
    keep: |uv| [uv[0], 1.0 - uv[1]],
    missing: [0.0, 1.0],
    vt: true,
};

/// Final UVs per face corner of every primitive (glTF texture coordinates,
/// f32): the solved chart's from `layout` (a vertex on a seam has one per
/// side), every other corner's as it was (or (0, 0) without UVs).
pub fn assemble_corner_uvs(asset: &SourceAsset, prepared: &PreparedChart, layout: &[DVec2]) -> Vec<CornerUvs> {
    assemble(asset, prepared, layout, GLTF)
}

/// As [`assemble_corner_uvs`] in OBJ's `vt` convention (f32, v up) for
/// the single OBJ primitive; corners outside the chart get (0, 1), glTF's
/// (0, 0).
pub fn assemble_obj_corners(asset: &SourceAsset, prepared: &PreparedChart, layout: &[DVec2]) -> CornerUvs {
    assemble(asset, prepared, layout, OBJ).swap_remove(0)
}

/// Final UVs per vertex of every primitive: as [`assemble_corner_uvs`],
/// a vertex on a seam with its first corner's UV (the library's and the
/// editor's per-vertex view; files get every side).
pub fn assemble_uvs(asset: &SourceAsset, prepared: &PreparedChart, layout: &[DVec2]) -> PrimitiveUvs {
    assemble_corner_uvs(asset, prepared, layout)
        .iter()
        .zip(&asset.primitives)
        .map(|(c, prim)| {
            let mut uvs = c.split(&prim.indices).uvs;
            uvs.truncate(prim.positions.len());
            uvs
        })
        .collect()
}

fn assemble(asset: &SourceAsset, prepared: &PreparedChart, layout: &[DVec2], how: Storage) -> Vec<CornerUvs> {
    let chart = &prepared.chart;
    // An OBJ atlas's corners outside the chart keep their `vt` bits as read.
    let raw_vt = match &asset.container {
        crate::io::Container::Obj { faces, .. } if how.vt => faces.vt.as_deref(),
        _ => None,
    };
    let welded = &prepared.welded;
    // Welded triangle → the chart triangle that gives its corners.
    let mut chart_triangle = vec![u32::MAX; welded.mesh.n_triangles()];
    for (k, &w) in chart.triangle_ids.iter().enumerate() {
        chart_triangle[w as usize] = k as u32;
    }
    for &(w, k) in &prepared.opening.duplicates {
        chart_triangle[w as usize] = k;
    }
    let mut first_triangle = 0usize;
    asset
        .primitives
        .iter()
        .zip(&welded.vertex_of)
        .map(|(prim, map)| {
            let old = |v: u32| match (raw_vt, &prim.uvs) {
                (Some(vt), _) => vt[v as usize],
                (None, Some(u)) => (how.keep)(u[v as usize]),
                (None, None) => how.missing,
            };
            let mut corners = Vec::with_capacity(prim.indices.len());
            for (j, t) in prim.indices.chunks_exact(3).enumerate() {
                let k = chart_triangle[first_triangle + j];
                for &v in t {
                    corners.push(if k == u32::MAX {
                        old(v)
                    } else {
                        let tri = chart.mesh.triangles[k as usize];
                        let w = map[v as usize];
                        let c = tri
                            .iter()
                            .find(|&&c| chart.welded_ids[c as usize] == w)
                            .expect("corner of its triangle");
                        (how.store)(layout[*c as usize])
                    });
                }
            }
            first_triangle += prim.indices.len() / 3;
            let unused = (0..prim.positions.len() as u32)
                .map(|v| match chart.local_of(map[v as usize]) {
                    Some(local) => (how.store)(layout[local as usize]),
                    None => old(v),
                })
                .collect();
            CornerUvs { corners, unused }
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
