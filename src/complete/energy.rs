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

use glam::{DMat2, DVec2, DVec3};

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
    let (value, grad_f, h) = psi_terms(jacobian(rest, x))?;
    Some(pull_back(rest, value, &grad_f, &h))
}

/// Weighted energy, gradient and projected Hessian (`[h_xx, h_xy, h_yy]`)
/// of one triangle with respect to corner `k` alone (the others held): a
/// vertex's share of [`triangle_terms`], for local sweeps. `None` when folded.
pub fn corner_terms(rest: &RestTriangle, x: [DVec2; 3], k: usize) -> Option<(f64, DVec2, [f64; 3])> {
    let f = jacobian(rest, x);
    let (a, b, c, d) = (f[0], f[1], f[2], f[3]);
    let j = a * d - b * c;
    if j <= 0.0 {
        return None;
    }
    let dm = rest.inv_rest;
    // ∂F_ij/∂x_k,i = e_j (see `pull_back`): a 4-vector `v` of F's order
    // seen by corner k is (e·v[0..2], e·v[2..4]).
    let e = [[-(dm[0] + dm[2]), -(dm[1] + dm[3])], [dm[0], dm[1]], [dm[2], dm[3]]][k];
    let seen = |v: [f64; 4]| DVec2::new(e[0] * v[0] + e[1] * v[1], e[0] * v[2] + e[1] * v[3]);
    let i2 = a * a + b * b + c * c + d * d;
    let (inv_j2, inv_j3) = (1.0 / (j * j), 1.0 / (j * j * j));
    let (fs, gs) = (seen(f), seen([d, -c, -b, a]));
    // The terms of `psi_terms`' H_F seen by one corner: 2(1+J⁻²) I,
    // −4J⁻³ (f gᵀ + g fᵀ), 6 I₂ J⁻⁴ g gᵀ; H_J adds nothing (the area is
    // linear in one corner), and the twist mode is projected as there.
    let mut hess = DMat2::from_diagonal(DVec2::splat(2.0 * (1.0 + inv_j2) * (e[0] * e[0] + e[1] * e[1])))
        - 4.0 * inv_j3 * (outer(fs, gs) + outer(gs, fs))
        + 6.0 * i2 * inv_j2 * inv_j2 * outer(gs, gs);
    if let Some((lambda_twist, t)) = twist_mode(f, i2, j) {
        let ts = seen(t);
        hess -= lambda_twist * outer(ts, ts);
    }
    let w = rest.weight;
    let grad = (2.0 * (1.0 + inv_j2) * fs - 2.0 * i2 * inv_j3 * gs) * w;
    let value = i2 * (1.0 + inv_j2);
    Some((
        w * value,
        grad,
        [w * hess.x_axis.x, w * hess.y_axis.x, w * hess.y_axis.y],
    ))
}

/// The twist mode of `F` (invariants `i2` = I₂, `j` = J) when its
/// eigenvalue `λ_t = 2 − 2 (I₂ − J) / J³` is negative: `λ_t` and
/// `T = R₉₀ Q / √2` (vec order a, b, c, d), Q the rotation of F's polar
/// decomposition, `[[a + d, b − c], [c − b, a + d]] / r`, r² = I₂ + 2J > 0.
pub(crate) fn twist_mode(f: [f64; 4], i2: f64, j: f64) -> Option<(f64, [f64; 4])> {
    let (a, b, c, d) = (f[0], f[1], f[2], f[3]);
    let lambda_twist = 2.0 - 2.0 * (i2 - j) / (j * j * j);
    if lambda_twist >= 0.0 {
        return None;
    }
    let r = ((a + d) * (a + d) + (c - b) * (c - b)).sqrt();
    let (co, s) = ((a + d) / r, (c - b) / r);
    Some((lambda_twist, [-s, -co, co, -s].map(|x| x / std::f64::consts::SQRT_2)))
}

/// `p qᵀ`.
fn outer(p: DVec2, q: DVec2) -> DMat2 {
    DMat2::from_cols(p * q.x, p * q.y)
}

/// ψ per unit area at `F`, its gradient and its Hessian (vec order a, b,
/// c, d; row-major 4 × 4), the twist mode projected to keep it positive
/// semi-definite. `None` when `det F <= 0`.
fn psi_terms(f: [f64; 4]) -> Option<(f64, [f64; 4], [f64; 16])> {
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
    if let Some((lambda_twist, t)) = twist_mode(f, i2, j) {
        for r in 0..4 {
            for q in 0..4 {
                h[r * 4 + q] -= lambda_twist * t[r] * t[q];
            }
        }
    }
    Some((value, grad_f, h))
}

/// One triangle's energy per unit area `value`, its gradient `grad_f` and
/// Hessian `h` with respect to `F` (vec order a, b, c, d), as the weighted
/// energy, gradient and Hessian with respect to the corners (`F = X R⁻¹`).
fn pull_back(rest: &RestTriangle, value: f64, grad_f: &[f64; 4], h: &[f64; 16]) -> (f64, [f64; 6], [f64; 36]) {
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
    (w * value, grad, hess)
}

/// The least-squares conformal energy of one triangle (Lévy et al. 2002):
/// `½ ‖F‖² − det F` per unit area, zero exactly when `F` is a similarity;
/// quadratic in the corners, so its Hessian is constant and positive
/// semi-definite. Defined for folded triangles too.
pub fn conformal_terms(rest: &RestTriangle, x: [DVec2; 3]) -> Option<(f64, [f64; 6], [f64; 36])> {
    let f = jacobian(rest, x);
    let (a, b, c, d) = (f[0], f[1], f[2], f[3]);
    let value = 0.5 * (a * a + b * b + c * c + d * d) - (a * d - b * c);
    let cofactor = [d, -c, -b, a];
    let grad_f = [a - cofactor[0], b - cofactor[1], c - cofactor[2], d - cofactor[3]];
    // H = I − H_J, H_J: ∂²J/∂a∂d = 1, ∂²J/∂b∂c = −1.
    let mut h = [0.0f64; 16];
    for k in 0..4 {
        h[k * 5] = 1.0;
    }
    h[3] = -1.0;
    h[12] = -1.0;
    h[6] = 1.0;
    h[9] = 1.0;
    Some(pull_back(rest, value, &grad_f, &h))
}

/// Progressive reference shapes (Liu et al. 2018, "Progressive
/// parameterizations"): each triangle whose energy `ψ(F)` against its rest
/// shape exceeds `cap` gets, in `out`, a reference shape part-way between
/// its rest shape and its current one, against which it scores exactly
/// `cap`; the others keep their rest shape. With `F = U Σ Vᵀ` the reference
/// makes it `F' = U Σ^(1−t) Vᵀ`: the same rotations, the stretches shrunk in
/// log space by the `t ∈ (0, 1)` that reaches the cap (`ψ(Σ^u) =
/// Σᵢ 2 cosh(2u ln σᵢ)` grows with `u = 1 − t`). The weights stay.
/// Returns how many triangles were given a reference.
pub fn progressive_rest(
    rest: &[RestTriangle],
    layout: &[DVec2],
    triangles: &[[u32; 3]],
    cap: f64,
    out: &mut Vec<RestTriangle>,
) -> usize {
    out.clear();
    out.extend_from_slice(rest);
    let mut capped = 0;
    for ((r, t), o) in rest.iter().zip(triangles).zip(out.iter_mut()) {
        let f = jacobian(r, t.map(|v| layout[v as usize]));
        if psi(f) <= cap {
            continue;
        }
        let Some((theta, s1, s2)) = right_rotation_and_stretches(f) else {
            continue;
        };
        let (l1, l2) = (s1.ln(), s2.ln());
        // ψ(Σ^u) − cap is convex and increasing in u ≥ 0, positive at u = 1:
        // Newton's method from there descends monotonically onto its root.
        let mut u = 1.0f64;
        for _ in 0..30 {
            let (a1, a2) = (2.0 * u * l1, 2.0 * u * l2);
            let excess = 2.0 * a1.cosh() + 2.0 * a2.cosh() - cap;
            let slope = 4.0 * (l1 * a1.sinh() + l2 * a2.sinh());
            if excess <= 1e-12 * cap || slope <= 0.0 {
                break;
            }
            u -= excess / slope;
        }
        // Σ^(1−t) = Σ^u: the reference takes Σ^(−t) = Σ^(u−1) off the right.
        let (k1, k2) = ((u - 1.0) * l1, (u - 1.0) * l2);
        let (k1, k2) = (k1.exp(), k2.exp());
        // V = Rot(−θ); M = V diag(k1, k2) Vᵀ (row-major).
        let (c, s) = (theta.cos(), theta.sin());
        let m = [
            c * c * k1 + s * s * k2,
            (k2 - k1) * c * s,
            (k2 - k1) * c * s,
            s * s * k1 + c * c * k2,
        ];
        let d = r.inv_rest;
        o.inv_rest = [
            d[0] * m[0] + d[1] * m[2],
            d[0] * m[1] + d[1] * m[3],
            d[2] * m[0] + d[3] * m[2],
            d[2] * m[1] + d[3] * m[3],
        ];
        capped += 1;
    }
    capped
}

/// For `F` with `det F > 0`: `θ` and `σ₁ ≥ σ₂ > 0` with
/// `F = Rot(φ) diag(σ₁, σ₂) Rot(θ)` (closed-form 2 × 2 SVD), `Rot(x)` the
/// counter-clockwise rotation by `x`.
fn right_rotation_and_stretches(f: [f64; 4]) -> Option<(f64, f64, f64)> {
    let (a, b, c, d) = (f[0], f[1], f[2], f[3]);
    let (e, g, h, k) = ((a + d) / 2.0, (a - d) / 2.0, (c + b) / 2.0, (c - b) / 2.0);
    let q = (e * e + k * k).sqrt();
    let r = (g * g + h * h).sqrt();
    let (s1, s2) = (q + r, q - r);
    (s2 > 0.0).then(|| ((k.atan2(e) - h.atan2(g)) / 2.0, s1, s2))
}

/// The factor `μ` by which to scale the rest shapes' lengths so that
/// `layout` scores least on average (energy per unit rest area): with the
/// rest scaled by `μ`, `F` becomes `F / μ` and `ψ` per unit area
/// `‖F‖²/μ² + μ²‖F⁻¹‖²`, least at `μ⁴ = Σ w‖F‖² / Σ w‖F⁻¹‖²`. Folded
/// triangles are left out; 1 when nothing is left.
pub fn best_fit_scale(rest: &[RestTriangle], layout: &[DVec2], triangles: &[[u32; 3]]) -> f64 {
    let (mut direct, mut inverse) = (0.0, 0.0);
    for (t, r) in triangles.iter().zip(rest) {
        let f = jacobian(r, t.map(|v| layout[v as usize]));
        let j = f[0] * f[3] - f[1] * f[2];
        if j <= 0.0 {
            continue;
        }
        let i2 = f.iter().map(|x| x * x).sum::<f64>();
        direct += r.weight * i2;
        inverse += r.weight * i2 / (j * j);
    }
    let mu = (direct / inverse).sqrt().sqrt();
    if mu.is_finite() && mu > 0.0 { mu } else { 1.0 }
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
    fn progressive_references_cap_the_energy_and_keep_the_rotations() {
        let r = rest();
        let mut rng = Rng::new(12);
        let (mut capped, mut kept) = (0, 0);
        for _ in 0..300 {
            // From mild to squashed and stretched, turned any way.
            let x = [
                DVec2::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1)),
                DVec2::new(rng.range(0.05, 4.0), rng.range(-0.5, 0.5)),
                DVec2::new(rng.range(-1.0, 1.0), rng.range(0.001, 1.0)),
            ];
            let f = jacobian(&r, x);
            if f[0] * f[3] - f[1] * f[2] <= 0.0 {
                continue;
            }
            let cap = 40.0;
            let mut out = Vec::new();
            let n = progressive_rest(&[r], &x, &[[0, 1, 2]], cap, &mut out);
            let g = jacobian(&out[0], x);
            assert_eq!(out[0].weight, r.weight);
            if psi(f) <= cap {
                kept += 1;
                assert_eq!(n, 0);
                assert_eq!(out[0], r);
                continue;
            }
            capped += 1;
            assert_eq!(n, 1);
            assert!((psi(g) - cap).abs() < 1e-6 * cap, "ψ {} against the reference", psi(g));
            // Same rotations: F' = U Σ^u Vᵀ shares U and V with F = U Σ Vᵀ,
            // so F F'⁻¹ = U Σ^(1−u) Uᵀ is symmetric.
            let det_g = g[0] * g[3] - g[1] * g[2];
            let g_inv = [g[3] / det_g, -g[1] / det_g, -g[2] / det_g, g[0] / det_g];
            let p = [
                f[0] * g_inv[0] + f[1] * g_inv[2],
                f[0] * g_inv[1] + f[1] * g_inv[3],
                f[2] * g_inv[0] + f[3] * g_inv[2],
                f[2] * g_inv[1] + f[3] * g_inv[3],
            ];
            let scale = p.iter().map(|v| v.abs()).fold(0.0, f64::max);
            assert!((p[1] - p[2]).abs() < 1e-9 * scale, "F F'⁻¹ not symmetric: {p:?}");
            // ... and positive definite (the stretch shrinks, never flips).
            assert!(p[0] > 0.0 && p[0] * p[3] - p[1] * p[2] > 0.0, "{p:?}");
        }
        assert!(capped > 30 && kept > 30, "{capped} capped, {kept} kept");
    }

    #[test]
    fn the_closed_form_svd_rebuilds_the_matrix() {
        let mut rng = Rng::new(13);
        for _ in 0..100 {
            let f = [
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
            ];
            let Some((theta, s1, s2)) = right_rotation_and_stretches(f) else {
                assert!(f[0] * f[3] - f[1] * f[2] <= 1e-12);
                continue;
            };
            assert!(s1 >= s2 && s2 > 0.0);
            // F Rot(θ)ᵀ = Rot(φ) Σ: its columns are orthogonal with lengths σ₁, σ₂.
            let (c, s) = (theta.cos(), theta.sin());
            let col0 = DVec2::new(f[0] * c - f[1] * s, f[2] * c - f[3] * s);
            let col1 = DVec2::new(f[0] * s + f[1] * c, f[2] * s + f[3] * c);
            assert!(col0.dot(col1).abs() < 1e-9, "{f:?}");
            assert!(
                (col0.length() - s1).abs() < 1e-9 && (col1.length() - s2).abs() < 1e-9,
                "{f:?}"
            );
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
