//! Splitting vertices into wedges: the corners of a vertex that are joined
//! across manifold edges keep one vertex, and every other group of corners
//! gets a copy of its own. This is how a chart is opened along seams (an
//! edge on a seam joins nothing) and how it is repaired for the solve: a
//! pinch (a vertex where two fans meet, a bow-tie) becomes one vertex per
//! fan, an edge shared by more than two triangles keeps one consistently
//! wound pair joined and leaves the others on a boundary, and two triangles
//! whose windings disagree across an edge are not joined there.
//!
//! Copies are numbered after the original vertices, in corner order, so a
//! mesh with nothing to split comes back unchanged with the same ids.

use super::TriMesh;
use super::topology::UnionFind;

/// A mesh with its vertices split into wedges.
#[derive(Debug, Clone, PartialEq)]
pub struct Wedges {
    /// The split mesh: the same triangles in the same order.
    pub mesh: TriMesh,
    /// For every vertex of `mesh`, the vertex of the input it copies
    /// (`origin[v] == v` for the first `n` vertices).
    pub origin: Vec<u32>,
    /// What was repaired that no seam asked for, for the report.
    pub repairs: Repairs,
}

/// Where the input was not a manifold, consistently wound surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Repairs {
    /// Edges shared by more than two triangles: the edge and its triangles.
    pub non_manifold_edges: Vec<([u32; 2], Vec<u32>)>,
    /// Edges whose two triangles are wound the same way: the edge and them.
    pub inconsistent_edges: Vec<([u32; 2], [u32; 2])>,
    /// Vertices (of the input) split into several fans with no seam or
    /// repaired edge through them: pinches.
    pub pinches: Vec<u32>,
    /// Back faces of double-sided faces (welded triangles repeating an
    /// earlier one's vertices in the other winding): laid out apart.
    pub back_faces: Vec<u32>,
}

impl Repairs {
    /// Nothing was repaired.
    pub fn is_empty(&self) -> bool {
        self.non_manifold_edges.is_empty()
            && self.inconsistent_edges.is_empty()
            && self.pinches.is_empty()
            && self.back_faces.is_empty()
    }
}

impl Wedges {
    /// How many vertices were added.
    pub fn n_added(&self) -> usize {
        self.origin.iter().enumerate().filter(|(v, o)| *v as u32 != **o).count()
    }
}

/// One half-edge `tri[k] → tri[k + 1]` of triangle `t`, keyed by its
/// undirected edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct HalfEdge {
    edge: [u32; 2],
    triangle: u32,
    k: u8,
}

/// The half-edges of `mesh`, sorted by undirected edge (then triangle).
fn sorted_half_edges(mesh: &TriMesh) -> Vec<HalfEdge> {
    let mut half: Vec<HalfEdge> = mesh
        .triangles
        .iter()
        .enumerate()
        .flat_map(|(t, tri)| {
            (0..3).map(move |k| {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                HalfEdge {
                    edge: [a.min(b), a.max(b)],
                    triangle: t as u32,
                    k: k as u8,
                }
            })
        })
        .collect();
    rayon::slice::ParallelSliceMut::par_sort_unstable(&mut half[..]);
    half
}

/// Splits `mesh`'s vertices into wedges; corners are joined across every
/// edge that is manifold and consistently wound and for which `is_seam`
/// says no. Triangles must name three distinct vertices in range.
pub fn split_wedges(mesh: &TriMesh, is_seam: &dyn Fn([u32; 2]) -> bool) -> Wedges {
    let first = split_once(mesh, is_seam);
    // Corners joined around a vertex through other edges can still bring
    // three triangles (or two wound alike) onto one edge: those beyond a
    // consistently wound pair are set apart whole, and what that pinches is
    // split again.
    let Some(detached) = detach_extra(&first.mesh) else {
        return first;
    };
    let second = split_once(&detached.mesh, &|_| false);
    let origin: Vec<u32> = second
        .origin
        .iter()
        .map(|&v| first.origin[detached.origin[v as usize] as usize])
        .collect();
    let mut repairs = first.repairs;
    repairs
        .pinches
        .extend(second.repairs.pinches.iter().map(|&v| origin[v as usize]));
    repairs.pinches.sort_unstable();
    repairs.pinches.dedup();
    Wedges {
        mesh: second.mesh,
        origin,
        repairs,
    }
}

/// `mesh` with every triangle beyond a consistently wound pair on one of
/// its edges given vertices of its own (each vertex's origin alongside);
/// `None` when every edge is manifold and consistently wound.
fn detach_extra(mesh: &TriMesh) -> Option<Wedges> {
    let half = sorted_half_edges(mesh);
    let mut detach = vec![false; mesh.triangles.len()];
    for group in half.chunk_by(|a, b| a.edge == b.edge) {
        let forward = |h: &HalfEdge| mesh.triangles[h.triangle as usize][h.k as usize] == h.edge[0];
        let live: Vec<&HalfEdge> = group.iter().filter(|h| !detach[h.triangle as usize]).collect();
        // Kept: one a → b and one b → a half-edge, else only the first.
        let kept = match (
            live.iter().position(|h| forward(h)),
            live.iter().position(|h| !forward(h)),
        ) {
            (Some(a), Some(b)) => [a, b],
            _ => [0, 0],
        };
        for (_, h) in live.iter().enumerate().filter(|(k, _)| !kept.contains(k)) {
            detach[h.triangle as usize] = true;
        }
    }
    if !detach.contains(&true) {
        return None;
    }
    let mut positions = mesh.positions.clone();
    let mut origin: Vec<u32> = (0..mesh.n_vertices() as u32).collect();
    let mut triangles = mesh.triangles.clone();
    for (_, tri) in triangles.iter_mut().enumerate().filter(|(t, _)| detach[*t]) {
        for v in tri.iter_mut() {
            origin.push(*v);
            positions.push(mesh.positions[*v as usize]);
            *v = (origin.len() - 1) as u32;
        }
    }
    Some(Wedges {
        mesh: TriMesh { positions, triangles },
        origin,
        repairs: Repairs::default(),
    })
}

/// One pass of [`split_wedges`].
fn split_once(mesh: &TriMesh, is_seam: &dyn Fn([u32; 2]) -> bool) -> Wedges {
    let half = sorted_half_edges(mesh);
    let mut corners = UnionFind::new(mesh.triangles.len() * 3);
    let mut repairs = Repairs::default();
    let mut repaired_vertex = vec![false; mesh.n_vertices()];
    let mut start = 0;
    while start < half.len() {
        let edge = half[start].edge;
        let end = start + half[start..].iter().take_while(|h| h.edge == edge).count();
        let group = &half[start..end];
        start = end;
        if is_seam(edge) {
            edge.iter().for_each(|&v| repaired_vertex[v as usize] = true);
            continue;
        }
        join_across(mesh, edge, group, &mut corners, &mut repairs, &mut repaired_vertex);
    }
    let (triangles, origin) = number_wedges(mesh, &mut corners);
    let mut positions = mesh.positions.clone();
    positions.extend(origin[mesh.n_vertices()..].iter().map(|&o| mesh.positions[o as usize]));
    let mut pinched: Vec<u32> = origin[mesh.n_vertices()..]
        .iter()
        .copied()
        .filter(|&o| !repaired_vertex[o as usize])
        .collect();
    pinched.sort_unstable();
    pinched.dedup();
    repairs.pinches = pinched;
    Wedges {
        mesh: TriMesh { positions, triangles },
        origin,
        repairs,
    }
}

/// Joins the corners of the triangles on `edge` (all its half-edges in
/// `group`): each half-edge `a → b` pairs with one `b → a`, in triangle
/// order; what stays unpaired borders the edge alone.
fn join_across(
    mesh: &TriMesh,
    edge: [u32; 2],
    group: &[HalfEdge],
    corners: &mut UnionFind,
    repairs: &mut Repairs,
    repaired_vertex: &mut [bool],
) {
    let forward = |h: &&HalfEdge| mesh.triangles[h.triangle as usize][h.k as usize] == edge[0];
    let ahead: Vec<&HalfEdge> = group.iter().filter(forward).collect();
    let back: Vec<&HalfEdge> = group.iter().filter(|h| !forward(h)).collect();
    if group.len() > 2 {
        let triangles = group.iter().map(|h| h.triangle).collect();
        repairs.non_manifold_edges.push((edge, triangles));
        edge.iter().for_each(|&v| repaired_vertex[v as usize] = true);
    } else if group.len() == 2 && back.len() != 1 {
        repairs
            .inconsistent_edges
            .push((edge, [group[0].triangle, group[1].triangle]));
        edge.iter().for_each(|&v| repaired_vertex[v as usize] = true);
    }
    for (h, g) in ahead.iter().zip(&back) {
        // h: a → b at corner k of its triangle; g: b → a.
        let (t, k) = (h.triangle as usize, h.k as usize);
        let (s, j) = (g.triangle as usize, g.k as usize);
        corners.union(t * 3 + k, s * 3 + (j + 1) % 3);
        corners.union(t * 3 + (k + 1) % 3, s * 3 + j);
    }
}

/// Gives each group of joined corners a vertex: the first group met at a
/// vertex keeps its id, later ones get new ids in corner order. The
/// triangles on the new ids, and each vertex's origin.
fn number_wedges(mesh: &TriMesh, corners: &mut UnionFind) -> (Vec<[u32; 3]>, Vec<u32>) {
    let n = mesh.n_vertices();
    let mut origin: Vec<u32> = (0..n as u32).collect();
    // The root of the group that kept vertex v's id.
    let mut kept_root = vec![u32::MAX; n];
    let mut id_of_root = vec![u32::MAX; mesh.triangles.len() * 3];
    let mut triangles = mesh.triangles.clone();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for (k, &v) in tri.iter().enumerate() {
            let root = corners.find(t * 3 + k);
            if id_of_root[root] == u32::MAX {
                id_of_root[root] = if kept_root[v as usize] == u32::MAX {
                    kept_root[v as usize] = root as u32;
                    v
                } else {
                    origin.push(v);
                    (origin.len() - 1) as u32
                };
            }
            triangles[t][k] = id_of_root[root];
        }
    }
    (triangles, origin)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::{Topology, TopologyError, triangle_components};
    use crate::testing::grid_mesh;
    use glam::DVec3;

    fn no_seam(_: [u32; 2]) -> bool {
        false
    }

    #[test]
    fn a_manifold_disk_comes_back_unchanged() {
        let mesh = grid_mesh(6, 5);
        let w = split_wedges(&mesh, &no_seam);
        assert_eq!(w.mesh, mesh);
        assert_eq!(w.n_added(), 0);
        assert!(w.repairs.is_empty());
    }

    #[test]
    fn a_bow_tie_becomes_two_fans_and_is_named_a_pinch() {
        let mesh = TriMesh {
            positions: vec![
                DVec3::ZERO,
                DVec3::X,
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::NEG_X,
                DVec3::new(-1.0, -1.0, 0.0),
            ],
            triangles: vec![[0, 1, 2], [0, 3, 4]],
        };
        let w = split_wedges(&mesh, &no_seam);
        assert_eq!(w.mesh.triangles, vec![[0, 1, 2], [5, 3, 4]]);
        assert_eq!(w.origin[5], 0);
        assert_eq!(w.repairs.pinches, vec![0]);
    }

    #[test]
    fn a_seam_across_a_grid_opens_it_into_two_sheets_along_the_seam() {
        // A 4 × 3 grid cut along its middle column line x = 1/3 from the
        // bottom to the top: the line's inner vertices split, its ends too.
        let mesh = grid_mesh(4, 3);
        let nx = 4u32;
        let column: Vec<u32> = (0..3).map(|j| j * nx + 1).collect();
        let seam = |e: [u32; 2]| column.contains(&e[0]) && column.contains(&e[1]);
        let w = split_wedges(&mesh, &seam);
        assert_eq!(w.n_added(), 3);
        assert!(w.repairs.pinches.is_empty());
        let (n_pieces, piece_of) = triangle_components(&w.mesh);
        assert_eq!(n_pieces, 2, "two sheets side by side");
        assert_eq!(piece_of[0], 0);
    }

    #[test]
    fn a_slit_inside_a_disk_makes_a_hole_and_its_tips_stay_whole() {
        let mesh = grid_mesh(5, 5);
        let slit = [6u32, 7, 8];
        let seam = |e: [u32; 2]| slit.windows(2).any(|w| [w[0].min(w[1]), w[0].max(w[1])] == e);
        let w = split_wedges(&mesh, &seam);
        // Only the slit's middle vertex is on two seam edges.
        assert_eq!(w.n_added(), 1);
        assert_eq!(w.origin[25], 7);
        let topology = Topology::build(&w.mesh).unwrap();
        assert_eq!(topology.loops.len(), 2, "the outline and the slit's hole");
    }

    #[test]
    fn a_third_triangle_on_an_edge_is_left_on_a_boundary_and_named() {
        let mesh = TriMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::NEG_Y, DVec3::Z],
            triangles: vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        };
        let w = split_wedges(&mesh, &no_seam);
        assert_eq!(w.repairs.non_manifold_edges, vec![([0, 1], vec![0, 1, 2])]);
        assert!(w.repairs.pinches.is_empty());
        // Triangles 0 and 1 stay joined; triangle 2 has its own copies of 0 and 1.
        assert_eq!(w.mesh.triangles[0][..2], [0, 1]);
        assert_eq!(w.mesh.triangles[1][..2], [1, 0]);
        assert!(w.mesh.triangles[2][0] >= 5 && w.mesh.triangles[2][1] >= 5);
    }

    #[test]
    fn any_soup_comes_out_a_manifold_consistently_wound_surface() {
        // Random triangles over few vertices: fins, fans glued around
        // non-manifold edges, windings that disagree.
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = |n: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % u64::from(n)) as u32
        };
        for _ in 0..400 {
            let n = 4 + next(6);
            let positions = (0..n)
                .map(|v| DVec3::new(f64::from(v), f64::from(v * v % 7), 0.0))
                .collect();
            let triangles = (0..2 + next(14))
                .map(|_| {
                    let a = next(n);
                    let b = (a + 1 + next(n - 1)) % n;
                    let c = (0..n)
                        .find(|&c| c != a && c != b && next(3) == 0)
                        .unwrap_or((a.max(b) + 1) % n);
                    [a, b, if c == a || c == b { (a.max(b) + 2) % n } else { c }]
                })
                .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
                .collect();
            let mesh = TriMesh { positions, triangles };
            let w = split_wedges(&mesh, &no_seam);
            assert_eq!(w.mesh.triangles.len(), mesh.triangles.len());
            for (t, tri) in w.mesh.triangles.iter().enumerate() {
                assert_eq!(tri.map(|v| w.origin[v as usize]), mesh.triangles[t]);
            }
            if let Err(
                e @ (TopologyError::NonManifoldEdge { .. }
                | TopologyError::InconsistentOrientation { .. }
                | TopologyError::NonManifoldVertex { .. }),
            ) = Topology::build(&w.mesh)
            {
                panic!("{e} in {:?} from {:?}", w.mesh.triangles, mesh.triangles);
            }
        }
    }

    #[test]
    fn disagreeing_windings_are_not_joined() {
        let mesh = TriMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)],
            triangles: vec![[0, 1, 2], [1, 2, 3]],
        };
        let w = split_wedges(&mesh, &no_seam);
        assert_eq!(w.repairs.inconsistent_edges, vec![([1, 2], [0, 1])]);
        assert_eq!(triangle_components(&w.mesh).0, 2, "two triangles apart");
    }
}
