//! Checks a glTF document against the parts of the spec uvpin's reading
//! relies on, before the `gltf` crate sees it: every index the meshes,
//! accessors, buffer views and images name is in range, component types,
//! element types and strides are what the spec allows where uvpin reads
//! them, and every accessor's bytes lie inside its view and every view
//! inside its buffer's declared length (which the loader checks against the
//! real data). Counts are bounded by the input limits, so nothing huge is
//! allocated on a file's say-so.

use super::read::InputLimits;
use serde_json::Value;

const BYTE: u64 = 5120;
const UNSIGNED_BYTE: u64 = 5121;
const SHORT: u64 = 5122;
const UNSIGNED_SHORT: u64 = 5123;
const UNSIGNED_INT: u64 = 5125;
const FLOAT: u64 = 5126;

/// The first problem found, as a message naming the object (`accessors[3].count: …`).
pub type Problem = String;

fn array<'a>(json: &'a Value, key: &str) -> &'a [Value] {
    json.get(key).and_then(Value::as_array).map_or(&[], Vec::as_slice)
}

/// An optional non-negative integer field; `Err` if present but not one.
fn uint(object: &Value, key: &str, at: &str) -> Result<Option<u64>, Problem> {
    match object.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v
            .as_u64()
            .map(Some)
            .ok_or_else(|| format!("{at}.{key}: must be a non-negative integer, got {}", short(v))),
    }
}

/// A required non-negative integer field.
fn required_uint(object: &Value, key: &str, at: &str) -> Result<u64, Problem> {
    uint(object, key, at)?.ok_or_else(|| format!("{at}.{key}: missing"))
}

/// An index field into a list of `len` objects named `list`.
fn index(object: &Value, key: &str, at: &str, list: &str, len: usize) -> Result<Option<usize>, Problem> {
    match uint(object, key, at)? {
        Some(i) if i as usize >= len || i > usize::MAX as u64 => Err(format!(
            "{at}.{key}: {list}[{i}] does not exist (the file has {len} {list})"
        )),
        other => Ok(other.map(|i| i as usize)),
    }
}

/// At most 40 characters of a JSON value, for messages.
fn short(v: &Value) -> String {
    let s = v.to_string();
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s
    }
}

fn component_size(component_type: u64) -> Option<u64> {
    match component_type {
        BYTE | UNSIGNED_BYTE => Some(1),
        SHORT | UNSIGNED_SHORT => Some(2),
        UNSIGNED_INT | FLOAT => Some(4),
        _ => None,
    }
}

/// Bytes of one element of `kind` (`VEC3`, …) of components of `size`
/// bytes; matrix columns are aligned to 4 bytes.
fn element_size(kind: &str, size: u64) -> Option<u64> {
    let column = |rows: u64| (rows * size).div_ceil(4) * 4;
    match kind {
        "SCALAR" => Some(size),
        "VEC2" => Some(2 * size),
        "VEC3" => Some(3 * size),
        "VEC4" => Some(4 * size),
        "MAT2" => Some(2 * column(2)),
        "MAT3" => Some(3 * column(3)),
        "MAT4" => Some(4 * column(4)),
        _ => None,
    }
}

/// What one accessor is, once checked.
#[derive(Debug, Clone)]
struct AccessorShape {
    component_type: u64,
    kind: String,
    normalized: bool,
}

/// Checks the whole document; `Err` names the first problem.
///
/// # Errors
/// The first out-of-range index, forbidden type or stride, count over the
/// limits, or byte range outside its view or buffer.
pub fn validate(json: &Value, limits: &InputLimits, has_bin: bool) -> Result<(), Problem> {
    let buffers = check_buffers(json, limits, has_bin)?;
    let views = check_views(json, &buffers)?;
    let accessors = array(json, "accessors")
        .iter()
        .enumerate()
        .map(|(i, a)| check_accessor(a, &format!("accessors[{i}]"), &views, limits))
        .collect::<Result<Vec<_>, _>>()?;
    check_images(json, views.len())?;
    for (m, mesh) in array(json, "meshes").iter().enumerate() {
        for (p, prim) in array(mesh, "primitives").iter().enumerate() {
            check_primitive(json, prim, &format!("meshes[{m}].primitives[{p}]"), &accessors)?;
        }
    }
    Ok(())
}

/// Each buffer's declared length (at least 1, within the file limit; a
/// buffer without `uri` is the GLB BIN chunk).
fn check_buffers(json: &Value, limits: &InputLimits, has_bin: bool) -> Result<Vec<u64>, Problem> {
    array(json, "buffers")
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let at = format!("buffers[{i}]");
            let length = required_uint(b, "byteLength", &at)?;
            if length > limits.max_file_bytes {
                return Err(format!(
                    "{at}.byteLength: {length} bytes is more than the input limit of {} bytes",
                    limits.max_file_bytes
                ));
            }
            match b.get("uri") {
                None if !has_bin || i != 0 => Err(format!("{at}: no uri, and it is not the GLB BIN chunk")),
                Some(u) if !u.is_string() => Err(format!("{at}.uri: must be a string")),
                _ => Ok(length),
            }
        })
        .collect()
}

/// Each buffer view's length and stride; every view inside its buffer.
fn check_views(json: &Value, buffers: &[u64]) -> Result<Vec<(u64, Option<u64>)>, Problem> {
    array(json, "bufferViews")
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let at = format!("bufferViews[{i}]");
            let buffer =
                index(v, "buffer", &at, "buffers", buffers.len())?.ok_or_else(|| format!("{at}.buffer: missing"))?;
            let offset = uint(v, "byteOffset", &at)?.unwrap_or(0);
            let length = required_uint(v, "byteLength", &at)?;
            let stride = uint(v, "byteStride", &at)?;
            if let Some(s) = stride
                && !(4..=252).contains(&s)
            {
                return Err(format!("{at}.byteStride: {s} is outside 4..=252"));
            }
            if offset.checked_add(length).is_none_or(|end| end > buffers[buffer]) {
                return Err(format!(
                    "{at}: bytes {offset}..{} are outside buffers[{buffer}] ({} bytes)",
                    offset.saturating_add(length),
                    buffers[buffer]
                ));
            }
            Ok((length, stride))
        })
        .collect()
}

/// The last byte (exclusive) that `count` elements of `element` bytes at
/// `offset` with `stride` reach.
fn extent(offset: u64, stride: u64, count: u64, element: u64) -> Option<u64> {
    stride
        .checked_mul(count.checked_sub(1)?)?
        .checked_add(offset)?
        .checked_add(element)
}

fn check_accessor(
    a: &Value,
    at: &str,
    views: &[(u64, Option<u64>)],
    limits: &InputLimits,
) -> Result<AccessorShape, Problem> {
    let component_type = required_uint(a, "componentType", at)?;
    let size = component_size(component_type)
        .ok_or_else(|| format!("{at}.componentType: {component_type} is not a glTF component type"))?;
    let kind = a
        .get("type")
        .and_then(Value::as_str)
        .ok_or_else(|| format!("{at}.type: missing"))?;
    let element = element_size(kind, size).ok_or_else(|| format!("{at}.type: {kind:?} is not a glTF accessor type"))?;
    let count = required_uint(a, "count", at)?;
    let max_count = limits.max_vertices.max(3 * limits.max_triangles) as u64;
    if count == 0 || count > max_count || count.saturating_mul(element) > limits.max_file_bytes {
        return Err(format!(
            "{at}.count: {count} is outside 1..={max_count} (the input limits)"
        ));
    }
    if let Some(view) = index(a, "bufferView", at, "bufferViews", views.len())? {
        let (length, stride) = views[view];
        let stride = stride.unwrap_or(element);
        if stride < element {
            return Err(format!(
                "{at}: bufferViews[{view}].byteStride {stride} is smaller than one {kind} element ({element} bytes)"
            ));
        }
        let offset = uint(a, "byteOffset", at)?.unwrap_or(0);
        if extent(offset, stride, count, element).is_none_or(|end| end > length) {
            return Err(format!(
                "{at}: {count} elements from byte {offset} run past the end of bufferViews[{view}] ({length} bytes)"
            ));
        }
    }
    if let Some(sparse) = a.get("sparse") {
        check_sparse(sparse, &format!("{at}.sparse"), count, element, views)?;
    }
    Ok(AccessorShape {
        component_type,
        kind: kind.to_string(),
        normalized: a.get("normalized").and_then(Value::as_bool).unwrap_or(false),
    })
}

/// A sparse accessor's indices and values lie inside their views.
fn check_sparse(
    sparse: &Value,
    at: &str,
    count: u64,
    element: u64,
    views: &[(u64, Option<u64>)],
) -> Result<(), Problem> {
    let n = required_uint(sparse, "count", at)?;
    if n == 0 || n > count {
        return Err(format!("{at}.count: {n} is outside 1..={count}"));
    }
    let part = |key: &str, size: u64| -> Result<(), Problem> {
        let object = sparse.get(key).ok_or_else(|| format!("{at}.{key}: missing"))?;
        let at = format!("{at}.{key}");
        let view = index(object, "bufferView", &at, "bufferViews", views.len())?
            .ok_or_else(|| format!("{at}.bufferView: missing"))?;
        let offset = uint(object, "byteOffset", &at)?.unwrap_or(0);
        if extent(offset, size, n, size).is_none_or(|end| end > views[view].0) {
            return Err(format!("{at}: {n} entries run past the end of bufferViews[{view}]"));
        }
        Ok(())
    };
    let indices = sparse.get("indices").ok_or_else(|| format!("{at}.indices: missing"))?;
    let index_type = required_uint(indices, "componentType", &format!("{at}.indices"))?;
    let index_size = match index_type {
        UNSIGNED_BYTE => 1,
        UNSIGNED_SHORT => 2,
        UNSIGNED_INT => 4,
        t => {
            return Err(format!(
                "{at}.indices.componentType: {t} is not an unsigned integer type"
            ));
        }
    };
    part("indices", index_size)?;
    part("values", element)
}

/// Every image names an existing buffer view, or has a `uri`.
fn check_images(json: &Value, n_views: usize) -> Result<(), Problem> {
    for (i, image) in array(json, "images").iter().enumerate() {
        let at = format!("images[{i}]");
        let view = index(image, "bufferView", &at, "bufferViews", n_views)?;
        if view.is_none() && !image.get("uri").is_some_and(Value::is_string) {
            return Err(format!("{at}: neither a uri nor a bufferView"));
        }
    }
    Ok(())
}

/// A primitive's attributes, indices, material and morph targets name
/// existing objects, and what uvpin reads has the type the spec requires.
fn check_primitive(json: &Value, prim: &Value, at: &str, accessors: &[AccessorShape]) -> Result<(), Problem> {
    let attributes = prim
        .get("attributes")
        .and_then(Value::as_object)
        .ok_or_else(|| format!("{at}.attributes: missing"))?;
    for (name, value) in attributes {
        let object = serde_json::json!({ "a": value });
        let a = index(
            &object,
            "a",
            &format!("{at}.attributes.{name}"),
            "accessors",
            accessors.len(),
        )?
        .ok_or_else(|| format!("{at}.attributes.{name}: missing"))?;
        check_attribute(name, &accessors[a], &format!("{at}.attributes.{name} (accessors[{a}])"))?;
    }
    if !attributes.contains_key("POSITION") {
        return Err(format!("{at}.attributes: no POSITION"));
    }
    if let Some(i) = index(prim, "indices", at, "accessors", accessors.len())? {
        let a = &accessors[i];
        let unsigned = matches!(a.component_type, UNSIGNED_BYTE | UNSIGNED_SHORT | UNSIGNED_INT);
        if a.kind != "SCALAR" || !unsigned || a.normalized {
            return Err(format!(
                "{at}.indices (accessors[{i}]): must be SCALAR unsigned integers, got {} of component type {}",
                a.kind, a.component_type
            ));
        }
    }
    index(prim, "material", at, "materials", array(json, "materials").len())?;
    if let Some(mode) = uint(prim, "mode", at)?
        && mode > 6
    {
        return Err(format!("{at}.mode: {mode} is not a glTF primitive mode"));
    }
    for (t, target) in array(prim, "targets").iter().enumerate() {
        for key in ["POSITION", "NORMAL", "TANGENT"] {
            index(target, key, &format!("{at}.targets[{t}]"), "accessors", accessors.len())?;
        }
    }
    Ok(())
}

/// POSITION must be float VEC3; TEXCOORD_n float or normalised unsigned VEC2.
fn check_attribute(name: &str, a: &AccessorShape, at: &str) -> Result<(), Problem> {
    let ok = match name {
        "POSITION" => a.kind == "VEC3" && a.component_type == FLOAT,
        n if n.starts_with("TEXCOORD_") => {
            a.kind == "VEC2"
                && (a.component_type == FLOAT
                    || (a.normalized && matches!(a.component_type, UNSIGNED_BYTE | UNSIGNED_SHORT)))
        }
        _ => true,
    };
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{at}: {} of component type {}{} is not allowed for {name}",
            a.kind,
            a.component_type,
            if a.normalized { " (normalized)" } else { "" }
        ))
    }
}

/// The declared counts of the mesh's primitives stay within the limits.
///
/// # Errors
/// The totals over `limits`.
pub fn check_mesh_size(json: &Value, mesh: usize, limits: &InputLimits) -> Result<(), Problem> {
    let accessors = array(json, "accessors");
    let count = |i: Option<u64>| {
        i.and_then(|i| accessors.get(i as usize))
            .and_then(|a| a.get("count").and_then(Value::as_u64))
            .unwrap_or(0)
    };
    let (mut vertices, mut corners) = (0u64, 0u64);
    let prims = json
        .get("meshes")
        .and_then(|m| m.get(mesh))
        .map_or(&[][..], |m| array(m, "primitives"));
    for prim in prims {
        let v = count(
            prim.get("attributes")
                .and_then(|a| a.get("POSITION"))
                .and_then(Value::as_u64),
        );
        vertices += v;
        corners += match prim.get("indices").and_then(Value::as_u64) {
            Some(i) => count(Some(i)),
            None => v,
        };
    }
    if vertices > limits.max_vertices as u64 {
        return Err(format!(
            "meshes[{mesh}]: {vertices} vertices, more than the input limit of {}",
            limits.max_vertices
        ));
    }
    if corners / 3 > limits.max_triangles as u64 {
        return Err(format!(
            "meshes[{mesh}]: {} triangles, more than the input limit of {}",
            corners / 3,
            limits.max_triangles
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn doc() -> Value {
        json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": 48}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 12}],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}
            ],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}]
        })
    }

    fn problem(edit: impl Fn(&mut Value)) -> String {
        let mut d = doc();
        edit(&mut d);
        validate(&d, &InputLimits::DEFAULT, true).unwrap_err()
    }

    #[test]
    fn a_valid_document_passes() {
        assert_eq!(validate(&doc(), &InputLimits::DEFAULT, true), Ok(()));
    }

    #[test]
    fn hostile_documents_are_named_problems() {
        let p = problem(|d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9));
        assert!(p.contains("accessors[9] does not exist"), "{p}");
        let p = problem(|d| d["accessors"][1]["componentType"] = json!(5122));
        assert!(p.contains("must be SCALAR unsigned integers"), "{p}");
        let p = problem(|d| d["accessors"][1]["componentType"] = json!(5126));
        assert!(p.contains("must be SCALAR unsigned integers"), "{p}");
        let p = problem(|d| d["bufferViews"][0]["byteStride"] = json!(4));
        assert!(p.contains("smaller than one VEC3 element"), "{p}");
        let p = problem(|d| d["accessors"][0]["type"] = json!("VEC2"));
        assert!(p.contains("not allowed for POSITION"), "{p}");
        let p = problem(|d| d["accessors"][0]["componentType"] = json!(5121));
        assert!(p.contains("not allowed for POSITION"), "{p}");
        let p = problem(|d| d["meshes"][0]["primitives"][0]["indices"] = json!(7));
        assert!(p.contains("accessors[7] does not exist"), "{p}");
        let p = problem(|d| {
            d["accessors"][0] = json!({"componentType": 5126, "count": 2147483648u64, "type": "VEC3",
                "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5125}, "values": {"bufferView": 0}}});
        });
        assert!(p.contains("input limits"), "{p}");
        let p = problem(|d| d["bufferViews"][0]["byteLength"] = json!(100));
        assert!(p.contains("outside buffers[0]"), "{p}");
        let p = problem(|d| d["accessors"][0]["count"] = json!(4));
        assert!(p.contains("run past the end"), "{p}");
        let p = problem(|d| d["accessors"][0]["count"] = json!(0));
        assert!(p.contains("outside 1..="), "{p}");
        let p = problem(|d| d["bufferViews"][0]["buffer"] = json!(-1));
        assert!(p.contains("non-negative integer"), "{p}");
    }
}

/// Why `json` (a glTF JSON text) cannot be kept as read, if so: an object
/// that names one key twice (a JSON value model keeps only one of them, so
/// the file could not be written back as it was). The message has the line
/// and column.
pub fn duplicate_key(json: &[u8]) -> Option<String> {
    serde_json::from_slice::<NoDuplicates>(json)
        .err()
        .map(|e| e.to_string())
}

/// A JSON value checked for objects with a key given twice.
struct NoDuplicates;

impl<'de> serde::Deserialize<'de> for NoDuplicates {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NoDuplicatesVisitor)
    }
}

struct NoDuplicatesVisitor;

impl<'de> serde::de::Visitor<'de> for NoDuplicatesVisitor {
    type Value = NoDuplicates;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<NoDuplicates, A::Error> {
        let mut seen = std::collections::HashSet::new();
        while let Some(key) = map.next_key::<String>()? {
            if !seen.insert(key.clone()) {
                return Err(serde::de::Error::custom(format!(
                    "the key {key:?} appears twice in one object (only one could be kept)"
                )));
            }
            map.next_value::<NoDuplicates>()?;
        }
        Ok(NoDuplicates)
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<NoDuplicates, A::Error> {
        while seq.next_element::<NoDuplicates>()?.is_some() {}
        Ok(NoDuplicates)
    }

    fn visit_bool<E>(self, _: bool) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }

    fn visit_i64<E>(self, _: i64) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }

    fn visit_u64<E>(self, _: u64) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }

    fn visit_f64<E>(self, _: f64) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }

    fn visit_str<E>(self, _: &str) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }

    fn visit_unit<E>(self) -> Result<NoDuplicates, E> {
        Ok(NoDuplicates)
    }
}

#[cfg(test)]
mod duplicate_tests {
    #[test]
    fn a_key_given_twice_is_named_with_its_place() {
        assert_eq!(
            super::duplicate_key(br#"{"a": [1, {"b": 2, "c": 3}], "d": 12345678901234567890123}"#),
            None
        );
        let e = super::duplicate_key(b"{\"a\": 1,\n \"m\": {\"x\": 1, \"x\": 2}}").unwrap();
        assert!(e.contains("\"x\" appears twice") && e.contains("line 2"), "{e}");
    }
}
