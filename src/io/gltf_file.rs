//! glTF in and out.
//!
//! Reading uses the `gltf` crate (validation and accessor decoding, sparse and
//! normalised accessors included). Writing edits the file's own JSON: new
//! accessors and buffer views are appended and the primitives' TEXCOORD_n is
//! pointed at them, so every other object, extension, extra and unknown field
//! is written back as read, and every existing accessor keeps its bytes.

use super::MeshSelector;
use super::atomic::{self, Staged};
use super::corners::CornerUvs;
use super::gltf_split::DataError;
use super::{AssetError, AssetFormat, Container, SourceAsset, glb};
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
    rules: &super::InputRules,
) -> Result<SourceAsset, AssetError> {
    let p = || path.to_path_buf();
    let invalid = |message: String| AssetError::Gltf { path: p(), message };
    let (json_bytes, bin, others) = if format == AssetFormat::Glb || bytes.starts_with(b"glTF") {
        let g = glb::parse(bytes).map_err(|source| AssetError::Glb { path: p(), source })?;
        let others = g.others.iter().map(|&(k, d)| (k, d.to_vec())).collect();
        (g.json.to_vec(), g.bin.map(|b| b.to_vec()), others)
    } else {
        (bytes.to_vec(), None, Vec::new())
    };
    let json: Value = serde_json::from_slice(&json_bytes).map_err(|e| invalid(format!("JSON: {e}")))?;
    if let Some(why) = super::validate::duplicate_key(&json_bytes) {
        return Err(invalid(format!("JSON: {why}")));
    }
    super::validate::validate(&json, &rules.limits, bin.is_some()).map_err(invalid)?;
    let buffers = load_buffers(path, &json, bin.as_deref(), rules)?;
    // The checks above cover what the reader indexes; a panic in the gltf
    // crate on a file they missed is still an error naming the file.
    let read = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        read_document(path, bytes, &json, &buffers, selector, uv_set, rules)
    }));
    let (mesh_index, mesh_name, primitives, n_meshes) = match read {
        Ok(result) => result?,
        Err(_) => {
            return Err(invalid(
                "the glTF reader failed on this file (it breaks the glTF spec)".into(),
            ));
        }
    };
    Ok(SourceAsset {
        path: p(),
        format,
        mesh_index,
        mesh_name,
        primitives,
        uv_set,
        container: Container::Gltf { json, bin, others },
        n_meshes,
        rules: rules.clone(),
        decoded_texture: super::TextureCache::default(),
    })
}

/// The selected mesh read from a validated document: its index, name,
/// TRIANGLES primitives, and the number of meshes in the file.
type ReadMesh = (usize, Option<String>, Vec<PrimitiveGeometry>, usize);

fn read_document(
    path: &Path,
    bytes: &[u8],
    json: &Value,
    buffers: &[Vec<u8>],
    selector: Option<&MeshSelector>,
    uv_set: u32,
    rules: &super::InputRules,
) -> Result<ReadMesh, AssetError> {
    let document = gltf::Gltf::from_slice(bytes)
        .map_err(|e| AssetError::Gltf {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?
        .document;
    let mesh = select_mesh(path, &document, selector)?;
    super::validate::check_mesh_size(json, mesh.index(), &rules.limits).map_err(|message| AssetError::TooLarge {
        path: path.to_path_buf(),
        message,
    })?;
    // Lines and points beside the triangles are kept as they are, unsolved.
    let triangles: Vec<gltf::Primitive> = mesh
        .primitives()
        .filter(|p| p.mode() == gltf::mesh::Mode::Triangles)
        .collect();
    if triangles.is_empty()
        && let Some(first) = mesh.primitives().next()
    {
        return Err(AssetError::NonTrianglePrimitive {
            path: path.to_path_buf(),
            mesh: mesh.index(),
            primitive: first.index(),
            mode: format!("{:?}", first.mode()).to_uppercase(),
        });
    }
    let primitives = triangles
        .iter()
        .map(|prim| read_primitive(path, prim, mesh.index(), buffers, uv_set))
        .collect::<Result<Vec<_>, _>>()?;
    if primitives.is_empty() {
        return Err(AssetError::MeshSelection {
            path: path.to_path_buf(),
            message: format!("mesh {} has no primitives", mesh.index()),
        });
    }
    Ok((
        mesh.index(),
        mesh.name().map(str::to_string),
        primitives,
        document.meshes().len(),
    ))
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
    // glTF numbers a primitive's texture coordinate sets without gaps.
    let sets = (0..)
        .take_while(|&k| prim.get(&gltf::Semantic::TexCoords(k)).is_some())
        .count() as u32;
    if uv_set > sets {
        return Err(perr(format!(
            "uv_set {uv_set} would leave TEXCOORD_{sets}..{} missing, and glTF numbers the sets without gaps: \
             the primitive has {sets} (give uv_set: {sets} for a new one)",
            uv_set - 1
        )));
    }
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

/// Every buffer's bytes: the GLB BIN chunk, a data URI, or a file relative
/// to the asset's folder (read within `rules`); each at least its declared
/// `byteLength` long.
fn load_buffers(
    path: &Path,
    json: &Value,
    bin: Option<&[u8]>,
    rules: &super::InputRules,
) -> Result<Vec<Vec<u8>>, AssetError> {
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = json
        .get("buffers")
        .and_then(Value::as_array)
        .map_or(&[][..], Vec::as_slice);
    let mut out = Vec::with_capacity(buffers.len());
    for (index, buffer) in buffers.iter().enumerate() {
        let err = |message: String| AssetError::Buffer {
            path: path.to_path_buf(),
            buffer: index,
            message,
        };
        let declared = buffer.get("byteLength").and_then(Value::as_u64).unwrap_or(0) as usize;
        let data = match buffer.get("uri").and_then(Value::as_str) {
            None => bin
                .ok_or_else(|| err("refers to the GLB BIN chunk, but there is none".into()))?
                .to_vec(),
            Some(uri) => read_uri(base, uri, rules).map_err(|e| err(e.to_string()))?,
        };
        if data.len() < declared {
            return Err(err(format!("has {} bytes, but byteLength is {declared}", data.len())));
        }
        out.push(data);
    }
    Ok(out)
}

/// The file a relative glTF URI names inside `base`.
///
/// # Errors
/// An absolute path or a URI with a scheme (glTF asks for relative URIs).
pub fn uri_path(base: &Path, uri: &str) -> Result<PathBuf, DataError> {
    let decoded = percent_decode(uri);
    let has_scheme = uri.split_once(':').is_some_and(|(scheme, _)| {
        scheme.len() > 1 && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
    });
    if has_scheme || Path::new(&decoded).is_absolute() {
        return Err(DataError::NotRelative { uri: uri.to_string() });
    }
    Ok(base.join(decoded))
}

/// Bytes of a buffer or image URI: a base64 data URI, or a relative file
/// read within `rules`.
///
/// # Errors
/// A malformed data URI; a file that cannot be read under `rules`.
pub fn read_uri(base: &Path, uri: &str, rules: &super::InputRules) -> Result<Vec<u8>, DataError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest.split_once(";base64,").ok_or(DataError::DataUriWithoutBase64)?;
        return Ok(base64::engine::general_purpose::STANDARD.decode(data)?);
    }
    let file = uri_path(base, uri)?;
    super::read::read_regular(&file, rules.limits.max_file_bytes, &rules.scope)
        .map_err(|reason| DataError::Read { file, reason })
}

pub(crate) fn percent_decode(s: &str) -> String {
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

/// The absolute folder of `p`, links resolved as far as it exists; folders
/// not made yet follow by name (so URIs relative to it stay relative).
fn absolute_dir(p: &Path) -> PathBuf {
    let dir = p
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    super::paths::absolute(dir)
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

/// The files of `asset` with `uvs` (one list per primitive of
/// `asset.primitives`, in glTF texture coordinates) as its
/// TEXCOORD_`uv_set`, written as `out` (.glb for a .glb asset; .gltf plus a
/// buffer `<stem>.uvpin-<content>.bin` for a .gltf asset, renamed into place
/// first, the earlier output's buffer removed after), staged.
///
/// # Errors
/// An output of another type than the input; an external buffer of a GLB
/// that cannot be read again.
pub fn stage_with_uvs(asset: &SourceAsset, uvs: &[CornerUvs], out: &Path) -> Result<Staged, AssetError> {
    let werr = |message: String| AssetError::Write {
        path: out.to_path_buf(),
        message,
    };
    let Container::Gltf {
        json: original, bin, ..
    } = &asset.container
    else {
        return Err(werr("not a glTF asset".into()));
    };
    // GLB bytes under a .gltf name are a GLB: a .gltf could not name its
    // binary chunk, and the geometry would be lost.
    let read_as = if bin.is_some() { AssetFormat::Glb } else { asset.format };
    if AssetFormat::of(out) != Some(read_as) {
        let glb_named_gltf = read_as != asset.format;
        return Err(werr(format!(
            "the output must have the input's type (.{}) so nothing but the UVs changes{}",
            match read_as {
                AssetFormat::Glb => "glb",
                AssetFormat::Gltf => "gltf",
                AssetFormat::Obj => "obj",
            },
            if glb_named_gltf {
                "; the input holds GLB bytes under a .gltf name"
            } else {
                ""
            }
        )));
    }
    match read_as {
        AssetFormat::Glb => stage_glb(asset, original.clone(), bin.as_deref(), uvs, out),
        AssetFormat::Gltf => stage_gltf(asset, original.clone(), uvs, out),
        AssetFormat::Obj => unreachable!("checked above"),
    }
}

/// Points each primitive's TEXCOORD_`uv_set` at accessor `accessor`.
fn set_uv_attribute(json: &mut Value, asset: &SourceAsset, prim: usize, accessor: usize) {
    let attribute = format!("TEXCOORD_{}", asset.uv_set);
    json["meshes"][asset.mesh_index]["primitives"][prim]["attributes"][attribute.as_str()] = json!(accessor);
}

/// Appends the UVs to `blob` (the bytes of buffer `buffer`) with their
/// accessors, and points the primitives at them. A primitive whose corners
/// need more vertices than it has (a seam runs through it) is split first
/// ([`super::gltf_split`]), read from the `original` document.
fn append_uvs(
    json: &mut Value,
    original: &Value,
    asset: &SourceAsset,
    uvs: &[CornerUvs],
    buffer: usize,
    blob: &mut Vec<u8>,
) -> Result<(), DataError> {
    let mut buffers: Option<Vec<Vec<u8>>> = None;
    let skip = format!("TEXCOORD_{}", asset.uv_set);
    for (prim, corners) in asset.primitives.iter().zip(uvs) {
        let split = corners.split(&prim.indices);
        if !split.is_identity() {
            if buffers.is_none() {
                let bin = match &asset.container {
                    Container::Gltf { bin, .. } => bin.as_deref(),
                    Container::Obj { .. } => None,
                };
                buffers = Some(
                    load_buffers(&asset.path, original, bin, &asset.rules)
                        .map_err(|e| DataError::Asset(Box::new(e)))?,
                );
            }
            let data = buffers.as_deref().expect("loaded");
            let at = (asset.mesh_index, prim.index);
            super::gltf_split::split_primitive(original, json, data, at, &skip, &split, buffer, blob)?;
        }
        pad4(blob);
        let offset = blob.len();
        blob.extend_from_slice(&f32_bytes(&split.uvs));
        let acc = push_uv_accessor(json, buffer, offset, &split.uvs);
        set_uv_attribute(json, asset, prim.index, acc);
    }
    pad4(blob);
    Ok(())
}

/// Moves every external file buffer of a GLB's JSON into its BIN chunk
/// `blob` (buffer 0), so the output is complete wherever it is written:
/// their views are re-pointed and re-offset, the buffers list renumbered.
fn embed_external_buffers(asset: &SourceAsset, json: &mut Value, blob: &mut Vec<u8>) -> Result<(), DataError> {
    let base = asset.path.parent().unwrap_or(Path::new("."));
    let buffers = array(json, "buffers").clone();
    // Per old buffer index: its new index, or the offset it landed at in BIN.
    let mut moved: Vec<Result<usize, u64>> = Vec::with_capacity(buffers.len());
    let mut kept = 0usize;
    for (i, b) in buffers.iter().enumerate() {
        match b.get("uri").and_then(Value::as_str).filter(|u| !u.starts_with("data:")) {
            Some(uri) if i != 0 => {
                let bytes = read_uri(base, uri, &asset.rules)?;
                while !blob.len().is_multiple_of(16) {
                    blob.push(0);
                }
                moved.push(Err(blob.len() as u64));
                blob.extend_from_slice(&bytes);
            }
            _ => {
                moved.push(Ok(kept));
                kept += 1;
            }
        }
    }
    for view in array(json, "bufferViews") {
        let Some(b) = view.get("buffer").and_then(Value::as_u64) else {
            continue;
        };
        match moved.get(b as usize) {
            Some(Ok(new)) => view["buffer"] = json!(new),
            Some(Err(at)) => {
                let offset = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0);
                view["buffer"] = json!(0);
                view["byteOffset"] = json!(offset + at);
            }
            None => {}
        }
    }
    let remaining: Vec<Value> = buffers
        .into_iter()
        .zip(&moved)
        .filter(|(_, m)| m.is_ok())
        .map(|(b, _)| b)
        .collect();
    json["buffers"] = Value::Array(remaining);
    Ok(())
}

/// A .glb: the UVs appended to the BIN chunk (made buffer 0 if the file has
/// none), external buffers embedded.
fn stage_glb(
    asset: &SourceAsset,
    mut json: Value,
    bin: Option<&[u8]>,
    uvs: &[CornerUvs],
    out: &Path,
) -> Result<Staged, AssetError> {
    let werr = |message: String| AssetError::Write {
        path: out.to_path_buf(),
        message,
    };
    let original = json.clone();
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
    embed_external_buffers(asset, &mut json, &mut blob).map_err(|e| werr(e.to_string()))?;
    let (in_dir, out_dir) = (absolute_dir(&asset.path), absolute_dir(out));
    rebase_uris(&mut json, &in_dir, &out_dir);
    append_uvs(&mut json, &original, asset, uvs, 0, &mut blob).map_err(|e| werr(e.to_string()))?;
    json["buffers"][0]["byteLength"] = json!(blob.len());
    let text = serde_json::to_vec(&json).map_err(|e| werr(e.to_string()))?;
    let others = match &asset.container {
        Container::Gltf { others, .. } => others.as_slice(),
        Container::Obj { .. } => &[],
    };
    let mut staged = Staged::new();
    staged.add(out, glb::build_with(&text, Some(&blob), others));
    Ok(staged)
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
            let Ok(target) = uri_path(in_dir, &uri) else {
                continue;
            };
            if uri.starts_with("data:") {
                continue;
            }
            referenced.push(target.clone());
            if in_dir != out_dir {
                let rel = relative_path(out_dir, &target);
                item["uri"] = json!(percent_encode_path(&rel.to_string_lossy()));
            }
        }
    }
    referenced
}

/// A short content hash for a buffer's file name.
fn content_tag(bytes: &[u8]) -> String {
    let h = bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    });
    format!("{:016x}", h ^ bytes.len() as u64)
}

/// A .gltf: the UVs in a new buffer `<stem>.uvpin-<content>.bin` beside it,
/// staged before the .gltf that names it; an earlier output's uvpin buffer
/// that the new file no longer names is removed after.
fn stage_gltf(asset: &SourceAsset, mut json: Value, uvs: &[CornerUvs], out: &Path) -> Result<Staged, AssetError> {
    let werr = |message: String| AssetError::Write {
        path: out.to_path_buf(),
        message,
    };
    let original = json.clone();
    let (in_dir, out_dir) = (absolute_dir(&asset.path), absolute_dir(out));
    let referenced = rebase_uris(&mut json, &in_dir, &out_dir);
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let mut blob = Vec::new();
    let buffer = array(&mut json, "buffers").len();
    append_uvs(&mut json, &original, asset, uvs, buffer, &mut blob).map_err(|e| werr(e.to_string()))?;
    let bin_name = format!("{stem}.uvpin-{}.bin", content_tag(&blob));
    array(&mut json, "buffers").push(json!({ "uri": percent_encode_path(&bin_name), "byteLength": blob.len() }));
    let text = serde_json::to_vec_pretty(&json).map_err(|e| werr(e.to_string()))?;
    let bin_path = out.with_file_name(&bin_name);
    let mut staged = Staged::new();
    staged.add(bin_path, blob);
    staged.add(out, text);
    for old in earlier_buffers(out, &stem) {
        let named = referenced.contains(&old) || old.file_name() == Some(bin_name.as_ref());
        if !named {
            staged.remove_after(old);
        }
    }
    Ok(staged)
}

/// uvpin's buffers of earlier outputs named `stem` beside `out`: exactly
/// `<stem>.uvpin-<16 hex digits>.bin` (not another output's whose stem
/// begins the same way, such as `a.uvpinned` for `a`).
fn earlier_buffers(out: &Path, stem: &str) -> Vec<PathBuf> {
    let dir = absolute_dir(out);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Vec::new();
    };
    let prefix = format!("{stem}.uvpin-");
    let ours = |n: &str| {
        n.strip_prefix(&prefix)
            .and_then(|rest| rest.strip_suffix(".bin"))
            .is_some_and(|tag| tag.len() == 16 && tag.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)))
    };
    entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| ours(n))
        .map(|n| dir.join(n))
        .collect()
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
    pad4(&mut blob);
    json["buffers"][0]["byteLength"] = json!(blob.len());
    if let Some(uvs) = uvs {
        add_uv_set(&mut json, &mut blob, 0, uvs);
    }
    (json, blob)
}

/// Adds TEXCOORD_`set` to the one primitive of a fresh document made by
/// [`new_document`].
pub fn add_uv_set(json: &mut Value, blob: &mut Vec<u8>, set: u32, uvs: &[[f32; 2]]) {
    let offset = blob.len();
    blob.extend_from_slice(&f32_bytes(uvs));
    let acc = push_uv_accessor(json, 0, offset, uvs);
    json["meshes"][0]["primitives"][0]["attributes"][format!("TEXCOORD_{set}")] = json!(acc);
    pad4(blob);
    json["buffers"][0]["byteLength"] = json!(blob.len());
}

/// A fresh document's bytes as .glb, or as .gltf with an embedded data URI.
///
/// # Errors
/// An output that is neither .glb nor .gltf.
pub fn encode_new_document(json: &Value, blob: &[u8], out: &Path) -> Result<Vec<u8>, AssetError> {
    let werr = |message: String| AssetError::Write {
        path: out.to_path_buf(),
        message,
    };
    match AssetFormat::of(out) {
        Some(AssetFormat::Glb) => Ok(glb::build(
            &serde_json::to_vec(json).map_err(|e| werr(e.to_string()))?,
            Some(blob),
        )),
        Some(AssetFormat::Gltf) => {
            let mut json = json.clone();
            json["buffers"][0]["uri"] = json!(format!(
                "data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(blob)
            ));
            serde_json::to_vec_pretty(&json).map_err(|e| werr(e.to_string()))
        }
        _ => Err(werr("a new glTF document must be written as .glb or .gltf".into())),
    }
}

/// Writes a fresh document as .glb, or as .gltf with an embedded data URI.
///
/// # Errors
/// As [`encode_new_document`], and the write's.
pub fn write_new_document(json: &Value, blob: &[u8], out: &Path) -> Result<(), AssetError> {
    let bytes = encode_new_document(json, blob, out)?;
    atomic::write_atomically(out, &bytes).map_err(|e| AssetError::Write {
        path: out.to_path_buf(),
        message: e.message,
    })
}

/// The texture coordinates to write: glTF's per primitive, and, for an OBJ
/// asset, the OBJ `vt` of its one primitive.
#[derive(Debug, Clone)]
pub struct StoredUvs {
    pub gltf: Vec<CornerUvs>,
    pub obj_vt: Option<CornerUvs>,
}

/// Whether `out` can hold the asset with the UV set it asks for: an OBJ
/// holds one set, so a new set beside an OBJ's `vt` goes to glTF.
///
/// # Errors
/// An OBJ output for UV set 1 and above.
pub fn check_output_kind(asset: &SourceAsset, out: &Path) -> Result<(), AssetError> {
    if matches!(asset.container, Container::Obj { .. })
        && AssetFormat::of(out) == Some(AssetFormat::Obj)
        && asset.uv_set > 0
    {
        return Err(AssetError::Write {
            path: out.to_path_buf(),
            message: format!(
                "an OBJ file holds one UV set: write uv_set {} as .glb or .gltf (the `vt` stays set 0)",
                asset.uv_set
            ),
        });
    }
    Ok(())
}

/// The asset with new UVs in whatever form `out` asks for, staged: the same
/// type as the input (everything else kept), or .glb/.gltf from an OBJ.
///
/// # Errors
/// An output type that cannot hold the input; as [`stage_with_uvs`].
pub fn stage_asset(asset: &SourceAsset, uvs: &StoredUvs, out: &Path) -> Result<Staged, AssetError> {
    check_output_kind(asset, out)?;
    let mut staged = Staged::new();
    match (&asset.container, AssetFormat::of(out), &uvs.obj_vt) {
        (Container::Obj { bytes, faces }, Some(AssetFormat::Obj), Some(vt)) => {
            let written = super::obj::with_tex_coords(bytes, faces, &vt.corners).map_err(|e| AssetError::Write {
                path: out.to_path_buf(),
                message: e.to_string(),
            })?;
            staged.add(out, written);
        }
        (Container::Obj { .. }, Some(AssetFormat::Glb | AssetFormat::Gltf), _) => {
            let prim = &asset.primitives[0];
            let name = asset
                .path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let split = uvs.gltf[0].split(&prim.indices);
            let mut positions = prim.positions.clone();
            positions.extend(split.copies.iter().map(|&c| prim.positions[c as usize]));
            let (mut json, mut blob) = if asset.uv_set == 0 {
                new_document(&positions, &split.indices, Some(&split.uvs), &name)
            } else {
                // The OBJ's own `vt` stays set 0, per vertex (a copy has
                // its source vertex's), in glTF's convention.
                let Container::Obj { faces, .. } = &asset.container else {
                    unreachable!("matched as OBJ")
                };
                let vt = faces.vt.as_deref().unwrap_or_default();
                let gltf = |v: u32| vt.get(v as usize).map_or([0.0, 0.0], |t| [t[0], 1.0 - t[1]]);
                let own: Vec<[f32; 2]> = (0..prim.positions.len() as u32)
                    .chain(split.copies.iter().copied())
                    .map(gltf)
                    .collect();
                new_document(&positions, &split.indices, Some(&own), &name)
            };
            if asset.uv_set > 0 {
                add_uv_set(&mut json, &mut blob, asset.uv_set, &split.uvs);
            }
            staged.add(out, encode_new_document(&json, &blob, out)?);
        }
        (Container::Gltf { .. }, _, _) => return stage_with_uvs(asset, &uvs.gltf, out),
        (Container::Obj { .. }, _, _) => {
            return Err(AssetError::Write {
                path: out.to_path_buf(),
                message: "write an OBJ input as .obj, .glb or .gltf".into(),
            });
        }
    }
    Ok(staged)
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
        .filter_map(|uri| uri_path(base, uri).ok())
        .collect()
}
