//! A sweep file read and its grid laid out: what every way of running a sweep
//! shares (threads on one machine, shards of a job array, Ray tasks).

use super::file::{self, SweepFile};
use super::{Run, SweepError, grid};
use std::path::{Path, PathBuf};

/// The sweep file, the constraint files its patterns name, the grid of runs
/// and the output folder.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    /// The sweep file.
    pub path: PathBuf,
    pub sweep: SweepFile,
    /// The constraint files, each once, in pattern order.
    pub files: Vec<PathBuf>,
    /// The same files as the rows name them (relative to the sweep's folder).
    pub names: Vec<String>,
    /// Every run of the grid, in row order.
    pub runs: Vec<Run>,
    /// The output folder (relative to the working folder where it is inside it).
    pub output: PathBuf,
}

impl SweepPlan {
    /// Reads `sweep_path` and lays out its grid; solves nothing.
    ///
    /// # Errors
    /// The sweep file (unreadable, RON errors, a pattern matching nothing, a
    /// grid too large).
    pub fn open(sweep_path: &Path) -> Result<Self, SweepError> {
        let sweep = SweepFile::load(sweep_path)?;
        // A bare file name's folder is the current one.
        let base = sweep_path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let files = expand_files(&sweep, sweep_path, base)?;
        let names: Vec<String> = files
            .iter()
            .map(|f| f.strip_prefix(base).unwrap_or(f).display().to_string())
            .collect();
        let output = output_folder(base, &sweep.output);
        let runs = grid(&sweep, &names);
        check_grid(&runs, &sweep, sweep_path)?;
        Ok(SweepPlan {
            path: sweep_path.to_path_buf(),
            sweep,
            files,
            names,
            runs,
            output,
        })
    }

    /// Where the thumbnails of runs written into `folder` go (`None`: the
    /// sweep draws none).
    pub fn thumbs_in(&self, folder: &Path) -> Option<PathBuf> {
        self.sweep.thumbnails.then(|| folder.join("thumbs"))
    }
}

/// The grid and its contact sheet stay within [`file::MAX_RUNS`] and
/// [`file::MAX_SHEET_PIXELS`].
fn check_grid(runs: &[Run], sweep: &SweepFile, sweep_path: &Path) -> Result<(), SweepError> {
    let too_large = |size: file::SizeError| SweepError::TooLarge {
        path: sweep_path.to_path_buf(),
        size,
    };
    if runs.len() > file::MAX_RUNS {
        return Err(too_large(file::SizeError::Runs { runs: runs.len() }));
    }
    let pixels = runs.len() as u64 * u64::from(sweep.thumbnail_size).pow(2);
    if sweep.thumbnails && pixels > file::MAX_SHEET_PIXELS {
        return Err(too_large(file::SizeError::Sheet {
            runs: runs.len(),
            size: sweep.thumbnail_size,
            pixels,
        }));
    }
    Ok(())
}

/// The constraint files the sweep's patterns name, each once.
fn expand_files(sweep: &SweepFile, sweep_path: &Path, base: &Path) -> Result<Vec<PathBuf>, SweepError> {
    let mut files: Vec<PathBuf> = Vec::new();
    for pattern in &sweep.constraints {
        let found = file::expand(pattern, base);
        if found.is_empty() {
            return Err(SweepError::NoFiles {
                sweep: sweep_path.to_path_buf(),
                pattern: pattern.clone(),
            });
        }
        for f in found {
            if !files.contains(&f) {
                files.push(f);
            }
        }
    }
    Ok(files)
}

/// The output folder, relative to the working folder where it is inside it.
fn output_folder(base: &Path, output: &Path) -> PathBuf {
    let cwd = std::env::current_dir().unwrap_or_default();
    let output = crate::io::paths::normalize(&base.join(output), &cwd);
    output.strip_prefix(&cwd).map(Path::to_path_buf).unwrap_or(output)
}
