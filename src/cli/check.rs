//! `uvpin check`: metrics of existing UVs, one line per chart.

use crate::constraints::{LoadedConstraints, MeshSelector};
use crate::guard;
use crate::mesh::weld::{WeldedMesh, weld};
use crate::metrics::sander_stretch;
use crate::param::uv_to_xy;
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

/// Returns exit code 0 when every chart is fold-free and every constraint
/// within tolerance, 2 otherwise.
pub fn run(
    asset_path: &Path,
    uv_set: u32,
    mesh: Option<&str>,
    constraints: Option<&Path>,
    json: bool,
) -> crate::Result<u8> {
    let selector = mesh.map(|m| {
        m.parse::<usize>()
            .map(MeshSelector::Index)
            .unwrap_or_else(|_| MeshSelector::Name(m.into()))
    });
    let asset = crate::io::load_asset(asset_path, selector.as_ref(), uv_set)?;
    if let Some(p) = asset.primitives.iter().find(|p| p.uvs.is_none()) {
        return Err(crate::io::AssetError::Primitive {
            path: asset.path.clone(),
            mesh: asset.mesh_index,
            primitive: p.index,
            message: format!("has no TEXCOORD_{uv_set} to check"),
        }
        .into());
    }
    let welded = weld(&asset.primitives);
    let uv_of = welded_uvs(&asset, &welded);
    let charts: Vec<ChartCheck> = (0..welded.n_charts as u32)
        .map(|c| check_chart(&welded, c, &uv_of))
        .collect();
    let (residuals, tolerance) = match constraints {
        Some(path) => check_constraints(path, &asset, &welded, &uv_of)?,
        None => (Vec::new(), crate::options::SolverOptions::DEFAULT.tolerance),
    };
    let clean =
        charts.iter().all(|c| c.flipped == 0 && c.zero_area == 0) && residuals.iter().all(|r| r.residual <= tolerance);
    if json {
        print_json(&asset, uv_set, &charts, &residuals);
    } else {
        print_lines(&asset, uv_set, &charts, &residuals);
    }
    Ok(if clean { 0 } else { 2 })
}

/// Each welded vertex's UV (welding included the UV, so it is unique).
fn welded_uvs(asset: &crate::io::SourceAsset, welded: &WeldedMesh) -> Vec<DVec2> {
    let mut uv_of = vec![DVec2::ZERO; welded.mesh.n_vertices()];
    for (prim, map) in asset.primitives.iter().zip(&welded.vertex_of) {
        let uvs = prim.uvs.as_ref().expect("checked: every primitive has UVs");
        for (i, &w) in map.iter().enumerate() {
            uv_of[w as usize] = DVec2::new(uvs[i][0] as f64, uvs[i][1] as f64);
        }
    }
    uv_of
}

/// Orientation and stretch of chart `c`'s UVs (as stored, f32).
fn check_chart(welded: &WeldedMesh, c: u32, uv_of: &[DVec2]) -> ChartCheck {
    let chart = welded.chart(c);
    let uvs: Vec<[f32; 2]> = chart
        .welded_ids
        .iter()
        .map(|&w| uv_of[w as usize].as_vec2().to_array())
        .collect();
    let counts = guard::count_uv_orientations(&uvs, &chart.mesh.triangles);
    let mirrored = counts.flipped == chart.mesh.n_triangles();
    let layout: Vec<DVec2> = chart
        .welded_ids
        .iter()
        .map(|&w| {
            let p = uv_to_xy(uv_of[w as usize]);
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
    }
}

/// Each constraint's residual, and the file's tolerance.
fn check_constraints(
    path: &Path,
    asset: &crate::io::SourceAsset,
    welded: &WeldedMesh,
    uv_of: &[DVec2],
) -> crate::Result<(Vec<ConstraintCheck>, f64)> {
    let loaded = LoadedConstraints::load(path)?;
    let residuals = loaded
        .resolve(&asset.primitives, welded)?
        .into_iter()
        .map(|r| {
            let actual = uv_of[r.welded as usize];
            // glTF stores f32: measure against the target as it can be stored.
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

fn print_json(asset: &crate::io::SourceAsset, uv_set: u32, charts: &[ChartCheck], residuals: &[ConstraintCheck]) {
    let out = serde_json::json!({
        "asset": asset.path.display().to_string(),
        "mesh": asset.mesh_index,
        "uv_set": uv_set,
        "charts": charts,
        "constraints": residuals,
    });
    println!("{}", serde_json::to_string_pretty(&out).expect("json"));
}

fn print_lines(asset: &crate::io::SourceAsset, uv_set: u32, charts: &[ChartCheck], residuals: &[ConstraintCheck]) {
    println!(
        "{} mesh {} TEXCOORD_{uv_set}: {} charts",
        asset.path.display(),
        asset.mesh_index,
        charts.len()
    );
    for c in charts {
        println!(
            "chart {:>4}: {:>7} vertices {:>7} triangles  flipped {:>6}  zero-area {:>6}  stretch L2 {:>9.4}  L∞ {:>10.4}{}",
            c.chart,
            c.vertices,
            c.triangles,
            c.flipped,
            c.zero_area,
            c.stretch_l2,
            c.stretch_linf,
            if c.mirrored { "  (mirrored)" } else { "" }
        );
    }
    for r in residuals {
        println!(
            "constraints[{}] vertex {}: target ({:.6}, {:.6}) actual ({:.6}, {:.6}) residual {:.3e}",
            r.index, r.vertex, r.target.x, r.target.y, r.actual.x, r.actual.y, r.residual
        );
    }
}
