//! Reading input files safely: only regular files (a FIFO, a device or a
//! folder is an error at once, never a blocking read), never more bytes
//! than the input budget allows, and, where a scope is set (the daemon),
//! only inside the allowed folders.

use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;

/// How much input uvpin accepts: larger inputs are a clear error before
/// anything big is allocated. The `limits` section of `config/uvpin.ron`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InputLimits {
    /// Bytes of one asset file, buffer or image at most (default 1 GiB).
    pub max_file_bytes: u64,
    /// Vertices of one mesh (all its primitives) at most (default 8 million).
    pub max_vertices: usize,
    /// Triangles of one mesh at most (default 16 million).
    pub max_triangles: usize,
    /// Bytes of a constraint, sweep or configuration file at most (default 16 MiB).
    pub max_text_bytes: u64,
    /// Width × height of a decoded texture image at most (default 64 million pixels).
    pub max_image_pixels: u64,
}

impl InputLimits {
    pub const DEFAULT: InputLimits = InputLimits {
        max_file_bytes: 1 << 30,
        max_vertices: 8_000_000,
        max_triangles: 16_000_000,
        max_text_bytes: 16 << 20,
        max_image_pixels: 64_000_000,
    };
}

impl Default for InputLimits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Where input files may be read from.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum ReadScope {
    /// Anywhere the user can read (the command line).
    #[default]
    Anywhere,
    /// Only inside these folders (canonical paths), after resolving links
    /// (the daemon: its watched folders, and what the configuration allows).
    Within(Arc<Vec<PathBuf>>),
}

impl ReadScope {
    /// The scope of `folders` (made canonical; those that do not exist are
    /// kept as given).
    pub fn within(folders: impl IntoIterator<Item = PathBuf>) -> Self {
        let folders = folders.into_iter().map(|f| f.canonicalize().unwrap_or(f)).collect();
        ReadScope::Within(Arc::new(folders))
    }

    /// Whether `path` (resolved) lies inside the scope.
    pub fn allows(&self, path: &Path) -> bool {
        self.allows_real(&path.canonicalize().unwrap_or_else(|_| path.to_path_buf()))
    }

    /// Whether the already resolved path `real` lies inside the scope.
    pub fn allows_real(&self, real: &Path) -> bool {
        match self {
            ReadScope::Anywhere => true,
            ReadScope::Within(folders) => folders.iter().any(|f| real.starts_with(f)),
        }
    }
}

/// Why a file could not be read.
#[derive(Debug, Error)]
pub enum ReadError {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("it is {kind}, not a regular file")]
    NotRegular { kind: &'static str },
    #[error("it is {size} bytes, more than the input limit of {limit} bytes")]
    TooLarge { size: u64, limit: u64 },
    #[error("it is outside the folders uvpin may read here (allow more with `allow_paths` in the configuration)")]
    OutsideScope,
}

impl ReadError {
    /// Whether the file does not exist.
    pub fn is_not_found(&self) -> bool {
        matches!(self, ReadError::Io(e) if e.kind() == std::io::ErrorKind::NotFound)
    }
}

/// What kind of non-regular file `meta` describes.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_dir() {
        "a folder"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_char_device() || t.is_block_device() {
        "a device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

/// Reads the regular file at `path` (links resolved), at most `limit` bytes,
/// inside `scope`.
///
/// # Errors
/// A missing or unreadable file, one that is not a regular file (checked
/// before and after opening, without blocking), one larger than `limit`, one
/// outside `scope`.
pub fn read_regular(path: &Path, limit: u64, scope: &ReadScope) -> Result<Vec<u8>, ReadError> {
    use std::os::unix::fs::OpenOptionsExt;
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular { kind: kind_of(&meta) });
    }
    if !scope.allows(path) {
        return Err(ReadError::OutsideScope);
    }
    // Opening a FIFO blocks until a writer appears, unless non-blocking; the
    // file could have been replaced since the check above, so it is checked
    // again once open.
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular { kind: kind_of(&meta) });
    }
    // The file opened may not be the one checked (swapped for a link in
    // between): where the open handle really is decides, before a byte is read.
    if let ReadScope::Within(_) = scope {
        use std::os::fd::AsRawFd;
        let opened = std::fs::read_link(format!("/proc/self/fd/{}", file.as_raw_fd()));
        if opened.is_ok_and(|real| !scope.allows_real(&real)) {
            return Err(ReadError::OutsideScope);
        }
    }
    if meta.len() > limit {
        return Err(ReadError::TooLarge {
            size: meta.len(),
            limit,
        });
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    // One byte past the limit tells a file that grew since its size was read;
    // `u64::MAX` as the limit reads to the end.
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge {
            size: bytes.len() as u64,
            limit,
        });
    }
    Ok(bytes)
}

/// Checks that `path` may be replaced by an output: it does not exist, or
/// it is a regular file (a device, FIFO, folder or socket is never replaced).
///
/// # Errors
/// [`ReadError::NotRegular`] for such a target.
pub fn check_output_target(path: &Path) -> Result<(), ReadError> {
    match std::fs::metadata(path) {
        Ok(meta) if !meta.is_file() => Err(ReadError::NotRegular { kind: kind_of(&meta) }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_limit_of_u64_max_reads_the_whole_file() {
        let dir = crate::testing::fresh_dir("read-max");
        std::fs::write(dir.join("f"), b"twelve bytes").unwrap();
        let bytes = read_regular(&dir.join("f"), u64::MAX, &ReadScope::Anywhere).unwrap();
        assert_eq!(bytes, b"twelve bytes");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn fifos_devices_and_folders_are_errors_at_once() {
        let dir = std::env::temp_dir().join(format!("uvpin-read-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("pipe.glb");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let any = ReadScope::Anywhere;
        let t0 = std::time::Instant::now();
        assert!(matches!(
            read_regular(&fifo, 100, &any),
            Err(ReadError::NotRegular { kind: "a FIFO" })
        ));
        assert!(matches!(
            read_regular(Path::new("/dev/zero"), 100, &any),
            Err(ReadError::NotRegular { kind: "a device" })
        ));
        assert!(matches!(
            read_regular(&dir, 100, &any),
            Err(ReadError::NotRegular { kind: "a folder" })
        ));
        assert!(t0.elapsed().as_secs() < 2, "no blocking read");
        let file = dir.join("a.bin");
        std::fs::write(&file, [7u8; 64]).unwrap();
        assert_eq!(read_regular(&file, 64, &any).unwrap().len(), 64);
        assert!(matches!(
            read_regular(&file, 63, &any),
            Err(ReadError::TooLarge { size: 64, limit: 63 })
        ));
        let elsewhere = ReadScope::within([dir.join("sub")]);
        assert!(matches!(
            read_regular(&file, 64, &elsewhere),
            Err(ReadError::OutsideScope)
        ));
        assert!(read_regular(&file, 64, &ReadScope::within([dir.clone()])).is_ok());
        assert!(check_output_target(Path::new("/dev/null")).is_err());
        assert!(check_output_target(&file).is_ok() && check_output_target(&dir.join("new")).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
