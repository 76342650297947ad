//! The ECS layer: each solved chart is an entity; its mesh, boundary,
//! factorisation, step-1 layout and solver are components; each system is a
//! thin adapter around one core function. One `Schedule::run` is one tick:
//!
//! `map_boundary → factor_bar_net → solve_force_density → start_stepping →
//! step_constraints → guard_foldovers → complete_constraints → finish_solve →
//! export_layout → draw_previews`
//!
//! A tick advances every chart by at most one proposal or Newton step
//! ([`crate::solver::ChartSolver::tick`]), so the daemon can run the same
//! schedule forever and a newer edit supersedes a running solve.

pub mod components;
pub mod systems;
#[cfg(feature = "daemon")]
pub mod watch;

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
            systems::start_stepping,
        )
            .chain()
            .in_set(SolveSystems::Unwrap),
        (
            systems::step_constraints,
            systems::guard_foldovers,
            systems::complete_constraints,
        )
            .chain()
            .in_set(SolveSystems::Step),
        (systems::finish_solve, systems::export_layout)
            .chain()
            .in_set(SolveSystems::Export),
    ));
    #[cfg(feature = "pictures")]
    schedule.add_systems(
        systems::draw_previews
            .after(systems::export_layout)
            .in_set(SolveSystems::Export),
    );
    schedule
}

/// Prepares the chart of `job` (weld, chart, topology, hole fill) and spawns
/// its entity into `world`; `load_ms` is the time spent loading it.
///
/// # Errors
/// Errors of [`crate::chart::prepare`].
pub fn spawn_job(world: &mut World, job: SolveJob, load_ms: f64) -> Result<Entity, crate::Error> {
    let t0 = std::time::Instant::now();
    let prepared = crate::chart::prepare(&job.source, &job.asset)?;
    let mut timings = Timings::default();
    timings.0.load_ms = load_ms;
    timings.0.topology_ms = t0.elapsed().as_secs_f64() * 1e3;
    Ok(world
        .spawn((job, ChartData(std::sync::Arc::new(prepared)), timings))
        .id())
}

/// Upper bound on schedule ticks for one batch of solves (each tick is one
/// proposal or Newton step per chart).
pub const MAX_TICKS: usize = 1_000_000;

/// Runs `schedule` until no entity is still working, at most `max_ticks` times.
/// Returns the number of ticks run.
pub fn run_to_convergence(world: &mut World, schedule: &mut Schedule, max_ticks: usize) -> usize {
    for tick in 0..max_ticks {
        schedule.run(world);
        let mut working = world.query_filtered::<(), (With<SolveJob>, Without<Exported>, Without<Failed>)>();
        if working.iter(world).next().is_none() {
            return tick + 1;
        }
    }
    max_ticks
}
