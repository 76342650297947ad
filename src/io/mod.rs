//! Reading meshes from glTF (.glb, .gltf with embedded or external buffers)
//! and OBJ, and writing a UV set back with nothing else changed.

pub mod atomic;
pub mod corners;
pub mod folder;
pub mod glb;
pub mod gltf_file;
pub mod gltf_split;
pub mod obj;
pub mod paths;
pub mod read;
pub mod scan;
pub mod validate;

pub use read::{InputLimits, ReadError, ReadScope};

use crate::mesh::weld::PrimitiveGeometry;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Which mesh of the asset: its index or its name.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum MeshSelector {
    Index(usize),
    Name(String),
}

/// What went wrong with an asset file. Every variant names the file.
#[derive(Debug, Error)]
pub enum AssetError {
    #[error("{path}: cannot read: {source}")]
    Read { path: PathBuf, source: ReadError },
    #[error("{path}: more than the input limits allow: {message}")]
    TooLarge { path: PathBuf, message: String },
    #[error("{path}: unsupported file type (use .glb, .gltf, .obj, .ply, .stl or .off)")]
    UnknownFormat { path: PathBuf },
    #[error("{path}: {source}")]
    Scan { path: PathBuf, source: scan::ScanError },
    #[error("{path}: corrupt GLB: {source}")]
    Glb { path: PathBuf, source: glb::GlbError },
    #[error("{path}: invalid glTF: {message}")]
    Gltf { path: PathBuf, message: String },
    #[error("{path}: buffer {buffer}: {message}")]
    Buffer {
        path: PathBuf,
        buffer: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    MeshSelection { path: PathBuf, message: String },
    #[error(
        "{path}: mesh {mesh} primitive {primitive} has mode {mode}; only TRIANGLES primitives can be parameterised"
    )]
    NonTrianglePrimitive {
        path: PathBuf,
        mesh: usize,
        primitive: usize,
        mode: String,
    },
    #[error("{path}: mesh {mesh} primitive {primitive}: {message}")]
    Primitive {
        path: PathBuf,
        mesh: usize,
        primitive: usize,
        message: String,
    },
    #[error("{path}: mesh {mesh} primitive {primitive} vertex {vertex}: position {position:?} is not finite")]
    NonFinitePosition {
        path: PathBuf,
        mesh: usize,
        primitive: usize,
        vertex: usize,
        position: [f32; 3],
    },
    #[error("{path}:{line}: {error}")]
    Obj {
        path: PathBuf,
        line: usize,
        error: obj::ObjLineError,
    },
    #[error("{path}: cannot write: {message}")]
    Write { path: PathBuf, message: String },
}

/// File type, from the extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AssetFormat {
    Glb,
    Gltf,
    Obj,
}

impl AssetFormat {
    pub fn of(path: &Path) -> Option<Self> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "glb" => Some(AssetFormat::Glb),
            "gltf" => Some(AssetFormat::Gltf),
            "obj" => Some(AssetFormat::Obj),
            _ => None,
        }
    }
}

/// The raw file content needed to write it back unchanged but for the UVs.
#[derive(Debug, Clone)]
pub enum Container {
    Gltf {
        /// The glTF JSON exactly as read (key order kept).
        json: serde_json::Value,
        /// The GLB BIN chunk.
        bin: Option<Vec<u8>>,
        /// The GLB's other chunks (type, data), written back as read.
        others: Vec<(u32, Vec<u8>)>,
    },
    Obj {
        /// The file as read: lines uvpin does not change are written back
        /// byte for byte (encoding, line endings, a byte-order mark).
        bytes: Vec<u8>,
        /// How its faces became the primitive's triangles.
        faces: std::sync::Arc<obj::ObjFaces>,
    },
}

/// The decoded base-colour texture, shared by every picture of an asset
/// (nothing without the `pictures` feature).
#[cfg(feature = "pictures")]
pub type TextureCache = std::sync::OnceLock<Option<std::sync::Arc<image::RgbaImage>>>;
#[cfg(not(feature = "pictures"))]
pub type TextureCache = ();

/// One mesh of an asset file, ready for welding.
#[derive(Debug, Clone)]
pub struct SourceAsset {
    pub path: PathBuf,
    pub format: AssetFormat,
    pub mesh_index: usize,
    pub mesh_name: Option<String>,
    /// The mesh's TRIANGLES primitives (all of them), with the existing UVs of `uv_set`.
    pub primitives: Vec<PrimitiveGeometry>,
    pub uv_set: u32,
    pub container: Container,
    /// Number of meshes in the file.
    pub n_meshes: usize,
    /// The rules it was read under (its buffers' and images' reads follow them).
    pub rules: InputRules,
    /// The base-colour texture, decoded on first use by
    /// the pictures' texture lookup and then shared by
    /// every picture of this asset (a sweep draws one per run).
    pub decoded_texture: TextureCache,
}

/// What input may be read: the size limits, and from where.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct InputRules {
    pub limits: InputLimits,
    pub scope: ReadScope,
}

/// Reads mesh `mesh` of the asset at `path` with the existing UVs of
/// TEXCOORD_`uv_set`, within `rules`.
///
/// # Errors
/// Unreadable or corrupt files (not a regular file, too large, truncated
/// GLB, bad chunk lengths, invalid JSON, indices, types or byte ranges that
/// break the glTF spec, missing buffers), a mesh that does not exist,
/// non-TRIANGLES primitives, non-finite positions, indices out of range,
/// more vertices or triangles than the limits.
pub fn load_asset(
    path: &Path,
    mesh: Option<&MeshSelector>,
    uv_set: u32,
    rules: &InputRules,
) -> Result<SourceAsset, AssetError> {
    let scanned = scan::ScanFormat::of(path);
    let format = match scanned {
        Some(_) => AssetFormat::Obj,
        None => AssetFormat::of(path).ok_or_else(|| AssetError::UnknownFormat {
            path: path.to_path_buf(),
        })?,
    };
    let mut bytes =
        read::read_regular(path, rules.limits.max_file_bytes, &rules.scope).map_err(|source| AssetError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    // A scanner format is read as the OBJ it amounts to (no UVs).
    if let Some(scan_format) = scanned {
        let mesh = scan::read(scan_format, &bytes).map_err(|source| AssetError::Scan {
            path: path.to_path_buf(),
            source,
        })?;
        bytes = mesh.to_obj().into_bytes();
    }
    match format {
        AssetFormat::Obj => {
            if let Some(MeshSelector::Index(i)) = mesh
                && *i != 0
            {
                return Err(AssetError::MeshSelection {
                    path: path.to_path_buf(),
                    message: format!("an OBJ file holds one mesh (0); mesh {i} was asked for"),
                });
            }
            let mut read = obj::read_mesh(path, &String::from_utf8_lossy(&bytes), &rules.limits, true)?;
            if uv_set > 1 || (uv_set == 1 && read.faces.vt.is_none()) {
                let has = if read.faces.vt.is_some() {
                    "its `vt`"
                } else {
                    "none: no face corner has a `vt`"
                };
                return Err(AssetError::MeshSelection {
                    path: path.to_path_buf(),
                    message: format!(
                        "an OBJ file holds one UV set ({has}; uv_set 0, and uv_set 1 writes a new set \
                         beside a `vt` as glTF); uv_set {uv_set} was asked for"
                    ),
                });
            }
            if uv_set == 1 {
                // A new set beside the `vt` (which stays set 0 of a glTF
                // output): it holds nothing yet.
                read.primitive.uvs = None;
            }
            Ok(SourceAsset {
                path: path.to_path_buf(),
                format,
                mesh_index: 0,
                mesh_name: None,
                primitives: vec![read.primitive],
                uv_set,
                container: Container::Obj {
                    bytes,
                    faces: std::sync::Arc::new(read.faces),
                },
                n_meshes: 1,
                rules: rules.clone(),
                decoded_texture: TextureCache::default(),
            })
        }
        AssetFormat::Glb | AssetFormat::Gltf => gltf_file::load(path, format, &bytes, mesh, uv_set, rules),
    }
}

/// Reads an OBJ file with its texture coordinates, for checking them: the
/// asset (one vertex per distinct `v`/`vt` pair) and the `vt` values as
/// stored (v up), or `None` when its faces have none.
///
/// # Errors
/// As [`load_asset`].
pub fn load_obj_with_tex_coords(
    path: &Path,
    rules: &InputRules,
) -> Result<(SourceAsset, Option<obj::TexCoords>), AssetError> {
    let bytes =
        read::read_regular(path, rules.limits.max_file_bytes, &rules.scope).map_err(|source| AssetError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    let read = obj::read_mesh(path, &String::from_utf8_lossy(&bytes), &rules.limits, true)?;
    let asset = SourceAsset {
        path: path.to_path_buf(),
        format: AssetFormat::Obj,
        mesh_index: 0,
        mesh_name: None,
        primitives: vec![read.primitive],
        uv_set: 0,
        container: Container::Obj {
            bytes,
            faces: std::sync::Arc::new(read.faces),
        },
        n_meshes: 1,
        rules: rules.clone(),
        decoded_texture: TextureCache::default(),
    };
    Ok((asset, read.tex_coords))
}

impl SourceAsset {
    /// Every file this asset was read from: the asset itself, then the
    /// external buffers of a .gltf.
    pub fn files(&self) -> Vec<PathBuf> {
        let mut files = vec![self.path.clone()];
        if let Container::Gltf { json, .. } = &self.container {
            let base = self.path.parent().unwrap_or(Path::new("."));
            files.extend(gltf_file::external_buffer_files(json, base));
        }
        files
    }

    /// Whether any primitive has UVs in the set read (an atlas there).
    pub fn has_uvs(&self) -> bool {
        self.primitives.iter().any(|p| p.uvs.is_some())
    }

    /// The same asset with no UVs in its set: laid out afresh, the whole
    /// mesh is unwrapped and the atlas there written over.
    pub fn without_uvs(&self) -> SourceAsset {
        let mut asset = self.clone();
        asset.primitives.iter_mut().for_each(|p| p.uvs = None);
        asset
    }

    /// An in-memory asset holding `mesh` as one primitive (f32 positions), for
    /// the library API; it cannot be written back as a file.
    pub fn from_mesh(mesh: &crate::mesh::TriMesh) -> Self {
        SourceAsset {
            path: PathBuf::from("<memory>"),
            format: AssetFormat::Glb,
            mesh_index: 0,
            mesh_name: None,
            primitives: vec![PrimitiveGeometry {
                index: 0,
                positions: mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect(),
                indices: mesh.triangles.iter().flatten().copied().collect(),
                uvs: None,
            }],
            uv_set: 0,
            container: Container::Gltf {
                json: serde_json::Value::Null,
                bin: None,
                others: Vec::new(),
            },
            n_meshes: 1,
            rules: InputRules::default(),
            decoded_texture: TextureCache::default(),
        }
    }
}

/// A content hash (64-bit, for change detection only).
pub fn content_hash(bytes: &[u8]) -> u64 {
    use std::hash::Hasher;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    h.write_usize(bytes.len());
    h.write(bytes);
    h.finish()
}
