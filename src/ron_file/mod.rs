//! Parsing RON text with the options every uvpin file uses (`Option` fields
//! written without `Some`) and errors located by line and column. A UTF-8
//! byte-order mark is skipped; error messages quote at most a short,
//! escaped snippet of the file.

pub mod tokens;

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

/// Characters of a file that a message may quote.
pub const SNIPPET_CHARS: usize = 40;

/// At most [`SNIPPET_CHARS`] characters of `text`, control characters and
/// quotes escaped, in backquotes: what an error may show of a file.
pub fn snippet(text: &str) -> String {
    let mut out: String = text.chars().take(SNIPPET_CHARS).flat_map(char::escape_debug).collect();
    if text.chars().nth(SNIPPET_CHARS).is_some() {
        out.push('…');
    }
    format!("`{out}`")
}

/// A message of the RON parser made safe to show: the parts it quotes
/// from the file (between backquotes) shortened and escaped, and the whole
/// at most a few hundred characters.
fn safe_message(message: &str) -> String {
    let mut out = String::new();
    for (k, part) in message.split('`').enumerate() {
        if k % 2 == 1 {
            out += &snippet(part);
        } else {
            out.extend(part.chars().flat_map(|c| {
                if c.is_control() {
                    c.escape_debug().collect::<Vec<_>>()
                } else {
                    vec![c]
                }
            }));
        }
    }
    if out.chars().count() > 300 {
        out = out.chars().take(300).collect::<String>() + "…";
    }
    out
}

/// Parses `text` (from `path`, for messages) as `T`.
///
/// # Errors
/// A [`RonSyntaxError`] at the first problem.
pub fn parse_ron<T: DeserializeOwned>(path: &Path, text: &str) -> Result<T, RonSyntaxError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .from_str(text)
        .map_err(|e| RonSyntaxError {
            path: path.to_path_buf(),
            line: e.span.start.line,
            column: e.span.start.col,
            message: safe_message(&e.code.to_string()),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize, Debug)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct T {
        a: u32,
    }

    #[test]
    fn a_bom_is_skipped_and_quoted_file_content_is_short() {
        let t: T = parse_ron(Path::new("f.ron"), "\u{feff}(a: 3)").unwrap();
        assert_eq!(t.a, 3);
        let secret = format!("(a: 1, {}: 2)", "x".repeat(10_000));
        let e = parse_ron::<T>(Path::new("f.ron"), &secret).unwrap_err();
        assert!(e.message.len() < 400, "{}", e.message);
        assert!(e.message.contains('…'), "{}", e.message);
        assert_eq!(snippet("a\nb"), "`a\\nb`");
    }
}
