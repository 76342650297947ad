//! Solver options: the `solver` section of a constraint file or of
//! `config/uvpin.ron`. Every field is optional; its default is in its doc.

#![warn(missing_docs)]

use serde::{Deserialize, Serialize};

/// When the completion phase runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Completion {
    /// After the spline path stalls (default).
    #[default]
    Auto,
    /// Always, from the step-1 layout, instead of the spline path.
    Always,
    /// Never: a stalled spline path ends `Partial`.
    Never,
}

/// Which foldover guard accepts a spline step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Guard {
    /// The exact orientation of every triangle, virtual ones included, in
    /// double precision and as stored (default).
    #[default]
    Exact,
    /// The paper's pointwise condition (Eq. 5/7): the spline's Jacobian
    /// determinant positive at the constraint points only. For comparison:
    /// it lets folds through, there is no completion or polish, and a folded
    /// result is never written (the report says so).
    Paper,
}

/// Limits and switches of every phase.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverOptions {
    /// Foldover guard of the spline path (default `Exact`; `Paper` for comparison only).
    pub guard: Guard,
    /// Spline path: accepted steps at most (default 100).
    pub max_iterations: u32,
    /// Spline path: halvings of one step before it counts as stalled (default 20).
    pub max_halvings: u32,
    /// Spline path: an iteration needing at least this many halvings is "heavy" (default 3:
    /// it moved the constraints at most 1/8 of their remaining way).
    pub stall_halvings: u32,
    /// Spline path: this many heavy iterations in a row is a stall (default 1:
    /// in 1,500 random, warped and swirled cases no spline path that reached
    /// its targets had a heavy iteration; after a stall the completion takes
    /// over, which reaches them anyway).
    pub stall_iterations: u32,
    /// Spline path: outer-boundary vertices used as zero-displacement centres, at most (default 48).
    pub max_boundary_centres: usize,
    /// A constraint is reached when its residual is at most this, texture units (default 1e-9).
    pub tolerance: f64,
    /// When the completion phase runs (default `Auto`: after a stall).
    pub completion: Completion,
    /// Completion: soft-constraint rounds at most; the weight grows each round (default 14).
    pub completion_rounds: u32,
    /// Completion: Newton steps per round at most (default 10).
    pub newton_iterations: u32,
    /// Completion: weight of the soft constraints in the first round (default 10).
    pub initial_weight: f64,
    /// Completion: factor the weight grows by per round (default 10).
    pub weight_growth: f64,
    /// Distortion polish (symmetric Dirichlet, constraints and boundary held)
    /// once the targets are reached (default true).
    pub polish: bool,
    /// Polish: Newton steps at most (default 20).
    pub polish_iterations: u32,
    /// Polish charts up to this many vertices, where it is cheap (default
    /// 50000). Above it the polish follows only a completion whose snap left
    /// the layout more distorted than step 1.
    pub polish_max_vertices: usize,
    /// Stop the completion and polish after this many milliseconds of solving
    /// (default none): the best fold-free layout so far is kept.
    pub time_budget_ms: Option<f64>,
    /// A chart with more vertices than this is solved on a coarse level
    /// first, then prolonged and settled by local sweeps (default 5000):
    /// near-linear cost and a polish at any size (not a chart on the square
    /// with a landmark on its outer loop).
    pub multilevel_above: usize,
    /// Multilevel: vertices of the coarse level at most (default 16000, at
    /// least 500); a chart's coarse level has a sixteenth of its vertices up
    /// to that.
    pub multilevel_coarse: usize,
}

impl SolverOptions {
    /// The defaults: the exact guard, the completion and the polish on.
    pub const DEFAULT: SolverOptions = SolverOptions {
        guard: Guard::Exact,
        max_iterations: 100,
        max_halvings: 20,
        stall_halvings: 3,
        stall_iterations: 1,
        max_boundary_centres: 48,
        tolerance: 1e-9,
        completion: Completion::Auto,
        completion_rounds: 14,
        newton_iterations: 10,
        initial_weight: 10.0,
        weight_growth: 10.0,
        polish: true,
        polish_iterations: 20,
        polish_max_vertices: 50_000,
        time_budget_ms: None,
        multilevel_above: 5_000,
        multilevel_coarse: 16_000,
    };
}

/// A solver option out of its range: the field and the value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("solver.{field}: {why}, got {value}")]
pub struct OptionError {
    /// The option's name under `solver`.
    pub field: &'static str,
    /// The value given.
    pub value: f64,
    /// What it must be.
    pub why: &'static str,
}

impl SolverOptions {
    /// Checks the real-valued options: the tolerance and the first soft
    /// weight must be positive and finite, the weight's growth finite and
    /// at least 1, a time budget finite and not negative.
    ///
    /// # Errors
    /// The first option out of range.
    pub fn check(&self) -> Result<(), OptionError> {
        let positive = |field, value: f64| {
            (value.is_finite() && value > 0.0).then_some(()).ok_or(OptionError {
                field,
                value,
                why: "must be a positive number",
            })
        };
        positive("tolerance", self.tolerance)?;
        if self.multilevel_coarse < 500 {
            return Err(OptionError {
                field: "multilevel_coarse",
                value: self.multilevel_coarse as f64,
                why: "must be at least 500",
            });
        }
        positive("initial_weight", self.initial_weight)?;
        if !(self.weight_growth.is_finite() && self.weight_growth >= 1.0) {
            let why = "must be a number of at least 1";
            return Err(OptionError {
                field: "weight_growth",
                value: self.weight_growth,
                why,
            });
        }
        if let Some(ms) = self.time_budget_ms
            && !(ms.is_finite() && ms >= 0.0)
        {
            return Err(OptionError {
                field: "time_budget_ms",
                value: ms,
                why: "must be a number of milliseconds, 0 or more",
            });
        }
        Ok(())
    }
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_negative_and_infinite_settings_are_named() {
        assert_eq!(SolverOptions::DEFAULT.check(), Ok(()));
        let bad = |o: SolverOptions| o.check().unwrap_err().field;
        assert_eq!(
            bad(SolverOptions {
                initial_weight: f64::NAN,
                ..SolverOptions::DEFAULT
            }),
            "initial_weight"
        );
        assert_eq!(
            bad(SolverOptions {
                initial_weight: -1.0,
                ..SolverOptions::DEFAULT
            }),
            "initial_weight"
        );
        assert_eq!(
            bad(SolverOptions {
                weight_growth: 0.5,
                ..SolverOptions::DEFAULT
            }),
            "weight_growth"
        );
        assert_eq!(
            bad(SolverOptions {
                weight_growth: f64::INFINITY,
                ..SolverOptions::DEFAULT
            }),
            "weight_growth"
        );
        assert_eq!(
            bad(SolverOptions {
                tolerance: 0.0,
                ..SolverOptions::DEFAULT
            }),
            "tolerance"
        );
        assert_eq!(
            bad(SolverOptions {
                time_budget_ms: Some(-5.0),
                ..SolverOptions::DEFAULT
            }),
            "time_budget_ms"
        );
        let e = SolverOptions {
            initial_weight: -2.0,
            ..SolverOptions::DEFAULT
        }
        .check()
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "solver.initial_weight: must be a positive number, got -2"
        );
    }
}
