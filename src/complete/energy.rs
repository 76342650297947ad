//! Symmetric Dirichlet energy per triangle, with its gradient and a
//! positive semi-definite projection of its Hessian (projected Newton).
//!
//! For a triangle with rest shape `R` (its 3D triangle laid flat) and layout
//! positions `X`, the Jacobian is `F = X R⁻¹` (2 × 2) and
//! `ψ(F) = ‖F‖² + ‖F⁻¹‖² = I₂ (1 + J⁻²)`, `I₂ = ‖F‖²`, `J = det F`: 4 for an
//! isometry, +∞ as the triangle's area goes to zero (a barrier against folds).
//!
//! The Hessian `∂²ψ/∂F²` has a closed form, and of its analytic eigenpairs
//! (Smith et al. 2019) only the twist mode can be negative:
//! `λ_t = 2 − 2 (I₂ − J) / J³` along `T = R₉₀ Q / √2`, with `Q` the rotation of
//! `F`'s polar decomposition. Projection is one rank-1 correction.

use glam::{DVec2, DVec3};

/// Rest shape of one triangle: `R⁻¹` (row-major) and its weight (area).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestTriangle {
    pub inv_rest: [f64; 4],
    pub weight: f64,
}

/// Rest shapes of the filled chart's triangles, scaled so the real triangles'
/// total area is 1 (the texture square's area). Virtual hole triangles get
/// `virtual_weight` times their area: they keep the barrier (holes never
/// fold) but barely resist changing shape. Degenerate 3D triangles get an
/// equilateral rest shape of the mean triangle area.
pub fn rest_shapes(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    n_real_triangles: usize,
    virtual_weight: f64,
) -> Vec<RestTriangle> {
    let flat = |t: &[u32; 3]| -> (DVec2, DVec2, f64) {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        let (e1, e2) = (b - a, c - a);
        let l1 = e1.length();
        if l1 <= 0.0 {
            return (DVec2::ZERO, DVec2::ZERO, 0.0);
        }
        let x = e1 / l1;
        let r2 = DVec2::new(e2.dot(x), e2.cross(x).length());
        (DVec2::new(l1, 0.0), r2, 0.5 * l1 * r2.y)
    };
    let real_area: f64 = triangles[..n_real_triangles].iter().map(|t| flat(t).2).sum();
    let scale = if real_area > 0.0 { 1.0 / real_area.sqrt() } else { 1.0 };
    let mean_area = 1.0 / n_real_triangles.max(1) as f64;
    triangles
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let (mut r1, mut r2, mut area) = flat(t);
            r1 *= scale;
            r2 *= scale;
            area *= scale * scale;
            if area.is_nan() || area <= 1e-12 * mean_area {
                // Equilateral of the mean area.
                let side = (4.0 * mean_area / 3f64.sqrt()).sqrt();
                r1 = DVec2::new(side, 0.0);
                r2 = DVec2::new(0.5 * side, 0.5 * 3f64.sqrt() * side);
                area = mean_area;
            }
            // R = [r1 r2] (columns); R⁻¹ = adj / det.
            let det = r1.x * r2.y - r2.x * r1.y;
            let inv_rest = [r2.y / det, -r2.x / det, -r1.y / det, r1.x / det];
            let weight = if i < n_real_triangles {
                area
            } else {
                virtual_weight * area
            };
            RestTriangle { inv_rest, weight }
        })
        .collect()
}

/// `F = X R⁻¹` for layout corners `x` (row-major 2 × 2).
#[inline]
pub fn jacobian(rest: &RestTriangle, x: [DVec2; 3]) -> [f64; 4] {
    let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
    let d = rest.inv_rest;
    // X = [e1 e2] (columns); F = X D.
    [
        e1.x * d[0] + e2.x * d[2],
        e1.x * d[1] + e2.x * d[3],
        e1.y * d[0] + e2.y * d[2],
        e1.y * d[1] + e2.y * d[3],
    ]
}

/// ψ(F) per unit weight; +∞ when `det F <= 0`.
#[inline]
pub fn psi(f: [f64; 4]) -> f64 {
    let j = f[0] * f[3] - f[1] * f[2];
    if j <= 0.0 {
        return f64::INFINITY;
    }
    let i2 = f.iter().map(|x| x * x).sum::<f64>();
    i2 * (1.0 + 1.0 / (j * j))
}

/// Weighted energy, gradient (6, for the corners' x, y) and projected
/// Hessian (6 × 6, row-major) of one triangle. `None` when folded.
pub fn triangle_terms(rest: &RestTriangle, x: [DVec2; 3]) -> Option<(f64, [f64; 6], [f64; 36])> {
    let f = jacobian(rest, x);
    let (a, b, c, d) = (f[0], f[1], f[2], f[3]);
    let j = a * d - b * c;
    if j <= 0.0 {
        return None;
    }
    let i2 = a * a + b * b + c * c + d * d;
    let (j2, j3) = (j * j, j * j * j);
    let value = i2 * (1.0 + 1.0 / j2);
    // ∂J/∂F = cofactor.
    let g = [d, -c, -b, a];
    let mut grad_f = [0.0; 4];
    for k in 0..4 {
        grad_f[k] = 2.0 * f[k] * (1.0 + 1.0 / j2) - 2.0 * i2 / j3 * g[k];
    }
    // H_F = 2(1+J⁻²) I − 4J⁻³ (f gᵀ + g fᵀ) + 6 I₂ J⁻⁴ g gᵀ − 2 I₂ J⁻³ H_J.
    let mut h = [0.0f64; 16];
    for r in 0..4 {
        for s in 0..4 {
            let mut v = -4.0 / j3 * (f[r] * g[s] + g[r] * f[s]) + 6.0 * i2 / (j2 * j2) * g[r] * g[s];
            if r == s {
                v += 2.0 * (1.0 + 1.0 / j2);
            }
            h[r * 4 + s] = v;
        }
    }
    // H_J: ∂²J/∂a∂d = 1, ∂²J/∂b∂c = −1 (vec order a, b, c, d).
    let hj = 2.0 * i2 / j3;
    h[3] -= hj;
    h[12] -= hj;
    h[6] += hj;
    h[9] += hj;
    // Twist mode projection. Q, the rotation of F's polar decomposition, is
    // [[a + d, b − c], [c − b, a + d]] / r with r² = I₂ + 2J > 0; T = R₉₀ Q / √2.
    let lambda_twist = 2.0 - 2.0 * (i2 - j) / j3;
    if lambda_twist < 0.0 {
        let r = ((a + d) * (a + d) + (c - b) * (c - b)).sqrt();
        let (co, s) = ((a + d) / r, (c - b) / r);
        let t = [-s, -co, co, -s].map(|x| x / std::f64::consts::SQRT_2);
        for r in 0..4 {
            for q in 0..4 {
                h[r * 4 + q] -= lambda_twist * t[r] * t[q];
            }
        }
    }
    // vec(F) = B x: F_ij = Σ_k coef[k][j] · x_k,i (corner k, coordinate i),
    // so B's row (i, j) touches only the three x_·,i.
    let dm = rest.inv_rest;
    let coef = [[-(dm[0] + dm[2]), -(dm[1] + dm[3])], [dm[0], dm[1]], [dm[2], dm[3]]];
    let w = rest.weight;
    let mut grad = [0.0f64; 6];
    for k in 0..3 {
        for i in 0..2 {
            grad[2 * k + i] = w * (coef[k][0] * grad_f[2 * i] + coef[k][1] * grad_f[2 * i + 1]);
        }
    }
    // (H B)[(i, j)][(l, m)] = Σ_n H[(i, j)][(m, n)] coef[l][n].
    let mut hb = [[0.0f64; 6]; 4];
    for (row, hb_row) in hb.iter_mut().enumerate() {
        for l in 0..3 {
            for m in 0..2 {
                hb_row[2 * l + m] = h[row * 4 + 2 * m] * coef[l][0] + h[row * 4 + 2 * m + 1] * coef[l][1];
            }
        }
    }
    // (Bᵀ H B)[(k, i)][col] = Σ_j coef[k][j] (H B)[(i, j)][col].
    let mut hess = [0.0f64; 36];
    for (k, c) in coef.iter().enumerate() {
        for i in 0..2 {
            let p = 2 * k + i;
            for col in 0..6 {
                hess[p * 6 + col] = w * (c[0] * hb[2 * i][col] + c[1] * hb[2 * i + 1][col]);
            }
        }
    }
    Some((w * value, grad, hess))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Rng;

    fn rest() -> RestTriangle {
        let p = [DVec3::ZERO, DVec3::new(1.0, 0.1, 0.0), DVec3::new(0.3, 0.8, 0.2)];
        rest_shapes(&p, &[[0, 1, 2]], 1, 0.0)[0]
    }

    #[test]
    fn isometry_scores_four_and_is_stationary() {
        let r = rest();
        // The rest shape itself (any rotation + translation) is an isometry.
        let inv = r.inv_rest;
        let det = inv[0] * inv[3] - inv[1] * inv[2];
        let rest_m = [inv[3] / det, -inv[1] / det, -inv[2] / det, inv[0] / det];
        let x = [
            DVec2::new(0.2, 0.3),
            DVec2::new(0.2 + rest_m[0], 0.3 + rest_m[2]),
            DVec2::new(0.2 + rest_m[1], 0.3 + rest_m[3]),
        ];
        let (e, g, _) = triangle_terms(&r, x).unwrap();
        assert!((e / r.weight - 4.0).abs() < 1e-12);
        assert!(g.iter().all(|v| v.abs() < 1e-10), "{g:?}");
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let r = rest();
        let mut rng = Rng::new(4);
        for _ in 0..20 {
            let x = [
                DVec2::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1)),
                DVec2::new(rng.range(0.8, 1.2), rng.range(-0.1, 0.3)),
                DVec2::new(rng.range(0.1, 0.5), rng.range(0.5, 1.0)),
            ];
            let Some((_, g, h)) = triangle_terms(&r, x) else {
                continue;
            };
            let flat = |x: &[DVec2; 3]| [x[0].x, x[0].y, x[1].x, x[1].y, x[2].x, x[2].y];
            let unflat = |v: [f64; 6]| [DVec2::new(v[0], v[1]), DVec2::new(v[2], v[3]), DVec2::new(v[4], v[5])];
            let eps = 1e-6;
            for k in 0..6 {
                let (mut up, mut dn) = (flat(&x), flat(&x));
                up[k] += eps;
                dn[k] -= eps;
                let (eu, gu, _) = triangle_terms(&r, unflat(up)).unwrap();
                let (ed, gd, _) = triangle_terms(&r, unflat(dn)).unwrap();
                assert!(((eu - ed) / (2.0 * eps) - g[k]).abs() < 1e-5 * (1.0 + g[k].abs()));
                // Where no projection happened, the Hessian is the exact one.
                let f = jacobian(&r, x);
                let j = f[0] * f[3] - f[1] * f[2];
                let i2: f64 = f.iter().map(|v| v * v).sum();
                if 2.0 - 2.0 * (i2 - j) / (j * j * j) >= 0.0 {
                    for m in 0..6 {
                        let fd = (gu[m] - gd[m]) / (2.0 * eps);
                        assert!(
                            (fd - h[k * 6 + m]).abs() < 1e-4 * (1.0 + fd.abs()),
                            "H[{k}][{m}] {fd} vs {}",
                            h[k * 6 + m]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn projected_hessian_is_positive_semi_definite() {
        let r = rest();
        let mut rng = Rng::new(8);
        let mut projected = 0;
        for _ in 0..200 {
            // Squashed triangles make the twist mode negative.
            let x = [
                DVec2::ZERO,
                DVec2::new(rng.range(0.2, 3.0), rng.range(-0.5, 0.5)),
                DVec2::new(rng.range(-1.0, 1.0), rng.range(0.01, 0.3)),
            ];
            let Some((_, _, h)) = triangle_terms(&r, x) else {
                continue;
            };
            let f = jacobian(&r, x);
            let j = f[0] * f[3] - f[1] * f[2];
            let i2: f64 = f.iter().map(|v| v * v).sum();
            if 2.0 - 2.0 * (i2 - j) / (j * j * j) < 0.0 {
                projected += 1;
            }
            for _ in 0..20 {
                let v: Vec<f64> = (0..6).map(|_| rng.range(-1.0, 1.0)).collect();
                let q: f64 = (0..6)
                    .map(|p| (0..6).map(|m| v[p] * h[p * 6 + m] * v[m]).sum::<f64>())
                    .sum();
                assert!(
                    q >= -1e-9 * (1.0 + h.iter().map(|x| x.abs()).fold(0.0, f64::max)),
                    "vᵀHv = {q}"
                );
            }
        }
        assert!(projected > 10);
        // A folded triangle has no terms.
        assert!(triangle_terms(&r, [DVec2::ZERO, DVec2::new(0.0, 1.0), DVec2::new(1.0, 0.0)]).is_none());
    }
}
