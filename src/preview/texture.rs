//! The base-colour texture of a glTF asset's material, decoded for pictures.

use crate::io::{Container, SourceAsset};
use serde_json::Value;

/// The base-colour texture of the first material (of the asset's mesh) that
/// has one, decoded once per loaded asset; `None` when there is none or it
/// cannot be decoded (pictures then show a plain square).
pub fn base_colour_texture(asset: &SourceAsset) -> Option<std::sync::Arc<image::RgbaImage>> {
    asset
        .decoded_texture
        .get_or_init(|| decode(asset).map(std::sync::Arc::new))
        .clone()
}

fn decode(asset: &SourceAsset) -> Option<image::RgbaImage> {
    let Container::Gltf { json, bin, .. } = &asset.container else {
        return None;
    };
    let mesh = json.get("meshes")?.get(asset.mesh_index)?;
    let material = mesh
        .get("primitives")?
        .as_array()?
        .iter()
        .filter_map(|p| p.get("material").and_then(Value::as_u64))
        .find_map(|m| {
            json.get("materials")?
                .get(m as usize)?
                .get("pbrMetallicRoughness")?
                .get("baseColorTexture")?
                .get("index")?
                .as_u64()
        })?;
    let source = json.get("textures")?.get(material as usize)?.get("source")?.as_u64()?;
    let image = json.get("images")?.get(source as usize)?;
    let bytes = if let Some(view) = image.get("bufferView").and_then(Value::as_u64) {
        let view = json.get("bufferViews")?.get(view as usize)?;
        let buffer = view.get("buffer")?.as_u64()? as usize;
        let offset = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
        let length = view.get("byteLength")?.as_u64()? as usize;
        let data = buffer_bytes(json, bin.as_deref(), buffer, asset)?;
        data.get(offset..offset + length)?.to_vec()
    } else {
        uri_bytes(image.get("uri")?.as_str()?, asset)?
    };
    decode_within(&bytes, asset.rules.limits.max_image_pixels)
}

/// Decodes an image of at most `max_pixels` (width × height): the decoder
/// checks its header against the limit before the pixels are allocated.
fn decode_within(bytes: &[u8], max_pixels: u64) -> Option<image::RgbaImage> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .ok()?;
    let mut limits = image::Limits::default();
    // Up to 16 bytes a pixel (RGBA of 32-bit floats) while decoding.
    limits.max_alloc = Some(max_pixels.saturating_mul(16));
    reader.limits(limits);
    reader.decode().ok().map(|i| i.to_rgba8())
}

fn buffer_bytes(json: &Value, bin: Option<&[u8]>, index: usize, asset: &SourceAsset) -> Option<Vec<u8>> {
    let buffer = json.get("buffers")?.get(index)?;
    match buffer.get("uri").and_then(Value::as_str) {
        None => bin.map(<[u8]>::to_vec),
        Some(uri) => uri_bytes(uri, asset),
    }
}

/// A buffer's or image's bytes, read within the asset's rules (only a
/// regular file, within the size limit and the read scope).
fn uri_bytes(uri: &str, asset: &SourceAsset) -> Option<Vec<u8>> {
    let base = asset.path.parent()?;
    crate::io::gltf_file::read_uri(base, uri, &asset.rules).ok()
}

/// The image at `path` (a constraint file's `image:`), read within `rules`
/// and decoded within its pixel limit.
///
/// # Errors
/// Unreadable (not a regular file, too large, outside the read scope) or
/// not a decodable image.
pub fn load_image(path: &std::path::Path, rules: &crate::io::InputRules) -> Result<image::RgbaImage, ImageError> {
    let bytes = crate::io::read::read_regular(path, rules.limits.max_file_bytes, &rules.scope).map_err(|reason| {
        ImageError::Read {
            path: path.to_path_buf(),
            reason,
        }
    })?;
    decode_within(&bytes, rules.limits.max_image_pixels).ok_or_else(|| ImageError::Undecodable {
        path: path.to_path_buf(),
    })
}

/// Why an `image:` was not read.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{}: {reason}", path.display())]
    Read {
        path: std::path::PathBuf,
        reason: crate::io::read::ReadError,
    },
    #[error("{}: not an image that can be decoded (PNG or JPEG)", path.display())]
    Undecodable { path: std::path::PathBuf },
}

/// `image` as PNG bytes.
pub fn png_bytes(image: &image::RgbaImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut out, image::ImageFormat::Png)
        .expect("PNG encoding into memory");
    out.into_inner()
}
