//! Systems (verb phrases): each calls one session or solver method for
//! every chart that needs it and moves components; the decisions are the
//! core's ([`crate::session::ChartSession`], [`crate::solver::ChartSolver`]).
// A system's query names its components as a tuple: long, but read in place.
#![allow(clippy::type_complexity)]

use super::components::*;
use crate::error::Error;
use crate::session::StartFrom;
use bevy_ecs::prelude::*;
use std::sync::Arc;

/// Marks `entity` failed with `error` when a step did not succeed.
fn fail_on(commands: &mut Commands, entity: Entity, result: Result<(), Error>) {
    if let Err(e) = result {
        commands.entity(entity).insert(Failed(Arc::new(e)));
    }
}

/// Places the outer loop on the square (§III.B) for charts without one.
pub fn map_boundary(mut commands: Commands, mut charts: Query<(Entity, &mut Session), Without<Failed>>) {
    for (entity, mut session) in &mut charts {
        if session.0.boundary().is_none() {
            let result = session.0.map_boundary();
            fail_on(&mut commands, entity, result);
        }
    }
}

/// Builds and factors D = CᵀQC (Eq. 1–2) once per chart (not for one
/// solved from its coarse level: its solver runs step 1 only if it must).
pub fn factor_bar_net(mut commands: Commands, mut charts: Query<(Entity, &SolveJob, &mut Session), Without<Failed>>) {
    for (entity, job, mut session) in &mut charts {
        if session.0.bar_net().is_none() && session.0.boundary().is_some() && !session.0.starts_coarse(&job.options) {
            let result = session.0.factor_bar_net();
            fail_on(&mut commands, entity, result);
        }
    }
}

/// Solves Eq. 1 for the free nodes of charts whose boundary is new or moved.
pub fn solve_force_density(mut commands: Commands, mut charts: Query<(Entity, &mut Session), Without<Failed>>) {
    for (entity, mut session) in &mut charts {
        if session.0.step_one_layout().is_none() && session.0.bar_net().is_some() {
            let result = session.0.solve_force_density();
            fail_on(&mut commands, entity, result);
        }
    }
}

/// Starts the chart solver from step 1 for charts with no solver, or one
/// of an older session revision (new constraints, a moved boundary): the
/// old solve is dropped, never written.
pub fn start_stepping(
    mut commands: Commands,
    mut charts: Query<(Entity, &SolveJob, &mut Session, Option<&Solver>), Without<Failed>>,
) {
    for (entity, job, mut session, solver) in &mut charts {
        let revision = session.0.revision();
        let ready = session.0.step_one_layout().is_some() || session.0.starts_coarse(&job.options);
        if solver.is_some_and(|s| s.1 == revision) || !ready {
            continue;
        }
        match session.0.new_solver(&job.options, StartFrom::StepOne) {
            Ok(solver) => {
                commands
                    .entity(entity)
                    .insert(Solver(solver, revision))
                    .remove::<(Candidate, Finished, Exported)>();
            }
            Err(e) => {
                commands.entity(entity).insert(Failed(Arc::new(e)));
            }
        }
    }
}

/// Proposes one spline step (Eq. 6) of the current fraction for every stepping chart.
pub fn step_constraints(
    mut commands: Commands,
    mut charts: Query<(Entity, &mut Solver), (Without<Candidate>, Without<Failed>)>,
) {
    for (entity, mut solver) in &mut charts {
        if let Some(candidate) = solver.0.propose() {
            commands.entity(entity).insert(Candidate(candidate));
        }
    }
}

/// The foldover guard: accepts each candidate (every triangle keeps its
/// orientation, exactly, as computed and as stored) or halves the step.
pub fn guard_foldovers(mut commands: Commands, mut charts: Query<(Entity, &mut Solver, &Candidate), Without<Failed>>) {
    for (entity, mut solver, candidate) in &mut charts {
        solver.0.judge(&candidate.0);
        commands.entity(entity).remove::<Candidate>();
    }
}

/// Once the spline path is over: the completion and polish, one Newton step per tick.
pub fn complete_constraints(
    mut commands: Commands,
    mut charts: Query<(Entity, &mut Solver), (Without<Finished>, Without<Candidate>, Without<Failed>)>,
) {
    for (entity, mut solver) in &mut charts {
        let result = solver.0.newton_tick();
        fail_on(&mut commands, entity, result);
    }
}

/// Builds the report once the solver is done.
pub fn finish_solve(
    mut commands: Commands,
    mut charts: Query<(Entity, &mut Session, &mut Solver), (Without<Finished>, Without<Candidate>, Without<Failed>)>,
) {
    for (entity, mut session, mut solver) in &mut charts {
        if solver.0.is_done() && solver.1 == session.0.revision() {
            let report = session.0.report(&mut solver.0);
            commands.entity(entity).insert(Finished(report));
        }
    }
}

/// Checks the layout exactly as it will be stored and writes the model,
/// its pictures and report in one commit.
pub fn export_layout(
    mut commands: Commands,
    charts: Query<(Entity, &SolveJob, &Session, &Solver, &Finished), (Without<Exported>, Without<Failed>)>,
) {
    for (entity, job, session, solver, finished) in &charts {
        let report = session.0.export(&solver.0, &finished.0, &job.outputs);
        commands.entity(entity).insert(Exported(report));
    }
}
