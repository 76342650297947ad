//! The JSON the editor's page reads and sends.

use super::hub::FileView;
use super::preview::{Preview, Shown};
use super::text::WantedConstraint;
use crate::chart::PrimitiveUvs;
use crate::io::SourceAsset;
use crate::report::Report;
use glam::DVec2;
use serde_json::{Value, json};

/// A content hash as the page carries it (JSON numbers lose u64 bits).
pub fn hash_text(hash: u64) -> String {
    format!("{hash:016x}")
}

/// UVs per primitive, flat (`[u0, v0, u1, v1, …]`).
fn flat_uvs(uvs: &PrimitiveUvs) -> Value {
    uvs.iter()
        .map(|p| p.iter().flat_map(|uv| [uv[0], uv[1]]).collect::<Vec<f32>>())
        .collect()
}

/// The parts of a report the page shows.
fn report(r: &Report) -> Value {
    json!({
        "status": r.status,
        "message": r.message,
        "constraints": r.constraints.iter().map(|c| json!({
            "index": c.index,
            "primitive": c.primitive,
            "vertex": c.vertex,
            "target": [c.target.x, c.target.y],
            "result": [c.result.x, c.result.y],
            "residual": c.residual,
            "reached": c.reached,
        })).collect::<Vec<_>>(),
        "max_residual": r.max_residual,
        "stretch_l2": r.stretch_final.l2,
        "stretch_linf": r.stretch_final.linf,
        "flipped": r.orientation.flipped + r.orientation.zero_area,
        "boundary_mode": r.boundary_mode,
        "total_ms": r.total_ms,
        "hint": r.hint,
    })
}

/// A constraint file's state: its list as the page edits it, the last
/// written solve (of the asset as it is now), the current error;
/// `texture`: the key of the texture the page may ask for (it changes when
/// the texture does), if any.
pub fn state(view: &FileView, texture: Option<String>) -> Value {
    let constraints: Vec<Value> = view
        .inputs
        .iter()
        .flat_map(|i| {
            i.existing.iter().map(|e| {
                let spec = &i.loaded.file.constraints[e.index];
                let target = i.loaded.target_uv(spec);
                json!({
                    "index": e.index,
                    "primitive": e.primitive,
                    "vertex": e.vertex,
                    "target": [target.x, target.y],
                    "label": spec.label,
                })
            })
        })
        .collect();
    let editable = view
        .inputs
        .as_ref()
        .is_some_and(|i| Some(i.text_hash) == view.text_hash);
    // A solve of the asset before an edit of it is not this mesh's layout.
    let solved = view.solved.as_ref().filter(|s| {
        view.inputs
            .as_ref()
            .is_some_and(|i| std::sync::Arc::ptr_eq(&s.asset, &i.asset))
    });
    json!({
        "id": view.id,
        "name": view.name,
        "state": view.state,
        "error": view.error,
        "version": view.version,
        "hash": view.text_hash.map(hash_text),
        "editable": editable,
        "asset": view.inputs.as_ref().map(|i| format!("{:p}", std::sync::Arc::as_ptr(&i.asset))),
        "primitive": view.inputs.as_ref().map(|i| i.loaded.file.primitive),
        "has_texture": texture.is_some(),
        "texture": texture,
        "constraints": constraints,
        "solved": solved.map(|s| json!({
            "report": report(&s.report),
            "uvs": flat_uvs(&s.uvs),
            "in_chart": s.in_chart,
            "written": flat_uvs(&s.written),
        })),
    })
}

/// The mesh: per primitive its positions and triangle indices, flat.
pub fn mesh(asset: &SourceAsset) -> Value {
    let bounds = crate::mesh::nearest::bounds(&asset.primitives);
    json!({
        "primitives": asset.primitives.iter().map(|p| json!({
            "index": p.index,
            "positions": p.positions.iter().flatten().copied().collect::<Vec<f32>>(),
            "indices": p.indices,
        })).collect::<Vec<_>>(),
        "bounds": bounds.map(|b| json!({ "min": [b.min.x, b.min.y, b.min.z], "max": [b.max.x, b.max.y, b.max.z] })),
        "up": bounds.map(|b| b.up_axis().vector().to_array()),
    })
}

/// A drag preview's answer: the chart's UVs (`uvs`), or its coarse
/// level's (`coarse`: its key, UVs per coarse vertex, and its mesh unless
/// the page holds the level named `held`).
pub fn preview(p: &Preview, seq: Value, held: Option<&str>) -> Value {
    let mut out = json!({
        "seq": seq,
        "report": report(&p.report),
        "ms": p.ms,
    });
    match &p.shown {
        Shown::Chart(uvs) => out["uvs"] = flat_uvs(uvs),
        Shown::Coarse { key, mesh, uvs } => {
            let key = hash_text(*key);
            let mut coarse = json!({
                "key": key,
                "uvs": uvs.iter().flatten().copied().collect::<Vec<f32>>(),
            });
            if held != Some(key.as_str()) {
                coarse["mesh"] = json!({
                    "vertices": mesh.vertices.iter().flat_map(|&(k, v)| [k, v]).collect::<Vec<u32>>(),
                    "indices": mesh.triangles.iter().flatten().copied().collect::<Vec<u32>>(),
                });
            }
            out["coarse"] = coarse;
        }
    }
    out
}

/// Constraints a page may send at most.
const MAX_WANTED: usize = 10_000;

/// Why the page's constraint list cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PayloadError {
    #[error("expected `constraints: [...]`")]
    NoList,
    #[error("too many constraints ({count}; at most {MAX_WANTED})")]
    TooMany { count: usize },
    #[error("constraints[{index}]: expected {{vertex, uv: [u, v], primitive?, label?}}")]
    Malformed { index: usize },
}

/// The page's constraint list: `[{primitive, vertex, uv: [u, v], label}]`;
/// the file's default primitive is left implicit.
///
/// # Errors
/// A malformed list, with the offending constraint's index.
pub fn wanted(body: &Value, default_primitive: usize) -> Result<Vec<WantedConstraint>, PayloadError> {
    let list = body
        .get("constraints")
        .and_then(Value::as_array)
        .ok_or(PayloadError::NoList)?;
    if list.len() > MAX_WANTED {
        return Err(PayloadError::TooMany { count: list.len() });
    }
    list.iter()
        .enumerate()
        .map(|(k, c)| {
            let bad = || PayloadError::Malformed { index: k };
            let vertex = c
                .get("vertex")
                .and_then(Value::as_u64)
                .filter(|v| *v <= u64::from(u32::MAX));
            let uv = c.get("uv").and_then(Value::as_array).filter(|a| a.len() == 2);
            let uv = uv.and_then(|a| Some(DVec2::new(a[0].as_f64()?, a[1].as_f64()?)));
            let primitive = match c.get("primitive") {
                None | Some(Value::Null) => None,
                Some(p) => Some(p.as_u64().ok_or_else(bad)? as usize),
            };
            let label = match c.get("label") {
                None | Some(Value::Null) => None,
                Some(Value::String(s)) if s.trim().is_empty() => None,
                Some(Value::String(s)) if s.len() <= 200 => Some(s.clone()),
                Some(_) => return Err(bad()),
            };
            Ok(WantedConstraint {
                primitive: primitive.filter(|&p| p != default_primitive),
                vertex: vertex.ok_or_else(bad)? as u32,
                uv: uv.filter(|uv| uv.is_finite()).ok_or_else(bad)?,
                label,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_list_is_read_strictly() {
        let body = json!({ "constraints": [
            { "vertex": 4, "uv": [0.25, 0.5], "primitive": 0, "label": "eye" },
            { "vertex": 5, "uv": [0.5, 0.5], "primitive": 1, "label": "  " },
        ]});
        let w = wanted(&body, 0).unwrap();
        assert_eq!(w[0].primitive, None);
        assert_eq!(w[1].primitive, Some(1));
        assert_eq!((w[0].label.as_deref(), w[1].label.as_deref()), (Some("eye"), None));
        for bad in [
            json!({}),
            json!({ "constraints": [{ "vertex": -1, "uv": [0, 0] }] }),
            json!({ "constraints": [{ "vertex": 1, "uv": [0] }] }),
            json!({ "constraints": [{ "vertex": 1, "uv": [0, 0], "label": 3 }] }),
            json!({ "constraints": [{ "vertex": 4294967296u64, "uv": [0, 0] }] }),
        ] {
            assert!(wanted(&bad, 0).is_err(), "{bad}");
        }
        let one = json!({ "vertex": 1, "uv": [0, 0] });
        let many = json!({ "constraints": vec![one; MAX_WANTED + 1] });
        assert_eq!(wanted(&many, 0), Err(PayloadError::TooMany { count: MAX_WANTED + 1 }));
        let second = json!({ "constraints": [{ "vertex": 1, "uv": [0, 0] }, { "vertex": 2 }] });
        assert_eq!(wanted(&second, 0), Err(PayloadError::Malformed { index: 1 }));
        assert_eq!(hash_text(255), "00000000000000ff");
    }
}
