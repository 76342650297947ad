//! The chart solver: the algorithm's one home. From step 1's results it
//! runs the spline path (Eq. 6) with the exact foldover guard and step
//! halving, then, as [`policy`] decides, the completion (soft-to-hard
//! Newton, snap onto the targets) and the polish, falling back to the
//! closest fold-free layout when the targets cannot be reached.
//!
//! [`ChartSolver::tick`] does one spline proposal and its guard, or one
//! Newton step, so the ECS can run every chart a tick at a time (a newer
//! edit drops a running solve between ticks); [`ChartSolver::run`] runs to
//! the end. The ECS systems call [`ChartSolver::propose`],
//! [`ChartSolver::judge`] and [`ChartSolver::newton_tick`], the three parts
//! of a tick, in that order.

pub mod multilevel;
pub mod own;
pub mod policy;
pub mod step_one;

use crate::chart::{self, PreparedChart};
use crate::complete::attempts::PathBudget;
use crate::complete::context::NewtonContext;
use crate::complete::pattern::{Build, PendingNewtonPattern};
use crate::complete::polish::{Polish, PolishGoal, PolishStats};
use crate::complete::soft::{SoftCompletion, SoftProgress, SoftStats};
use crate::constraints::ConstraintSource;
use crate::domain::solve::{ChartParts, FreeSolve, SolveDomain};
use crate::error::Error;
use crate::guard;
use crate::metrics::{Stretch, sander_stretch};
use crate::options::SolverOptions;
use crate::param::bar_net::{BarNet, FilledChart};
use crate::param::boundary::BoundaryMap;
use crate::rbf::stepping::{FullStep, StepProblem, SteppingPhase, SteppingState, apply_step, fit_spline, full_step};
use glam::DVec2;
use policy::{AfterSpline, Policy, PolishOutcome, PolishRule, SplineEnd};
use std::sync::Arc;
use std::time::Instant;

/// Where a chart's solve stands.
#[derive(Debug, Clone)]
pub enum Phase {
    /// The spline path: the full step's field is kept while its step is halved.
    SplineStepping {
        full_step: Option<FullStep>,
    },
    /// The soft-to-hard completion.
    Completion(Box<SoftCompletion>),
    Polish(Box<Polish>),
    Done,
}

/// Milliseconds the solver spent per stage.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolverTimes {
    /// Setting up and running the spline path (fits and evaluations, Eq. 6).
    pub stepping_ms: f64,
    /// Orientation checks of the spline's candidates.
    pub guard_ms: f64,
    pub complete_ms: f64,
    pub polish_ms: f64,
}

impl SolverTimes {
    pub fn total_ms(&self) -> f64 {
        self.stepping_ms + self.guard_ms + self.complete_ms + self.polish_ms
    }
}

/// The stages of a solve, in order, for progress displays (a CLI's bar, a
/// daemon's log of a long solve).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// Reading the constraint file and the asset.
    Loading,
    /// Welding, choosing the chart, repairing and cutting it open.
    Opening,
    /// The bar-net solve (Eq. 1–2) and the solver's start (a free chart's
    /// fitted to the targets, or its coarse level solved and prolonged).
    StepOne,
    /// The spline path (Eq. 6) with the foldover guard.
    SplinePath,
    /// The soft-to-hard completion.
    Completion,
    /// The distortion polish.
    Polish,
    /// The planner between candidates ([`crate::plan`]): one judged, the
    /// next opened, or the winner taken onto the chart itself.
    Choosing,
    /// The report, the free chart's fallbacks, the other charts.
    Finishing,
    /// Writing the outputs.
    Writing,
}

impl Stage {
    /// A short name for a progress line.
    pub fn label(self) -> &'static str {
        match self {
            Stage::Loading => "loading",
            Stage::Opening => "opening the chart",
            Stage::StepOne => "step 1",
            Stage::SplinePath => "spline path",
            Stage::Completion => "completion",
            Stage::Polish => "polish",
            Stage::Choosing => "choosing a layout",
            Stage::Finishing => "finishing",
            Stage::Writing => "writing",
        }
    }
}

/// Where a solve stands: its stage and, when known, how far through it
/// (0 to 1, an estimate: the share of the way to the targets on the spline
/// path, of the rounds in the completion, of the steps in the polish).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    pub stage: Stage,
    pub fraction: Option<f64>,
}

impl Progress {
    /// `stage`, with no measure of how far through it.
    pub fn at(stage: Stage) -> Self {
        Progress { stage, fraction: None }
    }
}

/// A partial layout more stretched than this many times the chart's own
/// shape is replaced by that shape fitted to the targets
/// ([`ChartSolver::settle_for`]).
pub const SETTLE_FACTOR: f64 = 3.0;

/// What the solve did, phase by phase.
#[derive(Debug, Clone, Default)]
pub struct SolveRecord {
    pub soft: Option<SoftStats>,
    pub polish: Option<PolishStats>,
    /// The layout's symmetric Dirichlet energy after the last Newton step
    /// (0 when no Newton step ran).
    pub energy_end: f64,
    /// The time budget stopped the completion or polish.
    pub out_of_time: bool,
    /// Sander stretch when the targets were reached, before any polish.
    pub stretch_before_polish: Option<Stretch>,
    /// Whether the distortion polish ran, or why not (set when decided).
    pub polish_outcome: Option<PolishOutcome>,
    /// Milliseconds a free chart's Newton phases spent triangulating its scaffold.
    pub scaffold_ms: f64,
    /// A free chart's spline path stalled holding its outer loop and ran
    /// again from the start with the loop free: which run was kept.
    pub spline_loop_freed: Option<LoopFreed>,
    /// A partial layout too stretched to use was replaced: its stretch.
    pub settled_from: Option<Stretch>,
    /// A large chart started from its coarse level: what that did.
    pub multilevel: Option<multilevel::MultilevelStats>,
    /// For a partial layout: the stretch of the chart's own shape (its free
    /// layout without landmarks, or step 1's), the yardstick it is held to.
    pub own_stretch: Option<Stretch>,
}

/// What came of running a free chart's stalled spline path again with its
/// outer loop free.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LoopFreed {
    /// The run with the loop free ended as close to the targets or closer: kept.
    Kept,
    /// It ended further from them: the first run's layout kept.
    Discarded,
}

/// Where a solve starts: the layout, its domain, whether it is storable
/// as f32 already, and what a coarse level did for it.
struct Started {
    layout: Vec<DVec2>,
    domain: SolveDomain,
    storable: bool,
    coarse: Option<multilevel::MultilevelStats>,
}

/// Everything a chart's solve starts from.
#[derive(Debug, Clone, Copy)]
pub struct SolverInputs<'a> {
    pub prepared: &'a PreparedChart,
    /// Where the constraints came from: errors found here point into it.
    pub source: &'a ConstraintSource,
    pub options: &'a SolverOptions,
    pub boundary: &'a BoundaryMap,
    /// The step-1 layout of the filled chart.
    pub step1: &'a [DVec2],
    /// Step 1's factor: its elimination order serves the Newton pattern.
    pub bar_net: Option<&'a BarNet>,
    /// A Newton pattern kept from an earlier solve of the same geometry.
    pub pattern: Option<&'a Arc<PendingNewtonPattern>>,
    /// Milliseconds already spent on this solve (loading to step 1),
    /// counted against the time budget.
    pub elapsed_ms: f64,
}

/// The solve of one chart, from step 1's results to the final layout.
#[derive(Debug, Clone)]
pub struct ChartSolver {
    filled: Arc<FilledChart>,
    problem: StepProblem,
    options: SolverOptions,
    policy: Policy,
    /// The layout the spline path and the completion start from: step 1's
    /// (square), or the fitted free start with the scaffold's fixed points
    /// appended (free).
    start: Vec<DVec2>,
    domain: SolveDomain,
    /// The current layout: fold-free at all times (in double precision, and
    /// as stored once it is storable).
    layout: Vec<DVec2>,
    /// The spline path's progress; kept when it is over, for the report.
    spline: SteppingState,
    /// Whether the layout is fold-free as stored (f32) on the spline path;
    /// carried from step to step instead of recounted.
    spline_storable: bool,
    /// A reached layout more stretched than this (Sander L2) is polished
    /// whatever the chart's size ([`Self::hold_stretch_to`]).
    stretch_bound: Option<f64>,
    /// The spline path's last layout when it stalled: kept if the
    /// completion ends further from the targets.
    spline_layout: Option<Vec<DVec2>>,
    /// A free chart's first spline path, stalled holding its outer loop,
    /// while the path runs again with the loop free ([`AfterSpline::FreeTheLoop`]).
    held_loop_run: Option<(Vec<DVec2>, SteppingState)>,
    phase: Phase,
    pattern: Arc<PendingNewtonPattern>,
    record: SolveRecord,
    times: SolverTimes,
    elapsed_before_ms: f64,
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

impl ChartSolver {
    /// The solve of `start.prepared` from its step-1 layout: the
    /// constraints split into the spline's and those on the outer boundary,
    /// the spline path set up, the Newton pattern shared or started.
    ///
    /// # Errors
    /// A constraint on the outer boundary whose target contradicts the
    /// boundary map; a step-1 layout that folds on the square (a bug).
    pub fn new(start: SolverInputs) -> Result<Self, Error> {
        let t0 = Instant::now();
        let filled = &start.prepared.filled;
        let triangles = &filled.mesh.triangles;
        // One pass when storable (which implies positive in f64); the f64
        // check only for a squeezed start. A free chart starts from step 1
        // only where that start is positive ([`crate::domain::start`]
        // checks every start it takes): a strip of slivers that step 1
        // crowds to nothing in double precision (a CAD part's fillet) is
        // still laid out from its conformal start.
        let storable = guard::all_positive_as_stored(start.step1, triangles);
        let square = start.prepared.domain.free().is_none();
        if let Some(t) = (!storable && square)
            .then(|| guard::first_non_positive(start.step1, triangles))
            .flatten()
        {
            return Err(Error::Internal(format!(
                "the step-1 layout has a flipped or zero-area triangle ({t})"
            )));
        }
        let (problem, policy, pattern) = Self::problem_of(&start)?;
        let chart = ChartParts {
            id: start.prepared.chart.id,
            filled,
            topology: &start.prepared.topology,
            step1: start.step1,
            pattern: &pattern,
        };
        let (layout, domain) = SolveDomain::start(&start.prepared.domain, &chart, &problem)?;
        let storable = storable || start.prepared.domain.free().is_some();
        let started = Started {
            layout,
            domain,
            storable,
            coarse: None,
        };
        Ok(Self::assemble(&start, (problem, policy, pattern), started, t0))
    }

    /// A large free chart's solver started from its coarse level, solved
    /// and prolonged ([`multilevel`]), before and without its own step 1
    /// (`start.step1` is not read); the chart must be one
    /// ([`multilevel::applies`]). Why not, when its coarse level could not
    /// be made, solved or placed in its room: it is then solved from step 1
    /// ([`ChartSolver::new`]) and the report says why.
    ///
    /// # Errors
    /// As [`ChartSolver::new`].
    pub fn from_coarse_level(start: SolverInputs) -> Result<Result<Self, multilevel::Missed>, Error> {
        let t0 = Instant::now();
        match multilevel::coarse_start(&start) {
            Ok((layout, stats)) => Self::from_prolonged(start, layout, stats, t0),
            Err(missed) => Ok(Err(missed)),
        }
    }

    /// The solve of `start.prepared` from `layout`, its coarse level's
    /// solve prolonged (`stats` what that took, since `t0`): on the square
    /// a step-1 layout (its outer loop on the square's sides, every triangle
    /// positive); free, the start of the free domain as it is. Why not,
    /// when its room does not admit it.
    ///
    /// # Errors
    /// As [`ChartSolver::new`].
    pub fn from_prolonged(
        start: SolverInputs,
        layout: Vec<DVec2>,
        stats: multilevel::MultilevelStats,
        t0: Instant,
    ) -> Result<Result<Self, multilevel::Missed>, Error> {
        if start.prepared.domain.free().is_none() {
            let mut solver = ChartSolver::new(SolverInputs {
                step1: &layout,
                ..start
            })?;
            solver.record.multilevel = Some(stats);
            solver.times.stepping_ms = ms(t0);
            return Ok(Ok(solver));
        }
        let (problem, policy, pattern) = Self::problem_of(&start)?;
        let chart = ChartParts {
            id: start.prepared.chart.id,
            filled: &start.prepared.filled,
            topology: &start.prepared.topology,
            step1: &[],
            pattern: &pattern,
        };
        match multilevel::start_in(&start, &chart, &problem, layout) {
            Ok((layout, domain)) => {
                let started = Started {
                    layout,
                    domain,
                    storable: true,
                    coarse: Some(stats),
                };
                Ok(Ok(Self::assemble(&start, (problem, policy, pattern), started, t0)))
            }
            Err(missed) => Ok(Err(missed)),
        }
    }

    /// The spline path's problem, the policy and the Newton pattern of a
    /// solve of `start`.
    fn problem_of(start: &SolverInputs) -> Result<(StepProblem, Policy, Arc<PendingNewtonPattern>), Error> {
        let filled = &start.prepared.filled;
        let options = *start.options;
        let problem = chart::step_problem(
            start.prepared,
            start.source,
            start.boundary,
            options.max_boundary_centres,
        )?;
        let policy = Policy::new(&options, filled.n_real_vertices);
        let pattern = match start.pattern {
            Some(p) if p.serves(&problem.movable) => p.clone(),
            _ => {
                // Step 1 ordered the same vertex graph: no second ordering.
                let order = start.bar_net.and_then(BarNet::elimination_order).map(Arc::new);
                let build = if start.prepared.domain.free().is_some() {
                    Build::Lazily
                } else {
                    policy.pattern_build()
                };
                Arc::new(PendingNewtonPattern::new(
                    filled.clone(),
                    problem.movable.clone(),
                    order,
                    build,
                ))
            }
        };
        Ok((problem, policy, pattern))
    }

    fn assemble(
        start: &SolverInputs,
        (problem, policy, pattern): (StepProblem, Policy, Arc<PendingNewtonPattern>),
        started: Started,
        t0: Instant,
    ) -> Self {
        let options = *start.options;
        let spline = SteppingState::start(&problem, &started.layout, &options, policy.completion_follows_stall());
        ChartSolver {
            filled: start.prepared.filled.clone(),
            problem,
            options,
            policy,
            start: started.layout.clone(),
            layout: started.layout,
            domain: started.domain,
            spline,
            spline_storable: started.storable,
            stretch_bound: None,
            spline_layout: None,
            held_loop_run: None,
            phase: Phase::SplineStepping { full_step: None },
            pattern,
            record: SolveRecord {
                multilevel: started.coarse,
                ..SolveRecord::default()
            },
            times: SolverTimes {
                stepping_ms: ms(t0),
                ..SolverTimes::default()
            },
            elapsed_before_ms: start.elapsed_ms,
        }
    }

    /// Replaces a finished solve's layout (the filled chart's, checked by
    /// the caller: fold-free as stored and admitted by its domain) by one
    /// that keeps its shape, when the best one it found is too stretched to
    /// be of use; `from` is that one's stretch, for the report.
    pub fn settle_for(&mut self, layout: Vec<DVec2>, from: Stretch) {
        debug_assert!(self.is_done() && layout.len() == self.layout.len());
        self.layout = layout;
        self.record.settled_from = Some(from);
    }

    /// The layout this solve started from (the filled chart's).
    pub fn start_layout(&self) -> &[DVec2] {
        &self.start[..self.filled.mesh.n_vertices()]
    }

    /// The largest distance of a constrained vertex from its target.
    pub fn max_residual(&self) -> f64 {
        self.problem.max_residual(&self.layout)
    }

    /// Milliseconds this solve has taken, loading and step 1 included.
    pub fn elapsed_ms(&self) -> f64 {
        self.elapsed_before_ms + self.times.total_ms()
    }

    /// Notes the stretch a partial layout is held to (the chart's own shape).
    pub fn note_own_stretch(&mut self, own: Stretch) {
        self.record.own_stretch = Some(own);
    }

    pub fn phase(&self) -> &Phase {
        &self.phase
    }

    /// Where this solve stands ([`Progress`]).
    pub fn progress(&self) -> Progress {
        let (stage, fraction) = match &self.phase {
            Phase::SplineStepping { .. } => {
                let (start, now) = (self.problem.max_residual(&self.start), self.max_residual());
                (Stage::SplinePath, (start > 0.0).then(|| 1.0 - now / start))
            }
            Phase::Completion(soft) => (
                Stage::Completion,
                Some(f64::from(soft.stats.rounds) / f64::from(self.options.completion_rounds.max(1))),
            ),
            Phase::Polish(polish) => (
                Stage::Polish,
                Some(f64::from(polish.stats.steps) / f64::from(self.options.polish_iterations.max(1))),
            ),
            Phase::Done => (Stage::Finishing, None),
        };
        Progress {
            stage,
            fraction: fraction.map(|f| f.clamp(0.0, 1.0)),
        }
    }

    pub fn is_done(&self) -> bool {
        matches!(self.phase, Phase::Done)
    }

    /// The current layout of the filled chart (layout coordinates, y up).
    pub fn layout(&self) -> &[DVec2] {
        &self.layout[..self.filled.mesh.n_vertices()]
    }

    /// The whole working layout: a free chart's scaffold points after the chart's.
    pub fn full_layout(&self) -> &[DVec2] {
        &self.layout
    }

    /// A free chart's room, scaffold and start (`None`: a square chart).
    pub fn free(&self) -> Option<&FreeSolve> {
        self.domain.free()
    }

    pub fn problem(&self) -> &StepProblem {
        &self.problem
    }

    pub fn spline(&self) -> &SteppingState {
        &self.spline
    }

    pub fn record(&self) -> &SolveRecord {
        &self.record
    }

    pub fn times(&self) -> SolverTimes {
        self.times
    }

    pub fn options(&self) -> &SolverOptions {
        &self.options
    }

    /// The Newton pattern this solve uses (for a daemon to keep).
    pub fn pattern(&self) -> &Arc<PendingNewtonPattern> {
        &self.pattern
    }

    /// One tick: a spline proposal and its guard, then the completion's or
    /// polish's Newton step (or the decision of what follows the spline path).
    ///
    /// # Errors
    /// As [`ChartSolver::newton_tick`].
    pub fn tick(&mut self) -> Result<(), Error> {
        if let Some(candidate) = self.propose() {
            self.judge(&candidate);
        }
        self.newton_tick()
    }

    /// Ticks until the solve is done.
    ///
    /// # Errors
    /// As [`ChartSolver::newton_tick`].
    pub fn run(&mut self) -> Result<(), Error> {
        while !self.is_done() {
            self.tick()?;
        }
        Ok(())
    }

    /// The spline path's next candidate (Eq. 6): every constrained vertex
    /// moved the current fraction `t` of its remaining way, every free
    /// vertex by `t` times the spline field. `None` when the path is over
    /// (a singular spline system ends it, as a stall).
    pub fn propose(&mut self) -> Option<Vec<DVec2>> {
        let Phase::SplineStepping { full_step: step } = &mut self.phase else {
            return None;
        };
        if !self.spline.is_stepping() {
            return None;
        }
        let t0 = Instant::now();
        if step.is_none() {
            match full_step(&self.layout, &self.problem) {
                Ok(field) => *step = Some(field),
                Err(e) => self.spline.record_failure(&e),
            }
        }
        let candidate = step
            .as_ref()
            .map(|s| apply_step(&self.layout, &self.problem, &s.field, self.spline.t));
        self.times.stepping_ms += ms(t0);
        candidate
    }

    /// The foldover guard: accepts `candidate` only if every triangle,
    /// virtual ones included, keeps its orientation (Eq. 3, exactly) in
    /// double precision and as stored in f32; otherwise the step is halved.
    /// (The paper's pointwise guard, Eq. 5/7, when asked for comparison.)
    pub fn judge(&mut self, candidate: &[DVec2]) {
        let Phase::SplineStepping { full_step } = &mut self.phase else {
            return;
        };
        let t0 = Instant::now();
        let triangles = &self.filled.mesh.triangles;
        let accepted = match (self.policy.paper_guard, full_step.as_ref()) {
            (true, Some(step)) => step.paper_guard_accepts(&self.layout, &self.problem, self.spline.t),
            _ => guard::acceptable(candidate, triangles, self.spline_storable) && self.domain.admits(candidate),
        };
        if accepted {
            let residual = self.problem.max_residual(candidate);
            self.layout.copy_from_slice(candidate);
            if !self.spline_storable {
                self.spline_storable = guard::all_positive_as_stored(&self.layout, triangles);
            }
            *full_step = None;
            self.spline.record_guard(true, residual, &self.options);
        } else {
            self.spline.record_guard(false, f64::INFINITY, &self.options);
        }
        self.times.guard_ms += ms(t0);
    }

    /// Once the spline path is over: decides what follows it, then advances
    /// the completion or polish by one Newton step per call, within the
    /// time budget.
    ///
    /// # Errors
    /// The Newton pattern could not be built (never for a valid mesh).
    pub fn newton_tick(&mut self) -> Result<(), Error> {
        let t0 = Instant::now();
        match &mut self.phase {
            Phase::SplineStepping { .. } if self.spline.is_stepping() => return Ok(()),
            Phase::SplineStepping { .. } => {
                let result = self.after_spline();
                self.times.complete_ms += ms(t0);
                if self.is_done() {
                    self.finish_in_domain();
                }
                return result;
            }
            Phase::Completion(soft) => {
                let progress = soft.step(&mut self.layout, &self.problem, &self.options);
                self.record.energy_end = soft.energy();
                self.record.scaffold_ms = soft.newton().scaffold_ms();
                self.times.complete_ms += ms(t0);
                self.after_soft_step(progress);
            }
            Phase::Polish(polish) => {
                let over = polish.step(&mut self.layout, &self.options);
                self.record.energy_end = polish.energy();
                self.record.scaffold_ms = polish.newton().scaffold_ms();
                self.record.polish = Some(polish.stats);
                self.times.polish_ms += ms(t0);
                if over {
                    self.phase = Phase::Done;
                }
            }
            Phase::Done => return Ok(()),
        }
        self.check_budget();
        if self.is_done() {
            self.finish_in_domain();
        }
        Ok(())
    }

    /// Once done: the domain's last word on the layout
    /// ([`SolveDomain::finish`]).
    fn finish_in_domain(&mut self) {
        let n = self.filled.mesh.n_vertices();
        let shape = crate::domain::start::Shape::of(&self.filled);
        self.domain.finish(&mut self.layout[..n], &shape, &self.problem);
    }

    /// Polishes a reached layout more stretched than `l2` (Sander L2)
    /// whatever the chart's size: the planner holds a large chart to its own
    /// free layout as measured on its coarse level, so no vertex-count
    /// cut-off leaves a reached layout that stretched.
    pub fn hold_stretch_to(&mut self, l2: f64) {
        self.stretch_bound = Some(l2).filter(|b| b.is_finite());
    }

    /// Whether the current layout is more stretched than the bound it is
    /// held to.
    fn above_bound(&self) -> bool {
        self.stretch_bound.is_some_and(|b| self.stretch().l2 > b)
    }

    /// The Sander stretch of the current layout (real triangles).
    fn stretch(&self) -> Stretch {
        let f = &self.filled;
        sander_stretch(
            &f.mesh.positions[..f.n_real_vertices],
            &self.layout[..f.n_real_vertices],
            &f.mesh.triangles[..f.n_real_triangles],
        )
    }

    fn newton_context(&self) -> Result<NewtonContext, Error> {
        let pattern = self
            .pattern
            .get()
            .map_err(|e| Error::Internal(format!("completion system: {e}")))?;
        Ok(self
            .domain
            .newton_context(&self.filled, &self.problem, pattern, &self.layout))
    }

    /// What follows the spline path ([`Policy::after_spline`]).
    fn after_spline(&mut self) -> Result<(), Error> {
        self.keep_closer_spline_run();
        let reached = self.spline.phase == SteppingPhase::Reached;
        let storable = if self.policy.paper_guard {
            guard::all_positive_as_stored(&self.layout, &self.filled.mesh.triangles)
        } else {
            self.spline_storable
        };
        let end = SplineEnd {
            reached,
            movable: !self.problem.movable.is_empty(),
            storable,
            loop_can_be_freed: self.can_free_the_loop(),
            too_stretched: reached && self.policy.polish == PolishRule::IfSnapDistorts && self.above_bound(),
        };
        match self.policy.after_spline(end) {
            AfterSpline::Done(outcome) => {
                self.record.polish_outcome = Some(outcome);
                self.phase = Phase::Done;
            }
            AfterSpline::Polish(goal) => {
                self.record.stretch_before_polish = Some(self.stretch());
                let context = self.newton_context()?;
                self.start_polish(context, goal);
            }
            AfterSpline::FreeTheLoop => self.free_the_loop(),
            AfterSpline::Complete => {
                let spline = std::mem::replace(&mut self.layout, self.start.clone());
                self.spline_layout = Some(spline);
                let context = self.newton_context()?;
                let soft = SoftCompletion::new(
                    context,
                    &self.filled,
                    &self.problem,
                    (&self.layout, PathBudget::Every),
                    &self.options,
                );
                self.record.energy_end = soft.energy();
                self.phase = Phase::Completion(Box::new(soft));
            }
        }
        Ok(())
    }

    /// A free chart's spline path holds a sample of its outer loop at first
    /// (zero-displacement centres, as on the square). Where the targets bend
    /// the chart as a whole (a head turned against its body) that field
    /// folds at once and the path stalls; the completion from the start then
    /// drags the boundary along itself, where it can catch (a jaw's tip
    /// under the other jaw's hook). So the path runs once more from the
    /// start with the loop free ([`AfterSpline::FreeTheLoop`]); the first
    /// run is kept aside, and the closer of the two goes on
    /// ([`Self::keep_closer_spline_run`]): to the completion if both stalled.
    fn free_the_loop(&mut self) {
        self.problem.anchors.clear();
        let held = std::mem::replace(&mut self.layout, self.start.clone());
        let fresh = SteppingState::start(
            &self.problem,
            &self.layout,
            &self.options,
            self.policy.completion_follows_stall(),
        );
        self.held_loop_run = Some((held, std::mem::replace(&mut self.spline, fresh)));
        self.record.spline_loop_freed = Some(LoopFreed::Kept);
        self.phase = Phase::SplineStepping { full_step: None };
    }

    /// Whether a stalled spline path may run again with the outer loop
    /// free: a free chart whose path held a sample of it, stalled (not
    /// skipped), with time left, and whose constrained vertices can carry a
    /// spline alone from the start (its fit succeeds: three or more, not on
    /// one line, none coinciding).
    fn can_free_the_loop(&self) -> bool {
        let stalled = matches!(self.spline.phase, SteppingPhase::Stalled(_));
        if self.domain.free().is_none() || self.problem.anchors.is_empty() || !stalled || self.budget_spent() {
            return false;
        }
        let freed = StepProblem {
            anchors: Vec::new(),
            ..self.problem.clone()
        };
        fit_spline(&self.start, &freed).is_ok()
    }

    /// After the path with the loop free: the layout of whichever of the two
    /// runs ended closer to the targets, with that run's state (its stall
    /// reason) and both runs' counts.
    fn keep_closer_spline_run(&mut self) {
        let Some((held, held_state)) = self.held_loop_run.take() else {
            return;
        };
        if self.problem.max_residual(&held) < self.problem.max_residual(&self.layout) {
            self.layout = held;
            let freed = std::mem::replace(&mut self.spline, held_state);
            self.add_counts(&freed);
            self.record.spline_loop_freed = Some(LoopFreed::Discarded);
        } else {
            self.add_counts(&held_state);
        }
    }

    fn add_counts(&mut self, other: &SteppingState) {
        self.spline.iterations += other.iterations;
        self.spline.total_halvings += other.total_halvings;
    }

    fn start_polish(&mut self, mut context: NewtonContext, goal: PolishGoal) {
        // A free chart on its targets: its rest shapes take the scale its
        // layout fits best, the scale the targets made, so the polish does
        // not press it larger or smaller than they allow.
        self.domain.fit_rest_scale(&mut context, &self.layout, &self.problem);
        let polish = Polish::new(context, &self.problem, &self.layout, goal);
        self.record.energy_end = polish.energy();
        self.record.polish = Some(polish.stats);
        self.record.polish_outcome = Some(PolishOutcome::Ran);
        self.phase = Phase::Polish(Box::new(polish));
    }

    /// After a completion step: on to the polish after a snap
    /// ([`Policy::after_snap`]), or the end.
    fn after_soft_step(&mut self, progress: SoftProgress) {
        if progress == SoftProgress::Working {
            return;
        }
        let Phase::Completion(soft) = std::mem::replace(&mut self.phase, Phase::Done) else {
            unreachable!("called in the completion phase")
        };
        self.record.soft = Some(soft.stats.clone());
        if progress == SoftProgress::Exhausted {
            self.keep_closest();
            return;
        }
        let before = self.stretch();
        self.record.stretch_before_polish = Some(before);
        let distorted = soft.snap_distorted() || self.stretch_bound.is_some_and(|b| before.l2 > b);
        match self.policy.after_snap(distorted, soft.is_storable()) {
            Ok(goal) => self.start_polish(soft.into_newton(), goal),
            Err(outcome) => self.record.polish_outcome = Some(outcome),
        }
    }

    /// The completion ended short of the targets: keep whichever fold-free
    /// layout is closer to them, its own or the spline path's.
    fn keep_closest(&mut self) {
        self.record.polish_outcome = Some(self.policy.after_unreached());
        if let Some(spline) = &self.spline_layout
            && self.problem.max_residual(spline) < self.problem.max_residual(&self.layout)
        {
            self.layout.clone_from(spline);
        }
    }

    /// Stops the completion or polish once the time budget is spent; the
    /// layout stays the last accepted one.
    /// Whether the time budget (if any) is spent.
    fn budget_spent(&self) -> bool {
        self.options
            .time_budget_ms
            .is_some_and(|budget| self.elapsed_before_ms + self.times.total_ms() > budget)
    }

    fn check_budget(&mut self) {
        if self.is_done() || !self.budget_spent() {
            return;
        }
        self.record.out_of_time = true;
        match std::mem::replace(&mut self.phase, Phase::Done) {
            Phase::Completion(soft) => {
                self.record.soft = Some(soft.stats.clone());
                self.keep_closest();
            }
            Phase::Polish(polish) => self.record.polish = Some(polish.stats),
            Phase::SplineStepping { .. } | Phase::Done => {}
        }
    }
}
