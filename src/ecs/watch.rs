//! The daemon's side of the ECS (`uvpin watch`). File events arrive as
//! [`FileChanged`] messages; [`ingest_file_events`] turns them into chart
//! entities (one per constraint file) and decides what the solve systems
//! redo; [`report_results`] logs each result and keeps the status file.
//!
//! Incremental rules, all keyed by content hashes:
//! - a constraint file whose content did not change does nothing;
//! - a constraint edit on the same asset reuses the weld, the chart topology
//!   and hole fill, the bar-net factorisation and, when the corners are the
//!   same, the step-1 layout: only the spline path (and completion) run;
//! - an asset edit redoes everything for every constraint file that names it;
//! - the daemon's own writes (in-place mode) are recognised by hash and ignored.
//!
//! A new edit replaces the entity's solve state at once, so a running solve
//! of older content is dropped and never written.

use super::components::*;
use super::{SolveSystems, solve_schedule};
use crate::config::OutputMode;
use crate::constraints::LoadedConstraints;
use crate::error::Error;
use crate::options::SolverOptions;
use crate::report::Status;
use crate::session::{ChartSession, Kept};
use crate::watch::events::{FileEvent, FileRules};
use crate::watch::log::Logger;
use crate::watch::registry::{self, AssetCache, AssetSelection, WatchRoot, content_hash, display, normalize};
use crate::watch::status::{FileState, LastSolve, StatusBoard};
use bevy_ecs::message::Messages;
use bevy_ecs::prelude::*;
use serde_json::json;
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// A file event from the watcher (or the start-up scan).
#[derive(Message, Debug, Clone)]
pub struct FileChanged(pub FileEvent);

/// What the daemon watches and where it writes.
#[derive(Resource, Debug, Clone)]
pub struct WatchSettings {
    /// What input may be read: the limits, and only inside the watched
    /// folders and the configuration's `allow_paths`.
    pub input: crate::io::InputRules,
    /// How long a constraint file must have rested before a parse error
    /// counts (a burst of saves can be read half-written): the debounce.
    pub settle: std::time::Duration,
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

/// Counts of what the incremental rules decided (for tests and the log).
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

/// The daemon's memory between ticks.
#[derive(Resource, Debug, Default)]
pub struct WatchRegistry {
    /// Constraint file → its chart entity.
    pub files: BTreeMap<PathBuf, Entity>,
    pub assets: AssetCache,
    /// Hash of each file the daemon wrote that is also an input (in-place mode).
    pub written: HashMap<PathBuf, u64>,
    /// Folders of assets outside every watched root; the daemon watches them too.
    pub asset_folders: BTreeSet<PathBuf>,
    /// Constraint files to read again at these times: they failed to parse
    /// while still being written (a burst of saves).
    pub rechecks: Vec<(Instant, PathBuf)>,
    pub counters: WatchCounters,
}

/// The log and the status file.
#[derive(Resource, Debug)]
pub struct DaemonLog {
    pub logger: Logger,
    pub status: StatusBoard,
    /// Whether to write the status file (off in ECS tests).
    pub write_status: bool,
    /// The last status-file write error, logged once.
    pub status_error: Option<String>,
}

/// A constraint file watched by the daemon.
#[derive(Component, Debug, Clone)]
pub struct WatchedFile {
    pub path: PathBuf,
    /// Hash of the content last acted on.
    pub hash: Option<u64>,
    /// The asset named by the last parsed content.
    pub asset_path: Option<PathBuf>,
    /// The file is gone (its last output is kept).
    pub removed: bool,
}

/// The schedule of the daemon: file ingestion, the solve systems, then logging
/// and the status file.
pub fn watch_schedule() -> Schedule {
    let mut schedule = solve_schedule();
    schedule.add_systems(ingest_file_events.before(SolveSystems::Unwrap));
    schedule.add_systems((report_results, write_status_file).chain().after(SolveSystems::Export));
    schedule
}

/// Inserts the daemon's resources into `world`.
pub fn init_watch_world(world: &mut World, settings: WatchSettings, log: DaemonLog) {
    world.init_resource::<Messages<FileChanged>>();
    world.insert_resource(settings);
    world.insert_resource(log);
    world.init_resource::<WatchRegistry>();
}

/// Whether any chart is still being solved.
pub fn is_busy(world: &mut World) -> bool {
    let mut working = world.query_filtered::<(), (With<SolveJob>, Without<Exported>, Without<Failed>)>();
    working.iter(world).next().is_some()
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

/// Applies this tick's file events (exclusive system).
pub fn ingest_file_events(world: &mut World) {
    let events: Vec<FileEvent> = world
        .resource_mut::<Messages<FileChanged>>()
        .drain()
        .map(|m| m.0)
        .collect();
    if events.is_empty() {
        return;
    }
    let settings = world.resource::<WatchSettings>().clone();
    // Constraint files to (re)load; `true` forces a reload of unchanged content.
    let mut to_load: BTreeMap<PathBuf, bool> = BTreeMap::new();
    let mut seen = HashSet::new();
    for event in events {
        if !seen.insert(event.clone()) {
            continue;
        }
        match event {
            FileEvent::ConstraintsChanged(p) => {
                to_load.entry(p).or_insert(false);
            }
            FileEvent::AssetChanged(p) => asset_changed(world, &p, &mut to_load),
            FileEvent::Removed(p) => {
                let known: Vec<PathBuf> = world
                    .resource::<WatchRegistry>()
                    .files
                    .keys()
                    .filter(|f| f.starts_with(&p))
                    .cloned()
                    .collect();
                for f in known {
                    to_load.entry(f).or_insert(false);
                }
                let assets: Vec<PathBuf> = world
                    .resource::<WatchRegistry>()
                    .assets
                    .assets
                    .keys()
                    .filter(|a| a.starts_with(&p))
                    .cloned()
                    .collect();
                asset_changed(world, &p, &mut to_load);
                for a in assets.into_iter().filter(|a| *a != p) {
                    asset_changed(world, &a, &mut to_load);
                }
            }
            FileEvent::FolderAppeared(dir) => {
                let (constraints, assets) = scan_folder(&dir, &settings.rules);
                for a in assets {
                    asset_changed(world, &a, &mut to_load);
                }
                for c in constraints {
                    to_load.entry(c).or_insert(false);
                }
            }
            FileEvent::Rescan => {
                let cached: Vec<PathBuf> = world
                    .resource::<WatchRegistry>()
                    .assets
                    .assets
                    .keys()
                    .cloned()
                    .collect();
                for a in cached {
                    asset_changed(world, &a, &mut to_load);
                }
                let known: Vec<PathBuf> = world.resource::<WatchRegistry>().files.keys().cloned().collect();
                for f in known {
                    to_load.entry(f).or_insert(false);
                }
                for root in &settings.roots {
                    let (constraints, _) = scan_folder(root.folder(), &settings.rules);
                    for c in constraints.into_iter().filter(|c| root.contains(c)) {
                        to_load.entry(c).or_insert(false);
                    }
                }
            }
        }
    }
    for (path, force) in to_load {
        load_constraint_file(world, &settings, &path, force);
    }
}

/// Constraint files (entities) whose last parsed content names `asset`.
fn dependants(world: &mut World, asset: &Path) -> Vec<Entity> {
    let mut q = world.query::<(Entity, &WatchedFile)>();
    q.iter(world)
        .filter(|(_, w)| !w.removed && w.asset_path.as_deref() == Some(asset))
        .map(|(e, _)| e)
        .collect()
}

/// Marks the cached `asset` as removed from (or back on) disk.
fn set_missing(world: &mut World, asset: &Path, missing: bool) {
    if let Some(entry) = world.resource_mut::<WatchRegistry>().assets.assets.get_mut(asset) {
        entry.missing = missing;
    }
}

/// What the daemon writes for one constraint file: the asset as `model`,
/// and its pictures beside it when asked; all in one commit, the pictures
/// also of a refused layout.
fn outputs(settings: &WatchSettings, model: PathBuf) -> crate::export::Outputs {
    crate::export::Outputs {
        #[cfg(feature = "pictures")]
        pictures: settings
            .previews
            .map(|size| crate::preview::Pictures::beside(&model, size))
            .unwrap_or_default(),
        model: Some(model),
        report: None,
        writing: writing(settings),
        on_error: crate::export::OnError::DrawPictures,
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

/// An asset file (or a buffer of one) was written, created or removed.
fn asset_changed(world: &mut World, file: &Path, to_load: &mut BTreeMap<PathBuf, bool>) {
    let cached = world.resource::<WatchRegistry>().assets.assets_using(file);
    for asset in &cached {
        let registry = world.resource::<WatchRegistry>();
        let entry = &registry.assets.assets[asset];
        let now = AssetCache::current_hash(&entry.files, &world.resource::<WatchSettings>().input.scope);
        let (was_missing, old_hash) = (entry.missing, entry.hash);
        let written = registry.written.get(asset).copied();
        match now {
            Err(read) => {
                if was_missing {
                    continue;
                }
                set_missing(world, asset, true);
                // Removed, or there and unreadable (permissions, a FIFO, too
                // large): the log says which.
                let why = if read.is_not_found() {
                    "the asset was removed; the last output is kept".to_string()
                } else {
                    format!("the asset cannot be read ({read}); the last output is kept")
                };
                for e in dependants(world, asset) {
                    let err = Error::Asset(crate::io::AssetError::Read {
                        path: asset.clone(),
                        source: crate::io::ReadError::Io(std::io::Error::other(why.clone())),
                    });
                    asset_gone(world, e, err);
                }
            }
            Ok(h) if h == old_hash || Some(h) == written => {
                world.resource_mut::<WatchRegistry>().counters.unchanged += 1;
                if was_missing {
                    set_missing(world, asset, false);
                    for e in dependants(world, asset) {
                        asset_back_unchanged(world, e, to_load);
                    }
                }
            }
            Ok(_) => {
                world.resource_mut::<WatchRegistry>().assets.assets.remove(asset);
                for e in dependants(world, asset) {
                    let path = world.get::<WatchedFile>(e).expect("watched").path.clone();
                    to_load.insert(path, true);
                }
            }
        }
    }
    // Constraint files waiting for an asset that failed to load (missing,
    // corrupt, or a missing .bin beside it): retry them.
    let is_buffer = file.extension().is_some_and(|e| e.eq_ignore_ascii_case("bin"));
    let mut q = world.query::<(&WatchedFile, Has<Failed>)>();
    let waiting: Vec<PathBuf> = q
        .iter(world)
        .filter(|(w, failed)| {
            *failed
                && !w.removed
                && w.asset_path.as_deref().is_some_and(|a| {
                    !cached.iter().any(|c| c == a)
                        && (a == file || (is_buffer && a.parent() == file.parent()) || a.starts_with(file))
                })
        })
        .map(|(w, _)| w.path.clone())
        .collect();
    for p in waiting {
        to_load.insert(p, true);
    }
}

/// The asset of `entity` was removed: a running solve stops; a finished
/// one keeps its result (the last output stays), so that an identical
/// re-creation needs no new solve.
fn asset_gone(world: &mut World, entity: Entity, err: Error) {
    let mut e = world.entity_mut(entity);
    if e.get::<Exported>().is_none() {
        e.remove::<(Finished, Candidate)>();
    }
    e.insert(Failed(Arc::new(err)));
}

/// The asset of `entity` is back with the content it had: its last result
/// stands again (nothing to solve), or, if its solve was cut short, it is
/// solved again.
fn asset_back_unchanged(world: &mut World, entity: Entity, to_load: &mut BTreeMap<PathBuf, bool>) {
    if world.get::<Failed>(entity).is_none() {
        return;
    }
    let path = world.get::<WatchedFile>(entity).expect("watched").path.clone();
    let Some(status) = world.get::<Exported>(entity).map(|e| e.0.status) else {
        to_load.insert(path, true);
        return;
    };
    world.entity_mut(entity).remove::<Failed>();
    let settings = world.resource::<WatchSettings>();
    let name = display(&path, &settings.cwd);
    let mut log = world.resource_mut::<DaemonLog>();
    log.logger.info(
        "unchanged",
        Some(&name),
        "the asset is back unchanged; its last result stands",
        json!({}),
    );
    let entry = log.status.entry(&name);
    entry.state = FileState::of(status);
    entry.last_error = None;
}

/// Marks `entity` failed: a running solve stops and nothing is written.
fn fail(world: &mut World, entity: Entity, err: Error) {
    world
        .entity_mut(entity)
        .remove::<(Finished, Exported, Candidate)>()
        .insert(Failed(Arc::new(err)));
}

/// The constraint file is gone: its last output is kept, a running solve stops.
fn constraint_removed(world: &mut World, settings: &WatchSettings, entity: Entity) {
    let mut w = world.get_mut::<WatchedFile>(entity).expect("watched");
    if w.removed {
        return;
    }
    w.removed = true;
    let name = display(&w.path, &settings.cwd);
    if world.get::<SolveJob>(entity).is_some() && world.get::<Exported>(entity).is_none() {
        fail(world, entity, Error::Internal("constraint file removed".into()));
    }
    let mut log = world.resource_mut::<DaemonLog>();
    log.logger
        .info("removed", Some(&name), "removed; its last output is kept", json!({}));
    log.status.entry(&name).state = FileState::Removed;
}

/// Reads one constraint file and (re)starts its solve if its content changed
/// (or `force`), reusing whatever the previous solve of the same asset left.
fn load_constraint_file(world: &mut World, settings: &WatchSettings, path: &Path, force: bool) {
    let Some(root) = registry::root_of(&settings.roots, path).filter(|_| settings.rules.is_constraint_file(path))
    else {
        return;
    };
    let root = root.clone();
    let Some(entity) = watched_entity(world, path) else {
        return;
    };
    let Some(text) = read_if_changed(world, settings, entity, path, force) else {
        return;
    };
    let t0 = Instant::now();
    let loaded = match LoadedConstraints::parse_with_defaults(path, &text, &settings.defaults) {
        Ok(l) => l,
        Err(crate::constraints::ConstraintFileError::Syntax(_)) if still_being_written(path, settings.settle) => {
            return recheck_later(world, settings, entity, path);
        }
        Err(e) => return fail(world, entity, e.into()),
    };
    let asset_path = normalize(&loaded.asset_path(), &settings.cwd);
    note_asset(world, settings, entity, &asset_path);
    if let Err(e) = check_in_place_target(settings, &loaded, &asset_path) {
        return fail(world, entity, e);
    }
    let asset = match load_asset(world, settings, &loaded, &asset_path) {
        Ok(a) => a,
        Err(e) => return fail(world, entity, e),
    };
    let output = registry::output_path(
        &settings.output,
        &root,
        path,
        &settings.rules.constraint_suffix,
        &asset_path,
        &settings.cwd,
    );
    if let Err(e) = check_single_writer(world, settings, entity, &loaded, &output) {
        return fail(world, entity, e);
    }
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let job = SolveJob::from_file(loaded, asset, None).writing(outputs(settings, output));
    if let Err(e) = restart_solve(world, settings, entity, job, load_ms) {
        fail(world, entity, e);
    }
}

/// The entity of a constraint file, spawned when first seen (if it is a file).
fn watched_entity(world: &mut World, path: &Path) -> Option<Entity> {
    if let Some(&e) = world.resource::<WatchRegistry>().files.get(path) {
        return Some(e);
    }
    if !path.is_file() {
        return None;
    }
    let e = world
        .spawn(WatchedFile {
            path: path.to_path_buf(),
            hash: None,
            asset_path: None,
            removed: false,
        })
        .id();
    world
        .resource_mut::<WatchRegistry>()
        .files
        .insert(path.to_path_buf(), e);
    Some(e)
}

/// The file's text when its content changed since it was last acted on (or
/// `force`); `None` when there is nothing to do (unchanged, removed, or
/// unreadable: then the entity is marked).
fn read_if_changed(
    world: &mut World,
    settings: &WatchSettings,
    entity: Entity,
    path: &Path,
    force: bool,
) -> Option<String> {
    let limit = settings.input.limits.max_text_bytes;
    let bytes = match crate::io::read::read_regular(path, limit, &settings.input.scope) {
        Ok(b) => b,
        Err(e) if e.is_not_found() || path.is_dir() => {
            constraint_removed(world, settings, entity);
            return None;
        }
        Err(source) => {
            let err = crate::constraints::ConstraintFileError::Read {
                path: path.to_path_buf(),
                source,
            };
            world.get_mut::<WatchedFile>(entity).expect("watched").hash = None;
            fail(world, entity, err.into());
            return None;
        }
    };
    let hash = content_hash(&bytes);
    let watched = world.get::<WatchedFile>(entity).expect("watched").clone();
    if watched.hash == Some(hash) && !force && !(world.get::<Failed>(entity).is_some() && watched.removed) {
        unchanged(world, settings, entity, &watched);
        return None;
    }
    {
        let mut w = world.get_mut::<WatchedFile>(entity).expect("watched");
        w.hash = Some(hash);
        w.removed = false;
    }
    match String::from_utf8(bytes) {
        Ok(t) => Some(t),
        Err(e) => {
            let err = crate::constraints::ConstraintFileError::NotUtf8 {
                path: path.to_path_buf(),
                at: e.utf8_error().valid_up_to(),
            };
            fail(world, entity, err.into());
            None
        }
    }
}

/// The same content again: nothing to solve. A file back with the content
/// it had before it was removed (an editor's delete + recreate) gets its
/// last state back.
fn unchanged(world: &mut World, settings: &WatchSettings, entity: Entity, watched: &WatchedFile) {
    world.get_mut::<WatchedFile>(entity).expect("watched").removed = false;
    if watched.removed {
        let state = world
            .get::<Exported>(entity)
            .map_or(FileState::Error, |e| FileState::of(e.0.status));
        let name = display(&watched.path, &settings.cwd);
        world.resource_mut::<DaemonLog>().status.entry(&name).state = state;
    }
    world.resource_mut::<WatchRegistry>().counters.unchanged += 1;
}

/// Whether `path` was modified less than `settle` ago (a save may still be
/// writing it; RON that does not parse yet may be half-written).
fn still_being_written(path: &Path, settle: std::time::Duration) -> bool {
    std::fs::metadata(path)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age < settle)
}

/// A constraint file that does not parse yet while it is still being
/// written: read again once it has rested (its content is not taken as seen).
fn recheck_later(world: &mut World, settings: &WatchSettings, entity: Entity, path: &Path) {
    world.get_mut::<WatchedFile>(entity).expect("watched").hash = None;
    let due = Instant::now() + settings.settle;
    world
        .resource_mut::<WatchRegistry>()
        .rechecks
        .push((due, path.to_path_buf()));
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

/// Remembers the asset the file names, and its folder when no watched root covers it.
fn note_asset(world: &mut World, settings: &WatchSettings, entity: Entity, asset_path: &Path) {
    world.get_mut::<WatchedFile>(entity).expect("watched").asset_path = Some(asset_path.to_path_buf());
    if let Some(folder) = asset_path.parent()
        && !settings
            .roots
            .iter()
            .any(|r| !r.single_file && folder.starts_with(&r.path))
    {
        world
            .resource_mut::<WatchRegistry>()
            .asset_folders
            .insert(folder.to_path_buf());
    }
}

/// The asset, from the cache when its content is unchanged.
fn load_asset(
    world: &mut World,
    settings: &WatchSettings,
    loaded: &LoadedConstraints,
    asset_path: &Path,
) -> Result<Arc<crate::io::SourceAsset>, Error> {
    let selection = AssetSelection {
        mesh: loaded.file.mesh.clone(),
        uv_set: loaded.file.uv_set,
    };
    let mut registry = world.resource_mut::<WatchRegistry>();
    match registry.assets.load(asset_path, &selection, &settings.input) {
        Ok(a) => Ok(a),
        Err(crate::io::AssetError::Read { source, .. }) if source.is_not_found() => Err(loaded
            .asset_error(
                "asset",
                format!("{} does not exist", display(asset_path, &settings.cwd)),
            )
            .into()),
        Err(e) => Err(e.into()),
    }
}

/// In place, one constraint file per asset: another file writing `output` is an error.
fn check_single_writer(
    world: &mut World,
    settings: &WatchSettings,
    entity: Entity,
    loaded: &LoadedConstraints,
    output: &Path,
) -> Result<(), Error> {
    if settings.output != OutputMode::InPlace {
        return Ok(());
    }
    let mut q = world.query::<(Entity, &WatchedFile, &SolveJob)>();
    let other = q
        .iter(world)
        .find(|(e, w, j)| *e != entity && !w.removed && j.output() == Some(output))
        .map(|(_, w, _)| display(&w.path, &settings.cwd));
    match other {
        None => Ok(()),
        Some(other) => Err(loaded
            .asset_error(
                "asset",
                format!(
                    "in-place mode: {} is already written by {other}; one constraint file per asset",
                    display(output, &settings.cwd)
                ),
            )
            .into()),
    }
}

/// How much of the previous solve a new job keeps, in the log's words.
fn kept_words(kept: Option<Kept>) -> &'static str {
    match kept {
        None | Some(Kept::Weld) => "from scratch",
        Some(Kept::Geometry) => "reusing the chart and its factorisation",
        Some(Kept::StepOne) => "reusing the step-1 layout",
    }
}

/// Gives the entity `job`: its chart session retargeted when the asset is
/// the same (keeping what still applies), else opened anew; a running
/// solve is dropped. Logs the start.
fn restart_solve(
    world: &mut World,
    settings: &WatchSettings,
    entity: Entity,
    job: SolveJob,
    load_ms: f64,
) -> Result<(), Error> {
    let same_asset = world
        .get::<SolveJob>(entity)
        .is_some_and(|j| Arc::ptr_eq(&j.asset, &job.asset));
    let superseded = world.get::<SolveJob>(entity).is_some()
        && world.get::<Exported>(entity).is_none()
        && world.get::<Failed>(entity).is_none();
    let kept = match world.get_mut::<Session>(entity).filter(|_| same_asset) {
        Some(mut session) => Some(session.0.retarget(job.source.clone(), load_ms)?),
        None => {
            let session = ChartSession::open(job.source.clone(), job.asset.clone(), load_ms)?;
            world.entity_mut(entity).insert(Session(session));
            None
        }
    };
    let n_constraints = world
        .get::<Session>(entity)
        .map_or(0, |s| s.0.prepared().constraints.len());
    let asset_name = display(&job.asset.path, &settings.cwd);
    world
        .entity_mut(entity)
        .remove::<(Solver, Candidate, Finished, Exported, Failed)>()
        .insert(job);
    log_start(world, settings, entity, (n_constraints, kept, superseded), &asset_name);
    Ok(())
}

/// Counts and logs a solve's start; the status board says it is solving.
fn log_start(
    world: &mut World,
    settings: &WatchSettings,
    entity: Entity,
    (n_constraints, kept, superseded): (usize, Option<Kept>, bool),
    asset_name: &str,
) {
    let name = display(&world.get::<WatchedFile>(entity).expect("watched").path, &settings.cwd);
    let mut registry = world.resource_mut::<WatchRegistry>();
    registry.counters.solves_started += 1;
    let (geometry, step_one) = match kept {
        None | Some(Kept::Weld) => (false, false),
        Some(Kept::Geometry) => (true, false),
        Some(Kept::StepOne) => (true, true),
    };
    registry.counters.geometry_reused += u64::from(geometry);
    registry.counters.step1_reused += u64::from(step_one);
    let mut log = world.resource_mut::<DaemonLog>();
    let message = format!(
        "solving {n_constraints} constraints, {}{}",
        kept_words(kept),
        if superseded {
            " (supersedes the running solve)"
        } else {
            ""
        }
    );
    log.logger.info(
        "solving",
        Some(&name),
        &message,
        json!({ "constraints": n_constraints, "reuse_geometry": geometry, "reuse_step1": step_one, "superseded": superseded }),
    );
    let entry = log.status.entry(&name);
    entry.state = FileState::Solving;
    entry.asset = Some(asset_name.to_string());
    entry.last_error = None;
}

/// Logs every finished solve and every failure, updates the status board,
/// and remembers the hash of outputs that are also inputs (in-place mode).
pub fn report_results(
    mut log: ResMut<DaemonLog>,
    mut registry: ResMut<WatchRegistry>,
    settings: Res<WatchSettings>,
    exported: Query<(&WatchedFile, &Exported), Changed<Exported>>,
    failed: Query<(&WatchedFile, &Failed), Changed<Failed>>,
) {
    for (watched, Exported(report)) in &exported {
        let name = display(&watched.path, &settings.cwd);
        if report.status == Status::Error {
            let message = report.message.clone().unwrap_or_else(|| "the write failed".into());
            log.logger.error("error", Some(&name), &message, json!({}));
            let entry = log.status.entry(&name);
            entry.state = FileState::Error;
            entry.last_error = Some(message);
            continue;
        }
        if let Some(out) = &report.output {
            let out = PathBuf::from(out);
            let files = registry
                .assets
                .assets
                .get(&out)
                .map_or_else(|| vec![out.clone()], |a| a.files.clone());
            if (registry.assets.assets.contains_key(&out) || settings.output == OutputMode::InPlace)
                && let Ok(h) = AssetCache::current_hash(&files, &settings.input.scope)
            {
                registry.written.insert(out, h);
            }
        }
        let reached = report.constraints.iter().filter(|c| c.reached).count();
        let output = report
            .output
            .as_deref()
            .map(|o| display(Path::new(o), &settings.cwd))
            .unwrap_or_default();
        let status = if report.status == Status::Reached {
            "reached"
        } else {
            "partial"
        };
        let message = format!(
            "{status} {reached}/{} constraints, max residual {:.1e}, {} flipped, stretch {:.3}, {:.1} ms -> {output}",
            report.constraints.len(),
            report.max_residual,
            report.orientation.flipped,
            report.stretch_final.l2,
            report.total_ms,
        );
        log.logger.info(
            "solved",
            Some(&name),
            &message,
            json!({
                "status": status,
                "reached": reached,
                "constraints": report.constraints.len(),
                "max_residual": report.max_residual,
                "flipped": report.orientation.flipped,
                "zero_area": report.orientation.zero_area,
                "stretch_l2": report.stretch_final.l2,
                "time_ms": report.total_ms,
                "times": report.times,
                "output": output,
            }),
        );
        if report.status == Status::Partial
            && let Some(hint) = &report.hint
        {
            log.logger.warn("hint", Some(&name), hint, json!({}));
        }
        let entry = log.status.entry(&name);
        entry.state = if report.status == Status::Reached {
            FileState::Reached
        } else {
            FileState::Partial
        };
        entry.last_error = None;
        let mut last = LastSolve::from_report(report);
        last.output = Some(output);
        entry.last_solve = Some(last);
    }
    for (watched, Failed(err)) in &failed {
        if watched.removed {
            continue;
        }
        let name = display(&watched.path, &settings.cwd);
        let message = err.to_string();
        log.logger.error(
            "error",
            Some(&name),
            &format!("{message} (the last good output is kept)"),
            json!({}),
        );
        let entry = log.status.entry(&name);
        entry.state = FileState::Error;
        entry.last_error = Some(message);
    }
}

/// Rewrites the status file when it changed.
pub fn write_status_file(mut log: ResMut<DaemonLog>) {
    if !log.write_status {
        return;
    }
    match log.status.write_if_dirty() {
        Ok(()) => log.status_error = None,
        Err(e) => {
            let message = format!("cannot write the status file {}: {e}", log.status.path.display());
            if log.status_error.as_deref() != Some(message.as_str()) {
                log.logger.warn("status_file", None, &message, json!({}));
                log.status_error = Some(message);
            }
        }
    }
}
