//! The ECS layer: each solved chart is an entity holding its chart session
//! ([`crate::session::ChartSession`]: mesh, boundary, factorisation, step-1
//! layout) and its solver; each system is a thin adapter around one session
//! or solver method. One `Schedule::run` is one tick:
//!
//! `map_boundary → factor_bar_net → solve_force_density → start_planning →
//! step_constraints → guard_foldovers → complete_constraints → advance_plan →
//! finish_solve → export_layout`
//!
//! A tick advances every chart by at most one proposal or Newton step of
//! its plan's running solver ([`crate::solver::ChartSolver::tick`]), or one
//! step of the plan between solves ([`crate::plan::ChartPlan::advance`]):
//! the same solve sequence as [`crate::assembly::solve`], system by system.
//! The daemon runs the same schedule forever, and a newer edit supersedes a
//! running solve.

pub mod components;
pub mod systems;

pub use components::*;

use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SingleThreadedExecutor;

/// The stages of one tick, in order.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub enum SolveSystems {
    /// Step 1: boundary onto the square, bar-net factor and solve (§III).
    Unwrap,
    /// Step 2: one spline proposal (Eq. 6) and its guard; then step 3, one
    /// completion or polish Newton step.
    Step,
    /// Reports and file output.
    Export,
}

/// The solve schedule. Single-threaded: the per-chart work is sequential and
/// splits its own heavy loops over rayon; the parallel executor only adds
/// overhead.
pub fn solve_schedule() -> Schedule {
    let mut schedule = Schedule::default();
    schedule.set_executor(SingleThreadedExecutor::default());
    schedule.configure_sets((SolveSystems::Unwrap, SolveSystems::Step, SolveSystems::Export).chain());
    schedule.add_systems((
        (
            systems::map_boundary,
            systems::factor_bar_net,
            systems::solve_force_density,
            systems::start_planning,
        )
            .chain()
            .in_set(SolveSystems::Unwrap),
        (
            systems::step_constraints,
            systems::guard_foldovers,
            systems::complete_constraints,
            systems::advance_plan,
        )
            .chain()
            .in_set(SolveSystems::Step),
        (systems::finish_solve, systems::export_layout)
            .chain()
            .in_set(SolveSystems::Export),
    ));
    schedule
}

/// Opens the chart session of `job` (weld, chart, topology, hole fill) and
/// spawns its entity into `world`; `load_ms` is the time spent loading it.
///
/// # Errors
/// Errors of [`crate::session::ChartSession::open`].
pub fn spawn_job(world: &mut World, job: SolveJob, load_ms: f64) -> Result<Entity, crate::error::Error> {
    let session = crate::session::ChartSession::open(job.source.clone(), job.asset.clone(), load_ms)?;
    Ok(world.spawn((job, Session(session))).id())
}

/// Upper bound on schedule ticks for one batch of solves (each tick is one
/// proposal or Newton step per chart).
pub const MAX_TICKS: usize = 1_000_000;

/// Runs `schedule` until no entity is still working, at most `max_ticks` times.
/// Returns the number of ticks run.
pub fn run_to_convergence(world: &mut World, schedule: &mut Schedule, max_ticks: usize) -> usize {
    for tick in 0..max_ticks {
        schedule.run(world);
        if !is_busy(world) {
            return tick + 1;
        }
    }
    max_ticks
}

/// Whether any chart is still being solved (neither exported nor failed).
pub fn is_busy(world: &mut World) -> bool {
    let mut working = world.query_filtered::<(), (With<SolveJob>, Without<Exported>, Without<Failed>)>();
    working.iter(world).next().is_some()
}
