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

/// The completion's Newton pattern (sparsity, symbolic factorisation,
/// Hessian slots) for this chart's free set. It depends only on the mesh and
/// the free set, so it is kept across constraint edits of the same geometry;
/// when the polish will need it anyway it is built on another thread while
/// the spline path runs.
#[derive(Component, Debug, Clone)]
pub struct NewtonPatternSlot(pub Arc<PendingNewtonPattern>);

/// A [`NewtonPattern`](crate::complete::newton::NewtonPattern) being built
/// in the background, built, or not built yet.
#[derive(Debug)]
pub struct PendingNewtonPattern {
    filled: Arc<crate::param::bar_net::FilledChart>,
    movable: Vec<u32>,
    /// The movable vertices in step 1's elimination order, if known.
    order: Option<Arc<Vec<u32>>>,
    state: std::sync::Mutex<PatternState>,
}

type PatternResult = Result<Arc<crate::complete::newton::NewtonPattern>, crate::sparse::SparseError>;

#[derive(Debug)]
enum PatternState {
    NotStarted,
    Building(std::thread::JoinHandle<PatternResult>),
    Built(PatternResult),
}

impl PendingNewtonPattern {
    /// The pattern over `movable`, built on first use (in elimination order
    /// `order` if given, see [`crate::complete::newton_pattern`]).
    pub fn lazy(
        filled: Arc<crate::param::bar_net::FilledChart>,
        movable: Vec<u32>,
        order: Option<Arc<Vec<u32>>>,
    ) -> Self {
        PendingNewtonPattern {
            filled,
            movable,
            order,
            state: std::sync::Mutex::new(PatternState::NotStarted),
        }
    }

    /// The pattern over `movable`, started now on its own thread (built on
    /// first use instead if no thread can be started).
    pub fn in_background(
        filled: Arc<crate::param::bar_net::FilledChart>,
        movable: Vec<u32>,
        order: Option<Arc<Vec<u32>>>,
    ) -> Self {
        let pending = Self::lazy(filled.clone(), movable.clone(), order.clone());
        let build = move || {
            crate::complete::newton_pattern(&filled, &movable, order.as_deref().map(Vec::as_slice)).map(Arc::new)
        };
        if let Ok(handle) = std::thread::Builder::new()
            .name("uvpin-newton-pattern".into())
            .spawn(build)
        {
            *pending.state.lock().unwrap_or_else(|p| p.into_inner()) = PatternState::Building(handle);
        }
        pending
    }

    /// Whether this is the pattern over exactly `movable`.
    pub fn serves(&self, movable: &[u32]) -> bool {
        self.movable == movable
    }

    /// The pattern: waits for the background build, or builds it now.
    ///
    /// # Errors
    /// The pattern faer rejected (never for a valid mesh), or the build
    /// thread panicked.
    pub fn get(&self) -> PatternResult {
        let mut state = self.state.lock().unwrap_or_else(|p| p.into_inner());
        let result = match std::mem::replace(&mut *state, PatternState::NotStarted) {
            PatternState::Built(result) => result,
            PatternState::Building(handle) => handle.join().unwrap_or_else(|_| {
                Err(crate::sparse::SparseError::Pattern(
                    "the Newton pattern thread panicked".into(),
                ))
            }),
            PatternState::NotStarted => {
                crate::complete::newton_pattern(&self.filled, &self.movable, self.order.as_deref().map(Vec::as_slice))
                    .map(Arc::new)
            }
        };
        *state = PatternState::Built(result.clone());
        result
    }
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
