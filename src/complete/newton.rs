//! Projected Newton on the symmetric Dirichlet energy (plus an optional soft
//! constraint term) over a fixed set of free vertices.
//!
//! The sparsity pattern depends only on the mesh and the free set, so the
//! symbolic Cholesky is done once and every Newton step refactors numerically.
//! The line search never lets a triangle's area reach zero: it starts at 0.9 ×
//! the largest step that keeps every triangle (virtual ones included)
//! positive, backtracks until Armijo holds, and accepts only layouts that
//! also keep their orientation as stored (f32).

use super::energy::{RestTriangle, triangle_terms};
use crate::guard;
use crate::sparse::{SparseError, SpdPattern};
use faer::Mat;
use glam::DVec2;

/// A soft pull of some vertices toward targets: `w/2 · Σ |x_c − t_c|²`.
#[derive(Debug, Clone, Copy)]
pub struct SoftTargets<'a> {
    pub vertices: &'a [u32],
    pub targets: &'a [DVec2],
    pub weight: f64,
}

/// The Newton system over one free set.
#[derive(Debug, Clone)]
pub struct NewtonSystem {
    free_row: Vec<Option<u32>>,
    n_free: usize,
    pattern: SpdPattern,
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

impl NewtonSystem {
    /// Pattern for the vertices with `is_free[v]` over `triangles`.
    ///
    /// # Errors
    /// A pattern faer rejects (never for a valid mesh).
    pub fn new(triangles: &[[u32; 3]], is_free: &[bool]) -> Result<Self, SparseError> {
        let mut free_row = vec![None; is_free.len()];
        let mut n_free = 0usize;
        for (v, &f) in is_free.iter().enumerate() {
            if f {
                free_row[v] = Some(n_free as u32);
                n_free += 1;
            }
        }
        let mut entries: Vec<(usize, usize)> = (0..2 * n_free).map(|r| (r, r)).collect();
        for t in triangles {
            for p in 0..6 {
                let Some(rp) = free_row[t[p / 2] as usize] else {
                    continue;
                };
                for q in 0..6 {
                    let Some(rq) = free_row[t[q / 2] as usize] else {
                        continue;
                    };
                    let (gp, gq) = (2 * rp as usize + p % 2, 2 * rq as usize + q % 2);
                    if gp >= gq {
                        entries.push((gp, gq));
                    }
                }
            }
        }
        let pattern = SpdPattern::new_supernodal(2 * n_free.max(1), &entries)?;
        Ok(NewtonSystem {
            free_row,
            n_free,
            pattern,
        })
    }

    pub fn n_free(&self) -> usize {
        self.n_free
    }

    /// One projected Newton step from `layout` (updated in place). The step
    /// counts as converged when the Newton decrement or the energy decrease
    /// is below `tolerance` relative to the energy.
    pub fn step(
        &self,
        layout: &mut [DVec2],
        rest: &[RestTriangle],
        triangles: &[[u32; 3]],
        soft: Option<SoftTargets>,
        tolerance: f64,
    ) -> NewtonStep {
        let n2 = 2 * self.n_free;
        let stuck = |e: f64| NewtonStep {
            energy_before: e,
            energy_after: e,
            alpha: 0.0,
            converged: true,
        };
        if self.n_free == 0 {
            return stuck(energy(layout, rest, triangles, soft));
        }
        let mut grad = vec![0.0f64; n2];
        let mut values: Vec<f64> = vec![0.0; n2];
        let mut total = 0.0;
        for (t, r) in triangles.iter().zip(rest) {
            let x = t.map(|v| layout[v as usize]);
            let Some((e, g, h)) = triangle_terms(r, x) else {
                return stuck(f64::INFINITY);
            };
            total += e;
            for p in 0..6 {
                let Some(rp) = self.free_row[t[p / 2] as usize] else {
                    continue;
                };
                let gp = 2 * rp as usize + p % 2;
                grad[gp] += g[p];
                for q in 0..6 {
                    let Some(rq) = self.free_row[t[q / 2] as usize] else {
                        continue;
                    };
                    let gq = 2 * rq as usize + q % 2;
                    if gp >= gq {
                        values.push(h[p * 6 + q]);
                    }
                }
            }
        }
        if let Some(s) = soft {
            for (&v, &target) in s.vertices.iter().zip(s.targets) {
                let d = layout[v as usize] - target;
                total += 0.5 * s.weight * d.length_squared();
                if let Some(r) = self.free_row[v as usize] {
                    let r = 2 * r as usize;
                    grad[r] += s.weight * d.x;
                    grad[r + 1] += s.weight * d.y;
                    values[r] += s.weight;
                    values[r + 1] += s.weight;
                }
            }
        }
        // Newton direction: H p = −g, with a growing shift if H is singular.
        let max_diag = (0..n2).map(|r| values[r]).fold(0.0f64, f64::max).max(1e-300);
        let mut shift = 1e-12 * max_diag;
        let mut direction = None;
        for _ in 0..6 {
            let mut v = values.clone();
            (0..n2).for_each(|r| v[r] += shift);
            if let Ok(f) = self.pattern.factor(&v) {
                let mut rhs = Mat::<f64>::zeros(n2, 1);
                (0..n2).for_each(|r| rhs[(r, 0)] = -grad[r]);
                f.solve_in_place(&mut rhs);
                direction = Some((0..n2).map(|r| rhs[(r, 0)]).collect::<Vec<f64>>());
                break;
            }
            shift *= 1e3;
        }
        let Some(p) = direction else { return stuck(total) };
        let slope: f64 = grad.iter().zip(&p).map(|(g, d)| g * d).sum();
        if !(slope < 0.0) || -slope < 1e-14 * total.abs().max(1e-300) {
            return stuck(total);
        }
        let mut dir = vec![DVec2::ZERO; layout.len()];
        for (v, r) in self.free_row.iter().enumerate() {
            if let Some(r) = r {
                dir[v] = DVec2::new(p[2 * *r as usize], p[2 * *r as usize + 1]);
            }
        }
        let mut alpha = (0.9 * max_safe_step(layout, &dir, triangles)).min(1.0);
        let start: Vec<DVec2> = layout.to_vec();
        // Once storable as f32, always storable; a layout that is not yet (a
        // squeezed step 1) must only stay positive while the barrier spreads it.
        let storable = guard::all_positive_as_stored(&start, triangles);
        for _ in 0..60 {
            for (v, x) in layout.iter_mut().enumerate() {
                *x = start[v] + dir[v] * alpha;
            }
            let e = energy(layout, rest, triangles, soft);
            if e <= total + 1e-4 * alpha * slope && guard::acceptable(layout, triangles, storable) {
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
