//! `uvpin solve --explain`: one line per phase.

use super::summary::SolveSummary;
use super::{CompletionStats, Status};
use crate::metrics::Stretch;
use crate::param::boundary::{BoundaryShape, CornerSource};
use crate::rbf::stepping::SteppingPhase;
use crate::solver::LoopFreed;
use crate::solver::policy::{PolishOutcome, Reached};

/// One line per phase: step 1, spline path, completion, polish, result.
pub(super) fn explain_lines(
    s: &SolveSummary,
    c: &CompletionStats,
    status: Status,
    (step1, last): (&Stretch, &Stretch),
    max_residual: f64,
) -> Vec<String> {
    let mut lines = vec![step1_line(s, step1)];
    lines.extend(free_line(s));
    lines.extend(multilevel_line(s));
    lines.extend([
        spline_line(s),
        completion_line(s, c),
        polish_line(s, c, last),
        format!(
            "result: {}, max residual {max_residual:.3e}, {:.2} ms in all",
            status_word(status),
            s.times.total_ms()
        ),
    ]);
    lines
}

/// A large chart's coarse level.
fn multilevel_line(s: &SolveSummary) -> Option<String> {
    let m = s.solver.record().multilevel.as_ref()?;
    Some(
        format!(
            "coarse level: {} vertices, coarsened in {:.0} ms, solved in {:.0} ms, prolonged in {:.0} ms with {} local \
         sweeps ({} vertices put in their ring's kernel)",
            m.coarse_vertices, m.coarsen_ms, m.coarse_solve_ms, m.prolong_ms, m.sweeps, m.in_kernel
        ) + &m
            .stuck
            .as_ref()
            .map_or(String::new(), |e| format!("; {e} until its surroundings swept on"))
            + if m.out_of_time {
                "; time_budget_ms ran out: the last stages were put back without sweeps"
            } else {
                ""
            },
    )
}

/// A free boundary's region and start.
fn free_line(s: &SolveSummary) -> Option<String> {
    let free = s.solver.free()?;
    let setup = free.domain.room.setup();
    let r = setup.region;
    let source = match setup.source {
        crate::free::RegionSource::Given => "the given region",
        crate::free::RegionSource::Texture => "the texture",
        crate::free::RegionSource::Island => "the chart's own island",
    };
    let start = match free.start {
        crate::domain::start::StartKind::Island => "its island as it was",
        crate::domain::start::StartKind::Through => "least-squares conformal through the targets",
        crate::domain::start::StartKind::Conformal => "least-squares conformal",
        crate::domain::start::StartKind::StepOne => "step 1 (the conformal layout folded)",
        crate::domain::start::StartKind::Coarse => "a coarse level of the chart, solved and prolonged",
        crate::domain::start::StartKind::Projection => "the view of a camera fitted to the targets",
        crate::domain::start::StartKind::Square => "the chart's solve on the square, mapped onto the region",
    };
    let islands = setup.obstacles.triangles.len();
    Some(format!(
        "free boundary inside {source} (u {:.4}..{:.4}, v {:.4}..{:.4}{}): start {start}{}{}; {:.2} ms",
        r.min.x,
        r.max.x,
        r.min.y,
        r.max.y,
        if islands > 0 {
            format!(", clear of {islands} triangles of other islands")
        } else {
            String::new()
        },
        if free.shrink < 1.0 {
            format!(", shrunk ×{} to fit", free.shrink)
        } else {
            String::new()
        },
        if free.relax_steps > 0 {
            format!(
                ", relaxed in {} Newton steps and fitted to the targets",
                free.relax_steps
            )
        } else {
            String::new()
        },
        free.start_ms
    ))
}

fn status_word(status: Status) -> &'static str {
    match status {
        Status::Reached => "reached",
        Status::Partial => "partial",
        Status::Error => "error",
    }
}

fn step1_line(s: &SolveSummary, step1: &Stretch) -> String {
    let t = &s.times;
    if s.solver.record().multilevel.is_some() {
        return format!(
            "step 1 (bar-net, Eq. 1-2): on the coarse level only; the prolonged start has stretch L2 {:.4}, L∞ {:.4}",
            step1.l2, step1.linf
        );
    }
    format!(
        "step 1 (bar-net, Eq. 1-2): outer loop of {} vertices on the {} (corners {}); {} holes fan-filled; \
         {} free vertices solved; stretch L2 {:.4}, L∞ {:.4}; {:.2} ms",
        s.boundary.loop_vertices.len(),
        match s.boundary.shape {
            BoundaryShape::Square => "square",
            BoundaryShape::BulgedSquare => "bulged square (zero-area trap)",
            BoundaryShape::Triangle => "square's lower-left half (a loop of 3)",
        },
        match s.boundary.corner_source {
            CornerSource::Given => "given".to_string(),
            CornerSource::Automatic { shift } => format!("automatic, {shift} shifts"),
        },
        s.prepared.filled.n_holes(),
        s.solver.problem().movable.len(),
        step1.l2,
        step1.linf,
        t.boundary_ms + t.factor_ms + t.solve_ms
    )
}

fn spline_line(s: &SolveSummary) -> String {
    let line = spline_phase_line(s);
    match s.solver.record().spline_loop_freed {
        None => line,
        Some(LoopFreed::Kept) => format!("{line}; run again with the outer loop free after stalling with it held"),
        Some(LoopFreed::Discarded) => format!(
            "{line}; the run held the outer loop: run again with the loop free, it ended further from the targets"
        ),
    }
}

fn spline_phase_line(s: &SolveSummary) -> String {
    let st = s.solver.spline();
    let ms = s.times.stepping_ms + s.times.guard_ms;
    match &st.phase {
        SteppingPhase::Skipped => "spline path (Eq. 6): skipped (completion: Always)".into(),
        SteppingPhase::Reached if st.iterations == 0 => {
            "spline path (Eq. 6): not needed (the start is on the targets)".into()
        }
        SteppingPhase::Reached => format!(
            "spline path (Eq. 6): reached in {} steps, {} halvings; {ms:.2} ms",
            st.iterations, st.total_halvings
        ),
        SteppingPhase::Stalled(reason) => format!(
            "spline path (Eq. 6): stalled after {} steps, {} halvings ({reason}); {ms:.2} ms",
            st.iterations, st.total_halvings
        ),
        SteppingPhase::Stepping => "spline path (Eq. 6): unfinished".into(),
    }
}

/// How the soft rounds ended.
fn snap_words(c: &CompletionStats) -> String {
    match (c.snapped_at_round, c.arc_retry) {
        (Some(r), false) => format!("snapped onto the targets in round {}", r + 1),
        (Some(r), true) => format!(
            "snapped onto the targets in round {} moving along arc paths{}",
            r + 1,
            if c.paths_cross {
                " (tried first: two constraints' straight paths meet head-on)"
            } else {
                ""
            }
        ),
        (None, _) if c.proven_unreachable => {
            "could not snap onto the targets (proven unreachable, see the hint: one straight attempt, no arc retries)"
                .into()
        }
        (None, _) => "could not snap onto the targets (straight and arc paths tried)".into(),
    }
}

fn completion_line(s: &SolveSummary, c: &CompletionStats) -> String {
    if !c.soft {
        return "completion: not needed".into();
    }
    format!(
        "completion (soft-to-hard symmetric Dirichlet): {}{} rounds, {} Newton steps, {}; energy {:.4} → {:.4}{}{}; {:.2} ms",
        if c.repair_steps > 0 {
            format!("{} steps spreading triangles too small for f32, then ", c.repair_steps)
        } else {
            String::new()
        },
        c.rounds,
        c.newton_steps,
        snap_words(c),
        c.energy_start,
        c.energy_snapped.unwrap_or(c.energy_end),
        if c.capped_triangles > 0 {
            format!(
                "; up to {} triangles measured against progressive reference shapes",
                c.capped_triangles
            )
        } else {
            String::new()
        },
        if c.out_of_time { " (time budget)" } else { "" },
        s.times.complete_ms
    )
}

fn polish_line(s: &SolveSummary, c: &CompletionStats, last: &Stretch) -> String {
    let record = s.solver.record();
    let outcome = record.polish_outcome.unwrap_or(PolishOutcome::NothingToMove);
    match (outcome, record.stretch_before_polish) {
        (PolishOutcome::Ran, Some(before)) => format!(
            "polish ({}): {} Newton steps{}; stretch L2 {:.4} → {:.4}, L∞ {:.4} → {:.4}; {:.2} ms",
            if s.solver.free().is_some() {
                "constraints held, boundary free, scaffold rebuilt each step"
            } else {
                "constraints and boundary held"
            },
            c.polish_steps,
            if c.polish_repair_steps > 0 {
                format!(
                    " ({} of them spreading triangles too small for f32)",
                    c.polish_repair_steps
                )
            } else {
                String::new()
            },
            before.l2,
            last.l2,
            before.linf,
            last.linf,
            s.times.polish_ms
        ),
        (PolishOutcome::Off, _) => "polish: off".into(),
        (PolishOutcome::PaperGuard, _) => "polish: not run (the paper's guard: its spline path alone)".into(),
        (PolishOutcome::TargetsNotReached, _) => "polish: not run (the targets were not reached)".into(),
        (PolishOutcome::AboveLimit { after }, _) => {
            let after = match after {
                Reached::Completion => {
                    "the completion left the layout no more distorted than step 1, in all and in its worst triangle"
                }
                Reached::SplinePath => "the spline path reached the targets",
            };
            format!(
                "polish: not run ({after}, on {} vertices: above polish_max_vertices {})",
                s.prepared.filled.n_real_vertices,
                s.solver.options().polish_max_vertices
            )
        }
        (PolishOutcome::NothingToMove | PolishOutcome::Ran, _) => "polish: not run".into(),
    }
}
