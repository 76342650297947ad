//! Plain bookkeeping of the daemon: watched roots, where outputs go, content
//! hashes, and the asset cache that lets a constraint edit skip re-reading
//! and re-welding its asset.

use crate::config::OutputMode;
use crate::io::MeshSelector;
use crate::io::{InputRules, ReadError, ReadScope, SourceAsset};
use std::collections::HashMap;
use std::hash::Hasher;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A content hash (64-bit, for change detection only).
pub fn content_hash(bytes: &[u8]) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    h.write_usize(bytes.len());
    h.write(bytes);
    h.finish()
}

pub use crate::io::paths::normalize;

/// A path as shown in logs and the status file: relative to `cwd` when
/// inside it, control characters (a newline in a file name) escaped so a
/// name cannot forge a log line.
pub fn display(path: &Path, cwd: &Path) -> String {
    let shown = path.strip_prefix(cwd).unwrap_or(path).display().to_string();
    if shown.chars().any(char::is_control) {
        shown.chars().flat_map(char::escape_debug).collect()
    } else {
        shown
    }
}

/// One watched path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WatchRoot {
    /// Absolute, normalised.
    pub path: PathBuf,
    /// A single constraint file rather than a folder.
    pub single_file: bool,
}

impl WatchRoot {
    /// The folder that holds the root's constraint files.
    pub fn folder(&self) -> &Path {
        if self.single_file {
            self.path.parent().unwrap_or(Path::new("/"))
        } else {
            &self.path
        }
    }

    /// Whether `file` belongs to this root.
    pub fn contains(&self, file: &Path) -> bool {
        if self.single_file {
            file == self.path
        } else {
            file.starts_with(&self.path)
        }
    }
}

/// The root a constraint file belongs to (the innermost, if nested).
pub fn root_of<'a>(roots: &'a [WatchRoot], file: &Path) -> Option<&'a WatchRoot> {
    roots
        .iter()
        .filter(|r| r.contains(file))
        .max_by_key(|r| r.folder().components().count())
}

/// Where the solve of `constraint_file` (in `root`) is written, for an asset
/// at `asset_path`: in `Folder` mode the constraint file's path relative to
/// its root with the suffix replaced by the asset's extension; in `InPlace`
/// mode the asset itself.
pub fn output_path(
    mode: &OutputMode,
    root: &WatchRoot,
    constraint_file: &Path,
    suffix: &str,
    asset_path: &Path,
    cwd: &Path,
) -> PathBuf {
    match mode {
        OutputMode::InPlace => asset_path.to_path_buf(),
        OutputMode::Folder(dir) => {
            let dir = if dir.is_absolute() { dir.clone() } else { cwd.join(dir) };
            let relative = constraint_file
                .strip_prefix(root.folder())
                .unwrap_or(Path::new(constraint_file.file_name().unwrap_or_default()));
            let name = relative.file_name().and_then(|n| n.to_str()).unwrap_or("output");
            let stem = name.strip_suffix(suffix).unwrap_or(name);
            let ext = asset_path.extension().and_then(|e| e.to_str()).unwrap_or("glb");
            let file = format!("{stem}.{}", ext.to_ascii_lowercase());
            match relative.parent() {
                Some(parent) => dir.join(parent).join(file),
                None => dir.join(file),
            }
        }
    }
}

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

    /// Returns the asset at `path` with `selection`, from the cache or read
    /// now (hash taken before reading, so a write racing the read is seen as
    /// a later change).
    ///
    /// # Errors
    /// A removed asset, and [`crate::io::load_asset`]'s errors.
    pub fn load(
        &mut self,
        path: &Path,
        selection: &AssetSelection,
        rules: &InputRules,
    ) -> Result<Arc<SourceAsset>, crate::io::AssetError> {
        if let Some(cached) = self.assets.get(path) {
            if cached.missing {
                return Err(crate::io::AssetError::Read {
                    path: path.to_path_buf(),
                    source: ReadError::Io(std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        "the asset was removed",
                    )),
                });
            }
            if let Some(asset) = cached.get(selection) {
                return Ok(asset);
            }
        }
        // Within the rules' scope and limit: an asset outside the watched
        // folders is refused before a byte of it is read.
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
        let files = asset.files();
        let hash = combined_hash(main_hash, &files[1..]);
        let entry = self.assets.entry(path.to_path_buf()).or_insert_with(|| CachedAsset {
            hash,
            files: files.clone(),
            missing: false,
            loaded: Vec::new(),
        });
        if entry.hash != hash {
            // Read again after a change: older selections are stale.
            *entry = CachedAsset {
                hash,
                files,
                missing: false,
                loaded: Vec::new(),
            };
        }
        entry.loaded.push((selection.clone(), asset.clone()));
        Ok(asset)
    }

    /// The combined hash of an asset's files as they are now, in the same
    /// form as [`CachedAsset::hash`], read only within `scope`.
    pub fn current_hash(files: &[PathBuf], scope: &ReadScope) -> Result<u64, ReadError> {
        let (main, buffers) = files
            .split_first()
            .ok_or_else(|| ReadError::Io(std::io::Error::other("no files")))?;
        let main_hash = content_hash(&read_for_hash(main, scope)?);
        Ok(combined_hash(main_hash, buffers))
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_mirror_constraint_names_under_the_output_folder() {
        let cwd = Path::new("/work");
        let root = WatchRoot {
            path: "/work/assets".into(),
            single_file: false,
        };
        let out = output_path(
            &OutputMode::Folder("out".into()),
            &root,
            Path::new("/work/assets/heads/bob.uvpin.ron"),
            ".uvpin.ron",
            Path::new("/work/assets/meshes/head.GLTF"),
            cwd,
        );
        assert_eq!(out, Path::new("/work/out/heads/bob.gltf"));
        let single = WatchRoot {
            path: "/work/assets/bob.uvpin.ron".into(),
            single_file: true,
        };
        let out = output_path(
            &OutputMode::Folder("/tmp/o".into()),
            &single,
            Path::new("/work/assets/bob.uvpin.ron"),
            ".uvpin.ron",
            Path::new("/work/assets/head.glb"),
            cwd,
        );
        assert_eq!(out, Path::new("/tmp/o/bob.glb"));
        let in_place = output_path(
            &OutputMode::InPlace,
            &root,
            Path::new("/work/assets/bob.uvpin.ron"),
            ".uvpin.ron",
            Path::new("/work/assets/head.glb"),
            cwd,
        );
        assert_eq!(in_place, Path::new("/work/assets/head.glb"));
    }

    #[test]
    fn normalize_cleans_missing_paths_and_roots_pick_the_innermost() {
        let cwd = std::env::temp_dir().canonicalize().unwrap();
        let p = normalize(Path::new("a/./b/../c/no-such.glb"), &cwd);
        assert_eq!(p, cwd.join("a/c/no-such.glb"));
        let roots = vec![
            WatchRoot {
                path: "/w".into(),
                single_file: false,
            },
            WatchRoot {
                path: "/w/inner".into(),
                single_file: false,
            },
        ];
        assert_eq!(
            root_of(&roots, Path::new("/w/inner/x.uvpin.ron")).unwrap().path,
            Path::new("/w/inner")
        );
        assert!(root_of(&roots, Path::new("/elsewhere/x.uvpin.ron")).is_none());
    }
}
