//! One candidate solved at one level: the chart itself when it is small,
//! else its coarse level ([`crate::solver::multilevel::Level`]). A start
//! from the square is two solves in a row: the chart on the square (its
//! region mapped onto it, the targets with it), then free from there.
//! Tick by tick, as the chart solver is.

use super::candidates::Start;
use crate::chart::PreparedChart;
use crate::complete::pattern::PendingNewtonPattern;
use crate::constraints::ConstraintSource;
use crate::domain::Domain;
use crate::domain::start::StartKind;
use crate::error::Error;
use crate::options::SolverOptions;
use crate::param::bar_net::BarNet;
use crate::param::boundary::BoundaryMap;
use crate::solver::multilevel::Level;
use crate::solver::{ChartSolver, SolverInputs, step_one};
use glam::DVec2;
use std::sync::Arc;

/// A chart at the level a candidate is solved on, step 1 run.
#[derive(Debug, Clone)]
pub struct LevelChart {
    pub prepared: PreparedChart,
    pub boundary: Arc<BoundaryMap>,
    pub bar_net: Option<Arc<BarNet>>,
    /// The step-1 layout (or the warm start on the square).
    pub step1: Arc<Vec<DVec2>>,
    pub pattern: Option<Arc<PendingNewtonPattern>>,
    /// The coarse level's collapses (`None`: the chart itself).
    pub level: Option<Level>,
}

impl LevelChart {
    /// `level`'s coarse chart with its own step 1.
    ///
    /// # Errors
    /// Step 1 fails on it.
    pub fn coarse(level: Level, source: &ConstraintSource) -> Result<LevelChart, Error> {
        let (boundary, net, step1) = step_one::run(&level.coarse, source, std::path::Path::new(""))?;
        Ok(LevelChart {
            prepared: level.coarse.clone(),
            boundary: Arc::new(boundary),
            bar_net: Some(Arc::new(net)),
            step1: Arc::new(step1),
            pattern: None,
            level: Some(level),
        })
    }

    fn inputs<'a>(
        &'a self,
        source: &'a ConstraintSource,
        options: &'a SolverOptions,
        elapsed_ms: f64,
    ) -> SolverInputs<'a> {
        SolverInputs {
            prepared: &self.prepared,
            source,
            options,
            boundary: &self.boundary,
            step1: &self.step1,
            bar_net: self.bar_net.as_deref(),
            pattern: self.pattern.as_ref(),
            elapsed_ms,
        }
    }
}

/// Where an attempt stands.
#[derive(Debug, Clone)]
enum Stage {
    /// One solve, from the candidate's own start.
    Own(ChartSolver),
    /// The chart on the square, before its free solve from there.
    OnSquare(ChartSolver),
    /// The free solve from the square's layout.
    FromSquare(ChartSolver),
}

/// A candidate being solved at one level.
#[derive(Debug, Clone)]
pub struct Attempt {
    pub chart: LevelChart,
    stage: Stage,
}

impl Attempt {
    /// The solve of `chart` from `start`; `elapsed_ms` counts against the
    /// time budget.
    ///
    /// # Errors
    /// The solver cannot start: a landmark on the square's outer loop whose
    /// target contradicts it, no room for the start, a start from the square
    /// asked of a chart that is not free.
    pub fn new(
        chart: LevelChart,
        start: Start,
        source: &ConstraintSource,
        options: &SolverOptions,
        elapsed_ms: f64,
    ) -> Result<Attempt, Error> {
        let stage = match start {
            Start::Own => Stage::Own(ChartSolver::new(chart.inputs(source, options, elapsed_ms))?),
            Start::Square => {
                let on_square = on_square(&chart.prepared)?;
                Stage::OnSquare(ChartSolver::new(SolverInputs {
                    prepared: &on_square,
                    pattern: None,
                    ..chart.inputs(source, options, elapsed_ms)
                })?)
            }
        };
        Ok(Attempt { chart, stage })
    }

    /// An attempt whose solver is made already (a chart's solve from its
    /// coarse level, prolonged).
    pub fn solving(chart: LevelChart, solver: ChartSolver) -> Attempt {
        Attempt {
            chart,
            stage: Stage::Own(solver),
        }
    }

    /// The running solver.
    pub fn solver(&self) -> &ChartSolver {
        match &self.stage {
            Stage::Own(s) | Stage::OnSquare(s) | Stage::FromSquare(s) => s,
        }
    }

    /// The running solver, to tick.
    pub fn solver_mut(&mut self) -> &mut ChartSolver {
        match &mut self.stage {
            Stage::Own(s) | Stage::OnSquare(s) | Stage::FromSquare(s) => s,
        }
    }

    /// Once the running solver is done: the next solve, if there is one;
    /// whether the attempt is over.
    ///
    /// # Errors
    /// The free solve from the square's layout cannot start.
    pub fn advance(&mut self, source: &ConstraintSource, options: &SolverOptions) -> Result<bool, Error> {
        let Stage::OnSquare(square) = &self.stage else {
            return Ok(self.solver().is_done());
        };
        if !square.is_done() {
            return Ok(false);
        }
        let Domain::Free(setup) = &self.chart.prepared.domain else {
            return Err(Error::Internal(
                "a start from the square for a chart on the square".into(),
            ));
        };
        let (lo, hi) = setup.region.layout_box();
        let mapped: Vec<DVec2> = square.layout().iter().map(|&p| lo + p * (hi - lo)).collect();
        let mut free = self.chart.prepared.clone();
        free.domain = Domain::Free(Arc::new(setup.starting_from(mapped, StartKind::Square)));
        let elapsed = square.elapsed_ms();
        let solver = ChartSolver::new(SolverInputs {
            prepared: &free,
            ..self.chart.inputs(source, options, elapsed)
        })?;
        self.stage = Stage::FromSquare(solver);
        Ok(false)
    }

    /// The finished solver and the chart it was solved on.
    pub fn into_parts(self) -> (LevelChart, ChartSolver) {
        match self.stage {
            Stage::Own(s) | Stage::OnSquare(s) | Stage::FromSquare(s) => (self.chart, s),
        }
    }
}

/// A free chart on the square instead: its region's rectangle mapped onto
/// the square, the targets with it.
fn on_square(prepared: &PreparedChart) -> Result<PreparedChart, Error> {
    let Domain::Free(setup) = &prepared.domain else {
        return Err(Error::Internal(
            "a start from the square for a chart on the square".into(),
        ));
    };
    let (min, size) = (setup.region.min, setup.region.max - setup.region.min);
    let mut square = prepared.clone();
    square.domain = Domain::Square;
    for c in &mut square.constraints {
        c.target_uv = (c.target_uv - min) / size;
    }
    Ok(square)
}
