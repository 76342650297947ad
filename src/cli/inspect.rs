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
pub fn parse_point(s: &str) -> Result<DVec3, PointError> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let numbers: Vec<f64> = parts
        .iter()
        .filter_map(|p| p.parse().ok())
        .filter(|x: &f64| x.is_finite())
        .collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 => Ok(DVec3::new(x, y, z)),
        _ => Err(PointError { given: s.to_string() }),
    }
}

/// A `--near` that is not three finite numbers.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("expected X,Y,Z (three numbers), got `{}`", given.escape_debug())]
pub struct PointError {
    pub given: String,
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

/// `uvpin inspect --seams`: where the constraint file's solve would cut its
/// asset open, printed (and drawn to `preview`).
///
/// # Errors
/// The constraint file's or asset's errors, a chart that cannot be opened,
/// a picture that cannot be written.
pub fn seams(constraints: &Path, preview: Option<&Path>, json: bool) -> Result<(), crate::Error> {
    let (loaded, asset) = crate::api::load(
        constraints,
        &crate::options::SolverOptions::DEFAULT,
        &Default::default(),
    )?;
    let source = crate::constraints::ConstraintSource::File(std::sync::Arc::new(loaded));
    let session = crate::session::ChartSession::open(source, std::sync::Arc::new(asset), 0.0)?;
    let p = session.prepared();
    let cut = crate::report::seam_of(p);
    let rest = crate::atlas::rest_charts(session.asset(), p);
    if json {
        let value = serde_json::json!({ "chart": p.chart.id, "seam": cut, "laid_out_apart": rest.len(), "secondary": p.secondary });
        super::print_out(&serde_json::to_string_pretty(&value).expect("serialises"));
    } else {
        let mut out = format!("{}: chart {}\n", constraints.display(), p.chart.id);
        match &cut {
            None => out += "  a disk already: no seam\n",
            Some(s) => {
                writeln!(out, "  {} seam: {} edges, length {:.4} ({:.2} × √area), {} cones, {} edges through handles, {} edges around the landmarks' chart", s.source, s.n_edges, s.length, s.relative_length, s.cones, s.handle_edges, s.separation_edges).expect("string");
                let edges: Vec<String> = s.edges.iter().map(|e| format!("{}-{}", id(e[0]), id(e[1]))).collect();
                writeln!(out, "  edges (vertex ids): {}", edges.join(" ")).expect("string");
            }
        }
        writeln!(
            out,
            "  {} other charts laid out apart and packed; {} other charts with landmarks",
            rest.len(),
            p.secondary.len()
        )
        .expect("string");
        super::print_out(out.trim_end());
    }
    if let Some(path) = preview {
        let title = format!(
            "{}: where uvpin cuts",
            constraints
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        );
        let image = crate::preview::draw_seams(p, &title, 640);
        let png = crate::preview::render::encode_png(&image).map_err(|e| crate::Error::Internal(e.to_string()))?;
        let mut staged = crate::io::atomic::Staged::new();
        staged.add(path, png);
        staged.commit().map_err(|e| {
            crate::Error::Asset(crate::io::AssetError::Write {
                path: path.to_path_buf(),
                message: e.to_string(),
            })
        })?;
    }
    Ok(())
}

fn id(v: Option<u32>) -> String {
    v.map_or_else(|| "?".into(), |v| v.to_string())
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
