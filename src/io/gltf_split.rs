//! Splitting a glTF primitive's vertices along seams: every vertex
//! attribute of the primitive (positions, normals, tangents, colours, every
//! texture coordinate set, joints and weights) and of its morph targets
//! gets the copies' values appended, in new accessors; the indices are
//! rewritten to name the copies. The old accessors and every byte of the
//! old buffers stay as they were.

use super::corners::VertexSplit;
use serde_json::{Value, json};

/// What keeps a glTF's data from being read or carried into the output.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    #[error("buffer view {view} does not exist")]
    ViewMissing { view: usize },
    #[error("buffer view {view} names no buffer")]
    ViewWithoutBuffer { view: usize },
    #[error("buffer {buffer} does not exist")]
    BufferMissing { buffer: usize },
    #[error("buffer view {view} is shorter than its accessor")]
    ViewShort { view: usize },
    #[error("accessor {index} does not exist")]
    AccessorMissing { index: usize },
    #[error("accessor {index}: component type {component}")]
    ComponentType { index: usize, component: u64 },
    #[error("accessor {index}: type")]
    AccessorType { index: usize },
    #[error("accessor {index} has no count")]
    NoCount { index: usize },
    #[error("accessor {index}: sparse index type")]
    SparseIndexType { index: usize },
    #[error("accessor {index}: sparse index {i}")]
    SparseIndex { index: usize, i: usize },
    #[error("accessor {index}: sparse indices without a view")]
    SparseIndicesWithoutView { index: usize },
    #[error("accessor {index}: sparse values without a view")]
    SparseValuesWithoutView { index: usize },
    #[error("accessor {index} has {n} elements, fewer than the primitive's vertices")]
    FewerElements { index: usize, n: usize },
    #[error("data URI without ;base64,")]
    DataUriWithoutBase64,
    #[error("bad base64: {0}")]
    Base64(#[from] base64::DecodeError),
    #[error(
        "URI {} is not a relative path (only relative paths and data URIs are read)",
        crate::ron_file::snippet(uri)
    )]
    NotRelative { uri: String },
    #[error("cannot read {}: {reason}", file.display())]
    Read {
        file: std::path::PathBuf,
        reason: super::read::ReadError,
    },
    #[error(transparent)]
    Asset(Box<super::AssetError>),
}

/// Bytes of one component of a glTF `componentType`.
fn component_size(component: u64) -> Option<usize> {
    match component {
        5120 | 5121 => Some(1),
        5122 | 5123 => Some(2),
        5125 | 5126 => Some(4),
        _ => None,
    }
}

/// Components of a glTF accessor `type`.
fn components(kind: &str) -> Option<usize> {
    Some(match kind {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" | "MAT2" => 4,
        "MAT3" => 9,
        "MAT4" => 16,
        _ => return None,
    })
}

fn int(v: &Value, key: &str) -> Option<usize> {
    v.get(key).and_then(Value::as_u64).map(|x| x as usize)
}

/// The bytes of `count` elements of `size` bytes at `offset` of buffer
/// view `view`, `stride` apart (its `byteStride`, or `size`).
fn view_elements(
    json: &Value,
    buffers: &[Vec<u8>],
    view: usize,
    offset: usize,
    count: usize,
    size: usize,
) -> Result<Vec<u8>, DataError> {
    let v = json["bufferViews"].get(view).ok_or(DataError::ViewMissing { view })?;
    let buffer = int(v, "buffer").ok_or(DataError::ViewWithoutBuffer { view })?;
    let data = buffers.get(buffer).ok_or(DataError::BufferMissing { buffer })?;
    let start = int(v, "byteOffset").unwrap_or(0) + offset;
    let stride = int(v, "byteStride").unwrap_or(size).max(size);
    let mut out = Vec::with_capacity(count * size);
    for i in 0..count {
        let at = start + i * stride;
        let bytes = data.get(at..at + size).ok_or(DataError::ViewShort { view })?;
        out.extend_from_slice(bytes);
    }
    Ok(out)
}

/// Accessor `index`'s elements, tightly packed (sparse values applied),
/// and the size of one element.
fn accessor_elements(json: &Value, buffers: &[Vec<u8>], index: usize) -> Result<(Vec<u8>, usize), DataError> {
    let a = json["accessors"]
        .get(index)
        .ok_or(DataError::AccessorMissing { index })?;
    let component = a.get("componentType").and_then(Value::as_u64).unwrap_or(0);
    let size = component_size(component).ok_or(DataError::ComponentType { index, component })?
        * a.get("type")
            .and_then(Value::as_str)
            .and_then(components)
            .ok_or(DataError::AccessorType { index })?;
    let count = int(a, "count").ok_or(DataError::NoCount { index })?;
    let mut data = match int(a, "bufferView") {
        Some(view) => view_elements(json, buffers, view, int(a, "byteOffset").unwrap_or(0), count, size)?,
        None => vec![0u8; count * size],
    };
    if let Some(sparse) = a.get("sparse") {
        let n = int(sparse, "count").unwrap_or(0);
        let idx = &sparse["indices"];
        let isize = component_size(idx.get("componentType").and_then(Value::as_u64).unwrap_or(0))
            .ok_or(DataError::SparseIndexType { index })?;
        let at = |s: &Value| (int(s, "bufferView"), int(s, "byteOffset").unwrap_or(0));
        let (Some(iv), io) = at(idx) else {
            return Err(DataError::SparseIndicesWithoutView { index });
        };
        let (Some(vv), vo) = at(&sparse["values"]) else {
            return Err(DataError::SparseValuesWithoutView { index });
        };
        let indices = view_elements(json, buffers, iv, io, n, isize)?;
        let values = view_elements(json, buffers, vv, vo, n, size)?;
        for k in 0..n {
            let i = indices[k * isize..(k + 1) * isize]
                .iter()
                .rev()
                .fold(0usize, |acc, &b| acc << 8 | b as usize);
            let target = data
                .get_mut(i * size..(i + 1) * size)
                .ok_or(DataError::SparseIndex { index, i })?;
            target.copy_from_slice(&values[k * size..(k + 1) * size]);
        }
    }
    Ok((data, size))
}

fn pad(blob: &mut Vec<u8>, to: usize) {
    while !blob.len().is_multiple_of(to) {
        blob.push(0);
    }
}

/// A copy of accessor `template` holding `data` (elements of `size`
/// bytes) in a new view of buffer `buffer` at the end of `blob`; its index.
/// Elements are 4-byte aligned, as vertex attributes must be.
fn push_like(json: &mut Value, template: usize, data: &[u8], size: usize, buffer: usize, blob: &mut Vec<u8>) -> usize {
    let stride = size.div_ceil(4) * 4;
    pad(blob, 4);
    let offset = blob.len();
    for element in data.chunks_exact(size) {
        blob.extend_from_slice(element);
        blob.extend(std::iter::repeat_n(0u8, stride - size));
    }
    let mut view =
        json!({ "buffer": buffer, "byteOffset": offset, "byteLength": blob.len() - offset, "target": 34962 });
    if stride != size {
        view["byteStride"] = json!(stride);
    }
    let views = json["bufferViews"].as_array_mut().expect("bufferViews");
    views.push(view);
    let view_index = views.len() - 1;
    let mut accessor = json["accessors"][template].clone();
    let object = accessor.as_object_mut().expect("an accessor object");
    object.remove("sparse");
    object.insert("bufferView".into(), json!(view_index));
    object.insert("byteOffset".into(), json!(0));
    object.insert("count".into(), json!(data.len() / size));
    let accessors = json["accessors"].as_array_mut().expect("accessors");
    accessors.push(accessor);
    accessors.len() - 1
}

/// Accessor `index`'s elements with the copies' appended, as a new accessor.
fn extended(
    original: &Value,
    json: &mut Value,
    buffers: &[Vec<u8>],
    index: usize,
    split: &VertexSplit,
    buffer: usize,
    blob: &mut Vec<u8>,
) -> Result<usize, DataError> {
    let (mut data, size) = accessor_elements(original, buffers, index)?;
    let n = data.len() / size;
    for &c in &split.copies {
        let c = c as usize;
        if c >= n {
            return Err(DataError::FewerElements { index, n });
        }
        data.extend_from_within(c * size..(c + 1) * size);
    }
    Ok(push_like(json, index, &data, size, buffer, blob))
}

/// Splits primitive `prim` of mesh `mesh` as `split` says: every vertex
/// attribute but `skip` (the UV set written anew) and every morph target
/// attribute extended with the copies, new indices; read from the
/// `original` document and its `buffers`, written into `json` and `blob`
/// (buffer `buffer` of `json`).
///
/// # Errors
/// An accessor that cannot be read (out of its buffer, unknown types).
#[allow(clippy::too_many_arguments)]
pub fn split_primitive(
    original: &Value,
    json: &mut Value,
    buffers: &[Vec<u8>],
    (mesh, prim): (usize, usize),
    skip: &str,
    split: &VertexSplit,
    buffer: usize,
    blob: &mut Vec<u8>,
) -> Result<(), DataError> {
    let source = &original["meshes"][mesh]["primitives"][prim];
    let attributes: Vec<(String, usize)> = source["attributes"]
        .as_object()
        .into_iter()
        .flatten()
        .filter(|(name, _)| name.as_str() != skip)
        .filter_map(|(name, a)| Some((name.clone(), a.as_u64()? as usize)))
        .collect();
    for (name, accessor) in attributes {
        let new = extended(original, json, buffers, accessor, split, buffer, blob)?;
        json["meshes"][mesh]["primitives"][prim]["attributes"][name.as_str()] = json!(new);
    }
    let targets = source
        .get("targets")
        .and_then(Value::as_array)
        .cloned()
        .unwrap_or_default();
    for (t, target) in targets.iter().enumerate() {
        for (name, a) in target.as_object().into_iter().flatten() {
            let Some(accessor) = a.as_u64() else { continue };
            let new = extended(original, json, buffers, accessor as usize, split, buffer, blob)?;
            json["meshes"][mesh]["primitives"][prim]["targets"][t][name.as_str()] = json!(new);
        }
    }
    let indices = push_indices(json, &split.indices, split.uvs.len(), buffer, blob);
    json["meshes"][mesh]["primitives"][prim]["indices"] = json!(indices);
    Ok(())
}

/// The indices as a new accessor (16-bit when they fit, else 32-bit).
fn push_indices(json: &mut Value, indices: &[u32], n_vertices: usize, buffer: usize, blob: &mut Vec<u8>) -> usize {
    let short = n_vertices <= u16::MAX as usize;
    pad(blob, 4);
    let offset = blob.len();
    for &i in indices {
        if short {
            blob.extend_from_slice(&(i as u16).to_le_bytes());
        } else {
            blob.extend_from_slice(&i.to_le_bytes());
        }
    }
    let length = blob.len() - offset;
    pad(blob, 4);
    let views = json["bufferViews"].as_array_mut().expect("bufferViews");
    views.push(json!({ "buffer": buffer, "byteOffset": offset, "byteLength": length, "target": 34963 }));
    let view = views.len() - 1;
    let accessors = json["accessors"].as_array_mut().expect("accessors");
    accessors.push(json!({
        "bufferView": view,
        "componentType": if short { 5123 } else { 5125 },
        "count": indices.len(),
        "type": "SCALAR",
    }));
    accessors.len() - 1
}
