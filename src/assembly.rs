//! The assembly: a landmarked chart's solve ([`crate::plan`]) and what is
//! written beside it. The other charts and pieces holding landmarks are
//! solved after it, each clear of those before; a constraint no chart
//! names is reported unreached; the rest is unwrapped (once per session,
//! [`ChartSession::rest`]) and packed around them ([`crate::atlas`]); the
//! layout is checked as stored and written in one commit
//! ([`crate::export`]).
//!
//! ```text
//! ChartSession (the cache) ─ solve(session, options)
//!        ▼
//! ChartPlan: candidates on the coarse level, the winner finished    (crate::plan)
//!        ▼
//! finish: the chosen chart kept, secondaries solved (the chart again, clear
//!         of a short one's targets, when that reaches more), every
//!         constraint reported
//!        ▼
//! export(session, solution, outputs)                                (one commit)
//! ```

#![warn(missing_docs)]

use crate::chart;
use crate::complete::obstruction::{Obstruction, find_obstruction};
use crate::error::Error;
use crate::export::{self, Outputs, Secondary, Written};
use crate::io::corners::CornerUvs;
use crate::mesh::weld::Chart;
use crate::options::SolverOptions;
use crate::pins::ResolvedConstraint;
use crate::plan::ChartPlan;
use crate::report::{self, Report};
use crate::session::{ChartSession, StartFrom};
use crate::solver::{ChartSolver, Progress, Stage};
use glam::DVec2;
use std::sync::Arc;

/// A finished solve, not yet written: the landmarked chart's solver (its
/// final layout and record), the other charts holding landmarks solved
/// around it, and the report of them all.
#[derive(Debug, Clone)]
pub struct Solution {
    /// The landmarked chart's finished solver.
    pub solver: ChartSolver,
    /// The other charts and pieces holding landmarks, solved after it.
    pub secondary: Arc<Vec<Secondary>>,
    /// What was reached, and how.
    pub report: Report,
}

/// The other charts and pieces solved after the landmarked chart, their
/// reports, and those that could not be solved (with why), to be laid out
/// with the rest.
struct Secondaries {
    solved: Vec<Secondary>,
    reports: Vec<Report>,
    unsolved: Vec<(Arc<Chart>, String)>,
}

/// Solves `session`'s constraints from start to end; the session becomes
/// the chart as chosen.
///
/// # Errors
/// As [`ChartPlan::advance`]: every candidate failed to open (the first
/// one's error), or a Newton system could not be built (a bug).
pub fn solve(session: &mut ChartSession, options: &SolverOptions) -> Result<Solution, Error> {
    solve_watching(session, options, &mut |_| {})
}

/// As [`solve`], telling `watch` where it stands: each stage as it begins,
/// and after every tick.
///
/// # Errors
/// As [`solve`].
pub fn solve_watching(
    session: &mut ChartSession,
    options: &SolverOptions,
    watch: &mut dyn FnMut(Progress),
) -> Result<Solution, Error> {
    let solved = run(session, options, StartFrom::StepOne, &|| false, watch)?;
    solved.ok_or_else(|| Error::Internal("a solve that nothing stops was stopped".into()))
}

/// As [`solve`], started `from` where asked; `stop` is asked between ticks,
/// and when it says so the solve is dropped (`None`, the session as it was).
///
/// # Errors
/// As [`solve`].
pub fn solve_until(
    session: &mut ChartSession,
    options: &SolverOptions,
    from: StartFrom,
    stop: &dyn Fn() -> bool,
) -> Result<Option<Solution>, Error> {
    run(session, options, from, stop, &mut |_| {})
}

/// The one solve sequence: the plan ticked to its end, then [`finish`].
/// The ECS schedule runs the same plan system by system.
fn run(
    session: &mut ChartSession,
    options: &SolverOptions,
    from: StartFrom,
    stop: &dyn Fn() -> bool,
    watch: &mut dyn FnMut(Progress),
) -> Result<Option<Solution>, Error> {
    watch(Progress::at(Stage::StepOne));
    let mut plan = ChartPlan::new(session.clone(), *options, from);
    while !plan.is_done() {
        if stop() {
            return Ok(None);
        }
        plan.tick()?;
        watch(plan.progress());
    }
    watch(Progress::at(Stage::Finishing));
    Ok(Some(finish(session, plan.into_solution()?, stop)))
}

/// A finished plan made a solution: its chart becomes `session`, the other
/// charts and pieces holding landmarks are solved around it, and every
/// constraint of the file is accounted for. When one of those falls short,
/// the chart is solved again clear of where their targets are, and the
/// two solves compared: the one reaching more constraints is kept (the
/// first when `stop` says so during the second).
pub fn finish(session: &mut ChartSession, planned: crate::plan::Solution, stop: &dyn Fn() -> bool) -> Solution {
    let options = *planned.solver.options();
    let mut best = around(session, planned);
    let all = |s: &Solution| reached(&s.report) == s.report.every_constraint().count();
    if !all(&best) {
        let again = cleared(session, &best, &options, stop);
        best = better_of(session, best, again, |n, first| {
            format!(
                "solved again clear of the other pieces' targets: {n} constraints reached, against {first} the first time"
            )
        });
    }
    if !all(&best) {
        let fresh = session
            .afresh()
            .and_then(|s| s.ok())
            .and_then(|s| solved_again(s, &options, stop));
        best = better_of(session, best, fresh, |n, first| {
            format!("laid out afresh without the atlas in its set: {n} constraints reached, against {first} keeping it")
        });
    }
    if let Some(note) = session.atlas_note() {
        best.report.warnings.push(note);
    }
    best
}

/// `first`, or `again` (and its session) when it reaches more constraints,
/// with `why` (constraints reached again and first) in its explain.
fn better_of(
    session: &mut ChartSession,
    first: Solution,
    again: Option<(ChartSession, Solution)>,
    why: impl Fn(usize, usize) -> String,
) -> Solution {
    match again {
        Some((again, mut solution)) if reached(&solution.report) > reached(&first.report) => {
            solution
                .report
                .explain
                .push(why(reached(&solution.report), reached(&first.report)));
            *session = again;
            session.forget_placed();
            solution
        }
        _ => first,
    }
}

/// Constraints reached in every chart of `report`.
fn reached(report: &Report) -> usize {
    report.every_constraint().filter(|c| c.reached).count()
}

/// How far the room kept for another chart reaches past its targets' box
/// (texture units).
const KEPT_FOR_OTHERS: f64 = 0.03;

/// `session`'s chart solved again clear of a box about the targets of each
/// other chart that `first` left short (grown by [`KEPT_FOR_OTHERS`]), and
/// the other charts around it; `None` when none fell short, the chart
/// is not free in the texture (on the square, or kept in its own atlas
/// island, where the other islands stay), has obstacles of its own
/// already, the solve fails, or `stop` says so.
fn cleared(
    session: &ChartSession,
    first: &Solution,
    options: &SolverOptions,
    stop: &dyn Fn() -> bool,
) -> Option<(ChartSession, Solution)> {
    let free_in_texture = session.prepared().domain.free().is_some_and(|f| f.island.is_none());
    if !free_in_texture || !session.pick().placed.is_empty() {
        return None;
    }
    let kept: Vec<[DVec2; 3]> = first
        .report
        .charts
        .iter()
        .filter(|r| r.constraints.iter().any(|c| !c.reached))
        .flat_map(|r| {
            let (lo, hi) = crate::injective::bounds(r.constraints.iter().map(|c| crate::param::uv_to_xy(c.target)));
            box_triangles(lo - KEPT_FOR_OTHERS, hi + KEPT_FOR_OTHERS)
        })
        .collect();
    if kept.is_empty() {
        return None;
    }
    let pick = chart::Pick {
        placed: Arc::new(kept),
        ..session.pick().clone()
    };
    // Made anew: the first solve may have set pieces aside with the rest
    // of this session's chart, which the second does not inherit.
    solved_again(session.picked(pick).ok()?, options, stop)
}

/// `session` planned and finished around (no second solve of its own);
/// `None` when a solve fails or `stop` says so.
fn solved_again(
    session: ChartSession,
    options: &SolverOptions,
    stop: &dyn Fn() -> bool,
) -> Option<(ChartSession, Solution)> {
    let mut plan = ChartPlan::new(session, *options, StartFrom::StepOne);
    while !plan.is_done() {
        if stop() {
            return None;
        }
        plan.tick().ok()?;
    }
    let planned = plan.into_solution().ok()?;
    let mut again = planned.session.clone();
    let solution = around(&mut again, planned);
    Some((again, solution))
}

/// [`finish`] with the chart as solved: the others solved around it.
fn around(session: &mut ChartSession, planned: crate::plan::Solution) -> Solution {
    *session = planned.session;
    let (solver, mut report) = (planned.solver, planned.report);
    let mut secondary = Vec::new();
    if !(session.prepared().secondary.is_empty() && session.prepared().opening.pieces.is_empty()) {
        let Secondaries {
            solved,
            reports,
            unsolved,
        } = solve_secondary(session, &solver);
        report.add_charts(reports);
        secondary = solved;
        set_aside(session, unsolved, &mut report);
    }
    account_for_every_constraint(session, &mut report);
    Solution {
        solver,
        secondary: Arc::new(secondary),
        report,
    }
}

/// The other charts holding constraints, each solved free with its own
/// constraints, clear of `solver`'s layout and of those solved before it;
/// their reports, and why any could not be solved.
fn solve_secondary(session: &ChartSession, solver: &ChartSolver) -> Secondaries {
    let prepared = session.prepared();
    let mut placed = prepared.placed(solver.layout());
    let (mut solved, mut reports, mut unsolved) = (Vec::new(), Vec::new(), Vec::new());
    let charts = prepared.secondary.iter().map(|&id| (id, None));
    let pieces = prepared.opening.pieces.iter().map(|p| (p.id, Some(p.clone())));
    let items: Vec<(u32, Option<Arc<Chart>>)> = pieces.chain(charts).collect();
    let density = prepared.density(solver.layout());
    let resolved = (session.source())
        .resolve(&session.asset().primitives, &prepared.welded)
        .map(|(all, _)| all)
        .unwrap_or_default();
    let kept = KeptForLater::new(session, &resolved, &items);
    for (k, (id, piece)) in items.into_iter().enumerate() {
        let mut room = placed.clone();
        room.extend(kept.after(k));
        let outcome = session
            .beside(k, (id, piece.clone()), (&room, density))
            .and_then(|mut other| {
                let solution = solve(&mut other, solver.options())?;
                Ok((other.prepared().clone(), solution))
            });
        // Solved clear of what was laid out before it, as the scaffold
        // promises; checked as stored all the same.
        let outcome = outcome.and_then(|(piece, solution)| {
            let mut parts = vec![prepared.part(solver.layout())];
            parts.extend(solved.iter().map(|s: &Secondary| s.prepared.part(&s.layout)));
            parts.push(piece.part(solution.solver.layout()));
            match chart::overlap_of(&parts) {
                Some(overlap) => Err(Error::Internal(format!(
                    "it was laid out over the charts before it ({overlap})"
                ))),
                None => Ok((piece, solution)),
            }
        });
        match outcome {
            Ok((prepared, solution)) => {
                placed.extend(prepared.placed(solution.solver.layout()));
                reports.push(solution.report);
                solved.push(Secondary {
                    layout: solution.solver.layout().to_vec(),
                    prepared,
                });
            }
            // A chart or piece that cannot be solved is laid out with the
            // rest, its landmarks unreached: partial, never an error.
            Err(e) => {
                let (piece, why) = match piece {
                    Some(piece) => (piece, e.to_string()),
                    None => (Arc::new(prepared.welded.chart(id)), format!("chart {id}: {e}")),
                };
                let why = proof_for(&resolved, &piece).unwrap_or(why);
                unsolved.push((piece, why));
            }
        }
    }
    Secondaries {
        solved,
        reports,
        unsolved,
    }
}

/// The room kept about the targets of the charts and pieces solved after
/// each one, which a piece laid out before them would otherwise spread
/// over.
struct KeptForLater {
    /// Per chart or piece in solving order, its targets' box grown by
    /// [`KEPT_FOR_OTHERS`] (`None` without targets, or for a piece that a
    /// camera's view keeps room for already,
    /// [`chart::PreparedChart::reserved_after`]).
    boxes: Vec<Option<(DVec2, DVec2)>>,
    /// Per chart or piece, its own targets.
    targets: Vec<Vec<DVec2>>,
}

impl KeptForLater {
    /// Over `items` in solving order, `resolved` all of the file's
    /// constraints.
    fn new(session: &ChartSession, resolved: &[ResolvedConstraint], items: &[(u32, Option<Arc<Chart>>)]) -> Self {
        let prepared = session.prepared();
        let facing = matches!(session.pick().form, Some(crate::cut::prepare::Form::Facing { .. }));
        let (mut targets, mut boxes) = (Vec::new(), Vec::new());
        for (id, piece) in items {
            let chart = piece.clone().unwrap_or_else(|| Arc::new(prepared.welded.chart(*id)));
            let t: Vec<DVec2> = (resolved.iter())
                .filter(|c| chart.local_of(c.welded).is_some())
                .map(|c| crate::param::uv_to_xy(c.target_uv))
                .collect();
            let seen = facing && piece.is_some();
            boxes.push((!t.is_empty() && !seen).then(|| {
                let (lo, hi) = crate::injective::bounds(&t);
                (lo - KEPT_FOR_OTHERS, hi + KEPT_FOR_OTHERS)
            }));
            targets.push(t);
        }
        KeptForLater { boxes, targets }
    }

    /// The boxes of those after the `k`-th that hold none of its targets.
    fn after(&self, k: usize) -> Vec<[DVec2; 3]> {
        let own = &self.targets[k];
        let clear = |(lo, hi): &(DVec2, DVec2)| !own.iter().any(|t| t.cmpge(*lo).all() && t.cmple(*hi).all());
        (self.boxes[k + 1..].iter().flatten())
            .filter(|b| clear(b))
            .flat_map(|&(lo, hi)| box_triangles(lo, hi))
            .collect()
    }
}

/// The rectangle `lo..hi` as two counter-clockwise triangles.
fn box_triangles(lo: DVec2, hi: DVec2) -> [[DVec2; 3]; 2] {
    let (a, b, c, d) = (lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y));
    [[a, b, c], [a, c, d]]
}

/// Why `piece`'s landmarks (among `resolved`, all of the file's) cannot
/// all be in place, when their targets alone prove it (three on a
/// triangle mirror it, one lies inside a triangle of others, ...): the
/// reason a user can act on, rather than how the piece's solve failed.
fn proof_for(resolved: &[ResolvedConstraint], piece: &Chart) -> Option<String> {
    let n = piece.mesh.n_vertices();
    let (mut pins, mut index_of) = (vec![None; n], vec![None; n]);
    for c in resolved {
        if let Some(v) = piece.local_of(c.welded) {
            pins[v as usize] = Some(crate::param::uv_to_xy(c.target_uv));
            index_of[v as usize] = Some(c.index);
        }
    }
    let is_constraint: Vec<bool> = index_of.iter().map(Option::is_some).collect();
    let edges = crate::param::bar_net::unique_edges(&piece.mesh);
    // A boxed vertex is judged inside its neighbours' hull: a free piece
    // may have room outside it.
    let found = find_obstruction(&piece.mesh.triangles, &edges, &pins, &is_constraint, n)
        .filter(|o| !matches!(o, Obstruction::BoxedVertex { .. }))?;
    let name = |v: u32| index_of[v as usize].map_or(format!("vertex {v}"), |i| format!("constraints[{i}]"));
    Some(crate::complete::obstruction_hint(
        &found,
        |v| index_of[v as usize],
        name,
    ))
}

/// Pieces holding landmarks that could not be solved are laid out with the
/// rest, their constraints reported unreached: the result is partial,
/// never an error that writes nothing.
fn set_aside(session: &mut ChartSession, unsolved: Vec<(Arc<Chart>, String)>, report: &mut Report) {
    let Some((_, why)) = unsolved.first() else {
        return;
    };
    let message = format!(
        "{} piece(s) holding landmarks laid out without them: {why}",
        unsolved.len()
    );
    report_unreached(
        session,
        report,
        |c| unsolved.iter().any(|(piece, _)| piece.local_of(c.welded).is_some()),
        |_| message,
    );
    session.lay_with_rest(unsolved.into_iter().map(|(piece, _)| piece));
}

/// A constraint of the file that no chart's report names (its vertex set
/// apart by a repair, say) is reported unreached, its residual measured
/// where it is written: "k of n" counts every constraint, and exit 0 means
/// every one is on target.
fn account_for_every_constraint(session: &ChartSession, report: &mut Report) {
    // A chart solved after another (its pick replaces charts) reports only
    // its own constraints; the first one accounts for them all.
    if !session.pick().replaced.is_empty() {
        return;
    }
    let charts = report.charts.iter().flat_map(|r| &r.constraints);
    let named: std::collections::HashSet<usize> = report.constraints.iter().chain(charts).map(|c| c.index).collect();
    report_unreached(
        session,
        report,
        |c| !named.contains(&c.index),
        |first| {
            format!(
                "constraints[{first}] is on a part of the mesh that was laid out without it (set apart by a repair, or a \
                 piece that could not be solved)"
            )
        },
    );
}

/// The file's constraints that `unreached` picks, reported unreached (their
/// residuals are measured where they are written); a reached report
/// becomes partial, with `message` of the first one's index.
fn report_unreached(
    session: &ChartSession,
    report: &mut Report,
    unreached: impl Fn(&ResolvedConstraint) -> bool,
    message: impl FnOnce(usize) -> String,
) {
    let resolved = session
        .source()
        .resolve(&session.asset().primitives, &session.prepared().welded);
    let missing: Vec<report::ConstraintReport> = resolved
        .iter()
        .flat_map(|(all, _)| all)
        .filter(|c| unreached(c))
        .map(|c| report::ConstraintReport::of(c, DVec2::NAN, DVec2::NAN, f64::INFINITY, false))
        .collect();
    let Some(first) = missing.first().map(|c| c.index) else {
        return;
    };
    report.constraints.extend(missing);
    report.max_residual = f64::INFINITY;
    if report.status == report::Status::Reached {
        report.status = report::Status::Partial;
        report.message = Some(message(first));
    }
}

/// Checks `solution`'s layout as stored and writes what `outputs` names in
/// one commit ([`export::export`]): the final report, and the UVs as
/// written unless the layout was refused. Pictures without a background
/// are drawn over the constraint file's `image:`.
pub fn export(session: &ChartSession, solution: &Solution, outputs: &Outputs) -> Written {
    let rest = session.rest(solution.solver.options());
    let finished = finished(session, solution, &rest);
    #[cfg(feature = "pictures")]
    if outputs.pictures.any() && outputs.pictures.background.is_none() {
        let mut outputs = outputs.clone();
        outputs.pictures.background = session.source().image_path();
        return export::export(&finished, &solution.report, &outputs);
    }
    export::export(&finished, &solution.report, outputs)
}

/// The final UVs per face corner of every primitive, as a file would store
/// them, with the checks and packing of [`export()`]: the final report, and
/// the UVs unless it refused the layout.
pub fn final_uvs(session: &ChartSession, solution: &Solution) -> (Report, Option<Vec<CornerUvs>>) {
    let mut report = solution.report.clone();
    let rest = session.rest(solution.solver.options());
    let uvs = export::final_uvs(&finished(session, solution, &rest), &mut report);
    (report, uvs)
}

/// `solution` as the export reads it: the chart, its layout, the rest to
/// pack around it and the secondary charts.
fn finished<'a>(
    session: &'a ChartSession,
    solution: &'a Solution,
    rest: &'a crate::atlas::Rest,
) -> export::Finished<'a> {
    export::Finished {
        asset: session.asset(),
        prepared: session.prepared(),
        outer_loop: session.boundary().map_or(&[], |b| &b.loop_vertices),
        layout: solution.solver.layout(),
        guard: solution.solver.options().guard,
        rest: Some(rest),
        secondary: &solution.secondary,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pins::Pins;
    use glam::DVec3;

    #[test]
    fn a_chart_over_another_charts_targets_is_solved_again_clear_of_them() {
        // Two sheets apart in space: the first pinned along its left part,
        // the second, small, at two points where the first's right part
        // would lie.
        let grid = crate::testing::grid_mesh(12, 12);
        let n = grid.n_vertices() as u32;
        let mut mesh = grid.clone();
        mesh.positions
            .extend(grid.positions.iter().map(|p| *p * 0.05 + DVec3::X * 3.0));
        mesh.triangles.extend(grid.triangles.iter().map(|t| t.map(|v| v + n)));
        let at = |i: u32, j: u32| i + 12 * j;
        let pins = Pins::new(&[
            (at(0, 3), DVec2::new(0.2, 0.7)),
            (at(3, 3), DVec2::new(0.35, 0.7)),
            (at(3, 8), DVec2::new(0.35, 0.45)),
            (at(0, 8), DVec2::new(0.2, 0.45)),
            (n + at(4, 5), DVec2::new(0.62, 0.58)),
            (n + at(7, 5), DVec2::new(0.64, 0.58)),
        ]);
        let mut session = ChartSession::of_mesh(&mesh, pins).expect("a session");
        let solved = solve(&mut session, &SolverOptions::DEFAULT).expect("a solve");
        assert!(
            session.pick().placed.is_empty(),
            "the room kept for the second sheet is not kept for the next targets"
        );
        let r = &solved.report;
        assert_eq!(r.status, report::Status::Reached, "{:?}", r.message);
        assert!(
            r.explain.iter().any(|l| l.starts_with("solved again clear of")),
            "the first solve covered the second sheet's targets"
        );
    }
}
