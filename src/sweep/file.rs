//! The sweep file (`uvpin sweep SWEEP.ron`): which constraint files, which
//! axes to vary, where the results go.

use crate::options::SolverOptions;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Blend of every target between its step-1 position (0) and the requested one (1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Blend {
    pub from: f64,
    pub to: f64,
    /// Number of values, `from` and `to` included (1: just `to`).
    pub steps: u32,
}

impl Blend {
    pub fn values(&self) -> Vec<f64> {
        match self.steps {
            0 => Vec::new(),
            1 => vec![self.to],
            n => (0..n)
                .map(|k| self.from + (self.to - self.from) * k as f64 / (n - 1) as f64)
                .collect(),
        }
    }
}

/// Seeded random jitter of the targets (interior constraints only).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Jitter {
    pub seed: u64,
    /// Each coordinate moves uniformly within ± this (texture units); the
    /// result is clamped to the unit square.
    pub amplitude: f64,
    /// Draws per blend value.
    pub samples: u32,
}

/// Corner choice of a setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum CornerChoice {
    /// As the constraint file says (default).
    #[default]
    FromFile,
    /// Ignore the file's corners: arc-length quarters, snapped to ear tips.
    Auto,
}

/// One solver setting to compare.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Setting {
    /// Shown in rows, the summary and the contact sheet.
    pub name: String,
    /// Solver options of this setting; fields not given take their defaults
    /// (not the constraint file's). Without it the constraint file's own
    /// options (or the defaults) are used.
    #[serde(default)]
    pub solver: Option<SolverOptions>,
    #[serde(default)]
    pub corners: CornerChoice,
}

/// The sweep file. Paths are relative to the sweep file's folder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepFile {
    /// Constraint files, or patterns with `*` and `?` in the file name and
    /// `**` for any depth of folders.
    pub constraints: Vec<String>,
    /// Folder for runs.csv, runs.jsonl, summary.md, thumbs/ and contact_sheet.png.
    pub output: PathBuf,
    /// Default: just the requested targets (blend 1).
    #[serde(default)]
    pub blend: Option<Blend>,
    #[serde(default)]
    pub jitter: Option<Jitter>,
    /// Default: one setting, "default" (the constraint files' own options).
    #[serde(default)]
    pub settings: Vec<Setting>,
    /// Per-run layout thumbnails and a contact sheet (default true).
    #[serde(default = "yes")]
    pub thumbnails: bool,
    /// Thumbnail size in pixels (default 160).
    #[serde(default = "thumbnail_size")]
    pub thumbnail_size: u32,
}

fn yes() -> bool {
    true
}

fn thumbnail_size() -> u32 {
    160
}

/// Blend steps, jitter samples or settings of one sweep at most.
pub const MAX_AXIS: usize = 1000;
/// Thumbnail size at most, in pixels.
pub const MAX_THUMBNAIL: u32 = 1024;
/// Runs of one sweep at most.
pub const MAX_RUNS: usize = 100_000;
/// Pixels of the contact sheet at most (its runs × thumbnail area).
pub const MAX_SHEET_PIXELS: u64 = 64_000_000;

/// Which of a sweep's sizes is past its bound.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SizeError {
    #[error("{field}: {n} is more than {MAX_AXIS}")]
    Axis { field: &'static str, n: usize },
    #[error("thumbnail_size: {size} is outside 16..={MAX_THUMBNAIL}")]
    Thumbnail { size: u32 },
    #[error("{runs} runs, more than {MAX_RUNS}")]
    Runs { runs: usize },
    #[error("{runs} thumbnails of {size} px make a contact sheet of {pixels} pixels, more than {MAX_SHEET_PIXELS}")]
    Sheet { runs: usize, size: u32, pixels: u64 },
}

impl SweepFile {
    /// Reads a sweep file.
    ///
    /// # Errors
    /// Unreadable file; RON errors with line:column.
    pub fn load(path: &Path) -> Result<Self, super::SweepError> {
        let limit = crate::io::InputLimits::DEFAULT.max_text_bytes;
        let bytes = crate::io::read::read_regular(path, limit, &crate::io::ReadScope::Anywhere).map_err(|source| {
            super::SweepError::Read {
                path: path.to_path_buf(),
                source,
            }
        })?;
        let sweep: SweepFile = crate::ron_file::parse_ron(path, &String::from_utf8_lossy(&bytes))?;
        sweep.check_sizes().map_err(|size| super::SweepError::TooLarge {
            path: path.to_path_buf(),
            size,
        })?;
        for setting in &sweep.settings {
            if let Some(Err(source)) = setting.solver.as_ref().map(SolverOptions::check) {
                return Err(super::SweepError::Option {
                    path: path.to_path_buf(),
                    setting: setting.name.clone(),
                    source,
                });
            }
        }
        Ok(sweep)
    }

    /// The grid's sizes are bounded: blends and jitter samples at most
    /// [`MAX_AXIS`] each, thumbnails 16 to [`MAX_THUMBNAIL`] pixels.
    fn check_sizes(&self) -> Result<(), SizeError> {
        let axes = [
            ("blend.steps", self.blend.map_or(0, |b| b.steps as usize)),
            ("jitter.samples", self.jitter.map_or(0, |j| j.samples as usize)),
            ("settings", self.settings.len()),
        ];
        if let Some(&(field, n)) = axes.iter().find(|(_, n)| *n > MAX_AXIS) {
            return Err(SizeError::Axis { field, n });
        }
        if !(16..=MAX_THUMBNAIL).contains(&self.thumbnail_size) {
            return Err(SizeError::Thumbnail {
                size: self.thumbnail_size,
            });
        }
        Ok(())
    }

    /// The blend values (default `[1.0]`).
    pub fn blend_values(&self) -> Vec<f64> {
        self.blend.map_or_else(|| vec![1.0], |b| b.values())
    }

    /// The settings (default one, "default").
    pub fn settings(&self) -> Vec<Setting> {
        if self.settings.is_empty() {
            vec![Setting {
                name: "default".into(),
                solver: None,
                corners: CornerChoice::FromFile,
            }]
        } else {
            self.settings.clone()
        }
    }
}

/// Whether `name` matches `pattern` (`*` any run, `?` one character).
pub fn wildcard_match(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    let (mut pi, mut ni) = (0, 0);
    let (mut star, mut mark) = (None, 0);
    while ni < n.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == n[ni]) {
            pi += 1;
            ni += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some(pi);
            mark = ni;
            pi += 1;
        } else if let Some(s) = star {
            pi = s + 1;
            mark += 1;
            ni = mark;
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

/// The files matching `pattern` (relative to `base`), sorted. A pattern
/// without wildcards names one file, which must exist.
pub fn expand(pattern: &str, base: &Path) -> Vec<PathBuf> {
    let full = base.join(pattern);
    let components: Vec<String> = full
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let mut found = Vec::new();
    let mut start = PathBuf::new();
    let mut rest = components.as_slice();
    while let Some((first, tail)) = rest.split_first() {
        if first.contains(['*', '?']) {
            break;
        }
        start.push(first);
        rest = tail;
    }
    if start.as_os_str().is_empty() {
        start.push(".");
    }
    walk(&start, rest, &mut found);
    found.sort();
    found.dedup();
    found
}

fn walk(dir: &Path, rest: &[String], found: &mut Vec<PathBuf>) {
    let Some((first, tail)) = rest.split_first() else {
        if dir.is_file() {
            found.push(dir.to_path_buf());
        }
        return;
    };
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let mut entries: Vec<_> = entries.flatten().collect();
    entries.sort_by_key(|e| e.file_name());
    if first == "**" {
        walk(dir, tail, found);
        for e in &entries {
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                walk(&e.path(), rest, found);
            }
        }
        return;
    }
    for e in entries {
        let name = e.file_name().to_string_lossy().into_owned();
        if wildcard_match(first, &name) {
            walk(&e.path(), tail, found);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards_and_blend_values() {
        assert!(wildcard_match("*.uvpin.ron", "face.uvpin.ron"));
        assert!(wildcard_match("f?ce*", "face.uvpin.ron"));
        assert!(!wildcard_match("*.uvpin.ron", "face.glb"));
        let b = Blend {
            from: 0.0,
            to: 1.0,
            steps: 5,
        };
        assert_eq!(b.values(), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
    }
}
