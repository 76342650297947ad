//! The polish: with the targets reached, Newton steps on the symmetric
//! Dirichlet energy with the constrained vertices (and the boundary) held.
//! It also spreads a layout whose triangles are too small for f32 until it
//! can be stored.

use super::context::{NewtonContext, StepRequest};
use super::{POLISH_TOLERANCE, REPAIR_STEPS};
use crate::options::SolverOptions;
use crate::rbf::stepping::StepProblem;
use glam::DVec2;

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
    /// A free chart's polish holds its scaffold's slivers fuller first
    /// ([`super::context::SCAFFOLD_MIN_HEIGHT`]); their own shapes follow
    /// once that stage stops gaining. At rest in its own shape a sliver
    /// never pushes back, so a part of the chart pressed against its
    /// region's border (targets that fill the texture) or against another
    /// part of its boundary (the alligator's closed mouth) stays pressed:
    /// every step toward relief is cut at the sliver (3 % and then 0.6 % of
    /// the Newton step on the camel's head, 0.2 % on the alligator), and
    /// the polish stops at once.
    floored: bool,
    energy_now: f64,
    pub stats: PolishStats,
}

impl Polish {
    /// The polish of `layout` toward `goal`, holding `problem`'s constrained
    /// vertices; a free chart's scaffold rests in its own shapes after a
    /// first stage with its slivers held fuller (`newton` comes with them
    /// so).
    pub fn new(mut newton: NewtonContext, problem: &StepProblem, layout: &[DVec2], goal: PolishGoal) -> Self {
        let floored = newton.is_free() && goal == PolishGoal::Distortion;
        if !floored {
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
            floored,
            energy_now: energy_start,
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
        let stuck = step.alpha == 0.0 || steps + 1 >= REPAIR_STEPS;
        if self.floored && finished && !out_of_steps && self.newton.is_storable() {
            // The squeeze is relieved as far as the fuller slivers push: on
            // with the scaffold in its own shapes, a barrier only.
            self.floored = false;
            self.newton.scaffold_in_own_shapes(layout);
            self.energy_now = self.newton.energy(layout);
            return false;
        }
        (finished && self.newton.is_storable()) || stuck
    }
}
