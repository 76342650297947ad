//! What a seam costs along each edge: where an artist would not cut is dear.
//! An edge is as dear as it is long, times how close it runs to the
//! landmarks, how much it faces the way the landmarks face (the camera of
//! the photo they come from), and less where it follows a crease, most of
//! all a concave one (a fold the eye does not see). Edges within the margin
//! rings of a landmark are barred (a cost no other way exceeds), and so is
//! the landmarks' own region, the surface within their typical spacing of
//! one: a seam between two landmarks would tear apart what their targets
//! hold together.

use super::graph::{EdgeGraph, NONE, rings, shortest_paths};
use crate::mesh::TriMesh;
use glam::DVec3;

/// Cost factor of an edge inside a landmark's margin: used only where no
/// other seam exists (a handle through a landmark's rings).
pub const BARRED: f64 = 1e6;

/// What seams should keep away from.
#[derive(Debug, Clone, Copy)]
pub struct CostRules<'a> {
    /// Vertices that seams keep away from (the landmarks).
    pub landmarks: &'a [u32],
    /// Rings of vertices around each landmark that no seam enters.
    pub margin_rings: u32,
}

/// Per-vertex facts the costs and the cone choice share.
#[derive(Debug, Clone)]
pub struct Surroundings {
    /// Rings from the nearest landmark (`u32::MAX` without landmarks).
    pub ring: Vec<u32>,
    /// Vertices inside the landmarks' region (see the module docs).
    pub inside: Vec<bool>,
    /// How dear a seam through each vertex is (1 = as cheap as it gets):
    /// near and facing the landmarks costs more.
    pub dearness: Vec<f64>,
    /// The direction the landmarks face (their normals' mean), if any.
    pub facing: Option<DVec3>,
}

/// Area-weighted vertex normals (unit, or zero where undefined).
pub fn vertex_normals(mesh: &TriMesh) -> Vec<DVec3> {
    let mut normals = vec![DVec3::ZERO; mesh.n_vertices()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &v in t {
            normals[v as usize] += n;
        }
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}

/// Rings, dearness and facing of every vertex of `mesh` for `rules`.
pub fn surroundings(mesh: &TriMesh, graph: &EdgeGraph, rules: &CostRules) -> Surroundings {
    let n = mesh.n_vertices();
    if rules.landmarks.is_empty() {
        return Surroundings {
            ring: vec![u32::MAX; n],
            inside: vec![false; n],
            dearness: vec![1.0; n],
            facing: None,
        };
    }
    let normals = vertex_normals(mesh);
    let facing = rules
        .landmarks
        .iter()
        .map(|&v| normals[v as usize])
        .sum::<DVec3>()
        .try_normalize();
    let length: Vec<f64> = graph
        .edges
        .iter()
        .map(|e| mesh.positions[e[0] as usize].distance(mesh.positions[e[1] as usize]))
        .collect();
    let paths = shortest_paths(graph, &length, rules.landmarks);
    let spacing = landmark_spacing(graph, &length, &paths);
    let inside: Vec<bool> = paths
        .distance
        .iter()
        .map(|&d| spacing.is_some_and(|s| d <= REGION * s))
        .collect();
    let geodesic = paths.distance;
    let far = geodesic.iter().copied().filter(|d| d.is_finite()).fold(0.0, f64::max);
    let dearness = (0..n)
        .map(|v| {
            let near = if far > 0.0 && geodesic[v].is_finite() {
                1.0 - geodesic[v] / far
            } else {
                0.0
            };
            let front = facing.map_or(0.0, |f| normals[v].dot(f).max(0.0));
            (1.0 + 3.0 * near * near) * (1.0 + 2.0 * front)
        })
        .collect();
    Surroundings {
        ring: rings(graph, rules.landmarks),
        inside,
        dearness,
        facing,
    }
}

/// The landmarks' region reaches this far from each, relative to their
/// typical spacing: past the middle between neighbours (0.5) and the centre
/// of three (0.58).
const REGION: f64 = 0.75;

/// The median geodesic distance from a landmark to its nearest neighbour,
/// read off the landmarks' Voronoi cells (`paths` from all of them): an
/// edge joining two cells closes a path between their landmarks. `None`
/// for fewer than two landmarks.
fn landmark_spacing(graph: &EdgeGraph, length: &[f64], paths: &super::graph::ShortestPaths) -> Option<f64> {
    let n_sources = paths.nearest.iter().filter(|&&s| s != NONE).max()? + 1;
    let mut nearest = vec![f64::INFINITY; n_sources as usize];
    for (e, &[a, b]) in graph.edges.iter().enumerate() {
        let (sa, sb) = (paths.nearest[a as usize], paths.nearest[b as usize]);
        if sa != sb && sa != NONE && sb != NONE {
            let d = paths.distance[a as usize] + length[e] + paths.distance[b as usize];
            nearest[sa as usize] = nearest[sa as usize].min(d);
            nearest[sb as usize] = nearest[sb as usize].min(d);
        }
    }
    let mut finite: Vec<f64> = nearest.into_iter().filter(|d| d.is_finite()).collect();
    if finite.is_empty() {
        return None;
    }
    finite.sort_by(f64::total_cmp);
    Some(finite[finite.len() / 2])
}

/// The unsigned dihedral angle at edge `e` (0 flat, π folded flat back) and
/// whether the crease is concave (a valley seen from the front).
fn crease(mesh: &TriMesh, graph: &EdgeGraph, e: usize) -> (f64, bool) {
    let [t0, t1] = graph.faces[e];
    if t1 == NONE {
        return (0.0, false);
    }
    let normal = |t: u32| {
        let [a, b, c] = mesh.triangles[t as usize].map(|i| mesh.positions[i as usize]);
        (b - a).cross(c - a).normalize_or_zero()
    };
    let (n0, n1) = (normal(t0), normal(t1));
    let angle = n0.dot(n1).clamp(-1.0, 1.0).acos();
    // The far corner of t1 lies above t0's plane in a valley.
    let far = mesh.triangles[t1 as usize]
        .iter()
        .find(|v| !graph.edges[e].contains(v))
        .map(|&v| mesh.positions[v as usize]);
    let on = mesh.positions[graph.edges[e][0] as usize];
    let concave = far.is_some_and(|p| (p - on).dot(n0) > 0.0);
    (angle, concave)
}

/// The seam cost of every edge of `graph` (see the module docs); boundary
/// edges cost nothing (they are open already).
pub fn edge_costs(mesh: &TriMesh, graph: &EdgeGraph, around: &Surroundings, rules: &CostRules) -> Vec<f64> {
    (0..graph.edges.len())
        .map(|e| {
            if graph.is_boundary(e as u32) {
                return 0.0;
            }
            let [a, b] = graph.edges[e];
            let length = mesh.positions[a as usize].distance(mesh.positions[b as usize]);
            let (angle, concave) = crease(mesh, graph, e);
            let sharp = (angle / std::f64::consts::FRAC_PI_4).min(1.0);
            let crease = 1.0 - if concave { 0.6 } else { 0.3 } * sharp;
            let dear = 0.5 * (around.dearness[a as usize] + around.dearness[b as usize]);
            let barred = [a, b]
                .iter()
                .any(|&v| around.ring[v as usize] <= rules.margin_rings || around.inside[v as usize]);
            length * crease * dear * if barred { BARRED } else { 1.0 }
        })
        .collect()
}
