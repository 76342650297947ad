//! The completion's attempts: from the same start, the targets pulled
//! straight on, or moving along arcs that bulge to the right or to the left
//! of their direction of travel (the paper's "polyline path"), so that
//! constraints asked to swap places pass each other. Each attempt's rounds
//! are watched for stalling; the closest attempt is kept.

use crate::rbf::stepping::StepProblem;
use glam::DVec2;
use std::f64::consts::FRAC_1_SQRT_2;

/// Rounds in a row whose end leaves the largest residual where it was (to
/// within 1 %) before an attempt counts as stuck.
const STALLED_ROUNDS: u32 = 3;

/// Rounds over which an arc attempt's targets travel along their arcs.
pub const ARC_ROUNDS: u32 = 4;

/// How far an arc bulges sideways at its middle, relative to its length.
const ARC_BULGE: f64 = 0.5;

/// How the targets travel in one attempt.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TargetPath {
    Straight,
    /// Along arcs bulging right (`side` = 1) or left (−1) of the direction of travel.
    Arc {
        side: f64,
    },
}

/// How many of a completion's paths it may try.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PathBudget {
    /// Every path in its order (straight and both arcs).
    #[default]
    Every,
    /// The first path only: the caller has a cheaper remedy to try before
    /// the others (a disk cut open only for its short boundary, solved
    /// uncut), and comes back for them if that does no better.
    First,
}

/// What the end of a round means for the attempt.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoundEnd {
    /// Go on with the next round.
    Continue,
    /// This attempt is over (out of rounds, or stuck).
    AttemptOver,
}

/// The attempts of one completion and what they reached.
#[derive(Debug, Clone)]
pub struct Attempts {
    /// The layout every attempt starts from.
    start: Vec<DVec2>,
    /// Per constraint, where it starts and its target.
    paths: Vec<(DVec2, DVec2)>,
    order: Vec<TargetPath>,
    /// Paths left out by a [`PathBudget::First`].
    skipped: usize,
    current: usize,
    /// Largest residual at the end of the last round, and how many rounds
    /// in a row have not lowered it.
    last_round_residual: f64,
    stalled_rounds: u32,
    /// The closest layout any finished attempt reached, and its largest residual.
    best: Option<(f64, Vec<DVec2>)>,
    /// The closest layout any round ended on without being distorted past
    /// [`SANE_PSI`] on average, and its largest residual.
    best_sane: Option<(f64, Vec<DVec2>)>,
    /// The least distorted layout a round ended on, and its mean ψ.
    least_distorted: Option<(f64, Vec<DVec2>)>,
}

/// A layout whose triangles score at most this on average (ψ per unit
/// area; 4 = isometry, ~27 for a fivefold stretch) is usable when the
/// targets cannot be reached: the kept layout is the closest such one, not
/// the closest one, which the growing pull may have squeezed to nothing.
pub const SANE_PSI: f64 = 50.0;

impl Attempts {
    /// The attempts from `start`: arcs first when two constraints' straight
    /// paths meet head-on (they would collide against the barrier), else
    /// straight first; a single straight pull when the targets are proven
    /// unreachable (no path reaches them; the straight pull lands closest).
    /// `budget` may keep only the first.
    pub fn begin(start: &[DVec2], problem: &StepProblem, proven_unreachable: bool, budget: PathBudget) -> Self {
        let paths: Vec<(DVec2, DVec2)> = problem
            .constraint_vertices
            .iter()
            .zip(&problem.targets)
            .map(|(&v, &t)| (start[v as usize], t))
            .collect();
        let (right, left) = (TargetPath::Arc { side: 1.0 }, TargetPath::Arc { side: -1.0 });
        let mut order = if proven_unreachable {
            vec![TargetPath::Straight]
        } else if paths_cross(&paths) {
            vec![right, left, TargetPath::Straight]
        } else {
            vec![TargetPath::Straight, right, left]
        };
        let skipped = match budget {
            PathBudget::Every => 0,
            PathBudget::First => order.drain(1..).count(),
        };
        Attempts {
            start: start.to_vec(),
            paths,
            order,
            skipped,
            current: 0,
            last_round_residual: f64::INFINITY,
            stalled_rounds: 0,
            best: None,
            best_sane: None,
            least_distorted: None,
        }
    }

    /// Records a round's end at `layout`: largest residual `residual`, mean
    /// ψ (energy per unit rest area) `mean_psi`.
    pub fn consider(&mut self, layout: &[DVec2], residual: f64, mean_psi: f64) {
        if mean_psi <= SANE_PSI && self.best_sane.as_ref().is_none_or(|(r, _)| residual < *r) {
            self.best_sane = Some((residual, layout.to_vec()));
        }
        if self.least_distorted.as_ref().is_none_or(|(e, _)| mean_psi < *e) {
            self.least_distorted = Some((mean_psi, layout.to_vec()));
        }
    }

    /// Whether two constraints' straight paths meet head-on.
    pub fn paths_cross(&self) -> bool {
        paths_cross(&self.paths)
    }

    /// How many paths the budget left out.
    pub fn skipped(&self) -> usize {
        self.skipped
    }

    pub fn path(&self) -> TargetPath {
        self.order[self.current]
    }

    /// Where the targets are in round `round` of the current attempt:
    /// `None` when they are at their final places.
    pub fn moving_targets(&self, round: u32) -> Option<Vec<DVec2>> {
        let TargetPath::Arc { side } = self.path() else {
            return None;
        };
        let s = ((round + 1) as f64 / ARC_ROUNDS as f64).min(1.0);
        (s < 1.0).then(|| self.paths.iter().map(|&(a, t)| arc_point(a, t, s, side)).collect())
    }

    /// Records the end of round `round` with largest residual `residual`;
    /// `last_round` says the round budget is spent. Once the targets have
    /// arrived (arcs travelled), rounds that no longer bring the constraints
    /// closer mean the attempt is stuck against the barrier.
    pub fn end_round(&mut self, round: u32, residual: f64, last_round: bool) -> RoundEnd {
        let arrived = self.path() == TargetPath::Straight || round + 1 >= ARC_ROUNDS;
        self.stalled_rounds = if arrived && residual > 0.99 * self.last_round_residual {
            self.stalled_rounds + 1
        } else {
            0
        };
        self.last_round_residual = residual;
        if last_round || self.stalled_rounds >= STALLED_ROUNDS {
            RoundEnd::AttemptOver
        } else {
            RoundEnd::Continue
        }
    }

    /// Ends the current attempt at `layout` (largest residual `residual`) and
    /// moves on: the next attempt's start is copied into `layout` (`true`),
    /// or, after the last, the closest sane layout any round ended on (the
    /// least distorted one if none was sane) (`false`).
    pub fn next_attempt(&mut self, layout: &mut [DVec2], residual: f64) -> bool {
        if self.best.as_ref().is_none_or(|(r, _)| residual < *r) {
            self.best = Some((residual, layout.to_vec()));
        }
        self.last_round_residual = f64::INFINITY;
        self.stalled_rounds = 0;
        if self.current + 1 < self.order.len() {
            layout.copy_from_slice(&self.start);
            self.current += 1;
            return true;
        }
        let kept = match (self.best_sane.take(), self.least_distorted.take(), self.best.take()) {
            (Some((_, sane)), _, _) => Some(sane),
            (None, Some((_, least)), _) => Some(least),
            (None, None, best) => best.map(|(_, b)| b),
        };
        if let Some(kept) = kept {
            layout.copy_from_slice(&kept);
        }
        false
    }
}

/// A point `s ∈ [0, 1]` of the way along the arc from `start` to `target`,
/// bulging to the right of the direction of travel (`side` = 1) or to the
/// left (−1): two constraints asked to swap places head-on pass each other
/// on opposite sides (the paper's "polyline path" for its Fig. 8).
fn arc_point(start: DVec2, target: DVec2, s: f64, side: f64) -> DVec2 {
    let d = target - start;
    let right = DVec2::new(d.y, -d.x) * side;
    (start + d * s + right * (ARC_BULGE * 4.0 * s * (1.0 - s))).clamp(DVec2::splat(1e-3), DVec2::splat(1.0 - 1e-3))
}

/// Which side of the line `a → b` the point `p` is on (0 when on it, to
/// within rounding).
fn side(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    let v = (b - a).perp_dot(p - a);
    if v.abs() <= 1e-12 * (b - a).length_squared().max((p - a).length_squared()) {
        0.0
    } else {
        v.signum()
    }
}

/// Whether two straight paths meet head-on: they cross, or run into each
/// other along one line (a swap), travelling in directions more than 135°
/// apart. (Paths that cross at an angle, as in a swirl, pass each other at
/// different times.)
fn meet_head_on((a, b): (DVec2, DVec2), (c, d): (DVec2, DVec2)) -> bool {
    if (b - a).dot(d - c) > -FRAC_1_SQRT_2 * (b - a).length() * (d - c).length() {
        return false;
    }
    let (s1, s2, s3, s4) = (side(a, b, c), side(a, b, d), side(c, d, a), side(c, d, b));
    if s1 == 0.0 && s2 == 0.0 {
        // Collinear: do they overlap along the line?
        let axis = (b - a).normalize_or_zero();
        let (lo1, hi1) = (0.0f64, (b - a).dot(axis));
        let (t1, t2) = ((c - a).dot(axis), (d - a).dot(axis));
        return axis != DVec2::ZERO && t1.max(t2) > lo1.min(hi1) && t1.min(t2) < lo1.max(hi1);
    }
    s1 * s2 < 0.0 && s3 * s4 < 0.0
}

/// Whether any two of `paths` (start → target) meet head-on.
fn paths_cross(paths: &[(DVec2, DVec2)]) -> bool {
    paths
        .iter()
        .enumerate()
        .any(|(i, &p)| paths[i + 1..].iter().any(|&q| meet_head_on(p, q)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_and_head_on_paths_are_found() {
        let p = |a: (f64, f64), b: (f64, f64)| (DVec2::new(a.0, a.1), DVec2::new(b.0, b.1));
        // Head-on swap.
        assert!(paths_cross(&[p((0.2, 0.5), (0.8, 0.5)), p((0.8, 0.5), (0.2, 0.5))]));
        // Crossing head-on, and crossing at a right angle (not head-on).
        assert!(paths_cross(&[p((0.2, 0.2), (0.8, 0.8)), p((0.8, 0.7), (0.2, 0.3))]));
        assert!(!paths_cross(&[p((0.2, 0.2), (0.8, 0.8)), p((0.2, 0.8), (0.8, 0.2))]));
        // Side by side, and one after the other on a line.
        assert!(!paths_cross(&[p((0.2, 0.2), (0.8, 0.2)), p((0.2, 0.3), (0.8, 0.3))]));
        assert!(!paths_cross(&[p((0.1, 0.5), (0.3, 0.5)), p((0.4, 0.5), (0.6, 0.5))]));
    }

    fn problem(targets: &[(f64, f64)]) -> StepProblem {
        StepProblem {
            constraint_vertices: (0..targets.len() as u32).collect(),
            targets: targets.iter().map(|&(x, y)| DVec2::new(x, y)).collect(),
            ..Default::default()
        }
    }

    #[test]
    fn the_order_of_attempts_follows_the_paths() {
        let start = [DVec2::new(0.2, 0.5), DVec2::new(0.8, 0.5)];
        let swap = problem(&[(0.8, 0.5), (0.2, 0.5)]);
        let a = Attempts::begin(&start, &swap, false, PathBudget::Every);
        assert!(a.paths_cross());
        assert_eq!(a.path(), TargetPath::Arc { side: 1.0 });
        let apart = problem(&[(0.2, 0.6), (0.8, 0.6)]);
        assert_eq!(
            Attempts::begin(&start, &apart, false, PathBudget::Every).path(),
            TargetPath::Straight
        );
        let proven = Attempts::begin(&start, &swap, true, PathBudget::Every);
        assert_eq!(proven.order, vec![TargetPath::Straight]);
        // A budget of one keeps the path that would go first, and says what it left.
        let first = Attempts::begin(&start, &swap, false, PathBudget::First);
        assert_eq!(
            (first.order.clone(), first.skipped()),
            (vec![TargetPath::Arc { side: 1.0 }], 2)
        );
        let mut layout = start.to_vec();
        assert!(!Attempts::begin(&start, &apart, false, PathBudget::First).next_attempt(&mut layout, 0.1));
    }

    #[test]
    fn arc_targets_travel_then_arrive() {
        let start = [DVec2::new(0.2, 0.5), DVec2::new(0.8, 0.5)];
        let a = Attempts::begin(&start, &problem(&[(0.8, 0.5), (0.2, 0.5)]), false, PathBudget::Every);
        let first = a.moving_targets(0).expect("on the way");
        // A quarter of the way, bulging right of travel (down, for +x travel).
        assert!(first[0].x > 0.2 && first[0].x < 0.5 && first[0].y < 0.5);
        assert!(first[1].y > 0.5, "the other passes on the other side");
        assert!(a.moving_targets(ARC_ROUNDS - 1).is_none());
    }

    #[test]
    fn stuck_attempts_end_and_the_closest_layout_is_kept() {
        let start = [DVec2::new(0.2, 0.5), DVec2::new(0.8, 0.5)];
        let mut a = Attempts::begin(&start, &problem(&[(0.3, 0.5), (0.7, 0.5)]), false, PathBudget::Every);
        // Straight: three rounds without progress after the first.
        assert_eq!(a.end_round(0, 0.1, false), RoundEnd::Continue);
        for round in 1..3 {
            assert_eq!(a.end_round(round, 0.1, false), RoundEnd::Continue);
        }
        assert_eq!(a.end_round(3, 0.1, false), RoundEnd::AttemptOver);
        let mut layout = vec![DVec2::new(0.25, 0.5), DVec2::new(0.75, 0.5)];
        let closest = layout.clone();
        assert!(a.next_attempt(&mut layout, 0.05));
        assert_eq!(layout, start, "the next attempt starts from the start");
        assert_eq!(a.end_round(0, 0.2, true), RoundEnd::AttemptOver);
        assert!(a.next_attempt(&mut layout, 0.2));
        assert!(!a.next_attempt(&mut layout, 0.3));
        assert_eq!(layout, closest, "after the last attempt, the closest one");
    }
}
