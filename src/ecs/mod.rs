//! The ECS layer: each solved chart is an entity; its mesh, boundary,
//! factorisation, layouts and stepping state are components; each system is a
//! thin adapter around one core function. One `Schedule::run` is one tick:
//!
//! `map_boundary → factor_bar_net → solve_force_density → start_stepping →
//! step_constraints → guard_foldovers → complete_constraints → finish_solve →
//! export_layout → draw_previews`
//!
//! A tick advances every chart by at most one proposal, so the daemon can run
//! the same schedule forever and a newer edit supersedes a running solve.

pub mod components;
pub mod systems;
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

/// The solve schedule. Single-threaded: on 2 cores the per-chart work is
/// sequential anyway and the parallel executor only adds overhead.
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
        (systems::finish_solve, systems::export_layout, systems::draw_previews)
            .chain()
            .in_set(SolveSystems::Export),
    ));
    schedule
}

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
