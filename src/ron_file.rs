//! Parsing RON text with the options every uvpin file uses (`Option` fields
//! written without `Some`) and errors located by line and column.

use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A RON syntax or schema error (misspelt key, missing comma, wrong type).
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{path}:{line}:{column}: {message}")]
pub struct RonSyntaxError {
    pub path: PathBuf,
    pub line: usize,
    pub column: usize,
    pub message: String,
}

/// Parses `text` (from `path`, for messages) as `T`.
pub fn parse_ron<T: DeserializeOwned>(path: &Path, text: &str) -> Result<T, RonSyntaxError> {
    ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .from_str(text)
        .map_err(|e| RonSyntaxError {
            path: path.to_path_buf(),
            line: e.span.start.line,
            column: e.span.start.col,
            message: e.code.to_string(),
        })
}
