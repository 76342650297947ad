//! What the daemon shows the editor: per served constraint file, its state
//! and error, the inputs of its last content that loaded (to edit and to
//! preview against) and its last written solve. The daemon publishes after
//! every tick that changed something; the server's threads read snapshots
//! and wait for the next version (server-sent events).

use super::text::ExistingItem;
use crate::chart::PrimitiveUvs;
use crate::constraints::LoadedConstraints;
use crate::daemon::status::FileState;
use crate::io::SourceAsset;
use crate::report::Report;
use crate::session::ChartSession;
use serde::Serialize;
use std::path::PathBuf;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Duration;

/// The last content of a constraint file that loaded: what edits are made
/// against and what drag previews solve.
#[derive(Debug, Clone)]
pub struct EditInputs {
    pub loaded: Arc<LoadedConstraints>,
    pub asset: Arc<SourceAsset>,
    /// The vertex each item of the file resolved to.
    pub existing: Vec<ExistingItem>,
    /// Hash of the file's bytes (see [`crate::io::content_hash`]).
    pub text_hash: u64,
}

/// A written solve: its report and the UVs of every primitive.
#[derive(Debug, Clone)]
pub struct SolvedView {
    pub report: Report,
    pub uvs: PrimitiveUvs,
    /// Per primitive and triangle: 1 where the page draws it from the
    /// chart's vertex UVs, 0 where from `written`.
    pub in_chart: Vec<Vec<u8>>,
    /// Per primitive and face corner: the UV set as written (every chart
    /// and packed piece where the file has it; empty if refused).
    pub written: PrimitiveUvs,
    /// The chart session after the solve, which drag previews start from
    /// (its last layout), and its asset.
    pub session: Arc<ChartSession>,
    pub asset: Arc<SourceAsset>,
}

/// One served constraint file.
#[derive(Debug, Clone)]
pub struct FileView {
    /// Its number in the editor's URLs (stable while the daemon runs).
    pub id: usize,
    /// As the log names it (relative to the working directory).
    pub name: String,
    pub path: PathBuf,
    pub state: FileState,
    /// The current content's error (the last solve is still shown).
    pub error: Option<String>,
    /// Hash of the current content (`None`: unreadable).
    pub text_hash: Option<u64>,
    pub inputs: Option<Arc<EditInputs>>,
    pub solved: Option<Arc<SolvedView>>,
    /// Bumped whenever anything above changes.
    pub version: u64,
}

/// What the daemon says of one file after a tick.
#[derive(Debug, Clone)]
pub struct FileUpdate {
    pub path: PathBuf,
    pub name: String,
    pub state: FileState,
    pub error: Option<String>,
    pub text_hash: Option<u64>,
    /// New inputs, if the content that loaded changed.
    pub inputs: Option<Arc<EditInputs>>,
    /// A new written solve, if there is one.
    pub solved: Option<Arc<SolvedView>>,
}

/// A file as listed to the page.
#[derive(Debug, Clone, Serialize)]
pub struct FileSummary {
    pub id: usize,
    pub name: String,
    pub state: FileState,
    pub version: u64,
}

#[derive(Debug, Default)]
struct HubState {
    version: u64,
    files: Vec<FileView>,
    closed: bool,
}

/// Shared between the daemon (which publishes) and the server's threads.
#[derive(Debug, Default)]
pub struct Hub {
    state: Mutex<HubState>,
    changed: Condvar,
}

impl Hub {
    fn lock(&self) -> MutexGuard<'_, HubState> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Applies the daemon's updates; wakes the waiting readers if anything changed.
    pub fn publish(&self, updates: Vec<FileUpdate>) {
        let mut s = self.lock();
        let mut any = false;
        for u in updates {
            let known = s.files.iter().position(|f| f.path == u.path);
            let k = known.unwrap_or_else(|| {
                let id = s.files.len();
                s.files.push(FileView {
                    id,
                    name: u.name.clone(),
                    path: u.path.clone(),
                    state: u.state,
                    error: None,
                    text_hash: None,
                    inputs: None,
                    solved: None,
                    version: 0,
                });
                id
            });
            let file = &s.files[k];
            let changed = known.is_none()
                || file.state != u.state
                || file.error != u.error
                || file.text_hash != u.text_hash
                || u.inputs.is_some()
                || u.solved.is_some();
            if !changed {
                continue;
            }
            s.version += 1;
            let version = s.version;
            let file = &mut s.files[k];
            file.state = u.state;
            file.error = u.error;
            file.text_hash = u.text_hash;
            file.inputs = u.inputs.or(file.inputs.take());
            file.solved = u.solved.or(file.solved.take());
            file.version = version;
            any = true;
        }
        if any {
            self.changed.notify_all();
        }
    }

    /// The files and the hub's version.
    pub fn summary(&self) -> (u64, Vec<FileSummary>) {
        let s = self.lock();
        let files = s
            .files
            .iter()
            .map(|f| FileSummary {
                id: f.id,
                name: f.name.clone(),
                state: f.state,
                version: f.version,
            })
            .collect();
        (s.version, files)
    }

    pub fn file(&self, id: usize) -> Option<FileView> {
        self.lock().files.get(id).cloned()
    }

    /// Waits until the version passes `seen` (`Some(version)`), the hub is
    /// closed (`None`), or `timeout` passes (`Some(seen)`).
    pub fn wait(&self, seen: u64, timeout: Duration) -> Option<u64> {
        let s = self.lock();
        let (s, _) = self
            .changed
            .wait_timeout_while(s, timeout, |s| s.version <= seen && !s.closed)
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        (!s.closed).then_some(s.version)
    }

    /// The daemon is stopping: every waiting reader returns.
    pub fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }

    pub fn is_closed(&self) -> bool {
        self.lock().closed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn update(path: &str, state: FileState) -> FileUpdate {
        FileUpdate {
            path: path.into(),
            name: path.into(),
            state,
            error: None,
            text_hash: Some(1),
            inputs: None,
            solved: None,
        }
    }

    #[test]
    fn versions_move_only_on_change_and_wake_waiters() {
        let hub = Arc::new(Hub::default());
        hub.publish(vec![update("a", FileState::Solving), update("b", FileState::Solving)]);
        let (v, files) = hub.summary();
        assert_eq!((v, files.len(), files[1].id), (2, 2, 1));
        hub.publish(vec![update("a", FileState::Solving)]);
        assert_eq!(hub.summary().0, 2);
        assert_eq!(hub.wait(2, Duration::from_millis(10)), Some(2));
        let waiter = {
            let hub = hub.clone();
            std::thread::spawn(move || hub.wait(2, Duration::from_secs(30)))
        };
        hub.publish(vec![update("a", FileState::Reached)]);
        assert_eq!(waiter.join().unwrap(), Some(3));
        assert_eq!(hub.file(0).unwrap().version, 3);
        let waiter = {
            let hub = hub.clone();
            std::thread::spawn(move || hub.wait(3, Duration::from_secs(30)))
        };
        hub.close();
        assert_eq!(waiter.join().unwrap(), None);
    }
}
