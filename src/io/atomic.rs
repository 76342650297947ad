//! Atomic file output: every file is written to a temporary file beside its
//! target, flushed to disk, then renamed over the target. Readers see the
//! old file or the new one, never a half-written one. [`Staged`] does this
//! for several files at once (a model and its buffer, a report, pictures):
//! all temporary files first, then the renames in order, each old file kept
//! under a second name until every rename is done, so a failure at any
//! point puts back every file and removes every folder it made.

use super::folder::Folder;
use super::paths::absolute;
use super::read::{ReadError, check_output_target};
use std::ffi::OsString;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The marker in uvpin's temporary file names: `.NAME.uvpin-PID-N.tmp`.
const TEMP_MARK: &str = ".uvpin-";

/// Temporary names made by this process so far (each one is new).
static TEMPORARIES: AtomicU64 = AtomicU64::new(0);

/// A new temporary name for writing `path` (same folder, hidden), unique in
/// this process and, by its process id, among processes.
pub fn temp_path(path: &Path) -> PathBuf {
    path.with_file_name(temp_name(path.file_name().unwrap_or_default()))
}

/// The process id of a temporary file of uvpin's (`.NAME.uvpin-PID-N.tmp`,
/// or `.NAME.uvpin-PID.tmp` as older versions named them).
fn temp_owner(name: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (_, owner) = rest.rsplit_once(TEMP_MARK)?;
    owner.split('-').next()?.parse().ok()
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

/// Whether two existing paths are one file (the same device and inode).
fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => false,
    }
}

/// Checks that no two of `paths` name one file: by name, or (for files that
/// exist) through a link.
///
/// # Errors
/// The second path that names a file named before.
pub fn check_distinct<'a>(paths: impl IntoIterator<Item = &'a Path>) -> Result<(), WriteError> {
    let paths: Vec<&Path> = paths.into_iter().collect();
    for (k, b) in paths.iter().enumerate() {
        if let Some(a) = paths[..k]
            .iter()
            .find(|a| absolute(a) == absolute(b) || same_file(a, b))
        {
            return Err(WriteError::new(
                b,
                format!(
                    "two outputs name this one file ({} too); nothing was written",
                    a.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Where staged files may be written.
#[derive(Debug, Clone, Default)]
pub enum WriteScope {
    /// Anywhere the user can write (the command line).
    #[default]
    Anywhere,
    /// Only into these folders and below, as they really are when opened
    /// (the daemon: its output folder, or the watched folders in place). A
    /// folder swapped for a link to elsewhere is refused; one swapped after
    /// it was opened keeps receiving the files (they go through its handle).
    Within(std::sync::Arc<Vec<PathBuf>>),
}

impl WriteScope {
    /// The scope of `folders`.
    pub fn within(folders: impl IntoIterator<Item = PathBuf>) -> Self {
        WriteScope::Within(std::sync::Arc::new(folders.into_iter().map(|f| absolute(&f)).collect()))
    }

    /// Whether the folder really at `real` lies in the scope.
    fn allows(&self, real: &Path) -> bool {
        match self {
            WriteScope::Anywhere => true,
            WriteScope::Within(roots) => roots
                .iter()
                .any(|r| real.starts_with(r.canonicalize().unwrap_or_else(|_| r.clone()))),
        }
    }
}

/// Whether a commit may make the folders its files go in.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Folders {
    /// Missing folders are made (and removed again if the commit fails).
    #[default]
    Make,
    /// Every folder must exist already: writing in place never brings back
    /// a folder that was moved away while a solve ran.
    MustExist,
}

/// Where a commit may write, and whether it may make folders.
#[derive(Debug, Clone, Default)]
pub struct Writing {
    pub scope: WriteScope,
    pub folders: Folders,
}

/// Files to replace together, renamed into place in the order they were added.
#[derive(Debug, Default)]
pub struct Staged {
    files: Vec<(PathBuf, Vec<u8>)>,
    /// Removed once every file is in place (an earlier output's buffer).
    obsolete: Vec<PathBuf>,
    writing: Writing,
}

/// A file in a held folder: the folder and the name.
type Entry = (std::sync::Arc<Folder>, OsString);

/// What a commit has done so far, to be undone on failure: folders made,
/// temporary files written, old files kept aside, new files renamed in.
#[derive(Debug, Default)]
struct Progress {
    folders: Vec<PathBuf>,
    temps: Vec<Entry>,
    /// Per renamed target: its folder and name, and the old file's second
    /// name, if it had one.
    renamed: Vec<(Entry, Option<OsString>)>,
}

impl Progress {
    /// Puts every old file back, removes every new one, every temporary
    /// file and every folder made (last made first).
    fn undo(self) {
        for ((folder, name), kept) in self.renamed.iter().rev() {
            let _ = match kept {
                Some(old) => folder.rename(old, name),
                None => folder.remove(name),
            };
        }
        for (folder, tmp) in &self.temps {
            let _ = folder.remove(tmp);
        }
        for made in self.folders.iter().rev() {
            let _ = std::fs::remove_dir(made);
        }
    }

    /// Makes the missing folders of `dir`, outermost first, noting each.
    fn make_folders(&mut self, dir: &Path) -> std::io::Result<()> {
        if dir.as_os_str().is_empty() || dir.is_dir() {
            return Ok(());
        }
        if let Some(parent) = dir.parent() {
            self.make_folders(parent)?;
        }
        std::fs::create_dir(dir)?;
        self.folders.push(dir.to_path_buf());
        Ok(())
    }
}

impl Staged {
    pub fn new() -> Self {
        Staged::default()
    }

    /// These files, written as `writing` allows.
    #[must_use]
    pub fn writing(mut self, writing: Writing) -> Self {
        self.writing = writing;
        self
    }

    /// These files, written only within `scope` (folders made as needed).
    #[must_use]
    pub fn within(self, scope: WriteScope) -> Self {
        self.writing(Writing {
            scope,
            folders: Folders::Make,
        })
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

    /// Writes every file: all to temporary files (fsynced) in their folders,
    /// held open and checked against the scope, then renames them into
    /// place in order through those handles, each old file kept aside (a
    /// second name) until all are in place, then removes the obsolete files.
    ///
    /// # Errors
    /// Two files naming one; a target that is not a regular file (a device,
    /// a FIFO, a folder); a folder outside the scope, or that cannot be
    /// made; a file that cannot be written or renamed. Then every target
    /// and folder is as it was.
    pub fn commit(self) -> Result<(), WriteError> {
        let halt = self.test_halt();
        self.commit_with(move || {
            if let Some(name) = halt {
                halt_for_good(&name);
            }
        })
    }

    /// A test hook: with `UVPIN_TEST_HALT_BEFORE_RENAMES=NAME:K` the K-th
    /// commit of this process that writes a file named NAME stops for good
    /// once its temporary files are written, before any rename, so a test
    /// can kill the process there and find every target as it was. Returns
    /// the name when this commit is that one.
    fn test_halt(&self) -> Option<String> {
        static SEEN: AtomicU64 = AtomicU64::new(0);
        let wanted = std::env::var("UVPIN_TEST_HALT_BEFORE_RENAMES").ok()?;
        let (name, k) = wanted.rsplit_once(':')?;
        let k: u64 = k.parse().ok()?;
        let ours = self.paths().any(|p| p.file_name().is_some_and(|n| n == name));
        (ours && SEEN.fetch_add(1, Ordering::SeqCst) + 1 == k).then(|| name.to_string())
    }

    /// [`Staged::commit`], calling `between` after the temporary files are
    /// written and before the renames (where a test swaps folders).
    fn commit_with(self, between: impl FnOnce()) -> Result<(), WriteError> {
        check_distinct(self.paths())?;
        for (path, _) in &self.files {
            check_output_target(path)
                .map_err(|e: ReadError| WriteError::new(path, format!("refusing to replace it: {e}")))?;
        }
        let mut progress = Progress::default();
        let written = self.write_temps(&mut progress).and_then(|held| {
            between();
            self.rename_all(&held, &mut progress)
        });
        match written {
            Ok(()) => {
                for ((folder, _), kept) in &progress.renamed {
                    if let Some(k) = kept {
                        let _ = folder.remove(k);
                    }
                }
                for old in &self.obsolete {
                    let _ = std::fs::remove_file(old);
                }
                Ok(())
            }
            Err(e) => {
                progress.undo();
                Err(e)
            }
        }
    }

    /// Each file to a new temporary file in its folder (made if missing,
    /// opened, checked against the scope); the folders and names to rename.
    fn write_temps(&self, progress: &mut Progress) -> Result<Vec<Entry>, WriteError> {
        let mut held = Vec::with_capacity(self.files.len());
        for (path, bytes) in &self.files {
            let fail = |e: &dyn std::fmt::Display| WriteError::new(path, e);
            let name = path.file_name().ok_or_else(|| fail(&"not a file name"))?.to_os_string();
            let parent = path.parent().unwrap_or(Path::new(""));
            if self.writing.folders == Folders::Make {
                progress.make_folders(parent).map_err(|e| fail(&e))?;
            }
            let folder = std::sync::Arc::new(Folder::open(parent).map_err(|e| fail(&e))?);
            if !self.writing.scope.allows(&folder.real) {
                let why = format!(
                    "its folder is {}, outside the folders uvpin may write",
                    folder.real.display()
                );
                return Err(fail(&why));
            }
            let tmp = temp_name(&name);
            let mut file = folder.create_new(&tmp).map_err(|e| fail(&e))?;
            progress.temps.push((folder.clone(), tmp));
            file.write_all(bytes)
                .and_then(|()| file.sync_all())
                .map_err(|e| fail(&e))?;
            held.push((folder, name));
        }
        Ok(held)
    }

    /// Renames each temporary file over its target, the old file kept aside.
    fn rename_all(&self, held: &[Entry], progress: &mut Progress) -> Result<(), WriteError> {
        let temps: Vec<OsString> = progress.temps.iter().map(|(_, t)| t.clone()).collect();
        for (((folder, name), tmp), (path, _)) in held.iter().zip(&temps).zip(&self.files) {
            let kept = if folder.has(name) {
                let k = temp_name(name);
                folder.keep_as(name, &k).map_err(|e| WriteError::new(path, e))?;
                Some(k)
            } else {
                None
            };
            if let Err(e) = folder.rename(tmp, name) {
                if let Some(k) = &kept {
                    let _ = folder.remove(k);
                }
                return Err(WriteError::new(path, e));
            }
            progress.renamed.push(((folder.clone(), name.clone()), kept));
        }
        Ok(())
    }
}

/// Says on standard error (a JSON log line) that the test hook of
/// [`Staged::test_halt`] stopped a commit writing `name`, and waits forever.
fn halt_for_good(name: &str) -> ! {
    eprintln!(
        "{}",
        serde_json::json!({ "event": "halted_before_renames", "file": name })
    );
    loop {
        std::thread::park();
    }
}

/// A new temporary name beside the file `name` (see [`temp_path`]).
fn temp_name(name: &std::ffi::OsStr) -> OsString {
    let n = TEMPORARIES.fetch_add(1, Ordering::Relaxed);
    let name = name.to_string_lossy();
    OsString::from(format!(".{name}{TEMP_MARK}{}-{n}.tmp", std::process::id()))
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
        let dir = crate::testing::fresh_dir("staged");
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
        std::fs::write(dir.join(".x.glb.uvpin-999999999-3.tmp"), b"").unwrap();
        let ours = temp_path(&dir.join("y.glb"));
        std::fs::write(&ours, b"").unwrap();
        assert_eq!(remove_stale_temporaries(&dir), 2);
        assert!(ours.exists());
        assert_eq!(temp_owner(".a.b.uvpin-12.tmp"), Some(12));
        assert_eq!(temp_owner(".a.b.uvpin-12-7.tmp"), Some(12));
        assert_ne!(temp_path(&dir.join("y.glb")), ours, "every temporary name is new");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The folder's files and folders, with their contents.
    fn snapshot(dir: &Path) -> Vec<(PathBuf, Option<Vec<u8>>)> {
        let mut out = Vec::new();
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                out.push((p.clone(), None));
                out.extend(snapshot(&p));
            } else {
                out.push((p.clone(), Some(std::fs::read(&p).unwrap())));
            }
        }
        out.sort();
        out
    }

    #[test]
    fn a_folder_swapped_for_a_link_mid_commit_keeps_the_files_inside() {
        let root = crate::testing::fresh_dir("staged-swap");
        std::fs::create_dir_all(root.join("watched/sub")).unwrap();
        std::fs::create_dir_all(root.join("outside")).unwrap();
        let scope = WriteScope::within([root.join("watched")]);
        // Swapped after the folder was opened and checked: the files go
        // through the held folder, wherever its path now leads.
        let mut s = Staged::new().within(scope.clone());
        s.add(root.join("watched/sub/a.glb"), b"model".to_vec());
        s.add(root.join("watched/sub/a.json"), b"report".to_vec());
        s.commit_with(|| {
            std::fs::rename(root.join("watched/sub"), root.join("watched/moved")).unwrap();
            std::os::unix::fs::symlink(root.join("outside"), root.join("watched/sub")).unwrap();
        })
        .unwrap();
        assert_eq!(
            std::fs::read_dir(root.join("outside")).unwrap().count(),
            0,
            "nothing written outside"
        );
        assert_eq!(std::fs::read(root.join("watched/moved/a.glb")).unwrap(), b"model");
        // Swapped before: refused, nothing written anywhere.
        let mut s = Staged::new().within(scope);
        s.add(root.join("watched/sub/b.glb"), b"model".to_vec());
        let e = s.commit().unwrap_err();
        assert!(e.message.contains("outside the folders uvpin may write"), "{e}");
        assert_eq!(std::fs::read_dir(root.join("outside")).unwrap().count(), 0);
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn two_outputs_naming_one_file_write_nothing() {
        let dir = crate::testing::fresh_dir("staged-same");
        std::fs::write(dir.join("out.glb"), b"old").unwrap();
        let before = snapshot(&dir);
        for second in [dir.join("out.glb"), dir.join("new/../out.glb"), dir.join("./out.glb")] {
            let mut s = Staged::new();
            s.add(dir.join("out.glb"), b"model".to_vec());
            s.add(second, b"report".to_vec());
            assert!(
                s.commit()
                    .unwrap_err()
                    .message
                    .contains("two outputs name this one file")
            );
            assert_eq!(snapshot(&dir), before);
        }
        // A hard link to it is the same file too.
        std::fs::hard_link(dir.join("out.glb"), dir.join("link.glb")).unwrap();
        let mut s = Staged::new();
        s.add(dir.join("out.glb"), b"model".to_vec());
        s.add(dir.join("link.glb"), b"report".to_vec());
        assert!(s.commit().is_err());
        assert_eq!(std::fs::read(dir.join("out.glb")).unwrap(), b"old");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_failure_after_some_renames_puts_every_file_and_folder_back() {
        let dir = crate::testing::fresh_dir("staged-undo");
        std::fs::write(dir.join("a.glb"), b"old a").unwrap();
        std::fs::write(dir.join("blocker"), b"a file where a folder should be").unwrap();
        let before = snapshot(&dir);
        // The third file's folder cannot be made (a file is in its way),
        // after the first two were written in new folders.
        let mut s = Staged::new();
        s.add(dir.join("a.glb"), b"new a".to_vec());
        s.add(dir.join("new/deeper/b.json"), b"{}".to_vec());
        s.add(dir.join("blocker/c.png"), b"png".to_vec());
        assert!(s.commit().is_err());
        assert_eq!(
            snapshot(&dir),
            before,
            "no file replaced, no folder left, no temporary file"
        );
        // A rename that fails (a folder appeared where the file goes) after
        // another one was done: the first file is put back.
        let mut s = Staged::new();
        s.add(dir.join("a.glb"), b"new a".to_vec());
        s.add(dir.join("d.glb"), b"d".to_vec());
        let result = s.commit_with(|| std::fs::create_dir_all(dir.join("d.glb/inside")).unwrap());
        assert!(result.is_err());
        std::fs::remove_dir_all(dir.join("d.glb")).unwrap();
        assert_eq!(snapshot(&dir), before);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
