//! Step 3: the completion phase, which reaches the constraints the spline
//! path stalls on, and the distortion polish.
//!
//! Soft-to-hard symmetric Dirichlet (algorithm.md): from the step-1 layout,
//! minimise `SD(x) + w/2 · Σ |x_c − t_c|²` by projected Newton
//! ([`newton`]), the weight growing ×10 per round; after every step, if
//! putting the constrained vertices exactly on their targets keeps every
//! triangle positive (as stored), snap them there. Then polish: minimise SD
//! with the constraints and the boundary held. Every layout this phase
//! accepts is fold-free, virtual hole triangles included.
//!
//! [`CompletionState`] advances one Newton step per call, so the ECS can run
//! it tick by tick.

pub mod energy;
pub mod newton;

use crate::guard;
use crate::options::SolverOptions;
use crate::param::bar_net::FilledChart;
use crate::rbf::stepping::StepProblem;
use crate::sparse::SparseError;
use energy::{RestTriangle, rest_shapes};
use glam::DVec2;
use newton::{NewtonSystem, SoftTargets};
use serde::Serialize;

/// Weight of virtual hole triangles in the energy, relative to their area:
/// enough for the barrier (holes never fold), too little to resist reshaping.
pub const VIRTUAL_WEIGHT: f64 = 0.01;

/// A soft round ends when a Newton step gains less than this (relative):
/// rounds are continuation steps toward the hard constraints, not solves.
const ROUND_TOLERANCE: f64 = 1e-4;

/// The polish stops when a Newton step gains less than this (relative).
const POLISH_TOLERANCE: f64 = 1e-3;

/// Newton steps at most while repairing a layout that f32 cannot store yet.
pub const REPAIR_STEPS: u32 = 2000;

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
    /// The time budget cut the phase short.
    pub out_of_time: bool,
    /// The soft rounds were retried with targets moving along arcs.
    pub arc_retry: bool,
}

/// The completion and polish of one chart.
#[derive(Debug, Clone)]
pub struct CompletionState {
    pub phase: CompletionPhase,
    pub stats: CompletionStats,
    rest: Vec<RestTriangle>,
    soft_system: Option<NewtonSystem>,
    polish_system: Option<NewtonSystem>,
    /// Polish for distortion (else only to repair an unstorable layout).
    polish_enabled: bool,
    /// The layout the soft rounds started from (for the arc-path retry).
    soft_start: Option<Vec<DVec2>>,
    /// Retries: targets move along arcs (start, final target) per constraint,
    /// bulging right (+1) then left (−1) of the direction of travel.
    arcs: Option<(Vec<(DVec2, DVec2)>, f64)>,
}

/// Rounds over which the retry's targets travel along their arcs.
const ARC_ROUNDS: u32 = 6;

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
            soft_system: None,
            polish_system: None,
            polish_enabled: false,
            soft_start: None,
            arcs: None,
        }
    }

    /// Soft-to-hard completion (then polish, if `polish` or if the layout
    /// cannot be stored as f32 yet), from `layout`.
    ///
    /// # Errors
    /// A sparsity pattern faer rejects.
    pub fn soft(
        filled: &FilledChart,
        problem: &StepProblem,
        layout: &[DVec2],
        options: &SolverOptions,
        polish: bool,
    ) -> Result<Self, SparseError> {
        let mut s = Self::with_systems(filled, problem, true)?;
        s.polish_enabled = polish;
        s.phase = if guard::all_positive_as_stored(layout, &filled.mesh.triangles) {
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
        s.stats.energy_start = newton::energy(layout, &s.rest, &filled.mesh.triangles, None);
        Ok(s)
    }

    /// Polish only (the targets are already reached), from `layout`; with
    /// `polish` false it only repairs a layout f32 cannot store yet.
    ///
    /// # Errors
    /// A sparsity pattern faer rejects.
    pub fn polish(
        filled: &FilledChart,
        problem: &StepProblem,
        layout: &[DVec2],
        polish: bool,
    ) -> Result<Self, SparseError> {
        let mut s = Self::with_systems(filled, problem, false)?;
        s.polish_enabled = polish;
        s.phase = CompletionPhase::Polish { steps: 0 };
        s.stats.polish = polish;
        s.stats.repair = !guard::all_positive_as_stored(layout, &filled.mesh.triangles);
        s.stats.energy_start = newton::energy(layout, &s.rest, &filled.mesh.triangles, None);
        s.stats.energy_end = s.stats.energy_start;
        Ok(s)
    }

    fn with_systems(filled: &FilledChart, problem: &StepProblem, soft: bool) -> Result<Self, SparseError> {
        let n = filled.mesh.n_vertices();
        let rest = rest_shapes(
            &filled.mesh.positions,
            &filled.mesh.triangles,
            filled.n_real_triangles,
            VIRTUAL_WEIGHT,
        );
        let mut free = vec![false; n];
        problem.movable.iter().for_each(|&v| free[v as usize] = true);
        let soft_system = if soft {
            Some(NewtonSystem::new(&filled.mesh.triangles, &free)?)
        } else {
            None
        };
        // Always built: a snapped layout f32 cannot store yet needs the repair.
        problem
            .constraint_vertices
            .iter()
            .for_each(|&v| free[v as usize] = false);
        let polish_system = Some(NewtonSystem::new(&filled.mesh.triangles, &free)?);
        Ok(CompletionState {
            phase: CompletionPhase::Done,
            stats: CompletionStats::default(),
            rest,
            soft_system,
            polish_system,
            polish_enabled: false,
            soft_start: None,
            arcs: None,
        })
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
                let system = self.soft_system.as_ref().expect("soft system");
                let step = system.step(layout, &self.rest, triangles, None, POLISH_TOLERANCE);
                self.stats.repair_steps += 1;
                let stuck = step.alpha == 0.0 || steps + 1 >= REPAIR_STEPS;
                self.phase = if guard::all_positive_as_stored(layout, triangles) || stuck {
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
                    self.soft_start = Some(layout.to_vec());
                }
                let system = self.soft_system.as_ref().expect("soft system");
                // Scale the pull with the distortion energy (4 = isometry): a
                // badly squeezed start has energy ~1e20 and must not drown it.
                let scale = (newton::energy(layout, &self.rest, triangles, None) / 4.0).max(1.0);
                let arc_targets: Option<Vec<DVec2>> = self.arcs.as_ref().map(|(arcs, side)| {
                    let s = ((round + 1) as f64 / ARC_ROUNDS as f64).min(1.0);
                    arcs.iter()
                        .map(|&(a, t)| if s >= 1.0 { t } else { arc_point(a, t, s, *side) })
                        .collect()
                });
                let soft = SoftTargets {
                    vertices: &problem.constraint_vertices,
                    targets: arc_targets.as_deref().unwrap_or(&problem.targets),
                    weight: weight * scale,
                };
                let step = system.step(layout, &self.rest, triangles, Some(soft), ROUND_TOLERANCE);
                self.stats.newton_steps += 1;
                self.stats.rounds = round + 1;
                if try_snap(layout, problem, triangles) {
                    self.stats.snapped = true;
                    self.stats.snapped_at_round = Some(round);
                    let storable = guard::all_positive_as_stored(layout, triangles);
                    self.stats.repair |= !storable;
                    self.phase = if self.polish_enabled || !storable {
                        self.stats.polish |= self.polish_enabled;
                        CompletionPhase::Polish { steps: 0 }
                    } else {
                        CompletionPhase::Done
                    };
                } else if step.converged || steps_in_round + 1 >= options.newton_iterations {
                    self.phase = if round + 1 >= options.completion_rounds {
                        // Retries from the same start, targets moving along arcs
                        // bulging right, then left.
                        let side = match &self.arcs {
                            None => Some(1.0),
                            Some((_, side)) if *side > 0.0 => Some(-1.0),
                            Some(_) => None,
                        };
                        match (side, &self.soft_start) {
                            (Some(side), Some(start)) => {
                                layout.copy_from_slice(start);
                                let paths = problem
                                    .constraint_vertices
                                    .iter()
                                    .zip(&problem.targets)
                                    .map(|(&v, &t)| (start[v as usize], t))
                                    .collect();
                                self.arcs = Some((paths, side));
                                self.stats.arc_retry = true;
                                CompletionPhase::Soft {
                                    round: 0,
                                    weight: options.initial_weight,
                                    steps_in_round: 0,
                                }
                            }
                            _ => CompletionPhase::Done,
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
                let system = self.polish_system.as_ref().expect("polish system");
                let repairing = !guard::all_positive_as_stored(layout, triangles);
                let step = system.step(layout, &self.rest, triangles, None, POLISH_TOLERANCE);
                self.stats.polish_steps = steps + 1;
                if repairing {
                    self.stats.polish_repair_steps += 1;
                }
                let relative_gain = (step.energy_before - step.energy_after) / step.energy_before.max(1e-300);
                let finished = !self.polish_enabled
                    || step.converged
                    || relative_gain < POLISH_TOLERANCE
                    || steps + 1 - self.stats.polish_repair_steps >= options.polish_iterations;
                let storable = guard::all_positive_as_stored(layout, triangles);
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

/// Puts every constrained vertex exactly on its target if that keeps every
/// triangle positive as stored; returns whether it did.
pub fn try_snap(layout: &mut [DVec2], problem: &StepProblem, triangles: &[[u32; 3]]) -> bool {
    let mut candidate = layout.to_vec();
    for (&v, &t) in problem.constraint_vertices.iter().zip(&problem.targets) {
        candidate[v as usize] = t;
    }
    if guard::acceptable(&candidate, triangles, guard::all_positive_as_stored(layout, triangles)) {
        layout.copy_from_slice(&candidate);
        true
    } else {
        false
    }
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
