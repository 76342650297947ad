//! glTF in and out.
//!
//! Reading uses the `gltf` crate (validation and accessor decoding, sparse and
//! normalised accessors included). Writing edits the file's own JSON: new
//! accessors and buffer views are appended and the primitives' TEXCOORD_n is
//! pointed at them, so every other object, extension, extra and unknown field
//! is written back as read, and every existing accessor keeps its bytes.

use super::{AssetError, AssetFormat, Container, SourceAsset, atomic, glb};
use crate::constraints::MeshSelector;
use crate::mesh::weld::PrimitiveGeometry;
use base64::Engine;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

pub(super) fn load(
    path: &Path,
    format: AssetFormat,
    bytes: &[u8],
    selector: Option<&MeshSelector>,
    uv_set: u32,
) -> Result<SourceAsset, AssetError> {
    let p = || path.to_path_buf();
    let (json_bytes, bin) = if format == AssetFormat::Glb || bytes.starts_with(b"glTF") {
        let g = glb::parse(bytes).map_err(|source| AssetError::Glb { path: p(), source })?;
        (g.json.to_vec(), g.bin.map(|b| b.to_vec()))
    } else {
        (bytes.to_vec(), None)
    };
    let json: Value = serde_json::from_slice(&json_bytes).map_err(|e| AssetError::Gltf {
        path: p(),
        message: format!("JSON: {e}"),
    })?;
    let document = gltf::Gltf::from_slice(bytes)
        .map_err(|e| AssetError::Gltf {
            path: p(),
            message: e.to_string(),
        })?
        .document;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(path, base, &document, bin.as_deref())?;
    let mesh = select_mesh(path, &document, selector)?;
    let primitives = mesh
        .primitives()
        .map(|prim| read_primitive(path, &prim, mesh.index(), &buffers, uv_set))
        .collect::<Result<Vec<_>, _>>()?;
    if primitives.is_empty() {
        return Err(AssetError::MeshSelection {
            path: p(),
            message: format!("mesh {} has no primitives", mesh.index()),
        });
    }
    Ok(SourceAsset {
        path: p(),
        format,
        mesh_index: mesh.index(),
        mesh_name: mesh.name().map(str::to_string),
        primitives,
        uv_set,
        container: Container::Gltf { json, bin },
        n_meshes: document.meshes().len(),
        decoded_texture: super::TextureCache::default(),
    })
}

/// The mesh `selector` names (by index or name; default the first).
fn select_mesh<'a>(
    path: &Path,
    document: &'a gltf::Document,
    selector: Option<&MeshSelector>,
) -> Result<gltf::Mesh<'a>, AssetError> {
    let n_meshes = document.meshes().len();
    let fail = |message: String| AssetError::MeshSelection {
        path: path.to_path_buf(),
        message,
    };
    match selector.unwrap_or(&MeshSelector::Index(0)) {
        MeshSelector::Index(i) => document.meshes().nth(*i).ok_or_else(|| {
            fail(if n_meshes == 0 {
                "the file has no meshes".into()
            } else {
                format!("mesh {i} does not exist (the file has meshes 0..{n_meshes})")
            })
        }),
        MeshSelector::Name(name) => document
            .meshes()
            .find(|m| m.name() == Some(name.as_str()))
            .ok_or_else(|| {
                let names: Vec<String> = document.meshes().map(|m| m.name().unwrap_or("").to_string()).collect();
                fail(format!("no mesh named {name:?} (names: {names:?})"))
            }),
    }
}

/// One TRIANGLES primitive's positions, indices and TEXCOORD_`uv_set`, checked.
fn read_primitive(
    path: &Path,
    prim: &gltf::Primitive,
    mesh_index: usize,
    buffers: &[Vec<u8>],
    uv_set: u32,
) -> Result<PrimitiveGeometry, AssetError> {
    let pi = prim.index();
    if prim.mode() != gltf::mesh::Mode::Triangles {
        return Err(AssetError::NonTrianglePrimitive {
            path: path.to_path_buf(),
            mesh: mesh_index,
            primitive: pi,
            mode: format!("{:?}", prim.mode()).to_uppercase(),
        });
    }
    let perr = |message: String| AssetError::Primitive {
        path: path.to_path_buf(),
        mesh: mesh_index,
        primitive: pi,
        message,
    };
    let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
    let positions: Vec<[f32; 3]> = reader
        .read_positions()
        .ok_or_else(|| perr("no POSITION attribute".into()))?
        .collect();
    if let Some((vertex, position)) = positions
        .iter()
        .enumerate()
        .find(|(_, q)| q.iter().any(|x| !x.is_finite()))
    {
        return Err(AssetError::NonFinitePosition {
            path: path.to_path_buf(),
            mesh: mesh_index,
            primitive: pi,
            vertex,
            position: *position,
        });
    }
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..positions.len() as u32).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(perr(format!(
            "{} indices is not a whole number of triangles",
            indices.len()
        )));
    }
    if let Some((k, &i)) = indices
        .iter()
        .enumerate()
        .find(|(_, i)| **i as usize >= positions.len())
    {
        return Err(perr(format!(
            "index {k} is {i}, but the primitive has {} vertices",
            positions.len()
        )));
    }
    let uvs: Option<Vec<[f32; 2]>> = reader.read_tex_coords(uv_set).map(|t| t.into_f32().collect());
    if let Some(u) = &uvs
        && u.len() != positions.len()
    {
        return Err(perr(format!(
            "TEXCOORD_{uv_set} has {} entries for {} vertices",
            u.len(),
            positions.len()
        )));
    }
    Ok(PrimitiveGeometry {
        index: pi,
        positions,
        indices,
        uvs,
    })
}

fn load_buffers(
    path: &Path,
    base: &Path,
    document: &gltf::Document,
    bin: Option<&[u8]>,
) -> Result<Vec<Vec<u8>>, AssetError> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let err = |message: String| AssetError::Buffer {
            path: path.to_path_buf(),
            buffer: buffer.index(),
            message,
        };
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => bin
                .ok_or_else(|| err("refers to the GLB BIN chunk, but there is none".into()))?
                .to_vec(),
            gltf::buffer::Source::Uri(uri) => read_uri(base, uri).map_err(err)?,
        };
        if data.len() < buffer.length() {
            return Err(err(format!(
                "has {} bytes, but byteLength is {}",
                data.len(),
                buffer.length()
            )));
        }
        out.push(data);
    }
    Ok(out)
}

/// Bytes of a buffer URI: a base64 data URI or a file relative to `base`.
fn read_uri(base: &Path, uri: &str) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest.split_once(";base64,").ok_or("data URI without ;base64,")?;
        return base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| format!("bad base64: {e}"));
    }
    let file = base.join(percent_decode(uri));
    std::fs::read(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let Ok(v) = u8::from_str_radix(std::str::from_utf8(&b[i + 1..i + 3]).unwrap_or("zz"), 16)
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn percent_encode_path(s: &str) -> String {
    s.replace('%', "%25").replace(' ', "%20")
}

/// Relative path from directory `from` to file `to` (both absolute).
fn relative_path(from: &Path, to: &Path) -> PathBuf {
    let (f, t): (Vec<_>, Vec<_>) = (from.components().collect(), to.components().collect());
    let common = f.iter().zip(&t).take_while(|(a, b)| a == b).count();
    let mut out = PathBuf::new();
    for _ in common..f.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    out
}

fn absolute_dir(p: &Path) -> PathBuf {
    let dir = p
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf())
}

fn f32_bytes(uvs: &[[f32; 2]]) -> Vec<u8> {
    uvs.iter()
        .flat_map(|uv| uv.iter().flat_map(|x| x.to_le_bytes()))
        .collect()
}

fn pad4(blob: &mut Vec<u8>) {
    while !blob.len().is_multiple_of(4) {
        blob.push(0);
    }
}

fn array<'a>(json: &'a mut Value, key: &str) -> &'a mut Vec<Value> {
    if !json.get(key).is_some_and(Value::is_array) {
        json[key] = Value::Array(Vec::new());
    }
    json[key].as_array_mut().expect("array")
}

/// Appends a float VEC2 accessor (with its buffer view) for `uvs`, stored at
/// `offset` of buffer `buffer`; returns the accessor index.
fn push_uv_accessor(json: &mut Value, buffer: usize, offset: usize, uvs: &[[f32; 2]]) -> usize {
    let (mut min, mut max) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for uv in uvs {
        for k in 0..2 {
            min[k] = min[k].min(uv[k]);
            max[k] = max[k].max(uv[k]);
        }
    }
    if uvs.is_empty() {
        (min, max) = ([0.0; 2], [0.0; 2]);
    }
    let views = array(json, "bufferViews");
    views.push(json!({
        "buffer": buffer,
        "byteOffset": offset,
        "byteLength": uvs.len() * 8,
        "target": 34962,
    }));
    let view = views.len() - 1;
    let accessors = array(json, "accessors");
    accessors.push(json!({
        "bufferView": view,
        "componentType": 5126,
        "count": uvs.len(),
        "type": "VEC2",
        "min": [min[0], min[1]],
        "max": [max[0], max[1]],
    }));
    accessors.len() - 1
}

/// Writes `asset` with `uvs` (one list per primitive of `asset.primitives`, in
/// glTF texture coordinates) as its TEXCOORD_`uv_set`, to `out` (.glb for a
/// .glb asset, .gltf + `<stem>.uvpin.bin` for a .gltf asset). Atomic.
pub fn write_with_uvs(asset: &SourceAsset, uvs: &[Vec<[f32; 2]>], out: &Path) -> Result<(), AssetError> {
    let werr = |message: String| AssetError::Write {
        path: out.to_path_buf(),
        message,
    };
    let Container::Gltf { json: original, bin } = &asset.container else {
        return Err(werr("not a glTF asset".into()));
    };
    if AssetFormat::of(out) != Some(asset.format) {
        return Err(werr(format!(
            "the output must have the input's type (.{}) so nothing but the UVs changes",
            match asset.format {
                AssetFormat::Glb => "glb",
                AssetFormat::Gltf => "gltf",
                AssetFormat::Obj => "obj",
            }
        )));
    }
    match asset.format {
        AssetFormat::Glb => write_glb(asset, original.clone(), bin.as_deref(), uvs, out),
        AssetFormat::Gltf => write_gltf(asset, original.clone(), uvs, out),
        AssetFormat::Obj => unreachable!("checked above"),
    }
}

/// Points each primitive's TEXCOORD_`uv_set` at accessor `accessor`.
fn set_uv_attribute(json: &mut Value, asset: &SourceAsset, prim: usize, accessor: usize) {
    let attribute = format!("TEXCOORD_{}", asset.uv_set);
    json["meshes"][asset.mesh_index]["primitives"][prim]["attributes"][attribute.as_str()] = json!(accessor);
}

/// Appends the UVs to `blob` (the bytes of buffer `buffer`) with their
/// accessors, and points the primitives at them.
fn append_uvs(json: &mut Value, asset: &SourceAsset, uvs: &[Vec<[f32; 2]>], buffer: usize, blob: &mut Vec<u8>) {
    for (prim, prim_uvs) in asset.primitives.iter().zip(uvs) {
        pad4(blob);
        let offset = blob.len();
        blob.extend_from_slice(&f32_bytes(prim_uvs));
        let acc = push_uv_accessor(json, buffer, offset, prim_uvs);
        set_uv_attribute(json, asset, prim.index, acc);
    }
    pad4(blob);
}

/// A .glb: the UVs appended to the BIN chunk (made buffer 0 if the file has none).
fn write_glb(
    asset: &SourceAsset,
    mut json: Value,
    bin: Option<&[u8]>,
    uvs: &[Vec<[f32; 2]>],
    out: &Path,
) -> Result<(), AssetError> {
    let werr = |message: String| AssetError::Write {
        path: out.to_path_buf(),
        message,
    };
    let buffers = array(&mut json, "buffers");
    let uses_bin = buffers.first().is_some_and(|b| b.get("uri").is_none()) && bin.is_some();
    if !uses_bin {
        // Make room for a BIN-chunk buffer at index 0.
        buffers.insert(0, json!({ "byteLength": 0 }));
        for view in array(&mut json, "bufferViews") {
            if let Some(b) = view.get("buffer").and_then(Value::as_u64) {
                view["buffer"] = json!(b + 1);
            }
        }
    }
    let mut blob = if uses_bin {
        bin.map(<[u8]>::to_vec).unwrap_or_default()
    } else {
        Vec::new()
    };
    append_uvs(&mut json, asset, uvs, 0, &mut blob);
    json["buffers"][0]["byteLength"] = json!(blob.len());
    let text = serde_json::to_vec(&json).map_err(|e| werr(e.to_string()))?;
    atomic::write_atomically(out, &glb::build(&text, Some(&blob))).map_err(|e| werr(e.to_string()))
}

/// Rewrites the relative URIs of `json`'s buffers and images so they stay
/// valid from `out_dir`; returns the files they name.
fn rebase_uris(json: &mut Value, in_dir: &Path, out_dir: &Path) -> Vec<PathBuf> {
    let mut referenced: Vec<PathBuf> = Vec::new();
    for key in ["buffers", "images"] {
        let Some(items) = json.get_mut(key).and_then(Value::as_array_mut) else {
            continue;
        };
        for item in items {
            let Some(uri) = item.get("uri").and_then(Value::as_str).map(str::to_string) else {
                continue;
            };
            if uri.starts_with("data:") || uri.contains("://") {
                continue;
            }
            let target = in_dir.join(percent_decode(&uri));
            referenced.push(target.clone());
            if in_dir != out_dir {
                let rel = relative_path(out_dir, &target);
                item["uri"] = json!(percent_encode_path(&rel.to_string_lossy()));
            }
        }
    }
    referenced
}

/// A .gltf: the UVs in a new buffer `<stem>.uvpin.bin` beside it.
fn write_gltf(asset: &SourceAsset, mut json: Value, uvs: &[Vec<[f32; 2]>], out: &Path) -> Result<(), AssetError> {
    let werr = |message: String| AssetError::Write {
        path: out.to_path_buf(),
        message,
    };
    let (in_dir, out_dir) = (absolute_dir(&asset.path), absolute_dir(out));
    let referenced = rebase_uris(&mut json, &in_dir, &out_dir);
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let mut bin_name = format!("{stem}.uvpin.bin");
    let mut k = 1;
    while referenced.iter().any(|r| *r == out_dir.join(&bin_name)) {
        bin_name = format!("{stem}.uvpin-{k}.bin");
        k += 1;
    }
    let mut blob = Vec::new();
    let buffer = array(&mut json, "buffers").len();
    append_uvs(&mut json, asset, uvs, buffer, &mut blob);
    array(&mut json, "buffers").push(json!({ "uri": percent_encode_path(&bin_name), "byteLength": blob.len() }));
    let text = serde_json::to_vec_pretty(&json).map_err(|e| werr(e.to_string()))?;
    let bin_path = out.with_file_name(&bin_name);
    atomic::write_atomically(&bin_path, &blob).map_err(|e| werr(format!("{}: {e}", bin_path.display())))?;
    atomic::write_atomically(out, &text).map_err(|e| werr(e.to_string()))
}

/// A fresh glTF document holding one mesh (positions, indices, optional
/// TEXCOORD_0): JSON and the binary buffer. Used for OBJ → glTF and to make
/// the sample asset.
pub fn new_document(positions: &[[f32; 3]], indices: &[u32], uvs: Option<&[[f32; 2]]>, name: &str) -> (Value, Vec<u8>) {
    let mut blob: Vec<u8> = positions
        .iter()
        .flat_map(|p| p.iter().flat_map(|x| x.to_le_bytes()))
        .collect();
    let pos_len = blob.len();
    blob.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in positions {
        for k in 0..3 {
            min[k] = min[k].min(p[k]);
            max[k] = max[k].max(p[k]);
        }
    }
    let mut json = json!({
        "asset": { "version": "2.0", "generator": concat!("uvpin ", env!("CARGO_PKG_VERSION")) },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "name": name }],
        "meshes": [{ "name": name, "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1, "mode": 4 }] }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": pos_len, "target": 34962 },
            { "buffer": 0, "byteOffset": pos_len, "byteLength": indices.len() * 4, "target": 34963 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": positions.len(), "type": "VEC3", "min": min, "max": max },
            { "bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR" }
        ],
        "buffers": [{ "byteLength": 0 }]
    });
    if let Some(uvs) = uvs {
        pad4(&mut blob);
        let offset = blob.len();
        blob.extend_from_slice(&f32_bytes(uvs));
        let acc = push_uv_accessor(&mut json, 0, offset, uvs);
        json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(acc);
    }
    pad4(&mut blob);
    json["buffers"][0]["byteLength"] = json!(blob.len());
    (json, blob)
}

/// Writes a fresh document as .glb, or as .gltf with an embedded data URI.
pub fn write_new_document(json: &Value, blob: &[u8], out: &Path) -> Result<(), AssetError> {
    let werr = |message: String| AssetError::Write {
        path: out.to_path_buf(),
        message,
    };
    let bytes = match AssetFormat::of(out) {
        Some(AssetFormat::Glb) => glb::build(&serde_json::to_vec(json).map_err(|e| werr(e.to_string()))?, Some(blob)),
        Some(AssetFormat::Gltf) => {
            let mut json = json.clone();
            json["buffers"][0]["uri"] = json!(format!(
                "data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(blob)
            ));
            serde_json::to_vec_pretty(&json).map_err(|e| werr(e.to_string()))?
        }
        _ => {
            return Err(werr("a new glTF document must be written as .glb or .gltf".into()));
        }
    };
    atomic::write_atomically(out, &bytes).map_err(|e| werr(e.to_string()))
}

/// Writes the asset with new UVs in whatever form `out` asks for: the same
/// type as the input (everything else kept), or .glb/.gltf from an OBJ.
pub fn write_asset(asset: &SourceAsset, uvs: &[Vec<[f32; 2]>], out: &Path) -> Result<(), AssetError> {
    match (&asset.container, AssetFormat::of(out)) {
        (Container::Obj { text }, Some(AssetFormat::Obj)) => {
            atomic::write_atomically(out, super::obj::with_uvs(text, &uvs[0]).as_bytes()).map_err(|e| {
                AssetError::Write {
                    path: out.to_path_buf(),
                    message: e.to_string(),
                }
            })
        }
        (Container::Obj { .. }, Some(AssetFormat::Glb | AssetFormat::Gltf)) => {
            let prim = &asset.primitives[0];
            let name = asset
                .path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let (json, blob) = new_document(&prim.positions, &prim.indices, Some(&uvs[0]), &name);
            write_new_document(&json, &blob, out)
        }
        (Container::Gltf { .. }, _) => write_with_uvs(asset, uvs, out),
        (Container::Obj { .. }, _) => Err(AssetError::Write {
            path: out.to_path_buf(),
            message: "write an OBJ input as .obj, .glb or .gltf".into(),
        }),
    }
}

/// The external files of a glTF JSON's buffers (URIs that are not data URIs),
/// relative to `base`, the glTF file's folder.
pub fn external_buffer_files(json: &Value, base: &Path) -> Vec<PathBuf> {
    json.get("buffers")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(|b| b.get("uri").and_then(Value::as_str))
        .filter(|uri| !uri.starts_with("data:"))
        .map(|uri| base.join(percent_decode(uri)))
        .collect()
}
