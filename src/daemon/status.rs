//! The status file: per constraint file, its last status, residuals, flips,
//! time and last error, as JSON a painter plug-in or a script can poll. It is
//! rewritten atomically after every change.

use crate::report::Report;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The state of one constraint file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FileState {
    /// A solve of the current content is running.
    Solving,
    /// The last solve reached every constraint; its output is written.
    Reached,
    /// The last solve was fold-free but left some constraints short; written.
    Partial,
    /// The current content (or its asset) has an error; the last good output is kept.
    Error,
    /// The constraint file was removed; its last output is kept.
    Removed,
}

impl FileState {
    /// The state a finished solve of `status` leaves.
    pub fn of(status: crate::report::Status) -> Self {
        match status {
            crate::report::Status::Reached => FileState::Reached,
            crate::report::Status::Partial => FileState::Partial,
            crate::report::Status::Error => FileState::Error,
        }
    }
}

/// One constraint's residual in the last solve.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualEntry {
    pub index: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    pub vertex: u32,
    pub residual: f64,
    pub reached: bool,
}

/// The last solve that was written.
#[derive(Debug, Clone, Serialize)]
pub struct LastSolve {
    /// `reached` or `partial`.
    pub status: crate::report::Status,
    /// When it was written (Unix milliseconds).
    pub at_ms: u64,
    pub output: Option<String>,
    /// Solve time, milliseconds.
    pub time_ms: f64,
    pub max_residual: f64,
    pub residuals: Vec<ResidualEntry>,
    /// Flipped and zero-area triangles as written (always 0).
    pub flipped: usize,
    pub zero_area: usize,
    pub stretch_l2: f64,
}

impl LastSolve {
    pub fn from_report(report: &Report) -> Self {
        LastSolve {
            status: report.status,
            at_ms: super::log::unix_ms(),
            output: report.output.clone(),
            time_ms: report.total_ms,
            max_residual: report.max_residual,
            residuals: report
                .constraints
                .iter()
                .map(|c| ResidualEntry {
                    index: c.index,
                    label: c.label.clone(),
                    vertex: c.vertex,
                    residual: c.residual,
                    reached: c.reached,
                })
                .collect(),
            flipped: report.orientation.flipped,
            zero_area: report.orientation.zero_area,
            stretch_l2: report.stretch_final.l2,
        }
    }
}

/// One constraint file's entry.
#[derive(Debug, Clone, Serialize)]
pub struct FileStatus {
    pub state: FileState,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub asset: Option<String>,
    /// The error of the current content, if any.
    pub last_error: Option<String>,
    /// The last written solve (kept through later errors).
    pub last_solve: Option<LastSolve>,
}

/// The whole status file.
#[derive(Debug, Clone, Serialize)]
pub struct StatusBoard {
    /// Format version of this file.
    pub version: u32,
    /// When it was last written (Unix milliseconds).
    pub updated_ms: u64,
    /// The daemon's process id.
    pub pid: u32,
    /// Per constraint file (as named on the command line or found in a watched folder).
    pub files: BTreeMap<String, FileStatus>,
    #[serde(skip)]
    pub path: PathBuf,
    #[serde(skip)]
    pub dirty: bool,
}

impl StatusBoard {
    pub fn new(path: PathBuf) -> Self {
        StatusBoard {
            version: 1,
            updated_ms: 0,
            pid: std::process::id(),
            files: BTreeMap::new(),
            path,
            dirty: true,
        }
    }

    /// The entry of `file`, created as `Solving` if new.
    pub fn entry(&mut self, file: &str) -> &mut FileStatus {
        self.dirty = true;
        self.files.entry(file.to_string()).or_insert(FileStatus {
            state: FileState::Solving,
            asset: None,
            last_error: None,
            last_solve: None,
        })
    }

    /// Writes the file atomically if anything changed since the last write.
    ///
    /// # Errors
    /// The file system's.
    pub fn write_if_dirty(&mut self) -> std::io::Result<()> {
        if !self.dirty {
            return Ok(());
        }
        self.updated_ms = super::log::unix_ms();
        let text = serde_json::to_vec_pretty(self).map_err(std::io::Error::other)?;
        crate::io::atomic::write_atomically(&self.path, &text).map_err(|e| std::io::Error::other(e.message))?;
        self.dirty = false;
        Ok(())
    }
}
