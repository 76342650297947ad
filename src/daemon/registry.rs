//! The daemon's rules as a state machine over plain data: file events go
//! in, [`Action`]s come out ([`Registry::on_events`]); the outcome of each
//! solve comes back in ([`Registry::on_outcome`]). Every rule is here,
//! keyed by content hashes:
//! - a constraint file whose content did not change does nothing;
//! - a constraint edit on the same asset reuses the cached asset (and the
//!   chart session keeps what still applies);
//! - an asset edit re-solves every constraint file that names it; an asset
//!   removed stops their solves and keeps their last outputs, and back
//!   unchanged it needs no new solve;
//! - the daemon's own writes (in place) are recognised by hash and ignored;
//! - in place, only assets inside the watched folders are written, each by
//!   one constraint file;
//! - a constraint file that does not parse while it is still being written
//!   is read again once it has rested (a burst of saves);
//! - an asset's folder outside every watched folder is watched too.
//!
//! The files are read through [`Disk`] (the real one, or a test's).

use super::assets::{AssetCache, AssetSelection, Lookup, ReadAsset};
use super::events::{FileEvent, FileRules};
use super::paths::{WatchRoot, display, normalize, output_path, root_of};
use super::status::FileState;
use crate::config::OutputMode;
use crate::constraints::{ConstraintFileError, LoadedConstraints};
use crate::error::Error;
use crate::export::{OnError, Outputs};
use crate::io::{AssetError, InputRules, ReadError, ReadScope, SourceAsset, content_hash};
use crate::options::SolverOptions;
use crate::report::Status;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What the daemon watches and where it writes.
#[derive(Debug, Clone)]
pub struct WatchSettings {
    /// What input may be read: the limits, and only inside the watched
    /// folders and the configuration's `allow_paths`.
    pub input: InputRules,
    /// How long a constraint file must have rested before a parse error
    /// counts (a burst of saves can be read half-written): the debounce.
    pub settle: Duration,
    pub roots: Vec<WatchRoot>,
    pub output: OutputMode,
    pub rules: FileRules,
    /// Solver options for constraint files without a `solver` section.
    pub defaults: SolverOptions,
    /// Working directory: relative output folders and displayed paths.
    pub cwd: PathBuf,
    /// Picture size beside each output (`None`: no pictures).
    pub previews: Option<u32>,
}

/// Counts of what the rules decided (for tests and the log).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct WatchCounters {
    /// Solves started (one per accepted content change).
    pub solves_started: u64,
    /// Events whose file content had not changed.
    pub unchanged: u64,
    /// Solves that reused the previous chart geometry and bar-net factor.
    pub geometry_reused: u64,
    /// Solves that also reused the step-1 layout.
    pub step1_reused: u64,
}

/// Where a constraint file's solve stands.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum SolveState {
    /// Nothing started yet.
    #[default]
    Idle,
    /// A solve of the current content is running.
    Running,
    /// The last solve ended with this status (written unless `Error`).
    Written(Status),
    /// The current content or its asset failed; `kept` is the last
    /// written solve's status when it still stands (the asset was removed
    /// after it was written).
    Failed { kept: Option<Status> },
}

/// One constraint file.
#[derive(Debug, Clone, Default)]
pub struct FileRecord {
    /// Hash of the content last acted on (`None`: to be read again).
    pub hash: Option<u64>,
    /// The asset named by the last parsed content.
    pub asset: Option<PathBuf>,
    /// The file is gone (its last output is kept).
    pub removed: bool,
    /// Where its solves write.
    pub output: Option<PathBuf>,
    pub solve: SolveState,
}

/// What the rules ask for.
#[derive(Debug, Clone)]
pub enum Action {
    /// Solve `file`'s new content (dropping a running solve).
    Solve {
        file: PathBuf,
        loaded: Box<LoadedConstraints>,
        asset: Arc<SourceAsset>,
        outputs: Outputs,
        /// Milliseconds spent reading the file and its asset.
        load_ms: f64,
    },
    /// `file` has an error: a running solve stops, nothing is written.
    Fail { file: PathBuf, error: Arc<Error> },
    /// `file`'s asset is gone: a running solve stops; a finished one's
    /// result stands (its output is kept).
    Stop { file: PathBuf, error: Arc<Error> },
    /// `file`'s asset is back unchanged: its last result stands again.
    Restore { file: PathBuf, status: Status },
    /// `file` was removed; its last output is kept.
    Removed { file: PathBuf },
    /// `file` is back with the content it had when removed: its last state.
    Back { file: PathBuf, state: FileState },
    /// Read `file` again once `after` has passed (it is still being written).
    Recheck { file: PathBuf, after: Duration },
    /// Watch `folder` too (an asset's folder outside every watched one).
    Watch { folder: PathBuf },
}

/// How a finished solve came back.
#[derive(Debug, Clone)]
pub enum Outcome {
    /// Exported with this status, written to `output` (unless `Error`).
    Exported { status: Status, output: Option<PathBuf> },
    /// Failed (an error found while solving, or the input's).
    Failed,
}

/// What the rules read: the only way they see files.
pub trait Disk {
    /// A constraint file's bytes, within `rules`.
    ///
    /// # Errors
    /// Not found, outside the scope, too large, not a regular file.
    fn read_text(&self, path: &Path, rules: &InputRules) -> Result<Vec<u8>, ReadError>;
    /// The combined hash of an asset's files as they are now.
    ///
    /// # Errors
    /// The main file cannot be read.
    fn asset_hash(&self, files: &[PathBuf], scope: &ReadScope) -> Result<u64, ReadError>;
    /// Reads an asset.
    ///
    /// # Errors
    /// Any asset error.
    fn read_asset(&self, path: &Path, selection: &AssetSelection, rules: &InputRules) -> Result<ReadAsset, AssetError>;
    fn is_file(&self, path: &Path) -> bool;
    fn is_dir(&self, path: &Path) -> bool;
    /// Every constraint file and asset file under `dir`.
    fn scan(&self, dir: &Path, rules: &FileRules) -> (Vec<PathBuf>, Vec<PathBuf>);
    /// Whether `path` was modified less than `window` ago.
    fn modified_within(&self, path: &Path, window: Duration) -> bool;
}

/// The daemon's memory: every constraint file, the asset cache, the
/// hashes of its own writes, the folders it asked to watch.
#[derive(Debug, Default)]
pub struct Registry {
    pub files: BTreeMap<PathBuf, FileRecord>,
    pub assets: AssetCache,
    /// Hash of each file the daemon wrote that is also an input (in place).
    pub written: HashMap<PathBuf, u64>,
    /// Asset folders outside every watched root, asked for already.
    pub asset_folders: BTreeSet<PathBuf>,
    pub counters: WatchCounters,
}

/// Constraint files to read, and whether to read one even if its content
/// is unchanged (its asset changed).
type ToLoad = BTreeMap<PathBuf, bool>;

impl Registry {
    /// The actions a batch of file events asks for (duplicates count once).
    pub fn on_events(&mut self, events: &[FileEvent], settings: &WatchSettings, disk: &dyn Disk) -> Vec<Action> {
        let mut to_load = ToLoad::new();
        let mut actions = Vec::new();
        let mut seen = std::collections::HashSet::new();
        for event in events.iter().filter(|e| seen.insert(*e)) {
            self.on_event(event, settings, disk, &mut to_load, &mut actions);
        }
        for (path, force) in to_load {
            self.load(&path, force, settings, disk, &mut actions);
        }
        actions
    }

    fn on_event(
        &mut self,
        event: &FileEvent,
        settings: &WatchSettings,
        disk: &dyn Disk,
        to_load: &mut ToLoad,
        actions: &mut Vec<Action>,
    ) {
        match event {
            FileEvent::ConstraintsChanged(p) => {
                to_load.entry(p.clone()).or_insert(false);
            }
            FileEvent::AssetChanged(p) => self.asset_changed(p, settings, disk, to_load, actions),
            FileEvent::Removed(p) => {
                for f in self.files.keys().filter(|f| f.starts_with(p)) {
                    to_load.entry(f.clone()).or_insert(false);
                }
                let inside: Vec<PathBuf> = self
                    .assets
                    .assets
                    .keys()
                    .filter(|a| a.starts_with(p))
                    .cloned()
                    .collect();
                self.asset_changed(p, settings, disk, to_load, actions);
                for a in inside.iter().filter(|a| *a != p) {
                    self.asset_changed(a, settings, disk, to_load, actions);
                }
            }
            FileEvent::FolderAppeared(dir) => {
                let (constraints, assets) = disk.scan(dir, &settings.rules);
                for a in &assets {
                    self.asset_changed(a, settings, disk, to_load, actions);
                }
                for c in constraints {
                    to_load.entry(c).or_insert(false);
                }
            }
            FileEvent::Rescan => self.rescan(settings, disk, to_load, actions),
        }
    }

    /// The OS dropped events: every cached asset and every constraint file
    /// known or present is looked at again.
    fn rescan(&mut self, settings: &WatchSettings, disk: &dyn Disk, to_load: &mut ToLoad, actions: &mut Vec<Action>) {
        let cached: Vec<PathBuf> = self.assets.assets.keys().cloned().collect();
        for a in &cached {
            self.asset_changed(a, settings, disk, to_load, actions);
        }
        for f in self.files.keys() {
            to_load.entry(f.clone()).or_insert(false);
        }
        for root in &settings.roots {
            let (constraints, _) = disk.scan(root.folder(), &settings.rules);
            for c in constraints.into_iter().filter(|c| root.contains(c)) {
                to_load.entry(c).or_insert(false);
            }
        }
    }

    /// Constraint files whose last parsed content names `asset`.
    fn dependants(&self, asset: &Path) -> Vec<PathBuf> {
        self.files
            .iter()
            .filter(|(_, r)| !r.removed && r.asset.as_deref() == Some(asset))
            .map(|(p, _)| p.clone())
            .collect()
    }

    /// An asset file (or a buffer of one) was written, created or removed.
    fn asset_changed(
        &mut self,
        file: &Path,
        settings: &WatchSettings,
        disk: &dyn Disk,
        to_load: &mut ToLoad,
        actions: &mut Vec<Action>,
    ) {
        let cached = self.assets.assets_using(file);
        for asset in &cached {
            let entry = &self.assets.assets[asset];
            let (was_missing, old_hash) = (entry.missing, entry.hash);
            match disk.asset_hash(&entry.files, &settings.input.scope) {
                Err(_) if was_missing => {}
                Err(read) => self.asset_gone(asset, &read, actions),
                Ok(h) if h == old_hash || Some(&h) == self.written.get(asset) => {
                    self.counters.unchanged += 1;
                    if was_missing {
                        self.set_missing(asset, false);
                        for f in self.dependants(asset) {
                            self.asset_back_unchanged(&f, to_load, actions);
                        }
                    }
                }
                Ok(_) => {
                    self.assets.assets.remove(asset);
                    for f in self.dependants(asset) {
                        to_load.insert(f, true);
                    }
                }
            }
        }
        // Constraint files waiting for an asset that failed to load
        // (missing, corrupt, or a missing .bin beside it): read again.
        let is_buffer = file.extension().is_some_and(|e| e.eq_ignore_ascii_case("bin"));
        let waiting = self.files.iter().filter(|(_, r)| {
            matches!(r.solve, SolveState::Failed { .. })
                && !r.removed
                && r.asset.as_deref().is_some_and(|a| {
                    !cached.iter().any(|c| c == a)
                        && (a == file || (is_buffer && a.parent() == file.parent()) || a.starts_with(file))
                })
        });
        for (p, _) in waiting {
            to_load.insert(p.clone(), true);
        }
    }

    fn set_missing(&mut self, asset: &Path, missing: bool) {
        if let Some(entry) = self.assets.assets.get_mut(asset) {
            entry.missing = missing;
        }
    }

    /// The asset was removed, or is there and unreadable (permissions, a
    /// FIFO, too large): its dependants stop, keeping finished results.
    fn asset_gone(&mut self, asset: &Path, read: &ReadError, actions: &mut Vec<Action>) {
        self.set_missing(asset, true);
        let why = if read.is_not_found() {
            "the asset was removed".to_string()
        } else {
            format!("the asset cannot be read ({read})")
        };
        for file in self.dependants(asset) {
            let error = Arc::new(Error::Asset(AssetError::Read {
                path: asset.to_path_buf(),
                source: ReadError::Io(std::io::Error::other(why.clone())),
            }));
            let record = self.files.get_mut(&file).expect("a dependant is known");
            let kept = match record.solve {
                SolveState::Written(s) => Some(s),
                SolveState::Failed { kept } => kept,
                SolveState::Idle | SolveState::Running => None,
            };
            record.solve = SolveState::Failed { kept };
            actions.push(Action::Stop { file, error });
        }
    }

    /// The asset of `file` is back with the content it had: its last result
    /// stands again, or, if its solve was cut short, it is solved again.
    fn asset_back_unchanged(&mut self, file: &Path, to_load: &mut ToLoad, actions: &mut Vec<Action>) {
        let record = self.files.get_mut(file).expect("a dependant is known");
        match record.solve {
            SolveState::Failed { kept: Some(status) } => {
                record.solve = SolveState::Written(status);
                actions.push(Action::Restore {
                    file: file.to_path_buf(),
                    status,
                });
            }
            SolveState::Failed { kept: None } => {
                to_load.insert(file.to_path_buf(), true);
            }
            _ => {}
        }
    }

    /// Reads one constraint file and, if its content changed (or `force`),
    /// asks for a solve of it, or says what is wrong.
    fn load(&mut self, path: &Path, force: bool, settings: &WatchSettings, disk: &dyn Disk, actions: &mut Vec<Action>) {
        let Some(root) = root_of(&settings.roots, path).filter(|_| settings.rules.is_constraint_file(path)) else {
            return;
        };
        if !self.files.contains_key(path) {
            if !disk.is_file(path) {
                return;
            }
            self.files.insert(path.to_path_buf(), FileRecord::default());
        }
        let Some(text) = self.read_if_changed(path, force, settings, disk, actions) else {
            return;
        };
        let t0 = Instant::now();
        let loaded = match LoadedConstraints::parse_with_defaults(path, &text, &settings.defaults) {
            Ok(l) => l,
            Err(ConstraintFileError::Syntax(_)) if disk.modified_within(path, settings.settle) => {
                self.record(path).hash = None;
                let file = path.to_path_buf();
                return actions.push(Action::Recheck {
                    file,
                    after: settings.settle,
                });
            }
            Err(e) => return self.fail(path, e.into(), actions),
        };
        let asset_path = normalize(&loaded.asset_path(), &settings.cwd);
        self.note_asset(path, &asset_path, settings, actions);
        let root = root.clone();
        match self.job(path, &root, &loaded, &asset_path, settings, disk) {
            Ok((asset, output)) => {
                let record = self.record(path);
                record.output = Some(output.clone());
                record.solve = SolveState::Running;
                actions.push(Action::Solve {
                    file: path.to_path_buf(),
                    loaded: Box::new(loaded),
                    asset,
                    outputs: outputs(settings, output),
                    load_ms: t0.elapsed().as_secs_f64() * 1e3,
                });
            }
            Err(e) => self.fail(path, e, actions),
        }
    }

    /// The asset and the output of a parsed constraint file, after the
    /// in-place rules.
    fn job(
        &mut self,
        path: &Path,
        root: &WatchRoot,
        loaded: &LoadedConstraints,
        asset_path: &Path,
        settings: &WatchSettings,
        disk: &dyn Disk,
    ) -> Result<(Arc<SourceAsset>, PathBuf), Error> {
        check_in_place_target(settings, loaded, asset_path)?;
        let asset = self.asset(loaded, asset_path, settings, disk)?;
        let suffix = &settings.rules.constraint_suffix;
        let output = output_path(&settings.output, root, path, suffix, asset_path, &settings.cwd);
        self.check_single_writer(path, loaded, &output, settings)?;
        Ok((asset, output))
    }

    fn record(&mut self, path: &Path) -> &mut FileRecord {
        self.files.entry(path.to_path_buf()).or_default()
    }

    /// The file's text when its content changed since it was last acted on
    /// (or `force`); `None` when there is nothing to do (unchanged,
    /// removed, or unreadable: then the actions say so).
    fn read_if_changed(
        &mut self,
        path: &Path,
        force: bool,
        settings: &WatchSettings,
        disk: &dyn Disk,
        actions: &mut Vec<Action>,
    ) -> Option<String> {
        let bytes = match disk.read_text(path, &settings.input) {
            Ok(b) => b,
            Err(e) if e.is_not_found() || disk.is_dir(path) => {
                self.constraint_removed(path, actions);
                return None;
            }
            Err(source) => {
                self.record(path).hash = None;
                let error = ConstraintFileError::Read {
                    path: path.to_path_buf(),
                    source,
                };
                self.fail(path, error.into(), actions);
                return None;
            }
        };
        let hash = content_hash(&bytes);
        let record = self.record(path).clone();
        let failed = matches!(record.solve, SolveState::Failed { .. });
        if record.hash == Some(hash) && !force && !(failed && record.removed) {
            self.unchanged(path, &record, actions);
            return None;
        }
        let record = self.record(path);
        (record.hash, record.removed) = (Some(hash), false);
        match String::from_utf8(bytes) {
            Ok(t) => Some(t),
            Err(e) => {
                let error = ConstraintFileError::NotUtf8 {
                    path: path.to_path_buf(),
                    at: e.utf8_error().valid_up_to(),
                };
                self.fail(path, error.into(), actions);
                None
            }
        }
    }

    /// The same content again: nothing to solve. A file back with the
    /// content it had before it was removed (an editor's delete + recreate)
    /// gets its last state back.
    fn unchanged(&mut self, path: &Path, record: &FileRecord, actions: &mut Vec<Action>) {
        self.record(path).removed = false;
        if record.removed {
            let state = match record.solve {
                SolveState::Written(s) | SolveState::Failed { kept: Some(s) } => FileState::of(s),
                _ => FileState::Error,
            };
            let file = path.to_path_buf();
            actions.push(Action::Back { file, state });
        }
        self.counters.unchanged += 1;
    }

    /// The constraint file is gone: its last output is kept, a running solve stops.
    fn constraint_removed(&mut self, path: &Path, actions: &mut Vec<Action>) {
        let record = self.record(path);
        if record.removed {
            return;
        }
        record.removed = true;
        if record.solve == SolveState::Running {
            self.fail(path, Error::Internal("constraint file removed".into()), actions);
        }
        actions.push(Action::Removed {
            file: path.to_path_buf(),
        });
    }

    /// `path` has an error: its solve stops, nothing is written.
    fn fail(&mut self, path: &Path, error: Error, actions: &mut Vec<Action>) {
        self.record(path).solve = SolveState::Failed { kept: None };
        actions.push(Action::Fail {
            file: path.to_path_buf(),
            error: Arc::new(error),
        });
    }

    /// Remembers the asset `file` names, and asks to watch its folder when
    /// no watched folder covers it.
    fn note_asset(&mut self, file: &Path, asset: &Path, settings: &WatchSettings, actions: &mut Vec<Action>) {
        self.record(file).asset = Some(asset.to_path_buf());
        let Some(folder) = asset.parent() else { return };
        let covered = settings
            .roots
            .iter()
            .any(|r| !r.single_file && folder.starts_with(&r.path));
        if !covered && self.asset_folders.insert(folder.to_path_buf()) {
            actions.push(Action::Watch {
                folder: folder.to_path_buf(),
            });
        }
    }

    /// The asset, from the cache when its content is unchanged.
    fn asset(
        &mut self,
        loaded: &LoadedConstraints,
        asset_path: &Path,
        settings: &WatchSettings,
        disk: &dyn Disk,
    ) -> Result<Arc<SourceAsset>, Error> {
        let selection = AssetSelection {
            mesh: loaded.file.mesh.clone(),
            uv_set: loaded.file.uv_set(),
        };
        let missing = || {
            let message = format!("{} does not exist", display(asset_path, &settings.cwd));
            Error::from(loaded.asset_error("asset", message))
        };
        match self.assets.lookup(asset_path, &selection) {
            Lookup::Hit(asset) => Ok(asset),
            Lookup::Missing => Err(missing()),
            Lookup::Absent => match disk.read_asset(asset_path, &selection, &settings.input) {
                Ok(read) => {
                    let asset = read.asset.clone();
                    self.assets.insert(asset_path, &selection, read);
                    Ok(asset)
                }
                Err(AssetError::Read { source, .. }) if source.is_not_found() => Err(missing()),
                Err(e) => Err(e.into()),
            },
        }
    }

    /// In place, one constraint file per asset: another file writing `output` is an error.
    fn check_single_writer(
        &self,
        path: &Path,
        loaded: &LoadedConstraints,
        output: &Path,
        settings: &WatchSettings,
    ) -> Result<(), Error> {
        if settings.output != OutputMode::InPlace {
            return Ok(());
        }
        let other = self
            .files
            .iter()
            .find(|(p, r)| *p != path && !r.removed && r.output.as_deref() == Some(output));
        match other {
            None => Ok(()),
            Some((other, _)) => Err(loaded
                .asset_error(
                    "asset",
                    format!(
                        "in-place mode: {} is already written by {}; one constraint file per asset",
                        display(output, &settings.cwd),
                        display(other, &settings.cwd)
                    ),
                )
                .into()),
        }
    }

    /// A solve of `file` came back. Remembers the hash of a written output
    /// that is also an input (in place, or another file's asset), so the
    /// daemon's own write is not taken for an edit.
    pub fn on_outcome(&mut self, file: &Path, outcome: &Outcome, settings: &WatchSettings, disk: &dyn Disk) {
        let record = self.record(file);
        match outcome {
            Outcome::Failed => {
                if !matches!(record.solve, SolveState::Failed { .. }) {
                    record.solve = SolveState::Failed { kept: None };
                }
            }
            Outcome::Exported { status, output } => {
                record.solve = SolveState::Written(*status);
                let Some(out) = output.as_ref().filter(|_| *status != Status::Error) else {
                    return;
                };
                let cached = self.assets.assets.get(out);
                let files = cached.map_or_else(|| vec![out.clone()], |a| a.files.clone());
                if (cached.is_some() || settings.output == OutputMode::InPlace)
                    && let Ok(h) = disk.asset_hash(&files, &settings.input.scope)
                {
                    self.written.insert(out.clone(), h);
                }
            }
        }
    }

    /// The output `file` writes, once known.
    pub fn output_of(&self, file: &Path) -> Option<&Path> {
        self.files.get(file).and_then(|r| r.output.as_deref())
    }

    /// Whether `file` was removed (its errors are not reported).
    pub fn is_removed(&self, file: &Path) -> bool {
        self.files.get(file).is_some_and(|r| r.removed)
    }
}

/// What the daemon writes for one constraint file: the asset as `model`,
/// and its pictures beside it when asked; all in one commit, the pictures
/// also of a refused layout.
fn outputs(settings: &WatchSettings, model: PathBuf) -> Outputs {
    Outputs {
        #[cfg(feature = "pictures")]
        pictures: settings
            .previews
            .map(|size| crate::preview::Pictures::beside(&model, size))
            .unwrap_or_default(),
        model: Some(model),
        report: None,
        writing: writing(settings),
        on_error: OnError::DrawPictures,
    }
}

/// Where the daemon may write: its output folder (folders made as needed),
/// or in place the watched folders (as they are when each write opens its
/// folder; never made: a folder moved away mid-solve does not come back).
fn writing(settings: &WatchSettings) -> crate::io::atomic::Writing {
    use crate::io::atomic::{Folders, WriteScope, Writing};
    match &settings.output {
        OutputMode::Folder(dir) => Writing {
            scope: WriteScope::within([settings.cwd.join(dir)]),
            folders: Folders::Make,
        },
        OutputMode::InPlace => Writing {
            scope: WriteScope::within(settings.roots.iter().map(|r| r.folder().to_path_buf())),
            folders: Folders::MustExist,
        },
    }
}

/// In place, only assets inside the watched folders are written.
fn check_in_place_target(settings: &WatchSettings, loaded: &LoadedConstraints, asset_path: &Path) -> Result<(), Error> {
    let inside = settings.roots.iter().any(|r| asset_path.starts_with(r.folder()));
    if settings.output != OutputMode::InPlace || inside {
        return Ok(());
    }
    Err(loaded
        .asset_error(
            "asset",
            format!(
                "in-place mode writes only assets inside the watched folders; {} is outside them",
                display(asset_path, &settings.cwd)
            ),
        )
        .into())
}

/// The files as they are on this machine's disk.
#[derive(Debug, Clone, Copy, Default)]
pub struct RealDisk;

impl Disk for RealDisk {
    fn read_text(&self, path: &Path, rules: &InputRules) -> Result<Vec<u8>, ReadError> {
        crate::io::read::read_regular(path, rules.limits.max_text_bytes, &rules.scope)
    }

    fn asset_hash(&self, files: &[PathBuf], scope: &ReadScope) -> Result<u64, ReadError> {
        super::assets::current_hash(files, scope)
    }

    fn read_asset(&self, path: &Path, selection: &AssetSelection, rules: &InputRules) -> Result<ReadAsset, AssetError> {
        super::assets::read_asset(path, selection, rules)
    }

    fn is_file(&self, path: &Path) -> bool {
        path.is_file()
    }

    fn is_dir(&self, path: &Path) -> bool {
        path.is_dir()
    }

    fn scan(&self, dir: &Path, rules: &FileRules) -> (Vec<PathBuf>, Vec<PathBuf>) {
        scan_folder(dir, rules)
    }

    fn modified_within(&self, path: &Path, window: Duration) -> bool {
        std::fs::metadata(path)
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age < window)
    }
}

/// Every constraint file and asset file under `dir` (recursively; hidden
/// folders skipped, symbolic links not followed).
pub fn scan_folder(dir: &Path, rules: &FileRules) -> (Vec<PathBuf>, Vec<PathBuf>) {
    let (mut constraints, mut assets) = (Vec::new(), Vec::new());
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for entry in entries.flatten() {
            let path = entry.path();
            let Ok(kind) = entry.file_type() else { continue };
            let hidden = entry.file_name().to_string_lossy().starts_with('.');
            if kind.is_dir() && !hidden {
                stack.push(path);
            } else if rules.is_constraint_file(&path) {
                constraints.push(path);
            } else if rules.is_asset_file(&path) {
                assets.push(path);
            }
        }
    }
    constraints.sort();
    assets.sort();
    (constraints, assets)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    /// Files in memory: bytes by path, and which were written just now.
    #[derive(Default)]
    struct FakeDisk {
        files: HashMap<PathBuf, Vec<u8>>,
        recent: HashSet<PathBuf>,
    }

    fn not_found() -> ReadError {
        ReadError::Io(std::io::Error::from(std::io::ErrorKind::NotFound))
    }

    impl Disk for FakeDisk {
        fn read_text(&self, path: &Path, _: &InputRules) -> Result<Vec<u8>, ReadError> {
            self.files.get(path).cloned().ok_or_else(not_found)
        }

        fn asset_hash(&self, files: &[PathBuf], _: &ReadScope) -> Result<u64, ReadError> {
            let bytes = self.files.get(&files[0]).ok_or_else(not_found)?;
            Ok(content_hash(bytes))
        }

        fn read_asset(&self, path: &Path, _: &AssetSelection, _: &InputRules) -> Result<ReadAsset, AssetError> {
            let hash = self.asset_hash(&[path.to_path_buf()], &ReadScope::Anywhere);
            let hash = hash.map_err(|source| AssetError::Read {
                path: path.to_path_buf(),
                source,
            })?;
            let mut asset = SourceAsset::from_mesh(&crate::testing::grid_mesh(4, 4));
            asset.path = path.to_path_buf();
            Ok(ReadAsset {
                asset: Arc::new(asset),
                hash,
            })
        }

        fn is_file(&self, path: &Path) -> bool {
            self.files.contains_key(path)
        }

        fn is_dir(&self, _: &Path) -> bool {
            false
        }

        fn scan(&self, dir: &Path, rules: &FileRules) -> (Vec<PathBuf>, Vec<PathBuf>) {
            let mut inside: Vec<PathBuf> = self.files.keys().filter(|p| p.starts_with(dir)).cloned().collect();
            inside.sort();
            inside.into_iter().partition(|p| rules.is_constraint_file(p))
        }

        fn modified_within(&self, path: &Path, _: Duration) -> bool {
            self.recent.contains(path)
        }
    }

    fn settings(output: OutputMode) -> WatchSettings {
        WatchSettings {
            input: InputRules::default(),
            settle: Duration::from_millis(100),
            roots: vec![WatchRoot {
                path: "/w".into(),
                single_file: false,
            }],
            output,
            rules: FileRules {
                constraint_suffix: ".uvpin.ron".into(),
                own: Vec::new(),
            },
            defaults: SolverOptions::DEFAULT,
            cwd: "/".into(),
            previews: None,
        }
    }

    fn ron(asset: &str, u: f64) -> Vec<u8> {
        format!("(asset: \"{asset}\", constraints: [(vertex: 6, uv: ({u}, 0.5))])").into_bytes()
    }

    fn changed(path: &str) -> Vec<FileEvent> {
        vec![FileEvent::ConstraintsChanged(path.into())]
    }

    /// The actions in short: kind and file.
    fn kinds(actions: &[Action]) -> Vec<String> {
        actions
            .iter()
            .map(|a| match a {
                Action::Solve { file, .. } => format!("solve {}", file.display()),
                Action::Fail { file, error } => format!("fail {}: {error}", file.display()),
                Action::Stop { file, .. } => format!("stop {}", file.display()),
                Action::Restore { file, status } => format!("restore {} {status:?}", file.display()),
                Action::Removed { file } => format!("removed {}", file.display()),
                Action::Back { file, state } => format!("back {} {state:?}", file.display()),
                Action::Recheck { file, after } => format!("recheck {} {after:?}", file.display()),
                Action::Watch { folder } => format!("watch {}", folder.display()),
            })
            .collect()
    }

    fn disk_with(files: &[(&str, Vec<u8>)]) -> FakeDisk {
        FakeDisk {
            files: files.iter().map(|(p, b)| (PathBuf::from(p), b.clone())).collect(),
            ..FakeDisk::default()
        }
    }

    #[test]
    fn only_a_content_change_solves() {
        let s = settings(OutputMode::Folder("/out".into()));
        let mut disk = disk_with(&[("/w/a.uvpin.ron", ron("m.glb", 0.4)), ("/w/m.glb", b"v1".to_vec())]);
        let mut r = Registry::default();
        assert_eq!(
            kinds(&r.on_events(&changed("/w/a.uvpin.ron"), &s, &disk)),
            ["solve /w/a.uvpin.ron"]
        );
        assert!(r.on_events(&changed("/w/a.uvpin.ron"), &s, &disk).is_empty());
        assert_eq!(r.counters.unchanged, 1);
        disk.files.insert("/w/a.uvpin.ron".into(), ron("m.glb", 0.45));
        let actions = r.on_events(&changed("/w/a.uvpin.ron"), &s, &disk);
        let Action::Solve { outputs, asset, .. } = &actions[0] else {
            panic!("{:?}", kinds(&actions))
        };
        assert_eq!(outputs.model.as_deref(), Some(Path::new("/out/a.glb")));
        assert_eq!(asset.path, Path::new("/w/m.glb"), "the cached asset");
        // Two events for one file in one batch: one read.
        let twice = [changed("/w/a.uvpin.ron"), changed("/w/a.uvpin.ron")].concat();
        assert!(r.on_events(&twice, &s, &disk).is_empty());
    }

    #[test]
    fn a_half_written_file_is_read_again_once_it_has_rested() {
        let s = settings(OutputMode::Folder("/out".into()));
        let mut disk = disk_with(&[
            ("/w/a.uvpin.ron", b"(asset: \"m.gl".to_vec()),
            ("/w/m.glb", b"v1".to_vec()),
        ]);
        disk.recent.insert("/w/a.uvpin.ron".into());
        let mut r = Registry::default();
        let actions = r.on_events(&changed("/w/a.uvpin.ron"), &s, &disk);
        assert_eq!(kinds(&actions), ["recheck /w/a.uvpin.ron 100ms"]);
        assert_eq!(r.files[Path::new("/w/a.uvpin.ron")].hash, None, "not taken as seen");
        disk.recent.clear();
        let actions = r.on_events(&changed("/w/a.uvpin.ron"), &s, &disk);
        assert!(
            kinds(&actions)[0].starts_with("fail /w/a.uvpin.ron"),
            "{:?}",
            kinds(&actions)
        );
    }

    #[test]
    fn an_asset_removed_stops_its_files_and_back_unchanged_restores_them() {
        let s = settings(OutputMode::Folder("/out".into()));
        let mut disk = disk_with(&[("/w/a.uvpin.ron", ron("m.glb", 0.4)), ("/w/m.glb", b"v1".to_vec())]);
        let mut r = Registry::default();
        r.on_events(&changed("/w/a.uvpin.ron"), &s, &disk);
        let written = Outcome::Exported {
            status: Status::Reached,
            output: Some("/out/a.glb".into()),
        };
        r.on_outcome(Path::new("/w/a.uvpin.ron"), &written, &s, &disk);
        let asset_event = vec![FileEvent::AssetChanged("/w/m.glb".into())];
        disk.files.remove(Path::new("/w/m.glb"));
        assert_eq!(kinds(&r.on_events(&asset_event, &s, &disk)), ["stop /w/a.uvpin.ron"]);
        assert!(r.on_events(&asset_event, &s, &disk).is_empty(), "already gone");
        disk.files.insert("/w/m.glb".into(), b"v1".to_vec());
        let actions = r.on_events(&asset_event, &s, &disk);
        assert_eq!(kinds(&actions), ["restore /w/a.uvpin.ron Reached"]);
        disk.files.insert("/w/m.glb".into(), b"v2".to_vec());
        assert_eq!(kinds(&r.on_events(&asset_event, &s, &disk)), ["solve /w/a.uvpin.ron"]);
    }

    #[test]
    fn in_place_writes_only_assets_inside_one_file_each_and_ignores_its_own_writes() {
        let s = settings(OutputMode::InPlace);
        let mut disk = disk_with(&[
            ("/w/a.uvpin.ron", ron("m.glb", 0.4)),
            ("/w/b.uvpin.ron", ron("m.glb", 0.3)),
            ("/w/c.uvpin.ron", ron("../elsewhere/n.glb", 0.3)),
            ("/w/m.glb", b"v1".to_vec()),
        ]);
        let mut r = Registry::default();
        let events = [
            changed("/w/a.uvpin.ron"),
            changed("/w/b.uvpin.ron"),
            changed("/w/c.uvpin.ron"),
        ]
        .concat();
        let got = kinds(&r.on_events(&events, &s, &disk));
        assert_eq!(got[0], "solve /w/a.uvpin.ron");
        assert!(
            got[1].starts_with("fail /w/b.uvpin.ron") && got[1].contains("already written by"),
            "{got:?}"
        );
        assert_eq!(got[2], "watch /elsewhere");
        assert!(
            got[3].starts_with("fail /w/c.uvpin.ron") && got[3].contains("outside them"),
            "{got:?}"
        );
        // The daemon writes the asset: that write is not an edit.
        disk.files.insert("/w/m.glb".into(), b"v1 with new UVs".to_vec());
        let written = Outcome::Exported {
            status: Status::Reached,
            output: Some("/w/m.glb".into()),
        };
        r.on_outcome(Path::new("/w/a.uvpin.ron"), &written, &s, &disk);
        let asset_event = vec![FileEvent::AssetChanged("/w/m.glb".into())];
        assert!(r.on_events(&asset_event, &s, &disk).is_empty());
        // A removed constraint file keeps its output; back unchanged, its state returns.
        let text = disk.files.remove(Path::new("/w/a.uvpin.ron")).unwrap();
        assert_eq!(
            kinds(&r.on_events(&changed("/w/a.uvpin.ron"), &s, &disk)),
            ["removed /w/a.uvpin.ron"]
        );
        disk.files.insert("/w/a.uvpin.ron".into(), text);
        let back = kinds(&r.on_events(&changed("/w/a.uvpin.ron"), &s, &disk));
        assert_eq!(back, ["back /w/a.uvpin.ron Reached"]);
    }
}
