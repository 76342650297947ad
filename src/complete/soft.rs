//! The soft-to-hard completion: from the step-1 layout, minimise
//! `SD(x) + w/2 · Σ |x_c − t_c|²` by projected Newton, the weight growing
//! each round, and snap the constrained vertices onto their targets as soon
//! as that keeps every triangle positive (as stored).

use super::attempts::{Attempts, PathBudget, RoundEnd, TargetPath};
use super::context::{NewtonContext, StepRequest};
use super::energy::{self, RestTriangle};
use super::newton::SoftTargets;
use super::obstruction::Obstruction;
use super::{POLISH_TOLERANCE, PROGRESSIVE_CAP, Pinned, REPAIR_STEPS, RepairWatch, find_obstruction};
use crate::options::SolverOptions;
use crate::param::bar_net::FilledChart;
use crate::rbf::stepping::StepProblem;
use glam::DVec2;

/// A soft round ends when a Newton step gains less than this (relative):
/// rounds are continuation steps toward the hard constraints, not solves.
const ROUND_TOLERANCE: f64 = 1e-2;

/// The repair goes on while a Newton step still lowers the energy by this
/// much (relative).
const REPAIR_GAIN: f64 = 0.05;

/// What the soft rounds did (for the report and `--explain`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SoftStats {
    pub rounds: u32,
    pub newton_steps: u32,
    /// Steps spent spreading a start too squeezed for f32, before the rounds.
    pub repair_steps: u32,
    /// The start could not be stored as f32 (so the repair ran first).
    pub started_unstorable: bool,
    /// The round in which the constrained vertices were put exactly on
    /// their targets, and how the targets travelled in that attempt.
    pub snapped_at_round: Option<u32>,
    pub snapped_path: Option<TargetPath>,
    /// Some constraints' straight paths meet head-on, so arcs were tried first.
    pub paths_cross: bool,
    /// A certificate that the targets are unreachable ([`super::obstruction`]),
    /// found when the rounds started: then one straight attempt only.
    pub obstruction: Option<Obstruction>,
    /// Symmetric Dirichlet energy (area-weighted sum, 4 per unit area =
    /// isometry) at the start, and right after the snap.
    pub energy_start: f64,
    pub energy_snapped: Option<f64>,
    /// The largest energy of one real triangle (ψ) at the start and right after the snap.
    pub worst_start: f64,
    pub worst_snapped: Option<f64>,
    /// The most triangles any step measured against a progressive reference
    /// shape instead of their rest shape ([`PROGRESSIVE_CAP`]).
    pub capped_triangles: usize,
    /// Paths a [`PathBudget::First`] left untried.
    pub skipped_paths: usize,
}

/// Where the soft-to-hard phase stands after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SoftProgress {
    Working,
    /// The constrained vertices are exactly on their targets.
    Snapped,
    /// Every attempt is over; the layout is the closest one (not on target).
    Exhausted,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Stage {
    /// Spreading a start too squeezed to store as f32 (SD alone,
    /// constraints free) before the rounds begin.
    Repair { steps: u32 },
    /// Soft constraints with weight `weight` (before the energy scale).
    Round { round: u32, weight: f64, steps: u32 },
}

/// The soft-to-hard completion of one chart, one Newton step per call.
#[derive(Debug, Clone)]
pub struct SoftCompletion {
    newton: NewtonContext,
    stage: Stage,
    /// Made when the first round starts (after any repair).
    attempts: Option<Attempts>,
    /// The rounds' reference shapes, remade before each step (the rest
    /// shapes with [`PROGRESSIVE_CAP`] applied).
    reference: Vec<RestTriangle>,
    /// The current layout's energy (scales the pull: a badly squeezed start
    /// has energy ~1e20 and must not drown it).
    energy_now: f64,
    budget: PathBudget,
    repair_watch: RepairWatch,
    pub stats: SoftStats,
}

impl SoftCompletion {
    /// The completion from `layout` with the Newton machinery `newton`,
    /// trying the paths `budget` allows.
    pub fn new(
        newton: NewtonContext,
        filled: &FilledChart,
        problem: &StepProblem,
        (layout, budget): (&[DVec2], PathBudget),
        options: &SolverOptions,
    ) -> Self {
        let energy_start = newton.energy(layout);
        // The certificate pins the outer boundary. A free chart's (the
        // targets alone, [`Pinned::Targets`]) is left to the report: its
        // completion keeps every path, which lowers the distortion of a
        // layout left short.
        let obstruction = (!newton.is_free())
            .then(|| find_obstruction(filled, (layout, Pinned::BoundaryAndTargets), problem))
            .flatten();
        let stats = SoftStats {
            started_unstorable: !newton.is_storable(),
            obstruction,
            energy_start,
            worst_start: newton.worst_psi(layout),
            ..SoftStats::default()
        };
        let stage = if newton.is_storable() {
            first_round(options)
        } else {
            Stage::Repair { steps: 0 }
        };
        SoftCompletion {
            newton,
            stage,
            attempts: None,
            reference: Vec::new(),
            energy_now: energy_start,
            budget,
            repair_watch: RepairWatch::default(),
            stats,
        }
    }

    /// The layout's energy against the rest shapes after the last step.
    pub fn energy(&self) -> f64 {
        self.energy_now
    }

    pub fn newton(&self) -> &NewtonContext {
        &self.newton
    }

    /// The Newton machinery, for the polish that follows a snap.
    pub fn into_newton(self) -> NewtonContext {
        self.newton
    }

    /// One Newton step on `layout`, which stays fold-free.
    pub fn step(&mut self, layout: &mut [DVec2], problem: &StepProblem, options: &SolverOptions) -> SoftProgress {
        let progress = match self.stage {
            Stage::Repair { steps } => {
                self.repair(layout, steps, options);
                SoftProgress::Working
            }
            Stage::Round { round, weight, steps } => self.round_step(layout, problem, options, (round, weight, steps)),
        };
        self.energy_now = self.newton.energy(layout);
        progress
    }

    /// A step of SD alone, until the layout can be stored as f32 and the
    /// distortion has settled too (rounds from a layout that is merely
    /// storable crawl: tiny safe steps).
    fn repair(&mut self, layout: &mut [DVec2], steps: u32, options: &SolverOptions) {
        let request = StepRequest {
            reference: None,
            soft: None,
            held: None,
            tolerance: POLISH_TOLERANCE,
        };
        let step = self.newton.step(layout, request);
        self.stats.repair_steps += 1;
        let stuck = step.alpha == 0.0 || steps + 1 >= REPAIR_STEPS || self.repair_watch.stalled(&self.newton, layout);
        let settled = step.converged || step.energy_after > (1.0 - REPAIR_GAIN) * step.energy_before;
        self.stage = if (settled && self.newton.is_storable()) || stuck {
            first_round(options)
        } else {
            Stage::Repair { steps: steps + 1 }
        };
    }

    /// One Newton step of round `round` (weight `weight`, `steps` steps
    /// into it), then a snap if the targets can be taken.
    fn round_step(
        &mut self,
        layout: &mut [DVec2],
        problem: &StepProblem,
        options: &SolverOptions,
        (round, weight, steps): (u32, f64, u32),
    ) -> SoftProgress {
        let attempts = self.attempts.get_or_insert_with(|| {
            let a = Attempts::begin(layout, problem, self.stats.obstruction.is_some(), self.budget);
            self.stats.paths_cross = a.paths_cross();
            self.stats.skipped_paths = a.skipped();
            a
        });
        let capped = energy::progressive_rest(
            self.newton.rest(),
            layout,
            self.newton.triangles(),
            PROGRESSIVE_CAP,
            &mut self.reference,
        );
        self.stats.capped_triangles = self.stats.capped_triangles.max(capped);
        let moving = attempts.moving_targets(round);
        let soft = SoftTargets {
            vertices: &problem.constraint_vertices,
            targets: moving.as_deref().unwrap_or(&problem.targets),
            weight: weight * (self.energy_now / 4.0).max(1.0),
        };
        let request = StepRequest {
            reference: Some(&self.reference),
            soft: Some(soft),
            held: None,
            tolerance: ROUND_TOLERANCE,
        };
        let step = self.newton.step(layout, request);
        self.stats.newton_steps += 1;
        self.stats.rounds = round + 1;
        if self.newton.try_snap(layout, problem) {
            self.snapped(layout, round);
            return SoftProgress::Snapped;
        }
        // A round ends when its step converged, or was a full Newton step
        // (the barrier did not cut it short, so the layout is near this
        // weight's minimum: more steps here gain less than moving on).
        let round_over = step.converged || step.alpha >= 1.0 || steps + 1 >= options.newton_iterations;
        if !round_over {
            self.stage = Stage::Round {
                round,
                weight,
                steps: steps + 1,
            };
            return SoftProgress::Working;
        }
        self.end_round(layout, problem, options, (round, weight))
    }

    /// The round is over: the next round, the next attempt, or the end.
    fn end_round(
        &mut self,
        layout: &mut [DVec2],
        problem: &StepProblem,
        options: &SolverOptions,
        (round, weight): (u32, f64),
    ) -> SoftProgress {
        let attempts = self.attempts.as_mut().expect("rounds have attempts");
        let residual = problem.max_residual(layout);
        attempts.consider(layout, residual, self.newton.mean_psi(layout));
        let last_round = round + 1 >= options.completion_rounds;
        if attempts.end_round(round, residual, last_round) == RoundEnd::Continue {
            self.stage = Stage::Round {
                round: round + 1,
                weight: weight * options.weight_growth,
                steps: 0,
            };
            return SoftProgress::Working;
        }
        let another = attempts.next_attempt(layout, residual);
        self.newton.recount(layout);
        if another {
            self.stage = first_round(options);
            SoftProgress::Working
        } else {
            SoftProgress::Exhausted
        }
    }

    /// Records the snap onto the targets in round `round`.
    fn snapped(&mut self, layout: &[DVec2], round: u32) {
        self.stats.snapped_at_round = Some(round);
        self.stats.snapped_path = self.attempts.as_ref().map(Attempts::path);
        self.stats.energy_snapped = Some(self.newton.energy(layout));
        self.stats.worst_snapped = Some(self.newton.worst_psi(layout));
    }

    /// Whether the snapped layout is more distorted than the start: higher
    /// symmetric Dirichlet energy in all, or in its worst triangle.
    pub fn snap_distorted(&self) -> bool {
        let s = &self.stats;
        s.energy_snapped.is_some_and(|e| e > s.energy_start) || s.worst_snapped.is_some_and(|w| w > s.worst_start)
    }

    pub fn is_storable(&self) -> bool {
        self.newton.is_storable()
    }
}

fn first_round(options: &SolverOptions) -> Stage {
    Stage::Round {
        round: 0,
        weight: options.initial_weight,
        steps: 0,
    }
}
