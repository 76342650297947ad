//! The watcher's side: raw file-system events (notify, debounced) become a
//! small domain enum, [`FileEvent`], sent over a crossbeam channel.

use notify::EventKind;
use notify::event::{CreateKind, ModifyKind, RenameMode};
use std::path::{Path, PathBuf};

/// What happened to a file the daemon cares about. Whether a path still
/// exists is checked when the event is handled, so a `Changed` for a file
/// that is gone counts as removed and vice versa (editors rename, delete and
/// recreate in one save).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum FileEvent {
    /// A constraint file (name ends with the configured suffix) was written or created.
    ConstraintsChanged(PathBuf),
    /// A possible asset file (.glb, .gltf, .bin, .obj) was written or created.
    AssetChanged(PathBuf),
    /// A file or folder was removed or renamed away.
    Removed(PathBuf),
    /// A folder was created (its contents may predate the watch).
    FolderAppeared(PathBuf),
    /// The OS dropped events: every watched folder must be rescanned.
    Rescan,
}

/// Which files are which.
#[derive(Debug, Clone)]
pub struct FileRules {
    /// Constraint files end with this (e.g. ".uvpin.ron").
    pub constraint_suffix: String,
    /// Files the daemon writes itself and never reads as input, whatever
    /// their names (its status file, even one named like a constraint file
    /// inside a watched folder); absolute and normalised.
    pub own: Vec<PathBuf>,
}

/// Extensions of files an asset may consist of.
pub const ASSET_EXTENSIONS: [&str; 4] = ["glb", "gltf", "bin", "obj"];

impl FileRules {
    /// Whether `path` names a constraint file. Hidden files (editor swap and
    /// lock files, uvpin's own temporaries) never are.
    pub fn is_constraint_file(&self, path: &Path) -> bool {
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
            return false;
        };
        !self.is_own(path)
            && !name.starts_with('.')
            && name.ends_with(&self.constraint_suffix)
            && name.len() > self.constraint_suffix.len()
    }

    /// Whether `path` is one of the daemon's own files.
    fn is_own(&self, path: &Path) -> bool {
        self.own.iter().any(|own| own == path)
    }

    /// Whether `path` may be (part of) an asset.
    pub fn is_asset_file(&self, path: &Path) -> bool {
        let hidden = path
            .file_name()
            .and_then(|n| n.to_str())
            .is_none_or(|n| n.starts_with('.'));
        !hidden
            && !self.is_own(path)
            && path
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| ASSET_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
    }

    /// The event for a path that was created or written, if it matters.
    fn changed(&self, path: &Path) -> Option<FileEvent> {
        if self.is_constraint_file(path) {
            Some(FileEvent::ConstraintsChanged(path.to_path_buf()))
        } else if self.is_asset_file(path) {
            Some(FileEvent::AssetChanged(path.to_path_buf()))
        } else if path.is_dir() {
            Some(FileEvent::FolderAppeared(path.to_path_buf()))
        } else {
            None
        }
    }

    /// Turns one (debounced) notify event into domain events. Access events
    /// (open, close) and files of no interest give nothing.
    pub fn classify(&self, kind: &EventKind, paths: &[PathBuf], need_rescan: bool) -> Vec<FileEvent> {
        if need_rescan {
            return vec![FileEvent::Rescan];
        }
        match kind {
            EventKind::Access(_) | EventKind::Other => Vec::new(),
            EventKind::Create(CreateKind::Folder) => {
                paths.iter().map(|p| FileEvent::FolderAppeared(p.clone())).collect()
            }
            EventKind::Remove(_) => paths.iter().map(|p| FileEvent::Removed(p.clone())).collect(),
            EventKind::Modify(ModifyKind::Name(RenameMode::From)) => {
                paths.iter().map(|p| FileEvent::Removed(p.clone())).collect()
            }
            EventKind::Modify(ModifyKind::Name(RenameMode::Both)) if paths.len() == 2 => {
                let mut events = vec![FileEvent::Removed(paths[0].clone())];
                events.extend(self.changed(&paths[1]));
                events
            }
            EventKind::Create(_) | EventKind::Modify(_) | EventKind::Any => {
                paths.iter().filter_map(|p| self.changed(p)).collect()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use notify::event::{AccessKind, DataChange, RemoveKind};

    fn rules() -> FileRules {
        FileRules {
            constraint_suffix: ".uvpin.ron".into(),
            own: vec![PathBuf::from("/w/a/status.uvpin.ron")],
        }
    }

    #[test]
    fn the_daemons_own_status_file_is_never_input_whatever_its_name() {
        let r = rules();
        assert!(!r.is_constraint_file(Path::new("/w/a/status.uvpin.ron")));
        assert!(r.is_constraint_file(Path::new("/w/a/head.uvpin.ron")));
        let kind = EventKind::Modify(ModifyKind::Data(DataChange::Any));
        assert!(
            r.classify(&kind, &[PathBuf::from("/w/a/status.uvpin.ron")], false)
                .is_empty()
        );
    }

    #[test]
    fn editor_side_files_and_access_events_are_ignored() {
        let r = rules();
        let kind = EventKind::Modify(ModifyKind::Data(DataChange::Any));
        for name in [
            "a/.head.uvpin.ron.swp",
            "a/head.uvpin.ron~",
            "a/.#head.uvpin.ron",
            "a/4913",
            "a/.out.glb.uvpin-12.tmp",
            "a/uvpin-status.json",
            "a/.uvpin.ron",
        ] {
            assert!(r.classify(&kind, &[PathBuf::from(name)], false).is_empty(), "{name}");
        }
        let open = EventKind::Access(AccessKind::Any);
        assert!(
            r.classify(&open, &[PathBuf::from("a/head.uvpin.ron")], false)
                .is_empty()
        );
    }

    #[test]
    fn saves_renames_and_removals_map_to_domain_events() {
        let r = rules();
        let ron = PathBuf::from("a/head.uvpin.ron");
        let glb = PathBuf::from("a/head.GLB");
        assert_eq!(
            r.classify(&EventKind::Create(CreateKind::File), std::slice::from_ref(&ron), false),
            vec![FileEvent::ConstraintsChanged(ron.clone())]
        );
        assert_eq!(
            r.classify(&EventKind::Modify(ModifyKind::Any), std::slice::from_ref(&glb), false),
            vec![FileEvent::AssetChanged(glb.clone())]
        );
        assert_eq!(
            r.classify(&EventKind::Remove(RemoveKind::File), std::slice::from_ref(&ron), false),
            vec![FileEvent::Removed(ron.clone())]
        );
        let tmp = PathBuf::from("a/head.uvpin.ron.tmp");
        assert_eq!(
            r.classify(
                &EventKind::Modify(ModifyKind::Name(RenameMode::Both)),
                &[tmp.clone(), ron.clone()],
                false
            ),
            vec![FileEvent::Removed(tmp), FileEvent::ConstraintsChanged(ron.clone())]
        );
        assert_eq!(r.classify(&EventKind::Any, &[ron], true), vec![FileEvent::Rescan]);
    }
}
