//! The daemon's charts in the ECS: the registry's actions applied to chart
//! entities (one per constraint file, holding its chart session), and each
//! finished solve reported — logged, put on the status board, and handed
//! back to the registry ([`report_results`]). The rules themselves are the
//! registry's ([`super::registry`]); nothing here decides.

use super::events::FileEvent;
use super::log::Logger;
use super::paths::display;
use super::registry::{Action, Outcome, RealDisk, Registry, WatchSettings};
use super::status::{FileState, LastSolve, StatusBoard};
use crate::ecs::{Candidate, Exported, Failed, Finished, Planning, Session, SolveJob, SolveSystems, solve_schedule};
use crate::error::Error;
use crate::report::Status;
use crate::session::{ChartSession, Kept};
use bevy_ecs::prelude::*;
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// The daemon's settings, as a resource.
#[derive(Resource, Debug, Clone)]
pub struct Settings(pub WatchSettings);

/// The registry and the entity of each constraint file.
#[derive(Resource, Debug, Default)]
pub struct DaemonState {
    pub registry: Registry,
    pub entities: BTreeMap<PathBuf, Entity>,
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
}

/// The chart's last outcome has been reported.
#[derive(Component, Debug, Clone, Copy)]
pub struct Reported;

/// When the chart's current solve started, and the last stage of it logged.
#[derive(Component, Debug, Clone, Copy)]
pub struct SolveClock {
    pub started: std::time::Instant,
    pub logged: Option<crate::solver::Stage>,
}

/// A solve running this long has each stage it enters logged.
pub const LONG_SOLVE: Duration = Duration::from_secs(2);

/// [`LONG_SOLVE`], or (a test hook) `UVPIN_TEST_LONG_SOLVE_MS` milliseconds.
fn long_solve() -> Duration {
    static LONG: std::sync::OnceLock<Duration> = std::sync::OnceLock::new();
    *LONG.get_or_init(|| {
        std::env::var("UVPIN_TEST_LONG_SOLVE_MS")
            .ok()
            .and_then(|ms| ms.parse().ok())
            .map_or(LONG_SOLVE, Duration::from_millis)
    })
}

/// What the rules ask of the watcher: to read a file again later, or to
/// watch one more folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum WatchRequest {
    Recheck { file: PathBuf, after: Duration },
    Watch { folder: PathBuf },
}

/// The schedule of the daemon: the solve systems, then logging and the
/// status file.
pub fn watch_schedule() -> Schedule {
    let mut schedule = solve_schedule();
    schedule.add_systems(log_long_solves.after(SolveSystems::Step).before(SolveSystems::Export));
    schedule.add_systems((report_results, write_status_file).chain().after(SolveSystems::Export));
    schedule
}

/// Inserts the daemon's resources into `world`.
pub fn init_watch_world(world: &mut World, settings: WatchSettings, log: DaemonLog) {
    world.insert_resource(Settings(settings));
    world.insert_resource(log);
    world.init_resource::<DaemonState>();
}

/// Hands file events to the registry and applies what it decides to the
/// chart entities; returns what the watcher must do.
pub fn handle(world: &mut World, events: &[FileEvent]) -> Vec<WatchRequest> {
    let settings = world.resource::<Settings>().0.clone();
    let actions = world
        .resource_mut::<DaemonState>()
        .registry
        .on_events(events, &settings, &RealDisk);
    let mut requests = Vec::new();
    for action in actions {
        match action {
            Action::Recheck { file, after } => requests.push(WatchRequest::Recheck { file, after }),
            Action::Watch { folder } => requests.push(WatchRequest::Watch { folder }),
            action => apply(world, &settings, action),
        }
    }
    requests
}

/// The entity of `file`, spawned when first needed.
fn entity_of(world: &mut World, file: &Path) -> Entity {
    if let Some(&e) = world.resource::<DaemonState>().entities.get(file) {
        return e;
    }
    let e = world
        .spawn(WatchedFile {
            path: file.to_path_buf(),
        })
        .id();
    world
        .resource_mut::<DaemonState>()
        .entities
        .insert(file.to_path_buf(), e);
    e
}

/// Applies one chart action.
fn apply(world: &mut World, settings: &WatchSettings, action: Action) {
    let name = |file: &Path| display(file, &settings.cwd);
    match action {
        Action::Solve {
            file,
            loaded,
            asset,
            outputs,
            load_ms,
        } => {
            let entity = entity_of(world, &file);
            let job = SolveJob::from_file(*loaded, asset, None).writing(outputs);
            if let Err(e) = restart_solve(world, settings, entity, job, load_ms) {
                fail(world, entity, Arc::new(e));
            }
        }
        Action::Fail { file, error } => {
            let entity = entity_of(world, &file);
            fail(world, entity, error);
        }
        Action::Stop { file, error } => {
            let entity = entity_of(world, &file);
            let mut e = world.entity_mut(entity);
            if e.get::<Exported>().is_none() {
                e.remove::<(Finished, Candidate)>();
            }
            e.remove::<Reported>().insert(Failed(error));
        }
        Action::Restore { file, status } => {
            let entity = entity_of(world, &file);
            world.entity_mut(entity).remove::<Failed>().insert(Reported);
            let mut log = world.resource_mut::<DaemonLog>();
            let message = "the asset is back unchanged; its last result stands";
            log.logger.info("unchanged", Some(&name(&file)), message, json!({}));
            let entry = log.status.entry(&name(&file));
            entry.state = FileState::of(status);
            entry.last_error = None;
        }
        Action::Removed { file } => {
            let mut log = world.resource_mut::<DaemonLog>();
            let message = "removed; its last output is kept";
            log.logger.info("removed", Some(&name(&file)), message, json!({}));
            log.status.entry(&name(&file)).state = FileState::Removed;
        }
        Action::Back { file, state } => {
            world.resource_mut::<DaemonLog>().status.entry(&name(&file)).state = state;
        }
        Action::Recheck { .. } | Action::Watch { .. } => {}
    }
}

/// Marks `entity` failed: a running solve stops and nothing is written.
fn fail(world: &mut World, entity: Entity, error: Arc<Error>) {
    world
        .entity_mut(entity)
        .remove::<(Finished, Exported, Candidate, Reported)>()
        .insert(Failed(error));
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
        .remove::<(Planning, Candidate, Finished, Exported, Failed, Reported)>()
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
    let (geometry, step_one, words) = match kept {
        None | Some(Kept::Weld) => (false, false, "from scratch"),
        Some(Kept::Geometry) => (true, false, "reusing the chart and its factorisation"),
        Some(Kept::StepOne) => (true, true, "reusing the step-1 layout"),
    };
    let counters = &mut world.resource_mut::<DaemonState>().into_inner().registry.counters;
    counters.solves_started += 1;
    counters.geometry_reused += u64::from(geometry);
    counters.step1_reused += u64::from(step_one);
    let mut log = world.resource_mut::<DaemonLog>();
    let superseding = if superseded {
        " (supersedes the running solve)"
    } else {
        ""
    };
    let message = format!("solving {n_constraints} constraints, {words}{superseding}");
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
    world.entity_mut(entity).insert(SolveClock {
        started: std::time::Instant::now(),
        logged: None,
    });
}

/// A chart whose solve is running.
type Running<'a> = (&'a WatchedFile, &'a Planning, &'a mut SolveClock);

/// Logs the stage of every solve running longer than [`LONG_SOLVE`], each
/// time it enters a new one: a long solve on a build machine shows where it is.
pub fn log_long_solves(
    log: Res<DaemonLog>,
    settings: Res<Settings>,
    mut charts: Query<Running, (Without<Finished>, Without<Failed>)>,
) {
    for (watched, planning, mut clock) in &mut charts {
        let elapsed = clock.started.elapsed();
        let progress = planning.0.progress();
        if elapsed < long_solve() || clock.logged == Some(progress.stage) {
            continue;
        }
        clock.logged = Some(progress.stage);
        let name = display(&watched.path, &settings.0.cwd);
        let how_far = progress
            .fraction
            .map_or(String::new(), |f| format!(", {:.0} % through", f * 100.0));
        let message = format!(
            "{} after {:.1} s{how_far}",
            progress.stage.label(),
            elapsed.as_secs_f64()
        );
        log.logger.info(
            "stage",
            Some(&name),
            &message,
            json!({ "stage": progress.stage, "elapsed_ms": elapsed.as_millis() as u64 }),
        );
    }
}

/// A chart whose outcome may not be reported yet.
type Unreported<'a> = (Entity, &'a WatchedFile, Option<&'a Exported>, Option<&'a Failed>);

/// Logs every finished solve and every failure once, puts them on the
/// status board, and hands them back to the registry.
pub fn report_results(
    mut commands: Commands,
    mut log: ResMut<DaemonLog>,
    mut state: ResMut<DaemonState>,
    settings: Res<Settings>,
    charts: Query<Unreported, Without<Reported>>,
) {
    for (entity, watched, exported, failed) in &charts {
        let outcome = match (failed, exported) {
            (Some(_), _) => Outcome::Failed,
            (None, Some(e)) => Outcome::Exported {
                status: e.0.report.status,
                output: e.0.report.output.as_ref().map(PathBuf::from),
            },
            (None, None) => continue,
        };
        commands.entity(entity).insert(Reported);
        state
            .registry
            .on_outcome(&watched.path, &outcome, &settings.0, &RealDisk);
        let name = display(&watched.path, &settings.0.cwd);
        match (failed, exported) {
            (Some(_), _) if state.registry.is_removed(&watched.path) => {}
            (Some(Failed(err)), _) => {
                // Said only when there is one: a first solve that fails has none.
                let kept = state.registry.output_of(&watched.path).is_some_and(Path::exists);
                report_error(&mut log, &name, &err.to_string(), kept);
            }
            (None, Some(Exported(written))) if written.report.status == Status::Error => {
                let message = written
                    .report
                    .message
                    .clone()
                    .unwrap_or_else(|| "the write failed".into());
                report_error(&mut log, &name, &message, false);
            }
            (None, Some(Exported(written))) => report_solved(&mut log, &name, &written.report, &settings.0.cwd),
            (None, None) => {}
        }
    }
}

/// Logs an error and puts it on the status board.
fn report_error(log: &mut DaemonLog, name: &str, message: &str, output_kept: bool) {
    let logged = if output_kept {
        format!("{message} (the last good output is kept)")
    } else {
        message.to_string()
    };
    log.logger.error("error", Some(name), &logged, json!({}));
    let entry = log.status.entry(name);
    entry.state = FileState::Error;
    entry.last_error = Some(message.to_string());
}

/// Logs a written solve (and its hint when partial); the status board keeps it.
fn report_solved(log: &mut DaemonLog, name: &str, report: &crate::report::Report, cwd: &Path) {
    let reached = report.constraints.iter().filter(|c| c.reached).count();
    let output = report
        .output
        .as_deref()
        .map(|o| display(Path::new(o), cwd))
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
        Some(name),
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
        log.logger.warn("hint", Some(name), hint, json!({}));
    }
    let entry = log.status.entry(name);
    entry.state = FileState::of(report.status);
    entry.last_error = None;
    let mut last = LastSolve::from_report(report);
    last.output = Some(output);
    entry.last_solve = Some(last);
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
