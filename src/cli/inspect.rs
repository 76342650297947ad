//! `uvpin inspect`: the asset's meshes, charts, bounding box, outer loops
//! and the vertices nearest a point, for people writing constraint files.

use crate::inspect::{ChartInfo, InspectRequest, Inspection};
use glam::DVec3;
use std::fmt::Write;
use std::path::Path;

/// Parses `X,Y,Z`.
///
/// # Errors
/// Not three finite numbers.
pub fn parse_point(s: &str) -> Result<DVec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let numbers: Vec<f64> = parts
        .iter()
        .filter_map(|p| p.parse().ok())
        .filter(|x: &f64| x.is_finite())
        .collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 => Ok(DVec3::new(x, y, z)),
        _ => Err(format!("expected X,Y,Z (three numbers), got `{}`", s.escape_debug())),
    }
}

/// Runs `uvpin inspect`; the exit code.
pub fn run(asset: &Path, request: &InspectRequest, json: bool) -> Result<u8, crate::io::AssetError> {
    let inspection = crate::inspect::inspect(asset, request, &crate::io::InputRules::default())?;
    if json {
        super::print_out(&serde_json::to_string_pretty(&inspection).expect("serialises"));
    } else {
        super::print_out(text(&inspection).trim_end());
    }
    Ok(0)
}

fn text(i: &Inspection) -> String {
    let mut out = format!("{}\n", i.asset);
    for m in &i.meshes {
        let name = m
            .name
            .as_deref()
            .map(|n| format!(" \"{}\"", n.escape_debug()))
            .unwrap_or_default();
        let marker = if m.index == i.mesh { "*" } else { " " };
        match &m.error {
            None => writeln!(
                out,
                "{marker}mesh {}{name}: {} primitives, {} vertices, {} triangles",
                m.index, m.primitives, m.vertices, m.triangles
            ),
            Some(e) => writeln!(out, "{marker}mesh {}{name}: {e}", m.index),
        }
        .expect("string");
    }
    for p in &i.primitives {
        let uvs = if p.has_uvs { "has" } else { "no" };
        writeln!(
            out,
            "  primitive {}: {} vertices, {} triangles, {uvs} TEXCOORD_{}",
            p.index, p.vertices, p.triangles, i.uv_set
        )
        .expect("string");
    }
    if let Some(b) = &i.bounds {
        let (lo, hi) = (b.min, b.max);
        writeln!(
            out,
            "bounding box: ({:.4}, {:.4}, {:.4}) .. ({:.4}, {:.4}, {:.4}), diagonal {:.4}",
            lo.x,
            lo.y,
            lo.z,
            hi.x,
            hi.y,
            hi.z,
            b.diagonal()
        )
        .expect("string");
    }
    writeln!(out, "up: {}", i.up_hint).expect("string");
    writeln!(
        out,
        "{} charts (connected pieces after welding), largest first:",
        i.charts.len()
    )
    .expect("string");
    for c in &i.charts {
        out += &chart_text(c);
    }
    if let Some(n) = &i.near {
        let p = n.point;
        writeln!(
            out,
            "nearest to ({}, {}, {}) (surface {:.4} away):",
            p.x, p.y, p.z, n.surface_distance
        )
        .expect("string");
        for v in &n.nearest {
            writeln!(
                out,
                "  primitive {} vertex {:>7}  at ({:.4}, {:.4}, {:.4})  distance {:.4}",
                v.primitive, v.vertex, v.position.x, v.position.y, v.position.z, v.distance
            )
            .expect("string");
        }
        if let Some(why) = &n.too_far {
            writeln!(out, "warning: a `near:` constraint here would be refused: {why}").expect("string");
        }
    }
    out
}

fn chart_text(c: &ChartInfo) -> String {
    let shape = match (c.boundary_loops, &c.problem) {
        (Some(0), _) => "closed (no boundary: cannot be solved)".to_string(),
        (Some(n), _) => format!("{n} boundary loops (1 outer, {} holes)", n - 1),
        (None, Some(p)) => format!("not solvable: {p}"),
        (None, None) => String::new(),
    };
    let mut out = format!(
        "  chart {}: {} vertices, {} triangles, {shape}\n",
        c.id, c.vertices, c.triangles
    );
    if let Some(outer) = &c.outer_loop {
        let one_primitive = outer.iter().all(|(p, _)| *p == outer[0].0);
        let ids: Vec<String> = outer
            .iter()
            .map(|(p, v)| {
                if one_primitive {
                    v.to_string()
                } else {
                    format!("{p}:{v}")
                }
            })
            .collect();
        writeln!(
            out,
            "    outer loop ({} vertices, in the faces' winding; corners go top_left, bottom_left, bottom_right, top_right along it): {}",
            outer.len(),
            ids.join(" ")
        )
        .expect("string");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_parse() {
        assert_eq!(parse_point("1, -2.5,3e-1"), Ok(DVec3::new(1.0, -2.5, 0.3)));
        assert!(parse_point("1,2").is_err());
        assert!(parse_point("1,2,3,4").is_err());
        assert!(parse_point("1,nan,3").is_err());
    }
}
