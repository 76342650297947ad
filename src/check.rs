//! Checks of texture coordinates as stored, from uvpin or any tool: per
//! chart, flipped and zero-area triangles (exactly as stored) and Sander
//! stretch; for the atlas, whether it is one-to-one; per constraint, the
//! residual against its target as the file format can hold it.

use crate::constraints::LoadedConstraints;
use crate::guard;
use crate::guard::VAxis;
use crate::io::{MeshSelector, SourceAsset};
use crate::mesh::weld::{WeldedMesh, weld};
use crate::metrics::sander_stretch;
use crate::param::{uv_to_xy, xy_to_uv};
use glam::DVec2;
use serde::Serialize;
use std::path::Path;

/// What [`check_file`] and [`check_stored`] found.
#[derive(Debug, Serialize)]
pub struct CheckReport {
    pub asset: String,
    pub mesh: usize,
    pub uv_set: u32,
    pub charts: Vec<ChartCheck>,
    pub atlas: Atlas,
    pub constraints: Vec<ConstraintCheck>,
    /// Every chart fold-free, the atlas one-to-one, every constraint within
    /// the file's tolerance.
    pub clean: bool,
}

/// The asset and its texture coordinates exactly as stored, per vertex of
/// each primitive, with the direction of their v axis.
pub struct StoredAsset {
    pub asset: SourceAsset,
    pub uvs: Vec<Vec<[f32; 2]>>,
    pub axis: VAxis,
}

#[derive(Debug, Serialize)]
pub struct ChartCheck {
    pub chart: u32,
    pub vertices: usize,
    pub triangles: usize,
    pub flipped: usize,
    pub zero_area: usize,
    /// Faces that name one vertex twice (no area in the mesh either): not
    /// counted as flipped or zero-area.
    pub repeated_corner: usize,
    /// Every triangle flipped: a mirrored chart (stretch measured on its mirror image).
    pub mirrored: bool,
    pub stretch_l2: f64,
    pub stretch_linf: f64,
    /// Pairs of its boundary edges that cross (it overlaps itself).
    pub crossings: usize,
    /// Other charts it overlaps.
    pub overlaps: Vec<u32>,
}

#[derive(Debug, Serialize)]
pub struct ConstraintCheck {
    pub index: usize,
    pub vertex: u32,
    pub target: DVec2,
    pub actual: DVec2,
    /// Distance from the stored UV to the target rounded to f32 (what glTF can hold).
    pub residual: f64,
}

/// The whole atlas: one-to-one or not.
#[derive(Debug, Serialize)]
pub struct Atlas {
    /// No chart crosses itself or overlaps another (every pair looked at).
    pub injective: bool,
    /// Every pair of boundary edges was looked at.
    pub complete: bool,
    pub overlapping_pairs: usize,
    pub crossings: usize,
}

/// Reads the asset to check: glTF's TEXCOORD_`uv_set`, or an OBJ's `vt`.
///
/// # Errors
/// Asset errors; a primitive without the UV set.
pub fn load_stored(asset_path: &Path, uv_set: u32, mesh: Option<&MeshSelector>) -> crate::Result<StoredAsset> {
    let rules = crate::io::InputRules::default();
    let missing = |asset: &SourceAsset, primitive: usize, what: String| {
        crate::error::Error::from(crate::io::AssetError::Primitive {
            path: asset.path.clone(),
            mesh: asset.mesh_index,
            primitive,
            message: format!("has no {what} to check"),
        })
    };
    if crate::io::AssetFormat::of(asset_path) == Some(crate::io::AssetFormat::Obj) {
        let (asset, vt) = crate::io::load_obj_with_tex_coords(asset_path, &rules)?;
        let vt = vt.ok_or_else(|| missing(&asset, 0, "texture coordinates (vt) on every face corner".into()))?;
        return Ok(StoredAsset {
            asset,
            uvs: vec![vt],
            axis: VAxis::Up,
        });
    }
    let asset = crate::io::load_asset(asset_path, mesh, uv_set, &rules)?;
    let uvs = asset
        .primitives
        .iter()
        .map(|p| {
            p.uvs
                .clone()
                .ok_or_else(|| missing(&asset, p.index, format!("TEXCOORD_{uv_set}")))
        })
        .collect::<crate::Result<Vec<_>>>()?;
    Ok(StoredAsset {
        asset,
        uvs,
        axis: VAxis::Down,
    })
}

/// Checks the UVs stored in `asset_path` (and the residuals of the
/// `constraints` file's landmarks, when given).
///
/// # Errors
/// Asset errors, a primitive without the UV set, constraint-file errors.
pub fn check_file(
    asset_path: &Path,
    uv_set: u32,
    mesh: Option<&MeshSelector>,
    constraints: Option<&Path>,
) -> crate::Result<CheckReport> {
    let stored = load_stored(asset_path, uv_set, mesh)?;
    let welded = weld(&stored.asset.primitives);
    let (residuals, tolerance) = match constraints {
        Some(path) => check_constraints(path, &stored, &welded, &welded_uvs(&stored, &welded))?,
        None => (Vec::new(), crate::options::SolverOptions::DEFAULT.tolerance),
    };
    Ok(check_welded(&stored, &welded, uv_set, residuals, tolerance))
}

/// Checks an in-memory mesh's texture coordinates, one per vertex (glTF
/// convention, v down) as [`check_stored`] does a file's.
pub fn check_mesh(mesh: &crate::mesh::TriMesh, uvs: &[[f32; 2]]) -> CheckReport {
    let mut asset = SourceAsset::from_mesh(mesh);
    asset.primitives[0].uvs = Some(uvs.to_vec());
    let stored = StoredAsset {
        asset,
        uvs: vec![uvs.to_vec()],
        axis: VAxis::Down,
    };
    check_stored(&stored, 0)
}

/// Checks UVs held in memory (no constraints): the charts and the atlas.
pub fn check_stored(stored: &StoredAsset, uv_set: u32) -> CheckReport {
    let welded = weld(&stored.asset.primitives);
    check_welded(stored, &welded, uv_set, Vec::new(), 0.0)
}

fn check_welded(
    stored: &StoredAsset,
    welded: &WeldedMesh,
    uv_set: u32,
    residuals: Vec<ConstraintCheck>,
    tolerance: f64,
) -> CheckReport {
    let uv_of = welded_uvs(stored, welded);
    let ids: Vec<u32> = (0..welded.n_charts as u32).collect();
    let mut charts: Vec<ChartCheck> = welded
        .charts(&ids)
        .iter()
        .map(|chart| check_chart(chart, &uv_of, stored.axis))
        .collect();
    let complete = check_overlaps(welded, &uv_of, stored.axis, &mut charts);
    let injective = complete && charts.iter().all(|c| c.crossings == 0 && c.overlaps.is_empty());
    let clean = injective
        && charts.iter().all(|c| c.flipped == 0 && c.zero_area == 0)
        && residuals.iter().all(|r| r.residual <= tolerance);
    let atlas = Atlas {
        injective,
        complete,
        overlapping_pairs: charts.iter().map(|c| c.overlaps.len()).sum::<usize>() / 2,
        crossings: charts.iter().map(|c| c.crossings).sum(),
    };
    CheckReport {
        asset: stored.asset.path.display().to_string(),
        mesh: stored.asset.mesh_index,
        uv_set,
        charts,
        atlas,
        constraints: residuals,
        clean,
    }
}

/// Each welded vertex's stored texture coordinates (welding included the
/// UV, so they are unique).
fn welded_uvs(stored: &StoredAsset, welded: &WeldedMesh) -> Vec<[f32; 2]> {
    let mut uv_of = vec![[0.0f32; 2]; welded.mesh.n_vertices()];
    for (uvs, map) in stored.uvs.iter().zip(&welded.vertex_of) {
        for (i, &w) in map.iter().enumerate() {
            uv_of[w as usize] = uvs[i];
        }
    }
    uv_of
}

/// A stored texture coordinate as a layout point (y up).
fn layout_point(uv: [f32; 2], axis: VAxis) -> DVec2 {
    let (u, v) = (uv[0] as f64, uv[1] as f64);
    match axis {
        VAxis::Down => uv_to_xy(DVec2::new(u, v)),
        VAxis::Up => DVec2::new(u, v),
    }
}

/// Orientation (exactly as stored) and stretch of `chart`.
fn check_chart(chart: &crate::mesh::weld::Chart, uv_of: &[[f32; 2]], axis: VAxis) -> ChartCheck {
    let c = chart.id;
    let uvs: Vec<[f32; 2]> = chart.welded_ids.iter().map(|&w| uv_of[w as usize]).collect();
    // A face naming one vertex twice has no area in the mesh itself: no
    // texture coordinates can give it one, so it is counted apart.
    let (repeated, faces): (Vec<[u32; 3]>, Vec<[u32; 3]>) = chart
        .mesh
        .triangles
        .iter()
        .partition(|t| t[0] == t[1] || t[1] == t[2] || t[0] == t[2]);
    let counts = guard::count_stored_orientations(&uvs, &faces, axis);
    let mirrored = counts.flipped > 0 && counts.flipped == faces.len();
    let layout: Vec<DVec2> = uvs
        .iter()
        .map(|&uv| {
            let p = layout_point(uv, axis);
            if mirrored { DVec2::new(-p.x, p.y) } else { p }
        })
        .collect();
    // A triangle with a NaN corner is counted above; the stretch is the rest's.
    let placed: Vec<[u32; 3]> = faces
        .iter()
        .filter(|t| t.iter().all(|&v| layout[v as usize].is_finite()))
        .copied()
        .collect();
    let s = sander_stretch(&chart.mesh.positions, &layout, &placed);
    ChartCheck {
        chart: c,
        vertices: chart.mesh.n_vertices(),
        triangles: chart.mesh.n_triangles(),
        flipped: if mirrored { 0 } else { counts.flipped },
        zero_area: counts.zero_area,
        repeated_corner: repeated.len(),
        mirrored,
        stretch_l2: s.l2,
        stretch_linf: s.linf,
        crossings: 0,
        overlaps: Vec::new(),
    }
}

/// Global injectivity of the whole atlas as stored: each chart's boundary
/// crossings and the charts it overlaps, written into `charts`; whether
/// every pair of edges could be looked at.
fn check_overlaps(welded: &WeldedMesh, uv_of: &[[f32; 2]], axis: VAxis, charts: &mut [ChartCheck]) -> bool {
    let points: Vec<DVec2> = uv_of.iter().map(|&uv| layout_point(uv, axis)).collect();
    let triangles = &welded.mesh.triangles;
    let chart_of: Vec<u32> = triangles
        .iter()
        .map(|t| welded.chart_of_vertex[t[0] as usize].expect("used vertices have charts"))
        .collect();
    let found = crate::injective::atlas_overlaps(&points, triangles, &chart_of, welded.n_charts, usize::MAX);
    for (c, n) in charts.iter_mut().zip(&found.self_crossings) {
        c.crossings = *n;
    }
    for &(a, b) in &found.overlapping {
        charts[a as usize].overlaps.push(b);
        charts[b as usize].overlaps.push(a);
    }
    found.complete
}

/// Each constraint's residual, and the file's tolerance.
fn check_constraints(
    path: &Path,
    stored: &StoredAsset,
    welded: &WeldedMesh,
    uv_of: &[[f32; 2]],
) -> crate::Result<(Vec<ConstraintCheck>, f64)> {
    let loaded = LoadedConstraints::load(path)?;
    let residuals = loaded
        .resolve(&stored.asset.primitives, welded)?
        .into_iter()
        .map(|r| {
            // In glTF texture coordinates, against the target as f32 can store it.
            let actual = xy_to_uv(layout_point(uv_of[r.welded as usize], stored.axis));
            let storable = r.target_uv.as_vec2().as_dvec2();
            ConstraintCheck {
                index: r.index,
                vertex: r.vertex,
                target: r.target_uv,
                actual,
                residual: actual.distance(storable),
            }
        })
        .collect();
    Ok((residuals, loaded.solver.tolerance))
}
