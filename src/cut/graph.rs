//! The edge graph of a manifold triangle mesh, and shortest paths on it.

use crate::mesh::TriMesh;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// No triangle, vertex or edge.
pub const NONE: u32 = u32::MAX;

/// Every edge once, its triangles, and each vertex's neighbours.
#[derive(Debug, Clone)]
pub struct EdgeGraph {
    /// Undirected edges `(min, max)`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// The triangles on each edge (`NONE` for the second of a boundary edge).
    pub faces: Vec<[u32; 2]>,
    /// Edge of each triangle's side `k` (from corner `k` to corner `k + 1`).
    pub triangle_edges: Vec<[u32; 3]>,
    offsets: Vec<usize>,
    /// `(neighbour, edge)`, grouped by vertex (see `offsets`).
    adjacency: Vec<(u32, u32)>,
}

impl EdgeGraph {
    /// The graph of `mesh` (manifold: at most two triangles per edge).
    pub fn new(mesh: &TriMesh) -> Self {
        let mut sides: Vec<([u32; 2], u32, u8)> = Vec::with_capacity(mesh.triangles.len() * 3);
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                sides.push(([a.min(b), a.max(b)], t as u32, k as u8));
            }
        }
        sides.sort_unstable();
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(sides.len() / 2 + 1);
        let mut faces: Vec<[u32; 2]> = Vec::with_capacity(sides.len() / 2 + 1);
        let mut triangle_edges = vec![[NONE; 3]; mesh.triangles.len()];
        for (edge, t, k) in sides {
            if edges.last() != Some(&edge) {
                edges.push(edge);
                faces.push([t, NONE]);
            } else {
                faces.last_mut().expect("pushed")[1] = t;
            }
            triangle_edges[t as usize][k as usize] = (edges.len() - 1) as u32;
        }
        let n = mesh.n_vertices();
        let mut offsets = vec![0usize; n + 1];
        for e in &edges {
            offsets[e[0] as usize + 1] += 1;
            offsets[e[1] as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut adjacency = vec![(0u32, 0u32); 2 * edges.len()];
        for (id, e) in edges.iter().enumerate() {
            for (a, b) in [(e[0], e[1]), (e[1], e[0])] {
                adjacency[fill[a as usize]] = (b, id as u32);
                fill[a as usize] += 1;
            }
        }
        EdgeGraph {
            edges,
            faces,
            triangle_edges,
            offsets,
            adjacency,
        }
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.offsets.len() - 1
    }

    /// `(neighbour, edge)` of every edge at `v`.
    pub fn around(&self, v: u32) -> &[(u32, u32)] {
        &self.adjacency[self.offsets[v as usize]..self.offsets[v as usize + 1]]
    }

    /// Whether edge `e` has one triangle only.
    pub fn is_boundary(&self, e: u32) -> bool {
        self.faces[e as usize][1] == NONE
    }

    /// The edge between `a` and `b`, if any.
    pub fn edge_between(&self, a: u32, b: u32) -> Option<u32> {
        self.around(a).iter().find(|(n, _)| *n == b).map(|(_, e)| *e)
    }

    /// Every vertex on a boundary edge.
    pub fn boundary_vertices(&self) -> Vec<u32> {
        let mut on = vec![false; self.n_vertices()];
        for (e, edge) in self.edges.iter().enumerate() {
            if self.is_boundary(e as u32) {
                on[edge[0] as usize] = true;
                on[edge[1] as usize] = true;
            }
        }
        (0..self.n_vertices() as u32).filter(|&v| on[v as usize]).collect()
    }
}

/// Shortest paths from a set of sources.
#[derive(Debug, Clone)]
pub struct ShortestPaths {
    /// Distance of each vertex from the nearest source (∞ if unreachable).
    pub distance: Vec<f64>,
    /// The edge each vertex is reached by (`NONE` at sources and unreached).
    pub parent: Vec<u32>,
    /// Which source (its position in the sources given) each vertex is
    /// nearest to (`NONE` unreached): the sources' Voronoi cells.
    pub nearest: Vec<u32>,
}

#[derive(PartialEq)]
struct Queued(f64, u32);

impl Eq for Queued {}

impl Ord for Queued {
    fn cmp(&self, other: &Self) -> Ordering {
        // The smallest distance first; ties by vertex id, so paths are deterministic.
        other.0.total_cmp(&self.0).then_with(|| other.1.cmp(&self.1))
    }
}

impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Dijkstra from `sources` with `cost[e] ≥ 0` per edge.
pub fn shortest_paths(graph: &EdgeGraph, cost: &[f64], sources: &[u32]) -> ShortestPaths {
    let n = graph.n_vertices();
    let mut distance = vec![f64::INFINITY; n];
    let mut parent = vec![NONE; n];
    let mut nearest = vec![NONE; n];
    let mut heap = BinaryHeap::new();
    for (k, &s) in sources.iter().enumerate() {
        if distance[s as usize] > 0.0 {
            nearest[s as usize] = k as u32;
        }
        distance[s as usize] = 0.0;
        heap.push(Queued(0.0, s));
    }
    while let Some(Queued(d, v)) = heap.pop() {
        if d > distance[v as usize] {
            continue;
        }
        for &(w, e) in graph.around(v) {
            let nd = d + cost[e as usize];
            if nd < distance[w as usize] {
                distance[w as usize] = nd;
                parent[w as usize] = e;
                nearest[w as usize] = nearest[v as usize];
                heap.push(Queued(nd, w));
            }
        }
    }
    ShortestPaths {
        distance,
        parent,
        nearest,
    }
}

impl ShortestPaths {
    /// The edges from `v` back to its source.
    pub fn path_to(&self, graph: &EdgeGraph, mut v: u32) -> Vec<u32> {
        let mut path = Vec::new();
        while self.parent[v as usize] != NONE {
            let e = self.parent[v as usize];
            path.push(e);
            let [a, b] = graph.edges[e as usize];
            v = if a == v { b } else { a };
        }
        path
    }
}

/// Breadth-first ring number of every vertex from `sources` (0 at a
/// source; `u32::MAX` unreached).
pub fn rings(graph: &EdgeGraph, sources: &[u32]) -> Vec<u32> {
    let mut ring = vec![u32::MAX; graph.n_vertices()];
    let mut frontier: Vec<u32> = sources.to_vec();
    for &s in sources {
        ring[s as usize] = 0;
    }
    let mut r = 0;
    while !frontier.is_empty() {
        r += 1;
        let mut next = Vec::new();
        for v in frontier {
            for &(w, _) in graph.around(v) {
                if ring[w as usize] == u32::MAX {
                    ring[w as usize] = r;
                    next.push(w);
                }
            }
        }
        frontier = next;
    }
    ring
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::grid_mesh;

    #[test]
    fn a_grid_has_its_edges_once_and_its_boundary() {
        let mesh = grid_mesh(4, 3);
        let g = EdgeGraph::new(&mesh);
        // 4×3 vertices: 3·3 + 4·2 axis edges and 3·2 diagonals.
        assert_eq!(g.edges.len(), 9 + 8 + 6);
        assert_eq!(g.boundary_vertices().len(), 10);
        for (t, sides) in g.triangle_edges.iter().enumerate() {
            for (k, &e) in sides.iter().enumerate() {
                let (a, b) = (mesh.triangles[t][k], mesh.triangles[t][(k + 1) % 3]);
                assert_eq!(g.edges[e as usize], [a.min(b), a.max(b)]);
            }
        }
    }

    #[test]
    fn shortest_paths_follow_the_cheap_edges() {
        let mesh = grid_mesh(5, 5);
        let g = EdgeGraph::new(&mesh);
        let cost: Vec<f64> = g.edges.iter().map(|_| 1.0).collect();
        let sp = shortest_paths(&g, &cost, &[0]);
        assert_eq!(sp.distance[24], 4.0, "four diagonals to the far corner");
        assert_eq!(sp.path_to(&g, 24).len(), 4);
        assert_eq!(rings(&g, &[12])[0], 2);
    }
}
