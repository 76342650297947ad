//! `uvpin check`: metrics of existing UVs, one line per chart.

use crate::constraints::LoadedConstraints;
use crate::guard;
use crate::guard::VAxis;
use crate::io::MeshSelector;
use crate::mesh::weld::{WeldedMesh, weld};
use crate::metrics::sander_stretch;
use crate::param::{uv_to_xy, xy_to_uv};
use glam::DVec2;
use serde::Serialize;
use std::path::Path;

#[derive(Debug, Serialize)]
struct ChartCheck {
    chart: u32,
    vertices: usize,
    triangles: usize,
    flipped: usize,
    zero_area: usize,
    /// Every triangle flipped: a mirrored chart (stretch measured on its mirror image).
    mirrored: bool,
    stretch_l2: f64,
    stretch_linf: f64,
    /// Pairs of its boundary edges that cross (it overlaps itself).
    crossings: usize,
    /// Other charts it overlaps.
    overlaps: Vec<u32>,
}

#[derive(Debug, Serialize)]
struct ConstraintCheck {
    index: usize,
    vertex: u32,
    target: DVec2,
    actual: DVec2,
    /// Distance from the stored UV to the target rounded to f32 (what glTF can hold).
    residual: f64,
}

/// The whole atlas: one-to-one or not.
#[derive(Debug, Serialize)]
struct Atlas {
    /// No chart crosses itself or overlaps another (every pair looked at).
    injective: bool,
    /// Every pair of boundary edges was looked at.
    complete: bool,
    overlapping_pairs: usize,
    crossings: usize,
}

/// The asset and its texture coordinates exactly as stored, per vertex of
/// each primitive, with the direction of their v axis.
struct StoredAsset {
    asset: crate::io::SourceAsset,
    uvs: Vec<Vec<[f32; 2]>>,
    axis: VAxis,
}

/// Reads the asset to check: glTF's TEXCOORD_`uv_set`, or an OBJ's `vt`.
/// `--mesh`: an index, else a name.
pub(super) fn mesh_selector(m: &str) -> MeshSelector {
    m.parse::<usize>()
        .map(MeshSelector::Index)
        .unwrap_or_else(|_| MeshSelector::Name(m.into()))
}

fn load_checked(asset_path: &Path, uv_set: u32, mesh: Option<&str>) -> crate::Result<StoredAsset> {
    let rules = crate::io::InputRules::default();
    let missing = |asset: &crate::io::SourceAsset, primitive: usize, what: String| {
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
    let selector = mesh.map(mesh_selector);
    let asset = crate::io::load_asset(asset_path, selector.as_ref(), uv_set, &rules)?;
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

/// Returns exit code 0 when every chart is fold-free, the atlas one-to-one
/// (no chart crosses itself or overlaps another) and every constraint within
/// tolerance, 2 otherwise.
pub fn run(
    asset_path: &Path,
    uv_set: u32,
    mesh: Option<&str>,
    constraints: Option<&Path>,
    json: bool,
) -> crate::Result<u8> {
    let stored = load_checked(asset_path, uv_set, mesh)?;
    let welded = weld(&stored.asset.primitives);
    let uv_of = welded_uvs(&stored, &welded);
    let mut charts: Vec<ChartCheck> = (0..welded.n_charts as u32)
        .map(|c| check_chart(&welded, c, &uv_of, stored.axis))
        .collect();
    let complete = check_overlaps(&welded, &uv_of, stored.axis, &mut charts);
    let (residuals, tolerance) = match constraints {
        Some(path) => check_constraints(path, &stored, &welded, &uv_of)?,
        None => (Vec::new(), crate::options::SolverOptions::DEFAULT.tolerance),
    };
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
    if json {
        print_json(&stored.asset, uv_set, &charts, &residuals, &atlas);
    } else {
        print_lines(&stored.asset, uv_set, &charts, &residuals, &atlas);
    }
    Ok(if clean { 0 } else { 2 })
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

/// Orientation (exactly as stored) and stretch of chart `c`.
fn check_chart(welded: &WeldedMesh, c: u32, uv_of: &[[f32; 2]], axis: VAxis) -> ChartCheck {
    let chart = welded.chart(c);
    let uvs: Vec<[f32; 2]> = chart.welded_ids.iter().map(|&w| uv_of[w as usize]).collect();
    let counts = guard::count_stored_orientations(&uvs, &chart.mesh.triangles, axis);
    let mirrored = counts.flipped == chart.mesh.n_triangles();
    let layout: Vec<DVec2> = uvs
        .iter()
        .map(|&uv| {
            let p = layout_point(uv, axis);
            if mirrored { DVec2::new(-p.x, p.y) } else { p }
        })
        .collect();
    let s = sander_stretch(&chart.mesh.positions, &layout, &chart.mesh.triangles);
    ChartCheck {
        chart: c,
        vertices: chart.mesh.n_vertices(),
        triangles: chart.mesh.n_triangles(),
        flipped: if mirrored { 0 } else { counts.flipped },
        zero_area: counts.zero_area,
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

fn print_json(
    asset: &crate::io::SourceAsset,
    uv_set: u32,
    charts: &[ChartCheck],
    residuals: &[ConstraintCheck],
    atlas: &Atlas,
) {
    let out = serde_json::json!({
        "asset": asset.path.display().to_string(),
        "mesh": asset.mesh_index,
        "uv_set": uv_set,
        "charts": charts,
        "atlas": atlas,
        "constraints": residuals,
    });
    super::print_out(&serde_json::to_string_pretty(&out).expect("json"));
}

fn print_lines(
    asset: &crate::io::SourceAsset,
    uv_set: u32,
    charts: &[ChartCheck],
    residuals: &[ConstraintCheck],
    atlas: &Atlas,
) {
    let mut lines = vec![format!(
        "{} mesh {} TEXCOORD_{uv_set}: {} charts",
        asset.path.display(),
        asset.mesh_index,
        charts.len()
    )];
    lines.extend(charts.iter().map(|c| {
        format!(
            "chart {:>4}: {:>7} vertices {:>7} triangles  flipped {:>6}  zero-area {:>6}  crossings {:>4}  stretch L2 {:>9.4}  L∞ {:>10.4}{}{}",
            c.chart,
            c.vertices,
            c.triangles,
            c.flipped,
            c.zero_area,
            c.crossings,
            c.stretch_l2,
            c.stretch_linf,
            if c.mirrored { "  (mirrored)" } else { "" },
            overlap_words(&c.overlaps)
        )
    }));
    lines.push(if atlas.injective {
        "atlas: one-to-one (no chart crosses itself or overlaps another)".to_string()
    } else if !atlas.complete {
        "atlas: not fully checked (too many long overlapping edges); treated as overlapping".to_string()
    } else {
        format!(
            "atlas: NOT one-to-one: {} boundary crossings inside charts, {} pairs of overlapping charts",
            atlas.crossings, atlas.overlapping_pairs
        )
    });
    lines.extend(residuals.iter().map(|r| {
        format!(
            "constraints[{}] vertex {}: target ({:.6}, {:.6}) actual ({:.6}, {:.6}) residual {:.3e}",
            r.index, r.vertex, r.target.x, r.target.y, r.actual.x, r.actual.y, r.residual
        )
    }));
    super::print_out(&lines.join("\n"));
}

/// `  overlaps charts 3, 7` (at most eight named), or nothing.
fn overlap_words(overlaps: &[u32]) -> String {
    if overlaps.is_empty() {
        return String::new();
    }
    let named: Vec<String> = overlaps.iter().take(8).map(u32::to_string).collect();
    let more = overlaps.len().saturating_sub(8);
    format!(
        "  overlaps chart{} {}{}",
        if overlaps.len() > 1 { "s" } else { "" },
        named.join(", "),
        if more > 0 {
            format!(" and {more} more")
        } else {
            String::new()
        }
    )
}
