//! The one place uvpin talks to faer's sparse Cholesky (so a faer upgrade
//! touches one file). Symbolic analysis (AMD ordering) and numeric
//! factorisation are separate: the pattern is fixed by the mesh, values change
//! with weights. Always `Par::Seq`: on 2 cores faer's parallel triangular solve
//! is 20–30× slower (crate-stack.md, F1).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{CholeskySymbolicParams, LltRef, SymbolicCholesky, factorize_symbolic_cholesky};
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Mat, Par, Side};
use std::sync::Arc;
use thiserror::Error;

/// Below this many unknowns the simplicial factorisation is used: faer's
/// supernodal analysis costs more than it saves on small charts.
const SIMPLICIAL_BELOW: usize = 20_000;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum SparseError {
    #[error("sparse pattern rejected: {0}")]
    Pattern(String),
    #[error("matrix is not positive definite (a disconnected vertex or a singular system)")]
    NotPositiveDefinite,
}

/// The fixed sparsity pattern of a symmetric matrix (lower triangle) with its
/// symbolic Cholesky analysis; shareable between numeric factorisations.
#[derive(Debug, Clone)]
pub struct SpdPattern {
    n: usize,
    symbolic: SymbolicSparseColMat<usize>,
    argsort: Arc<faer::sparse::Argsort<usize>>,
    cholesky: Arc<SymbolicCholesky<usize>>,
}

/// A numeric Cholesky factor `A = L Lᵀ` of a symmetric positive definite matrix.
#[derive(Debug, Clone)]
pub struct SpdFactor {
    pattern: SpdPattern,
    l_values: Vec<f64>,
}

impl SpdPattern {
    /// Analyses the pattern given by `entries` `(row, col)` with `row >= col`
    /// (duplicates allowed: their values are summed).
    pub fn new(n: usize, entries: &[(usize, usize)]) -> Result<Self, SparseError> {
        let pairs: Vec<Pair<usize, usize>> = entries.iter().map(|&(r, c)| Pair::new(r, c)).collect();
        let (symbolic, argsort) = SymbolicSparseColMat::<usize>::try_new_from_indices(n, n, &pairs)
            .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: if n < SIMPLICIAL_BELOW {
                SupernodalThreshold::FORCE_SIMPLICIAL
            } else {
                SupernodalThreshold::AUTO
            },
            ..Default::default()
        };
        let cholesky = factorize_symbolic_cholesky(symbolic.as_ref(), Side::Lower, Default::default(), params)
            .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        Ok(SpdPattern { n, symbolic, argsort: Arc::new(argsort), cholesky: Arc::new(cholesky) })
    }

    pub fn n(&self) -> usize {
        self.n
    }

    /// Numeric factorisation with `values` in the order of the `entries` given to [`SpdPattern::new`].
    pub fn factor(&self, values: &[f64]) -> Result<SpdFactor, SparseError> {
        let a = SparseColMat::<usize, f64>::new_from_argsort(self.symbolic.clone(), &self.argsort, values)
            .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        let mut l_values = vec![0.0f64; self.cholesky.len_val()];
        let mut mem =
            MemBuffer::new(self.cholesky.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        self.cholesky
            .factorize_numeric_llt::<f64>(
                &mut l_values,
                a.as_ref(),
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|_| SparseError::NotPositiveDefinite)?;
        Ok(SpdFactor { pattern: self.clone(), l_values })
    }
}

impl SpdFactor {
    /// Solves `A X = B` in place for the columns of `rhs` (n × k).
    pub fn solve_in_place(&self, rhs: &mut Mat<f64>) {
        let chol = &self.pattern.cholesky;
        let mut mem = MemBuffer::new(chol.solve_in_place_scratch::<f64>(rhs.ncols(), Par::Seq));
        LltRef::<usize, f64>::new(chol, &self.l_values).solve_in_place_with_conj(
            faer::Conj::No,
            rhs.as_mut(),
            Par::Seq,
            MemStack::new(&mut mem),
        );
    }

    pub fn pattern(&self) -> &SpdPattern {
        &self.pattern
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_tridiagonal_system() {
        let n = 50;
        let mut entries = Vec::new();
        let mut values = Vec::new();
        for i in 0..n {
            entries.push((i, i));
            values.push(2.0);
            if i > 0 {
                entries.push((i, i - 1));
                values.push(-1.0);
            }
        }
        // Split a diagonal entry into two duplicates: they must be summed.
        entries.push((0, 0));
        values.push(0.5);
        let pattern = SpdPattern::new(n, &entries).unwrap();
        let f = pattern.factor(&values).unwrap();
        let x_true: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut b = Mat::<f64>::zeros(n, 1);
        for i in 0..n {
            let d = if i == 0 { 2.5 } else { 2.0 };
            let mut s = d * x_true[i];
            if i > 0 {
                s -= x_true[i - 1];
            }
            if i + 1 < n {
                s -= x_true[i + 1];
            }
            b[(i, 0)] = s;
        }
        f.solve_in_place(&mut b);
        for i in 0..n {
            assert!((b[(i, 0)] - x_true[i]).abs() < 1e-12);
        }
        assert_eq!(pattern.factor(&vec![-1.0; values.len()]).unwrap_err(), SparseError::NotPositiveDefinite);
    }
}
