//! Step 3: the completion phase, which reaches the constraints the spline
//! path stalls on, and the distortion polish.
//!
//! Soft-to-hard symmetric Dirichlet (algorithm.md): from the step-1 layout,
//! minimise `SD(x) + w/2 · Σ |x_c − t_c|²` by projected Newton
//! ([`newton`]), the weight growing ×10 per round (a round ends at its first
//! full Newton step, or when a step converges), triangles the start squeezed
//! past [`PROGRESSIVE_CAP`] measured against progressive reference shapes
//! ([`energy::progressive_rest`]); after every step, if
//! putting the constrained vertices exactly on their targets keeps every
//! triangle positive (as stored), snap them there. Then polish: minimise SD
//! with the constraints and the boundary held. Every layout this phase
//! accepts is fold-free, virtual hole triangles included.
//!
//! [`CompletionState`] advances one Newton step per call, so the ECS can run
//! it tick by tick.

pub mod energy;
pub mod newton;
pub mod obstruction;

use crate::guard;
use crate::options::SolverOptions;
use crate::param::bar_net::FilledChart;
use crate::rbf::stepping::StepProblem;
use crate::sparse::SparseError;
use energy::{RestTriangle, rest_shapes};
use glam::DVec2;
use newton::{NewtonPattern, NewtonSystem, SoftTargets};
use serde::Serialize;
use std::f64::consts::FRAC_1_SQRT_2;
use std::sync::Arc;

/// Weight of virtual hole triangles in the energy, relative to their area:
/// enough for the barrier (holes never fold), too little to resist reshaping.
pub const VIRTUAL_WEIGHT: f64 = 0.01;

/// A soft round ends when a Newton step gains less than this (relative):
/// rounds are continuation steps toward the hard constraints, not solves.
const ROUND_TOLERANCE: f64 = 1e-2;

/// The polish stops when a Newton step gains less than this (relative).
const POLISH_TOLERANCE: f64 = 1e-3;

/// The repair goes on while a Newton step still lowers the energy by this
/// much (relative).
const REPAIR_GAIN: f64 = 0.05;

/// Newton steps at most while repairing a layout that f32 cannot store yet.
pub const REPAIR_STEPS: u32 = 2000;

/// In the soft rounds, no triangle's energy counts for more than this (ψ
/// per unit area, 4 = isometry): one squeezed harder against its rest shape
/// is measured against a progressive reference instead
/// ([`energy::progressive_rest`]). Measured on the 26k-vertex face.glb,
/// whose step-1 layout has triangles at ψ up to ~1e5, with three 4 rad
/// swirls that stall the spline path: 44, 36 and 38 soft Newton steps
/// against 85, 66 and 40 with rest shapes alone (caps of 40, 100 and 400
/// took fewer but left the snap more squeezed: worse stretch, or more
/// polish). Small disks have no triangle above it.
pub const PROGRESSIVE_CAP: f64 = 1000.0;

/// Where the completion stands.
#[derive(Debug, Clone, PartialEq)]
pub enum CompletionPhase {
    /// Spreading a start layout too squeezed to store as f32 (SD alone,
    /// constraints free) before the soft rounds begin.
    Repair {
        steps: u32,
    },
    /// Soft constraints with weight `weight`, round `round`.
    Soft {
        round: u32,
        weight: f64,
        steps_in_round: u32,
    },
    /// Targets reached; lowering distortion with them held.
    Polish {
        steps: u32,
    },
    Done,
}

/// What the completion and polish did (for the report and `--explain`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CompletionStats {
    /// The soft-to-hard phase ran.
    pub soft: bool,
    pub rounds: u32,
    pub newton_steps: u32,
    /// Constrained vertices were put exactly on their targets.
    pub snapped: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snapped_at_round: Option<u32>,
    /// The polish ran.
    pub polish: bool,
    /// The polish ran (or went on) to spread triangles too small to store as f32.
    pub repair: bool,
    pub polish_steps: u32,
    /// Steps spent spreading a start too squeezed for f32, before the soft rounds.
    pub repair_steps: u32,
    /// Polish steps spent on the same repair (not counted against `polish_iterations`).
    pub polish_repair_steps: u32,
    /// Symmetric Dirichlet energy (area-weighted mean, 4 = isometry) at the start and end.
    pub energy_start: f64,
    pub energy_end: f64,
    /// The same energy right after the snap onto the targets (before any polish).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub energy_snapped: Option<f64>,
    /// The largest energy of one real triangle (ψ, 4 = isometry) at the
    /// start of the soft rounds, and right after the snap.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_start: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_snapped: Option<f64>,
    /// The most triangles any soft step measured against a progressive
    /// reference shape instead of their rest shape ([`PROGRESSIVE_CAP`]).
    pub capped_triangles: usize,
    /// The time budget cut the phase short.
    pub out_of_time: bool,
    /// The targets were reached moving along arcs.
    pub arc_retry: bool,
    /// Some constraints' straight paths cross, so arcs were tried first.
    pub paths_cross: bool,
    /// The targets are provably unreachable ([`obstruction`]): one straight
    /// attempt for the closest layout, no retries along arcs.
    pub proven_unreachable: bool,
    /// The certificate behind `proven_unreachable`, found when the soft
    /// rounds started (the report names it without searching again).
    #[serde(skip)]
    pub obstruction: Option<obstruction::Obstruction>,
}

/// Whether the polish follows the soft rounds' snap onto the targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PolishAfterSnap {
    /// Only to repair a layout f32 cannot store yet.
    Off,
    Always,
    /// Only if the snapped layout is more distorted than the start (higher
    /// symmetric Dirichlet energy in all, or in its worst triangle): large
    /// charts, where the polish is not cheap, are still not left squeezed
    /// against the barrier by the snap.
    IfMoreDistorted,
}

/// The completion and polish of one chart.
#[derive(Debug, Clone)]
pub struct CompletionState {
    pub phase: CompletionPhase,
    pub stats: CompletionStats,
    rest: Vec<RestTriangle>,
    /// The soft rounds' reference shapes, remade before each step
    /// (`rest`, with [`PROGRESSIVE_CAP`] applied).
    reference: Vec<RestTriangle>,
    /// Newton system over the movable vertices (constraints included).
    system: Option<NewtonSystem>,
    /// The constrained vertices: held where they are while polishing.
    constrained: Vec<bool>,
    /// Polish for distortion (else only to repair an unstorable layout);
    /// after soft rounds, decided at the snap by `polish_after_snap`.
    polish_enabled: bool,
    polish_after_snap: PolishAfterSnap,
    /// The layout the soft rounds started from (each attempt starts there).
    soft_start: Option<Vec<DVec2>>,
    /// Per constraint, where it starts and its target.
    paths: Vec<(DVec2, DVec2)>,
    /// The attempts in order: targets straight on (0), or moving along arcs
    /// bulging right (+1) or left (−1) of the direction of travel.
    attempts: Vec<f64>,
    attempt: usize,
    /// Largest residual at the end of the last round, and how many rounds
    /// in a row have not lowered it.
    last_round_residual: f64,
    stalled_rounds: u32,
    /// The attempt that came closest: its largest residual and layout.
    best: Option<(f64, Vec<DVec2>)>,
    /// Whether the current layout keeps every triangle positive as stored
    /// (f32). Once true it stays true (every accepted step keeps it), so it
    /// is carried rather than recounted each step.
    storable: bool,
}

/// Rounds in a row whose end leaves the largest residual where it was (to
/// within 1 %) before an attempt counts as stuck.
const STALLED_ROUNDS: u32 = 3;

/// Rounds over which the retry's targets travel along their arcs.
const ARC_ROUNDS: u32 = 4;

/// How far an arc bulges sideways at its middle, relative to its length.
const ARC_BULGE: f64 = 0.5;

/// A point `s ∈ [0, 1]` of the way along the arc from `start` to `target`,
/// bulging to the right of the direction of travel: two constraints asked to
/// swap places head-on pass each other on opposite sides (the paper's
/// "polyline path" for its Fig. 8).
fn arc_point(start: DVec2, target: DVec2, s: f64, side: f64) -> DVec2 {
    let d = target - start;
    let right = DVec2::new(d.y, -d.x) * side;
    (start + d * s + right * (ARC_BULGE * 4.0 * s * (1.0 - s))).clamp(DVec2::splat(1e-3), DVec2::splat(1.0 - 1e-3))
}

impl CompletionState {
    /// Nothing to do.
    pub fn done() -> Self {
        CompletionState {
            phase: CompletionPhase::Done,
            stats: CompletionStats::default(),
            rest: Vec::new(),
            reference: Vec::new(),
            system: None,
            constrained: Vec::new(),
            polish_enabled: false,
            polish_after_snap: PolishAfterSnap::Off,
            soft_start: None,
            paths: Vec::new(),
            attempts: Vec::new(),
            attempt: 0,
            last_round_residual: f64::INFINITY,
            stalled_rounds: 0,
            best: None,
            storable: false,
        }
    }

    /// Soft-to-hard completion (then polish, as `polish` says, or if the
    /// layout cannot be stored as f32 yet), from `layout`, with the Newton
    /// pattern of [`newton_pattern`].
    pub fn soft(
        filled: &FilledChart,
        problem: &StepProblem,
        pattern: Arc<NewtonPattern>,
        layout: &[DVec2],
        options: &SolverOptions,
        polish: PolishAfterSnap,
    ) -> Self {
        let mut s = Self::with_system(filled, problem, pattern);
        s.polish_after_snap = polish;
        s.storable = guard::all_positive_as_stored(layout, &filled.mesh.triangles);
        s.phase = if s.storable {
            CompletionPhase::Soft {
                round: 0,
                weight: options.initial_weight,
                steps_in_round: 0,
            }
        } else {
            s.stats.repair = true;
            CompletionPhase::Repair { steps: 0 }
        };
        s.stats.soft = true;
        s.stats.obstruction = find_obstruction(filled, layout, problem);
        s.stats.proven_unreachable = s.stats.obstruction.is_some();
        s.stats.energy_start = newton::energy(layout, &s.rest, &filled.mesh.triangles, None);
        s.stats.energy_end = s.stats.energy_start;
        s.stats.worst_start = Some(worst_psi(
            layout,
            &s.rest,
            &filled.mesh.triangles[..filled.n_real_triangles],
        ));
        s
    }

    /// Polish only (the targets are already reached), from `layout`; with
    /// `polish` false it only repairs a layout f32 cannot store yet.
    pub fn polish(
        filled: &FilledChart,
        problem: &StepProblem,
        pattern: Arc<NewtonPattern>,
        layout: &[DVec2],
        polish: bool,
    ) -> Self {
        let mut s = Self::with_system(filled, problem, pattern);
        s.polish_enabled = polish;
        s.phase = CompletionPhase::Polish { steps: 0 };
        s.stats.polish = polish;
        s.storable = guard::all_positive_as_stored(layout, &filled.mesh.triangles);
        s.stats.repair = !s.storable;
        s.stats.energy_start = newton::energy(layout, &s.rest, &filled.mesh.triangles, None);
        s.stats.energy_end = s.stats.energy_start;
        s
    }

    fn with_system(filled: &FilledChart, problem: &StepProblem, pattern: Arc<NewtonPattern>) -> Self {
        let n = filled.mesh.n_vertices();
        let rest = rest_shapes(
            &filled.mesh.positions,
            &filled.mesh.triangles,
            filled.n_real_triangles,
            VIRTUAL_WEIGHT,
        );
        debug_assert!(
            pattern.has_free_set(&problem.movable),
            "a Newton pattern for another free set"
        );
        let system = Some(NewtonSystem::new(pattern));
        let mut constrained = vec![false; n];
        problem
            .constraint_vertices
            .iter()
            .for_each(|&v| constrained[v as usize] = true);
        CompletionState {
            rest,
            system,
            constrained,
            ..Self::done()
        }
    }

    /// After `layout` changed: a layout that was storable still is (every
    /// accepted step and snap keeps it so); one that was not is recounted.
    fn note_step(&mut self, layout: &[DVec2], triangles: &[[u32; 3]]) {
        if !self.storable {
            self.storable = guard::all_positive_as_stored(layout, triangles);
        }
    }

    pub fn is_done(&self) -> bool {
        self.phase == CompletionPhase::Done
    }

    /// Stops where it is (time budget); the layout stays the last accepted one.
    pub fn stop_out_of_time(&mut self) {
        if !self.is_done() {
            self.stats.out_of_time = true;
            self.phase = CompletionPhase::Done;
        }
    }

    /// One Newton step (soft or polish) on `layout`, which stays fold-free.
    pub fn advance(
        &mut self,
        layout: &mut [DVec2],
        filled: &FilledChart,
        problem: &StepProblem,
        options: &SolverOptions,
    ) {
        let triangles = &filled.mesh.triangles;
        match self.phase.clone() {
            CompletionPhase::Done => {}
            CompletionPhase::Repair { steps } => {
                let system = self.system.as_ref().expect("Newton system");
                let step = system.step(
                    layout,
                    &self.rest,
                    triangles,
                    None,
                    None,
                    POLISH_TOLERANCE,
                    self.storable,
                );
                self.note_step(layout, triangles);
                self.stats.repair_steps += 1;
                let stuck = step.alpha == 0.0 || steps + 1 >= REPAIR_STEPS;
                // Spread on until the distortion has settled too: soft rounds
                // from a layout that is merely storable crawl (tiny safe steps).
                let settled = step.converged || step.energy_after > (1.0 - REPAIR_GAIN) * step.energy_before;
                self.phase = if (settled && self.storable) || stuck {
                    CompletionPhase::Soft {
                        round: 0,
                        weight: options.initial_weight,
                        steps_in_round: 0,
                    }
                } else {
                    CompletionPhase::Repair { steps: steps + 1 }
                };
            }
            CompletionPhase::Soft {
                round,
                weight,
                steps_in_round,
            } => {
                if self.soft_start.is_none() {
                    self.paths = problem
                        .constraint_vertices
                        .iter()
                        .zip(&problem.targets)
                        .map(|(&v, &t)| (layout[v as usize], t))
                        .collect();
                    // Constraints whose straight paths cross meet head-on
                    // against the barrier: arcs first, then straight.
                    self.stats.paths_cross = paths_cross(&self.paths);
                    self.attempts = if self.stats.paths_cross {
                        vec![1.0, -1.0, 0.0]
                    } else {
                        vec![0.0, 1.0, -1.0]
                    };
                    // No path reaches proven-unreachable targets: one straight
                    // pull, the closest on average (measured on 120 proven
                    // cases: mean residual 0.12 vs 0.13 for the best of all
                    // three attempts, in a third of the time).
                    if self.stats.proven_unreachable {
                        self.attempts = vec![0.0];
                    }
                    self.soft_start = Some(layout.to_vec());
                }
                let capped =
                    energy::progressive_rest(&self.rest, layout, triangles, PROGRESSIVE_CAP, &mut self.reference);
                self.stats.capped_triangles = self.stats.capped_triangles.max(capped);
                let system = self.system.as_ref().expect("Newton system");
                // Scale the pull with the distortion energy (4 = isometry): a
                // badly squeezed start has energy ~1e20 and must not drown it.
                // (`energy_end` is the current layout's, kept after every step.)
                let scale = (self.stats.energy_end / 4.0).max(1.0);
                let side = self.attempts[self.attempt];
                let s = ((round + 1) as f64 / ARC_ROUNDS as f64).min(1.0);
                let arc_targets: Option<Vec<DVec2>> = (side != 0.0 && s < 1.0)
                    .then(|| self.paths.iter().map(|&(a, t)| arc_point(a, t, s, side)).collect());
                let soft = SoftTargets {
                    vertices: &problem.constraint_vertices,
                    targets: arc_targets.as_deref().unwrap_or(&problem.targets),
                    weight: weight * scale,
                };
                let step = system.step(
                    layout,
                    &self.reference,
                    triangles,
                    Some(soft),
                    None,
                    ROUND_TOLERANCE,
                    self.storable,
                );
                self.note_step(layout, triangles);
                self.stats.newton_steps += 1;
                self.stats.rounds = round + 1;
                if try_snap(layout, problem, triangles, self.storable) {
                    self.stats.snapped = true;
                    self.stats.arc_retry = side != 0.0;
                    self.stats.snapped_at_round = Some(round);
                    self.note_step(layout, triangles);
                    let snapped_energy = newton::energy(layout, &self.rest, triangles, None);
                    self.stats.energy_snapped = Some(snapped_energy);
                    let worst = worst_psi(layout, &self.rest, &triangles[..filled.n_real_triangles]);
                    self.stats.worst_snapped = Some(worst);
                    let worse = snapped_energy > self.stats.energy_start
                        || self.stats.worst_start.is_some_and(|start| worst > start);
                    self.polish_enabled = match self.polish_after_snap {
                        PolishAfterSnap::Off => false,
                        PolishAfterSnap::Always => true,
                        PolishAfterSnap::IfMoreDistorted => worse,
                    };
                    let storable = self.storable;
                    self.stats.repair |= !storable;
                    self.phase = if self.polish_enabled || !storable {
                        self.stats.polish |= self.polish_enabled;
                        CompletionPhase::Polish { steps: 0 }
                    } else {
                        CompletionPhase::Done
                    };
                } else if step.converged || step.alpha >= 1.0 || steps_in_round + 1 >= options.newton_iterations {
                    // A round ends: its step converged, or was a full Newton
                    // step (the barrier did not cut it short, so the layout is
                    // near this weight's minimum: more steps here gain less
                    // than moving on). Once the targets have arrived (arcs
                    // travelled), rounds that no longer bring the constraints
                    // closer mean this attempt is stuck against the barrier.
                    let residual = max_residual(layout, problem);
                    let arrived = side == 0.0 || round + 1 >= ARC_ROUNDS;
                    self.stalled_rounds = if arrived && residual > 0.99 * self.last_round_residual {
                        self.stalled_rounds + 1
                    } else {
                        0
                    };
                    self.last_round_residual = residual;
                    self.phase = if round + 1 >= options.completion_rounds || self.stalled_rounds >= STALLED_ROUNDS {
                        if self.best.as_ref().is_none_or(|(r, _)| residual < *r) {
                            self.best = Some((residual, layout.to_vec()));
                        }
                        self.last_round_residual = f64::INFINITY;
                        self.stalled_rounds = 0;
                        // The next attempt, from the same start; after the
                        // last, the closest layout any attempt reached.
                        match &self.soft_start {
                            Some(start) if self.attempt + 1 < self.attempts.len() => {
                                layout.copy_from_slice(start);
                                self.storable = guard::all_positive_as_stored(layout, triangles);
                                self.attempt += 1;
                                CompletionPhase::Soft {
                                    round: 0,
                                    weight: options.initial_weight,
                                    steps_in_round: 0,
                                }
                            }
                            _ => {
                                if let Some((_, best)) = self.best.take() {
                                    layout.copy_from_slice(&best);
                                    self.storable = guard::all_positive_as_stored(layout, triangles);
                                }
                                CompletionPhase::Done
                            }
                        }
                    } else {
                        CompletionPhase::Soft {
                            round: round + 1,
                            weight: weight * options.weight_growth,
                            steps_in_round: 0,
                        }
                    };
                } else {
                    self.phase = CompletionPhase::Soft {
                        round,
                        weight,
                        steps_in_round: steps_in_round + 1,
                    };
                }
            }
            CompletionPhase::Polish { steps } => {
                let system = self.system.as_ref().expect("Newton system");
                let repairing = !self.storable;
                let step = system.step(
                    layout,
                    &self.rest,
                    triangles,
                    None,
                    Some(&self.constrained),
                    POLISH_TOLERANCE,
                    self.storable,
                );
                self.note_step(layout, triangles);
                self.stats.polish_steps = steps + 1;
                if repairing {
                    self.stats.polish_repair_steps += 1;
                }
                let relative_gain = (step.energy_before - step.energy_after) / step.energy_before.max(1e-300);
                let finished = !self.polish_enabled
                    || step.converged
                    || relative_gain < POLISH_TOLERANCE
                    || steps + 1 - self.stats.polish_repair_steps >= options.polish_iterations;
                let storable = self.storable;
                let stuck = step.alpha == 0.0 || steps + 1 >= REPAIR_STEPS;
                self.phase = if (finished && storable) || stuck {
                    CompletionPhase::Done
                } else {
                    CompletionPhase::Polish { steps: steps + 1 }
                };
            }
        }
        if !self.rest.is_empty() {
            self.stats.energy_end = newton::energy(layout, &self.rest, triangles, None);
        }
    }
}

/// The Newton pattern over `problem`'s movable vertices (everything but the
/// outer boundary): the completion's and polish's sparsity pattern and
/// symbolic factorisation, which one chart's solves can share. `order`: the
/// movable vertices in an elimination order of the same graph (step 1's, see
/// [`crate::param::bar_net::BarNet::elimination_order`]), if known.
///
/// # Errors
/// A sparsity pattern faer rejects (never for a valid mesh).
pub fn newton_pattern(
    filled: &FilledChart,
    movable: &[u32],
    order: Option<&[u32]>,
) -> Result<NewtonPattern, SparseError> {
    let mut free = vec![false; filled.mesh.n_vertices()];
    movable.iter().for_each(|&v| free[v as usize] = true);
    NewtonPattern::new(&filled.mesh.triangles, &free, order)
}

/// The largest energy of one of `triangles` (ψ per unit area, 4 = isometry;
/// +∞ if one is folded).
fn worst_psi(layout: &[DVec2], rest: &[RestTriangle], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .zip(rest)
        .map(|(t, r)| energy::psi(energy::jacobian(r, t.map(|v| layout[v as usize]))))
        .fold(0.0, f64::max)
}

/// The largest distance from a constrained vertex to its target.
fn max_residual(layout: &[DVec2], problem: &StepProblem) -> f64 {
    problem
        .constraint_vertices
        .iter()
        .zip(&problem.targets)
        .map(|(&v, &t)| layout[v as usize].distance(t))
        .fold(0.0, f64::max)
}

/// Whether any two constraints' straight paths (start → target) meet
/// head-on: they cross, or run into each other along one line (a swap),
/// travelling in directions more than 135° apart. (Paths that cross at an
/// angle, as in a swirl, pass each other at different times.)
fn paths_cross(paths: &[(DVec2, DVec2)]) -> bool {
    let side = |a: DVec2, b: DVec2, p: DVec2| {
        let v = (b - a).perp_dot(p - a);
        if v.abs() <= 1e-12 * (b - a).length_squared().max((p - a).length_squared()) {
            0.0
        } else {
            v.signum()
        }
    };
    let meet = |(a, b): (DVec2, DVec2), (c, d): (DVec2, DVec2)| {
        let (s1, s2, s3, s4) = (side(a, b, c), side(a, b, d), side(c, d, a), side(c, d, b));
        // Only paths that meet head-on (directions more than 135° apart).
        if (b - a).dot(d - c) > -FRAC_1_SQRT_2 * (b - a).length() * (d - c).length() {
            return false;
        }
        if s1 == 0.0 && s2 == 0.0 {
            // Collinear: do they overlap along the line?
            let axis = (b - a).normalize_or_zero();
            let (lo1, hi1) = (0.0f64, (b - a).dot(axis));
            let (t1, t2) = ((c - a).dot(axis), (d - a).dot(axis));
            return axis != DVec2::ZERO && t1.max(t2) > lo1.min(hi1) && t1.min(t2) < lo1.max(hi1);
        }
        s1 * s2 < 0.0 && s3 * s4 < 0.0
    };
    paths
        .iter()
        .enumerate()
        .any(|(i, &p)| paths[i + 1..].iter().any(|&q| meet(p, q)))
}

/// Puts every constrained vertex exactly on its target if that keeps every
/// triangle positive (as stored, when `storable`: `layout` is); returns
/// whether it did.
pub fn try_snap(layout: &mut [DVec2], problem: &StepProblem, triangles: &[[u32; 3]], storable: bool) -> bool {
    let mut candidate = layout.to_vec();
    for (&v, &t) in problem.constraint_vertices.iter().zip(&problem.targets) {
        candidate[v as usize] = t;
    }
    if guard::acceptable(&candidate, triangles, storable) {
        layout.copy_from_slice(&candidate);
        true
    } else {
        false
    }
}

/// A certificate that no fold-free layout of this chart puts every
/// constraint of `problem` on its target ([`obstruction`]): the outer
/// boundary pinned where `layout` has it, each constraint at its target.
pub fn find_obstruction(
    filled: &FilledChart,
    layout: &[DVec2],
    problem: &StepProblem,
) -> Option<obstruction::Obstruction> {
    let n = filled.mesh.n_vertices();
    let mut pins: Vec<Option<DVec2>> = layout.iter().map(|&p| Some(p)).collect();
    problem.movable.iter().for_each(|&v| pins[v as usize] = None);
    let mut is_constraint = vec![false; n];
    for (&v, &t) in problem.constraint_vertices.iter().zip(&problem.targets) {
        pins[v as usize] = Some(t);
        is_constraint[v as usize] = true;
    }
    obstruction::find_obstruction(
        &filled.mesh.triangles,
        &filled.edges,
        &pins,
        &is_constraint,
        filled.n_real_vertices,
    )
}

/// One line on why constraints stay short when the targets are provably
/// unreachable: which constraints the certificate involves and what would
/// have to happen (`name` says who a vertex is).
pub fn obstruction_hint(
    certificate: &obstruction::Obstruction,
    constraint_of: impl Fn(u32) -> Option<usize>,
    name: impl Fn(u32) -> String,
) -> String {
    let mut involved: Vec<usize> = certificate.vertices().into_iter().filter_map(&constraint_of).collect();
    involved.sort_unstable();
    involved.dedup();
    let names: Vec<String> = involved.iter().map(|i| format!("constraints[{i}]")).collect();
    format!(
        "{} cannot reach their targets on this mesh: with them there, {}, so no fold-free layout has them all in place \
         (move a target, or refine the mesh there)",
        names.join(", "),
        certificate.describe(name)
    )
}

/// One line on why constraints stay short: which ones, and where the mesh
/// is squeezed hardest (the triangles that would have to fold or vanish).
pub fn partial_hint(
    filled: &FilledChart,
    layout: &[DVec2],
    problem: &StepProblem,
    unreached: &[(usize, u32)],
) -> String {
    if unreached.is_empty() {
        return String::new();
    }
    let rest = rest_shapes(
        &filled.mesh.positions,
        &filled.mesh.triangles,
        filled.n_real_triangles,
        1.0,
    );
    // Most compressed real triangle: smallest layout area relative to its rest area.
    let (worst, ratio) = filled.mesh.triangles[..filled.n_real_triangles]
        .iter()
        .zip(&rest)
        .enumerate()
        .map(|(i, (t, r))| {
            let [a, b, c] = t.map(|v| layout[v as usize]);
            (i, 0.5 * (b - a).perp_dot(c - a) / r.weight.max(1e-300))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, 1.0));
    let centre = filled.mesh.triangles[worst]
        .map(|v| layout[v as usize])
        .iter()
        .copied()
        .sum::<DVec2>()
        / 3.0;
    let names: Vec<String> = unreached.iter().map(|(i, _)| format!("constraints[{i}]")).collect();
    // The unreached constraint nearest to the squeeze.
    let nearest = unreached
        .iter()
        .filter_map(|&(i, v)| {
            problem
                .constraint_vertices
                .iter()
                .position(|&c| c == v)
                .map(|k| (i, layout[problem.constraint_vertices[k] as usize].distance(centre)))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1));
    format!(
        "{} cannot reach their targets without folding: the mesh is squeezed to {:.1e} of its area around triangle {worst}{} — \
         the targets conflict (they ask for crossing or mirrored positions) or the mesh is too coarse between them there",
        names.join(", "),
        ratio.max(0.0),
        nearest
            .map(|(i, _)| format!(", next to constraints[{i}]"))
            .unwrap_or_default()
    )
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
}
