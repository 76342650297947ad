//! The rules that sequence a chart's solve, each written once: what follows
//! the spline path, whether a polish follows the completion's snap, and
//! when the Newton pattern is worth building early.

use crate::complete::pattern::Build;
use crate::complete::polish::PolishGoal;
use crate::options::{Completion, Guard, SolverOptions};

/// When the distortion polish runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PolishRule {
    /// Never (`polish: false`, or the paper's guard): only a layout f32
    /// cannot store yet is spread until it can.
    Off,
    /// After any result that reached the targets (charts up to `polish_max_vertices`).
    Always,
    /// Larger charts, where the polish is not cheap: only after a completion
    /// whose snap left the layout more distorted than its start (in all, or
    /// in its worst triangle), so it is never left squeezed against the
    /// barrier, or when the layout is more stretched than the chart's own
    /// free layout allows ([`crate::solver::ChartSolver::hold_stretch_to`]).
    IfSnapDistorts,
}

/// Why no distortion polish ran (for `--explain`), or that it did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PolishOutcome {
    /// It ran (for distortion, or only to make the layout storable).
    Ran,
    /// `polish: false`.
    Off,
    /// The paper's guard is a comparison setting: its spline path alone.
    PaperGuard,
    TargetsNotReached,
    /// Nothing can move (every vertex is on the outer boundary).
    NothingToMove,
    /// Above `polish_max_vertices`, after a result that did not call for it.
    AboveLimit {
        after: Reached,
    },
}

/// What reached the targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reached {
    SplinePath,
    Completion,
}

/// What follows the spline path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AfterSpline {
    Polish(PolishGoal),
    /// The spline path once more from the start, a free chart's outer loop
    /// no longer held (it stalled holding it).
    FreeTheLoop,
    /// The completion, from the step-1 layout.
    Complete,
    Done(PolishOutcome),
}

/// How the spline path ended, as [`Policy::after_spline`] weighs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SplineEnd {
    /// Every target was reached.
    pub reached: bool,
    /// The chart has vertices the solve may move (not every one is on the
    /// outer loop or pinned).
    pub movable: bool,
    /// The layout is fold-free as stored (f32).
    pub storable: bool,
    /// A free chart's path stalled holding a sample of its outer loop and
    /// can run again without it.
    pub loop_can_be_freed: bool,
    /// It reached, more stretched than the bound the chart is held to.
    pub too_stretched: bool,
}

/// The solve's rules for one chart, fixed by the options and the chart's size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Policy {
    pub polish: PolishRule,
    pub completion: Completion,
    /// The paper's pointwise guard (a comparison setting): the spline path
    /// alone, no completion, no polish; its layouts are not known to be
    /// storable, so that is counted, not carried.
    pub paper_guard: bool,
    polish_requested: bool,
}

impl Policy {
    /// The rules for a chart of `n_vertices` real vertices.
    pub fn new(options: &SolverOptions, n_vertices: usize) -> Self {
        let paper_guard = options.guard == Guard::Paper;
        let polish = if paper_guard || !options.polish {
            PolishRule::Off
        } else if n_vertices <= options.polish_max_vertices {
            PolishRule::Always
        } else {
            PolishRule::IfSnapDistorts
        };
        Policy {
            polish,
            completion: options.completion,
            paper_guard,
            polish_requested: options.polish,
        }
    }

    /// Whether the completion takes over after a stall (and so the spline
    /// path may call a stall before finishing its last heavy iteration,
    /// whose step would be thrown away).
    pub fn completion_follows_stall(&self) -> bool {
        !self.paper_guard && self.completion == Completion::Auto
    }

    /// Whether the Newton pattern will surely be needed (a polish after any
    /// result, or the completion instead of the spline path): then it is
    /// built beside the spline path.
    pub fn pattern_build(&self) -> Build {
        if self.polish == PolishRule::Always || (!self.paper_guard && self.completion == Completion::Always) {
            Build::InBackground
        } else {
            Build::Lazily
        }
    }

    /// What follows the spline path, from how it ended.
    pub fn after_spline(&self, end: SplineEnd) -> AfterSpline {
        if self.paper_guard {
            return AfterSpline::Done(self.not_run(PolishOutcome::PaperGuard));
        }
        if !end.reached && end.loop_can_be_freed {
            return AfterSpline::FreeTheLoop;
        }
        if !end.reached {
            return match self.completion {
                Completion::Never => AfterSpline::Done(self.not_run(PolishOutcome::TargetsNotReached)),
                Completion::Auto | Completion::Always => AfterSpline::Complete,
            };
        }
        if !end.movable {
            return AfterSpline::Done(self.not_run(PolishOutcome::NothingToMove));
        }
        match (self.polish, end.storable) {
            (PolishRule::Always, _) => AfterSpline::Polish(PolishGoal::Distortion),
            (PolishRule::IfSnapDistorts, _) if end.too_stretched => AfterSpline::Polish(PolishGoal::Distortion),
            (_, false) => AfterSpline::Polish(PolishGoal::Storable),
            (PolishRule::IfSnapDistorts, true) => AfterSpline::Done(PolishOutcome::AboveLimit {
                after: Reached::SplinePath,
            }),
            (PolishRule::Off, true) => AfterSpline::Done(PolishOutcome::Off),
        }
    }

    /// What follows the completion's snap onto the targets: a polish
    /// (`Ok`), or why none runs. `distorted`: the snap left the layout more
    /// distorted than the completion's start; `storable`: as f32.
    pub fn after_snap(&self, distorted: bool, storable: bool) -> Result<PolishGoal, PolishOutcome> {
        let polish = match self.polish {
            PolishRule::Off => false,
            PolishRule::Always => true,
            PolishRule::IfSnapDistorts => distorted,
        };
        match (polish, storable, self.polish) {
            (true, _, _) => Ok(PolishGoal::Distortion),
            (false, false, _) => Ok(PolishGoal::Storable),
            (false, true, PolishRule::Off) => Err(PolishOutcome::Off),
            (false, true, _) => Err(PolishOutcome::AboveLimit {
                after: Reached::Completion,
            }),
        }
    }

    /// Why the polish did not run when the completion ended short of the targets.
    pub fn after_unreached(&self) -> PolishOutcome {
        self.not_run(PolishOutcome::TargetsNotReached)
    }

    /// `polish: false` explains every polish that did not run; else `reason`.
    fn not_run(&self, reason: PolishOutcome) -> PolishOutcome {
        if self.polish_requested {
            reason
        } else {
            PolishOutcome::Off
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn end(reached: bool, movable: bool, storable: bool, loop_can_be_freed: bool) -> SplineEnd {
        SplineEnd {
            reached,
            movable,
            storable,
            loop_can_be_freed,
            too_stretched: false,
        }
    }

    fn policy(n: usize, edit: impl Fn(&mut SolverOptions)) -> Policy {
        let mut o = SolverOptions::DEFAULT;
        edit(&mut o);
        Policy::new(&o, n)
    }

    #[test]
    fn the_polish_rule_follows_the_size_and_the_switches() {
        assert_eq!(policy(50_000, |_| {}).polish, PolishRule::Always);
        assert_eq!(policy(50_001, |_| {}).polish, PolishRule::IfSnapDistorts);
        assert_eq!(policy(10, |o| o.polish = false).polish, PolishRule::Off);
        assert_eq!(policy(10, |o| o.guard = Guard::Paper).polish, PolishRule::Off);
    }

    #[test]
    fn after_the_spline_path() {
        use AfterSpline::*;
        let small = policy(10, |_| {});
        assert_eq!(
            small.after_spline(end(true, true, true, false)),
            Polish(PolishGoal::Distortion)
        );
        assert_eq!(small.after_spline(end(false, true, true, false)), Complete);
        assert_eq!(small.after_spline(end(false, true, true, true)), FreeTheLoop);
        assert_eq!(
            small.after_spline(end(true, true, true, true)),
            Polish(PolishGoal::Distortion)
        );
        assert_eq!(
            small.after_spline(end(true, false, true, false)),
            Done(PolishOutcome::NothingToMove)
        );
        let large = policy(60_000, |_| {});
        let after = Reached::SplinePath;
        assert_eq!(
            large.after_spline(end(true, true, true, false)),
            Done(PolishOutcome::AboveLimit { after })
        );
        // ...unless it is more stretched than its own free layout allows.
        let stretched = SplineEnd {
            too_stretched: true,
            ..end(true, true, true, false)
        };
        assert_eq!(large.after_spline(stretched), Polish(PolishGoal::Distortion));
        // A layout f32 cannot store is always spread, whatever the rule...
        assert_eq!(
            large.after_spline(end(true, true, false, false)),
            Polish(PolishGoal::Storable)
        );
        let off = policy(10, |o| o.polish = false);
        assert_eq!(
            off.after_spline(end(true, true, false, false)),
            Polish(PolishGoal::Storable)
        );
        assert_eq!(off.after_spline(end(true, true, true, false)), Done(PolishOutcome::Off));
        // ...but not under the paper's guard, which runs its spline path alone.
        let paper = policy(10, |o| o.guard = Guard::Paper);
        assert_eq!(
            paper.after_spline(end(true, true, false, false)),
            Done(PolishOutcome::PaperGuard)
        );
        assert_eq!(
            paper.after_spline(end(false, true, true, false)),
            Done(PolishOutcome::PaperGuard)
        );
        let never = policy(10, |o| o.completion = Completion::Never);
        assert_eq!(
            never.after_spline(end(false, true, true, false)),
            Done(PolishOutcome::TargetsNotReached)
        );
        let never_off = policy(10, |o| {
            o.completion = Completion::Never;
            o.polish = false;
        });
        assert_eq!(
            never_off.after_spline(end(false, true, true, false)),
            Done(PolishOutcome::Off)
        );
    }

    #[test]
    fn after_the_snap() {
        let small = policy(10, |_| {});
        assert_eq!(small.after_snap(false, true), Ok(PolishGoal::Distortion));
        let large = policy(60_000, |_| {});
        assert_eq!(large.after_snap(true, true), Ok(PolishGoal::Distortion));
        assert_eq!(
            large.after_snap(false, true),
            Err(PolishOutcome::AboveLimit {
                after: Reached::Completion
            })
        );
        assert_eq!(large.after_snap(false, false), Ok(PolishGoal::Storable));
        let off = policy(10, |o| o.polish = false);
        assert_eq!(off.after_snap(true, true), Err(PolishOutcome::Off));
    }

    #[test]
    fn completion_follows_and_early_patterns() {
        assert!(policy(10, |_| {}).completion_follows_stall());
        assert!(!policy(10, |o| o.completion = Completion::Never).completion_follows_stall());
        assert!(!policy(10, |o| o.guard = Guard::Paper).completion_follows_stall());
        assert_eq!(policy(10, |_| {}).pattern_build(), Build::InBackground);
        assert_eq!(policy(60_000, |_| {}).pattern_build(), Build::Lazily);
        let always = policy(60_000, |o| o.completion = Completion::Always);
        assert_eq!(always.pattern_build(), Build::InBackground);
    }
}
