//! The thin-plate-spline displacement field of Eq. 6:
//! `ΔX = P(X) + Σ_i λ_i φ(‖X − C_i‖)`, `φ(r) = r² ln r`, `P` affine.
//!
//! Fitted by the null-space method: a QR factorisation of `P = [1 x y]`
//! (m × 3) splits the coefficients into `λ = Q₂ γ`, where the reduced system
//! `(Q₂ᵀ A Q₂) γ = Q₂ᵀ d` is definite (the TPS kernel is conditionally
//! definite of order 2), solved by Cholesky; then `P a = d − A λ` gives the
//! affine part. It is better conditioned than the bordered system
//! (docs/decisions.md). Both decompositions are faer's.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::solvers::{Qr, Solve, SolveLstsq};
use faer::{Conj, Mat, MatMut, MatRef, Par, Side};
use glam::DVec2;
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum TpsError {
    #[error("a thin-plate spline needs at least 3 centres, got {n}")]
    TooFewCentres { n: usize },
    #[error("the spline centres are (nearly) collinear: the affine part is undetermined")]
    CollinearCentres,
    #[error("centres {a} and {b} (nearly) coincide: the spline system is singular")]
    CoincidentCentres { a: usize, b: usize },
    #[error("centre and displacement counts differ ({centres} vs {displacements})")]
    LengthMismatch { centres: usize, displacements: usize },
}

/// `φ(r) = r² ln r` from the squared distance, with `φ(0) = 0`
/// (`r² ln r` is NaN at 0 otherwise).
#[inline]
pub fn phi_from_r2(r2: f64) -> f64 {
    if r2 > 0.0 { 0.5 * r2 * r2.ln() } else { 0.0 }
}

/// A fitted displacement field (Eq. 6).
#[derive(Debug, Clone)]
pub struct ThinPlateSpline {
    pub centres: Vec<DVec2>,
    /// `λ_i`, one 2-vector per centre.
    pub lambda: Vec<DVec2>,
    /// Affine part `P(X) = affine[0] + affine[1]·q.x + affine[2]·q.y` in the
    /// normalised coordinates `q = (X − origin) · inv_spread`.
    pub affine: [DVec2; 3],
    /// Centroid of the centres.
    pub origin: DVec2,
    /// 1 / RMS distance of the centres from `origin`; φ is evaluated on `‖q − q_i‖`.
    pub inv_spread: f64,
}

impl ThinPlateSpline {
    /// Fits the spline that displaces each `centres[i]` by `displacements[i]`
    /// exactly, by the null-space method: QR of `P`, Cholesky of the reduced
    /// kernel, then the affine part from `P a = d − A λ`.
    ///
    /// # Errors
    /// Fewer than 3 centres, collinear centres, coincident centres.
    pub fn fit(centres: &[DVec2], displacements: &[DVec2]) -> Result<Self, TpsError> {
        let m = centres.len();
        if m != displacements.len() {
            return Err(TpsError::LengthMismatch {
                centres: m,
                displacements: displacements.len(),
            });
        }
        if m < 3 {
            return Err(TpsError::TooFewCentres { n: m });
        }
        let (origin, spread) = normalisation(centres);
        let p = Mat::from_fn(m, 3, |i, j| {
            let q = (centres[i] - origin) / spread;
            [1.0, q.x, q.y][j]
        });
        let qr = p.qr();
        crate::simd::after_faer();
        check_affine_rank(qr.thin_R(), m)?;
        let a = kernel_matrix(centres, spread)?;
        let d = Mat::from_fn(m, 2, |i, j| displacements[i][j]);
        let lambda = kernel_weights(&qr, &a, &d)?;
        let affine = qr.solve_lstsq(&d - &a * &lambda);
        crate::simd::after_faer();
        Ok(ThinPlateSpline {
            centres: centres.to_vec(),
            lambda: (0..m).map(|i| DVec2::new(lambda[(i, 0)], lambda[(i, 1)])).collect(),
            affine: [0, 1, 2].map(|k| DVec2::new(affine[(k, 0)], affine[(k, 1)])),
            origin,
            inv_spread: 1.0 / spread,
        })
    }

    /// The Jacobian `∇ΔX` at `x` as its two columns (∂ΔX/∂x, ∂ΔX/∂y). With
    /// `φ(ρ) = ½ ρ² ln ρ²` on normalised distances, `∂φ/∂x = (ln ρ² + 1)(x − c) s²`.
    /// The paper's foldover condition (Eq. 5/7) asks `det(I + t ∇ΔX) > 0`.
    pub fn jacobian(&self, x: DVec2) -> [DVec2; 2] {
        let s = self.inv_spread;
        let s2 = s * s;
        let mut dx = self.affine[1] * s;
        let mut dy = self.affine[2] * s;
        for (c, l) in self.centres.iter().zip(&self.lambda) {
            let r = x - *c;
            let rho2 = r.length_squared() * s2;
            if rho2 > 0.0 {
                let g = (rho2.ln() + 1.0) * s2;
                dx += *l * (g * r.x);
                dy += *l * (g * r.y);
            }
        }
        [dx, dy]
    }

    /// The displacement ΔX at `x` (Eq. 6).
    #[inline]
    pub fn displacement(&self, x: DVec2) -> DVec2 {
        let q = (x - self.origin) * self.inv_spread;
        let s2 = self.inv_spread * self.inv_spread;
        let mut d = self.affine[0] + self.affine[1] * q.x + self.affine[2] * q.y;
        for (c, l) in self.centres.iter().zip(&self.lambda) {
            d += *l * phi_from_r2(x.distance_squared(*c) * s2);
        }
        d
    }
}

/// Centres evaluated together in [`ThinPlateSpline::displacements`]: four
/// f64 lanes, one AVX2 register.
const LANES: usize = 4;

impl ThinPlateSpline {
    /// The displacement ΔX (Eq. 6) at `layout[v]` for every `v` of
    /// `vertices`: the same sum as [`ThinPlateSpline::displacement`], with
    /// the kernel evaluated four centres at a time through [`ln_normal`]
    /// (branch-free, so the loop vectorises; AVX2 when the CPU has it). The
    /// spline path spends most of its time here, most of that in `ln`.
    pub fn displacements(&self, layout: &[DVec2], vertices: &[u32]) -> Vec<DVec2> {
        let padded = self.centres.len().div_ceil(LANES) * LANES;
        let mut soa = vec![0.0f64; 4 * padded];
        let (cx, rest) = soa.split_at_mut(padded);
        let (cy, rest) = rest.split_at_mut(padded);
        let (lx, ly) = rest.split_at_mut(padded);
        // Padding: zero weight at the origin (its φ is finite, so adds 0).
        for (i, (c, l)) in self.centres.iter().zip(&self.lambda).enumerate() {
            (cx[i], cy[i], lx[i], ly[i]) = (c.x, c.y, l.x, l.y);
        }
        let kernel = Kernel { cx, cy, lx, ly };
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above).
            return unsafe { displacements_avx2(self, &kernel, layout, vertices) };
        }
        displacements_with(self, &kernel, layout, vertices)
    }
}

/// Centres and weights as separate arrays, padded to a multiple of [`LANES`].
struct Kernel<'a> {
    cx: &'a [f64],
    cy: &'a [f64],
    lx: &'a [f64],
    ly: &'a [f64],
}

/// [`displacements_with`] in AVX2 registers, four centres at a time: the
/// same operations in the same order (no fused multiply-add), so the result
/// is bit for bit the portable one.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn displacements_avx2(spline: &ThinPlateSpline, kernel: &Kernel, layout: &[DVec2], vertices: &[u32]) -> Vec<DVec2> {
    use std::arch::x86_64::*;
    let s2 = _mm256_set1_pd(spline.inv_spread * spline.inv_spread);
    let n_chunks = kernel.cx.len() / LANES;
    let load = |values: &[f64], chunk: usize| -> __m256d {
        let lanes: &[f64; LANES] = values[chunk * LANES..][..LANES].try_into().expect("a full chunk");
        // SAFETY: `lanes` is four readable f64 (unaligned loads allowed).
        unsafe { _mm256_loadu_pd(lanes.as_ptr()) }
    };
    let lanes_of = |v: __m256d| -> [f64; LANES] {
        let mut out = [0.0f64; LANES];
        // SAFETY: `out` is four writable f64 (unaligned stores allowed).
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
        out
    };
    let mut out = Vec::with_capacity(vertices.len());
    for &v in vertices {
        let x = layout[v as usize];
        let (px, py) = (_mm256_set1_pd(x.x), _mm256_set1_pd(x.y));
        let (mut sum_x, mut sum_y) = (_mm256_setzero_pd(), _mm256_setzero_pd());
        for chunk in 0..n_chunks {
            let dx = _mm256_sub_pd(px, load(kernel.cx, chunk));
            let dy = _mm256_sub_pd(py, load(kernel.cy, chunk));
            let r2 = _mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), s2);
            let phi = phi_avx2(r2);
            sum_x = _mm256_add_pd(sum_x, _mm256_mul_pd(load(kernel.lx, chunk), phi));
            sum_y = _mm256_add_pd(sum_y, _mm256_mul_pd(load(kernel.ly, chunk), phi));
        }
        out.push(finish(spline, x, lanes_of(sum_x), lanes_of(sum_y)));
    }
    out
}

/// [`phi_branch_free`] on four lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn phi_avx2(r2: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let ln = ln_avx2(_mm256_max_pd(r2, _mm256_set1_pd(f64::MIN_POSITIVE)));
    let phi = _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(0.5), r2), ln);
    _mm256_and_pd(phi, _mm256_cmp_pd::<_CMP_GT_OQ>(r2, _mm256_setzero_pd()))
}

/// [`ln_normal`] on four lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn ln_avx2(x: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let c = _mm256_set1_pd;
    let bits = _mm256_castpd_si256(x);
    let exponent = _mm256_or_si256(
        _mm256_srli_epi64::<52>(bits),
        _mm256_set1_epi64x(TWO_52.to_bits() as i64),
    );
    let biased = _mm256_sub_pd(_mm256_castsi256_pd(exponent), c(TWO_52));
    let mantissa = _mm256_or_si256(
        _mm256_and_si256(bits, _mm256_set1_epi64x(MANTISSA_BITS as i64)),
        _mm256_set1_epi64x(1f64.to_bits() as i64),
    );
    let m = _mm256_castsi256_pd(mantissa);
    let high = _mm256_cmp_pd::<_CMP_GT_OQ>(m, c(std::f64::consts::SQRT_2));
    let m = _mm256_blendv_pd(m, _mm256_mul_pd(c(0.5), m), high);
    let k = _mm256_add_pd(_mm256_sub_pd(biased, c(1023.0)), _mm256_and_pd(high, c(1.0)));
    let f = _mm256_sub_pd(m, c(1.0));
    let s = _mm256_div_pd(f, _mm256_add_pd(c(2.0), f));
    let z = _mm256_mul_pd(s, s);
    let w = _mm256_mul_pd(z, z);
    let (mul, add, sub) = (_mm256_mul_pd, _mm256_add_pd, _mm256_sub_pd);
    let t1 = mul(w, add(c(LG[1]), mul(w, add(c(LG[3]), mul(w, c(LG[5]))))));
    let t2 = mul(
        z,
        add(c(LG[0]), mul(w, add(c(LG[2]), mul(w, add(c(LG[4]), mul(w, c(LG[6]))))))),
    );
    let r = add(t2, t1);
    let hfsq = mul(mul(c(0.5), f), f);
    sub(
        mul(k, c(LN2_HI)),
        sub(sub(hfsq, add(mul(s, add(hfsq, r)), mul(k, c(LN2_LO)))), f),
    )
}

/// Sum of the lanes (in a fixed order) plus the affine part.
#[inline(always)]
fn finish(spline: &ThinPlateSpline, x: DVec2, sum_x: [f64; LANES], sum_y: [f64; LANES]) -> DVec2 {
    let q = (x - spline.origin) * spline.inv_spread;
    let affine = spline.affine[0] + spline.affine[1] * q.x + spline.affine[2] * q.y;
    affine
        + DVec2::new(
            (sum_x[0] + sum_x[1]) + (sum_x[2] + sum_x[3]),
            (sum_y[0] + sum_y[1]) + (sum_y[2] + sum_y[3]),
        )
}

/// The portable evaluation: per lane, the kernel sum over the centres.
fn displacements_with(spline: &ThinPlateSpline, kernel: &Kernel, layout: &[DVec2], vertices: &[u32]) -> Vec<DVec2> {
    let s2 = spline.inv_spread * spline.inv_spread;
    let n_chunks = kernel.cx.len() / LANES;
    let mut out = Vec::with_capacity(vertices.len());
    for &v in vertices {
        let x = layout[v as usize];
        let (mut sum_x, mut sum_y) = ([0.0f64; LANES], [0.0f64; LANES]);
        for chunk in 0..n_chunks {
            for k in 0..LANES {
                let at = chunk * LANES + k;
                let (dx, dy) = (x.x - kernel.cx[at], x.y - kernel.cy[at]);
                let phi = phi_branch_free((dx * dx + dy * dy) * s2);
                sum_x[k] += kernel.lx[at] * phi;
                sum_y[k] += kernel.ly[at] * phi;
            }
        }
        out.push(finish(spline, x, sum_x, sum_y));
    }
    out
}

/// `φ = ½ ρ² ln ρ²` from `ρ²`, 0 at 0, without branches.
#[inline(always)]
fn phi_branch_free(r2: f64) -> f64 {
    let phi = 0.5 * r2 * ln_normal(r2.max(f64::MIN_POSITIVE));
    if r2 > 0.0 { phi } else { 0.0 }
}

// fdlibm's constants, digit for digit as published (f64 rounds the tails).
#[allow(clippy::excessive_precision)]
const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-1;
#[allow(clippy::excessive_precision)]
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
/// fdlibm's `Lg1` … `Lg7`.
#[allow(clippy::excessive_precision)]
const LG: [f64; 7] = [
    6.666_666_666_666_735_130e-1,
    3.999_999_999_940_941_908e-1,
    2.857_142_874_366_239_149e-1,
    2.222_219_843_214_978_396e-1,
    1.818_357_216_161_805_012e-1,
    1.531_383_769_920_937_332e-1,
    1.479_819_860_511_658_591e-1,
];
/// 2^52: or-ed under the exponent bits, it reads them as a float (no integer
/// conversion, which AVX2 lacks for 64-bit lanes).
const TWO_52: f64 = 4_503_599_627_370_496.0;
const MANTISSA_BITS: u64 = 0x000F_FFFF_FFFF_FFFF;

/// Natural logarithm of a positive normal `x` (fdlibm's `__ieee754_log`
/// reduction and polynomial, under 1 ulp), written without branches so that
/// a loop over it vectorises: `x = 2^k m`, `m ∈ [√½, √2)`, `f = m − 1`,
/// `s = f / (2 + f)`, `ln(1 + f) = f − ½f² + s (½f² + R(s²))`.
#[inline(always)]
pub fn ln_normal(x: f64) -> f64 {
    let bits = x.to_bits();
    let biased = f64::from_bits((bits >> 52) | TWO_52.to_bits()) - TWO_52;
    let m = f64::from_bits((bits & MANTISSA_BITS) | 1f64.to_bits());
    let high = m > std::f64::consts::SQRT_2;
    let m = if high { 0.5 * m } else { m };
    let k = biased - 1023.0 + if high { 1.0 } else { 0.0 };
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG[1] + w * (LG[3] + w * LG[5]));
    let t2 = z * (LG[0] + w * (LG[2] + w * (LG[4] + w * LG[6])));
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    k * LN2_HI - ((hfsq - (s * (hfsq + r) + k * LN2_LO)) - f)
}

/// The centroid of `centres` and their RMS distance from it: the spline
/// works in coordinates `(x − origin) / spread`, for the conditioning of `P`.
fn normalisation(centres: &[DVec2]) -> (DVec2, f64) {
    let m = centres.len() as f64;
    let c = centres.iter().copied().sum::<DVec2>() / m;
    let s = centres.iter().map(|p| p.distance_squared(c)).sum::<f64>() / m;
    (c, s.sqrt().max(f64::MIN_POSITIVE))
}

/// Whether `P = [1 x y]` has full column rank, from its `R` factor: the
/// affine part is undetermined when the centres are (nearly) collinear.
fn check_affine_rank(r: MatRef<'_, f64>, m: usize) -> Result<(), TpsError> {
    let column_collapses = (0..3).any(|k| r[(k, k)].abs() < 1e-10 * (m as f64).sqrt());
    if column_collapses || r[(2, 2)].abs() < 1e-8 * r[(0, 0)].abs() {
        return Err(TpsError::CollinearCentres);
    }
    Ok(())
}

/// The kernel matrix `A_ij = φ(‖q_i − q_j‖)` on normalised coordinates.
fn kernel_matrix(centres: &[DVec2], spread: f64) -> Result<Mat<f64>, TpsError> {
    let m = centres.len();
    // Filled as a plain column-major buffer (symmetric, so either order).
    let mut values = vec![0.0f64; m * m];
    for i in 0..m {
        for j in 0..i {
            let r2 = ((centres[i] - centres[j]) / spread).length_squared();
            if r2 < 1e-24 {
                return Err(TpsError::CoincidentCentres { a: j, b: i });
            }
            let phi = phi_from_r2(r2);
            values[i * m + j] = phi;
            values[j * m + i] = phi;
        }
    }
    Ok(MatRef::from_column_major_slice(&values, m, m).to_owned())
}

/// `x ← Qᵀ x` (`transpose`) or `x ← Q x`, with `Q` of `qr` applied as its
/// three Householder reflectors (O(m) per column, no m × m product).
fn apply_q(qr: &Qr<f64>, mut x: MatMut<'_, f64>, transpose: bool) {
    use faer::linalg::householder::{
        apply_block_householder_sequence_on_the_left_in_place_scratch as scratch,
        apply_block_householder_sequence_on_the_left_in_place_with_conj as apply,
        apply_block_householder_sequence_transpose_on_the_left_in_place_scratch as scratch_t,
        apply_block_householder_sequence_transpose_on_the_left_in_place_with_conj as apply_t,
    };
    let (basis, coeff) = (qr.Q_basis(), qr.Q_coeff());
    let (rows, block, cols) = (basis.nrows(), coeff.nrows(), x.ncols());
    let need = if transpose {
        scratch_t::<f64>(rows, block, cols)
    } else {
        scratch::<f64>(rows, block, cols)
    };
    let mut memory = MemBuffer::new(need);
    let stack = MemStack::new(&mut memory);
    if transpose {
        apply_t(basis, coeff, Conj::No, x.as_mut(), Par::Seq, stack);
    } else {
        apply(basis, coeff, Conj::No, x.as_mut(), Par::Seq, stack);
    }
}

/// The kernel weights `λ = Q₂ γ` with `(Q₂ᵀ A Q₂) γ = Q₂ᵀ d`, where `Q₂`
/// spans the null space of `Pᵀ` (the last `m − 3` columns of `Q`). The
/// reduced kernel is definite (the TPS kernel is conditionally definite of
/// order 2); which sign depends on the scaling, so both are tried.
fn kernel_weights(qr: &Qr<f64>, a: &Mat<f64>, d: &Mat<f64>) -> Result<Mat<f64>, TpsError> {
    let m = a.nrows();
    if m == 3 {
        return Ok(Mat::zeros(3, 2));
    }
    // Qᵀ A Q = Qᵀ (Qᵀ A)ᵀ, A being symmetric.
    let mut qt_a = a.clone();
    apply_q(qr, qt_a.as_mut(), true);
    let mut both = qt_a.transpose().to_owned();
    apply_q(qr, both.as_mut(), true);
    let reduced = both.get(3.., 3..);
    let mut qt_d = d.clone();
    apply_q(qr, qt_d.as_mut(), true);
    let rhs = qt_d.get(3.., ..);
    let gamma = match reduced.llt(Side::Lower) {
        Ok(llt) => llt.solve(rhs),
        Err(_) => {
            let negated = -reduced;
            let llt = negated
                .llt(Side::Lower)
                .map_err(|_| TpsError::CoincidentCentres { a: 0, b: 0 })?;
            -llt.solve(rhs)
        }
    };
    let mut lambda = Mat::<f64>::zeros(m, 2);
    lambda.get_mut(3.., ..).copy_from(&gamma);
    apply_q(qr, lambda.as_mut(), false);
    Ok(lambda)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Rng;

    #[test]
    fn the_jacobian_matches_finite_differences() {
        let centres = [
            DVec2::new(0.1, 0.2),
            DVec2::new(0.8, 0.1),
            DVec2::new(0.5, 0.9),
            DVec2::new(0.4, 0.4),
            DVec2::new(0.9, 0.7),
        ];
        let d = [
            DVec2::new(0.02, -0.01),
            DVec2::ZERO,
            DVec2::new(-0.03, 0.02),
            DVec2::new(0.05, 0.04),
            DVec2::ZERO,
        ];
        let spline = ThinPlateSpline::fit(&centres, &d).unwrap();
        let h = 1e-6;
        for x in [DVec2::new(0.3, 0.6), DVec2::new(0.41, 0.39), DVec2::new(0.7, 0.2)] {
            let [jx, jy] = spline.jacobian(x);
            let fx = (spline.displacement(x + DVec2::X * h) - spline.displacement(x - DVec2::X * h)) / (2.0 * h);
            let fy = (spline.displacement(x + DVec2::Y * h) - spline.displacement(x - DVec2::Y * h)) / (2.0 * h);
            assert!(
                (jx - fx).length() < 1e-7 && (jy - fy).length() < 1e-7,
                "{jx} {fx} {jy} {fy}"
            );
        }
    }

    #[test]
    fn branch_free_ln_matches_the_library_ln() {
        let mut rng = Rng::new(7);
        let mut worst = 0.0f64;
        let mut check = |x: f64| {
            let (ours, libm) = (ln_normal(x), x.ln());
            // Relative to |ln x|, or absolute near x = 1 where ln x → 0.
            let err = (ours - libm).abs() / libm.abs().max(1.0);
            worst = worst.max(err);
        };
        for _ in 0..20_000 {
            check(10f64.powf(rng.range(-300.0, 300.0)));
            check(1.0 + rng.range(-0.3, 0.3));
        }
        for x in [
            f64::MIN_POSITIVE,
            0.5,
            1.0,
            std::f64::consts::SQRT_2,
            2.0,
            1e-12,
            f64::MAX,
        ] {
            check(x);
        }
        assert!(worst < 5e-16, "worst relative error {worst:e}");
        assert_eq!(ln_normal(1.0), 0.0);
    }

    #[test]
    fn batch_displacements_match_one_at_a_time() {
        let mut rng = Rng::new(11);
        // 13 centres: not a multiple of the lane count, so padding is exercised.
        let centres: Vec<DVec2> = (0..13)
            .map(|_| DVec2::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0)))
            .collect();
        let displacements: Vec<DVec2> = (0..13)
            .map(|_| DVec2::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1)))
            .collect();
        let spline = ThinPlateSpline::fit(&centres, &displacements).unwrap();
        let mut layout: Vec<DVec2> = (0..500)
            .map(|_| DVec2::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0)))
            .collect();
        layout.extend_from_slice(&centres); // φ(0) at the centres themselves
        let vertices: Vec<u32> = (0..layout.len() as u32).rev().collect();
        let batch = spline.displacements(&layout, &vertices);
        for (&v, d) in vertices.iter().zip(&batch) {
            let one = spline.displacement(layout[v as usize]);
            assert!((*d - one).length() <= 1e-14, "vertex {v}: {d} against {one}");
        }
        // The AVX2 path (where the CPU has it) is bit for bit the portable one.
        let padded = centres.len().div_ceil(LANES) * LANES;
        let mut soa = vec![0.0; 4 * padded];
        for (i, (c, l)) in centres.iter().zip(&spline.lambda).enumerate() {
            (soa[i], soa[padded + i], soa[2 * padded + i], soa[3 * padded + i]) = (c.x, c.y, l.x, l.y);
        }
        let kernel = Kernel {
            cx: &soa[..padded],
            cy: &soa[padded..2 * padded],
            lx: &soa[2 * padded..3 * padded],
            ly: &soa[3 * padded..],
        };
        let portable = displacements_with(&spline, &kernel, &layout, &vertices);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above).
            assert_eq!(portable, unsafe {
                displacements_avx2(&spline, &kernel, &layout, &vertices)
            });
        }
        assert_eq!(portable, batch);
        for (c, d) in centres.iter().zip(&displacements) {
            let at = spline.displacements(&[*c], &[0])[0];
            assert!((at - *d).length() < 1e-10);
        }
    }

    #[test]
    fn phi_is_zero_at_the_centre() {
        assert_eq!(phi_from_r2(0.0), 0.0);
        assert!((phi_from_r2(std::f64::consts::E * std::f64::consts::E) - std::f64::consts::E.powi(2)).abs() < 1e-12);
    }

    #[test]
    fn reproduces_an_affine_map_exactly() {
        let mut rng = Rng::new(3);
        let centres: Vec<DVec2> = (0..12).map(|_| DVec2::new(rng.f64(), rng.f64())).collect();
        let map = |p: DVec2| DVec2::new(0.3 * p.x - 0.2 * p.y + 0.05, 0.1 * p.x + 0.4 * p.y - 0.02);
        let disp: Vec<DVec2> = centres.iter().map(|&c| map(c)).collect();
        let tps = ThinPlateSpline::fit(&centres, &disp).unwrap();
        for l in &tps.lambda {
            assert!(l.length() < 1e-10, "non-affine part {l:?}");
        }
        for _ in 0..50 {
            let x = DVec2::new(rng.range(-0.5, 1.5), rng.range(-0.5, 1.5));
            assert!((tps.displacement(x) - map(x)).length() < 1e-12);
        }
    }

    #[test]
    fn interpolates_arbitrary_displacements() {
        let mut rng = Rng::new(11);
        for m in [3, 4, 7, 40, 150] {
            let centres: Vec<DVec2> = (0..m).map(|_| DVec2::new(rng.f64(), rng.f64())).collect();
            let disp: Vec<DVec2> = (0..m)
                .map(|_| DVec2::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1)))
                .collect();
            let tps = ThinPlateSpline::fit(&centres, &disp).unwrap();
            for (c, d) in centres.iter().zip(&disp) {
                assert!((tps.displacement(*c) - *d).length() < 1e-10, "m = {m}");
            }
        }
    }

    #[test]
    fn degenerate_centre_sets_are_errors() {
        let two = [DVec2::ZERO, DVec2::ONE];
        assert_eq!(
            ThinPlateSpline::fit(&two, &two).unwrap_err(),
            TpsError::TooFewCentres { n: 2 }
        );
        let line: Vec<DVec2> = (0..5).map(|i| DVec2::splat(i as f64)).collect();
        assert_eq!(
            ThinPlateSpline::fit(&line, &line).unwrap_err(),
            TpsError::CollinearCentres
        );
        let dup = [DVec2::ZERO, DVec2::X, DVec2::Y, DVec2::X];
        assert!(matches!(
            ThinPlateSpline::fit(&dup, &dup).unwrap_err(),
            TpsError::CoincidentCentres { .. }
        ));
    }
}
