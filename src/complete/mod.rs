//! Step 3: the completion phase, which reaches the constraints the spline
//! path stalls on, and the distortion polish.
//!
//! Soft-to-hard symmetric Dirichlet ([`soft`]): from the step-1 layout,
//! minimise `SD(x) + w/2 · Σ |x_c − t_c|²` by projected Newton
//! ([`newton`]), the weight growing per round (a round ends at its first
//! full Newton step, or when a step converges), triangles the start squeezed
//! past [`PROGRESSIVE_CAP`] measured against progressive reference shapes
//! ([`energy::progressive_rest`]); after every step, if putting the
//! constrained vertices exactly on their targets keeps every triangle
//! positive (as stored), snap them there. Straight and arc attempts
//! ([`attempts`]) let constraints pass each other. Then [`polish`]: minimise
//! SD with the constraints and the boundary held. Every layout this phase
//! accepts is fold-free, virtual hole triangles included.
//!
//! Each phase advances one Newton step per call; the chart solver
//! sequences them.

pub mod attempts;
pub mod context;
pub mod energy;
pub mod newton;
pub mod obstruction;
pub mod pattern;
pub mod polish;
pub mod soft;

use crate::param::bar_net::FilledChart;
use crate::rbf::stepping::StepProblem;
use crate::sparse::SparseError;
use energy::rest_shapes;
use glam::DVec2;
use newton::NewtonPattern;

/// Weight of virtual hole triangles in the energy, relative to their area:
/// enough for the barrier (holes never fold), too little to resist reshaping.
pub const VIRTUAL_WEIGHT: f64 = 0.01;

/// The polish (and the repair of an unstorable start) stops when a Newton
/// step gains less than this (relative).
const POLISH_TOLERANCE: f64 = 1e-3;

/// Newton steps at most while repairing a layout that f32 cannot store yet.
pub const REPAIR_STEPS: u32 = 2000;

/// A repair gives up after this many Newton steps in a row that leave no
/// fewer triangles unstorable than its best so far: the energy still falls,
/// but towards rest shapes (slivers of a CAD part) that f32 cannot hold.
pub const REPAIR_PATIENCE: u32 = 200;

/// Whether a repair of a layout f32 cannot store yet still gains: the least
/// count of triangles it could not store, and the steps since.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RepairWatch {
    best: usize,
    since: u32,
}

impl Default for RepairWatch {
    fn default() -> Self {
        RepairWatch {
            best: usize::MAX,
            since: 0,
        }
    }
}

impl RepairWatch {
    /// Notes the triangles still unstorable after a repair step of
    /// `newton`'s chart (`layout`); `true` once [`REPAIR_PATIENCE`] steps in
    /// a row brought no new least count. A storable layout never stalls.
    pub fn stalled(&mut self, newton: &context::NewtonContext, layout: &[DVec2]) -> bool {
        !newton.is_storable() && self.note(crate::guard::count_unstorable(layout, newton.chart_triangles()))
    }

    /// Notes `left` triangles unstorable after a step; `true` once
    /// [`REPAIR_PATIENCE`] steps in a row brought no new least count.
    fn note(&mut self, left: usize) -> bool {
        if left < self.best {
            self.best = left;
            self.since = 0;
        } else {
            self.since += 1;
        }
        self.since >= REPAIR_PATIENCE
    }
}

/// In the soft rounds, no triangle's energy counts for more than this (ψ
/// per unit area, 4 = isometry): one squeezed harder against its rest shape
/// is measured against a progressive reference instead
/// ([`energy::progressive_rest`]), so that a start with triangles squeezed
/// far past isometry does not have their barriers cut every step short
/// (docs/decisions.md has the measurements behind the value).
pub const PROGRESSIVE_CAP: f64 = 1000.0;

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
    let free = crate::mesh::marked(filled.mesh.n_vertices(), movable);
    NewtonPattern::new(&filled.mesh.triangles, &free, order)
}

/// What a certificate may take as fixed ([`find_obstruction`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pinned {
    /// The outer boundary where the layout has it (on the square), and
    /// each constraint at its target.
    BoundaryAndTargets,
    /// Each constraint at its target only (a free boundary): a triangle
    /// of landmarks sent to its mirror image, two landmarks on one point,
    /// a landmark on or in a triangle of landmarks, crossing edges between
    /// landmarks are obstructions in any one-to-one layout of the chart.
    Targets,
}

impl Pinned {
    /// What a chart's certificate pins: the boundary too on the square,
    /// the targets alone when it is `free`.
    pub fn for_boundary(free: bool) -> Pinned {
        if free {
            Pinned::Targets
        } else {
            Pinned::BoundaryAndTargets
        }
    }
}

/// A certificate that no fold-free layout of this chart puts every
/// constraint of `problem` on its target ([`obstruction`]), with what
/// `pinned` says fixed (the outer boundary where `layout` has it).
pub fn find_obstruction(
    filled: &FilledChart,
    (layout, pinned): (&[DVec2], Pinned),
    problem: &StepProblem,
) -> Option<obstruction::Obstruction> {
    let n = filled.mesh.n_vertices();
    let mut pins: Vec<Option<DVec2>> = match pinned {
        Pinned::BoundaryAndTargets => layout.iter().map(|&p| Some(p)).collect(),
        Pinned::Targets => vec![None; n],
    };
    problem.movable.iter().for_each(|&v| pins[v as usize] = None);
    let mut is_constraint = vec![false; n];
    for (&v, &t) in problem.constraint_vertices.iter().zip(&problem.targets) {
        pins[v as usize] = Some(t);
        is_constraint[v as usize] = true;
    }
    let found = obstruction::find_obstruction(
        &filled.mesh.triangles,
        &filled.edges,
        &pins,
        &is_constraint,
        filled.n_real_vertices,
    );
    // A boxed vertex is measured inside its neighbours' hull: on a free
    // boundary the room it needs may lie outside it.
    found.filter(|o| pinned == Pinned::BoundaryAndTargets || !matches!(o, obstruction::Obstruction::BoxedVertex { .. }))
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
    fn a_repair_stalls_only_after_a_run_of_steps_without_a_new_least_count() {
        let mut watch = RepairWatch::default();
        // Falling, with ups and downs: never stalled.
        for k in 0..(3 * REPAIR_PATIENCE as usize) {
            let left = 1000 - k / 2 + (k % 7);
            assert!(!watch.note(left), "stalled at step {k} while still gaining");
        }
        // A new least count, then none lower: stalled exactly when the
        // patience runs out.
        assert!(!watch.note(1));
        let mut stalled_at = None;
        for k in 0..(2 * REPAIR_PATIENCE) {
            if watch.note(5000) {
                stalled_at = Some(k + 1);
                break;
            }
        }
        assert_eq!(stalled_at, Some(REPAIR_PATIENCE));
    }
}
