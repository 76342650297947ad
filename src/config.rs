//! `config/uvpin.ron`: defaults shared by every constraint file.

use crate::options::SolverOptions;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The configuration file. Every field is optional.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// `uvpin watch`: what to watch, where outputs go, debounce, log format.
    pub watch: WatchConfig,
    /// Solver options for constraint files without a `solver` section.
    pub solver: SolverOptions,
    /// How much input is accepted: file sizes, vertices, triangles.
    pub limits: crate::io::InputLimits,
}

/// Where `uvpin watch` writes solved assets.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum OutputMode {
    /// Into this folder, mirroring the constraint files' names relative to
    /// their watched folder: `assets/heads/bob.uvpin.ron` solving `bob.glb`
    /// gives `out/heads/bob.glb` (default `Folder("out")`).
    Folder(PathBuf),
    /// Back into the watched asset itself (the UV set named by the constraint
    /// file is replaced; everything else in the file is kept).
    InPlace,
}

/// Log line format of `uvpin watch`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum LogFormat {
    /// One readable line per event (default).
    #[default]
    Human,
    /// One JSON object per line (`ts`, `level`, `event`, `file`, ...).
    Json,
}

/// The `watch` section of `config/uvpin.ron`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WatchConfig {
    /// Folders (watched recursively) and single constraint files to watch;
    /// relative paths are relative to the working directory (default `["assets"]`).
    pub paths: Vec<PathBuf>,
    /// Where outputs go (default `Folder("out")`).
    pub output: OutputMode,
    /// The status file (default `uvpin-status.json` in the output folder, or in
    /// the working directory in `InPlace` mode).
    pub status_file: Option<PathBuf>,
    /// Debounce window in milliseconds: events of one path are gathered this
    /// long, because editors save in several writes (default 100).
    pub debounce_ms: u64,
    /// Log format (default `Human`).
    pub log: LogFormat,
    /// Constraint files are the files whose names end with this (default ".uvpin.ron").
    pub constraint_suffix: String,
    /// Pictures beside each output, refreshed with it: `<name>.uv.png` (the
    /// layout) and `<name>.render.png` (the mesh with a checker) (default true).
    pub previews: bool,
    /// Their size in pixels (default 512).
    pub preview_size: u32,
    /// Folders outside the watched ones that assets, buffers and images may
    /// be read from (default none: only the watched folders).
    pub allow_paths: Vec<PathBuf>,
}

impl Default for WatchConfig {
    fn default() -> Self {
        WatchConfig {
            paths: vec![PathBuf::from("assets")],
            output: OutputMode::Folder(PathBuf::from("out")),
            status_file: None,
            debounce_ms: 100,
            log: LogFormat::Human,
            constraint_suffix: ".uvpin.ron".into(),
            previews: true,
            preview_size: 512,
            allow_paths: Vec::new(),
        }
    }
}

impl WatchConfig {
    /// The status file's path.
    pub fn status_path(&self) -> PathBuf {
        match (&self.status_file, &self.output) {
            (Some(p), _) => p.clone(),
            (None, OutputMode::Folder(dir)) => dir.join("uvpin-status.json"),
            (None, OutputMode::InPlace) => PathBuf::from("uvpin-status.json"),
        }
    }
}

#[derive(Debug, Error)]
pub enum ConfigError {
    #[error("{path}: cannot read the configuration: {source}")]
    Read {
        path: PathBuf,
        source: crate::io::ReadError,
    },
    #[error(transparent)]
    Syntax(#[from] crate::ron_file::RonSyntaxError),
    #[error("{path}: {source}")]
    Option {
        path: PathBuf,
        source: crate::options::OptionError,
    },
}

impl Config {
    /// Reads a configuration file.
    ///
    /// # Errors
    /// Unreadable file; RON errors and unknown fields, with line:column.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let limit = crate::io::InputLimits::DEFAULT.max_text_bytes;
        let bytes = crate::io::read::read_regular(path, limit, &crate::io::ReadScope::Anywhere).map_err(|source| {
            ConfigError::Read {
                path: path.into(),
                source,
            }
        })?;
        let text = String::from_utf8_lossy(&bytes);
        let config: Config = crate::ron_file::parse_ron(path, &text)?;
        config.solver.check().map_err(|source| ConfigError::Option {
            path: path.into(),
            source,
        })?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_config_documents_the_built_in_defaults() {
        let shipped = Config::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("config/uvpin.ron")).unwrap();
        assert_eq!(shipped, Config::default());
    }
}
