//! Components of a chart entity (nouns).

use crate::assembly::Solution;
use crate::constraints::{ConstraintSource, LoadedConstraints};
use crate::error::Error;
use crate::export::{Outputs, Written};
use crate::io::SourceAsset;
use crate::options::SolverOptions;
use crate::plan::ChartPlan;
use crate::session::ChartSession;
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
    /// What the solve writes (nothing by default), in one commit.
    pub outputs: Outputs,
}

impl SolveJob {
    /// The job of a loaded constraint file (its solver options in force),
    /// writing the asset to `output` if given.
    pub fn from_file(loaded: LoadedConstraints, asset: Arc<SourceAsset>, output: Option<PathBuf>) -> Self {
        SolveJob {
            options: loaded.solver,
            source: ConstraintSource::File(Arc::new(loaded)),
            asset,
            outputs: Outputs {
                model: output,
                ..Outputs::default()
            },
        }
    }

    /// This job, writing `outputs`.
    #[must_use]
    pub fn writing(mut self, outputs: Outputs) -> Self {
        self.outputs = outputs;
        self
    }

    /// The asset file this job writes, if any.
    pub fn output(&self) -> Option<&std::path::Path> {
        self.outputs.model.as_deref()
    }
}

/// The chart's session: its prepared chart, step 1 (boundary map, bar-net
/// factor, layout) and Newton pattern, kept across constraint edits.
#[derive(Component, Debug, Clone)]
pub struct Session(pub ChartSession);

/// The chart's solve ([`ChartPlan`]): its candidates, each a solver from
/// its start (the spline path, completion and polish, the current layout
/// always fold-free), then the chosen one finished; with the session
/// revision it started from.
#[derive(Component, Debug, Clone)]
pub struct Planning(pub ChartPlan, pub u64);

/// A proposed layout waiting for the guard.
#[derive(Component, Debug, Clone)]
pub struct Candidate(pub Vec<DVec2>);

/// The solve is over (not yet written): the chosen chart's solver, the
/// other charts holding landmarks, the report; with the session revision
/// it started from.
#[derive(Component, Debug, Clone)]
pub struct Finished(pub Solution, pub u64);

/// The final report after output (status `Error` if the write failed) and
/// the UVs as written.
#[derive(Component, Debug, Clone)]
pub struct Exported(pub Written);

/// An input error found while solving; nothing is written.
#[derive(Component, Debug, Clone)]
pub struct Failed(pub Arc<Error>);
