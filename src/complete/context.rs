//! What the completion and the polish share: one chart's Newton system
//! over its movable vertices, the triangles it works on with their rest
//! shapes, and whether the current layout is storable as f32.
//!
//! Both work on the filled triangles (virtual hole triangles included); a
//! free chart adds its scaffold ([`crate::free::scaffold`]) outside its
//! outer loop, triangulated anew after every change, and is storable when
//! its triangles are positive as stored and its room admits it
//! ([`crate::free::room`]).

use super::VIRTUAL_WEIGHT;
use super::energy::{self, RestTriangle, rest_shapes};
use super::newton::{self, NewtonPattern, NewtonStep, NewtonSystem, SoftTargets};
use crate::free::room::Room;
use crate::free::scaffold::Scaffold;
use crate::guard;
use crate::injective::Edge;
use crate::param::bar_net::FilledChart;
use crate::rbf::stepping::StepProblem;
use glam::DVec2;
use std::sync::Arc;

/// Weight of a scaffold triangle in the energy, relative to its area: a
/// barrier that keeps the boundary apart, with little say in its shape.
pub const SCAFFOLD_WEIGHT: f64 = 0.01;

/// The least height, relative to its longest edge, of a scaffold triangle's
/// rest shape while the chart is moved (the start's relaxation, the soft
/// rounds); a thinner one is measured against itself with its apex lifted
/// to this height. At rest in its own shape, remade after every step, a
/// sliver never pushes back, so each step (0.9 of the safe one) squashed it
/// tenfold again: where the outer loop nearly touches itself (a closed
/// mouth) steps crawled at 1e-2–1e-4. Held fuller, it pushes the two sides
/// apart before they meet (Jiang et al. give slivers a regular reference).
pub const SCAFFOLD_MIN_HEIGHT: f64 = 0.1;

/// The Newton machinery of one chart's solve.
#[derive(Debug, Clone)]
pub struct NewtonContext {
    system: NewtonSystem,
    /// The triangles the energy and the guard see: the chart's first.
    triangles: Vec<[u32; 3]>,
    /// Each triangle's rest shape (virtual ones at [`VIRTUAL_WEIGHT`],
    /// scaffold ones their own shape at [`SCAFFOLD_WEIGHT`]).
    rest: Vec<RestTriangle>,
    /// How many of `triangles` are the chart's (the rest is scaffold).
    n_chart: usize,
    n_real: usize,
    free: Option<FreeDomain>,
    /// Whether the current layout is storable (f32). Once true it stays
    /// true (every accepted step keeps it), so it is carried rather than
    /// recounted each step.
    storable: bool,
    /// Milliseconds spent triangulating the scaffold.
    scaffold_ms: f64,
    /// The least relative height of a scaffold rest shape
    /// ([`SCAFFOLD_MIN_HEIGHT`], or 0: each in its own shape).
    scaffold_floor: f64,
    /// The last scaffold triangulation and the boundary positions it was
    /// made for: the scaffold depends on nothing else (its other points are
    /// fixed), so a rebuild for an unchanged boundary (the polish starting
    /// right after a snap, an attempt restarting where it stood) reuses it.
    last_scaffold: Option<(Vec<DVec2>, Vec<[u32; 3]>)>,
}

/// A free chart's room and scaffold.
#[derive(Debug, Clone)]
pub struct FreeDomain {
    pub room: Arc<Room>,
    pub scaffold: Arc<Scaffold>,
    /// Layout index of the scaffold's first fixed point.
    pub offset: u32,
    /// The chart's boundary edges (chart-local), loop after loop.
    pub edges: Vec<Edge>,
}

impl FreeDomain {
    pub fn new(room: Arc<Room>, scaffold: Arc<Scaffold>, offset: u32) -> Self {
        let edges = room.boundary_edges().collect();
        FreeDomain {
            room,
            scaffold,
            offset,
            edges,
        }
    }
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
    /// The context of a square chart for `problem`'s movable vertices,
    /// starting at `layout`, with the Newton pattern of [`super::newton_pattern`].
    pub fn new(filled: &FilledChart, problem: &StepProblem, pattern: Arc<NewtonPattern>, layout: &[DVec2]) -> Self {
        debug_assert!(
            pattern.has_free_set(&problem.movable),
            "a Newton pattern for another free set"
        );
        let triangles = filled.mesh.triangles.clone();
        NewtonContext {
            system: NewtonSystem::new(pattern),
            rest: rest_shapes(
                &filled.mesh.positions,
                &triangles,
                filled.n_real_triangles,
                VIRTUAL_WEIGHT,
            ),
            storable: guard::all_positive_as_stored(layout, &triangles),
            n_chart: triangles.len(),
            n_real: filled.n_real_triangles,
            triangles,
            free: None,
            scaffold_ms: 0.0,
            scaffold_floor: 0.0,
            last_scaffold: None,
        }
    }

    /// The context of a free chart (its pattern over every vertex of the
    /// filled chart), starting at `layout` (scaffold points appended), rest
    /// shapes scaled to the layout area `rest_area`.
    pub fn free(
        filled: &FilledChart,
        pattern: Arc<NewtonPattern>,
        layout: &[DVec2],
        domain: FreeDomain,
        rest_area: f64,
    ) -> Self {
        let n_real = filled.n_real_triangles;
        let triangles = filled.mesh.triangles.clone();
        let rest = scaled(
            rest_shapes(&filled.mesh.positions, &triangles, n_real, VIRTUAL_WEIGHT),
            rest_area,
        );
        let mut context = NewtonContext {
            system: NewtonSystem::new(pattern),
            rest,
            n_chart: triangles.len(),
            n_real,
            triangles,
            free: Some(domain),
            storable: false,
            scaffold_ms: 0.0,
            scaffold_floor: SCAFFOLD_MIN_HEIGHT,
            last_scaffold: None,
        };
        context.recount(layout);
        context
    }

    /// Scaffold triangles at rest in their own shapes from now on, however
    /// thin (the polish: a barrier only, with no say in where the boundary
    /// goes), the scaffold of `layout` remade.
    pub fn scaffold_in_own_shapes(&mut self, layout: &[DVec2]) {
        self.scaffold_floor = 0.0;
        self.rebuild_scaffold(layout);
    }

    /// Scaffold triangles no thinner than [`SCAFFOLD_MIN_HEIGHT`] again, the
    /// scaffold of `layout` remade: slivers push back.
    pub fn scaffold_floored(&mut self, layout: &[DVec2]) {
        self.scaffold_floor = SCAFFOLD_MIN_HEIGHT;
        self.rebuild_scaffold(layout);
    }

    /// Scales the real triangles' rest shapes to the size `layout` fits
    /// best ([`energy::best_fit_scale`]); returns their total area now.
    pub fn fit_rest_scale(&mut self, layout: &[DVec2]) -> f64 {
        let n = self.n_real;
        let mu = energy::best_fit_scale(&self.rest[..n], layout, &self.triangles[..n]);
        for r in &mut self.rest[..n] {
            r.inv_rest = r.inv_rest.map(|x| x / mu);
            r.weight *= mu * mu;
        }
        self.rest[..n].iter().map(|r| r.weight).sum()
    }

    /// The triangles the energy and guard see (the chart's, then the scaffold's).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    pub fn rest(&self) -> &[RestTriangle] {
        &self.rest
    }

    pub fn is_storable(&self) -> bool {
        self.storable
    }

    pub fn is_free(&self) -> bool {
        self.free.is_some()
    }

    /// Milliseconds spent triangulating the scaffold so far.
    pub fn scaffold_ms(&self) -> f64 {
        self.scaffold_ms
    }

    /// Scaffold triangles now.
    pub fn scaffold_size(&self) -> usize {
        self.triangles.len() - self.n_chart
    }

    /// The Newton system (for the conformal start of a free chart).
    pub fn system(&self) -> &NewtonSystem {
        &self.system
    }

    /// The symmetric Dirichlet energy of `layout` against the rest shapes
    /// (area-weighted sum, +∞ if a triangle is folded).
    pub fn energy(&self, layout: &[DVec2]) -> f64 {
        newton::energy(layout, &self.rest, &self.triangles, None)
    }

    /// The real triangles' energy per unit rest area (ψ averaged, 4 =
    /// isometry; +∞ if one is folded).
    pub fn mean_psi(&self, layout: &[DVec2]) -> f64 {
        let (t, r) = (&self.triangles[..self.n_real], &self.rest[..self.n_real]);
        let weight: f64 = r.iter().map(|r| r.weight).sum();
        newton::energy(layout, r, t, None) / weight.max(1e-300)
    }

    /// The largest energy of one real triangle (ψ per unit area, 4 =
    /// isometry; +∞ if one is folded).
    pub fn worst_psi(&self, layout: &[DVec2]) -> f64 {
        self.triangles[..self.n_real]
            .iter()
            .zip(&self.rest)
            .map(|(t, r)| energy::psi(energy::jacobian(r, t.map(|v| layout[v as usize]))))
            .fold(0.0, f64::max)
    }

    /// Whether a layout may be accepted: every triangle positive, and (once
    /// storable) storable.
    pub fn accepts(&self, layout: &[DVec2]) -> bool {
        let chart = &self.triangles[..self.n_chart];
        match &self.free {
            None => guard::acceptable(layout, chart, self.storable),
            Some(domain) => {
                guard::all_positive(layout, &self.triangles[self.n_chart..])
                    && guard::acceptable(layout, chart, self.storable)
                    && (!self.storable || domain.room.admits(layout).is_ok())
            }
        }
    }

    /// One projected Newton step on `layout`, which stays fold-free (and
    /// storable once it is).
    pub fn step(&mut self, layout: &mut [DVec2], request: StepRequest) -> NewtonStep {
        let accept = |l: &[DVec2]| self.accepts(l);
        let step = self.system.step(
            layout,
            request.reference.unwrap_or(&self.rest),
            &self.triangles,
            request.soft,
            request.held,
            request.tolerance,
            &accept,
        );
        self.note_change(layout);
        step
    }

    /// Puts every constrained vertex exactly on its target if the result
    /// may be accepted; returns whether it did.
    pub fn try_snap(&mut self, layout: &mut [DVec2], problem: &StepProblem) -> bool {
        let mut candidate = layout.to_vec();
        for (&v, &t) in problem.constraint_vertices.iter().zip(&problem.targets) {
            candidate[v as usize] = t;
        }
        if !self.accepts(&candidate) {
            return false;
        }
        layout.copy_from_slice(&candidate);
        self.note_change(layout);
        true
    }

    /// After `layout` changed by an accepted step or a snap: a layout that
    /// was storable still is; one that was not is recounted. A free chart's
    /// scaffold is triangulated anew.
    pub fn note_change(&mut self, layout: &[DVec2]) {
        if !self.storable {
            self.storable = self.count_storable(layout);
        }
        self.rebuild_scaffold(layout);
    }

    /// After `layout` was replaced (another attempt's start, the best
    /// attempt): storability is counted afresh, the scaffold rebuilt.
    pub fn recount(&mut self, layout: &[DVec2]) {
        self.storable = self.count_storable(layout);
        self.rebuild_scaffold(layout);
    }

    /// The chart's triangles (the scaffold's left out).
    pub fn chart_triangles(&self) -> &[[u32; 3]] {
        &self.triangles[..self.n_chart]
    }

    fn count_storable(&self, layout: &[DVec2]) -> bool {
        guard::all_positive_as_stored(layout, &self.triangles[..self.n_chart])
            && self.free.as_ref().is_none_or(|d| d.room.admits(layout).is_ok())
    }

    /// The scaffold around `layout`'s boundary, each triangle at rest in its
    /// own shape, no thinner than the floor (kept as it was if the boundary
    /// cannot be triangulated around, which an accepted layout never asks).
    /// Triangulated anew only when the boundary moved since the last time.
    fn rebuild_scaffold(&mut self, layout: &[DVec2]) {
        let Some(domain) = &self.free else {
            return;
        };
        let t0 = std::time::Instant::now();
        let boundary = domain.room.boundary_vertices();
        let at: Vec<DVec2> = boundary.iter().map(|&v| layout[v as usize]).collect();
        if self.last_scaffold.as_ref().is_none_or(|(was, _)| *was != at) {
            let scaffold = domain
                .scaffold
                .triangulate(layout, boundary, &domain.edges, domain.offset);
            self.last_scaffold = scaffold.map(|s| (at, s));
        }
        self.scaffold_ms += t0.elapsed().as_secs_f64() * 1e3;
        let Some((_, scaffold)) = &self.last_scaffold else {
            return;
        };
        self.triangles.truncate(self.n_chart);
        self.rest.truncate(self.n_chart);
        for &t in scaffold {
            let [a, b, c] = t.map(|v| layout[v as usize]);
            if let Some(r) = own_shape(a, b, c, self.scaffold_floor) {
                self.triangles.push(t);
                self.rest.push(r);
            }
        }
    }
}

/// Rest shapes scaled from total area 1 to `area`.
pub fn scaled(rest: Vec<RestTriangle>, area: f64) -> Vec<RestTriangle> {
    let s = area.max(1e-300);
    let inv = 1.0 / s.sqrt();
    rest.into_iter()
        .map(|r| RestTriangle {
            inv_rest: r.inv_rest.map(|x| x * inv),
            weight: r.weight * s,
        })
        .collect()
}

/// A layout triangle as its own rest shape, its apex (opposite the longest
/// edge) lifted to `floor` times that edge's length if it is lower, at
/// [`SCAFFOLD_WEIGHT`] times the rest area (`None` if it has no area).
fn own_shape(a: DVec2, b: DVec2, c: DVec2, floor: f64) -> Option<RestTriangle> {
    let det = (b - a).perp_dot(c - a);
    if det <= 0.0 || !det.is_finite() {
        return None;
    }
    let mut p = [a, b, c];
    let opposite = |k: usize| p[(k + 1) % 3].distance_squared(p[(k + 2) % 3]);
    let apex = (0..3).max_by(|&i, &j| opposite(i).total_cmp(&opposite(j))).unwrap_or(0);
    let (from, edge) = (p[(apex + 1) % 3], p[(apex + 2) % 3] - p[(apex + 1) % 3]);
    let length = edge.length();
    if det < floor * length * length {
        // Counter-clockwise: the apex lies left of its edge (`perp`).
        let foot = from + edge * ((p[apex] - from).dot(edge) / (length * length));
        p[apex] = foot + edge.perp() * floor;
    }
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let det = e1.perp_dot(e2);
    // R = [e1 e2] (columns); R⁻¹ = adj / det.
    Some(RestTriangle {
        inv_rest: [e2.y / det, -e2.x / det, -e1.y / det, e1.x / det],
        weight: SCAFFOLD_WEIGHT * 0.5 * det,
    })
}
