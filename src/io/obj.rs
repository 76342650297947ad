//! Wavefront OBJ as a convenience input: `v` positions and triangular `f`
//! faces. Vertex ids in constraint files are 0-based `v` indices. Output keeps
//! every line but `vt`, writes one `vt` per vertex and points `f` at them.

use super::AssetError;
use crate::mesh::weld::PrimitiveGeometry;
use std::path::Path;

/// Parses OBJ text into one primitive.
pub fn parse(path: &Path, text: &str) -> Result<PrimitiveGeometry, AssetError> {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let err = |line: usize, message: String| AssetError::Obj {
        path: path.to_path_buf(),
        line,
        message,
    };
    for (ln, line) in text.lines().enumerate() {
        let ln = ln + 1;
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => {
                let xyz: Vec<f32> = parts
                    .take(3)
                    .map(|s| s.parse::<f32>())
                    .collect::<Result<_, _>>()
                    .map_err(|e| err(ln, format!("bad vertex: {e}")))?;
                if xyz.len() != 3 {
                    return Err(err(ln, "a vertex needs x y z".into()));
                }
                if xyz.iter().any(|x| !x.is_finite()) {
                    return Err(err(
                        ln,
                        format!("vertex {} has a non-finite coordinate", positions.len()),
                    ));
                }
                positions.push([xyz[0], xyz[1], xyz[2]]);
            }
            Some("f") => {
                let corners: Vec<&str> = parts.collect();
                if corners.len() != 3 {
                    return Err(err(
                        ln,
                        format!("face with {} corners: only triangles are supported", corners.len()),
                    ));
                }
                for c in corners {
                    let v: i64 = c
                        .split('/')
                        .next()
                        .unwrap_or("")
                        .parse()
                        .map_err(|e| err(ln, format!("bad face index {c:?}: {e}")))?;
                    let idx = if v > 0 { v - 1 } else { positions.len() as i64 + v };
                    if idx < 0 || idx as usize >= positions.len() {
                        return Err(err(
                            ln,
                            format!("face index {v} out of range (1..={})", positions.len()),
                        ));
                    }
                    indices.push(idx as u32);
                }
            }
            _ => {}
        }
    }
    if indices.is_empty() {
        return Err(err(0, "no triangles".into()));
    }
    Ok(PrimitiveGeometry {
        index: 0,
        positions,
        indices,
        uvs: None,
    })
}

/// The OBJ text with `uvs` (one per `v`) as `vt` lines and faces pointing at them.
pub fn with_uvs(text: &str, uvs: &[[f32; 2]]) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let last_v = lines.iter().rposition(|l| l.split_whitespace().next() == Some("v"));
    let mut out = String::with_capacity(text.len() + uvs.len() * 24);
    let mut n_v = 0i64;
    for (i, line) in lines.iter().enumerate() {
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("vt") => continue,
            Some("v") => {
                n_v += 1;
                out.push_str(line);
            }
            Some("f") => {
                out.push('f');
                for c in parts {
                    let mut fields = c.split('/');
                    let v: i64 = fields.next().unwrap_or("0").parse().unwrap_or(0);
                    let abs = if v > 0 { v } else { n_v + v + 1 };
                    let normal = fields.nth(1).filter(|s| !s.is_empty());
                    match normal {
                        Some(n) => out.push_str(&format!(" {abs}/{abs}/{n}")),
                        None => out.push_str(&format!(" {abs}/{abs}")),
                    }
                }
            }
            _ => out.push_str(line),
        }
        out.push('\n');
        if Some(i) == last_v {
            for uv in uvs {
                // OBJ texture coordinates have v up.
                out.push_str(&format!("vt {} {}\n", uv[0], 1.0 - uv[1]));
            }
        }
    }
    out
}
