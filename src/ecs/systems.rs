//! Systems (verb phrases): each calls one session, plan, solver or
//! assembly method for every chart that needs it and moves components; the
//! decisions are the core's ([`crate::session::ChartSession`],
//! [`crate::plan::ChartPlan`], [`crate::solver::ChartSolver`],
//! [`crate::assembly`]).
// A system's query names its components as a tuple: long, but read in place.
#![allow(clippy::type_complexity)]

use super::components::*;
use crate::error::Error;
use crate::plan::ChartPlan;
use crate::session::StartFrom;
use crate::solver::ChartSolver;
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

/// Starts the chart's plan ([`crate::plan::ChartPlan`]: its candidates,
/// then the chosen one finished) once step 1 is ready, for charts with no
/// solve of the session's revision (new constraints, a moved boundary): an
/// older solve is dropped, never written.
pub fn start_planning(
    mut commands: Commands,
    charts: Query<(Entity, &SolveJob, &Session, Option<&Planning>, Option<&Finished>), Without<Failed>>,
) {
    for (entity, job, session, planning, finished) in &charts {
        let revision = session.0.revision();
        let current = planning.map(|p| p.1).or(finished.map(|f| f.1));
        let ready = session.0.step_one_layout().is_some() || session.0.starts_coarse(&job.options);
        if current == Some(revision) || !ready {
            continue;
        }
        let plan = ChartPlan::new(session.0.clone(), job.options, StartFrom::StepOne);
        commands
            .entity(entity)
            .insert(Planning(plan, revision))
            .remove::<(Candidate, Finished, Exported)>();
    }
}

/// Proposes one spline step (Eq. 6) of the current fraction for every
/// chart whose running solver is on its spline path.
pub fn step_constraints(
    mut commands: Commands,
    mut charts: Query<(Entity, &mut Planning), (Without<Candidate>, Without<Failed>)>,
) {
    for (entity, mut planning) in &mut charts {
        if let Some(candidate) = planning.0.solver_mut().and_then(|s| s.propose()) {
            commands.entity(entity).insert(Candidate(candidate));
        }
    }
}

/// The foldover guard: accepts each candidate (every triangle keeps its
/// orientation, exactly, as computed and as stored) or halves the step.
pub fn guard_foldovers(
    mut commands: Commands,
    mut charts: Query<(Entity, &mut Planning, &Candidate), Without<Failed>>,
) {
    for (entity, mut planning, candidate) in &mut charts {
        if let Some(solver) = planning.0.solver_mut() {
            solver.judge(&candidate.0);
        }
        commands.entity(entity).remove::<Candidate>();
    }
}

/// Once the spline path is over: the completion and polish, one Newton
/// step per tick.
pub fn complete_constraints(
    mut commands: Commands,
    mut charts: Query<(Entity, &mut Planning), (Without<Candidate>, Without<Failed>)>,
) {
    for (entity, mut planning) in &mut charts {
        if let Some(solver) = planning.0.solver_mut().filter(|s| !s.is_done()) {
            let result = solver.newton_tick().or_else(|e| planning.0.solver_failed(e));
            fail_on(&mut commands, entity, result);
        }
    }
}

/// Between solves, the plan's own step: a finished candidate judged, the
/// next one opened, the winner prolonged onto the chart, or the end.
pub fn advance_plan(
    mut commands: Commands,
    mut charts: Query<(Entity, &mut Planning), (Without<Candidate>, Without<Failed>)>,
) {
    for (entity, mut planning) in &mut charts {
        let between = planning.0.solver().is_none_or(ChartSolver::is_done);
        if between && !planning.0.is_done() {
            let result = planning.0.advance();
            fail_on(&mut commands, entity, result);
        }
    }
}

/// Once the plan is over: the chosen chart becomes the session, the other
/// charts holding landmarks are solved around it, and the report is built
/// ([`crate::assembly::finish`]).
pub fn finish_solve(mut commands: Commands, mut charts: Query<(Entity, &mut Session, &mut Planning), Without<Failed>>) {
    for (entity, mut session, mut planning) in &mut charts {
        if planning.1 != session.0.revision() {
            continue;
        }
        if let Some(planned) = planning.0.take_solution() {
            let solution = crate::assembly::finish(&mut session.0, planned, &|| false);
            let revision = planning.1;
            commands
                .entity(entity)
                .remove::<Planning>()
                .insert(Finished(solution, revision));
        }
    }
}

/// Checks the layout exactly as it will be stored and writes the model,
/// its pictures and report in one commit.
pub fn export_layout(
    mut commands: Commands,
    charts: Query<(Entity, &SolveJob, &Session, &Finished), (Without<Exported>, Without<Failed>)>,
) {
    for (entity, job, session, finished) in &charts {
        let written = crate::assembly::export(&session.0, &finished.0, &job.outputs);
        commands.entity(entity).insert(Exported(written));
    }
}
