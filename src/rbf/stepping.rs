//! Interpolated constraint stepping (§IV.B, the loop after Eq. 7) with the
//! exact foldover guard and step halving.
//!
//! Each iteration fits the thin-plate spline of Eq. 6 that moves every
//! constrained vertex a fraction `t` of its remaining way to its target
//! (outer-boundary anchors held with zero displacement, so the boundary stays
//! on the square), applies it to every free vertex, and asks the guard. A fold
//! halves `t`; an accepted step resets `t = 1`. The path **stalls** when
//! `stall_iterations` iterations in a row (default one) need ≥
//! `stall_halvings` halvings, when no step survives `max_halvings` halvings,
//! or at `max_iterations` (halving rarely rescues a stalled run, so it stops
//! early: docs/algorithm.md). When the completion takes over after a stall,
//! the last heavy iteration is not finished: the stall is called at its
//! `stall_halvings`-th halving, since the completion starts from the step-1
//! layout anyway.

use super::tps::{ThinPlateSpline, TpsError};
use crate::options::SolverOptions;
use glam::DVec2;

/// The fixed data of one chart's stepping.
#[derive(Debug, Clone, Default)]
pub struct StepProblem {
    /// Constrained vertices (filled-chart ids; on the square, never on the
    /// outer boundary, which the boundary map places).
    pub constraint_vertices: Vec<u32>,
    /// Their targets in layout coordinates (same order).
    pub targets: Vec<DVec2>,
    /// Outer-boundary vertices used as zero-displacement centres (a free
    /// chart's are let go if the path stalls holding them).
    pub anchors: Vec<u32>,
    /// Vertices the spline moves: on the square everything but the outer
    /// boundary, on a free chart every vertex (virtual hole vertices included).
    pub movable: Vec<u32>,
}

impl StepProblem {
    /// The largest distance of a constrained vertex from its target.
    pub fn max_residual(&self, layout: &[DVec2]) -> f64 {
        self.constraint_vertices
            .iter()
            .zip(&self.targets)
            .map(|(&v, t)| layout[v as usize].distance(*t))
            .fold(0.0, f64::max)
    }
}

/// Evenly spaced subset (by loop index) of `outer_loop`, at most `max` vertices
/// (all of them when the loop is shorter), always including `must` vertices.
pub fn pick_anchors(outer_loop: &[u32], max: usize, must: &[u32]) -> Vec<u32> {
    let n = outer_loop.len();
    let mut anchors: Vec<u32> = if n <= max {
        outer_loop.to_vec()
    } else {
        (0..max).map(|k| outer_loop[k * n / max]).collect()
    };
    for &v in must {
        if !anchors.contains(&v) {
            anchors.push(v);
        }
    }
    anchors
}

/// The full step (`t = 1`) of Eq. 6 from `layout`: the spline displacement
/// of every movable vertex (same order as `problem.movable`). The spline is
/// linear in the displacements it interpolates, so the step of fraction `t`
/// is exactly `t` times this field: halving a step needs no new evaluation
/// ([`apply_step`]).
///
/// # Errors
/// A [`TpsError`] when the centres make the spline system singular.
pub fn full_step(layout: &[DVec2], problem: &StepProblem) -> Result<FullStep, TpsError> {
    let spline = fit_spline(layout, problem)?;
    let field = displace_all(&spline, layout, &problem.movable);
    Ok(FullStep { spline, field })
}

/// The spline of a full step from `layout`: each constrained vertex
/// displaced onto its target, each anchor held.
///
/// # Errors
/// A [`TpsError`] when the centres make the spline system singular.
pub fn fit_spline(layout: &[DVec2], problem: &StepProblem) -> Result<ThinPlateSpline, TpsError> {
    let mut centres = Vec::with_capacity(problem.constraint_vertices.len() + problem.anchors.len());
    let mut displacements = Vec::with_capacity(centres.capacity());
    for (&v, &target) in problem.constraint_vertices.iter().zip(&problem.targets) {
        let p = layout[v as usize];
        centres.push(p);
        displacements.push(target - p);
    }
    for &v in &problem.anchors {
        centres.push(layout[v as usize]);
        displacements.push(DVec2::ZERO);
    }
    ThinPlateSpline::fit(&centres, &displacements)
}

/// The spline of a full step and its displacement of every movable vertex.
#[derive(Debug, Clone)]
pub struct FullStep {
    pub spline: ThinPlateSpline,
    pub field: Vec<DVec2>,
}

impl FullStep {
    /// The paper's foldover condition (Eq. 5/7) for the step of fraction `t`:
    /// `det(I + t ∇ΔX) > 0` at every constrained vertex of `layout`, and
    /// nowhere else (so folds between constraint points go unnoticed).
    pub fn paper_guard_accepts(&self, layout: &[DVec2], problem: &StepProblem, t: f64) -> bool {
        problem.constraint_vertices.iter().all(|&v| {
            let [jx, jy] = self.spline.jacobian(layout[v as usize]);
            let (a, b) = (DVec2::X + jx * t, DVec2::Y + jy * t);
            a.perp_dot(b) > 0.0
        })
    }
}

/// Candidate layout for a step of fraction `t` (Eq. 6) given the
/// [`full_step`] field: each constrained vertex `p_i` moves to
/// `p_i + t (target_i − p_i)` (exactly onto its target when `t = 1`),
/// anchors stay, and every movable vertex moves by `t` times the field.
pub fn apply_step(layout: &[DVec2], problem: &StepProblem, full: &[DVec2], t: f64) -> Vec<DVec2> {
    let mut candidate = layout.to_vec();
    for (&v, d) in problem.movable.iter().zip(full) {
        candidate[v as usize] += *d * t;
    }
    for (&v, &target) in problem.constraint_vertices.iter().zip(&problem.targets) {
        let p = layout[v as usize];
        candidate[v as usize] = if t == 1.0 { target } else { p + (target - p) * t };
    }
    candidate
}

/// Spline evaluations (vertices × centres) above which the work is split
/// over rayon's threads; below it the split costs more than it saves.
const PARALLEL_EVALUATIONS: usize = 40_000;

/// `layout[v] + ΔX(layout[v])` for every `v` of `vertices` (Eq. 6), split
/// over rayon's pool when there is enough work.
fn displace_all(spline: &ThinPlateSpline, layout: &[DVec2], vertices: &[u32]) -> Vec<DVec2> {
    use rayon::prelude::*;
    if vertices.len() * spline.centres.len() < PARALLEL_EVALUATIONS {
        return spline.displacements(layout, vertices);
    }
    let chunk = vertices.len().div_ceil(rayon::current_num_threads()).max(1);
    vertices
        .par_chunks(chunk)
        .map(|part| spline.displacements(layout, part))
        .collect::<Vec<_>>()
        .concat()
}

/// Where the spline path stands.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "phase", content = "reason")]
pub enum SteppingPhase {
    Stepping,
    /// Every constraint within tolerance.
    Reached,
    /// The spline path cannot go on; the reason in words.
    Stalled(String),
    /// Not run (`completion: Always`).
    Skipped,
}

/// Progress of the stepping loop; advanced by [`SteppingState::record_guard`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SteppingState {
    pub phase: SteppingPhase,
    /// Accepted steps so far.
    pub iterations: u32,
    /// Fraction of the remaining way the next proposal tries.
    pub t: f64,
    pub halvings_this_iteration: u32,
    pub total_halvings: u32,
    heavy_streak: u32,
    /// The completion takes over after a stall: the iteration that completes
    /// a streak of heavy ones is a stall at its `stall_halvings`-th halving.
    #[serde(skip)]
    completion_follows: bool,
}

impl SteppingState {
    /// Starts stepping, or is already `Reached` when every residual is
    /// within tolerance. `completion_follows`: a stall hands over to the
    /// completion (the chart solver's policy decides).
    pub fn start(problem: &StepProblem, layout: &[DVec2], options: &SolverOptions, completion_follows: bool) -> Self {
        let phase = if problem.max_residual(layout) <= options.tolerance {
            SteppingPhase::Reached
        } else if options.completion == crate::options::Completion::Always {
            SteppingPhase::Skipped
        } else {
            SteppingPhase::Stepping
        };
        SteppingState {
            phase,
            iterations: 0,
            t: 1.0,
            halvings_this_iteration: 0,
            total_halvings: 0,
            heavy_streak: 0,
            completion_follows,
        }
    }

    pub fn is_stepping(&self) -> bool {
        self.phase == SteppingPhase::Stepping
    }

    /// Records the guard's verdict on the proposal at `self.t`. On acceptance
    /// `max_residual` is the accepted layout's largest residual.
    pub fn record_guard(&mut self, accepted: bool, max_residual: f64, options: &SolverOptions) {
        if !self.is_stepping() {
            return;
        }
        if !accepted {
            self.halvings_this_iteration += 1;
            self.total_halvings += 1;
            self.t *= 0.5;
            if self.halvings_this_iteration > options.max_halvings {
                self.phase = SteppingPhase::Stalled(format!(
                    "no fold-free step found after {} halvings (step < 2^-{})",
                    options.max_halvings, options.max_halvings
                ));
            } else if self.completion_follows
                && self.halvings_this_iteration >= options.stall_halvings
                && self.heavy_streak + 1 >= options.stall_iterations
            {
                // This iteration is heavy whatever step it ends with, and it
                // completes the streak: finishing it would only be thrown away.
                self.phase = SteppingPhase::Stalled(stall_reason(options));
            }
            return;
        }
        self.iterations += 1;
        if self.halvings_this_iteration >= options.stall_halvings {
            self.heavy_streak += 1;
        } else {
            self.heavy_streak = 0;
        }
        self.halvings_this_iteration = 0;
        self.t = 1.0;
        if max_residual <= options.tolerance {
            self.phase = SteppingPhase::Reached;
        } else if self.heavy_streak >= options.stall_iterations {
            self.phase = SteppingPhase::Stalled(stall_reason(options));
        } else if self.iterations >= options.max_iterations {
            self.phase = SteppingPhase::Stalled(format!("iteration cap of {} reached", options.max_iterations));
        }
    }

    /// Records a proposal that could not be made (singular spline system).
    pub fn record_failure(&mut self, error: &TpsError) {
        self.phase = SteppingPhase::Stalled(format!("spline system: {error}"));
    }
}

/// Why the spline path stopped: its heavy iterations.
fn stall_reason(options: &SolverOptions) -> String {
    match options.stall_iterations {
        0 | 1 => format!("an iteration needed ≥ {} halvings", options.stall_halvings),
        n => format!("{n} iterations in a row needed ≥ {} halvings", options.stall_halvings),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether a completion follows a stall with these options (the
    /// chart solver's policy: the exact guard and `completion: Auto`).
    fn follows(o: &SolverOptions) -> bool {
        o.guard == crate::options::Guard::Exact && o.completion == crate::options::Completion::Auto
    }

    #[test]
    fn halving_then_acceptance_then_reached() {
        let o = SolverOptions::DEFAULT;
        let problem = StepProblem {
            constraint_vertices: vec![0],
            targets: vec![DVec2::ONE],
            ..Default::default()
        };
        let mut s = SteppingState::start(&problem, &[DVec2::ZERO], &o, follows(&o));
        assert!(s.is_stepping());
        s.record_guard(false, 0.0, &o);
        assert_eq!((s.t, s.total_halvings), (0.5, 1));
        s.record_guard(true, 0.5, &o);
        assert_eq!((s.t, s.iterations, s.halvings_this_iteration), (1.0, 1, 0));
        s.record_guard(true, 0.0, &o);
        assert_eq!(s.phase, SteppingPhase::Reached);
    }

    #[test]
    fn heavy_iterations_stall() {
        let problem = StepProblem {
            constraint_vertices: vec![0],
            targets: vec![DVec2::ONE],
            ..Default::default()
        };
        // Spline path alone (no completion after it): every heavy iteration
        // is finished, and two in a row stall.
        let mut o = SolverOptions::DEFAULT;
        o.stall_iterations = 2;
        o.completion = crate::options::Completion::Never;
        let mut s = SteppingState::start(&problem, &[DVec2::ZERO], &o, follows(&o));
        for _ in 0..2 {
            for _ in 0..o.stall_halvings {
                s.record_guard(false, 0.0, &o);
            }
            assert!(s.is_stepping());
            s.record_guard(true, 0.3, &o);
        }
        assert!(matches!(s.phase, SteppingPhase::Stalled(_)), "{:?}", s.phase);
        assert_eq!((s.iterations, s.total_halvings), (2, 2 * o.stall_halvings));

        // With the completion to follow, the heavy iteration that completes
        // the streak stops at its `stall_halvings`-th halving.
        o.completion = crate::options::Completion::Auto;
        let mut s = SteppingState::start(&problem, &[DVec2::ZERO], &o, follows(&o));
        for _ in 0..o.stall_halvings {
            s.record_guard(false, 0.0, &o);
        }
        s.record_guard(true, 0.3, &o);
        for _ in 0..o.stall_halvings {
            assert!(s.is_stepping());
            s.record_guard(false, 0.0, &o);
        }
        assert!(matches!(s.phase, SteppingPhase::Stalled(_)), "{:?}", s.phase);
        assert_eq!((s.iterations, s.total_halvings), (1, 2 * o.stall_halvings));

        // The defaults: the first heavy iteration is a stall.
        let o = SolverOptions::DEFAULT;
        let mut s = SteppingState::start(&problem, &[DVec2::ZERO], &o, follows(&o));
        s.record_guard(false, 0.0, &o);
        s.record_guard(true, 0.5, &o);
        for _ in 0..o.stall_halvings {
            assert!(s.is_stepping());
            s.record_guard(false, 0.0, &o);
        }
        let SteppingPhase::Stalled(reason) = &s.phase else {
            panic!("{:?}", s.phase)
        };
        assert_eq!(reason, "an iteration needed ≥ 3 halvings");
        assert_eq!((s.iterations, s.total_halvings), (1, 1 + o.stall_halvings));
    }

    #[test]
    fn anchors_are_subsampled_but_keep_required_vertices() {
        let lp: Vec<u32> = (0..100).collect();
        let a = pick_anchors(&lp, 10, &[33]);
        assert_eq!(a.len(), 11);
        assert!(a.contains(&33) && a.contains(&0));
        assert_eq!(pick_anchors(&lp[..8], 10, &[3]), lp[..8].to_vec());
    }
}
