//! The planner: how a landmarked chart is laid out is measured, not guessed.
//! Its candidates ([`candidates`]) — the chart as given on the square or
//! free, from its own start or its square solve, cut open, as a camera
//! fitted to the targets sees it, the landmarks' surroundings — are tried
//! simplest first, each on its coarse level when the chart is large
//! ([`attempt`]), and judged by what they give: reached or how short,
//! and the stretch against the chart's own free layout ([`own`]). The
//! first that reaches within [`own::ACCEPT`] of it ends the search; else
//! the best one tried is kept (a simpler one unless a later one is
//! measurably better). The winner's coarse layout is prolonged and
//! finished on the chart itself; a chart left short keeps a usable
//! layout ([`settle`]). The report's explain lists what was tried, what
//! each gave, and why the winner won.
//!
//! [`ChartPlan`] runs tick by tick, as the chart solver does: the ECS
//! systems tick its running solver and call [`ChartPlan::advance`] between;
//! [`crate::assembly::solve`] runs the same sequence in a loop.

pub mod attempt;
pub mod candidates;
pub mod settle;

use crate::cut::prepare::Form;
use crate::domain::Domain;
use crate::error::Error;
use crate::options::SolverOptions;
use crate::param::uv_to_xy;
use crate::report::{self, PlanReport, Report, TrialOutcome, TrialReport};
use crate::session::{ChartSession, StartFrom};
use crate::solver::multilevel::{Level, coarse_size};
use crate::solver::own;
use crate::solver::{ChartSolver, Progress, SolverInputs, Stage};
use attempt::{Attempt, LevelChart};
use candidates::{Candidate, Ended};
use glam::DVec2;
use std::sync::Arc;
use std::time::Instant;

/// A later candidate replaces a simpler one that reached only when its
/// stretch is below this share of it: measurably better.
const BETTER: f64 = 0.9;

/// A candidate short on its coarse level is searched on the chart itself
/// for at most this many times what every candidate took on its level.
const FINE_SEARCH: f64 = 4.0;

/// A tried candidate: what it gave, and while it may be chosen, its
/// chart and solve.
#[derive(Debug, Clone)]
struct Trial {
    report: TrialReport,
    key: Candidate,
    tried: Option<Tried>,
}

/// A tried candidate's chart and solve.
#[derive(Debug, Clone)]
struct Tried {
    session: ChartSession,
    chart: LevelChart,
    solver: ChartSolver,
}

impl Trial {
    fn ended(&self) -> Ended {
        match &self.report.outcome {
            TrialOutcome::Solved { reached: true, .. } => Ended::Reached,
            TrialOutcome::Solved { .. }
                if self
                    .tried
                    .as_ref()
                    .is_some_and(|t| t.chart.prepared.domain.free().is_some()) =>
            {
                Ended::ShortFree
            }
            TrialOutcome::Solved { .. } => Ended::Short,
            TrialOutcome::Dropped { .. } => Ended::Dropped,
        }
    }

    /// Whether its completion proved the targets unreachable by the
    /// landmarks alone (a triangle of landmarks sent to its mirror image):
    /// no other candidate can reach them either.
    fn proven_by_landmarks(&self) -> bool {
        let Some(tried) = &self.tried else {
            return false;
        };
        let landmarks = &tried.chart.prepared.constraint_vertices;
        let record = tried.solver.record();
        record
            .soft
            .as_ref()
            .and_then(|s| s.obstruction.as_ref())
            .is_some_and(|o| o.vertices().iter().all(|v| landmarks.contains(v)))
    }

    /// Reached within [`own::ACCEPT`] of its chart's own stretch.
    fn good_enough(&self) -> bool {
        match &self.report.outcome {
            TrialOutcome::Solved {
                reached: true,
                stretch,
                own,
                ..
            } => own.is_none_or(|o| stretch.l2 <= own::ACCEPT * o.l2),
            _ => false,
        }
    }
}

/// A candidate opened: its session and attempt at the trial level, or the
/// tried candidate (its index) whose chart, boundary and start it repeats.
enum Opened {
    Trying(Box<(ChartSession, Attempt)>),
    SameAs(usize),
}

/// A finished plan: the chart as chosen (its session), the solver with its
/// final layout, and the report; [`crate::assembly::finish`] adds the other
/// charts holding landmarks.
#[derive(Debug, Clone)]
pub struct Solution {
    pub session: ChartSession,
    pub solver: ChartSolver,
    pub report: Report,
}

/// Where a plan stands.
#[derive(Debug, Clone)]
enum State {
    /// The next candidate is to be opened.
    Next,
    /// A candidate being solved at its trial level.
    Trying {
        key: Candidate,
        session: ChartSession,
        attempt: Box<Attempt>,
        t0: Instant,
    },
    /// The chosen candidate's solve on the chart itself.
    Finishing {
        session: ChartSession,
        attempt: Box<Attempt>,
    },
    Done(Box<Solution>),
    /// The solution was taken ([`ChartPlan::take_solution`]).
    Taken,
}

/// The solve of one landmarked chart, candidate by candidate (see the
/// module docs).
#[derive(Debug, Clone)]
pub struct ChartPlan {
    base: ChartSession,
    options: SolverOptions,
    from: StartFrom,
    chart: candidates::Chart,
    trials: Vec<Trial>,
    chosen: Option<(usize, &'static str)>,
    first_error: Option<Arc<Error>>,
    state: State,
    started: Instant,
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

impl ChartPlan {
    /// The plan of `base`'s chart (as the file and the default rule make
    /// it), with `options`; a chart on the square as given starts `from`
    /// where asked.
    pub fn new(base: ChartSession, options: SolverOptions, from: StartFrom) -> ChartPlan {
        let chart = describe(&base);
        ChartPlan {
            base,
            options,
            from,
            chart,
            trials: Vec::new(),
            chosen: None,
            first_error: None,
            state: State::Next,
            started: Instant::now(),
        }
    }

    /// Whether the plan is over.
    pub fn is_done(&self) -> bool {
        matches!(self.state, State::Done(_) | State::Taken)
    }

    /// The solver running now, to tick (none between candidates).
    pub fn solver_mut(&mut self) -> Option<&mut ChartSolver> {
        match &mut self.state {
            State::Trying { attempt, .. } | State::Finishing { attempt, .. } => Some(attempt.solver_mut()),
            State::Next | State::Done(_) | State::Taken => None,
        }
    }

    /// The solver running now.
    pub fn solver(&self) -> Option<&ChartSolver> {
        match &self.state {
            State::Trying { attempt, .. } | State::Finishing { attempt, .. } => Some(attempt.solver()),
            State::Next | State::Done(_) | State::Taken => None,
        }
    }

    /// Where the solve stands.
    pub fn progress(&self) -> Progress {
        match &self.state {
            State::Next if self.trials.is_empty() => Progress::at(Stage::StepOne),
            State::Next => Progress::at(Stage::Choosing),
            State::Done(_) | State::Taken => Progress::at(Stage::Finishing),
            _ => self
                .solver()
                .map_or(Progress::at(Stage::StepOne), ChartSolver::progress),
        }
    }

    /// One tick: the running solver's, or the plan's own step between
    /// solves ([`Self::advance`]).
    ///
    /// # Errors
    /// As [`Self::advance`] and [`ChartSolver::tick`].
    pub fn tick(&mut self) -> Result<(), Error> {
        let ticked = match self.solver_mut() {
            Some(solver) if !solver.is_done() => solver.tick(),
            _ => return self.advance(),
        };
        ticked.or_else(|e| self.solver_failed(e))
    }

    /// The running solver failed with `e`: a candidate on trial is dropped
    /// with why (the plan goes on with the next); the chosen one's failure
    /// is the plan's.
    ///
    /// # Errors
    /// `e`, when the chosen candidate's solve failed.
    pub fn solver_failed(&mut self, e: Error) -> Result<(), Error> {
        match std::mem::replace(&mut self.state, State::Next) {
            State::Trying { key, t0, .. } => {
                self.fail_trial(key, e, t0);
                Ok(())
            }
            other => {
                self.state = other;
                Err(e)
            }
        }
    }

    /// Runs the plan to its end.
    ///
    /// # Errors
    /// As [`Self::tick`].
    pub fn run(&mut self) -> Result<(), Error> {
        while !self.is_done() {
            self.tick()?;
        }
        Ok(())
    }

    /// The finished solve.
    ///
    /// # Errors
    /// The plan is not done (a bug of the caller).
    pub fn into_solution(self) -> Result<Solution, Error> {
        match self.state {
            State::Done(solution) => Ok(*solution),
            _ => Err(Error::Internal(
                "a plan asked for its solution before it was done".into(),
            )),
        }
    }

    /// The finished solve, taken out once the plan is done (`None` before,
    /// and after it was taken).
    pub fn take_solution(&mut self) -> Option<Solution> {
        match std::mem::replace(&mut self.state, State::Taken) {
            State::Done(solution) => Some(*solution),
            other => {
                self.state = other;
                None
            }
        }
    }

    /// The plan's own step while no solver is running: the next candidate
    /// opened, a finished trial judged, the winner prolonged, or the end.
    ///
    /// # Errors
    /// Every candidate failed to open (the first one's error), or a solver
    /// of the chosen chart could not be built.
    pub fn advance(&mut self) -> Result<(), Error> {
        match std::mem::replace(&mut self.state, State::Next) {
            State::Next => self.open_next(),
            State::Trying {
                key,
                session,
                mut attempt,
                t0,
            } => {
                let source = session.source().clone();
                // A candidate whose solve fails (no room for it) is dropped
                // with why; the plan goes on with the next.
                let advanced = match attempt.advance(&source, &self.options) {
                    Ok(advanced) => advanced,
                    Err(e) => {
                        self.fail_trial(key, e, t0);
                        return Ok(());
                    }
                };
                if !advanced {
                    self.state = State::Trying {
                        key,
                        session,
                        attempt,
                        t0,
                    };
                    return Ok(());
                }
                self.judge(key, session, *attempt, t0);
                Ok(())
            }
            State::Finishing { session, mut attempt } => {
                let source = session.source().clone();
                if attempt.advance(&source, &self.options)? {
                    self.finish(session, attempt.into_parts().1)?;
                } else {
                    self.state = State::Finishing { session, attempt };
                }
                Ok(())
            }
            done @ (State::Done(_) | State::Taken) => {
                self.state = done;
                Ok(())
            }
        }
    }

    /// Opens the next candidate and starts its attempt, or, with none left
    /// (or one good enough), finishes the best.
    fn open_next(&mut self) -> Result<(), Error> {
        if self.trials.last().is_some_and(Trial::good_enough) {
            return self.choose(
                self.trials.len() - 1,
                "it reached its targets within 1.5× its own stretch",
            );
        }
        if self.trials.last().is_some_and(Trial::proven_by_landmarks) {
            return self.choose(
                self.trials.len() - 1,
                "the landmarks alone prove the targets unreachable (no form of the chart can change that)",
            );
        }
        // The paper's guard is for comparison with the paper's method: the
        // chart as given, nothing else.
        if self.options.guard == crate::options::Guard::Paper && !self.trials.is_empty() {
            return self.choose_best();
        }
        let tried: Vec<(Candidate, Ended)> = self.trials.iter().map(|t| (t.key.clone(), t.ended())).collect();
        let Some(key) = candidates::next(&self.chart, &tried) else {
            return self.choose_best();
        };
        let t0 = Instant::now();
        match self.start(&key) {
            Ok(Opened::Trying(opened)) => {
                let (session, attempt) = *opened;
                self.state = State::Trying {
                    key,
                    session,
                    attempt: Box::new(attempt),
                    t0,
                };
            }
            Ok(Opened::SameAs(k)) => {
                let why = format!("it makes the same chart, boundary and start as candidate {}", k + 1);
                self.drop_trial(key, why, t0);
            }
            Err(e) => self.fail_trial(key, e, t0),
        }
        Ok(())
    }

    /// Records `key` as not solved because of `e`, kept as the plan's
    /// error should no candidate be solved.
    fn fail_trial(&mut self, key: Candidate, e: Error, t0: Instant) {
        self.drop_trial(key, e.to_string(), t0);
        self.first_error.get_or_insert(Arc::new(e));
    }

    /// Records `key` as not solved, and why.
    fn drop_trial(&mut self, key: Candidate, why: String, t0: Instant) {
        let from = match key.start {
            candidates::Start::Own => "",
            candidates::Start::Square => ", from its solve on the square",
        };
        let candidate = format!("{}, {}{from}", key.form.name(), boundary_word(key.boundary));
        self.trials.push(Trial {
            report: TrialReport {
                candidate,
                outcome: TrialOutcome::Dropped { why },
                ms: ms(t0),
            },
            key,
            tried: None,
        });
    }

    /// The tried candidate (its index) with `key`'s start whose chart
    /// `session` makes again: as given or cut, the same triangles, the
    /// same landmarks, the same kind of boundary. Its solve would be the
    /// same.
    fn same_chart(&self, key: &Candidate, session: &ChartSession) -> Option<usize> {
        let plain = |form: &Form| matches!(form, Form::AsGiven | Form::Cut);
        let whole = |p: &crate::chart::PreparedChart| p.opening.pieces.is_empty() && p.opening.separation.is_empty();
        let a = session.prepared();
        if !(plain(&key.form) && whole(a)) {
            return None;
        }
        self.trials.iter().position(|t| {
            t.key.start == key.start
                && plain(&t.key.form)
                && t.tried.as_ref().is_some_and(|tried| {
                    let b = tried.session.prepared();
                    whole(b)
                        && a.chart.welded_ids == b.chart.welded_ids
                        && a.chart.mesh.triangles == b.chart.mesh.triangles
                        && a.filled.mesh.triangles == b.filled.mesh.triangles
                        && a.constraint_vertices == b.constraint_vertices
                        && std::mem::discriminant(&a.domain) == std::mem::discriminant(&b.domain)
                })
        })
    }

    /// The session of `key`'s chart and its attempt at the trial level.
    fn start(&self, key: &Candidate) -> Result<Opened, Error> {
        let elapsed = self.elapsed_ms();
        // Another start of a form and boundary tried on a coarse level
        // already is solved on that level: it is not made again.
        if let Some(tried) = self.same_level(key) {
            let attempt = Attempt::new(
                tried.chart.clone(),
                key.start,
                tried.session.source(),
                &self.options,
                elapsed,
            )?;
            return Ok(Opened::Trying(Box::new((tried.session.clone(), attempt))));
        }
        let mut session = if key.form == Form::AsGiven && key.boundary.is_none() {
            self.base.clone()
        } else {
            self.base.reshaped(&key.form, key.boundary)?
        };
        if let Some(k) = self.same_chart(key, &session) {
            return Ok(Opened::SameAs(k));
        }
        let chart = self.trial_level(&mut session, elapsed)?;
        let attempt = Attempt::new(chart, key.start, session.source(), &self.options, elapsed)?;
        Ok(Opened::Trying(Box::new((session, attempt))))
    }

    /// A tried candidate of `key`'s form and boundary whose coarse level
    /// is kept.
    fn same_level(&self, key: &Candidate) -> Option<&Tried> {
        self.trials
            .iter()
            .filter(|t| t.key.form == key.form && t.key.boundary == key.boundary)
            .find_map(|t| t.tried.as_ref())
            .filter(|t| t.chart.level.is_some())
    }

    /// The chart a candidate is tried on: its coarse level when it is
    /// large, else itself (step 1 run, warm on the square where asked).
    fn trial_level(&self, session: &mut ChartSession, elapsed: f64) -> Result<LevelChart, Error> {
        session.map_boundary()?;
        let n = session.prepared().filled.mesh.n_vertices();
        if n > self.options.multilevel_above {
            let boundary = session.boundary().expect("mapped");
            let inputs = SolverInputs {
                prepared: session.prepared(),
                source: session.source(),
                options: &self.options,
                boundary,
                step1: &[],
                bar_net: None,
                pattern: None,
                elapsed_ms: elapsed,
            };
            if let Ok(level) = Level::make(&inputs, coarse_size(n, &self.options)) {
                return LevelChart::coarse(level, session.source());
            }
        }
        let warm = match self.from {
            StartFrom::LastLayout => session.last_layout(),
            StartFrom::StepOne => None,
        };
        fine_level(session, warm)
    }

    /// Records a finished attempt and what it gave: a form that leaves
    /// landmarks on other parts is judged with them, each solved beside it.
    fn judge(&mut self, key: Candidate, session: ChartSession, attempt: Attempt, t0: Instant) {
        let (chart, solver) = attempt.into_parts();
        let tolerance = self.options.tolerance;
        let mut residual = solver.max_residual();
        let pieces = session.prepared().opening.pieces.len();
        if pieces > 0 && residual <= tolerance {
            let beside = (
                chart.prepared.placed(solver.layout()),
                chart.prepared.density(solver.layout()),
            );
            residual = residual.max(self.pieces_residual(&session, beside));
        }
        // A seam or separation through a landmark leaves a copy of it off
        // its target, however the chart is laid out.
        if let Some(off) = chart.prepared.landmark_copies_off(solver.layout(), session.prepared()) {
            residual = residual.max(off);
        }
        let reached = residual <= tolerance;
        let stretch = own::stretch(&chart.prepared, solver.layout());
        let own = reached
            .then(|| own::own_stretch(&chart.prepared, &self.options))
            .flatten();
        let mut candidate = key.describe(&chart.prepared.domain);
        if pieces > 0 {
            candidate += &format!(" (and {pieces} more part(s) holding landmarks)");
        }
        self.trials.push(Trial {
            report: TrialReport {
                candidate,
                outcome: TrialOutcome::Solved {
                    reached,
                    residual,
                    stretch,
                    own,
                    vertices: chart.prepared.filled.n_real_vertices,
                },
                ms: ms(t0),
            },
            key,
            tried: Some(Tried { session, chart, solver }),
        });
    }

    /// The farthest a landmark on `session`'s other pieces ends from its
    /// target, each piece solved free beside the `placed` triangles and
    /// those before it, at most at the chart's texel density `density` (as
    /// [`crate::assembly`] solves them); infinite when
    /// one cannot be solved.
    fn pieces_residual(&self, session: &ChartSession, (mut placed, density): (Vec<[DVec2; 3]>, f64)) -> f64 {
        let mut worst = 0.0f64;
        for (k, piece) in session.prepared().opening.pieces.iter().enumerate() {
            let solved = session
                .beside(k, (piece.id, Some(piece.clone())), (&placed, density))
                .and_then(|other| solve(other, &self.options));
            let Ok(solved) = solved else {
                return f64::INFINITY;
            };
            worst = worst.max(solved.solver.max_residual());
            placed.extend(solved.session.prepared().placed(solved.solver.layout()));
        }
        worst
    }

    /// Keeps the best candidate tried: the simplest that reached unless a
    /// later one is measurably less stretched; with none reached, the
    /// closest to the targets.
    fn choose_best(&mut self) -> Result<(), Error> {
        let solved: Vec<(usize, bool, f64, f64)> = self
            .trials
            .iter()
            .enumerate()
            .filter_map(|(i, t)| match &t.report.outcome {
                TrialOutcome::Solved {
                    reached,
                    residual,
                    stretch,
                    ..
                } => Some((i, *reached, *residual, stretch.l2)),
                TrialOutcome::Dropped { .. } => None,
            })
            .collect();
        let mut best: Option<(usize, f64)> = None;
        for &(i, reached, _, l2) in &solved {
            if reached && best.is_none_or(|(_, b)| l2 < BETTER * b) {
                best = Some((i, l2));
            }
        }
        if let Some((i, _)) = best {
            return self.choose(i, "it reached its targets with the least stretch");
        }
        // None reached: the simplest, unless a later one is measurably closer.
        let mut closest: Option<(usize, f64)> = None;
        for &(i, _, residual, _) in &solved {
            if closest.is_none_or(|(_, r)| residual < BETTER * r) {
                closest = Some((i, residual));
            }
        }
        let closest = closest.map(|c| c.0);
        match closest {
            Some(i) => self.choose(i, "none reached its targets; it came closest"),
            None => Err(match self.first_error.take().map(Arc::try_unwrap) {
                Some(Ok(e)) => e,
                Some(Err(shared)) => Error::Internal(shared.to_string()),
                None => Error::Internal("no candidate to lay the chart out".into()),
            }),
        }
    }

    /// Finishes trial `i` on the chart itself: its layout as it is when it
    /// was solved there; else, when it reached its targets on its coarse
    /// level, that layout prolonged; else (short there, or it cannot be put
    /// back) the candidate solved on the chart itself from its own start: a
    /// coarse level can crush what the chart has room for, and a set a
    /// fold-free layout of the chart witnesses is not lost to it.
    fn choose(&mut self, i: usize, why: &'static str) -> Result<(), Error> {
        match self.start_finishing(i, why) {
            // The others are kept until the chosen one's layout is known to
            // be storable ([`Self::finish`]).
            Ok(()) => Ok(()),
            // Solved on its level but with no start on the chart itself (no
            // room there): dropped on that evidence, the next best chosen.
            Err(e) if self.trials.iter().any(|t| t.tried.is_some()) => {
                self.chosen = None;
                self.trials[i].report.outcome = TrialOutcome::Dropped {
                    why: format!("solved on its level, but not on the chart itself: {e}"),
                };
                self.choose_best()
            }
            Err(e) => Err(e),
        }
    }

    /// The chosen candidate (`i`) put onto the chart itself, its solve there
    /// started.
    fn start_finishing(&mut self, i: usize, why: &'static str) -> Result<(), Error> {
        self.chosen = Some((i, why));
        let Some(Tried {
            mut session,
            chart,
            solver,
        }) = self.trials[i].tried.take()
        else {
            return Err(Error::Internal("the chosen candidate was not solved".into()));
        };
        let Some(level) = chart.level else {
            return self.finish(session, solver);
        };
        let elapsed = self.elapsed_ms();
        let reached = self.trials[i].ended() == Ended::Reached;
        let options = match reached {
            true => self.options,
            // Short on its level: the chart itself is searched for at most
            // a few times what the candidates took together on their levels,
            // so a set its level crushed is reached, and one it cannot reach
            // costs no unbounded search.
            false => {
                let tried: f64 = self.trials.iter().map(|t| t.report.ms).sum();
                let cap = elapsed + FINE_SEARCH * tried;
                SolverOptions {
                    time_budget_ms: Some(self.options.time_budget_ms.map_or(cap, |b| b.min(cap))),
                    ..self.options
                }
            }
        };
        let put_back = match reached {
            true => prolonged(&mut session, level, &solver, &options, elapsed)?,
            false => None,
        };
        let mut attempt = match put_back {
            Some(attempt) => attempt,
            None => {
                let chart = fine_level(&mut session, None)?;
                let start = self.trials[i].key.start;
                Attempt::new(chart, start, session.source(), &options, elapsed)?
            }
        };
        // Held to its own free layout as its level measured it: polished
        // above that, whatever its size.
        if let TrialOutcome::Solved { own: Some(own), .. } = &self.trials[i].report.outcome {
            attempt.solver_mut().hold_stretch_to(own::ACCEPT * own.l2);
        }
        self.state = State::Finishing {
            session,
            attempt: Box::new(attempt),
        };
        Ok(())
    }

    /// The end: a short layout settled, the report built with what was
    /// tried. A layout f32 cannot store (no file could be written) first
    /// drops its candidate for the next best one solved, while there is
    /// one; the last is settled.
    fn finish(&mut self, mut session: ChartSession, mut solver: ChartSolver) -> Result<(), Error> {
        session.map_boundary()?;
        if let Some((i, _)) = self.chosen
            && !storable(&session, &solver)
            && self.trials.iter().any(|t| t.tried.is_some())
        {
            self.chosen = None;
            self.trials[i].report.outcome = TrialOutcome::Dropped {
                why: "solved on its level, but its layout on the chart itself cannot be stored as f32 texture \
                      coordinates (triangles too thin)"
                    .into(),
            };
            return self.choose_best();
        }
        settle::settle(session.prepared(), session.step_one_layout(), &mut solver);
        self.trials.iter_mut().for_each(|t| t.tried = None);
        session.keep(&solver);
        let mut times = session.times().with_solver(solver.times());
        times.detour_ms = (times.load_ms + times.topology_ms + self.elapsed_ms() - times.total_ms()).max(0.0);
        let step1 = session.step_one_layout().unwrap_or(solver.start_layout()).to_vec();
        let plan = self.report();
        let mut report = report::build(&report::SolveSummary {
            constraint_file: session.source().name(),
            asset: session.asset(),
            prepared: session.prepared(),
            boundary: session.boundary().expect("mapped"),
            step1: &step1,
            solver: &solver,
            times,
        });
        report.explain.splice(0..0, plan.lines());
        report.plan = Some(plan);
        self.state = State::Done(Box::new(Solution {
            session,
            solver,
            report,
        }));
        Ok(())
    }

    /// What was tried and kept, for the report.
    pub fn report(&self) -> PlanReport {
        PlanReport {
            tried: self.trials.iter().map(|t| t.report.clone()).collect(),
            chosen: self.chosen.map(|c| c.0),
            why: self.chosen.map_or(String::new(), |c| c.1.to_string()),
        }
    }

    fn elapsed_ms(&self) -> f64 {
        self.base.times().load_ms + self.base.times().topology_ms + ms(self.started)
    }
}

/// Whether `solver`'s layout of `session`'s chart keeps every real
/// triangle as f32 stores it (what the export checks before it writes).
fn storable(session: &ChartSession, solver: &ChartSolver) -> bool {
    let filled = &session.prepared().filled;
    crate::guard::all_positive_as_stored(solver.layout(), &filled.mesh.triangles[..filled.n_real_triangles])
}

/// The chart of `session` itself as a level, its step 1 run (`warm` in
/// its place where given).
fn fine_level(session: &mut ChartSession, warm: Option<Arc<Vec<DVec2>>>) -> Result<LevelChart, Error> {
    session.run_step_one()?;
    let step1 = warm.or_else(|| session.step_one_layout().map(|l| Arc::new(l.to_vec())));
    Ok(LevelChart {
        prepared: session.prepared().clone(),
        boundary: Arc::new(session.boundary().expect("mapped").clone()),
        bar_net: session.bar_net().cloned(),
        step1: step1.ok_or_else(|| Error::Internal("step 1 was not solved".into()))?,
        pattern: session.pattern().cloned(),
        level: None,
    })
}

/// The fine solve of `session`'s chart from `solver`'s coarse layout on
/// `level`, prolonged; `None` when it cannot be put back.
fn prolonged(
    session: &mut ChartSession,
    level: Level,
    solver: &ChartSolver,
    options: &SolverOptions,
    elapsed: f64,
) -> Result<Option<Attempt>, Error> {
    let t0 = Instant::now();
    let boundary = Arc::new(session.boundary().expect("mapped").clone());
    let prepared = session.prepared().clone();
    let inputs = SolverInputs {
        prepared: &prepared,
        source: session.source(),
        options,
        boundary: &boundary,
        step1: &[],
        bar_net: None,
        pattern: session.pattern(),
        elapsed_ms: elapsed,
    };
    let Ok((layout, mut stats)) = level.prolong(&inputs, solver.layout()) else {
        return Ok(None);
    };
    stats.coarse_solve_ms = solver.times().total_ms();
    let Ok(fine) = ChartSolver::from_prolonged(inputs, layout, stats, t0)? else {
        return Ok(None);
    };
    let chart = LevelChart {
        prepared,
        boundary,
        bar_net: None,
        step1: Arc::new(Vec::new()),
        pattern: None,
        level: None,
    };
    Ok(Some(Attempt::solving(chart, fine)))
}

fn boundary_word(b: Option<crate::pins::BoundaryChoice>) -> &'static str {
    match b {
        Some(crate::pins::BoundaryChoice::Square) => "on the square",
        Some(crate::pins::BoundaryChoice::Free) => "free",
        None => "as the file or the default says",
    }
}

/// What the planner knows of `base`'s chart before trying anything.
fn describe(base: &ChartSession) -> candidates::Chart {
    let p = base.prepared();
    // A chart or piece solved beside another is free whatever the file
    // says: its pick's boundary is law too.
    let (named, region) = base.source().boundary();
    let boundary = named.or(base.pick().boundary);
    let law = candidates::Law::of(p, boundary, region);
    let landmarks = p
        .constraints
        .iter()
        .zip(&p.constraint_vertices)
        .map(|(c, &v)| (p.filled.mesh.positions[v as usize], uv_to_xy(c.target_uv)))
        .collect();
    let room = region.unwrap_or(crate::param::region::Region::TEXTURE).layout_box();
    candidates::Chart {
        law,
        disk: p.opening.seam.is_none() && p.opening.separation.is_empty(),
        square_by_default: matches!(p.domain, Domain::Square) && boundary.is_none(),
        landmarks,
        room,
        budget: crate::chart::separation_budget(base.source(), base.asset(), &p.welded, p.chart.id, &p.constraints),
    }
}

/// Solves `session`'s chart from start to end ([`ChartPlan`]).
///
/// # Errors
/// As [`ChartPlan::advance`].
pub fn solve(session: ChartSession, options: &SolverOptions) -> Result<Solution, Error> {
    let mut plan = ChartPlan::new(session, *options, StartFrom::StepOne);
    plan.run()?;
    plan.into_solution()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pins::Pins;

    /// A plan on a flat sheet pinned inside: on the square by default, free
    /// next.
    fn sheet_plan() -> ChartPlan {
        let at = |i: u32, j: u32| i + 10 * j;
        let pins = Pins::new(&[
            (at(3, 3), DVec2::new(0.3, 0.3)),
            (at(6, 3), DVec2::new(0.65, 0.3)),
            (at(5, 6), DVec2::new(0.5, 0.7)),
        ]);
        let session = ChartSession::of_mesh(&crate::testing::grid_mesh(10, 10), pins).expect("a session");
        ChartPlan::new(session, SolverOptions::DEFAULT, StartFrom::StepOne)
    }

    #[test]
    fn a_candidate_whose_solve_fails_is_dropped_and_the_plan_goes_on() {
        let mut plan = sheet_plan();
        while !matches!(plan.state, State::Trying { .. }) {
            plan.tick().expect("a tick");
        }
        plan.solver_failed(Error::Internal("no room here (a test)".into()))
            .expect("a candidate on trial is dropped, not the plan's error");
        plan.run().expect("the next candidate is solved");
        let report = plan.report();
        match &report.tried[0].outcome {
            TrialOutcome::Dropped { why } => assert!(why.contains("no room here"), "{why}"),
            other => panic!("the failed candidate is reported dropped: {other:?}"),
        }
        assert!(
            report.chosen.is_some_and(|c| c > 0),
            "another candidate won: {report:?}"
        );
        let solution = plan.into_solution().expect("done");
        assert_eq!(
            solution.report.status,
            report::Status::Reached,
            "{:?}",
            solution.report.message
        );
    }
}
