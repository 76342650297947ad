//! Systems (verb phrases): each calls one core function for every chart that needs it.
// A system's query names its components as a tuple: long, but read in place.
#![allow(clippy::type_complexity)]

use super::components::*;
use crate::chart;
use crate::complete::{CompletionState, PolishAfterSnap};
use crate::guard;
use crate::param::bar_net::BarNet;
use crate::param::boundary::map_outer_boundary;
use crate::rbf::stepping::{SteppingState, apply_step, full_step};
use crate::report;
use bevy_ecs::prelude::*;
use glam::DVec2;
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
        let c = &data.0;
        let result = map_outer_boundary(&c.chart.mesh, &c.topology, &c.traps, c.corners);
        times.0.boundary_ms += ms(t0);
        match result {
            Ok(b) => {
                commands.entity(entity).insert(BoundaryLayout(b));
            }
            Err(e) => {
                let err = job.constraints.corners_error(e.to_string());
                commands.entity(entity).insert(Failed(Arc::new(err.into())));
            }
        }
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
        let filled = &data.0.filled;
        let mut fixed = vec![false; filled.mesh.n_vertices()];
        for &v in &boundary.0.loop_vertices {
            fixed[v as usize] = true;
        }
        let result = BarNet::factor(filled, &fixed);
        times.0.factor_ms += ms(t0);
        match result {
            Ok(net) => {
                commands.entity(entity).insert(BarNetFactor(Arc::new(net)));
            }
            Err(source) => {
                let err = crate::Error::BarNet {
                    path: job.asset.path.clone(),
                    chart: data.0.chart.id,
                    source,
                };
                commands.entity(entity).insert(Failed(Arc::new(err)));
            }
        }
    }
}

/// Solves Eq. 1 for the free nodes whenever the boundary layout is new or changed.
pub fn solve_force_density(
    mut commands: Commands,
    mut charts: Query<
        (Entity, &ChartData, &BoundaryLayout, &BarNetFactor, &mut Timings),
        (Or<(Changed<BoundaryLayout>, Added<BarNetFactor>)>, Without<Failed>),
    >,
) {
    for (entity, data, boundary, net, mut times) in &mut charts {
        let t0 = Instant::now();
        let mut layout = vec![DVec2::ZERO; data.0.filled.mesh.n_vertices()];
        for (&v, &p) in boundary.0.loop_vertices.iter().zip(&boundary.0.positions) {
            layout[v as usize] = p;
        }
        net.0.solve(&mut layout);
        times.0.solve_ms += ms(t0);
        commands
            .entity(entity)
            .insert((Step1Layout(layout.clone()), Layout(layout)))
            .remove::<(Stepping, Completing, Candidate, Finished, Exported)>();
    }
}

/// Sets up spline stepping for charts with a step-1 layout and no stepping
/// yet: a new step-1 layout, or new constraints on a kept one (the daemon).
/// Checks the layout is fold-free and splits boundary constraints off.
pub fn start_stepping(
    mut commands: Commands,
    mut charts: Query<
        (
            Entity,
            &SolveJob,
            &ChartData,
            &BoundaryLayout,
            &Step1Layout,
            Option<&NewtonPatternSlot>,
            Option<&BarNetFactor>,
            &mut Timings,
        ),
        (Without<Stepping>, Without<Failed>),
    >,
) {
    for (entity, job, data, boundary, step1, pattern, bar_net, mut times) in &mut charts {
        let t0 = Instant::now();
        let c = &data.0;
        // One pass when storable (which implies positive in f64); the f64
        // check only for a squeezed start.
        let storable = guard::all_positive_as_stored(&step1.0, &c.filled.mesh.triangles);
        if let Some(t) = (!storable)
            .then(|| guard::first_non_positive(&step1.0, &c.filled.mesh.triangles))
            .flatten()
        {
            let err = crate::Error::Internal(format!("the step-1 layout has a flipped or zero-area triangle ({t})"));
            commands.entity(entity).insert(Failed(Arc::new(err)));
            continue;
        }
        let options = &job.constraints.solver;
        match chart::step_problem(c, &job.constraints, &boundary.0, options.max_boundary_centres) {
            Ok(problem) => {
                let state = SteppingState::start(&problem, &step1.0, options);
                if pattern.is_none_or(|p| !p.0.serves(&problem.movable)) {
                    // The polish runs after any result (and `Always` starts
                    // the completion at once): then the Newton pattern is
                    // needed anyway, so build it beside the spline path.
                    let polish_runs = options.guard == crate::options::Guard::Exact
                        && options.polish
                        && c.filled.n_real_vertices <= options.polish_max_vertices;
                    let needed = polish_runs || options.completion == crate::options::Completion::Always;
                    let (filled, movable) = (c.filled.clone(), problem.movable.clone());
                    // Step 1 ordered the same vertex graph: no second ordering.
                    let order = bar_net.and_then(|b| b.0.elimination_order()).map(Arc::new);
                    let pending = if needed && !movable.is_empty() {
                        PendingNewtonPattern::in_background(filled, movable, order)
                    } else {
                        PendingNewtonPattern::lazy(filled, movable, order)
                    };
                    commands.entity(entity).insert(NewtonPatternSlot(Arc::new(pending)));
                }
                commands
                    .entity(entity)
                    .insert(Stepping {
                        problem,
                        state,
                        full_step: None,
                        storable,
                    })
                    .remove::<Candidate>();
            }
            Err(e) => {
                commands.entity(entity).insert(Failed(Arc::new(e)));
            }
        }
        times.0.stepping_ms += ms(t0);
    }
}

/// Proposes one spline step (Eq. 6) of fraction `t` for every stepping chart.
pub fn step_constraints(
    mut commands: Commands,
    mut charts: Query<(Entity, &Layout, &mut Stepping, &mut Timings), (Without<Candidate>, Without<Failed>)>,
) {
    for (entity, layout, mut stepping, mut times) in &mut charts {
        if !stepping.state.is_stepping() {
            continue;
        }
        let t0 = Instant::now();
        if stepping.full_step.is_none() {
            match full_step(&layout.0, &stepping.problem) {
                Ok(field) => stepping.full_step = Some(field),
                Err(e) => {
                    stepping.state.record_failure(&e);
                    times.0.stepping_ms += ms(t0);
                    continue;
                }
            }
        }
        let step = stepping.full_step.as_ref().expect("computed above");
        let candidate = apply_step(&layout.0, &stepping.problem, &step.field, stepping.state.t);
        commands.entity(entity).insert(Candidate(candidate));
        times.0.stepping_ms += ms(t0);
    }
}

/// Accepts a candidate only if every triangle, virtual ones included, keeps
/// its orientation (Eq. 3, exactly) in double precision and as stored in f32;
/// otherwise halves the step.
pub fn guard_foldovers(
    mut commands: Commands,
    mut charts: Query<
        (
            Entity,
            &SolveJob,
            &ChartData,
            &mut Layout,
            &mut Stepping,
            &Candidate,
            &mut Timings,
        ),
        Without<Failed>,
    >,
) {
    for (entity, job, data, mut layout, mut stepping, candidate, mut times) in &mut charts {
        let t0 = Instant::now();
        let triangles = &data.0.filled.mesh.triangles;
        let options = &job.constraints.solver;
        let accepted = match (options.guard, &stepping.full_step) {
            (crate::options::Guard::Paper, Some(step)) => {
                step.paper_guard_accepts(&layout.0, &stepping.problem, stepping.state.t)
            }
            _ => guard::acceptable(&candidate.0, triangles, stepping.storable),
        };
        if accepted {
            let residual = stepping.problem.max_residual(&candidate.0);
            layout.0.clone_from(&candidate.0);
            if !stepping.storable {
                stepping.storable = guard::all_positive_as_stored(&layout.0, triangles);
            }
            stepping.full_step = None;
            stepping.state.record_guard(true, residual, options);
        } else {
            stepping.state.record_guard(false, f64::INFINITY, options);
        }
        commands.entity(entity).remove::<Candidate>();
        times.0.guard_ms += ms(t0);
    }
}

/// Once the spline path is over: starts the completion (after a stall, or
/// always if asked) or the polish (targets reached), then advances it one
/// Newton step per tick within the time budget.
pub fn complete_constraints(
    mut commands: Commands,
    mut charts: Query<
        (
            Entity,
            &SolveJob,
            &ChartData,
            &Step1Layout,
            &mut Layout,
            &Stepping,
            Option<&mut Completing>,
            Option<&NewtonPatternSlot>,
            &mut Timings,
        ),
        (Without<Finished>, Without<Candidate>, Without<Failed>),
    >,
) {
    use crate::rbf::stepping::SteppingPhase;
    for (entity, job, data, step1, mut layout, stepping, completing, slot, mut times) in &mut charts {
        if stepping.state.is_stepping() {
            continue;
        }
        let options = &job.constraints.solver;
        let filled = &data.0.filled;
        let real = &data.0.chart.mesh;
        let stretch = |layout: &[DVec2]| {
            crate::metrics::sander_stretch(&real.positions, &layout[..filled.n_real_vertices], &real.triangles)
        };
        let t0 = Instant::now();
        match completing {
            None => {
                let reached = stepping.state.phase == SteppingPhase::Reached;
                // The paper's guard is a comparison setting: its spline path alone.
                let paper = options.guard == crate::options::Guard::Paper;
                let polish = !paper && options.polish && filled.n_real_vertices <= options.polish_max_vertices;
                // Above polish_max_vertices the polish still follows a
                // completion whose snap left the layout more distorted than
                // step 1, in all or in its worst triangle (squeezed against
                // the barrier): it costs a fraction of the completion (26k
                // swirl: 20 steps after 44, L∞ 731 → 80).
                let polish_after_snap = if polish {
                    PolishAfterSnap::Always
                } else if !paper && options.polish {
                    PolishAfterSnap::IfMoreDistorted
                } else {
                    PolishAfterSnap::Off
                };
                // A layout f32 cannot store yet is always repaired by the polish.
                // The exact guard carries storability; the paper's does not.
                let storable = if paper {
                    crate::guard::all_positive_as_stored(&layout.0, &filled.mesh.triangles)
                } else {
                    stepping.storable
                };
                let has_free = !stepping.problem.movable.is_empty();
                // Built beside the spline path when it was sure to be needed.
                let pattern = || match slot {
                    Some(s) if s.0.serves(&stepping.problem.movable) => s.0.get(),
                    _ => crate::complete::newton_pattern(filled, &stepping.problem.movable, None).map(Arc::new),
                };
                let mut spline_layout = None;
                let state = if reached {
                    if has_free && !paper && (polish || !storable) {
                        pattern().map(|p| CompletionState::polish(filled, &stepping.problem, p, &layout.0, polish))
                    } else {
                        Ok(CompletionState::done())
                    }
                } else if paper || options.completion == crate::options::Completion::Never {
                    Ok(CompletionState::done())
                } else {
                    // From the step-1 layout (algorithm.md); the spline's result is the fallback.
                    pattern().map(|p| {
                        spline_layout = Some(std::mem::replace(&mut layout.0, step1.0.clone()));
                        CompletionState::soft(filled, &stepping.problem, p, &layout.0, options, polish_after_snap)
                    })
                };
                let stretch_before_polish =
                    (reached && has_free && !paper && (polish || !storable)).then(|| stretch(&layout.0));
                match state {
                    Ok(state) => {
                        commands.entity(entity).insert(Completing {
                            state,
                            spline_layout,
                            stretch_before_polish,
                        });
                    }
                    Err(e) => {
                        let err = crate::Error::Internal(format!("completion system: {e}"));
                        commands.entity(entity).insert(Failed(Arc::new(err)));
                    }
                }
                times.0.complete_ms += ms(t0);
            }
            Some(mut c) => {
                if c.state.is_done() {
                    continue;
                }
                let polishing = matches!(c.state.phase, crate::complete::CompletionPhase::Polish { .. });
                let was_snapped = c.state.stats.snapped;
                c.state.advance(&mut layout.0, filled, &stepping.problem, options);
                if c.state.stats.snapped && !was_snapped {
                    c.stretch_before_polish = Some(stretch(&layout.0));
                }
                if polishing {
                    times.0.polish_ms += ms(t0);
                } else {
                    times.0.complete_ms += ms(t0);
                }
                if options.time_budget_ms.is_some_and(|b| times.0.total_ms() > b) {
                    c.state.stop_out_of_time();
                }
                if c.state.is_done() && c.state.stats.soft && !c.state.stats.snapped {
                    // Not all reached: keep whichever fold-free layout is closer to the targets.
                    if let Some(spline) = &c.spline_layout
                        && stepping.problem.max_residual(spline) < stepping.problem.max_residual(&layout.0)
                    {
                        layout.0.clone_from(spline);
                    }
                }
            }
        }
    }
}

/// Builds the report once the spline path, completion and polish are over.
pub fn finish_solve(
    mut commands: Commands,
    charts: Query<
        (
            Entity,
            &SolveJob,
            &ChartData,
            &BoundaryLayout,
            &Step1Layout,
            &Layout,
            &Stepping,
            &Completing,
            &Timings,
        ),
        (Without<Finished>, Without<Candidate>, Without<Failed>),
    >,
) {
    for (entity, job, data, boundary, step1, layout, stepping, completing, times) in &charts {
        if stepping.state.is_stepping() || !completing.state.is_done() {
            continue;
        }
        let report = report::build(&report::SolveSummary {
            constraints: &job.constraints,
            asset: &job.asset,
            prepared: &data.0,
            boundary: &boundary.0,
            step1: &step1.0,
            layout: &layout.0,
            state: &stepping.state,
            completion: Some(&completing.state.stats),
            stretch_before_polish: completing.stretch_before_polish,
            problem: &stepping.problem,
            times: times.0,
        });
        commands.entity(entity).insert(Finished(report));
    }
}

/// Checks the layout exactly as it will be stored and writes the file atomically.
pub fn export_layout(
    mut commands: Commands,
    mut charts: Query<(Entity, &SolveJob, &ChartData, &Layout, &Finished, &mut Timings), Without<Exported>>,
) {
    for (entity, job, data, layout, finished, mut times) in &mut charts {
        let t0 = Instant::now();
        let mut report = finished.0.clone();
        let written = report.orientation;
        let folded_in_f64 = !guard::all_positive(&layout.0, &data.0.filled.mesh.triangles);
        if folded_in_f64 {
            // Only the paper's pointwise guard (a comparison setting) lets this happen.
            report.status = report::Status::Error;
            report.message = Some(format!(
                "folded: the {:?} guard let {} triangles flip and {} collapse; a folded layout is never written",
                job.constraints.solver.guard, written.flipped, written.zero_area
            ));
        } else if !written.is_clean() {
            report.status = report::Status::Error;
            report.message = Some(format!(
                "the layout is fold-free in double precision, but {} triangles would be flipped and {} zero-area once stored \
                 as f32 texture coordinates (thin parts of the chart are squeezed against the square's sides; smallest triangle \
                 area {:.1e} of the texture); nothing written",
                written.flipped,
                written.zero_area,
                crate::guard::smallest_area(&layout.0, &data.0.filled.mesh.triangles)
            ));
        } else if let Some(out) = &job.output {
            let uvs = chart::assemble_uvs(&job.asset, &data.0, &layout.0);
            match crate::io::gltf_file::write_asset(&job.asset, &uvs, out) {
                Ok(()) => report.output = Some(out.display().to_string()),
                Err(e) => {
                    report.status = report::Status::Error;
                    report.message = Some(e.to_string());
                }
            }
        }
        times.0.export_ms += ms(t0);
        report.times = times.0;
        report.total_ms = times.0.total_ms();
        commands.entity(entity).insert(Exported(report));
    }
}

/// Draws the requested pictures of each newly exported chart (also of a
/// folded or unwritten result, which the picture shows as such). A picture
/// that cannot be written becomes a warning in the report.
pub fn draw_previews(
    mut charts: Query<
        (
            &SolveJob,
            &ChartData,
            &BoundaryLayout,
            &Layout,
            &mut Exported,
            &PreviewRequest,
        ),
        Added<Exported>,
    >,
) {
    for (job, data, boundary, layout, mut exported, request) in &mut charts {
        if let Err(e) = crate::preview::draw_chart(
            &job.asset,
            &data.0,
            &boundary.0.loop_vertices,
            &layout.0,
            &exported.0,
            request.layout.as_deref(),
            request.render.as_deref(),
            request.size,
        ) {
            exported.0.warnings.push(format!("preview: {e}"));
        }
    }
}
