//! The force-density ("bar-net") solve of §III, Eq. 1–2, with holes fan-filled.
//!
//! Symbols: `C`, `C_f` = branch-node matrices of free and fixed nodes; `Q` =
//! diagonal of force densities `q`; `D = Cᵀ Q C`, `D_f = Cᵀ Q C_f`. With no
//! external forces (p = 0), Eq. 1 reads `D x = −D_f x_f` (same for y). Fixed
//! nodes are the outer boundary on the square; every other node, including
//! one virtual node per hole, is free. `D` is a weighted graph Laplacian, SPD
//! for a connected chart; it is factored once and re-solved when only the
//! fixed positions change.

use crate::mesh::TriMesh;
use crate::mesh::topology::Topology;
use crate::sparse::{SparseError, SpdFactor, SpdPattern, nested_dissection};
use faer::Mat;
use glam::{DVec2, DVec3};
use thiserror::Error;

/// ε of Eq. 2: keeps the longest bar's force density positive.
pub const FORCE_DENSITY_EPSILON: f64 = 1e-3;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum BarNetError {
    #[error("force-density system: {0}")]
    Sparse(#[from] SparseError),
}

/// A chart with each hole closed by one virtual vertex (the 3D centroid of the
/// hole's loop) and a fan of virtual triangles. Real vertices and triangles
/// come first, so a layout of the filled chart starts with the real layout.
#[derive(Debug, Clone)]
pub struct FilledChart {
    pub mesh: TriMesh,
    pub n_real_vertices: usize,
    pub n_real_triangles: usize,
    /// The hole loops (chart-local ids), in the order of their virtual vertices.
    pub holes: Vec<Vec<u32>>,
    /// Every edge (bar) once: the chart's edges, then the virtual spokes.
    pub edges: Vec<[u32; 2]>,
}

impl FilledChart {
    pub fn n_holes(&self) -> usize {
        self.holes.len()
    }
}

/// Closes every inner loop of `topology` with a virtual vertex and fan.
pub fn fill_holes(mesh: &TriMesh, topology: &Topology) -> FilledChart {
    let mut filled = mesh.clone();
    let holes: Vec<Vec<u32>> = topology.holes().cloned().collect();
    let mut edges = topology.edges.clone();
    for hole in &holes {
        let centre = hole.iter().map(|&v| mesh.positions[v as usize]).sum::<DVec3>() / hole.len() as f64;
        let c = filled.positions.len() as u32;
        filled.positions.push(centre);
        // The chart lies left of a → b; the fan triangle lies right of it: (b, a, c).
        for i in 0..hole.len() {
            let (a, b) = (hole[i], hole[(i + 1) % hole.len()]);
            filled.triangles.push([b, a, c]);
            edges.push([a, c]);
        }
    }
    FilledChart {
        mesh: filled,
        n_real_vertices: mesh.n_vertices(),
        n_real_triangles: mesh.n_triangles(),
        holes,
        edges,
    }
}

/// Every undirected edge of `mesh` once, `(min, max)`, sorted.
pub fn unique_edges(mesh: &TriMesh) -> Vec<[u32; 2]> {
    let mut keys: Vec<u64> = mesh
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .map(|(a, b)| ((a.min(b) as u64) << 32) | a.max(b) as u64)
        .collect();
    keys.sort_unstable();
    keys.dedup();
    keys.into_iter().map(|k| [(k >> 32) as u32, k as u32]).collect()
}

/// Force densities of Eq. 2: `q_i = 1 − len(e_i) / max_j len(e_j) + ε`.
pub fn force_densities(mesh: &TriMesh, edges: &[[u32; 2]]) -> Vec<f64> {
    let len: Vec<f64> = edges
        .iter()
        .map(|e| mesh.positions[e[0] as usize].distance(mesh.positions[e[1] as usize]))
        .collect();
    let max = len.iter().copied().fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    len.iter().map(|l| 1.0 - l / max + FORCE_DENSITY_EPSILON).collect()
}

/// Free unknowns from which the geometric nested-dissection order replaces AMD.
const NESTED_DISSECTION_FROM: usize = 200_000;

/// Compressed adjacency (offsets, neighbours) of the free unknowns from the
/// off-diagonal entries `(row, col)`.
fn free_adjacency(n: usize, off_diagonal: &[(usize, usize)]) -> (Vec<usize>, Vec<u32>) {
    let mut offsets = vec![0usize; n + 1];
    for &(r, c) in off_diagonal {
        offsets[r + 1] += 1;
        offsets[c + 1] += 1;
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut neighbours = vec![0u32; offsets[n]];
    for &(r, c) in off_diagonal {
        neighbours[fill[r]] = c as u32;
        fill[r] += 1;
        neighbours[fill[c]] = r as u32;
        fill[c] += 1;
    }
    (offsets, neighbours)
}

/// The factored bar-net of one chart: `D` of Eq. 1 over the free nodes.
#[derive(Debug, Clone)]
pub struct BarNet {
    /// Free-node row of each vertex; `None` for fixed vertices.
    free_row: Vec<Option<u32>>,
    /// Vertex of each free row.
    free_vertices: Vec<u32>,
    /// `(free row, fixed vertex, q)`: the entries of `−D_f`.
    couplings: Vec<(u32, u32, f64)>,
    /// `None` when every node is fixed: nothing to solve, the outer loop
    /// is the layout (a triangulated convex polygon embeds).
    factor: Option<SpdFactor>,
}

impl BarNet {
    /// Builds and factors `D = Cᵀ Q C` (Eq. 1) with `q` from Eq. 2 over the
    /// bars of the filled chart. `is_fixed[v]` marks fixed nodes.
    ///
    /// # Errors
    /// `D` not positive definite (a free component that touches no fixed
    /// vertex). With no free vertex there is nothing to factor.
    pub fn factor(filled: &FilledChart, is_fixed: &[bool]) -> Result<Self, BarNetError> {
        let q = force_densities(&filled.mesh, &filled.edges);
        Self::factor_with_densities(&filled.mesh.positions, &filled.edges, &q, is_fixed)
    }

    /// As [`BarNet::factor`] with explicit force densities `q` per edge.
    /// `positions` (one per vertex) guide the fill-reducing order of large systems.
    pub fn factor_with_densities(
        positions: &[DVec3],
        edges: &[[u32; 2]],
        q: &[f64],
        is_fixed: &[bool],
    ) -> Result<Self, BarNetError> {
        let n_vertices = positions.len();
        let mut free_row = vec![None; n_vertices];
        let mut free_vertices = Vec::new();
        for v in 0..n_vertices {
            if !is_fixed[v] {
                free_row[v] = Some(free_vertices.len() as u32);
                free_vertices.push(v as u32);
            }
        }
        let n = free_vertices.len();
        if n == 0 {
            return Ok(BarNet {
                free_row,
                free_vertices,
                couplings: Vec::new(),
                factor: None,
            });
        }
        let mut entries = Vec::with_capacity(n + edges.len() * 3);
        let mut values = Vec::with_capacity(n + edges.len() * 3);
        // Diagonal entries first (one per free row), then each edge's parts.
        for r in 0..n {
            entries.push((r, r));
            values.push(0.0);
        }
        let mut couplings = Vec::new();
        for (e, &qe) in edges.iter().zip(q) {
            let (a, b) = (e[0] as usize, e[1] as usize);
            match (free_row[a], free_row[b]) {
                (Some(ra), Some(rb)) => {
                    values[ra as usize] += qe;
                    values[rb as usize] += qe;
                    entries.push((ra.max(rb) as usize, ra.min(rb) as usize));
                    values.push(-qe);
                }
                (Some(ra), None) => {
                    values[ra as usize] += qe;
                    couplings.push((ra, b as u32, qe));
                }
                (None, Some(rb)) => {
                    values[rb as usize] += qe;
                    couplings.push((rb, a as u32, qe));
                }
                (None, None) => {}
            }
        }
        let order = (n >= NESTED_DISSECTION_FROM).then(|| {
            let adjacency = free_adjacency(n, &entries[n..]);
            let points: Vec<[f64; 3]> = free_vertices
                .iter()
                .map(|&v| positions[v as usize].to_array())
                .collect();
            nested_dissection(&points, |i| &adjacency.1[adjacency.0[i]..adjacency.0[i + 1]])
        });
        let pattern = SpdPattern::with_ordering(n, &entries, order.as_deref())?;
        let factor = pattern.factor(&values)?;
        Ok(BarNet {
            free_row,
            free_vertices,
            couplings,
            factor: Some(factor),
        })
    }

    /// Solves Eq. 1 (p = 0) for the free nodes. `layout` holds the fixed
    /// nodes' positions on entry; the free nodes' positions are overwritten.
    pub fn solve(&self, layout: &mut [DVec2]) {
        let Some(factor) = &self.factor else {
            return;
        };
        let n = self.free_vertices.len();
        let mut rhs = Mat::<f64>::zeros(n, 2);
        for &(r, v, q) in &self.couplings {
            let p = layout[v as usize];
            rhs[(r as usize, 0)] += q * p.x;
            rhs[(r as usize, 1)] += q * p.y;
        }
        factor.solve_in_place(&mut rhs);
        for (r, &v) in self.free_vertices.iter().enumerate() {
            layout[v as usize] = DVec2::new(rhs[(r, 0)], rhs[(r, 1)]);
        }
    }

    pub fn n_free(&self) -> usize {
        self.free_vertices.len()
    }

    /// The free vertices in the order the factorisation eliminates them
    /// (minimum degree, or nested dissection on big charts): a fill-reducing
    /// order for any system on the same vertex graph, such as the Newton
    /// Hessians of the completion.
    pub fn elimination_order(&self) -> Option<Vec<u32>> {
        let order = self.factor.as_ref()?.pattern().elimination_order()?;
        Some(order.into_iter().map(|r| self.free_vertices[r]).collect())
    }

    pub fn is_free(&self, v: u32) -> bool {
        self.free_row[v as usize].is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::param::boundary::{TrapCandidates, map_outer_boundary};
    use crate::testing::grid_mesh;

    /// Step 1 on a mesh: returns the filled chart and its layout.
    fn step1(mesh: &TriMesh) -> (FilledChart, Vec<DVec2>, BarNet) {
        let topo = Topology::build(mesh).unwrap();
        let traps = TrapCandidates::find(mesh, &topo);
        let b = map_outer_boundary(mesh, &topo, &traps, None).unwrap();
        let filled = fill_holes(mesh, &topo);
        let mut fixed = vec![false; filled.mesh.n_vertices()];
        let mut layout = vec![DVec2::ZERO; filled.mesh.n_vertices()];
        for (&v, &p) in b.loop_vertices.iter().zip(&b.positions) {
            fixed[v as usize] = true;
            layout[v as usize] = p;
        }
        let net = BarNet::factor(&filled, &fixed).unwrap();
        net.solve(&mut layout);
        (filled, layout, net)
    }

    #[test]
    fn a_strip_with_every_vertex_on_its_loop_is_its_loop() {
        // One row of quads: no node is free; the bulged square's loop,
        // strictly convex, is a fold-free layout of any triangulation.
        let mesh = grid_mesh(6, 2);
        let (filled, layout, net) = step1(&mesh);
        assert_eq!(net.n_free(), 0);
        assert!(crate::guard::all_positive(&layout, &filled.mesh.triangles));
    }

    #[test]
    fn grid_equilibrium_holds_at_every_free_node() {
        let mesh = grid_mesh(9, 7);
        let (filled, layout, _) = step1(&mesh);
        let edges = filled.edges.clone();
        let q = force_densities(&filled.mesh, &edges);
        let mut force = vec![DVec2::ZERO; layout.len()];
        for (e, &qe) in edges.iter().zip(&q) {
            let d = layout[e[1] as usize] - layout[e[0] as usize];
            force[e[0] as usize] += qe * d;
            force[e[1] as usize] -= qe * d;
        }
        let boundary: Vec<u32> = Topology::build(&mesh).unwrap().outer_loop().to_vec();
        for (v, f) in force.iter().enumerate() {
            if !boundary.contains(&(v as u32)) {
                assert!(f.length() < 1e-12, "vertex {v}: residual force {f:?}");
            }
        }
    }

    #[test]
    fn uniform_densities_reproduce_the_regular_grid() {
        // With equal q on a grid whose boundary sits on its own positions, every
        // interior node is the average of its neighbours; the regular grid
        // without diagonals satisfies that exactly.
        let (nx, ny) = (6, 5);
        let mesh = grid_mesh(nx, ny);
        let edges: Vec<[u32; 2]> = unique_edges(&mesh)
            .into_iter()
            .filter(|e| {
                let d = mesh.positions[e[0] as usize] - mesh.positions[e[1] as usize];
                d.x.abs() < 1e-12 || d.y.abs() < 1e-12
            })
            .collect();
        let q = vec![1.0; edges.len()];
        let mut fixed = vec![false; mesh.n_vertices()];
        let mut layout = vec![DVec2::splat(0.5); mesh.n_vertices()];
        for (v, p) in mesh.positions.iter().enumerate() {
            let (i, j) = (v % nx, v / nx);
            if i == 0 || j == 0 || i == nx - 1 || j == ny - 1 {
                fixed[v] = true;
                layout[v] = p.truncate();
            }
        }
        let net = BarNet::factor_with_densities(&mesh.positions, &edges, &q, &fixed).unwrap();
        net.solve(&mut layout);
        for (v, p) in mesh.positions.iter().enumerate() {
            assert!(layout[v].distance(p.truncate()) < 1e-13, "vertex {v}");
        }
    }

    #[test]
    fn holes_get_a_fan_and_layout_stays_positive() {
        let mut rng = crate::testing::Rng::new(7);
        let mesh = crate::testing::random_disk(&mut rng, 16, 3);
        let (filled, layout, net) = step1(&mesh);
        assert_eq!(filled.n_holes(), 3);
        assert_eq!(filled.mesh.n_vertices(), mesh.n_vertices() + 3);
        assert!(net.n_free() > 0);
        assert!(crate::guard::all_positive(&layout, &filled.mesh.triangles));
        // Its elimination order covers every free vertex (virtual ones
        // included) once: the Newton pattern takes it as its own order.
        let mut order = net.elimination_order().expect("an ordered factorisation");
        order.sort_unstable();
        let free: Vec<u32> = (0..filled.mesh.n_vertices() as u32)
            .filter(|&v| net.is_free(v))
            .collect();
        assert_eq!(order, free);
        assert!(
            free.contains(&(mesh.n_vertices() as u32)),
            "a virtual hole vertex is free"
        );
    }
}
