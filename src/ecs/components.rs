//! Components of a chart entity (nouns).

use crate::chart::PreparedChart;
use crate::complete::pattern::PendingNewtonPattern;
use crate::constraints::{ConstraintSource, LoadedConstraints};
use crate::error::Error;
use crate::io::SourceAsset;
use crate::options::SolverOptions;
use crate::param::bar_net::BarNet;
use crate::param::boundary::BoundaryMap;
use crate::report::{Report, StageTimes};
use crate::solver::ChartSolver;
use bevy_ecs::prelude::*;
use glam::DVec2;
use std::path::PathBuf;
use std::sync::Arc;

/// What to solve and where the result goes.
#[derive(Component, Debug, Clone)]
pub struct SolveJob {
    pub source: ConstraintSource,
    pub options: SolverOptions,
    pub asset: Arc<SourceAsset>,
    /// Output file; `None` solves without writing.
    pub output: Option<PathBuf>,
    /// Where the output and its pictures may be written (the daemon's
    /// output folder, or the watched folders in place, without making folders).
    pub writing: crate::io::atomic::Writing,
}

impl SolveJob {
    /// The job of a loaded constraint file (its solver options in force).
    pub fn from_file(loaded: LoadedConstraints, asset: Arc<SourceAsset>, output: Option<PathBuf>) -> Self {
        SolveJob {
            options: loaded.solver,
            source: ConstraintSource::File(Arc::new(loaded)),
            asset,
            output,
            writing: crate::io::atomic::Writing::default(),
        }
    }

    /// This job, written as `writing` allows.
    #[must_use]
    pub fn writing(mut self, writing: crate::io::atomic::Writing) -> Self {
        self.writing = writing;
        self
    }
}

/// The solved chart's mesh, topology, hole fill and constraints.
#[derive(Component, Debug, Clone)]
pub struct ChartData(pub Arc<PreparedChart>);

/// The outer loop on the square (§III.B).
#[derive(Component, Debug, Clone)]
pub struct BoundaryLayout(pub BoundaryMap);

/// The factored bar-net matrix D of Eq. 1, kept for re-solves.
#[derive(Component, Debug, Clone)]
pub struct BarNetFactor(pub Arc<BarNet>);

/// The step-1 layout (filled chart, layout coordinates).
#[derive(Component, Debug, Clone)]
pub struct Step1Layout(pub Vec<DVec2>);

/// The chart's solve from its step-1 layout: the spline path, completion
/// and polish, and the current (always fold-free) layout.
#[derive(Component, Debug, Clone)]
pub struct Solver(pub ChartSolver);

/// The completion's Newton pattern (sparsity, symbolic factorisation,
/// Hessian slots) for this chart's free set. It depends only on the mesh and
/// the free set, so it is kept across constraint edits of the same geometry.
#[derive(Component, Debug, Clone)]
pub struct NewtonPatternSlot(pub Arc<PendingNewtonPattern>);

/// A proposed layout waiting for the guard.
#[derive(Component, Debug, Clone)]
pub struct Candidate(pub Vec<DVec2>);

/// Time spent per stage on this chart outside the solver (loading,
/// topology, step 1, export).
#[derive(Component, Debug, Clone, Default)]
pub struct Timings(pub StageTimes);

/// The solve is over; its report (not yet written).
#[derive(Component, Debug, Clone)]
pub struct Finished(pub Report);

/// The final report after output (status `Error` if the write failed).
#[derive(Component, Debug, Clone)]
pub struct Exported(pub Report);

/// An input error found while solving; nothing is written.
#[derive(Component, Debug, Clone)]
pub struct Failed(pub Arc<Error>);

/// Pictures to draw once the solve is exported (see [`crate::preview`]).
#[cfg(feature = "pictures")]
#[derive(Component, Debug, Clone, Default)]
pub struct PreviewRequest(pub crate::preview::Pictures);
