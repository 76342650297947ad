//! `uvpin check`: metrics of existing UVs, one line per chart.

use crate::check::{CheckReport, check_file};
use crate::io::MeshSelector;
use std::path::Path;

/// `--mesh`: an index, else a name.
pub(super) fn mesh_selector(m: &str) -> MeshSelector {
    m.parse::<usize>()
        .map(MeshSelector::Index)
        .unwrap_or_else(|_| MeshSelector::Name(m.into()))
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
    let selector = mesh.map(mesh_selector);
    let report = check_file(asset_path, uv_set, selector.as_ref(), constraints)?;
    if json {
        print_json(&report);
    } else {
        print_lines(&report);
    }
    Ok(if report.clean { 0 } else { 2 })
}

fn print_json(report: &CheckReport) {
    let out = serde_json::json!({
        "asset": report.asset,
        "mesh": report.mesh,
        "uv_set": report.uv_set,
        "charts": report.charts,
        "atlas": report.atlas,
        "constraints": report.constraints,
        "clean": report.clean,
    });
    super::print_out(&serde_json::to_string_pretty(&out).expect("json"));
}

fn print_lines(report: &CheckReport) {
    let (charts, residuals, atlas, uv_set) = (&report.charts, &report.constraints, &report.atlas, report.uv_set);
    let mut lines = vec![format!(
        "{} mesh {} TEXCOORD_{uv_set}: {} charts",
        report.asset,
        report.mesh,
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
