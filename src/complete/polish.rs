//! The polish: with the targets reached, Newton steps on the symmetric
//! Dirichlet energy with the constrained vertices (and the boundary) held.
//! It also spreads a layout whose triangles are too small for f32 until it
//! can be stored.

use super::context::{NewtonContext, StepRequest};
use super::{POLISH_TOLERANCE, REPAIR_STEPS, RepairWatch};
use crate::options::SolverOptions;
use crate::rbf::stepping::StepProblem;
use glam::DVec2;

/// A free chart whose worst real triangle starts the polish above this
/// energy (ψ per unit area, 4 = isometry; about a 30 × squeeze) is first
/// polished with its scaffold's slivers held fuller
/// ([`super::context::SCAFFOLD_MIN_HEIGHT`]), then in their own shapes. At
/// rest in its own shape a sliver never pushes back, so a triangle the
/// completion squeezed against another part of the boundary (the
/// alligator's closed mouth) stays squeezed: every step toward relief is
/// cut at the sliver (0.2 % of the Newton step), and the polish stops at
/// once (L2 1.571, L∞ 129; seed 7, 24 landmarks).
pub const SQUEEZED_PSI: f64 = 1000.0;

/// A free chart's polish in own shapes that stops on a step cut to less
/// than this share of the Newton step was stopped by a sliver, not by the
/// energy: a chart pressed against its region's border (targets that fill
/// the texture) has no squeezed triangle, yet its steps were cut to 3 %
/// and 0.6 % on the camel's head, and the polish stopped there (L2 1.473,
/// L∞ 12.7; 24 landmarks from the square). It goes on with the slivers
/// held fuller, then in own shapes again.
pub const BLOCKED_STEP: f64 = 0.25;

/// The rest shapes of a free chart's scaffold slivers in the polish.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slivers {
    /// Held fuller ([`super::context::SCAFFOLD_MIN_HEIGHT`], see
    /// [`SQUEEZED_PSI`] and [`BLOCKED_STEP`]); their own shapes follow once
    /// this stage stops gaining.
    Floored,
    /// Their own shapes; a sliver that stops the polish sends it to
    /// [`Slivers::Floored`] ([`BLOCKED_STEP`]).
    OwnMayFloor,
    /// Their own shapes to the end (a chart on the square, a polish only to
    /// store, or after [`Slivers::Floored`]).
    Own,
}

/// Why the polish runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PolishGoal {
    /// Lower the distortion (and make the layout storable on the way).
    Distortion,
    /// Only make a layout that f32 cannot store yet storable.
    Storable,
}

/// What the polish did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolishStats {
    pub goal: PolishGoal,
    pub steps: u32,
    /// Steps taken while the layout was not yet storable (not counted
    /// against `polish_iterations`).
    pub repair_steps: u32,
    /// The start could not be stored as f32.
    pub started_unstorable: bool,
    /// Energy when the polish started.
    pub energy_start: f64,
}

/// The polish of one chart, one Newton step per call.
#[derive(Debug, Clone)]
pub struct Polish {
    newton: NewtonContext,
    /// The constrained vertices, held where they are.
    held: Vec<bool>,
    slivers: Slivers,
    energy_now: f64,
    repair: RepairWatch,
    pub stats: PolishStats,
}

impl Polish {
    /// The polish of `layout` toward `goal`, holding `problem`'s constrained
    /// vertices; a free chart's scaffold rests in its own shapes (after a
    /// first stage with its slivers held fuller if a triangle starts
    /// squeezed, [`SQUEEZED_PSI`], or a sliver stops it, [`BLOCKED_STEP`];
    /// `newton` comes with them so).
    pub fn new(mut newton: NewtonContext, problem: &StepProblem, layout: &[DVec2], goal: PolishGoal) -> Self {
        let slivers = match newton.is_free() && goal == PolishGoal::Distortion {
            true if newton.worst_psi(layout) > SQUEEZED_PSI => Slivers::Floored,
            true => Slivers::OwnMayFloor,
            false => Slivers::Own,
        };
        if slivers != Slivers::Floored {
            newton.scaffold_in_own_shapes(layout);
        }
        let mut held = vec![false; layout.len()];
        problem
            .constraint_vertices
            .iter()
            .for_each(|&v| held[v as usize] = true);
        let energy_start = newton.energy(layout);
        Polish {
            stats: PolishStats {
                goal,
                steps: 0,
                repair_steps: 0,
                started_unstorable: !newton.is_storable(),
                energy_start,
            },
            newton,
            held,
            slivers,
            energy_now: energy_start,
            repair: RepairWatch::default(),
        }
    }

    pub fn newton(&self) -> &NewtonContext {
        &self.newton
    }

    /// The layout's energy after the last step.
    pub fn energy(&self) -> f64 {
        self.energy_now
    }

    /// One Newton step on `layout`; `true` when the polish is over (it
    /// stopped gaining, or ran out of steps, with the layout storable; or it
    /// is stuck).
    pub fn step(&mut self, layout: &mut [DVec2], options: &SolverOptions) -> bool {
        let repairing = !self.newton.is_storable();
        let request = StepRequest {
            reference: None,
            soft: None,
            held: Some(&self.held),
            tolerance: POLISH_TOLERANCE,
        };
        let step = self.newton.step(layout, request);
        self.energy_now = self.newton.energy(layout);
        let steps = self.stats.steps;
        self.stats.steps += 1;
        self.stats.repair_steps += u32::from(repairing);
        let gain = (step.energy_before - step.energy_after) / step.energy_before.max(1e-300);
        let out_of_steps = steps + 1 - self.stats.repair_steps >= options.polish_iterations;
        let finished =
            self.stats.goal == PolishGoal::Storable || step.converged || gain < POLISH_TOLERANCE || out_of_steps;
        let stuck = step.alpha == 0.0 || steps + 1 >= REPAIR_STEPS || self.repair.stalled(&self.newton, layout);
        if finished && !out_of_steps && self.newton.is_storable() {
            match self.slivers {
                // Stopped by a sliver: on with the slivers pushing back.
                Slivers::OwnMayFloor if step.alpha < BLOCKED_STEP => {
                    self.slivers = Slivers::Floored;
                    self.newton.scaffold_floored(layout);
                }
                // The squeeze is relieved as far as the fuller slivers push:
                // on with the scaffold in its own shapes, a barrier only.
                Slivers::Floored => {
                    self.slivers = Slivers::Own;
                    self.newton.scaffold_in_own_shapes(layout);
                }
                _ => return true,
            }
            self.energy_now = self.newton.energy(layout);
            return false;
        }
        (finished && self.newton.is_storable()) || stuck
    }
}
