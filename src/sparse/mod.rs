//! The one place uvpin talks to faer's sparse Cholesky (so a faer upgrade
//! touches one file). Symbolic analysis (AMD ordering) and numeric
//! factorisation are separate: the pattern is fixed by the mesh, values change
//! with weights. Always `Par::Seq`: faer's parallel triangular solve is far
//! slower than the sequential one at these sizes (docs/decisions.md).

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

/// Where the blocks of a 2 × 2-block pattern's input landed. A block's
/// place is given per column: the slot of its first row (the second row
/// follows it). On a diagonal block, entry (0, 1) (above the diagonal) is
/// not the block's: never write it.
#[derive(Debug, Clone)]
pub struct Placement {
    /// Each node's place in the elimination order (its unknowns are
    /// `2 · position[v]` and the next).
    pub position: Vec<u32>,
    /// Per node, its diagonal block.
    pub diagonal: Vec<[u32; 2]>,
    /// Per input pair `(a, b)`, the block at row `max`, column `min` of
    /// their positions.
    pub pairs: Vec<[u32; 2]>,
}

/// A symmetric positive definite system of 2 × 2 blocks over a node graph
/// (the Newton Hessians): its symbolic factorisation, numbered in
/// elimination order so that values are assembled in place.
#[derive(Debug, Clone)]
pub struct BlockedPattern(SpdPattern);

/// The numeric factor and scratch of a [`BlockedPattern`], reused across
/// factorisations.
pub type BlockedWorkspace = FactorWorkspace;

impl BlockedPattern {
    /// The pattern of `n_nodes` nodes coupled where `node_pairs` says (either
    /// order), in the elimination order `order` if given (`order[k]` = the
    /// node eliminated k-th, a fill-reducing order of the same graph such as
    /// step 1's), else by minimum degree on the node graph, and where each
    /// node's and each pair's block went.
    ///
    /// # Errors
    /// A pair naming a node out of range, a bad `order`, or a pattern faer
    /// rejects.
    pub fn new(
        n_nodes: usize,
        node_pairs: &[(u32, u32)],
        order: Option<&[u32]>,
    ) -> Result<(Self, Placement), SparseError> {
        let (pattern, position) = SpdPattern::new_blocked(n_nodes, 2, node_pairs, order)?;
        let slot = |r: usize, c: usize| pattern.slot(r, c).expect("entry in the pattern") as u32;
        // Column 2p + 1 of a diagonal block starts at its diagonal.
        let diagonal = position
            .iter()
            .map(|&p| {
                let p = 2 * p as usize;
                [slot(p, p), slot(p + 1, p + 1) - 1]
            })
            .collect();
        let pairs = node_pairs
            .iter()
            .map(|&(a, b)| {
                let (a, b) = (position[a as usize], position[b as usize]);
                let (r, c) = (2 * a.max(b) as usize, 2 * a.min(b) as usize);
                [slot(r, c), slot(r, c + 1)]
            })
            .collect();
        let placement = Placement {
            position,
            diagonal,
            pairs,
        };
        Ok((BlockedPattern(pattern), placement))
    }

    /// How many values [`BlockedPattern::factor_into`] takes.
    pub fn n_values(&self) -> usize {
        self.0.n_values()
    }

    /// Factors values laid out as the [`Placement`] says.
    ///
    /// # Errors
    /// [`SparseError::NotPositiveDefinite`].
    pub fn factor_into(&self, values: &[f64], workspace: &mut BlockedWorkspace) -> Result<(), SparseError> {
        self.0.factor_into(values, workspace)
    }

    /// Solves `A x = b` in place (in elimination numbering) with the factor
    /// last made by [`BlockedPattern::factor_into`] in `workspace`.
    pub fn solve_with(&self, workspace: &mut BlockedWorkspace, b: &mut [f64]) {
        self.0.solve_with(workspace, b);
    }
}

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
    /// Where each value given to [`SpdPattern::factor`] goes (`None` for a
    /// pattern built column by column, which takes values in place only).
    argsort: Option<Arc<faer::sparse::Argsort<usize>>>,
    cholesky: Arc<SymbolicCholesky<usize>>,
}

/// Memory kept between numeric factorisations of one pattern (a Newton loop
/// refactors the same pattern every step): the factor's values and faer's
/// scratch, allocated once instead of page-faulted in on every step.
#[derive(Default)]
pub struct FactorWorkspace {
    l_values: Vec<f64>,
    scratch: Option<MemBuffer>,
    factored: bool,
}

impl std::fmt::Debug for FactorWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FactorWorkspace")
            .field("l_values", &self.l_values.len())
            .field("factored", &self.factored)
            .finish()
    }
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
            .map_err(|e| SparseError::Pattern(format!("{e:?}")));
        crate::simd::after_faer();
        let cholesky = cholesky?;
        Ok(SpdPattern {
            n,
            symbolic: Arc::new(symbolic),
            argsort: Some(Arc::new(argsort)),
            cholesky: Arc::new(cholesky),
        })
    }

    /// The pattern of a symmetric matrix made of `block × block` blocks over
    /// `n_nodes` nodes, coupled where `node_pairs` `(a, b)` says so (either
    /// order; diagonal blocks always). The elimination order is `order` if
    /// given (`order[k]` = the node eliminated k-th), else minimum degree on
    /// the node graph; either way each node's unknowns stay together: less
    /// fill, and far cheaper to analyse, than minimum degree on the unknowns.
    ///
    /// The pattern is numbered in that elimination order, so factorising
    /// permutes nothing: node `v` is node `position[v]` of the pattern (its
    /// unknowns `block · position[v] + k`), with `position` the second value
    /// returned. The columns are written straight from the node graph (no
    /// sorting of entries). Assemble values in place with
    /// [`SpdPattern::slot`] and factor with [`SpdPattern::factor_into`].
    ///
    /// # Errors
    /// A pair naming a node out of range, an `order` that is not a
    /// permutation of the nodes, or a pattern faer rejects.
    pub fn new_blocked(
        n_nodes: usize,
        block: usize,
        node_pairs: &[(u32, u32)],
        order: Option<&[u32]>,
    ) -> Result<(Self, Vec<u32>), SparseError> {
        let pattern_error = |e: &dyn std::fmt::Debug| SparseError::Pattern(format!("{e:?}"));
        if node_pairs.iter().any(|&(a, b)| a.max(b) as usize >= n_nodes) {
            return Err(SparseError::Pattern(format!("a node pair names a node ≥ {n_nodes}")));
        }
        let node_graph = node_graph(n_nodes, node_pairs)?;
        let position = match order {
            Some(order) => positions_of(order, n_nodes)?,
            None => minimum_degree(&node_graph)?,
        };
        // Node columns in elimination order: the later node of each pair is a
        // row of the earlier one's column (lower triangle), diagonal first.
        let mut node_rows: Vec<Vec<u32>> = (0..n_nodes as u32).map(|c| vec![c]).collect();
        for col in 0..n_nodes {
            for &row in node_graph.row_idx_of_col_raw(col) {
                let (a, b) = (position[row], position[col]);
                if a != b {
                    node_rows[a.min(b) as usize].push(a.max(b));
                }
            }
        }
        let n = n_nodes * block;
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0usize);
        for (c, rows) in node_rows.iter_mut().enumerate() {
            rows.sort_unstable();
            rows.dedup();
            for b in 0..block {
                let col = block * c + b;
                for &r in rows.iter() {
                    row_idx.extend((0..block).map(|a| block * r as usize + a).filter(|&row| row >= col));
                }
                col_ptr.push(row_idx.len());
            }
        }
        // faer's analysis without a permutation reads the upper triangle;
        // the numeric factorisation reads the lower one as assembled.
        let mut upper_ptr = vec![0usize; n + 1];
        row_idx.iter().for_each(|&r| upper_ptr[r + 1] += 1);
        for c in 0..n {
            upper_ptr[c + 1] += upper_ptr[c];
        }
        let mut upper_rows = vec![0usize; row_idx.len()];
        let mut next = upper_ptr.clone();
        for c in 0..n {
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                upper_rows[next[r]] = c;
                next[r] += 1;
            }
        }
        let upper = SymbolicSparseColMat::<usize>::new_checked(n, n, upper_ptr, None, upper_rows);
        let symbolic = SymbolicSparseColMat::<usize>::new_checked(n, n, col_ptr, None, row_idx);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let cholesky = factorize_symbolic_cholesky(upper.as_ref(), Side::Upper, SymmetricOrdering::Identity, params)
            .map_err(|e| pattern_error(&e));
        crate::simd::after_faer();
        let cholesky = cholesky?;
        let pattern = SpdPattern {
            n,
            symbolic: Arc::new(symbolic),
            argsort: None,
            cholesky: Arc::new(cholesky),
        };
        Ok((pattern, position))
    }

    /// Where entry `(row, col)` (`row >= col`) sits in the values of
    /// [`SpdPattern::factor_into`]; `None` outside the pattern.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let start = self.symbolic.col_ptr()[col];
        self.symbolic
            .row_idx_of_col_raw(col)
            .binary_search(&row)
            .ok()
            .map(|k| start + k)
    }

    /// How many values [`SpdPattern::factor_into`] takes.
    pub fn n_values(&self) -> usize {
        self.symbolic.row_idx().len()
    }

    /// Numeric factorisation of values already in the pattern's own order
    /// (see [`SpdPattern::slot`]), into `workspace`'s memory: no sorting, no
    /// summing of duplicates, no allocation once the workspace has been
    /// used. Solve with [`SpdPattern::solve_with`].
    pub fn factor_into(&self, values: &[f64], workspace: &mut FactorWorkspace) -> Result<(), SparseError> {
        let a = SparseColMatRef::new((*self.symbolic).as_ref(), values);
        workspace.factored = false;
        workspace.l_values.resize(self.cholesky.len_val(), 0.0);
        let scratch = workspace.scratch.get_or_insert_with(|| {
            MemBuffer::new(
                self.cholesky
                    .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
                    .or(self.cholesky.solve_in_place_scratch::<f64>(1, Par::Seq)),
            )
        });
        let result = self
            .cholesky
            .factorize_numeric_llt::<f64>(
                &mut workspace.l_values,
                a,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(scratch),
                Default::default(),
            )
            .map_err(|_| SparseError::NotPositiveDefinite);
        crate::simd::after_faer();
        result?;
        workspace.factored = true;
        Ok(())
    }

    /// Solves `A x = b` in place with the factor last computed by
    /// [`SpdPattern::factor_into`] in `workspace` (of this pattern).
    ///
    /// # Panics
    /// If the workspace holds no factor of this pattern.
    pub fn solve_with(&self, workspace: &mut FactorWorkspace, b: &mut [f64]) {
        assert!(
            workspace.factored && workspace.l_values.len() == self.cholesky.len_val(),
            "solve_with needs a factor from factor_into"
        );
        let n = b.len();
        let scratch = workspace.scratch.as_mut().expect("scratch made by factor_into");
        LltRef::<usize, f64>::new(&self.cholesky, &workspace.l_values).solve_in_place_with_conj(
            faer::Conj::No,
            faer::MatMut::from_column_major_slice_mut(b, n, 1),
            Par::Seq,
            MemStack::new(scratch),
        );
        crate::simd::after_faer();
    }

    pub fn n(&self) -> usize {
        self.n
    }

    /// Numeric factorisation with `values` in the order of the `entries` given to [`SpdPattern::new`].
    pub fn factor(&self, values: &[f64]) -> Result<SpdFactor, SparseError> {
        let argsort = self
            .argsort
            .as_ref()
            .ok_or_else(|| SparseError::Pattern("a blocked pattern takes values in place (factor_into)".into()))?;
        let a = SparseColMat::<usize, f64>::new_from_argsort((*self.symbolic).clone(), argsort, values)
            .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        self.factor_matrix(a.as_ref())
    }

    fn factor_matrix(&self, a: SparseColMatRef<'_, usize, f64>) -> Result<SpdFactor, SparseError> {
        let mut l_values = vec![0.0f64; self.cholesky.len_val()];
        let mut mem = MemBuffer::new(
            self.cholesky
                .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        );
        let result = self.cholesky.factorize_numeric_llt::<f64>(
            &mut l_values,
            a,
            Side::Lower,
            Default::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        );
        crate::simd::after_faer();
        result.map_err(|_| SparseError::NotPositiveDefinite)?;
        Ok(SpdFactor {
            pattern: self.clone(),
            l_values,
        })
    }
}

impl SpdFactor {
    /// Solves `A X = B` in place for the columns of `rhs` (n × k).
    pub fn solve_in_place(&self, rhs: &mut Mat<f64>) {
        let rhs = rhs.as_mut();
        let chol = &self.pattern.cholesky;
        let mut mem = MemBuffer::new(chol.solve_in_place_scratch::<f64>(rhs.ncols(), Par::Seq));
        LltRef::<usize, f64>::new(chol, &self.l_values).solve_in_place_with_conj(
            faer::Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut mem),
        );
        crate::simd::after_faer();
    }

    pub fn pattern(&self) -> &SpdPattern {
        &self.pattern
    }
}

impl SpdPattern {
    /// The fill-reducing elimination order the analysis chose (`order[k]` =
    /// the unknown eliminated k-th), if it permuted at all.
    pub fn elimination_order(&self) -> Option<Vec<usize>> {
        self.cholesky.perm().map(|p| p.arrays().0.to_vec())
    }
}

/// The graph of `n_nodes` nodes coupled where `node_pairs` says (either
/// order), as the lower triangle of a symmetric pattern, diagonal included.
///
/// # Errors
/// A pattern faer rejects.
pub(crate) fn node_graph(
    n_nodes: usize,
    node_pairs: &[(u32, u32)],
) -> Result<SymbolicSparseColMat<usize>, SparseError> {
    let mut nodes: Vec<Pair<usize, usize>> = (0..n_nodes).map(|v| Pair::new(v, v)).collect();
    nodes.extend(node_pairs.iter().map(|&(a, b)| {
        let (a, b) = (a.max(b) as usize, a.min(b) as usize);
        Pair::new(a, b)
    }));
    SymbolicSparseColMat::<usize>::try_new_from_indices(n_nodes, n_nodes, &nodes)
        .map(|(graph, _)| graph)
        .map_err(|e| SparseError::Pattern(format!("{e:?}")))
}

/// Each node's place in faer's approximate-minimum-degree elimination
/// order of `graph` (from [`node_graph`]).
///
/// # Errors
/// An ordering faer rejects.
pub(crate) fn minimum_degree(graph: &SymbolicSparseColMat<usize>) -> Result<Vec<u32>, SparseError> {
    let n_nodes = graph.ncols();
    let mut node_order = vec![0usize; n_nodes];
    let mut node_rank = vec![0usize; n_nodes];
    let mut mem = MemBuffer::new(amd::order_scratch::<usize>(n_nodes, graph.compute_nnz()));
    amd::order(
        &mut node_order,
        &mut node_rank,
        graph.as_ref(),
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
    Ok(node_rank.iter().map(|&r| r as u32).collect())
}

/// Each node's place in `order` (the nodes in elimination order).
///
/// # Errors
/// `order` is not a permutation of `0..n_nodes`.
pub(crate) fn positions_of(order: &[u32], n_nodes: usize) -> Result<Vec<u32>, SparseError> {
    if order.len() != n_nodes {
        return Err(SparseError::Pattern(format!(
            "elimination order of {} nodes for {n_nodes}",
            order.len()
        )));
    }
    let mut position = vec![u32::MAX; n_nodes];
    for (k, &v) in order.iter().enumerate() {
        match position.get_mut(v as usize) {
            Some(p) if *p == u32::MAX => *p = k as u32,
            _ => {
                return Err(SparseError::Pattern(format!(
                    "elimination order names node {v} twice or out of range"
                )));
            }
        }
    }
    Ok(position)
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
    fn blocked_pattern_in_elimination_order_solves_a_block_system() {
        // 2 × 2 blocks on a 12 × 9 grid graph: diagonal blocks [[4.5, 0.3], [0.3, 4.5]],
        // coupling blocks −I. Build A x for a known x in node numbering, then
        // assemble and solve in the pattern's numbering.
        let (nx, ny) = (12usize, 9usize);
        let n_nodes = nx * ny;
        let mut pairs = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let v = (i + j * nx) as u32;
                if i + 1 < nx {
                    pairs.push((v, v + 1));
                }
                if j + 1 < ny {
                    pairs.push((v + nx as u32, v));
                }
            }
        }
        let (pattern, position) = SpdPattern::new_blocked(n_nodes, 2, &pairs, None).unwrap();
        let mut seen: Vec<u32> = position.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..n_nodes as u32).collect::<Vec<_>>());
        let mut values = vec![0.0; pattern.n_values()];
        let x_true: Vec<f64> = (0..2 * n_nodes).map(|k| (k as f64 * 0.37).sin()).collect();
        let mut b = x_true.iter().map(|x| 4.5 * x).collect::<Vec<_>>();
        for v in 0..n_nodes {
            b[2 * v] += 0.3 * x_true[2 * v + 1];
            b[2 * v + 1] += 0.3 * x_true[2 * v];
            let p = 2 * position[v] as usize;
            values[pattern.slot(p, p).unwrap()] = 4.5;
            values[pattern.slot(p + 1, p + 1).unwrap()] = 4.5;
            values[pattern.slot(p + 1, p).unwrap()] = 0.3;
        }
        for &(a, c) in &pairs {
            let (a, c) = (a as usize, c as usize);
            for k in 0..2 {
                b[2 * a + k] -= x_true[2 * c + k];
                b[2 * c + k] -= x_true[2 * a + k];
                let (pa, pc) = (2 * position[a] as usize + k, 2 * position[c] as usize + k);
                values[pattern.slot(pa.max(pc), pa.min(pc)).unwrap()] = -1.0;
            }
            // The other entries of a coupling block are in the pattern, as zeros.
            let (pa, pc) = (2 * position[a] as usize, 2 * position[c] as usize);
            assert!(pattern.slot(pa.max(pc) + 1, pa.min(pc)).is_some());
        }
        let mut rhs = vec![0.0; 2 * n_nodes];
        for v in 0..n_nodes {
            for k in 0..2 {
                rhs[2 * position[v] as usize + k] = b[2 * v + k];
            }
        }
        let mut workspace = FactorWorkspace::default();
        // Twice through one workspace: the second factorisation reuses its memory.
        for _ in 0..2 {
            pattern.factor_into(&values, &mut workspace).unwrap();
            let mut x = rhs.clone();
            pattern.solve_with(&mut workspace, &mut x);
            for v in 0..n_nodes {
                for k in 0..2 {
                    assert!((x[2 * position[v] as usize + k] - x_true[2 * v + k]).abs() < 1e-12);
                }
            }
        }
        let negative: Vec<f64> = values.iter().map(|v| -v).collect();
        assert_eq!(
            pattern.factor_into(&negative, &mut workspace),
            Err(SparseError::NotPositiveDefinite)
        );
        assert!(SpdPattern::new_blocked(3, 2, &[(0, 3)], None).is_err());
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

    /// 2 × 2 blocks on an `nx × ny` grid graph: diagonal blocks
    /// [[4.5, 0.3], [0.3, 4.5]], coupling blocks −I (and a 0.1 cross term).
    fn grid_system(nx: usize, ny: usize) -> (usize, Vec<(u32, u32)>) {
        let mut pairs = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let v = (i + j * nx) as u32;
                if i + 1 < nx {
                    pairs.push((v, v + 1));
                }
                if j + 1 < ny {
                    pairs.push((v + nx as u32, v));
                }
                if i + 1 < nx && j + 1 < ny {
                    pairs.push((v, v + nx as u32 + 1));
                }
            }
        }
        (nx * ny, pairs)
    }

    #[test]
    fn blocked_systems_small_and_large_factor_and_solve() {
        for (nx, ny) in [(1, 1), (2, 1), (12, 9), (30, 31), (45, 44), (75, 70)] {
            let (n_nodes, pairs) = grid_system(nx, ny);
            // Ordered by minimum degree, or as numbered (a valid, worse
            // order), on both paths.
            let numbered: Vec<u32> = (0..n_nodes as u32).collect();
            let order = (nx == 30 || nx == 75).then_some(&numbered[..]);
            let (pattern, placement) = BlockedPattern::new(n_nodes, &pairs, order).unwrap();
            if order.is_some() {
                assert_eq!(placement.position, numbered);
            }
            let position = &placement.position;
            let mut seen = position.clone();
            seen.sort_unstable();
            assert_eq!(seen, (0..n_nodes as u32).collect::<Vec<_>>());
            let mut values = vec![0.0; pattern.n_values()];
            let x_true: Vec<f64> = (0..2 * n_nodes).map(|k| (k as f64 * 0.37).sin()).collect();
            let mut b: Vec<f64> = x_true.iter().map(|x| 8.0 * x).collect();
            for v in 0..n_nodes {
                b[2 * v] += 0.3 * x_true[2 * v + 1];
                b[2 * v + 1] += 0.3 * x_true[2 * v];
                let [c0, c1] = placement.diagonal[v].map(|c| c as usize);
                values[c0] = 8.0;
                values[c0 + 1] = 0.3;
                values[c1 + 1] = 8.0;
            }
            for (&(a, c), columns) in pairs.iter().zip(&placement.pairs) {
                let (a, c) = (a as usize, c as usize);
                // Block [[-1, 0.1], [0.1, -1]] between a and c (symmetric).
                for k in 0..2 {
                    b[2 * a + k] -= x_true[2 * c + k];
                    b[2 * c + k] -= x_true[2 * a + k];
                    b[2 * a + k] += 0.1 * x_true[2 * c + 1 - k];
                    b[2 * c + k] += 0.1 * x_true[2 * a + 1 - k];
                }
                for (column, &start) in columns.iter().enumerate() {
                    for row in 0..2 {
                        values[start as usize + row] = if row == column { -1.0 } else { 0.1 };
                    }
                }
            }
            let mut rhs = vec![0.0; 2 * n_nodes];
            for v in 0..n_nodes {
                for k in 0..2 {
                    rhs[2 * position[v] as usize + k] = b[2 * v + k];
                }
            }
            let mut factor = BlockedWorkspace::default();
            // As Newton steps do: one workspace, refactored in place.
            for _ in 0..3 {
                pattern.factor_into(&values, &mut factor).unwrap();
                let mut x = rhs.clone();
                pattern.solve_with(&mut factor, &mut x);
                for v in 0..n_nodes {
                    for k in 0..2 {
                        let err = (x[2 * position[v] as usize + k] - x_true[2 * v + k]).abs();
                        assert!(err < 1e-11, "{nx}×{ny}: node {v}.{k} off by {err:.1e}");
                    }
                }
            }
            let negative: Vec<f64> = values.iter().map(|v| -v).collect();
            assert_eq!(
                pattern.factor_into(&negative, &mut factor),
                Err(SparseError::NotPositiveDefinite)
            );
        }
        assert!(BlockedPattern::new(3, &[(0, 3)], None).is_err());
        assert!(BlockedPattern::new(3, &[(0, 1)], Some(&[0, 1, 1])).is_err());
        assert!(BlockedPattern::new(3, &[(0, 1)], Some(&[0, 1])).is_err());
        assert!(SpdPattern::new_blocked(3, 2, &[(0, 1)], Some(&[2, 1, 1])).is_err());
    }
}
