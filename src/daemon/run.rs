//! The daemon loop: a debounced notify watcher sends [`FileEvent`]s over a
//! crossbeam channel; the loop hands them to the registry
//! ([`charts::handle`]), arms the watches and re-reads it asks for, and
//! runs the watch schedule one tick at a time while there is work, and
//! blocks (no polling) while idle. SIGINT/SIGTERM end it after the tick in
//! progress, so a write in progress is finished.

use super::charts::{self, DaemonLog, WatchRequest, init_watch_world, watch_schedule};
use super::events::{FileEvent, FileRules};
use super::log::Logger;
use super::paths::{WatchRoot, display, normalize};
use super::registry::WatchSettings;
use super::status::{FileState, StatusBoard};
use crate::config::{OutputMode, WatchConfig};
use crate::ecs::is_busy;
use crate::options::SolverOptions;
use anyhow::{Context, bail};
use bevy_ecs::prelude::{Schedule, World};
use crossbeam_channel::{Receiver, select};
use notify::RecursiveMode;
use notify_debouncer_full::{DebounceEventResult, Debouncer, RecommendedCache, new_debouncer};
use serde_json::json;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What `uvpin watch` was asked to do.
#[derive(Debug, Clone)]
pub struct WatchOptions {
    pub config: WatchConfig,
    pub solver: SolverOptions,
    /// How much input is accepted.
    pub limits: crate::io::InputLimits,
    /// Process everything present, print a summary and exit.
    pub once: bool,
}

/// Something served beside the daemon (the landmark editor): it adds its
/// systems and resources to the daemon's world and schedule, and is
/// stopped when the daemon stops.
pub trait Attachment {
    /// Starts it beside the daemon's `world` and `schedule`.
    ///
    /// # Errors
    /// It cannot start (an address in use): the daemon does not start either.
    fn attach(&mut self, world: &mut World, schedule: &mut Schedule, logger: &Logger) -> anyhow::Result<()>;
    /// Stops it once the daemon's loop is over.
    fn stop(&mut self);
}

/// How the daemon ended (its exit code).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Stopped by a signal, or `--once` with every constraint reached: 0.
    Clean,
    /// `--once`: some results partial: 2.
    Partial,
    /// `--once`: some files had errors: 1.
    Errors,
}

impl Outcome {
    pub fn exit_code(self) -> u8 {
        match self {
            Outcome::Clean => 0,
            Outcome::Partial => 2,
            Outcome::Errors => 1,
        }
    }
}

/// The watched roots of `config`, absolute.
fn roots(config: &WatchConfig, rules: &FileRules, cwd: &Path) -> Vec<WatchRoot> {
    config
        .paths
        .iter()
        .map(|p| {
            let path = normalize(p, cwd);
            let single_file = path.is_file() || rules.is_constraint_file(&path);
            WatchRoot { path, single_file }
        })
        .collect()
}

/// The configured sizes must be usable.
fn check_sizes(config: &WatchConfig) -> anyhow::Result<()> {
    let max = crate::preview::MAX_SIZE;
    if config.previews && !(16..=max).contains(&config.preview_size) {
        bail!(
            "preview size {}: must be between 16 and {max} pixels",
            config.preview_size
        );
    }
    if config.debounce_ms > 60_000 {
        bail!("debounce {} ms: at most 60000", config.debounce_ms);
    }
    Ok(())
}

/// Where the daemon may read: the watched folders and `allow_paths`.
fn read_scope(config: &WatchConfig, roots: &[WatchRoot], cwd: &Path) -> crate::io::ReadScope {
    let folders = roots
        .iter()
        .map(|r| r.folder().to_path_buf())
        .chain(config.allow_paths.iter().map(|p| normalize(p, cwd)));
    crate::io::ReadScope::within(folders)
}

/// Removes the temporary files a killed run left in the folders this daemon
/// writes to (the output folder, or the watched folders in place).
fn remove_stale_temporaries(config: &WatchConfig, roots: &[WatchRoot], cwd: &Path, logger: &Logger) {
    let tops: Vec<PathBuf> = match &config.output {
        OutputMode::Folder(dir) => vec![normalize(dir, cwd)],
        OutputMode::InPlace => roots.iter().map(|r| r.folder().to_path_buf()).collect(),
    };
    let mut removed = 0;
    let mut stack = tops;
    while let Some(dir) = stack.pop() {
        removed += crate::io::atomic::remove_stale_temporaries(&dir);
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        stack.extend(
            entries
                .flatten()
                .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
                .map(|e| e.path()),
        );
    }
    if removed > 0 {
        let message = format!("removed {removed} temporary files an interrupted run left behind");
        logger.info("cleanup", None, &message, json!({ "removed": removed }));
    }
}

/// The event that makes the ECS scan an existing root.
fn scan_event(root: &WatchRoot) -> FileEvent {
    if root.single_file {
        FileEvent::ConstraintsChanged(root.path.clone())
    } else {
        FileEvent::FolderAppeared(root.path.clone())
    }
}

/// Runs `uvpin watch`, with `attachments` served beside it.
///
/// # Errors
/// Only start-up failures (no working directory, the watcher cannot start,
/// the signal handler cannot be set, an attachment cannot start). Everything
/// later is logged.
pub fn run(options: WatchOptions, mut attachments: Vec<Box<dyn Attachment>>) -> anyhow::Result<Outcome> {
    let cwd = std::env::current_dir()
        .and_then(|d| d.canonicalize())
        .context("cannot read the working directory")?;
    let config = &options.config;
    let status_path = normalize(&config.status_path(), &cwd);
    let rules = FileRules {
        constraint_suffix: config.constraint_suffix.clone(),
        own: vec![status_path.clone()],
    };
    let roots = roots(config, &rules, &cwd);
    if roots.is_empty() {
        bail!("nothing to watch: give a folder or a constraint file, or set watch.paths in the configuration");
    }
    check_sizes(config)?;
    let logger = Logger { format: config.log };
    remove_stale_temporaries(config, &roots, &cwd, &logger);
    let mut world = World::new();
    init_watch_world(
        &mut world,
        WatchSettings {
            input: crate::io::InputRules {
                limits: options.limits,
                scope: read_scope(config, &roots, &cwd),
            },
            // With --once nothing is read again later: no waiting for a save to settle.
            settle: Duration::from_millis(if options.once { 0 } else { config.debounce_ms.max(1) }),
            roots: roots.clone(),
            output: config.output.clone(),
            rules: rules.clone(),
            defaults: options.solver,
            cwd: cwd.clone(),
            previews: config.previews.then_some(config.preview_size),
        },
        DaemonLog {
            logger: logger.clone(),
            status: StatusBoard::new(status_path.clone()),
            write_status: true,
            status_error: None,
        },
    );
    let mut schedule = watch_schedule();
    let output = match &config.output {
        OutputMode::Folder(dir) => format!("{}/", display(&normalize(dir, &cwd), &cwd)),
        OutputMode::InPlace => "in place".into(),
    };
    let names: Vec<String> = roots.iter().map(|r| display(&r.path, &cwd)).collect();
    logger.info(
        "start",
        None,
        &format!(
            "{} {} -> {output}; debounce {} ms; status {}",
            if options.once { "solving" } else { "watching" },
            names.join(", "),
            config.debounce_ms,
            display(&status_path, &cwd)
        ),
        json!({ "paths": names, "output": output, "debounce_ms": config.debounce_ms, "once": options.once }),
    );
    if options.once {
        return Ok(run_once(&mut world, &mut schedule, &roots, &logger, &cwd));
    }
    for attachment in &mut attachments {
        attachment.attach(&mut world, &mut schedule, &logger)?;
    }
    let outcome = run_daemon(&mut world, &mut schedule, roots, config, &rules, &logger, &cwd);
    for attachment in &mut attachments {
        attachment.stop();
    }
    outcome
}

/// `--once`: solve every constraint file present, then summarise.
fn run_once(world: &mut World, schedule: &mut Schedule, roots: &[WatchRoot], logger: &Logger, cwd: &Path) -> Outcome {
    let mut missing = 0;
    let mut events = Vec::new();
    for root in roots {
        if root.path.exists() {
            events.push(scan_event(root));
        } else {
            missing += 1;
            logger.error("error", Some(&display(&root.path, cwd)), "does not exist", json!({}));
        }
    }
    // Nothing is read again later: no re-reads, no more watches.
    charts::handle(world, &events);
    crate::ecs::run_to_convergence(world, schedule, crate::ecs::MAX_TICKS);
    let log = world.resource::<DaemonLog>();
    let count = |s: FileState| log.status.files.values().filter(|f| f.state == s).count();
    let (reached, partial, errors) = (
        count(FileState::Reached),
        count(FileState::Partial),
        count(FileState::Error) + missing,
    );
    let total = log.status.files.len();
    logger.info(
        "summary",
        None,
        &format!("{total} constraint files: {reached} reached, {partial} partial, {errors} errors"),
        json!({ "files": total, "reached": reached, "partial": partial, "errors": errors }),
    );
    if total == 0 && missing == 0 {
        logger.warn("summary", None, "no constraint files found", json!({}));
    }
    if errors > 0 {
        Outcome::Errors
    } else if partial > 0 {
        Outcome::Partial
    } else {
        Outcome::Clean
    }
}

/// The OS watches: armed roots, roots waiting for their folder, extra folders.
struct Watches {
    debouncer: Debouncer<notify::RecommendedWatcher, RecommendedCache>,
    /// Folders watched, and whether recursively.
    watched: HashSet<(PathBuf, bool)>,
    armed: Vec<WatchRoot>,
    pending: Vec<WatchRoot>,
}

impl Watches {
    /// Whether `dir` is already watched: itself, or inside a folder watched recursively.
    fn covers(&self, dir: &Path) -> bool {
        self.watched
            .iter()
            .any(|(d, recursive)| d == dir || (*recursive && dir.starts_with(d)))
    }

    fn watch(&mut self, dir: &Path, recursive: bool, logger: &Logger, cwd: &Path) -> bool {
        if self.watched.contains(&(dir.to_path_buf(), recursive)) {
            return true;
        }
        let mode = if recursive {
            RecursiveMode::Recursive
        } else {
            RecursiveMode::NonRecursive
        };
        match self.debouncer.watch(dir, mode) {
            Ok(()) => {
                self.watched.insert((dir.to_path_buf(), recursive));
                true
            }
            Err(e) => {
                logger.warn(
                    "watch",
                    Some(&display(dir, cwd)),
                    &format!("cannot watch: {e}"),
                    json!({}),
                );
                false
            }
        }
    }

    /// Watches an asset's folder outside every watched one, if it exists;
    /// whether it is watched now.
    fn watch_asset_folder(&mut self, folder: &Path, logger: &Logger, cwd: &Path) -> bool {
        let covered = self.covers(folder);
        if !(folder.is_dir() && self.watch(folder, false, logger, cwd)) {
            return false;
        }
        // Said once it is armed, so a script (or a test) knows edits there are seen.
        if !covered {
            let name = display(folder, cwd);
            logger.info("asset_folder", Some(&name), "watching an asset's folder", json!({}));
        }
        true
    }

    /// Arms `root` if its folder exists (returns the scan event), else
    /// watches its nearest existing ancestor and keeps it pending.
    fn arm(&mut self, root: WatchRoot, logger: &Logger, cwd: &Path) -> Option<FileEvent> {
        if root.folder().is_dir() && self.watch(root.folder(), !root.single_file, logger, cwd) {
            let event = scan_event(&root);
            self.armed.push(root);
            return Some(event);
        }
        if !self.pending.contains(&root) {
            logger.warn(
                "waiting",
                Some(&display(&root.path, cwd)),
                "does not exist yet; it is picked up when it appears",
                json!({}),
            );
            self.pending.push(root.clone());
        }
        self.watch_nearest_ancestor(&root, logger, cwd);
        None
    }

    /// Watches (not recursively) the nearest existing folder above a
    /// pending root, so its creation is seen.
    fn watch_nearest_ancestor(&mut self, root: &WatchRoot, logger: &Logger, cwd: &Path) {
        let mut ancestor = root.folder().to_path_buf();
        while !ancestor.is_dir() && ancestor.pop() {}
        if ancestor.is_dir() {
            self.watch(&ancestor, false, logger, cwd);
        }
    }

    /// Re-checks pending roots and armed roots whose folder vanished.
    fn refresh(&mut self, logger: &Logger, cwd: &Path) -> Vec<FileEvent> {
        let gone: Vec<WatchRoot> = self.armed.iter().filter(|r| !r.folder().is_dir()).cloned().collect();
        for root in gone {
            self.armed.retain(|r| *r != root);
            let dir = root.folder().to_path_buf();
            let recursive = !root.single_file;
            self.watched.remove(&(dir.clone(), recursive));
            let _ = self.debouncer.unwatch(&dir);
            self.arm(root, logger, cwd);
        }
        let pending = std::mem::take(&mut self.pending);
        let mut events = Vec::new();
        for root in pending {
            let was_pending_name = root.path.clone();
            if root.folder().is_dir() {
                if let Some(e) = self.arm(root, logger, cwd) {
                    logger.info(
                        "appeared",
                        Some(&display(&was_pending_name, cwd)),
                        "now watched",
                        json!({}),
                    );
                    events.push(e);
                }
            } else {
                self.watch_nearest_ancestor(&root, logger, cwd);
                self.pending.push(root);
            }
        }
        events
    }
}

fn run_daemon(
    world: &mut World,
    schedule: &mut Schedule,
    roots: Vec<WatchRoot>,
    config: &WatchConfig,
    rules: &FileRules,
    logger: &Logger,
    cwd: &Path,
) -> anyhow::Result<Outcome> {
    let (shutdown_tx, shutdown_rx) = crossbeam_channel::bounded::<()>(4);
    ctrlc::set_handler(move || {
        let _ = shutdown_tx.try_send(());
    })
    .context("cannot install the SIGINT/SIGTERM handler")?;
    let (event_tx, event_rx) = crossbeam_channel::unbounded::<FileEvent>();
    let handler_rules = rules.clone();
    let handler_logger = logger.clone();
    let debouncer = new_debouncer(
        Duration::from_millis(config.debounce_ms.max(1)),
        None,
        move |result: DebounceEventResult| match result {
            Ok(events) => {
                for event in events {
                    for e in handler_rules.classify(&event.kind, &event.paths, event.need_rescan()) {
                        let _ = event_tx.send(e);
                    }
                }
            }
            Err(errors) => {
                for e in errors {
                    handler_logger.warn("watch", None, &format!("file watcher: {e}"), json!({}));
                }
            }
        },
    )
    .context("cannot start the file watcher")?;
    let mut watches = Watches {
        debouncer,
        watched: HashSet::new(),
        armed: Vec::new(),
        pending: Vec::new(),
    };
    let mut pending_events: Vec<FileEvent> = Vec::new();
    for root in roots {
        pending_events.extend(watches.arm(root, logger, cwd));
    }
    // Asset folders the registry asked to watch, until each is armed.
    let mut folders_wanted: Vec<PathBuf> = Vec::new();
    let mut rechecks: Vec<(Instant, PathBuf)> = Vec::new();
    loop {
        if pending_events.is_empty() && !is_busy(world) {
            // Idle: block until a file event, a due re-read, or a signal.
            let wait = rechecks
                .iter()
                .map(|(due, _)| due.saturating_duration_since(Instant::now()))
                .min()
                .unwrap_or(Duration::from_secs(3600));
            select! {
                recv(event_rx) -> e => match e {
                    Ok(e) => pending_events.push(e),
                    Err(_) => bail!("the file watcher stopped"),
                },
                recv(shutdown_rx) -> _ => break,
                default(wait) => {}
            }
        }
        due_rechecks(&mut rechecks, &mut pending_events);
        drain(&event_rx, &mut pending_events);
        if shutdown_rx.try_recv().is_ok() {
            break;
        }
        if !pending_events.is_empty() {
            if !watches.pending.is_empty()
                || pending_events
                    .iter()
                    .any(|e| matches!(e, FileEvent::Removed(_) | FileEvent::Rescan))
            {
                pending_events.extend(watches.refresh(logger, cwd));
            }
            for request in charts::handle(world, &pending_events) {
                match request {
                    WatchRequest::Recheck { file, after } => rechecks.push((Instant::now() + after, file)),
                    WatchRequest::Watch { folder } => folders_wanted.push(folder),
                }
            }
            pending_events.clear();
        }
        schedule.run(world);
        folders_wanted.retain(|folder| !watches.watch_asset_folder(folder, logger, cwd));
    }
    logger.info("stop", None, "stopping (signal)", json!({}));
    let mut log = world.resource_mut::<DaemonLog>();
    let _ = log.status.write_if_dirty();
    Ok(Outcome::Clean)
}

/// Moves the re-reads that are due into `events`.
fn due_rechecks(rechecks: &mut Vec<(Instant, PathBuf)>, events: &mut Vec<FileEvent>) {
    let now = Instant::now();
    rechecks.retain(|(due, path)| {
        let keep = *due > now;
        if !keep {
            events.push(FileEvent::ConstraintsChanged(path.clone()));
        }
        keep
    });
}

fn drain(rx: &Receiver<FileEvent>, into: &mut Vec<FileEvent>) {
    while let Ok(e) = rx.try_recv() {
        into.push(e);
    }
}
