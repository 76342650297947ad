//! A supernodal Cholesky factorisation for small block-structured systems:
//! the Newton Hessians of the completion phase (2 × 2 blocks per vertex,
//! a few thousand unknowns), refactored every Newton step.
//!
//! faer's general supernodal factorisation spends most of its time on
//! per-supernode bookkeeping at this size: a 1.7k-vertex Hessian has ~900
//! supernodes, most of them one vertex (two columns), and faer factored it
//! at ~2.5 G multiply-adds/s. Here the symbolic analysis works on the
//! vertex graph (the blocks stay together), each supernode is one dense
//! column-major panel, values are assembled straight into those panels, and
//! the numeric factorisation is left-looking: each supernode gathers the
//! updates of the supernodes below it in the elimination tree, one dense
//! kernel call per descendant, then factors its own panel in place.

use super::SparseError;

const NONE: u32 = u32::MAX;

/// Unknowns per node (a vertex's u and v).
const BLOCK: usize = 2;

/// Relaxed amalgamation: merged supernodes of up to `RELAX_NODES[0]` nodes
/// always, up to `[1]` with under `RELAX_ZEROS[0]` explicit zeros, up to
/// `[2]` with under `[1]`, any size under `[2]`.
/// (CHOLMOD's defaults, 4, 16 and 48 columns, in 2-column nodes; on the
/// 1.7k-vertex Hessians this halves the supernodes and speeds the
/// factorisation up ~2×, though it adds ~15 % explicit zeros.)
const RELAX_NODES: [usize; 3] = [2, 8, 24];
const RELAX_ZEROS: [f64; 3] = [0.8, 0.1, 0.05];

/// The symbolic factorisation of a symmetric pattern of `block × block`
/// blocks, its nodes numbered in elimination order.
#[derive(Debug, Clone)]
pub struct SupernodalPattern {
    n_nodes: usize,
    /// Supernode `s` holds the nodes `first[s]..first[s + 1]`.
    first: Vec<u32>,
    /// Supernode `s`'s row nodes (its own nodes, then those below), ascending:
    /// `rows[row_ptr[s]..row_ptr[s + 1]]`.
    row_ptr: Vec<usize>,
    rows: Vec<u32>,
    /// Where supernode `s`'s dense panel (all its rows × its own columns,
    /// column-major, in unknowns) starts in the values.
    value_ptr: Vec<usize>,
    /// The supernode holding each node.
    supernode_of: Vec<u32>,
    /// Multiply-adds of one numeric factorisation (for benchmarks).
    flops: f64,
}

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

/// Lists of nodes in one allocation: list `i` is `items[offsets[i]..offsets[i + 1]]`.
#[derive(Debug, Clone)]
struct Lists {
    offsets: Vec<usize>,
    items: Vec<u32>,
}

impl Default for Lists {
    fn default() -> Self {
        Lists {
            offsets: vec![0],
            items: Vec::new(),
        }
    }
}

impl Lists {
    /// `n` lists from `(list, item)` pairs, each list's items in the order given.
    fn grouped(n: usize, entries: impl Iterator<Item = (u32, u32)> + Clone) -> Self {
        let mut offsets = vec![0usize; n + 1];
        entries.clone().for_each(|(l, _)| offsets[l as usize + 1] += 1);
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut items = vec![0u32; offsets[n]];
        for (l, item) in entries {
            items[fill[l as usize]] = item;
            fill[l as usize] += 1;
        }
        Lists { offsets, items }
    }

    fn push(&mut self, list: &[u32]) {
        self.items.extend_from_slice(list);
        self.offsets.push(self.items.len());
    }

    fn get(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i]..self.offsets[i + 1]]
    }

    fn len(&self) -> usize {
        self.offsets.len() - 1
    }
}

/// A numeric factor of one [`SupernodalPattern`], with the scratch its
/// factorisations and solves reuse (nothing is allocated once it has been
/// used).
#[derive(Debug, Default, Clone)]
pub struct SupernodalFactor {
    values: Vec<f64>,
    factored: bool,
    /// Per node: its row index in the supernode being factored.
    local_row: Vec<u32>,
    /// Per supernode: the first descendant waiting to update it, the next one
    /// in that list, and where in its rows the next update starts.
    head: Vec<u32>,
    next: Vec<u32>,
    cursor: Vec<u32>,
    /// Where one update's rows and columns land.
    target_rows: Vec<u32>,
    target_cols: Vec<u32>,
    gathered: Vec<f64>,
}

impl SupernodalFactor {
    /// The factor's memory, handed back for the next assembly once its
    /// solves are done (the factor is gone): one buffer serves both, where
    /// [`SupernodalPattern::factor_taking`] alone would alternate two.
    pub fn take_memory(&mut self) -> Vec<f64> {
        self.factored = false;
        std::mem::take(&mut self.values)
    }
}

impl SupernodalPattern {
    /// The pattern of `n_nodes` nodes of two unknowns each, coupled where
    /// `node_pairs` says (either order; diagonal blocks always), ordered by
    /// minimum degree on the node graph, with where each node and each pair
    /// ended up ([`Placement`]). `order`, if given (`order[k]` = the node
    /// eliminated k-th, a fill-reducing order of the same graph, e.g. step
    /// 1's), replaces the minimum-degree ordering.
    ///
    /// # Errors
    /// A pair naming a node out of range, an `order` that is not a
    /// permutation of the nodes, or an ordering faer rejects.
    pub fn new(
        n_nodes: usize,
        node_pairs: &[(u32, u32)],
        order: Option<&[u32]>,
    ) -> Result<(Self, Placement), SparseError> {
        if node_pairs.iter().any(|&(a, b)| a.max(b) as usize >= n_nodes) {
            return Err(SparseError::Pattern(format!("a node pair names a node ≥ {n_nodes}")));
        }
        let mut position = match order {
            Some(order) => super::positions_of(order, n_nodes)?,
            None => super::minimum_degree(&super::node_graph(n_nodes, node_pairs)?)?,
        };
        // Neighbours later in the elimination order, per node (in that order).
        let later_neighbours = |position: &[u32]| {
            Lists::grouped(
                n_nodes,
                node_pairs.iter().filter(|(a, b)| a != b).map(|&(a, b)| {
                    let (a, b) = (position[a as usize], position[b as usize]);
                    (a.min(b), a.max(b))
                }),
            )
        };
        // Renumbered in a postorder of the elimination tree (the same fill):
        // each subtree's nodes contiguous, so a supernode can absorb its last child.
        let rank = postorder(&elimination_tree(&later_neighbours(&position)));
        position.iter_mut().for_each(|p| *p = rank[*p as usize]);
        let pattern = Self::analyse(&later_neighbours(&position));
        let placement = pattern.place(position, node_pairs);
        Ok((pattern, placement))
    }

    /// Where each node's diagonal block and each pair's block sit.
    fn place(&self, position: Vec<u32>, node_pairs: &[(u32, u32)]) -> Placement {
        let columns = |s: usize, row: usize, col: usize| {
            let ld = BLOCK * (self.row_ptr[s + 1] - self.row_ptr[s]);
            let local_col = col - self.first[s] as usize;
            let first = self.value_ptr[s] + BLOCK * local_col * ld + BLOCK * row;
            [first as u32, (first + ld) as u32]
        };
        let diagonal = position
            .iter()
            .map(|&p| {
                let s = self.supernode_of[p as usize] as usize;
                columns(s, p as usize - self.first[s] as usize, p as usize)
            })
            .collect();
        // Pairs grouped by the supernode of their column, each group's rows
        // marked once: no searching.
        let lower = |i: usize| {
            let (a, b) = node_pairs[i];
            let (a, b) = (position[a as usize], position[b as usize]);
            (a.max(b), a.min(b))
        };
        let by_supernode = Lists::grouped(
            self.n_supernodes(),
            (0..node_pairs.len()).map(|i| (self.supernode_of[lower(i).1 as usize], i as u32)),
        );
        let mut local_row = vec![0u32; self.n_nodes];
        let mut pairs = vec![[0u32; 2]; node_pairs.len()];
        for s in 0..self.n_supernodes() {
            let rows = &self.rows[self.row_ptr[s]..self.row_ptr[s + 1]];
            for (k, &r) in rows.iter().enumerate() {
                local_row[r as usize] = k as u32;
            }
            for &i in by_supernode.get(s) {
                let (row, col) = lower(i as usize);
                pairs[i as usize] = columns(s, local_row[row as usize] as usize, col as usize);
            }
        }
        Placement {
            position,
            diagonal,
            pairs,
        }
    }

    /// Symbolic factorisation of the nodes' lower pattern `later` (per node,
    /// the nodes after it coupled to it, in elimination order).
    fn analyse(later: &Lists) -> Self {
        let n = later.len();
        let parent = elimination_tree(later);
        let children = Lists::grouped(
            n,
            parent
                .iter()
                .enumerate()
                .filter(|(_, p)| **p != NONE)
                .map(|(j, &p)| (p, j as u32)),
        );
        // Each column's rows below the diagonal: its own later neighbours and
        // its children's rows (children come first: a parent is always later).
        let mut structure = Lists::default();
        let mut mark = vec![NONE; n];
        let mut column = Vec::new();
        for j in 0..n {
            column.clear();
            mark[j] = j as u32;
            for &r in later
                .get(j)
                .iter()
                .chain(children.get(j).iter().flat_map(|&c| structure.get(c as usize)))
            {
                if mark[r as usize] != j as u32 {
                    mark[r as usize] = j as u32;
                    column.push(r);
                }
            }
            column.sort_unstable();
            structure.push(&column);
        }
        // Fundamental supernodes: a node joins its predecessor's supernode when
        // it is that node's parent and only child, with the same rows below.
        let mut first = vec![0u32];
        for j in 1..n {
            let chain = parent[j - 1] == j as u32
                && children.get(j).len() == 1
                && structure.get(j - 1).len() == structure.get(j).len() + 1;
            if !chain {
                first.push(j as u32);
            }
        }
        first.push(n as u32);
        let first = relax(&first, &parent, &structure);
        let n_supernodes = first.len() - 1;
        let mut supernode_of = vec![0u32; n];
        let mut row_ptr = Vec::with_capacity(n_supernodes + 1);
        let mut rows = Vec::new();
        let mut value_ptr = Vec::with_capacity(n_supernodes + 1);
        let (mut values, mut flops) = (0usize, 0.0f64);
        row_ptr.push(0);
        value_ptr.push(0);
        for s in 0..n_supernodes {
            let (f, l) = (first[s] as usize, first[s + 1] as usize);
            supernode_of[f..l].iter_mut().for_each(|x| *x = s as u32);
            rows.extend(f as u32..l as u32);
            rows.extend_from_slice(structure.get(l - 1));
            row_ptr.push(rows.len());
            let (n_rows, n_cols) = (BLOCK * (row_ptr[s + 1] - row_ptr[s]), BLOCK * (l - f));
            values += n_rows * n_cols;
            value_ptr.push(values);
            // Column k of the panel updates the (n_rows − k)² / 2 entries below it.
            flops += (0..n_cols)
                .map(|k| ((n_rows - k) * (n_rows - k + 1) / 2) as f64)
                .sum::<f64>();
        }
        SupernodalPattern {
            n_nodes: n,
            first,
            row_ptr,
            rows,
            value_ptr,
            supernode_of,
            flops,
        }
    }

    /// How many unknowns.
    pub fn n(&self) -> usize {
        BLOCK * self.n_nodes
    }

    /// How many values [`SupernodalPattern::factor_into`] takes.
    pub fn n_values(&self) -> usize {
        *self.value_ptr.last().expect("one entry per supernode and one more")
    }

    pub fn n_supernodes(&self) -> usize {
        self.first.len() - 1
    }

    /// Multiply-adds of one numeric factorisation.
    pub fn flops(&self) -> f64 {
        self.flops
    }

    /// Factors `A = L Lᵀ` for `values` laid out as [`Placement`]
    /// says (the upper triangle of diagonal blocks is ignored), into
    /// `factor`'s memory.
    ///
    /// # Errors
    /// [`SparseError::NotPositiveDefinite`] if a pivot is not positive.
    pub fn factor_into(&self, values: &[f64], factor: &mut SupernodalFactor) -> Result<(), SparseError> {
        let mut copy = std::mem::take(&mut factor.values);
        copy.clear();
        copy.extend_from_slice(values);
        self.factor_taking(&mut copy, factor)
    }

    /// As [`SupernodalPattern::factor_into`], factoring `values` where they
    /// are: they move into `factor`, and `values` gets the factor's old
    /// memory (its contents unspecified). Saves copying ~1 MB per Newton step.
    ///
    /// # Errors
    /// [`SparseError::NotPositiveDefinite`] if a pivot is not positive.
    pub fn factor_taking(&self, values: &mut Vec<f64>, factor: &mut SupernodalFactor) -> Result<(), SparseError> {
        assert_eq!(values.len(), self.n_values(), "values of another pattern");
        factor.factored = false;
        std::mem::swap(values, &mut factor.values);
        factor.local_row.resize(self.n_nodes, 0);
        let n_supernodes = self.n_supernodes();
        factor.head.clear();
        factor.head.resize(n_supernodes, NONE);
        factor.next.resize(n_supernodes, NONE);
        factor.cursor.resize(n_supernodes, 0);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has the features `numeric_fma` is compiled for.
            return unsafe { numeric_fma(self, factor) };
        }
        numeric::<false>(self, factor)
    }

    /// Solves `A x = b` in place with the factor last made by
    /// [`SupernodalPattern::factor_into`] in `factor`.
    ///
    /// # Panics
    /// If `factor` holds no factor of this pattern.
    pub fn solve_with(&self, factor: &mut SupernodalFactor, b: &mut [f64]) {
        assert!(
            factor.factored && factor.values.len() == self.n_values() && b.len() == self.n(),
            "solve_with needs a factor of this pattern from factor_into"
        );
        let SupernodalFactor { values, gathered, .. } = factor;
        // Per supernode: its own unknowns are contiguous in `b`; those of the
        // rows below are gathered. A panel's diagonal holds 1 / L_jj.
        // Forward: L y = b.
        for s in 0..self.n_supernodes() {
            let (rows, panel, n_cols) = self.panel(s, values);
            let n_rows = BLOCK * rows.len();
            let start = BLOCK * self.first[s] as usize;
            self.gather_below(rows, n_cols, b, gathered);
            let own = &mut b[start..start + n_cols];
            for j in 0..n_cols {
                let column = &panel[j * n_rows..(j + 1) * n_rows];
                let yj = own[j] * column[j];
                own[j] = yj;
                for (x, &l) in own[j + 1..].iter_mut().zip(&column[j + 1..n_cols]) {
                    *x -= l * yj;
                }
                for (x, &l) in gathered.iter_mut().zip(&column[n_cols..]) {
                    *x -= l * yj;
                }
            }
            for (&r, pair) in rows[n_cols / BLOCK..].iter().zip(gathered.chunks_exact(BLOCK)) {
                b[BLOCK * r as usize..BLOCK * (r as usize + 1)].copy_from_slice(pair);
            }
        }
        // Backward: Lᵀ x = y.
        for s in (0..self.n_supernodes()).rev() {
            let (rows, panel, n_cols) = self.panel(s, values);
            let n_rows = BLOCK * rows.len();
            let start = BLOCK * self.first[s] as usize;
            self.gather_below(rows, n_cols, b, gathered);
            let own = &mut b[start..start + n_cols];
            for j in (0..n_cols).rev() {
                let column = &panel[j * n_rows..(j + 1) * n_rows];
                let above = dot(&own[j + 1..], &column[j + 1..n_cols]) + dot(gathered, &column[n_cols..]);
                own[j] = (own[j] - above) * column[j];
            }
        }
    }

    /// Supernode `s`'s row nodes, its panel and its number of columns.
    fn panel<'a>(&'a self, s: usize, values: &'a [f64]) -> (&'a [u32], &'a [f64], usize) {
        let rows = &self.rows[self.row_ptr[s]..self.row_ptr[s + 1]];
        let n_cols = BLOCK * (self.first[s + 1] - self.first[s]) as usize;
        (rows, &values[self.value_ptr[s]..self.value_ptr[s + 1]], n_cols)
    }

    /// The unknowns of `rows` below a supernode's `n_cols` own columns, from `from`.
    fn gather_below(&self, rows: &[u32], n_cols: usize, from: &[f64], to: &mut Vec<f64>) {
        to.clear();
        for &r in &rows[n_cols / BLOCK..] {
            to.extend_from_slice(&from[BLOCK * r as usize..BLOCK * (r as usize + 1)]);
        }
    }
}

/// Relaxed amalgamation (as in CHOLMOD): a supernode absorbs its last child
/// (the supernode just before it, in postorder) when the merged panel would
/// hold few explicit zeros for its size, so that fewer, wider supernodes
/// share the dense kernels. `first` delimits the fundamental supernodes.
fn relax(first: &[u32], parent: &[u32], structure: &Lists) -> Vec<u32> {
    let n_fundamental = first.len() - 1;
    let mut owner = vec![0u32; parent.len()];
    for s in 0..n_fundamental {
        owner[first[s] as usize..first[s + 1] as usize]
            .iter_mut()
            .for_each(|o| *o = s as u32);
    }
    let last = |s: usize| first[s + 1] as usize - 1;
    let mut cols: Vec<usize> = (0..n_fundamental).map(|s| last(s) + 1 - first[s] as usize).collect();
    let below: Vec<usize> = (0..n_fundamental).map(|s| structure.get(last(s)).len()).collect();
    let mut zeros = vec![0usize; n_fundamental];
    let mut merged_into = vec![NONE; n_fundamental];
    for j in (0..n_fundamental.saturating_sub(1)).rev() {
        let p = parent[last(j)];
        if p == NONE || owner[p as usize] as usize != j + 1 {
            continue;
        }
        let mut s = j + 1;
        while merged_into[s] != NONE {
            s = merged_into[s] as usize;
        }
        let n_cols = cols[j] + cols[s];
        // Each of j's columns gains the rows of s its own pattern lacks.
        let new_zeros = cols[j] * (cols[s] + below[s] - below[j]);
        let total_zeros = zeros[j] + zeros[s] + new_zeros;
        let entries = n_cols * (n_cols + 1) / 2 + n_cols * below[s];
        let fraction = total_zeros as f64 / entries as f64;
        let merge = n_cols <= RELAX_NODES[0]
            || (n_cols <= RELAX_NODES[1] && fraction < RELAX_ZEROS[0])
            || (n_cols <= RELAX_NODES[2] && fraction < RELAX_ZEROS[1])
            || fraction < RELAX_ZEROS[2];
        if merge {
            merged_into[j] = s as u32;
            cols[s] = n_cols;
            zeros[s] = total_zeros;
        }
    }
    let mut relaxed = vec![0u32];
    for j in 0..n_fundamental {
        if merged_into[j] == NONE {
            relaxed.push(first[j + 1]);
        }
    }
    relaxed
}

/// The elimination tree (Liu) of the nodes' lower pattern `later`:
/// `parent[j]` is the first node after `j` that eliminating `j` couples to.
fn elimination_tree(later: &Lists) -> Vec<u32> {
    let n = later.len();
    let earlier = Lists::grouped(n, (0..n).flat_map(|j| later.get(j).iter().map(move |&r| (r, j as u32))));
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for i in 0..n {
        for &k in earlier.get(i) {
            let mut r = k as usize;
            while ancestor[r] != NONE && ancestor[r] != i as u32 {
                let up = ancestor[r] as usize;
                ancestor[r] = i as u32;
                r = up;
            }
            if ancestor[r] == NONE {
                ancestor[r] = i as u32;
                parent[r] = i as u32;
            }
        }
    }
    parent
}

/// Each node's place in a postorder of the forest `parent` (children in
/// their order, each before its parent).
fn postorder(parent: &[u32]) -> Vec<u32> {
    let n = parent.len();
    let children = Lists::grouped(
        n,
        parent
            .iter()
            .enumerate()
            .filter(|(_, p)| **p != NONE)
            .map(|(j, &p)| (p, j as u32)),
    );
    let roots: Vec<u32> = (0..n as u32).filter(|&j| parent[j as usize] == NONE).collect();
    let mut rank = vec![0u32; n];
    let mut next = 0u32;
    // (node, how many of its children are done)
    let mut stack: Vec<(u32, usize)> = Vec::new();
    for &root in &roots {
        stack.push((root, 0));
        while let Some(top) = stack.last_mut() {
            let (node, done) = *top;
            if let Some(&child) = children.get(node as usize).get(done) {
                top.1 += 1;
                stack.push((child, 0));
            } else {
                rank[node as usize] = next;
                next += 1;
                stack.pop();
            }
        }
    }
    rank
}

/// `Σ a_i b_i` over four running sums (one sum is a chain of dependent adds).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut sums = [0.0f64; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4.remainder().iter().zip(b4.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in a4.zip(b4) {
        for k in 0..4 {
            sums[k] += x[k] * y[k];
        }
    }
    sums.iter().sum::<f64>() + tail
}

/// [`numeric`] compiled for AVX2 and FMA (the dense kernels vectorise).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn numeric_fma(pattern: &SupernodalPattern, factor: &mut SupernodalFactor) -> Result<(), SparseError> {
    numeric::<true>(pattern, factor)
}

/// `a · b + c`, fused where the CPU has FMA (`FMA`); otherwise two operations.
#[inline(always)]
fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA { a.mul_add(b, c) } else { a * b + c }
}

/// Rows and columns of one register tile of the update kernel.
const TILE_ROWS: usize = 8;
const TILE_COLS: usize = 4;

/// Where one descendant's update lands in the supernode being factored.
struct UpdateTarget<'a> {
    /// The target panel (column-major, `ld` rows).
    panel: &'a mut [f64],
    ld: usize,
    /// Per row node of the update: its first row in the target panel.
    rows: &'a [u32],
    /// The target rows are one contiguous run (then `rows[0]` + offset).
    contiguous: bool,
    /// Per update column: its column in the target panel.
    cols: &'a [u32],
}

/// One `NR × NJ` tile of a panel's update, `Σ_k L[top + r0 + i, k] ·
/// L[top + j0 + c, k]`, in registers (`acc[c][i]`; the rest stays zero).
#[inline(always)]
fn tile<const FMA: bool, const NR: usize, const NJ: usize>(
    panel: &[f64],
    ld: usize,
    n_cols: usize,
    top: usize,
    r0: usize,
    j0: usize,
) -> [[f64; TILE_ROWS]; TILE_COLS] {
    let mut acc = [[0.0f64; TILE_ROWS]; TILE_COLS];
    for k in 0..n_cols {
        let column = &panel[k * ld + top..];
        let x: &[f64; NR] = column[r0..r0 + NR].try_into().expect("a full tile");
        let a: &[f64; NJ] = column[j0..j0 + NJ].try_into().expect("a full tile");
        for c in 0..NJ {
            for i in 0..NR {
                acc[c][i] = madd::<FMA>(x[i], a[c], acc[c][i]);
            }
        }
    }
    acc
}

/// Subtracts the update one factored panel sends to a later supernode:
/// `Σ_k L[top + r, k] · L[top + j, k]` for the `len` rows from `top` and
/// the first `n_src` of them as columns (`L` is `panel`, column-major with
/// `ld` rows and `n_cols` columns), straight from registers into `target`.
/// Within each column group's diagonal tile it also subtracts above the
/// diagonal, into the target's unused upper triangle.
#[inline(always)]
fn subtract_update<const FMA: bool>(
    panel: &[f64],
    ld: usize,
    n_cols: usize,
    top: usize,
    len: usize,
    n_src: usize,
    target: &mut UpdateTarget,
) {
    let mut j0 = 0;
    while j0 < n_src {
        let nj = TILE_COLS.min(n_src - j0);
        let mut r0 = j0;
        while r0 < len {
            let nr = TILE_ROWS.min(len - r0);
            let acc = match (nr, nj) {
                (8, 4) => tile::<FMA, 8, 4>(panel, ld, n_cols, top, r0, j0),
                (8, _) => tile::<FMA, 8, 2>(panel, ld, n_cols, top, r0, j0),
                (6, 4) => tile::<FMA, 6, 4>(panel, ld, n_cols, top, r0, j0),
                (6, _) => tile::<FMA, 6, 2>(panel, ld, n_cols, top, r0, j0),
                (4, 4) => tile::<FMA, 4, 4>(panel, ld, n_cols, top, r0, j0),
                (4, _) => tile::<FMA, 4, 2>(panel, ld, n_cols, top, r0, j0),
                (_, 4) => tile::<FMA, 2, 4>(panel, ld, n_cols, top, r0, j0),
                _ => tile::<FMA, 2, 2>(panel, ld, n_cols, top, r0, j0),
            };
            for (c, acc) in acc.iter().enumerate().take(nj) {
                let col = target.cols[j0 + c] as usize * target.ld;
                let column = &mut target.panel[col..col + target.ld];
                if target.contiguous {
                    let row = target.rows[0] as usize + r0;
                    for (x, u) in column[row..row + nr].iter_mut().zip(&acc[..nr]) {
                        *x -= u;
                    }
                } else {
                    for (&row, u) in target.rows[r0 / 2..(r0 + nr) / 2].iter().zip(acc[..nr].chunks_exact(2)) {
                        let pair = &mut column[row as usize..row as usize + 2];
                        pair[0] -= u[0];
                        pair[1] -= u[1];
                    }
                }
            }
            r0 += nr;
        }
        j0 += nj;
    }
}

/// Left-looking supernodal factorisation in place in `factor.values`.
#[inline(always)]
fn numeric<const FMA: bool>(pattern: &SupernodalPattern, factor: &mut SupernodalFactor) -> Result<(), SparseError> {
    let bs = BLOCK;
    let SupernodalFactor {
        values,
        factored,
        local_row,
        head,
        next,
        cursor,
        target_rows,
        target_cols,
        ..
    } = factor;
    for t in 0..pattern.n_supernodes() {
        let t_rows = &pattern.rows[pattern.row_ptr[t]..pattern.row_ptr[t + 1]];
        let (t_first, t_end) = (pattern.first[t], pattern.first[t + 1]);
        let t_rows_len = bs * t_rows.len();
        for (k, &r) in t_rows.iter().enumerate() {
            local_row[r as usize] = k as u32;
        }
        // The panels below `t` (those already factored) and `t`'s own.
        let (done, rest) = values.split_at_mut(pattern.value_ptr[t]);
        let t_panel = &mut rest[..pattern.value_ptr[t + 1] - pattern.value_ptr[t]];
        // Updates from every descendant whose rows reach `t`'s columns.
        let mut s = head[t];
        while s != NONE {
            let s_idx = s as usize;
            let following = next[s_idx];
            let s_rows = &pattern.rows[pattern.row_ptr[s_idx]..pattern.row_ptr[s_idx + 1]];
            let s_cols = bs * (pattern.first[s_idx + 1] - pattern.first[s_idx]) as usize;
            let s_rows_len = bs * s_rows.len();
            let s_panel = &done[pattern.value_ptr[s_idx]..pattern.value_ptr[s_idx + 1]];
            let start = cursor[s_idx] as usize;
            let in_t = s_rows[start..].iter().take_while(|&&r| r < t_end).count();
            let (top, len, n_src) = (bs * start, s_rows_len - bs * start, bs * in_t);
            // Where the update's rows and columns land in `t`'s panel.
            target_rows.clear();
            target_rows.extend(s_rows[start..].iter().map(|&r| 2 * local_row[r as usize]));
            target_cols.clear();
            target_cols.extend(
                s_rows[start..start + in_t]
                    .iter()
                    .flat_map(|&r| [2 * (r - t_first), 2 * (r - t_first) + 1]),
            );
            let contiguous = target_rows.windows(2).all(|w| w[1] == w[0] + 2);
            let mut target = UpdateTarget {
                panel: t_panel,
                ld: t_rows_len,
                rows: target_rows,
                contiguous,
                cols: target_cols,
            };
            subtract_update::<FMA>(s_panel, s_rows_len, s_cols, top, len, n_src, &mut target);
            // On to the supernode holding `s`'s next row.
            let resume = start + in_t;
            if resume < s_rows.len() {
                cursor[s_idx] = resume as u32;
                let owner = pattern.supernode_of[s_rows[resume] as usize] as usize;
                next[s_idx] = head[owner];
                head[owner] = s;
            }
            s = following;
        }
        // `t`'s own panel: dense Cholesky of the diagonal block, the rows
        // below divided through (right-looking, column by column).
        let t_cols = bs * (t_end - t_first) as usize;
        for j in 0..t_cols {
            let (left, right) = t_panel.split_at_mut((j + 1) * t_rows_len);
            let col_j = &mut left[j * t_rows_len..];
            let pivot = col_j[j];
            if pivot.is_nan() || pivot <= 0.0 || pivot.is_infinite() {
                return Err(SparseError::NotPositiveDefinite);
            }
            // The diagonal keeps 1 / L_jj: the solves multiply by it (no
            // later update reads a panel's diagonal).
            let inv = 1.0 / pivot.sqrt();
            col_j[j] = inv;
            col_j[j + 1..].iter_mut().for_each(|x| *x *= inv);
            let col_j = &*col_j;
            for jj in j + 1..t_cols {
                let coef = -col_j[jj];
                let target = &mut right[(jj - j - 1) * t_rows_len..(jj - j) * t_rows_len];
                for (x, &l) in target[jj..].iter_mut().zip(&col_j[jj..]) {
                    *x = madd::<FMA>(l, coef, *x);
                }
            }
        }
        // `t` updates the supernode holding its first row below.
        let own = (t_end - t_first) as usize;
        if own < t_rows.len() {
            cursor[t] = own as u32;
            let owner = pattern.supernode_of[t_rows[own] as usize] as usize;
            next[t] = head[owner];
            head[owner] = t as u32;
        }
    }
    *factored = true;
    Ok(())
}
