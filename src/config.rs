//! `config/uvpin.ron`: defaults shared by every constraint file.

use crate::options::SolverOptions;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The configuration file. Every field is optional.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Solver options for constraint files without a `solver` section.
    pub solver: SolverOptions,
}

#[derive(Debug, Error)]
pub enum ConfigError {
    #[error("{path}: cannot read the configuration: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error(transparent)]
    Syntax(#[from] crate::ron_file::RonSyntaxError),
}

impl Config {
    /// Reads a configuration file.
    ///
    /// # Errors
    /// Unreadable file; RON errors and unknown fields, with line:column.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.into(),
            source,
        })?;
        Ok(crate::ron_file::parse_ron(path, &text)?)
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
