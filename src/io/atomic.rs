//! Atomic file output: every file is written to a temporary file beside its
//! target, flushed to disk, then renamed over the target. Readers see the
//! old file or the new one, never a half-written one. [`Staged`] does this
//! for several files at once (a model and its buffer, a report, pictures):
//! all temporary files first, then the renames in order, so a failure before
//! the renames replaces nothing.

use super::read::{ReadError, check_output_target};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The marker in uvpin's temporary file names: `.NAME.uvpin-PID.tmp`.
const TEMP_MARK: &str = ".uvpin-";

/// The temporary name used while writing `path` (same directory, hidden).
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}{TEMP_MARK}{}.tmp", std::process::id()))
}

/// The process id of a temporary file of uvpin's (`.NAME.uvpin-PID.tmp`).
fn temp_owner(name: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (_, pid) = rest.rsplit_once(TEMP_MARK)?;
    pid.parse().ok()
}

/// Removes uvpin's temporary files in `dir` (not recursively) whose process
/// is no longer running (what a killed run left behind); returns how many.
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let alive = |pid: u32| pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists();
    entries
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter(|e| temp_owner(&e.file_name().to_string_lossy()).is_some_and(|pid| !alive(pid)))
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
}

/// Why staged files could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct WriteError {
    pub path: PathBuf,
    pub message: String,
}

impl WriteError {
    fn new(path: &Path, message: impl std::fmt::Display) -> Self {
        WriteError {
            path: path.to_path_buf(),
            message: message.to_string(),
        }
    }
}

/// Files to replace together, renamed into place in the order they were added.
#[derive(Debug, Default)]
pub struct Staged {
    files: Vec<(PathBuf, Vec<u8>)>,
    /// Removed once every file is in place (an earlier output's buffer).
    obsolete: Vec<PathBuf>,
}

impl Staged {
    pub fn new() -> Self {
        Staged::default()
    }

    /// Adds `bytes` to be written as `path`.
    pub fn add(&mut self, path: impl Into<PathBuf>, bytes: Vec<u8>) {
        self.files.push((path.into(), bytes));
    }

    /// Adds `other`'s files (after this one's).
    pub fn append(&mut self, other: Staged) {
        self.files.extend(other.files);
        self.obsolete.extend(other.obsolete);
    }

    /// Marks `path` to be removed once every file is in place.
    pub fn remove_after(&mut self, path: PathBuf) {
        self.obsolete.push(path);
    }

    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|(p, _)| p.as_path())
    }

    /// Writes every file: all to temporary files (fsynced) first, then
    /// renames them into place in order, then removes the obsolete files.
    ///
    /// # Errors
    /// A target that is not a regular file (a device, a FIFO, a folder), a
    /// folder that cannot be made, a temporary file that cannot be written:
    /// then nothing is replaced and no temporary file is left. A rename
    /// that fails (rare: same folder) leaves the earlier ones done.
    pub fn commit(self) -> Result<(), WriteError> {
        for (path, _) in &self.files {
            check_output_target(path)
                .map_err(|e: ReadError| WriteError::new(path, format!("refusing to replace it: {e}")))?;
        }
        let mut temps: Vec<PathBuf> = Vec::with_capacity(self.files.len());
        let written = self.files.iter().try_for_each(|(path, bytes)| {
            let tmp = temp_path(path);
            let result = write_temp(path, &tmp, bytes);
            temps.push(tmp);
            result.map_err(|e| WriteError::new(path, e))
        });
        if let Err(e) = written {
            temps.iter().for_each(|t| drop(std::fs::remove_file(t)));
            return Err(e);
        }
        for (k, ((path, _), tmp)) in self.files.iter().zip(&temps).enumerate() {
            if let Err(e) = std::fs::rename(tmp, path) {
                temps[k..].iter().for_each(|t| drop(std::fs::remove_file(t)));
                return Err(WriteError::new(path, e));
            }
        }
        for old in &self.obsolete {
            let _ = std::fs::remove_file(old);
        }
        Ok(())
    }
}

/// Writes `bytes` to `tmp` (beside `path`, whose folder is made) and flushes it to disk.
fn write_temp(path: &Path, tmp: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    let mut f = std::fs::File::create(tmp)?;
    f.write_all(bytes)?;
    f.sync_all()
}

/// Writes `bytes` to `path` atomically (temp file + fsync + rename),
/// creating missing parent folders.
///
/// # Errors
/// As [`Staged::commit`].
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let mut staged = Staged::new();
    staged.add(path, bytes.to_vec());
    staged.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staged_files_are_all_written_or_none() {
        let dir = std::env::temp_dir().join(format!("uvpin-staged-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.glb"), b"old").unwrap();
        let mut s = Staged::new();
        s.add(dir.join("a.glb"), b"new".to_vec());
        s.add("/dev/null", b"x".to_vec());
        assert!(s.commit().unwrap_err().message.contains("a device"));
        assert_eq!(std::fs::read(dir.join("a.glb")).unwrap(), b"old");
        let mut s = Staged::new();
        s.add(dir.join("a.glb"), b"new".to_vec());
        s.add(dir.join("sub/b.json"), b"{}".to_vec());
        s.remove_after(dir.join("gone.bin"));
        std::fs::write(dir.join("gone.bin"), b"").unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read(dir.join("a.glb")).unwrap(), b"new");
        assert!(dir.join("sub/b.json").is_file() && !dir.join("gone.bin").exists());
        // A temporary file of a process that is gone is removed; ours stay.
        std::fs::write(dir.join(".x.glb.uvpin-999999999.tmp"), b"").unwrap();
        std::fs::write(temp_path(&dir.join("y.glb")), b"").unwrap();
        assert_eq!(remove_stale_temporaries(&dir), 1);
        assert!(temp_path(&dir.join("y.glb")).exists());
        assert_eq!(temp_owner(".a.b.uvpin-12.tmp"), Some(12));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
