//! Projected Newton on the symmetric Dirichlet energy (plus an optional soft
//! constraint term) over a fixed set of free vertices.
//!
//! The sparsity pattern depends only on the mesh and the free set, so the
//! symbolic Cholesky (minimum degree on vertices, 2 × 2 blocks, numbered in
//! elimination order) is a [`NewtonPattern`] made once per chart and shared.
//! Each Newton step assembles the projected Hessian straight into the
//! factor's value order (no sorting, no permutation) and refactors
//! numerically into reused memory (an older factorisation does not serve:
//! the Hessian changes too much between steps, docs/decisions.md).
//! The line search never lets a triangle's area reach zero: it starts at 0.9 ×
//! the largest step that keeps every triangle (virtual ones included)
//! positive, backtracks until Armijo holds, and accepts only layouts that
//! also keep their orientation as stored (f32). A full step with room left
//! before the barrier is stretched (doubled, up to 8×) while the energy
//! keeps falling and the layout stays acceptable.

use super::energy::{RestTriangle, triangle_terms};
use crate::sparse::{BlockedPattern, BlockedWorkspace, SparseError};
use glam::DVec2;
use std::sync::{Arc, Mutex};

/// A triangle's weighted energy, gradient and (projected) Hessian.
pub type Terms = fn(&RestTriangle, [DVec2; 3]) -> Option<(f64, [f64; 6], [f64; 36])>;

/// How far a full Newton step may be stretched (doubling) while the energy falls.
const MAX_STRETCH: f64 = 8.0;

/// A soft pull of some vertices toward targets: `w/2 · Σ |x_c − t_c|²`.
#[derive(Debug, Clone, Copy)]
pub struct SoftTargets<'a> {
    pub vertices: &'a [u32],
    pub targets: &'a [DVec2],
    pub weight: f64,
}

/// The fixed part of the Newton system over one free set: the sparsity
/// pattern with its symbolic factorisation and where each triangle's
/// Hessian goes. It depends only on the mesh and the free set, so one chart's
/// solves share it (the watch daemon across edits).
#[derive(Debug)]
pub struct NewtonPattern {
    free_row: Vec<Option<u32>>,
    n_free: usize,
    pattern: BlockedPattern,
    /// Per triangle, per entry of its 6 × 6 Hessian: where it adds into the
    /// pattern's values (`u32::MAX`: a fixed vertex, or the upper triangle).
    slots: Vec<[u32; 36]>,
    /// Per free vertex, the slots of its two diagonal entries.
    diagonal: Vec<[u32; 2]>,
    /// Per free vertex, the slot of its diagonal block's off-diagonal entry.
    off_diagonal: Vec<u32>,
}

/// The Newton system of one solve: a shared [`NewtonPattern`] and the
/// buffers its steps reuse.
#[derive(Debug, Clone)]
pub struct NewtonSystem {
    shape: Arc<NewtonPattern>,
    workspace: Workspace,
}

/// The Hessian values, gradient and factor memory of the last step, kept so
/// a step allocates nothing. Behind a mutex so steps can take `&self`; a
/// clone starts empty.
#[derive(Debug, Default)]
struct Workspace(Mutex<Buffers>);

#[derive(Debug, Default)]
struct Buffers {
    values: Vec<f64>,
    grad: Vec<f64>,
    factor: BlockedWorkspace,
}

impl Clone for Workspace {
    fn clone(&self) -> Self {
        Workspace::default()
    }
}

/// What one Newton step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonStep {
    pub energy_before: f64,
    pub energy_after: f64,
    /// Step length taken (0 when no descent was possible).
    pub alpha: f64,
    /// Newton decrement small, or no further progress: stop iterating.
    pub converged: bool,
}

impl NewtonPattern {
    /// Pattern for the vertices with `is_free[v]` over `triangles`. `order`,
    /// the free vertices in a fill-reducing elimination order of the same
    /// graph (step 1's bar-net factorisation has one), saves ordering again;
    /// an order of another vertex set is ignored.
    ///
    /// # Errors
    /// A pattern faer rejects (never for a valid mesh).
    pub fn new(triangles: &[[u32; 3]], is_free: &[bool], order: Option<&[u32]>) -> Result<Self, SparseError> {
        let mut free_index = vec![None; is_free.len()];
        let mut n_free = 0usize;
        for (v, &f) in is_free.iter().enumerate() {
            if f {
                free_index[v] = Some(n_free as u32);
                n_free += 1;
            }
        }
        // Each triangle edge between free vertices is a pair (shared edges twice).
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(3 * triangles.len());
        let mut edge_pair = vec![[u32::MAX; 3]; triangles.len()];
        for (t, edges) in triangles.iter().zip(&mut edge_pair) {
            for k in 0..3 {
                if let (Some(a), Some(b)) = (free_index[t[k] as usize], free_index[t[(k + 1) % 3] as usize]) {
                    edges[k] = pairs.len() as u32;
                    pairs.push((a, b));
                }
            }
        }
        let node_order: Option<Vec<u32>> = order.filter(|o| o.len() == n_free).and_then(|o| {
            o.iter()
                .map(|&v| free_index.get(v as usize).copied().flatten())
                .collect()
        });
        let (pattern, placement) = BlockedPattern::new(n_free.max(1), &pairs, node_order.as_deref())?;
        // A free vertex's row block is its place in the elimination order.
        let free_row: Vec<Option<u32>> = free_index
            .iter()
            .map(|i| i.map(|i| placement.position[i as usize]))
            .collect();
        let slots = triangles
            .iter()
            .zip(&edge_pair)
            .map(|(t, edges)| {
                let mut s = [u32::MAX; 36];
                for a in 0..3 {
                    let Some(ra) = free_row[t[a] as usize] else { continue };
                    for b in 0..3 {
                        let Some(rb) = free_row[t[b] as usize] else { continue };
                        if ra < rb {
                            continue;
                        }
                        // The block's columns: the vertex's own, or the edge's (a, b).
                        let columns = if a == b {
                            placement.diagonal[free_index[t[a] as usize].expect("free") as usize]
                        } else {
                            let k = if (a + 1) % 3 == b { a } else { b };
                            placement.pairs[edges[k] as usize]
                        };
                        for i in 0..2 {
                            for j in 0..2 {
                                // The lower triangle only (on a diagonal block, i ≥ j).
                                if a == b && i < j {
                                    continue;
                                }
                                s[(2 * a + i) * 6 + 2 * b + j] = columns[j] + i as u32;
                            }
                        }
                    }
                }
                s
            })
            .collect();
        // Per free vertex in elimination order, its two diagonal entries.
        let mut diagonal = vec![[0u32; 2]; n_free];
        let mut off_diagonal = vec![0u32; n_free];
        for (i, &p) in placement.position.iter().enumerate().take(n_free) {
            let [c0, c1] = placement.diagonal[i];
            diagonal[p as usize] = [c0, c1 + 1];
            off_diagonal[p as usize] = c0 + 1;
        }
        Ok(NewtonPattern {
            free_row,
            n_free,
            pattern,
            slots,
            diagonal,
            off_diagonal,
        })
    }

    pub fn n_free(&self) -> usize {
        self.n_free
    }

    /// Whether this pattern's free set is exactly `free` (sorted vertex ids).
    pub fn has_free_set(&self, free: &[u32]) -> bool {
        free.len() == self.n_free
            && free
                .iter()
                .all(|&v| self.free_row.get(v as usize).is_some_and(Option::is_some))
    }
}

impl NewtonSystem {
    pub fn new(shape: Arc<NewtonPattern>) -> Self {
        NewtonSystem {
            shape,
            workspace: Workspace::default(),
        }
    }

    pub fn n_free(&self) -> usize {
        self.shape.n_free
    }

    /// The pattern this system factors.
    pub fn pattern(&self) -> &Arc<NewtonPattern> {
        &self.shape
    }

    /// Energy at `layout`, with its gradient and Hessian written into
    /// `buffers`; vertices with `held[v]` are treated as fixed (identity
    /// rows). `None` if a triangle is folded.
    #[allow(clippy::too_many_arguments)]
    fn assemble(
        &self,
        buffers: &mut Buffers,
        layout: &[DVec2],
        rest: &[RestTriangle],
        triangles: &[[u32; 3]],
        soft: Option<SoftTargets>,
        held: Option<&[bool]>,
        terms: Terms,
    ) -> Option<f64> {
        let Buffers { values, grad, .. } = buffers;
        grad.clear();
        grad.resize(2 * self.shape.n_free, 0.0);
        values.clear();
        values.resize(self.shape.pattern.n_values(), 0.0);
        let mut total = 0.0;
        let is_held = |v: u32| held.is_some_and(|h| h[v as usize]);
        for ((t, r), slots) in triangles.iter().zip(rest).zip(&self.shape.slots) {
            let (e, g, h) = terms(r, t.map(|v| layout[v as usize]))?;
            total += e;
            let live = t.map(|v| self.shape.free_row[v as usize].filter(|_| !is_held(v)));
            for (k, row) in live.iter().enumerate() {
                if let Some(row) = row {
                    grad[2 * *row as usize] += g[2 * k];
                    grad[2 * *row as usize + 1] += g[2 * k + 1];
                }
            }
            if live.iter().all(Option::is_some) {
                for (&slot, &h) in slots.iter().zip(&h) {
                    if slot != u32::MAX {
                        values[slot as usize] += h;
                    }
                }
            } else {
                for (i, (&slot, &h)) in slots.iter().zip(&h).enumerate() {
                    if slot != u32::MAX && live[i / 12].is_some() && live[(i % 6) / 2].is_some() {
                        values[slot as usize] += h;
                    }
                }
            }
        }
        let n_patterned = self.shape.slots.len().min(triangles.len());
        let extra = triangles[n_patterned..]
            .iter()
            .zip(rest.get(n_patterned..).unwrap_or_default());
        total += self.assemble_extra(values, grad, layout, extra, &is_held, terms)?;
        if let Some(s) = soft {
            for (&v, &target) in s.vertices.iter().zip(s.targets) {
                let d = layout[v as usize] - target;
                total += 0.5 * s.weight * d.length_squared();
                if let Some(r) = self.shape.free_row[v as usize].filter(|_| !is_held(v)) {
                    let r = r as usize;
                    grad[2 * r] += s.weight * d.x;
                    grad[2 * r + 1] += s.weight * d.y;
                    for slot in self.shape.diagonal[r] {
                        values[slot as usize] += s.weight;
                    }
                }
            }
        }
        if let Some(held) = held {
            for (v, row) in self.shape.free_row.iter().enumerate() {
                if let (Some(row), true) = (row, held[v]) {
                    for slot in self.shape.diagonal[*row as usize] {
                        values[slot as usize] = 1.0;
                    }
                }
            }
        }
        Some(total)
    }

    /// Triangles past the pattern's (a free chart's scaffold): their energy
    /// and gradient in full, their Hessian's diagonal 2 × 2 blocks only
    /// (the pattern has no room for the couplings they make, and they
    /// change with every triangulation; the line search sees the true
    /// energy, so this only slows convergence near the border).
    fn assemble_extra<'a>(
        &self,
        values: &mut [f64],
        grad: &mut [f64],
        layout: &[DVec2],
        extra: impl Iterator<Item = (&'a [u32; 3], &'a RestTriangle)>,
        is_held: &dyn Fn(u32) -> bool,
        terms: Terms,
    ) -> Option<f64> {
        let mut total = 0.0;
        for (t, r) in extra {
            let (e, g, h) = terms(r, t.map(|v| layout[v as usize]))?;
            total += e;
            for (k, &v) in t.iter().enumerate() {
                let Some(row) = self
                    .shape
                    .free_row
                    .get(v as usize)
                    .copied()
                    .flatten()
                    .filter(|_| !is_held(v))
                else {
                    continue;
                };
                let row = row as usize;
                grad[2 * row] += g[2 * k];
                grad[2 * row + 1] += g[2 * k + 1];
                let [xx, yy] = self.shape.diagonal[row];
                values[xx as usize] += h[(2 * k) * 6 + 2 * k];
                values[self.shape.off_diagonal[row] as usize] += h[(2 * k + 1) * 6 + 2 * k];
                values[yy as usize] += h[(2 * k + 1) * 6 + 2 * k + 1];
            }
        }
        Some(total)
    }

    /// The Newton direction `H p = −g` for the Hessian and gradient in
    /// `buffers`, with a growing diagonal shift if `H` is singular (each
    /// retry has the values assembled anew by `reassemble`).
    fn direction(&self, buffers: &mut Buffers, mut reassemble: impl FnMut(&mut Buffers)) -> Option<Vec<f64>> {
        let mut relative_shift = 1e-12;
        for attempt in 0..6 {
            if attempt > 0 {
                reassemble(buffers);
            }
            let Buffers { values, grad, factor } = buffers;
            let diagonal = self.shape.diagonal.iter().flatten();
            let max_diag = diagonal
                .clone()
                .map(|&slot| values[slot as usize])
                .fold(0.0f64, f64::max)
                .max(1e-300);
            diagonal.for_each(|&slot| values[slot as usize] += relative_shift * max_diag);
            if self.shape.pattern.factor_into(values, factor).is_ok() {
                let mut p: Vec<f64> = grad.iter().map(|g| -g).collect();
                self.shape.pattern.solve_with(factor, &mut p);
                return Some(p);
            }
            relative_shift *= 1e3;
        }
        None
    }

    /// The minimiser of the least-squares conformal energy
    /// ([`super::energy::conformal_terms`]) over the free vertices, the
    /// vertices marked in `held` where `layout` has them: one exact Newton
    /// step (the energy is quadratic), written into `layout`. `false` when
    /// the system is singular (fewer than two held vertices).
    pub fn solve_conformal(
        &self,
        layout: &mut [DVec2],
        rest: &[RestTriangle],
        triangles: &[[u32; 3]],
        held: &[bool],
    ) -> bool {
        let mut buffers = self.workspace.0.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let terms: Terms = super::energy::conformal_terms;
        if self
            .assemble(&mut buffers, layout, rest, triangles, None, Some(held), terms)
            .is_none()
        {
            return false;
        }
        let reassemble = |buffers: &mut Buffers| {
            self.assemble(buffers, layout, rest, triangles, None, Some(held), terms);
        };
        let Some(p) = self.direction(&mut buffers, reassemble) else {
            return false;
        };
        for (v, r) in self.shape.free_row.iter().enumerate() {
            if let (Some(r), false) = (r, held[v]) {
                layout[v] += DVec2::new(p[2 * *r as usize], p[2 * *r as usize + 1]);
            }
        }
        layout.iter().all(|p| p.is_finite())
    }

    /// One projected Newton step from `layout` (updated in place), with the
    /// vertices marked in `held` kept where they are. The step counts as
    /// converged when the Newton decrement or the energy decrease is below
    /// `tolerance` relative to the energy. Every layout the step ends on
    /// passes `accept` (which `layout` passes), as well as staying positive
    /// in every triangle along the way.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &self,
        layout: &mut [DVec2],
        rest: &[RestTriangle],
        triangles: &[[u32; 3]],
        soft: Option<SoftTargets>,
        held: Option<&[bool]>,
        tolerance: f64,
        accept: &dyn Fn(&[DVec2]) -> bool,
    ) -> NewtonStep {
        let stuck = |e: f64| NewtonStep {
            energy_before: e,
            energy_after: e,
            alpha: 0.0,
            converged: true,
        };
        if self.shape.n_free == 0 {
            return stuck(energy(layout, rest, triangles, soft));
        }
        let mut buffers = self.workspace.0.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let terms: Terms = triangle_terms;
        let Some(total) = self.assemble(&mut buffers, layout, rest, triangles, soft, held, terms) else {
            return stuck(f64::INFINITY);
        };
        let reassemble = |buffers: &mut Buffers| {
            self.assemble(buffers, layout, rest, triangles, soft, held, terms);
        };
        let Some(p) = self.direction(&mut buffers, reassemble) else {
            return stuck(total);
        };
        let slope: f64 = buffers.grad.iter().zip(&p).map(|(g, d)| g * d).sum();
        if slope.is_nan() || slope >= 0.0 || -slope < 1e-14 * total.abs().max(1e-300) {
            return stuck(total);
        }
        let mut dir = vec![DVec2::ZERO; layout.len()];
        for (v, r) in self.shape.free_row.iter().enumerate() {
            if let Some(r) = r {
                dir[v] = DVec2::new(p[2 * *r as usize], p[2 * *r as usize + 1]);
            }
        }
        if let Some(held) = held {
            dir.iter_mut()
                .zip(held)
                .filter(|(_, h)| **h)
                .for_each(|(d, _)| *d = DVec2::ZERO);
        }
        let safe = 0.9 * max_safe_step(layout, &dir, triangles);
        let mut alpha = safe.min(1.0);
        let start: Vec<DVec2> = layout.to_vec();
        let place = |layout: &mut [DVec2], alpha: f64| {
            for ((x, &s), &d) in layout.iter_mut().zip(&start).zip(&dir) {
                *x = s + d * alpha;
            }
        };
        // Once storable as f32, always storable; a layout that is not yet (a
        // squeezed step 1) must only stay positive while the barrier spreads it.
        for _ in 0..60 {
            place(layout, alpha);
            let e = energy(layout, rest, triangles, soft);
            if e <= total + 1e-4 * alpha * slope && accept(layout) {
                // A full step with room before the barrier is stretched while
                // the energy keeps falling: the PSD projection makes the model
                // too stiff where the energy is nearly flat, so the tail of a
                // polish would take many full steps that each gain little.
                let (mut alpha, mut e) = (alpha, e);
                if alpha == 1.0 {
                    let mut a = alpha;
                    while 2.0 * a <= safe && a < MAX_STRETCH {
                        a *= 2.0;
                        place(layout, a);
                        let ea = energy(layout, rest, triangles, soft);
                        if ea < e && accept(layout) {
                            (alpha, e) = (a, ea);
                        } else {
                            break;
                        }
                    }
                    place(layout, alpha);
                }
                let converged = -0.5 * slope < tolerance * total || (total - e) < tolerance * total;
                return NewtonStep {
                    energy_before: total,
                    energy_after: e,
                    alpha,
                    converged,
                };
            }
            alpha *= 0.5;
        }
        layout.copy_from_slice(&start);
        stuck(total)
    }
}

/// Total energy (+∞ if any triangle is folded).
pub fn energy(layout: &[DVec2], rest: &[RestTriangle], triangles: &[[u32; 3]], soft: Option<SoftTargets>) -> f64 {
    let mut total = 0.0;
    for (t, r) in triangles.iter().zip(rest) {
        let f = super::energy::jacobian(r, t.map(|v| layout[v as usize]));
        total += r.weight * super::energy::psi(f);
    }
    if let Some(s) = soft {
        for (&v, &target) in s.vertices.iter().zip(s.targets) {
            total += 0.5 * s.weight * layout[v as usize].distance_squared(target);
        }
    }
    total
}

/// The largest `α` such that every triangle keeps positive area along
/// `layout + α · dir` (its area is quadratic in `α`); +∞ if none ever folds.
pub fn max_safe_step(layout: &[DVec2], dir: &[DVec2], triangles: &[[u32; 3]]) -> f64 {
    let mut best = f64::INFINITY;
    for t in triangles {
        let [a, b, c] = t.map(|v| layout[v as usize]);
        let [da, db, dc] = t.map(|v| dir[v as usize]);
        let (e1, e2, d1, d2) = (b - a, c - a, db - da, dc - da);
        let c0 = e1.perp_dot(e2);
        let c1 = e1.perp_dot(d2) + d1.perp_dot(e2);
        let c2 = d1.perp_dot(d2);
        let root = smallest_positive_root(c2, c1, c0);
        if root < best {
            best = root;
        }
    }
    best
}

/// Smallest positive root of `a α² + b α + c` (c > 0), or +∞.
fn smallest_positive_root(a: f64, b: f64, c: f64) -> f64 {
    let eps = 1e-14 * (a.abs() + b.abs() + c.abs());
    if a.abs() <= eps {
        return if b < 0.0 { -c / b } else { f64::INFINITY };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return f64::INFINITY;
    }
    let sq = disc.sqrt();
    // Numerically stable pair of roots.
    let q = -0.5 * (b + b.signum() * sq);
    let roots = [q / a, if q != 0.0 { c / q } else { f64::INFINITY }];
    roots.into_iter().filter(|r| *r > 0.0).fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn safe_step_stops_before_the_fold() {
        let layout = [DVec2::ZERO, DVec2::X, DVec2::Y];
        // Move the apex straight down through the base: area hits 0 at α = 1.
        let dir = [DVec2::ZERO, DVec2::ZERO, DVec2::new(0.0, -1.0)];
        assert!((max_safe_step(&layout, &dir, &[[0, 1, 2]]) - 1.0).abs() < 1e-12);
        let up = [DVec2::ZERO, DVec2::ZERO, DVec2::new(0.3, 1.0)];
        assert!(max_safe_step(&layout, &up, &[[0, 1, 2]]).is_infinite());
        assert!((smallest_positive_root(1.0, -3.0, 2.0) - 1.0).abs() < 1e-12);
    }
}
