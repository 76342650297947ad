//! A folder held open: files are made, renamed, linked and removed relative
//! to the handle (`openat`, `renameat`, `linkat`, `unlinkat`), so a path
//! component swapped for a link after the folder was opened and checked
//! cannot send a write elsewhere. Where the folder really is comes from the
//! handle itself (`/proc/self/fd`), not from its path.

use std::ffi::{CString, OsStr};
use std::fs::File;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd};
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};

/// An open folder and where it really is.
#[derive(Debug)]
pub struct Folder {
    handle: File,
    /// The folder's real path when it was opened (links resolved).
    pub real: PathBuf,
}

fn c_name(name: &OsStr) -> io::Result<CString> {
    if name.is_empty() || name.as_bytes().contains(&b'/') {
        return Err(io::Error::new(io::ErrorKind::InvalidInput, "not a plain file name"));
    }
    CString::new(name.as_bytes()).map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "a NUL in a file name"))
}

/// `-1` as the last OS error, anything else as success.
fn check(result: libc::c_int) -> io::Result<libc::c_int> {
    if result < 0 {
        Err(io::Error::last_os_error())
    } else {
        Ok(result)
    }
}

impl Folder {
    /// Opens the folder at `path` (following links) and reads where it is.
    ///
    /// # Errors
    /// Not a folder, or it cannot be opened.
    pub fn open(path: &Path) -> io::Result<Folder> {
        let path = if path.as_os_str().is_empty() {
            Path::new(".")
        } else {
            path
        };
        let handle = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_DIRECTORY | libc::O_CLOEXEC)
            .open(path)?;
        let fd_path = PathBuf::from(format!("/proc/self/fd/{}", handle.as_raw_fd()));
        let real = std::fs::read_link(fd_path).or_else(|_| path.canonicalize())?;
        Ok(Folder { handle, real })
    }

    fn fd(&self) -> libc::c_int {
        self.handle.as_raw_fd()
    }

    /// Makes the new file `name` in this folder for writing (never an
    /// existing file, never through a link).
    ///
    /// # Errors
    /// It exists, or cannot be made.
    pub fn create_new(&self, name: &OsStr) -> io::Result<File> {
        let c = c_name(name)?;
        let flags = libc::O_WRONLY | libc::O_CREAT | libc::O_EXCL | libc::O_NOFOLLOW | libc::O_CLOEXEC;
        // SAFETY: a valid folder descriptor and NUL-terminated name; the new
        // descriptor is owned by the returned File alone.
        let fd = check(unsafe { libc::openat(self.fd(), c.as_ptr(), flags, 0o666 as libc::c_uint) })?;
        // SAFETY: `fd` was just opened and nothing else owns it.
        Ok(unsafe { File::from_raw_fd(fd) })
    }

    /// Renames `from` to `to`, both in this folder (replacing `to`).
    ///
    /// # Errors
    /// The system's.
    pub fn rename(&self, from: &OsStr, to: &OsStr) -> io::Result<()> {
        let (f, t) = (c_name(from)?, c_name(to)?);
        // SAFETY: valid descriptors and NUL-terminated names.
        check(unsafe { libc::renameat(self.fd(), f.as_ptr(), self.fd(), t.as_ptr()) }).map(drop)
    }

    /// Gives the file `from` a second name `to` in this folder (a hard link,
    /// else a copy).
    ///
    /// # Errors
    /// Neither works.
    pub fn keep_as(&self, from: &OsStr, to: &OsStr) -> io::Result<()> {
        let (f, t) = (c_name(from)?, c_name(to)?);
        // SAFETY: valid descriptors and NUL-terminated names.
        if check(unsafe { libc::linkat(self.fd(), f.as_ptr(), self.fd(), t.as_ptr(), 0) }).is_ok() {
            return Ok(());
        }
        let flags = libc::O_RDONLY | libc::O_NOFOLLOW | libc::O_CLOEXEC;
        // SAFETY: as above; the descriptor is owned by the File alone.
        let fd = check(unsafe { libc::openat(self.fd(), f.as_ptr(), flags) })?;
        // SAFETY: `fd` was just opened and nothing else owns it.
        let mut old = unsafe { File::from_raw_fd(fd) };
        let mut copy = self.create_new(to)?;
        let copied = io::copy(&mut old, &mut copy).and_then(|_| copy.sync_all());
        if copied.is_err() {
            let _ = self.remove(to);
        }
        copied
    }

    /// Removes the file `name` from this folder.
    ///
    /// # Errors
    /// The system's.
    pub fn remove(&self, name: &OsStr) -> io::Result<()> {
        let c = c_name(name)?;
        // SAFETY: a valid descriptor and NUL-terminated name.
        check(unsafe { libc::unlinkat(self.fd(), c.as_ptr(), 0) }).map(drop)
    }

    /// Whether this folder has an entry `name` (a link is not followed).
    pub fn has(&self, name: &OsStr) -> bool {
        let Ok(c) = c_name(name) else { return false };
        // SAFETY: a zeroed stat is a valid out-buffer; valid descriptor and name.
        unsafe {
            let mut st: libc::stat = std::mem::zeroed();
            libc::fstatat(self.fd(), c.as_ptr(), &mut st, libc::AT_SYMLINK_NOFOLLOW) == 0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_folder_keeps_its_files_when_its_path_is_swapped_for_a_link() {
        let root = crate::testing::fresh_dir("folder");
        std::fs::create_dir_all(root.join("inside")).unwrap();
        std::fs::create_dir_all(root.join("outside")).unwrap();
        let folder = Folder::open(&root.join("inside")).unwrap();
        assert_eq!(folder.real, root.join("inside").canonicalize().unwrap());
        // The path now leads elsewhere; the handle does not.
        std::fs::rename(root.join("inside"), root.join("moved")).unwrap();
        std::os::unix::fs::symlink(root.join("outside"), root.join("inside")).unwrap();
        let mut f = folder.create_new(OsStr::new("a.tmp")).unwrap();
        io::Write::write_all(&mut f, b"x").unwrap();
        folder.rename(OsStr::new("a.tmp"), OsStr::new("a.glb")).unwrap();
        folder.keep_as(OsStr::new("a.glb"), OsStr::new("kept")).unwrap();
        assert!(folder.has(OsStr::new("kept")));
        folder.remove(OsStr::new("kept")).unwrap();
        assert!(root.join("moved/a.glb").is_file());
        assert_eq!(std::fs::read_dir(root.join("outside")).unwrap().count(), 0);
        assert!(
            folder.create_new(OsStr::new("../escape")).is_err(),
            "names only, no paths"
        );
        let _ = std::fs::remove_dir_all(&root);
    }
}
