//! Paths as the file system has them: absolute, free of `.` and `..`, links
//! resolved as far as the path exists.

use std::path::{Component, Path, PathBuf};

/// `path` made absolute and free of `.`/`..`: canonical if it exists,
/// lexically cleaned otherwise.
pub fn normalize(path: &Path, cwd: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        cwd.join(path)
    };
    let mut out = PathBuf::new();
    for c in absolute.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    // The longest existing prefix canonical, so paths compare equal to notify's.
    let mut existing = out.clone();
    let mut rest = Vec::new();
    while !existing.exists() {
        match existing.file_name() {
            Some(name) => rest.push(name.to_os_string()),
            None => return out,
        }
        if !existing.pop() {
            return out;
        }
    }
    let mut p = existing.canonicalize().unwrap_or(existing);
    p.extend(rest.iter().rev());
    p
}

/// [`normalize`] against the process's working directory.
pub fn absolute(path: &Path) -> PathBuf {
    let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("/"));
    normalize(path, &cwd)
}
