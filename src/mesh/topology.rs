//! Topology of one chart: edge manifoldness, consistent orientation, boundary
//! loops (outer loop = longest in 3D), and the disk check that makes the
//! force-density embedding of §III fold-free.

use super::TriMesh;
use thiserror::Error;

/// Why a chart cannot be parameterised. Every variant names the offending
/// vertices or triangles (chart-local indices unless stated otherwise).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TopologyError {
    #[error("triangle {triangle} repeats a vertex ({a}, {b}, {c}): it has no area in any layout")]
    DegenerateTriangle { triangle: usize, a: u32, b: u32, c: u32 },
    #[error("triangle {triangle} refers to vertex {vertex}, but the chart has only {n_vertices} vertices")]
    VertexOutOfRange {
        triangle: usize,
        vertex: u32,
        n_vertices: usize,
    },
    #[error(
        "non-manifold edge ({a}, {b}): shared by {n_triangles} triangles (at most 2 allowed), e.g. triangles {triangles:?}"
    )]
    NonManifoldEdge {
        a: u32,
        b: u32,
        n_triangles: usize,
        triangles: Vec<usize>,
    },
    #[error(
        "edge ({a}, {b}) is used in the same direction by triangles {t0} and {t1}: their windings disagree (the surface is not consistently oriented)"
    )]
    InconsistentOrientation { a: u32, b: u32, t0: usize, t1: usize },
    #[error("non-manifold vertex {vertex}: its triangles form {n_fans} separate fans (a bow-tie)")]
    NonManifoldVertex { vertex: u32, n_fans: usize },
    #[error("the chart is closed (no boundary edges): cut it open so it has a boundary to map onto the square")]
    Closed,
    #[error("the chart is not a disk: genus {genus} with {n_loops} boundary loops; cut handles open first")]
    NotADisk { genus: i64, n_loops: usize },
    #[error("the chart has no triangles")]
    Empty,
}

/// Topology of a manifold, consistently oriented chart with at least one boundary.
#[derive(Debug, Clone)]
pub struct Topology {
    /// Boundary loops, each following the faces' winding (the face lies to the
    /// left of each boundary edge `loop[i] → loop[i+1]`). `loops[outer]` is the
    /// longest loop in 3D (or the outermost in a camera's view,
    /// [`Topology::outermost_in`]); the others are holes.
    pub loops: Vec<Vec<u32>>,
    /// Index into `loops` of the outer loop.
    pub outer: usize,
    /// 3D length of each loop.
    pub loop_lengths: Vec<f64>,
    /// Every undirected edge once, `(min, max)`.
    pub edges: Vec<[u32; 2]>,
    /// `true` for edges with one triangle (same order as `edges`).
    pub edge_is_boundary: Vec<bool>,
}

impl Topology {
    /// Checks `mesh` and finds its boundary loops.
    ///
    /// # Errors
    /// Any [`TopologyError`]: repeated vertex in a triangle, edge with > 2
    /// triangles or inconsistent winding, bow-tie vertex, closed surface, genus
    /// > 0.
    pub fn build(mesh: &TriMesh) -> Result<Self, TopologyError> {
        check_triangles(mesh)?;
        let half = HalfEdges::new(mesh);
        let mut edges = classify_edges(mesh, &half)?;
        let used = check_fans(mesh, &mut edges.fans)?;
        let loops = boundary_loops(&edges.boundary_next);
        if loops.is_empty() {
            return Err(TopologyError::Closed);
        }
        let loop_lengths: Vec<f64> = loops.iter().map(|l| loop_length(mesh, l)).collect();
        let outer = (0..loops.len())
            .max_by(|&a, &b| loop_lengths[a].total_cmp(&loop_lengths[b]))
            .expect("non-empty");
        // Euler characteristic of the used vertices: V - E + F = 2 - 2g - b.
        let chi = used as i64 - edges.edges.len() as i64 + mesh.triangles.len() as i64;
        let genus2 = 2 - loops.len() as i64 - chi;
        if genus2 != 0 {
            return Err(TopologyError::NotADisk {
                genus: genus2 / 2,
                n_loops: loops.len(),
            });
        }
        Ok(Topology {
            loops,
            outer,
            loop_lengths,
            edges: edges.edges,
            edge_is_boundary: edges.edge_is_boundary,
        })
    }

    /// The outer boundary loop.
    pub fn outer_loop(&self) -> &[u32] {
        &self.loops[self.outer]
    }

    /// Takes as the outer loop the one that encloses the most area where
    /// `layout` puts the vertices (a chart seen by a camera, whose longest
    /// loop in 3D may be a bore's rim inside its outline).
    pub fn outermost_in(mut self, layout: &[glam::DVec2]) -> Self {
        let area = |l: &[u32]| {
            (0..l.len())
                .map(|i| layout[l[i] as usize].perp_dot(layout[l[(i + 1) % l.len()] as usize]))
                .sum::<f64>()
        };
        let widest = (0..self.loops.len()).max_by(|&a, &b| area(&self.loops[a]).total_cmp(&area(&self.loops[b])));
        if let Some(k) = widest {
            self.outer = k;
        }
        self
    }

    /// The inner loops (holes), in loop order.
    pub fn holes(&self) -> impl Iterator<Item = &Vec<u32>> {
        self.loops
            .iter()
            .enumerate()
            .filter(move |(i, _)| *i != self.outer)
            .map(|(_, l)| l)
    }
}

/// Every triangle names three distinct vertices of the mesh.
fn check_triangles(mesh: &TriMesh) -> Result<(), TopologyError> {
    let n = mesh.n_vertices();
    if mesh.triangles.is_empty() {
        return Err(TopologyError::Empty);
    }
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = *tri;
        if let Some(&v) = tri.iter().find(|&&v| v as usize >= n) {
            return Err(TopologyError::VertexOutOfRange {
                triangle: t,
                vertex: v,
                n_vertices: n,
            });
        }
        if a == b || b == c || a == c {
            return Err(TopologyError::DegenerateTriangle { triangle: t, a, b, c });
        }
    }
    Ok(())
}

/// Directed half-edges `a → b` grouped by their source `a` (compressed rows
/// of `(b, triangle)`): each twin lookup scans one vertex's few edges.
struct HalfEdges {
    offsets: Vec<usize>,
    rows: Vec<(u32, u32)>,
}

impl HalfEdges {
    fn new(mesh: &TriMesh) -> Self {
        let n = mesh.n_vertices();
        let mut offsets = vec![0usize; n + 1];
        for tri in &mesh.triangles {
            for &v in tri {
                offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut rows = vec![(0u32, 0u32); mesh.triangles.len() * 3];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let a = tri[k] as usize;
                rows[fill[a]] = (tri[(k + 1) % 3], t as u32);
                fill[a] += 1;
            }
        }
        HalfEdges { offsets, rows }
    }

    /// The half-edges leaving `a`: `(target, triangle)`.
    fn from(&self, a: u32) -> &[(u32, u32)] {
        &self.rows[self.offsets[a as usize]..self.offsets[a as usize + 1]]
    }

    /// The triangles of half-edges `a → b`.
    fn between(&self, a: u32, b: u32) -> impl Iterator<Item = u32> + '_ {
        self.from(a).iter().filter(move |(x, _)| *x == b).map(|h| h.1)
    }
}

/// The edges of a checked mesh and what they tell about its vertices.
struct EdgeClasses {
    edges: Vec<[u32; 2]>,
    edge_is_boundary: Vec<bool>,
    /// Per vertex, the next boundary vertex along the winding (`u32::MAX`: none).
    boundary_next: Vec<u32>,
    /// Corner fans: (triangle, corner) joined across interior edges.
    fans: UnionFind,
}

/// Classifies every edge as interior or boundary.
///
/// # Errors
/// An edge with more than two triangles, with two triangles of the same
/// winding, or a vertex where two boundary edges leave.
fn classify_edges(mesh: &TriMesh, half: &HalfEdges) -> Result<EdgeClasses, TopologyError> {
    let n_half = mesh.triangles.len() * 3;
    let mut out = EdgeClasses {
        edges: Vec::with_capacity(n_half / 2 + 8),
        edge_is_boundary: Vec::with_capacity(n_half / 2 + 8),
        boundary_next: vec![u32::MAX; mesh.n_vertices()],
        fans: UnionFind::new(n_half),
    };
    let corner = |t: u32, v: u32| -> usize {
        let tri = mesh.triangles[t as usize];
        let k = tri.iter().position(|&x| x == v).expect("vertex of triangle");
        t as usize * 3 + k
    };
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let twin = check_edge(half, t, a, b)?;
            match twin {
                None => {
                    if out.boundary_next[a as usize] != u32::MAX {
                        return Err(TopologyError::NonManifoldVertex { vertex: a, n_fans: 2 });
                    }
                    out.boundary_next[a as usize] = b;
                    out.edges.push([a.min(b), a.max(b)]);
                    out.edge_is_boundary.push(true);
                }
                Some(twin) if a < b => {
                    out.fans.union(corner(t as u32, a), corner(twin, a));
                    out.fans.union(corner(t as u32, b), corner(twin, b));
                    out.edges.push([a, b]);
                    out.edge_is_boundary.push(false);
                }
                Some(_) => {}
            }
        }
    }
    Ok(out)
}

/// Checks half-edge `a → b` of triangle `t`; its twin's triangle, if any.
fn check_edge(half: &HalfEdges, t: usize, a: u32, b: u32) -> Result<Option<u32>, TopologyError> {
    let n_same = half.between(a, b).count();
    let mut opposite = half.between(b, a);
    let twin = opposite.next();
    let n_opposite = twin.map_or(0, |_| 1 + opposite.count());
    if n_same + n_opposite > 2 {
        let mut triangles: Vec<usize> = half
            .between(a, b)
            .chain(half.between(b, a))
            .map(|t| t as usize)
            .collect();
        triangles.sort_unstable();
        return Err(TopologyError::NonManifoldEdge {
            a: a.min(b),
            b: a.max(b),
            n_triangles: triangles.len(),
            triangles: triangles.into_iter().take(4).collect(),
        });
    }
    if n_same > 1 {
        let other = half.between(a, b).find(|&o| o as usize != t).expect("two triangles");
        return Err(TopologyError::InconsistentOrientation {
            a,
            b,
            t0: t,
            t1: other as usize,
        });
    }
    Ok(twin)
}

/// Every vertex's corners must form one fan; returns how many vertices are used.
fn check_fans(mesh: &TriMesh, fans: &mut UnionFind) -> Result<usize, TopologyError> {
    let mut fan_of: Vec<u32> = vec![u32::MAX; mesh.n_vertices()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for (k, &v) in tri.iter().enumerate() {
            let root = fans.find(t * 3 + k) as u32;
            let slot = &mut fan_of[v as usize];
            if *slot == u32::MAX {
                *slot = root;
            } else if *slot != root {
                return Err(TopologyError::NonManifoldVertex { vertex: v, n_fans: 2 });
            }
        }
    }
    Ok(fan_of.iter().filter(|&&f| f != u32::MAX).count())
}

/// The boundary loops, each following `boundary_next` from its smallest vertex.
fn boundary_loops(boundary_next: &[u32]) -> Vec<Vec<u32>> {
    let mut loops = Vec::new();
    let mut visited = vec![false; boundary_next.len()];
    for start in 0..boundary_next.len() {
        if boundary_next[start] == u32::MAX || visited[start] {
            continue;
        }
        let mut lp = Vec::new();
        let mut v = start as u32;
        while !visited[v as usize] {
            visited[v as usize] = true;
            lp.push(v);
            v = boundary_next[v as usize];
            debug_assert!(v != u32::MAX, "open boundary chain");
        }
        loops.push(lp);
    }
    loops
}

/// 3D length of a closed vertex loop.
pub fn loop_length(mesh: &TriMesh, lp: &[u32]) -> f64 {
    (0..lp.len())
        .map(|i| mesh.positions[lp[i] as usize].distance(mesh.positions[lp[(i + 1) % lp.len()] as usize]))
        .sum()
}

/// The connected pieces of `mesh` (triangles joined through shared
/// vertices): their number, and each triangle's piece, numbered in
/// triangle order.
pub fn triangle_components(mesh: &TriMesh) -> (usize, Vec<u32>) {
    let mut uf = UnionFind::new(mesh.n_vertices());
    for t in &mesh.triangles {
        uf.union(t[0] as usize, t[1] as usize);
        uf.union(t[1] as usize, t[2] as usize);
    }
    let mut piece_of_root = vec![u32::MAX; mesh.n_vertices()];
    let mut n = 0u32;
    let pieces = mesh
        .triangles
        .iter()
        .map(|t| {
            let root = uf.find(t[0] as usize);
            if piece_of_root[root] == u32::MAX {
                piece_of_root[root] = n;
                n += 1;
            }
            piece_of_root[root]
        })
        .collect();
    (n as usize, pieces)
}

/// Disjoint sets with path halving and union by size.
#[derive(Debug, Clone)]
pub struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    pub fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }
    pub fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] as usize != x {
            let p = self.parent[x] as usize;
            self.parent[x] = self.parent[p];
            x = self.parent[x] as usize;
        }
        x
    }
    pub fn union(&mut self, a: usize, b: usize) {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return;
        }
        if self.size[ra] < self.size[rb] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb] = ra as u32;
        self.size[ra] += self.size[rb];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::grid_mesh;
    use glam::DVec3;

    #[test]
    fn grid_has_one_loop_of_perimeter_length() {
        let mesh = grid_mesh(5, 4);
        let topo = Topology::build(&mesh).unwrap();
        assert_eq!(topo.loops.len(), 1);
        assert_eq!(topo.outer_loop().len(), 2 * (5 - 1) + 2 * (4 - 1));
        assert!((topo.loop_lengths[0] - 2.0 * (1.0 + 1.0)).abs() < 1e-12);
    }

    #[test]
    fn the_outer_loop_in_a_view_is_the_one_around_the_others() {
        // A flat ring whose inner loop zigzags in depth: longer in 3D than
        // the outer loop, but inside it where a camera along z sees it.
        let n = 24;
        let mut positions = Vec::new();
        for i in 0..n {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            positions.push(DVec3::new(a.cos(), a.sin(), 0.0));
            let depth = if i % 2 == 0 { 3.0 } else { -3.0 };
            positions.push(DVec3::new(0.5 * a.cos(), 0.5 * a.sin(), depth));
        }
        let triangles = (0..n as u32)
            .flat_map(|i| {
                let j = (i + 1) % n as u32;
                [[2 * i, 2 * j, 2 * j + 1], [2 * i, 2 * j + 1, 2 * i + 1]]
            })
            .collect();
        let mesh = TriMesh { positions, triangles };
        let topo = Topology::build(&mesh).unwrap();
        assert!(topo.outer_loop()[0] % 2 == 1, "the zigzag loop is the longest in 3D");
        let view: Vec<glam::DVec2> = mesh.positions.iter().map(|p| p.truncate()).collect();
        let seen = topo.outermost_in(&view);
        assert!(seen.outer_loop().iter().all(|v| v % 2 == 0), "the loop around the ring");
        assert_eq!(seen.holes().count(), 1);
    }

    #[test]
    fn tetrahedron_is_closed() {
        let mesh = TriMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
        };
        assert_eq!(Topology::build(&mesh).unwrap_err(), TopologyError::Closed);
    }

    #[test]
    fn three_triangles_on_one_edge_are_non_manifold() {
        let mesh = TriMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::NEG_Y, DVec3::Z],
            triangles: vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        };
        match Topology::build(&mesh).unwrap_err() {
            TopologyError::NonManifoldEdge {
                a: 0,
                b: 1,
                n_triangles: 3,
                ..
            } => {}
            e => panic!("unexpected {e:?}"),
        }
    }

    #[test]
    fn flipped_neighbour_is_inconsistent() {
        let mesh = TriMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)],
            triangles: vec![[0, 1, 2], [1, 2, 3]],
        };
        assert!(matches!(
            Topology::build(&mesh).unwrap_err(),
            TopologyError::InconsistentOrientation { .. }
        ));
    }

    #[test]
    fn bow_tie_vertex_is_rejected() {
        let mesh = TriMesh {
            positions: vec![
                DVec3::ZERO,
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(-1.0, 0.0, 0.0),
                DVec3::new(-1.0, -1.0, 0.0),
            ],
            triangles: vec![[0, 1, 2], [0, 3, 4]],
        };
        assert!(matches!(
            Topology::build(&mesh).unwrap_err(),
            TopologyError::NonManifoldVertex { vertex: 0, .. }
        ));
    }

    #[test]
    fn cylinder_is_not_a_disk_but_annulus_is_fine() {
        // A grid with a hole: remove the two triangles of the centre quad.
        let mut mesh = grid_mesh(4, 4);
        mesh.triangles.retain(|t| {
            let c = t.iter().map(|&v| mesh.positions[v as usize]).sum::<DVec3>() / 3.0;
            !(c.x > 1.0 / 3.0 && c.x < 2.0 / 3.0 && c.y > 1.0 / 3.0 && c.y < 2.0 / 3.0)
        });
        let topo = Topology::build(&mesh).unwrap();
        assert_eq!(topo.loops.len(), 2);
        assert_eq!(topo.holes().count(), 1);
        // Glue the left and right columns: a cylinder (two boundary loops, genus 0) is fine
        // topologically, but a torus-like identification of both sides is not a disk.
        let mut tube = grid_mesh(5, 3);
        let nx = 5;
        for t in &mut tube.triangles {
            for v in t.iter_mut() {
                if *v as usize % nx == nx - 1 {
                    *v -= (nx - 1) as u32;
                }
            }
        }
        // A tube has 2 loops and genus 0 (an annulus): accepted as outer loop + hole.
        let topo = Topology::build(&tube).unwrap();
        assert_eq!(topo.loops.len(), 2);
    }
}
