//! The one place uvpin talks to faer's sparse Cholesky (so a faer upgrade
//! touches one file). Symbolic analysis (AMD ordering) and numeric
//! factorisation are separate: the pattern is fixed by the mesh, values change
//! with weights. Always `Par::Seq`: on 2 cores faer's parallel triangular solve
//! is 20–30× slower (crate-stack.md, F1).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{Pair, SparseColMat, SparseColMatRef, SymbolicSparseColMat};
use faer::{Mat, Par, Side};
use std::sync::Arc;
use thiserror::Error;

/// Below this many unknowns the simplicial factorisation is used: faer's
/// supernodal analysis costs more than it saves on small charts.
const SIMPLICIAL_BELOW: usize = 10_000;

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
    symbolic: Arc<SymbolicSparseColMat<usize>>,
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
    /// (duplicates allowed: their values are summed), with faer's AMD ordering.
    pub fn new(n: usize, entries: &[(usize, usize)]) -> Result<Self, SparseError> {
        Self::with_ordering(n, entries, None)
    }

    /// As [`SpdPattern::new`] with a fill-reducing elimination order
    /// (`order[k]` = the unknown eliminated k-th), e.g. from [`nested_dissection`].
    pub fn with_ordering(n: usize, entries: &[(usize, usize)], order: Option<&[usize]>) -> Result<Self, SparseError> {
        let threshold = if n < SIMPLICIAL_BELOW {
            SupernodalThreshold::FORCE_SIMPLICIAL
        } else {
            SupernodalThreshold::AUTO
        };
        Self::analyse(n, entries, order, threshold)
    }

    fn analyse(
        n: usize,
        entries: &[(usize, usize)],
        order: Option<&[usize]>,
        threshold: SupernodalThreshold,
    ) -> Result<Self, SparseError> {
        let pairs: Vec<Pair<usize, usize>> = entries.iter().map(|&(r, c)| Pair::new(r, c)).collect();
        let (symbolic, argsort) = SymbolicSparseColMat::<usize>::try_new_from_indices(n, n, &pairs)
            .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: threshold,
            ..Default::default()
        };
        let inverse: Option<Vec<usize>> = order.map(|o| {
            let mut inv = vec![0usize; o.len()];
            for (k, &i) in o.iter().enumerate() {
                inv[i] = k;
            }
            inv
        });
        let ordering = match (order, &inverse) {
            (Some(fwd), Some(inv)) => SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(fwd, inv, n)),
            _ => SymmetricOrdering::Amd,
        };
        let cholesky = factorize_symbolic_cholesky(symbolic.as_ref(), Side::Lower, ordering, params)
            .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        Ok(SpdPattern {
            n,
            symbolic: Arc::new(symbolic),
            argsort: Arc::new(argsort),
            cholesky: Arc::new(cholesky),
        })
    }

    /// The pattern of a symmetric matrix made of `block × block` blocks over
    /// `n_nodes` nodes (unknown `block · node + k`), coupled where
    /// `node_pairs` `(a, b)` says so (either order; diagonal blocks always).
    /// The elimination order is minimum degree on the node graph, each
    /// node's unknowns kept together: less fill, and far cheaper to analyse,
    /// than minimum degree on the unknowns. Assemble values in place with
    /// [`SpdPattern::slot`] and factor with [`SpdPattern::factor_assembled`].
    pub fn new_blocked(n_nodes: usize, block: usize, node_pairs: &[(u32, u32)]) -> Result<Self, SparseError> {
        let pattern_error = |e: &dyn std::fmt::Debug| SparseError::Pattern(format!("{e:?}"));
        let mut nodes: Vec<Pair<usize, usize>> = (0..n_nodes).map(|v| Pair::new(v, v)).collect();
        nodes.extend(node_pairs.iter().map(|&(a, b)| {
            let (a, b) = (a.max(b) as usize, a.min(b) as usize);
            Pair::new(a, b)
        }));
        let (node_graph, _) = SymbolicSparseColMat::<usize>::try_new_from_indices(n_nodes, n_nodes, &nodes)
            .map_err(|e| pattern_error(&e))?;
        let mut node_order = vec![0usize; n_nodes];
        let mut node_rank = vec![0usize; n_nodes];
        let mut mem = MemBuffer::new(amd::order_scratch::<usize>(n_nodes, node_graph.compute_nnz()));
        amd::order(
            &mut node_order,
            &mut node_rank,
            node_graph.as_ref(),
            amd::Control::default(),
            MemStack::new(&mut mem),
        )
        .map_err(|e| pattern_error(&e))?;
        let n = n_nodes * block;
        let mut entries = Vec::with_capacity(node_graph.compute_nnz() * block * block);
        for col in 0..n_nodes {
            for &row in node_graph.row_idx_of_col_raw(col) {
                for a in 0..block {
                    for b in 0..block {
                        let (r, c) = (block * row + a, block * col + b);
                        if r >= c {
                            entries.push((r, c));
                        }
                    }
                }
            }
        }
        let order: Vec<usize> = node_order
            .iter()
            .flat_map(|&v| (0..block).map(move |k| block * v + k))
            .collect();
        Self::analyse(n, &entries, Some(&order), SupernodalThreshold::FORCE_SUPERNODAL)
    }

    /// Where entry `(row, col)` (`row >= col`) sits in the values of
    /// [`SpdPattern::factor_assembled`]; `None` outside the pattern.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let start = self.symbolic.col_ptr()[col];
        self.symbolic
            .row_idx_of_col_raw(col)
            .binary_search(&row)
            .ok()
            .map(|k| start + k)
    }

    /// How many values [`SpdPattern::factor_assembled`] takes.
    pub fn n_values(&self) -> usize {
        self.symbolic.row_idx().len()
    }

    /// Numeric factorisation of values already in the pattern's own order
    /// (see [`SpdPattern::slot`]): no sorting, no summing of duplicates.
    pub fn factor_assembled(&self, values: &[f64]) -> Result<SpdFactor, SparseError> {
        self.factor_matrix(SparseColMatRef::new((*self.symbolic).as_ref(), values))
    }

    pub fn n(&self) -> usize {
        self.n
    }

    /// Numeric factorisation with `values` in the order of the `entries` given to [`SpdPattern::new`].
    pub fn factor(&self, values: &[f64]) -> Result<SpdFactor, SparseError> {
        let a = SparseColMat::<usize, f64>::new_from_argsort((*self.symbolic).clone(), &self.argsort, values)
            .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        self.factor_matrix(a.as_ref())
    }

    fn factor_matrix(&self, a: SparseColMatRef<'_, usize, f64>) -> Result<SpdFactor, SparseError> {
        let mut l_values = vec![0.0f64; self.cholesky.len_val()];
        let mut mem = MemBuffer::new(
            self.cholesky
                .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        );
        self.cholesky
            .factorize_numeric_llt::<f64>(
                &mut l_values,
                a,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|_| SparseError::NotPositiveDefinite)?;
        Ok(SpdFactor {
            pattern: self.clone(),
            l_values,
        })
    }
}

impl SpdFactor {
    /// Solves `A X = B` in place for the columns of `rhs` (n × k).
    pub fn solve_in_place(&self, rhs: &mut Mat<f64>) {
        self.solve_columns(rhs.as_mut());
    }

    /// Solves `A x = b` in place for one column `b`.
    pub fn solve_column(&self, b: &mut [f64]) {
        let n = b.len();
        self.solve_columns(faer::MatMut::from_column_major_slice_mut(b, n, 1));
    }

    fn solve_columns(&self, rhs: faer::MatMut<'_, f64>) {
        let chol = &self.pattern.cholesky;
        let mut mem = MemBuffer::new(chol.solve_in_place_scratch::<f64>(rhs.ncols(), Par::Seq));
        LltRef::<usize, f64>::new(chol, &self.l_values).solve_in_place_with_conj(
            faer::Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut mem),
        );
    }

    pub fn pattern(&self) -> &SpdPattern {
        &self.pattern
    }
}

/// Leaves of the dissection at most this big are ordered as they come.
const DISSECTION_LEAF: usize = 96;

/// Geometric nested dissection: an elimination order for a mesh Laplacian
/// from its vertices' 3D positions. Each set is split at the median of its
/// widest axis; the vertices of one half that touch the other form the
/// separator, eliminated after both halves. On planar-like meshes this gives
/// far less fill than minimum degree and costs O(n log n).
///
/// `neighbours(i)` lists the unknowns coupled to unknown `i`.
pub fn nested_dissection<'a>(points: &[[f64; 3]], neighbours: impl Fn(usize) -> &'a [u32]) -> Vec<usize> {
    let n = points.len();
    let mut order = Vec::with_capacity(n);
    // side[v]: which part of the current split v belongs to, tagged by split id.
    let mut side: Vec<(u32, bool)> = vec![(u32::MAX, false); n];
    let mut split_id = 0u32;
    // Work stack: a set to order, or a separator to emit once its halves are done.
    enum Work {
        Order(Vec<u32>),
        Emit(Vec<u32>),
    }
    let mut stack = vec![Work::Order((0..n as u32).collect())];
    while let Some(work) = stack.pop() {
        let mut set = match work {
            Work::Emit(sep) => {
                order.extend(sep.iter().map(|&v| v as usize));
                continue;
            }
            Work::Order(set) => set,
        };
        if set.len() <= DISSECTION_LEAF {
            order.extend(set.iter().map(|&v| v as usize));
            continue;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &v in &set {
            for k in 0..3 {
                lo[k] = lo[k].min(points[v as usize][k]);
                hi[k] = hi[k].max(points[v as usize][k]);
            }
        }
        let axis = (0..3)
            .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
            .unwrap_or(0);
        let mid = set.len() / 2;
        set.select_nth_unstable_by(mid, |&a, &b| {
            points[a as usize][axis].total_cmp(&points[b as usize][axis])
        });
        let right = set.split_off(mid);
        let id = split_id;
        split_id += 1;
        for &v in &right {
            side[v as usize] = (id, true);
        }
        let (sep, left): (Vec<u32>, Vec<u32>) = set
            .into_iter()
            .partition(|&v| neighbours(v as usize).iter().any(|&u| side[u as usize] == (id, true)));
        // Pushed in reverse: left half, right half, then the separator.
        stack.push(Work::Emit(sep));
        stack.push(Work::Order(right));
        stack.push(Work::Order(left));
    }
    order
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
        assert_eq!(
            pattern.factor(&vec![-1.0; values.len()]).unwrap_err(),
            SparseError::NotPositiveDefinite
        );
    }

    #[test]
    fn nested_dissection_is_a_permutation_and_solves_the_same_system() {
        // 5-point Laplacian (+ shift) of a 40 × 30 grid.
        let (nx, ny) = (40usize, 30usize);
        let n = nx * ny;
        let mut entries = Vec::new();
        let mut values = Vec::new();
        let mut adjacency: Vec<Vec<u32>> = vec![Vec::new(); n];
        for j in 0..ny {
            for i in 0..nx {
                let v = i + j * nx;
                entries.push((v, v));
                values.push(4.01);
                for (di, dj) in [(1usize, 0usize), (0, 1)] {
                    let (a, b) = (i + di, j + dj);
                    if a < nx && b < ny {
                        let u = a + b * nx;
                        entries.push((u, v));
                        values.push(-1.0);
                        adjacency[u].push(v as u32);
                        adjacency[v].push(u as u32);
                    }
                }
            }
        }
        let points: Vec<[f64; 3]> = (0..n).map(|v| [(v % nx) as f64, (v / nx) as f64, 0.0]).collect();
        let order = nested_dissection(&points, |i| &adjacency[i]);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..n).collect::<Vec<_>>());
        let rhs = |m: &mut Mat<f64>| {
            for i in 0..n {
                m[(i, 0)] = (i as f64 * 0.01).cos();
            }
        };
        let (mut a, mut b) = (Mat::<f64>::zeros(n, 1), Mat::<f64>::zeros(n, 1));
        rhs(&mut a);
        rhs(&mut b);
        SpdPattern::new(n, &entries)
            .unwrap()
            .factor(&values)
            .unwrap()
            .solve_in_place(&mut a);
        SpdPattern::with_ordering(n, &entries, Some(&order))
            .unwrap()
            .factor(&values)
            .unwrap()
            .solve_in_place(&mut b);
        for i in 0..n {
            assert!((a[(i, 0)] - b[(i, 0)]).abs() < 1e-10);
        }
    }
}
