//! Components of a chart entity (nouns).

use crate::chart::PreparedChart;
use crate::constraints::LoadedConstraints;
use crate::error::Error;
use crate::io::SourceAsset;
use crate::param::bar_net::BarNet;
use crate::param::boundary::BoundaryMap;
use crate::rbf::stepping::{StepProblem, SteppingState};
use crate::report::{Report, StageTimes};
use bevy_ecs::prelude::*;
use glam::DVec2;
use std::path::PathBuf;
use std::sync::Arc;

/// What to solve and where the result goes.
#[derive(Component, Debug, Clone)]
pub struct SolveJob {
    pub constraints: Arc<LoadedConstraints>,
    pub asset: Arc<SourceAsset>,
    /// Output file; `None` solves without writing.
    pub output: Option<PathBuf>,
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

/// The current, always fold-free layout (filled chart, layout coordinates).
#[derive(Component, Debug, Clone)]
pub struct Layout(pub Vec<DVec2>);

/// Spline stepping: the fixed problem and the progress.
#[derive(Component, Debug, Clone)]
pub struct Stepping {
    pub problem: StepProblem,
    pub state: SteppingState,
    /// The full-step spline field from the current layout (Eq. 6), kept
    /// while its step is being halved; cleared when a step is accepted.
    pub full_step: Option<crate::rbf::stepping::FullStep>,
    /// Whether the current layout is fold-free as stored (f32); carried from
    /// step to step instead of recounted.
    pub storable: bool,
}

/// The completion phase and polish (step 3), once the spline path is over.
#[derive(Component, Debug, Clone)]
pub struct Completing {
    pub state: crate::complete::CompletionState,
    /// The spline path's last layout when it stalled: kept if the completion
    /// ends further from the targets.
    pub spline_layout: Option<Vec<DVec2>>,
    /// Sander stretch before the polish started (targets reached).
    pub stretch_before_polish: Option<crate::metrics::Stretch>,
}

/// A proposed layout waiting for the guard.
#[derive(Component, Debug, Clone)]
pub struct Candidate(pub Vec<DVec2>);

/// Time spent per stage on this chart.
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
#[derive(Component, Debug, Clone, Default)]
pub struct PreviewRequest {
    /// The UV layout picture (PNG).
    pub layout: Option<PathBuf>,
    /// The 3D render with a checker or the texture (PNG).
    pub render: Option<PathBuf>,
    /// Width and height in pixels.
    pub size: u32,
}
