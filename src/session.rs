//! The chart session: one chart of one asset, with everything a solve
//! computes once and every later solve of new landmarks reuses (as
//! geometry-central's precomputing solvers do). The CLI, the sweep, the
//! editor's previews, the daemon's chart entities and the library all hold
//! one:
//!
//! ```text
//! open(source, asset) ─ retarget(source) ─┐
//!        │                                │  keeps the weld; the chart's topology and hole
//!        ▼                                │  fill for the same chart; step 1 for the same corners
//! map_boundary → factor_bar_net → solve_force_density     (step 1, §III, Eq. 1–2)
//!        ▼
//! new_solver(options, from) → ChartSolver (spline path Eq. 6, guard, completion, polish)
//!        ▼
//! report(solver) → export(solver, report, outputs)        (one commit)
//! ```
//!
//! [`ChartSession::solve`] runs it all in a row. Cloning a session is cheap:
//! its geometry, factor and Newton pattern are shared behind `Arc`s.

#![warn(missing_docs)]

use crate::chart::{self, PreparedChart, PrimitiveUvs};
use crate::complete::attempts::PathBudget;
use crate::complete::pattern::PendingNewtonPattern;
use crate::constraints::ConstraintSource;
use crate::domain::Domain;
use crate::domain::start::StartKind;
use crate::error::Error;
use crate::export::{self, Outputs};
use crate::io::SourceAsset;
use crate::options::SolverOptions;
use crate::param::bar_net::BarNet;
use crate::param::boundary::BoundaryMap;
use crate::report::{self, Report, StageTimes};
use crate::solver::step_one::{self, StepOne, StepOneTimes};
use crate::solver::{ChartSolver, Progress, SolverInputs, Stage};
use glam::DVec2;
use std::sync::Arc;
use std::time::Instant;

mod coarse;
pub use coarse::{CoarseMesh, CoarseSolution, CoarseView};

/// What [`ChartSession::solve_secondary`] gives: the other charts and
/// pieces solved with their reports, why other charts could not be, and
/// the pieces that could not be (with why), to be laid out with the rest.
struct Secondaries {
    solved: Vec<export::Secondary>,
    reports: Vec<Report>,
    unsolved: Vec<(Arc<crate::mesh::weld::Chart>, String)>,
}

/// A chart of an asset and what its solves share (see the module docs).
#[derive(Debug, Clone)]
pub struct ChartSession {
    asset: Arc<SourceAsset>,
    source: ConstraintSource,
    prepared: PreparedChart,
    /// The outer loop on the square (§III.B): depends on the corners.
    boundary: Option<Arc<BoundaryMap>>,
    /// `D` of Eq. 1 factored: depends on the chart only.
    bar_net: Option<Arc<BarNet>>,
    /// The step-1 layout of the filled chart: depends on the boundary.
    step_one: Option<Arc<Vec<DVec2>>>,
    /// The Newton pattern of the last solver started on this chart.
    pattern: Option<Arc<PendingNewtonPattern>>,
    /// The last finished layout of a chart on the square with these
    /// corners: the start of a [`StartFrom::LastLayout`] solve.
    last_layout: Option<Arc<Vec<DVec2>>>,
    /// Milliseconds spent on the current constraints' solve so far.
    times: StageTimes,
    /// Counts every change of what a solver would start from, so a running
    /// solver of an older revision is known to be stale.
    revision: u64,
    /// The other charts that need UVs, unwrapped on first export: depends
    /// on the geometry only (the packing around the chart is done anew).
    rest: Arc<std::sync::OnceLock<Arc<crate::atlas::Rest>>>,
    /// The other charts holding constraints, solved by the last
    /// [`Self::report`] around its layout, for [`Self::export`].
    secondary: Arc<Vec<export::Secondary>>,
    /// How the chart was picked and made ([`Self::reshaped`] keeps it).
    pick: chart::Pick,
}

/// What a [`ChartSession::retarget`] kept of the session's earlier work.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kept {
    /// Nothing but the weld: the constraints are in another chart.
    Weld,
    /// The chart, its topology and hole fill, the bar-net factor and the
    /// Newton pattern (the corners moved: a new boundary map and step 1).
    Geometry,
    /// All that and step 1: only the spline path and completion run.
    StepOne,
}

/// Where a solver starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StartFrom {
    /// Step 1's layout (or a free chart's own start).
    #[default]
    StepOne,
    /// The last finished layout of this chart, when it was on the square
    /// with the same corners (dragged targets move a little from where they
    /// were: the spline path then rarely stalls); else step 1's.
    LastLayout,
}

/// A finished solve: the solver (its final layout and record) and the
/// report, not yet written.
#[derive(Debug, Clone)]
pub struct Solution {
    /// The finished solver: its final layout and record.
    pub solver: ChartSolver,
    /// What was reached, and how.
    pub report: Report,
}

/// `solver` run to its end, if no tick fails.
fn finished(mut solver: ChartSolver) -> Option<ChartSolver> {
    solver.run().ok().map(|()| solver)
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

impl ChartSession {
    /// The chart of `asset` that `source`'s constraints pick, prepared
    /// ([`chart::prepare`]); `load_ms` is the time already spent loading.
    ///
    /// # Errors
    /// Constraint and topology errors against the asset.
    pub fn open(source: ConstraintSource, asset: Arc<SourceAsset>, load_ms: f64) -> Result<Self, Error> {
        let t0 = Instant::now();
        let prepared = chart::prepare(&source, &asset)?;
        let times = StageTimes {
            load_ms,
            topology_ms: ms(t0),
            ..StageTimes::default()
        };
        Ok(ChartSession {
            asset,
            source,
            prepared,
            boundary: None,
            bar_net: None,
            step_one: None,
            pattern: None,
            last_layout: None,
            times,
            revision: 0,
            rest: Arc::default(),
            secondary: Arc::default(),
            pick: chart::Pick::default(),
        })
    }

    /// A session on a chart already prepared (a piece laid out without
    /// landmarks beside the solved chart, [`crate::atlas`]).
    pub fn from_prepared(source: ConstraintSource, asset: Arc<SourceAsset>, prepared: PreparedChart) -> Self {
        ChartSession {
            asset,
            source,
            prepared,
            boundary: None,
            bar_net: None,
            step_one: None,
            pattern: None,
            last_layout: None,
            times: StageTimes::default(),
            revision: 0,
            rest: Arc::default(),
            secondary: Arc::default(),
            pick: chart::Pick::default(),
        }
    }

    /// The same asset and constraints with the chart made as `pick` says
    /// (another form, or another boundary where the file names none), on
    /// this session's weld: a candidate of [`crate::plan`].
    ///
    /// # Errors
    /// As [`ChartSession::open`].
    pub fn reshaped(
        &self,
        form: &crate::cut::prepare::Form,
        boundary: Option<crate::pins::BoundaryChoice>,
    ) -> Result<ChartSession, Error> {
        let t0 = Instant::now();
        let pick = chart::Pick {
            form: Some(form.clone()),
            boundary,
            ..self.pick.clone()
        };
        let prepared = chart::prepare_pick(&self.source, &self.asset, self.prepared.welded.clone(), &pick)?;
        let mut session = ChartSession::from_prepared(self.source.clone(), self.asset.clone(), prepared);
        session.pick = pick;
        session.times = StageTimes {
            load_ms: self.times.load_ms,
            topology_ms: self.times.topology_ms + ms(t0),
            ..StageTimes::default()
        };
        session.revision = self.revision;
        Ok(session)
    }

    /// The last finished layout on the square with these corners, the warm
    /// start of a [`StartFrom::LastLayout`] solve.
    pub fn last_layout(&self) -> Option<Arc<Vec<DVec2>>> {
        self.last_layout.clone().filter(|_| self.on_square())
    }

    /// Keeps `solver`'s finished layout as the next warm start, when on the square.
    pub fn keep_layout(&mut self, solver: &ChartSolver) {
        if self.on_square() {
            self.last_layout = Some(Arc::new(solver.layout().to_vec()));
        }
    }

    /// New constraints on the same asset: resolved again, keeping what
    /// still applies ([`Kept`]); `load_ms` is the time spent reading them.
    ///
    /// # Errors
    /// As [`ChartSession::open`]; the session is unchanged then.
    pub fn retarget(&mut self, source: ConstraintSource, load_ms: f64) -> Result<Kept, Error> {
        let t0 = Instant::now();
        let prepared = self.prepared.retargeted(&source, &self.asset)?;
        let kept = if !prepared.same_geometry(&self.prepared) {
            Kept::Weld
        } else if prepared.corners != self.prepared.corners {
            Kept::Geometry
        } else {
            Kept::StepOne
        };
        if kept != Kept::StepOne {
            (self.boundary, self.step_one, self.last_layout) = (None, None, None);
        }
        if kept == Kept::Weld {
            (self.bar_net, self.pattern) = (None, None);
            self.rest = Arc::default();
        }
        self.source = source;
        self.prepared = prepared;
        self.times = StageTimes {
            load_ms,
            topology_ms: ms(t0),
            ..StageTimes::default()
        };
        self.revision += 1;
        Ok(kept)
    }

    /// Places the outer loop on the square (§III.B), unless it is placed.
    ///
    /// # Errors
    /// Corners that are not on the outer loop, are mirrored, or trap a
    /// triangle (located at the `corners` field).
    pub fn map_boundary(&mut self) -> Result<(), Error> {
        if self.boundary.is_none() {
            let t0 = Instant::now();
            self.boundary = Some(Arc::new(step_one::map_boundary(&self.prepared, &self.source)?));
            self.times.boundary_ms += ms(t0);
        }
        Ok(())
    }

    /// Builds and factors `D = CᵀQC` (Eq. 1–2), unless it is factored.
    ///
    /// # Errors
    /// The boundary is not mapped yet (a bug), or `D` is singular.
    pub fn factor_bar_net(&mut self) -> Result<(), Error> {
        if self.bar_net.is_none() {
            let t0 = Instant::now();
            let boundary = self.mapped_boundary()?;
            let net = step_one::factor_bar_net(&self.prepared, boundary, &self.asset.path)?;
            self.bar_net = Some(Arc::new(net));
            self.times.factor_ms += ms(t0);
        }
        Ok(())
    }

    /// Solves Eq. 1 for the nodes off the outer loop, unless solved: the
    /// step-1 layout.
    ///
    /// # Errors
    /// The boundary is not mapped or `D` not factored yet (a bug).
    pub fn solve_force_density(&mut self) -> Result<(), Error> {
        if self.step_one.is_none() {
            let t0 = Instant::now();
            let net = self.bar_net.as_ref().ok_or_else(|| not_yet("the bar-net factor"))?;
            let layout = step_one::solve_force_density(&self.prepared, self.mapped_boundary()?, net);
            self.step_one = Some(Arc::new(layout));
            self.times.solve_ms += ms(t0);
        }
        Ok(())
    }

    /// Step 1 in a row: [`Self::map_boundary`], [`Self::factor_bar_net`],
    /// [`Self::solve_force_density`], each only if not done.
    ///
    /// # Errors
    /// As those methods.
    pub fn run_step_one(&mut self) -> Result<(), Error> {
        self.map_boundary()?;
        self.factor_bar_net()?;
        self.solve_force_density()
    }

    /// A solver of the current constraints, started `from` where asked,
    /// after step 1 (run first if needed).
    ///
    /// # Errors
    /// Step-1 errors; a constraint on the outer boundary whose target
    /// contradicts the boundary map.
    pub fn new_solver(&mut self, options: &SolverOptions, from: StartFrom) -> Result<ChartSolver, Error> {
        let paths = if self.cut_is_optional() {
            PathBudget::First
        } else {
            PathBudget::Every
        };
        self.new_solver_with(options, from, paths)
    }

    /// As [`Self::new_solver`], its completion trying the paths `paths` allows.
    fn new_solver_with(
        &mut self,
        options: &SolverOptions,
        from: StartFrom,
        paths: PathBudget,
    ) -> Result<ChartSolver, Error> {
        let mut solver = self.solver_of(options, from)?;
        if paths == PathBudget::First {
            solver.first_path_only();
        }
        Ok(solver)
    }

    /// A solver of the current constraints from the coarse level, or from
    /// step 1 started `from` where asked, every path allowed.
    fn solver_of(&mut self, options: &SolverOptions, from: StartFrom) -> Result<ChartSolver, Error> {
        let missed = match self.solver_from_coarse_level(options)? {
            Some(Ok(solver)) => {
                self.pattern = Some(solver.pattern().clone());
                return Ok(solver);
            }
            Some(Err(missed)) => Some(missed),
            None => None,
        };
        self.run_step_one()?;
        let (Some(boundary), Some(step_one)) = (&self.boundary, &self.step_one) else {
            return Err(not_yet("step 1"));
        };
        let warm = match from {
            StartFrom::LastLayout if self.on_square() => self.last_layout.as_deref(),
            _ => None,
        };
        let solver = ChartSolver::new(SolverInputs {
            prepared: &self.prepared,
            source: &self.source,
            options,
            boundary,
            step1: warm.unwrap_or(step_one),
            bar_net: self.bar_net.as_deref(),
            pattern: self.pattern.as_ref(),
            elapsed_ms: self.times.total_ms(),
        });
        let mut solver = match solver {
            // No start of its own fits the room: the square's solve may.
            Err(Error::NoRoom { .. }) if !self.on_square() => self
                .via_square(options, f64::INFINITY, self.times.total_ms())
                .map_or_else(|| solver, Ok)?,
            other => other?,
        };
        if let Some(missed) = missed {
            solver.note_multilevel_missed(missed);
        }
        self.pattern = Some(solver.pattern().clone());
        Ok(solver)
    }

    /// A large free chart's solver from its coarse level, without its own
    /// step 1 ([`ChartSolver::from_coarse_level`]); `None` when it is not
    /// one or its coarse level fails.
    ///
    /// # Errors
    /// As [`Self::new_solver`].
    fn solver_from_coarse_level(
        &mut self,
        options: &SolverOptions,
    ) -> Result<Option<Result<ChartSolver, crate::solver::multilevel::Missed>>, Error> {
        if self.prepared.filled.mesh.n_vertices() <= options.multilevel_above {
            return Ok(None);
        }
        self.map_boundary()?;
        match self.coarse_inputs(options) {
            Some(inputs) => ChartSolver::from_coarse_level(inputs).map(Some),
            None => Ok(None),
        }
    }

    /// Whether a solve with `options` starts from the chart's coarse level,
    /// without step 1 of its own (which it runs only if that level fails):
    /// a caller stepping through the stages skips step 1 then.
    pub fn starts_coarse(&self, options: &SolverOptions) -> bool {
        self.coarse_inputs(options).is_some()
    }

    /// The inputs of a solve from the coarse level, once the boundary is
    /// mapped, if the chart is solved so ([`crate::solver::multilevel::applies`]).
    fn coarse_inputs<'a>(&'a self, options: &'a SolverOptions) -> Option<SolverInputs<'a>> {
        let inputs = SolverInputs {
            prepared: &self.prepared,
            source: &self.source,
            options,
            boundary: self.boundary.as_deref()?,
            step1: &[],
            bar_net: None,
            pattern: self.pattern.as_ref(),
            elapsed_ms: self.times.total_ms(),
        };
        crate::solver::multilevel::applies(&inputs).then_some(inputs)
    }

    /// A free chart solved on the square instead, then free again from
    /// there: a square layout inside the region is a free layout. The
    /// region's rectangle is mapped onto the square and the targets with it;
    /// when that solve comes closer to them than `residual`, the free solve
    /// started from it (mapped back, shrunk just enough to fit the room) is
    /// returned, finished, if it is closer still. `None` otherwise (the
    /// square cannot hold the constraints, or does no better).
    fn via_square(&self, options: &SolverOptions, residual: f64, elapsed_ms: f64) -> Option<ChartSolver> {
        let (Domain::Free(setup), Some(boundary), Some(step_one)) =
            (&self.prepared.domain, &self.boundary, &self.step_one)
        else {
            return None;
        };
        let (lo, hi) = setup.region.layout_box();
        let (min, size) = (setup.region.min, setup.region.max - setup.region.min);
        let mut on_square = self.prepared.clone();
        on_square.domain = Domain::Square;
        for c in &mut on_square.constraints {
            c.target_uv = (c.target_uv - min) / size;
        }
        let inputs = |prepared| SolverInputs {
            prepared,
            source: &self.source,
            options,
            boundary,
            step1: step_one,
            bar_net: self.bar_net.as_deref(),
            pattern: None,
            elapsed_ms,
        };
        let mut square = ChartSolver::new(inputs(&on_square)).ok()?;
        square.run().ok()?;
        let mapped: Vec<DVec2> = square.layout().iter().map(|&p| lo + p * (hi - lo)).collect();
        let mut free = self.prepared.clone();
        free.domain = Domain::Free(Arc::new(setup.starting_from(mapped, StartKind::Square)));
        let mut solver = ChartSolver::new(SolverInputs {
            elapsed_ms: elapsed_ms + square.times().total_ms(),
            pattern: self.pattern.as_ref(),
            ..inputs(&free)
        })
        .ok()?;
        solver.run().ok()?;
        let closer = solver.max_residual() < residual;
        closer.then(|| solver.fell_short_by(residual))
    }

    /// The report of a finished `solver` of this session's constraints;
    /// remembers its layout as the start of a [`StartFrom::LastLayout`] solve.
    pub fn report(&mut self, solver: &mut ChartSolver) -> Report {
        self.detour_uncut(solver);
        self.timed_detour_via_square(solver);
        crate::plan::settle::settle(&self.prepared, self.step_one.as_deref().map(Vec::as_slice), solver);
        let boundary = self.boundary.as_deref().expect("a started solver mapped the boundary");
        // A chart started from its coarse level has no step 1 of its own:
        // its start stands in for it.
        let step_one = self.step_one.as_deref().map_or(solver.start_layout(), Vec::as_slice);
        let mut report = report::build(&report::SolveSummary {
            constraint_file: self.source.name(),
            asset: &self.asset,
            prepared: &self.prepared,
            boundary,
            step1: step_one,
            solver,
            times: self.times.with_solver(solver.times()),
        });
        self.keep_layout(solver);
        self.solve_others(solver, &mut report);
        report
    }

    /// A constraint of the file that no chart's report names (its vertex
    /// set apart by a repair, say) is reported unreached, its residual
    /// measured where it is written: "k of n" counts every constraint, and
    /// exit 0 means every one is on target.
    fn account_for_every_constraint(&self, report: &mut Report) {
        // A chart solved after another (its pick replaces charts) reports
        // only its own constraints; the first one accounts for them all.
        if !self.pick.replaced.is_empty() {
            return;
        }
        let charts = report.charts.iter().flat_map(|r| &r.constraints);
        let named: std::collections::HashSet<usize> =
            report.constraints.iter().chain(charts).map(|c| c.index).collect();
        self.report_unreached(
            report,
            |c| !named.contains(&c.index),
            |first| {
                format!(
                    "constraints[{first}] is on a part of the mesh that was laid out without it (set apart by a repair)"
                )
            },
        );
    }

    /// The file's constraints that `unreached` picks, reported unreached
    /// (their residuals are measured where they are written); a reached
    /// report becomes partial, with `message` of the first one's index.
    fn report_unreached(
        &self,
        report: &mut Report,
        unreached: impl Fn(&crate::pins::ResolvedConstraint) -> bool,
        message: impl FnOnce(usize) -> String,
    ) {
        let resolved = self.source.resolve(&self.asset.primitives, &self.prepared.welded);
        let missing: Vec<report::ConstraintReport> = resolved
            .iter()
            .flat_map(|(all, _)| all)
            .filter(|c| unreached(c))
            .map(|c| report::ConstraintReport::of(c, DVec2::NAN, DVec2::NAN, f64::INFINITY, false))
            .collect();
        let Some(first) = missing.first().map(|c| c.index) else {
            return;
        };
        report.constraints.extend(missing);
        report.max_residual = f64::INFINITY;
        if report.status == report::Status::Reached {
            report.status = report::Status::Partial;
            report.message = Some(message(first));
        }
    }

    /// The other charts and pieces holding landmarks solved after this
    /// chart ([`Self::solve_secondary`]), their reports added to `report`;
    /// then every constraint of the file accounted for.
    fn solve_others(&mut self, solver: &ChartSolver, report: &mut Report) {
        if !(self.prepared.secondary.is_empty() && self.prepared.opening.pieces.is_empty()) {
            let Secondaries {
                solved,
                reports,
                unsolved,
            } = self.solve_secondary(solver);
            report.add_charts(reports);
            self.secondary = Arc::new(solved);
            self.set_aside(unsolved, report);
        }
        self.account_for_every_constraint(report);
    }

    /// Pieces holding landmarks that could not be solved are laid out with
    /// the rest, their constraints reported unreached: the result is
    /// partial, never an error that writes nothing.
    fn set_aside(&mut self, unsolved: Vec<(Arc<crate::mesh::weld::Chart>, String)>, report: &mut Report) {
        let Some((_, why)) = unsolved.first() else {
            return;
        };
        let message = format!(
            "{} piece(s) holding landmarks laid out without them: {why}",
            unsolved.len()
        );
        self.report_unreached(
            report,
            |c| unsolved.iter().any(|(piece, _)| piece.local_of(c.welded).is_some()),
            |_| message,
        );
        let mut opening = (*self.prepared.opening).clone();
        opening.rest.extend(unsolved.into_iter().map(|(piece, _)| piece));
        self.prepared.opening = Arc::new(opening);
        self.rest = Arc::default();
    }

    /// A finished free solve short of its targets: the same chart solved on
    /// the square and then free from there ([`Self::via_square`]) takes its
    /// place when it comes closer. Free never does worse than the square.
    fn detour_via_square(&mut self, solver: &mut ChartSolver) {
        let residual = solver.max_residual();
        let short = residual > solver.options().tolerance;
        if !short || solver.free().is_none() || solver.free().is_some_and(|f| f.start == StartKind::Square) {
            return;
        }
        let options = *solver.options();
        if let Some(better) = self.via_square(&options, residual, solver.elapsed_ms()) {
            *solver = better;
        }
    }

    /// [`Self::detour_via_square`], its time counted: the solves it tried
    /// and the one it set aside, less the one it kept (counted as the
    /// solver's own).
    fn timed_detour_via_square(&mut self, solver: &mut ChartSolver) {
        let (t0, before) = (Instant::now(), solver.times().total_ms());
        self.detour_via_square(solver);
        self.times.detour_ms += before + ms(t0) - solver.times().total_ms();
    }

    /// Whether the chart was cut open only because its boundary is short
    /// for its area (a guess that the flat layout would be crushed), not
    /// because it must be (closed, with handles) or was told to.
    fn cut_is_optional(&self) -> bool {
        let opening = &self.prepared.opening;
        opening.seam.is_some() && !opening.seam_given && opening.separation.is_empty()
    }

    /// A finished solve short of its targets on a disk cut open only for
    /// its short boundary ([`Self::cut_is_optional`]): the chart solved as
    /// it is, uncut, takes the session's place when it comes closer to the
    /// targets (the square detour then follows on whichever is kept: the
    /// uncut solve is the cheaper remedy, tried first). Such a cut solve
    /// tries its completion's first path only
    /// ([`ChartSolver::first_path_only`]); when the uncut one does no
    /// better, it is solved again with every path, and the closer kept.
    fn detour_uncut(&mut self, solver: &mut ChartSolver) {
        let residual = solver.max_residual();
        if residual <= solver.options().tolerance || !self.cut_is_optional() {
            return;
        }
        let options = *solver.options();
        let t0 = Instant::now();
        match self.uncut_solve(solver, &options) {
            Some((uncut, mut alt)) if alt.max_residual() < residual => {
                alt.note_cut_fell_short(residual);
                *self = uncut;
                *solver = alt;
                return;
            }
            _ => self.times.detour_ms += ms(t0),
        }
        if !solver.skipped_paths() {
            return;
        }
        let (t1, first_path_ms) = (Instant::now(), solver.times().total_ms());
        let every = self.new_solver_with(&options, StartFrom::StepOne, PathBudget::Every);
        match every.ok().and_then(finished) {
            Some(every) if every.max_residual() < residual => {
                *solver = every;
                self.times.detour_ms += first_path_ms;
            }
            _ => self.times.detour_ms += ms(t1),
        }
    }

    /// This session's chart solved uncut with `options` after the cut
    /// `solver` (its time counted as detour), or `None` if it fails.
    fn uncut_solve(&self, solver: &ChartSolver, options: &SolverOptions) -> Option<(ChartSession, ChartSolver)> {
        let mut uncut = ChartSession::open(self.source.without_seams(), self.asset.clone(), 0.0).ok()?;
        uncut.revision = self.revision;
        uncut.times.load_ms = self.times.load_ms;
        uncut.times.detour_ms = self.times.with_solver(solver.times()).total_ms() - self.times.load_ms;
        let alt = finished(uncut.new_solver(options, StartFrom::StepOne).ok()?)?;
        Some((uncut, alt))
    }

    /// The other charts holding constraints, each solved free with its own
    /// constraints, clear of this chart's layout in `solver` and of those
    /// solved before it; their reports, and why any could not be solved.
    fn solve_secondary(&self, solver: &ChartSolver) -> Secondaries {
        let triangles_of = |p: &PreparedChart, layout: &[DVec2]| -> Vec<[DVec2; 3]> {
            let f = &p.filled;
            f.mesh.triangles[..f.n_real_triangles]
                .iter()
                .map(|t| t.map(|v| layout[v as usize]))
                .collect()
        };
        let mut placed = triangles_of(&self.prepared, solver.layout());
        let mut replaced = vec![self.prepared.chart.id];
        replaced.extend(&self.prepared.secondary);
        let (mut solved, mut reports, mut unsolved) = (Vec::new(), Vec::new(), Vec::new());
        let charts = self.prepared.secondary.iter().map(|&id| (id, None));
        let pieces = self.prepared.opening.pieces.iter().map(|p| (p.id, Some(p.clone())));
        for (id, piece) in pieces.chain(charts) {
            let pick = chart::Pick {
                chart: Some(id),
                placed: Arc::new(placed.clone()),
                replaced: replaced.clone(),
                form: piece.as_ref().and(self.pick.form.clone()),
                boundary: piece.as_ref().map(|_| crate::pins::BoundaryChoice::Free),
                piece,
            };
            let outcome =
                chart::prepare_pick(&self.source, &self.asset, self.prepared.welded.clone(), &pick).and_then(|p| {
                    let mut session = ChartSession::from_prepared(self.source.clone(), self.asset.clone(), p);
                    session.pick = pick.clone();
                    let solution = session.solve(solver.options())?;
                    Ok((session.prepared, solution))
                });
            match outcome {
                Ok((prepared, solution)) => {
                    placed.extend(triangles_of(&prepared, solution.solver.layout()));
                    reports.push(solution.report);
                    solved.push(export::Secondary {
                        layout: solution.solver.layout().to_vec(),
                        prepared,
                    });
                }
                // A chart or piece that cannot be solved is laid out with the
                // rest, its landmarks unreached: partial, never an error.
                Err(e) => match pick.piece {
                    Some(piece) => unsolved.push((piece, e.to_string())),
                    None => unsolved.push((Arc::new(self.prepared.welded.chart(id)), format!("chart {id}: {e}"))),
                },
            }
        }
        Secondaries {
            solved,
            reports,
            unsolved,
        }
    }

    /// Solves the current constraints from start to end.
    ///
    /// # Errors
    /// As [`Self::new_solver`]; a Newton system that cannot be built (a bug).
    pub fn solve(&mut self, options: &SolverOptions) -> Result<Solution, Error> {
        self.solve_watching(options, &mut |_| {})
    }

    /// As [`Self::solve`], telling `watch` where it stands: each stage as
    /// it begins, and after every tick of the solver.
    ///
    /// # Errors
    /// As [`Self::solve`].
    pub fn solve_watching(
        &mut self,
        options: &SolverOptions,
        watch: &mut dyn FnMut(Progress),
    ) -> Result<Solution, Error> {
        let solved = self.run_solve(options, StartFrom::StepOne, &|| false, watch)?;
        solved.ok_or_else(|| Error::Internal("a solve that nothing stops was stopped".into()))
    }

    /// As [`Self::solve`], started `from` where asked; `stop` is asked
    /// between ticks, and when it says so the solve is dropped (`None`).
    ///
    /// # Errors
    /// As [`Self::solve`].
    pub fn solve_until(
        &mut self,
        options: &SolverOptions,
        from: StartFrom,
        stop: &dyn Fn() -> bool,
    ) -> Result<Option<Solution>, Error> {
        self.run_solve(options, from, stop, &mut |_| {})
    }

    fn run_solve(
        &mut self,
        options: &SolverOptions,
        from: StartFrom,
        stop: &dyn Fn() -> bool,
        watch: &mut dyn FnMut(Progress),
    ) -> Result<Option<Solution>, Error> {
        watch(Progress::at(Stage::StepOne));
        let mut plan = crate::plan::ChartPlan::new(self.clone(), *options, from);
        while !plan.is_done() {
            if stop() {
                return Ok(None);
            }
            plan.tick()?;
            watch(plan.progress());
        }
        watch(Progress::at(Stage::Finishing));
        let solved = plan.into_solution()?;
        *self = solved.session;
        let mut report = solved.report;
        let solver = solved.solver;
        self.solve_others(&solver, &mut report);
        Ok(Some(Solution { solver, report }))
    }

    /// Checks `solver`'s layout as stored and writes what `outputs` names
    /// in one commit ([`export::export`]); the final report. Pictures
    /// without a background are drawn over the constraint file's `image:`.
    pub fn export(&self, solver: &ChartSolver, report: &Report, outputs: &Outputs) -> Report {
        let finished = self.finished(solver);
        #[cfg(feature = "pictures")]
        if outputs.pictures.any() && outputs.pictures.background.is_none() {
            let mut outputs = outputs.clone();
            outputs.pictures.background = self.source.image_path();
            return export::export(&finished, report, &outputs);
        }
        export::export(&finished, report, outputs)
    }

    /// `solver`'s layout, finished: the other charts that need UVs
    /// unwrapped (once per session) for packing around it.
    fn finished<'a>(&'a self, solver: &'a ChartSolver) -> export::Finished<'a> {
        let rest = self.rest.get_or_init(|| {
            let charts = crate::atlas::rest_charts(&self.asset, &self.prepared);
            Arc::new(crate::atlas::unwrap_all(
                &self.asset,
                &self.prepared,
                charts,
                solver.options(),
            ))
        });
        export::Finished {
            asset: &self.asset,
            prepared: &self.prepared,
            outer_loop: self.boundary.as_ref().map_or(&[], |b| &b.loop_vertices),
            layout: solver.layout(),
            guard: solver.options().guard,
            rest: Some(rest),
            secondary: &self.secondary,
        }
    }

    /// The final UVs per face corner of every primitive, as a file would
    /// store them, with the checks and packing of [`Self::export`]: the
    /// final report, and the UVs unless it refused the layout.
    pub fn final_uvs(
        &self,
        solver: &ChartSolver,
        report: &Report,
    ) -> (Report, Option<Vec<crate::io::corners::CornerUvs>>) {
        let mut report = report.clone();
        let uvs = export::final_uvs(&self.finished(solver), &mut report);
        (report, uvs)
    }

    /// The final UVs per primitive of the asset with `layout` on this chart.
    pub fn uvs(&self, layout: &[DVec2]) -> PrimitiveUvs {
        chart::assemble_uvs(&self.asset, &self.prepared, layout)
    }

    /// The asset the chart is from.
    pub fn asset(&self) -> &Arc<SourceAsset> {
        &self.asset
    }

    /// Where the current constraints came from.
    pub fn source(&self) -> &ConstraintSource {
        &self.source
    }

    /// The chart: weld, topology, hole fill, resolved constraints.
    pub fn prepared(&self) -> &PreparedChart {
        &self.prepared
    }

    /// The outer loop on the square, once mapped.
    pub fn boundary(&self) -> Option<&BoundaryMap> {
        self.boundary.as_deref()
    }

    /// The bar-net factor, once factored.
    pub fn bar_net(&self) -> Option<&Arc<BarNet>> {
        self.bar_net.as_ref()
    }

    /// The step-1 layout of the filled chart, once solved.
    pub fn step_one_layout(&self) -> Option<&[DVec2]> {
        self.step_one.as_deref().map(Vec::as_slice)
    }

    /// Step 1's results together (`None` until solved), with this
    /// solve's step-1 times.
    pub fn step_one(&self) -> Option<StepOne> {
        Some(StepOne {
            boundary: self.boundary.as_deref()?.clone(),
            bar_net: self.bar_net.clone()?,
            layout: self.step_one.as_deref()?.clone(),
            times: StepOneTimes {
                boundary_ms: self.times.boundary_ms,
                factor_ms: self.times.factor_ms,
                solve_ms: self.times.solve_ms,
            },
        })
    }

    /// The Newton pattern of the last solver started (kept for the same chart).
    pub fn pattern(&self) -> Option<&Arc<PendingNewtonPattern>> {
        self.pattern.as_ref()
    }

    /// This solve's times so far (load, topology, step 1).
    pub fn times(&self) -> StageTimes {
        self.times
    }

    /// Changes with every new starting point of a solve.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Puts the outer loop where `boundary` says (same loop, new positions):
    /// step 1 is solved again on the same factor.
    pub fn replace_boundary(&mut self, boundary: BoundaryMap) {
        self.boundary = Some(Arc::new(boundary));
        (self.step_one, self.last_layout) = (None, None);
        self.revision += 1;
    }

    fn on_square(&self) -> bool {
        matches!(self.prepared.domain, Domain::Square)
    }

    fn mapped_boundary(&self) -> Result<&BoundaryMap, Error> {
        self.boundary.as_deref().ok_or_else(|| not_yet("the boundary map"))
    }
}

/// A step asked for before the one it needs (a bug of the caller).
fn not_yet(what: &str) -> Error {
    Error::Internal(format!("{what} is needed first"))
}
