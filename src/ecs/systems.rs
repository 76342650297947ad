//! Systems (verb phrases): each calls one core function for every chart that
//! needs it and moves components; the decisions are the core's.
// A system's query names its components as a tuple: long, but read in place.
#![allow(clippy::type_complexity)]

use super::components::*;
use crate::report;
use crate::solver::step1;
use crate::solver::{ChartSolver, SolveStart};
use bevy_ecs::prelude::*;
use std::sync::Arc;
use std::time::Instant;

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// Places the outer loop on the square (§III.B) for charts without a boundary layout.
pub fn map_boundary(
    mut commands: Commands,
    mut charts: Query<(Entity, &SolveJob, &ChartData, &mut Timings), (Without<BoundaryLayout>, Without<Failed>)>,
) {
    for (entity, job, data, mut times) in &mut charts {
        let t0 = Instant::now();
        let result = step1::map_boundary(&data.0, &job.source);
        times.0.boundary_ms += ms(t0);
        match result {
            Ok(b) => commands.entity(entity).insert(BoundaryLayout(b)),
            Err(e) => commands.entity(entity).insert(Failed(Arc::new(e))),
        };
    }
}

/// Builds and factors D = CᵀQC (Eq. 1–2) once per chart.
pub fn factor_bar_net(
    mut commands: Commands,
    mut charts: Query<
        (Entity, &SolveJob, &ChartData, &BoundaryLayout, &mut Timings),
        (Without<BarNetFactor>, Without<Failed>),
    >,
) {
    for (entity, job, data, boundary, mut times) in &mut charts {
        let t0 = Instant::now();
        let result = step1::factor_bar_net(&data.0, &boundary.0, &job.asset.path);
        times.0.factor_ms += ms(t0);
        match result {
            Ok(net) => commands.entity(entity).insert(BarNetFactor(Arc::new(net))),
            Err(e) => commands.entity(entity).insert(Failed(Arc::new(e))),
        };
    }
}

/// Solves Eq. 1 for the free nodes whenever the boundary layout is new or
/// changed; a running solve of the old layout is dropped.
pub fn solve_force_density(
    mut commands: Commands,
    mut charts: Query<
        (Entity, &ChartData, &BoundaryLayout, &BarNetFactor, &mut Timings),
        (Or<(Changed<BoundaryLayout>, Added<BarNetFactor>)>, Without<Failed>),
    >,
) {
    for (entity, data, boundary, net, mut times) in &mut charts {
        let t0 = Instant::now();
        let layout = step1::solve_force_density(&data.0, &boundary.0, &net.0);
        times.0.solve_ms += ms(t0);
        commands
            .entity(entity)
            .insert(Step1Layout(layout))
            .remove::<(Solver, Candidate, Finished, Exported)>();
    }
}

/// Starts the chart solver for charts with a step-1 layout and no solver
/// yet: a new step-1 layout, or new constraints on a kept one (the daemon).
pub fn start_stepping(
    mut commands: Commands,
    charts: Query<
        (
            Entity,
            &SolveJob,
            &ChartData,
            &BoundaryLayout,
            &Step1Layout,
            Option<&NewtonPatternSlot>,
            Option<&BarNetFactor>,
            &Timings,
        ),
        (Without<Solver>, Without<Failed>),
    >,
) {
    for (entity, job, data, boundary, step1, pattern, bar_net, times) in &charts {
        let start = SolveStart {
            prepared: &data.0,
            source: &job.source,
            options: &job.options,
            boundary: &boundary.0,
            step1: &step1.0,
            bar_net: bar_net.map(|b| &*b.0),
            pattern: pattern.map(|p| &p.0),
            elapsed_ms: times.0.total_ms(),
        };
        match ChartSolver::start(start) {
            Ok(solver) => {
                let slot = NewtonPatternSlot(solver.pattern().clone());
                commands
                    .entity(entity)
                    .insert((Solver(solver), slot))
                    .remove::<Candidate>();
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
        if let Err(e) = solver.0.newton_tick() {
            commands.entity(entity).insert(Failed(Arc::new(e)));
        }
    }
}

/// Builds the report once the solver is done.
pub fn finish_solve(
    mut commands: Commands,
    charts: Query<
        (
            Entity,
            &SolveJob,
            &ChartData,
            &BoundaryLayout,
            &Step1Layout,
            &Solver,
            &Timings,
        ),
        (Without<Finished>, Without<Candidate>, Without<Failed>),
    >,
) {
    for (entity, job, data, boundary, step1, solver, times) in &charts {
        if !solver.0.is_done() {
            continue;
        }
        let report = report::build(&report::SolveSummary {
            constraint_file: job.source.name(),
            asset: &job.asset,
            prepared: &data.0,
            boundary: &boundary.0,
            step1: &step1.0,
            solver: &solver.0,
            times: times.0.with_solver(solver.0.times()),
        });
        commands.entity(entity).insert(Finished(report));
    }
}

/// Checks the layout exactly as it will be stored and writes the file atomically.
pub fn export_layout(
    mut commands: Commands,
    charts: Query<(Entity, &SolveJob, &ChartData, &Solver, &Finished, &Timings), Without<Exported>>,
) {
    for (entity, job, data, solver, finished, times) in &charts {
        let t0 = Instant::now();
        let mut report = finished.0.clone();
        let (layout, output, guard) = (solver.0.layout(), job.output.as_deref(), job.options.guard);
        let staged = crate::export::stage_chart(&job.asset, &data.0, layout, &mut report, output, guard);
        let staged = staged.writing(job.writing.clone());
        crate::export::commit(staged, &mut report);
        report.times.export_ms = times.0.export_ms + ms(t0);
        report.total_ms = report.times.total_ms();
        commands.entity(entity).insert(Exported(report));
    }
}

/// Draws the requested pictures of each newly exported chart (also of a
/// folded or unwritten result, which the picture shows as such). A picture
/// that cannot be written becomes a warning in the report.
#[cfg(feature = "pictures")]
pub fn draw_previews(
    mut charts: Query<
        (
            &SolveJob,
            &ChartData,
            &BoundaryLayout,
            &Solver,
            &mut Exported,
            &PreviewRequest,
        ),
        Added<Exported>,
    >,
) {
    for (job, data, boundary, solver, mut exported, request) in &mut charts {
        let loop_vertices = &boundary.0.loop_vertices;
        if let Err(e) = crate::preview::draw_chart(
            &job.asset,
            &data.0,
            loop_vertices,
            solver.0.layout(),
            &exported.0,
            &request.0,
            &job.writing,
        ) {
            exported.0.warnings.push(format!("preview: {e}"));
        }
    }
}
