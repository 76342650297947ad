//! Where a seam must reach so the opened surface lies flat without being
//! crushed: cone points, placed as Boundary First Flattening and Ben-Chen
//! et al. (2008) place them. The log scale factor `u` of the conformal
//! flattening that keeps `u = 0` on the boundary, the seams so far and the
//! cones solves `L u = −K` (`L` the cotangent Laplacian, `K` the angle
//! defects); where `|u|` is largest the flattening shrinks or stretches the
//! surface most, and the next cone goes there. Each new cone adds one solve
//! with the same factor (a bordered system in the cones' multipliers).

use super::graph::EdgeGraph;
use crate::mesh::TriMesh;
use crate::sparse::{SparseError, SpdFactor, SpdPattern};
use faer::Mat;
use faer::linalg::solvers::Solve;
use std::f64::consts::PI;

/// Angle defect `2π − Σθ` of every vertex (meaningful inside the surface).
pub fn angle_defects(mesh: &TriMesh) -> Vec<f64> {
    let mut k = vec![2.0 * PI; mesh.n_vertices()];
    for t in &mesh.triangles {
        let p = t.map(|i| mesh.positions[i as usize]);
        for c in 0..3 {
            let (a, b) = (p[(c + 1) % 3] - p[c], p[(c + 2) % 3] - p[c]);
            k[t[c] as usize] -= a.angle_between(b);
        }
    }
    k
}

/// Cotangent weight `(cot α + cot β) / 2` of every edge, kept positive so
/// the Laplacian stays definite on the free vertices.
fn cotan_weights(mesh: &TriMesh, graph: &EdgeGraph) -> Vec<f64> {
    let mut w = vec![0.0; graph.edges.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let p = tri.map(|i| mesh.positions[i as usize]);
        for k in 0..3 {
            // The side k → k+1 is opposite corner k+2.
            let o = (k + 2) % 3;
            let (a, b) = (p[k] - p[o], p[(k + 1) % 3] - p[o]);
            let cot = a.dot(b) / a.cross(b).length().max(1e-300);
            w[graph.triangle_edges[t][k] as usize] += 0.5 * cot;
        }
    }
    let mean = w.iter().map(|x| x.abs()).sum::<f64>() / w.len().max(1) as f64;
    w.iter().map(|&x| x.max(1e-3 * mean).max(1e-12)).collect()
}

/// The Laplacian restricted to the free vertices, factored, and the log
/// scale factor with the fixed vertices held at 0.
pub struct ScaleField {
    /// Index among the free vertices (`u32::MAX` for a fixed vertex).
    slot: Vec<u32>,
    factor: SpdFactor,
    /// `u` with only the first fixed set held.
    base: Vec<f64>,
    /// For each cone added, `L⁻¹ e_cone` over the free vertices.
    columns: Vec<Vec<f64>>,
    cones: Vec<u32>,
}

impl ScaleField {
    /// Factors `L` on the vertices not in `fixed` (which must hold at least
    /// one vertex of every piece) and solves for `u`.
    ///
    /// # Errors
    /// A Laplacian that is not definite (a piece with no fixed vertex).
    pub fn new(mesh: &TriMesh, graph: &EdgeGraph, fixed: &[bool]) -> Result<Self, SparseError> {
        let n = mesh.n_vertices();
        let mut slot = vec![u32::MAX; n];
        let mut n_free = 0u32;
        for v in 0..n {
            if !fixed[v] {
                slot[v] = n_free;
                n_free += 1;
            }
        }
        let w = cotan_weights(mesh, graph);
        let mut entries = Vec::with_capacity(n + 2 * graph.edges.len());
        let mut values = Vec::with_capacity(entries.capacity());
        let mut diagonal = vec![0.0; n_free as usize];
        for (e, &[a, b]) in graph.edges.iter().enumerate() {
            let (sa, sb) = (slot[a as usize], slot[b as usize]);
            for s in [sa, sb].into_iter().filter(|&s| s != u32::MAX) {
                diagonal[s as usize] += w[e];
            }
            if sa != u32::MAX && sb != u32::MAX {
                entries.push((sa.max(sb) as usize, sa.min(sb) as usize));
                values.push(-w[e]);
            }
        }
        for (s, d) in diagonal.into_iter().enumerate() {
            entries.push((s, s));
            values.push(d);
        }
        let factor = SpdPattern::new(n_free as usize, &entries)?.factor(&values)?;
        let defect = angle_defects(mesh);
        let mut rhs = Mat::<f64>::zeros(n_free as usize, 1);
        for v in 0..n {
            if slot[v] != u32::MAX {
                rhs[(slot[v] as usize, 0)] = -defect[v];
            }
        }
        factor.solve_in_place(&mut rhs);
        let base = (0..n)
            .map(|v| {
                if slot[v] == u32::MAX {
                    0.0
                } else {
                    rhs[(slot[v] as usize, 0)]
                }
            })
            .collect();
        Ok(ScaleField {
            slot,
            factor,
            base,
            columns: Vec::new(),
            cones: Vec::new(),
        })
    }

    /// Holds `u = 0` at free vertex `v` too (a cone), one more solve.
    pub fn add_cone(&mut self, v: u32) {
        let s = self.slot[v as usize];
        if s == u32::MAX || self.cones.contains(&v) {
            return;
        }
        let mut rhs = Mat::<f64>::zeros(self.factor.pattern().n(), 1);
        rhs[(s as usize, 0)] = 1.0;
        self.factor.solve_in_place(&mut rhs);
        self.columns.push((0..rhs.nrows()).map(|i| rhs[(i, 0)]).collect());
        self.cones.push(v);
    }

    /// The log scale factor `u` of every vertex with every cone held at 0.
    pub fn field(&self) -> Vec<f64> {
        let k = self.cones.len();
        if k == 0 {
            return self.base.clone();
        }
        // Multipliers α with u(cone_i) = base(cone_i) − Σ_j col_j(cone_i) α_j = 0.
        let mut a = Mat::<f64>::zeros(k, k);
        let mut b = Mat::<f64>::zeros(k, 1);
        for (i, &c) in self.cones.iter().enumerate() {
            let s = self.slot[c as usize] as usize;
            for (j, col) in self.columns.iter().enumerate() {
                a[(i, j)] = col[s];
            }
            b[(i, 0)] = self.base[c as usize];
        }
        let alpha = a.partial_piv_lu().solve(&b);
        (0..self.base.len())
            .map(|v| match self.slot[v] {
                u32::MAX => 0.0,
                s => {
                    let correction: f64 = (0..k).map(|j| self.columns[j][s as usize] * alpha[(j, 0)]).sum();
                    self.base[v] - correction
                }
            })
            .collect()
    }
}
