//! Where things are: watched roots, where outputs go, and how paths are
//! shown in the log.

use crate::config::OutputMode;
use std::path::{Path, PathBuf};

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
