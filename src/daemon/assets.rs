//! The asset cache: what a constraint edit reuses instead of reading and
//! welding its asset again, and the content hashes that tell a real change
//! from a touch, a re-creation or the daemon's own write.

use crate::io::{InputRules, MeshSelector, ReadError, ReadScope, SourceAsset, content_hash};
use std::collections::HashMap;
use std::hash::Hasher;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Which mesh and UV set of an asset file was read.
#[derive(Debug, Clone, PartialEq)]
pub struct AssetSelection {
    pub mesh: Option<MeshSelector>,
    pub uv_set: u32,
}

/// One asset file as last read.
#[derive(Debug, Clone)]
pub struct CachedAsset {
    /// Hash of every file of the asset (see [`SourceAsset::files`]).
    pub hash: u64,
    pub files: Vec<PathBuf>,
    /// The file was removed; the cache is kept to tell an identical
    /// re-creation from a changed one.
    pub missing: bool,
    /// Loaded selections (usually one).
    pub loaded: Vec<(AssetSelection, Arc<SourceAsset>)>,
}

impl CachedAsset {
    pub fn get(&self, selection: &AssetSelection) -> Option<Arc<SourceAsset>> {
        self.loaded.iter().find(|(s, _)| s == selection).map(|(_, a)| a.clone())
    }
}

/// Asset files by path.
#[derive(Debug, Default)]
pub struct AssetCache {
    pub assets: HashMap<PathBuf, CachedAsset>,
}

impl AssetCache {
    /// Paths of cached assets that consist of (among others) `file`.
    pub fn assets_using(&self, file: &Path) -> Vec<PathBuf> {
        let mut out: Vec<PathBuf> = self
            .assets
            .iter()
            .filter(|(_, a)| a.files.iter().any(|f| f == file))
            .map(|(p, _)| p.clone())
            .collect();
        out.sort();
        out
    }

    /// The asset at `path` with `selection`, if cached.
    pub fn lookup(&self, path: &Path, selection: &AssetSelection) -> Lookup {
        match self.assets.get(path) {
            Some(cached) if cached.missing => Lookup::Missing,
            Some(cached) => cached.get(selection).map_or(Lookup::Absent, Lookup::Hit),
            None => Lookup::Absent,
        }
    }

    /// Keeps `read` (the asset at `path` with `selection`); a new hash
    /// drops the selections read before it.
    pub fn insert(&mut self, path: &Path, selection: &AssetSelection, read: ReadAsset) {
        let files = read.asset.files();
        let entry = self.assets.entry(path.to_path_buf()).or_insert_with(|| CachedAsset {
            hash: read.hash,
            files: files.clone(),
            missing: false,
            loaded: Vec::new(),
        });
        if entry.hash != read.hash {
            *entry = CachedAsset {
                hash: read.hash,
                files,
                missing: false,
                loaded: Vec::new(),
            };
        }
        entry.loaded.push((selection.clone(), read.asset));
    }
}

/// What the cache holds of an asset.
#[derive(Debug, Clone)]
pub enum Lookup {
    /// Read before, with this selection.
    Hit(Arc<SourceAsset>),
    /// Not read with this selection (or never).
    Absent,
    /// Removed from the disk since it was read.
    Missing,
}

/// An asset as read, with the hash of all its files.
#[derive(Debug, Clone)]
pub struct ReadAsset {
    pub asset: Arc<SourceAsset>,
    pub hash: u64,
}

/// Reads the asset at `path` with `selection` within `rules` (the hash is
/// taken before reading, so a write racing the read is seen as a later change).
///
/// # Errors
/// [`crate::io::load_asset`]'s errors; an asset outside the scope is
/// refused before a byte of it is read.
pub fn read_asset(
    path: &Path,
    selection: &AssetSelection,
    rules: &InputRules,
) -> Result<ReadAsset, crate::io::AssetError> {
    let main_hash = read_for_hash(path, &rules.scope)
        .map(|b| content_hash(&b))
        .map_err(|source| crate::io::AssetError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    let asset = Arc::new(crate::io::load_asset(
        path,
        selection.mesh.as_ref(),
        selection.uv_set,
        rules,
    )?);
    let hash = combined_hash(main_hash, &asset.files()[1..]);
    Ok(ReadAsset { asset, hash })
}

/// The combined hash of an asset's files as they are now, in the same form
/// as [`CachedAsset::hash`], read only within `scope`.
///
/// # Errors
/// The main file cannot be read.
pub fn current_hash(files: &[PathBuf], scope: &ReadScope) -> Result<u64, ReadError> {
    let (main, buffers) = files
        .split_first()
        .ok_or_else(|| ReadError::Io(std::io::Error::other("no files")))?;
    let main_hash = content_hash(&read_for_hash(main, scope)?);
    Ok(combined_hash(main_hash, buffers))
}

/// A file's bytes for its content hash: only a regular file inside `scope`
/// (checked before reading), within the default size limit (a FIFO or a
/// device is an error, never a blocking read).
fn read_for_hash(path: &Path, scope: &ReadScope) -> Result<Vec<u8>, ReadError> {
    crate::io::read::read_regular(path, crate::io::InputLimits::DEFAULT.max_file_bytes, scope)
}

/// The hash of an asset: its main file's hash, then each buffer file's
/// content hash (0 for a buffer that cannot be read).
fn combined_hash(main_hash: u64, buffers: &[PathBuf]) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    h.write_u64(main_hash);
    for f in buffers {
        // Buffers were found through the asset (already within its scope).
        h.write_u64(
            read_for_hash(f, &ReadScope::Anywhere)
                .map(|b| content_hash(&b))
                .unwrap_or(0),
        );
    }
    h.finish()
}
