//! What the completion and the polish share: one chart's Newton system
//! over its movable vertices, its triangles' rest shapes, and whether the
//! current layout is storable as f32.

use super::VIRTUAL_WEIGHT;
use super::energy::{self, RestTriangle, rest_shapes};
use super::newton::{self, NewtonPattern, NewtonStep, NewtonSystem, SoftTargets};
use crate::guard;
use crate::param::bar_net::FilledChart;
use crate::rbf::stepping::StepProblem;
use glam::DVec2;
use std::sync::Arc;

/// The Newton machinery of one chart's solve.
#[derive(Debug, Clone)]
pub struct NewtonContext {
    system: NewtonSystem,
    /// Every triangle's rest shape (virtual hole triangles at [`VIRTUAL_WEIGHT`]).
    rest: Vec<RestTriangle>,
    /// Whether the current layout keeps every triangle positive as stored
    /// (f32). Once true it stays true (every accepted step keeps it), so it
    /// is carried rather than recounted each step.
    storable: bool,
}

/// What one step asks of the Newton system.
#[derive(Debug, Clone, Copy)]
pub struct StepRequest<'a> {
    /// Measure against these shapes instead of the rest shapes (the soft
    /// rounds' progressive references).
    pub reference: Option<&'a [RestTriangle]>,
    pub soft: Option<SoftTargets<'a>>,
    /// Vertices held where they are.
    pub held: Option<&'a [bool]>,
    /// Relative decrease below which the step counts as converged.
    pub tolerance: f64,
}

impl NewtonContext {
    /// The context for `problem`'s movable vertices, starting at `layout`,
    /// with the Newton pattern of [`super::newton_pattern`].
    pub fn new(filled: &FilledChart, problem: &StepProblem, pattern: Arc<NewtonPattern>, layout: &[DVec2]) -> Self {
        debug_assert!(
            pattern.has_free_set(&problem.movable),
            "a Newton pattern for another free set"
        );
        NewtonContext {
            system: NewtonSystem::new(pattern),
            rest: rest_shapes(
                &filled.mesh.positions,
                &filled.mesh.triangles,
                filled.n_real_triangles,
                VIRTUAL_WEIGHT,
            ),
            storable: guard::all_positive_as_stored(layout, &filled.mesh.triangles),
        }
    }

    pub fn rest(&self) -> &[RestTriangle] {
        &self.rest
    }

    pub fn is_storable(&self) -> bool {
        self.storable
    }

    /// The symmetric Dirichlet energy of `layout` against the rest shapes
    /// (area-weighted sum, +∞ if a triangle is folded).
    pub fn energy(&self, layout: &[DVec2], triangles: &[[u32; 3]]) -> f64 {
        newton::energy(layout, &self.rest, triangles, None)
    }

    /// The largest energy of one of the first `n` triangles (ψ per unit
    /// area, 4 = isometry; +∞ if one is folded).
    pub fn worst_psi(&self, layout: &[DVec2], triangles: &[[u32; 3]], n: usize) -> f64 {
        triangles[..n]
            .iter()
            .zip(&self.rest)
            .map(|(t, r)| energy::psi(energy::jacobian(r, t.map(|v| layout[v as usize]))))
            .fold(0.0, f64::max)
    }

    /// One projected Newton step on `layout`, which stays fold-free (and
    /// storable once it is).
    pub fn step(&mut self, layout: &mut [DVec2], triangles: &[[u32; 3]], request: StepRequest) -> NewtonStep {
        let step = self.system.step(
            layout,
            request.reference.unwrap_or(&self.rest),
            triangles,
            request.soft,
            request.held,
            request.tolerance,
            self.storable,
        );
        self.note_change(layout, triangles);
        step
    }

    /// After `layout` changed by an accepted step or a snap: a layout that
    /// was storable still is; one that was not is recounted.
    pub fn note_change(&mut self, layout: &[DVec2], triangles: &[[u32; 3]]) {
        if !self.storable {
            self.storable = guard::all_positive_as_stored(layout, triangles);
        }
    }

    /// After `layout` was replaced (another attempt's start, the best
    /// attempt): storability is counted afresh.
    pub fn recount(&mut self, layout: &[DVec2], triangles: &[[u32; 3]]) {
        self.storable = guard::all_positive_as_stored(layout, triangles);
    }
}
