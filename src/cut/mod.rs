//! Cutting a chart open to a disk where an artist would: a closed surface,
//! or one with handles, has no boundary loop to lay out (§III needs a disk).
//! Handles are opened by a tree–cotree cut ([`handles`]); a closed surface
//! is opened by a seam tree through cone points ([`cones`]), the points
//! where the flattening would crush it most. Every seam follows the
//! cheapest edges ([`cost`]): far from the landmarks and never within their
//! margin rings, on the side facing away from them, short, along creases.
//! Deterministic: the same mesh and landmarks give the same seam.

pub mod cones;
pub mod cost;
pub mod facing;
pub mod graph;
pub mod grown;
pub mod handles;
pub mod occlusion;
pub mod prepare;
pub mod separate;

use crate::mesh::TriMesh;
use crate::mesh::topology::{Topology, TopologyError};
use crate::mesh::wedges::{Wedges, split_wedges};
use graph::{EdgeGraph, shortest_paths};
use thiserror::Error;

/// How seams are chosen.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum SeamSpec {
    /// Where the chart needs them, placed automatically.
    #[default]
    Auto,
    /// Along these vertex paths (each step an edge of the mesh), and
    /// nowhere else.
    Edges(Vec<Vec<u32>>),
}

/// The rules of automatic seams.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeamRules {
    /// Rings of vertices around each landmark no seam enters. Default 3.
    pub margin_rings: u32,
    /// At most this many cone points on a closed surface. Default 16.
    pub max_cones: usize,
    /// Cones are added while the flattening's log scale factor somewhere
    /// off the seams, divided by how dear a seam there is, exceeds this
    /// (1: about 7× in area where a seam is cheap). Default 1.
    pub cone_threshold: f64,
    /// Whether a disk is cut out to cone points wherever its flattening
    /// would crush it, not only when it is nearly closed (default false:
    /// a landmarked patch keeps its shape; charts laid out without
    /// landmarks set it).
    pub spread_disks: bool,
}

impl SeamRules {
    /// The defaults written in each field's doc.
    pub const DEFAULT: SeamRules = SeamRules {
        margin_rings: 3,
        max_cones: 16,
        cone_threshold: 1.0,
        spread_disks: false,
    };
}

impl Default for SeamRules {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Where a chart is cut.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Seam {
    /// The seam's edges (vertex pairs `(min, max)` of the uncut mesh), sorted.
    pub edges: Vec<[u32; 2]>,
    /// The cone points the seam tree reaches (automatic seams).
    pub cones: Vec<u32>,
    /// How many of the edges open handles.
    pub n_handle_edges: usize,
    /// 3D length of the seam.
    pub length: f64,
}

/// Why a chart could not be cut open.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CutError {
    #[error("seams[{path}]: vertices {a} and {b} (steps {step} and {}) are not joined by an edge of the chart", step + 1)]
    NotAnEdge { path: usize, step: usize, a: u32, b: u32 },
    #[error("seams[{path}] runs through landmark vertex {vertex}: a landmark must not lie on a seam")]
    ThroughLandmark { path: usize, vertex: u32 },
    #[error(
        "seams[{path}] leaves the piece of the chart that is solved (the chart falls apart where it is not a surface)"
    )]
    OffPiece { path: usize },
    #[error("seams[{path}] runs along edge ({a}, {b}) inside a polygon of the file: a polygon keeps one UV per corner")]
    InsidePolygon { path: usize, a: u32, b: u32 },
    #[error("the seams leave the chart {left}: add seams that open it (or `seams: Auto`)")]
    NotOpened { left: String },
    #[error("the automatic seams leave the chart {left}: give `seams` that open it")]
    AutoNotOpened { left: String },
}

/// The chart opened along `seam`: its wedges and its topology.
#[derive(Debug, Clone)]
pub struct Opened {
    pub wedges: Wedges,
    pub topology: Topology,
    pub seam: Seam,
}

/// Opens `mesh` (manifold, one piece) along the seams `spec` asks for,
/// keeping them away from `landmarks` and off the `unseamable` edges
/// (`(min, max)` pairs, sorted). With `Auto`, a disk (holes allowed) is
/// not cut and comes back as `Ok(None)`.
///
/// # Errors
/// Given seams that are not edges, run through a landmark, or leave the
/// chart closed or with handles.
pub fn open(
    mesh: &TriMesh,
    spec: &SeamSpec,
    landmarks: &[u32],
    unseamable: &[[u32; 2]],
    rules: &SeamRules,
) -> Result<Option<Opened>, CutError> {
    let topology = Topology::build(mesh);
    if let (SeamSpec::Auto, Ok(t)) = (spec, &topology)
        && !rules.spread_disks
        && !nearly_closed(mesh, t)
    {
        return Ok(None);
    }
    let graph = EdgeGraph::new(mesh);
    let seam = match spec {
        SeamSpec::Auto => match topology {
            Ok(_) => {
                let seam = plan(mesh, &graph, landmarks, unseamable, rules);
                if seam.edges.is_empty() {
                    return Ok(None);
                }
                seam
            }
            Err(_) => plan(mesh, &graph, landmarks, unseamable, rules),
        },
        SeamSpec::Edges(paths) => given(mesh, &graph, paths, landmarks, unseamable)?,
    };
    let edges = &seam.edges;
    let wedges = split_wedges(mesh, &|e| edges.binary_search(&e).is_ok());
    match Topology::build(&wedges.mesh) {
        Ok(topology) => Ok(Some(Opened { wedges, topology, seam })),
        Err(e) if matches!(spec, SeamSpec::Auto) => Err(CutError::AutoNotOpened { left: describe(&e) }),
        Err(e) => Err(CutError::NotOpened { left: describe(&e) }),
    }
}

/// A disk whose boundary is short for its area (a bust open only at the
/// neck, a body open at a small hole): flattened as it is, it would be
/// crushed, so it is cut like a closed surface, from its boundary out to
/// cone points. A flat disk's boundary is 3.5 times the square root of its
/// area, a hemisphere's 2.5.
pub fn nearly_closed(mesh: &TriMesh, topology: &Topology) -> bool {
    short_for_its_area(mesh, topology.loop_lengths.iter().sum())
}

/// [`nearly_closed`] for any surface (a disk or not), from its edge graph.
fn nearly_closed_surface(mesh: &TriMesh, graph: &EdgeGraph) -> bool {
    let boundary: f64 = (0..graph.edges.len() as u32)
        .filter(|&e| graph.is_boundary(e))
        .map(|e| {
            let [a, b] = graph.edges[e as usize];
            mesh.positions[a as usize].distance(mesh.positions[b as usize])
        })
        .sum();
    short_for_its_area(mesh, boundary)
}

/// Whether a boundary of total length `boundary` is short for `mesh`'s area.
fn short_for_its_area(mesh: &TriMesh, boundary: f64) -> bool {
    boundary < NEARLY_CLOSED * mesh.area().sqrt()
}

/// See [`nearly_closed`].
const NEARLY_CLOSED: f64 = 1.5;

fn describe(e: &TopologyError) -> String {
    match e {
        TopologyError::Closed => "closed".into(),
        TopologyError::NotADisk { genus, n_loops } => format!("with genus {genus} and {n_loops} boundary loops"),
        other => format!("invalid ({other})"),
    }
}

/// The given seam paths as edges, checked.
fn given(
    mesh: &TriMesh,
    graph: &EdgeGraph,
    paths: &[Vec<u32>],
    landmarks: &[u32],
    unseamable: &[[u32; 2]],
) -> Result<Seam, CutError> {
    let mut edges = Vec::new();
    for (p, path) in paths.iter().enumerate() {
        if let Some(&vertex) = path.iter().find(|v| landmarks.contains(v)) {
            return Err(CutError::ThroughLandmark { path: p, vertex });
        }
        for (step, w) in path.windows(2).enumerate() {
            let (a, b) = (w[0], w[1]);
            let ok = (a as usize) < mesh.n_vertices() && graph.edge_between(a, b).is_some();
            if !ok {
                return Err(CutError::NotAnEdge { path: p, step, a, b });
            }
            if unseamable.binary_search(&[a.min(b), a.max(b)]).is_ok() {
                return Err(CutError::InsidePolygon { path: p, a, b });
            }
            edges.push([a.min(b), a.max(b)]);
        }
    }
    Ok(finish(mesh, edges, Vec::new(), 0))
}

fn finish(mesh: &TriMesh, mut edges: Vec<[u32; 2]>, cones: Vec<u32>, n_handle_edges: usize) -> Seam {
    edges.sort_unstable();
    edges.dedup();
    let length = edges
        .iter()
        .map(|e| mesh.positions[e[0] as usize].distance(mesh.positions[e[1] as usize]))
        .sum();
    Seam {
        edges,
        cones,
        n_handle_edges,
        length,
    }
}

/// The automatic seam of `mesh` (see the module docs).
fn plan(mesh: &TriMesh, graph: &EdgeGraph, landmarks: &[u32], unseamable: &[[u32; 2]], rules: &SeamRules) -> Seam {
    let cost_rules = cost::CostRules {
        landmarks,
        margin_rings: rules.margin_rings,
    };
    let around = cost::surroundings(mesh, graph, &cost_rules);
    let mut cost = cost::edge_costs(mesh, graph, &around, &cost_rules);
    for (e, edge) in graph.edges.iter().enumerate() {
        if unseamable.binary_search(edge).is_ok() {
            cost[e] = f64::INFINITY;
        }
    }
    let root = root(mesh, graph, &around, rules);
    let handle_edges = handles::handle_cuts(mesh, graph, &cost, root);
    let boundary = graph.boundary_vertices();
    let closed = boundary.is_empty();
    // A surface open only at small holes (a disk or not, a hole of three
    // vertices among them) is as good as closed.
    let spread = rules.spread_disks || nearly_closed_surface(mesh, graph);
    if !closed && !spread {
        // An open surface with room to lie flat needs its handles cut, nothing more.
        let edges = handle_edges.iter().map(|&e| graph.edges[e as usize]).collect();
        return finish(mesh, edges, Vec::new(), handle_edges.len());
    }
    let mut fixed = vec![false; mesh.n_vertices()];
    if closed {
        fixed[root as usize] = true;
    }
    boundary.iter().for_each(|&v| fixed[v as usize] = true);
    for &e in &handle_edges {
        graph.edges[e as usize].iter().for_each(|&v| fixed[v as usize] = true);
    }
    // A boundary too short for the square's four corners opens along a
    // seam out to one cone at least, as a closed surface does.
    let need_one = (closed || boundary.len() < 4) && handle_edges.is_empty();
    let cones = place_cones(mesh, graph, &fixed, &around, rules, need_one);
    let mut edges: Vec<[u32; 2]> = handle_edges.iter().map(|&e| graph.edges[e as usize]).collect();
    let mut tree: Vec<u32> = (0..mesh.n_vertices() as u32).filter(|&v| fixed[v as usize]).collect();
    for &c in &cones {
        let paths = shortest_paths(graph, &cost, &tree);
        for e in paths.path_to(graph, c) {
            edges.push(graph.edges[e as usize]);
            tree.extend(graph.edges[e as usize]);
        }
    }
    // A seam of one edge opens nothing (its ends stay whole): it goes on
    // from its cone along the cheapest other edge there.
    if closed
        && let [only] = edges[..]
        && let Some(&c) = cones.first()
    {
        let next = graph
            .around(c)
            .iter()
            .filter(|&&(w, e)| !only.contains(&w) && cost[e as usize].is_finite())
            .min_by(|a, b| cost[a.1 as usize].total_cmp(&cost[b.1 as usize]));
        if let Some(&(_, e)) = next {
            edges.push(graph.edges[e as usize]);
        }
    }
    let mut all_cones = if closed { vec![root] } else { Vec::new() };
    all_cones.extend(&cones);
    finish(mesh, edges, all_cones, handle_edges.len())
}

/// The rings around the landmarks that no cone or root enters: the rule's
/// margin, or on a mesh too small to leave anything outside it, only the
/// landmarks themselves.
fn margin(around: &cost::Surroundings, rules: &SeamRules) -> u32 {
    let outside = (0..around.ring.len())
        .any(|v| around.ring[v] > rules.margin_rings && around.ring[v] != u32::MAX && !around.inside[v]);
    if outside || around.facing.is_none() {
        rules.margin_rings
    } else {
        0
    }
}

/// Where the seam tree starts: the vertex where a seam is cheapest (far
/// behind the landmarks), or without landmarks one end of a long path.
fn root(mesh: &TriMesh, graph: &EdgeGraph, around: &cost::Surroundings, rules: &SeamRules) -> u32 {
    let m = margin(around, rules);
    let allowed = |v: usize| around.ring[v] > m && !around.inside[v];
    if around.facing.is_some() {
        let best = (0..mesh.n_vertices())
            .filter(|&v| allowed(v))
            .min_by(|&a, &b| around.dearness[a].total_cmp(&around.dearness[b]).then(a.cmp(&b)));
        if let Some(v) = best {
            return v as u32;
        }
    }
    let length: Vec<f64> = graph
        .edges
        .iter()
        .map(|e| mesh.positions[e[0] as usize].distance(mesh.positions[e[1] as usize]))
        .collect();
    let from_first = shortest_paths(graph, &length, &[0]).distance;
    let far = (0..mesh.n_vertices())
        .filter(|&v| from_first[v].is_finite())
        .max_by(|&a, &b| from_first[a].total_cmp(&from_first[b]).then(b.cmp(&a)))
        .unwrap_or(0);
    far as u32
}

/// Cone points in the order they were placed (see [`cones`]): where the
/// flattening's `|u|`, divided by how dear a seam there is, peaks, off the
/// landmarks' margin, while that exceeds the threshold; at least one when
/// `need_one` (a closed surface of genus 0 opens along a seam between two
/// points).
fn place_cones(
    mesh: &TriMesh,
    graph: &EdgeGraph,
    fixed: &[bool],
    around: &cost::Surroundings,
    rules: &SeamRules,
    need_one: bool,
) -> Vec<u32> {
    // A closed surface opens at one cone at least: where no vertex lies
    // beyond the landmarks' margin (a small part under many landmarks) or
    // the scale field cannot be had, the vertex farthest from them.
    let farthest = || {
        (0..mesh.n_vertices())
            .filter(|&v| !fixed[v] && around.ring[v] > 0)
            .max_by_key(|&v| (around.ring[v], std::cmp::Reverse(v)))
            .map(|v| v as u32)
    };
    let Ok(mut field) = cones::ScaleField::new(mesh, graph, fixed) else {
        return if need_one {
            farthest().into_iter().collect()
        } else {
            Vec::new()
        };
    };
    let mut placed: Vec<u32> = Vec::new();
    let m = margin(around, rules);
    while placed.len() < rules.max_cones {
        let u = field.field();
        let candidates =
            (0..mesh.n_vertices()).filter(|&v| !fixed[v] && around.ring[v] > m && !placed.contains(&(v as u32)));
        let best = candidates
            .map(|v| (v, u[v].abs() / around.dearness[v]))
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)));
        let Some((v, score)) = best else { break };
        if score < rules.cone_threshold && !(need_one && placed.is_empty()) {
            break;
        }
        field.add_cone(v as u32);
        placed.push(v as u32);
    }
    if need_one && placed.is_empty() {
        placed.extend(farthest());
    }
    placed
}

/// `chart`'s pieces (`piece_of` each triangle's) sorted for a solve: piece
/// `main`, the other pieces holding landmarks (`held[p]` > 0), and the
/// pieces without.
pub(crate) fn sorted_pieces(
    chart: &crate::mesh::weld::Chart,
    piece_of: &[u32],
    held: &[usize],
    main: usize,
) -> (
    crate::mesh::weld::Chart,
    Vec<crate::mesh::weld::Chart>,
    Vec<crate::mesh::weld::Chart>,
) {
    let (mut first, mut pieces, mut rest) = (None, Vec::new(), Vec::new());
    for (p, (piece, &h)) in chart.pieces(piece_of, held.len()).into_iter().zip(held).enumerate() {
        match (p == main, h > 0) {
            (true, _) => first = Some(piece),
            (false, true) => pieces.push(piece),
            (false, false) => rest.push(piece),
        }
    }
    (first.expect("the main piece is one of them"), pieces, rest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{blob_head, grid_mesh, holed_plate, torus, uv_sphere};

    fn opened(mesh: &TriMesh, landmarks: &[u32]) -> Opened {
        open(mesh, &SeamSpec::Auto, landmarks, &[], &SeamRules::DEFAULT)
            .expect("cut")
            .expect("needs a cut")
    }

    fn assert_disk(o: &Opened) {
        let t = &o.topology;
        let chi = o.wedges.mesh.n_vertices() as i64 - t.edges.len() as i64 + o.wedges.mesh.n_triangles() as i64;
        assert_eq!(chi, 2 - t.loops.len() as i64, "genus 0");
        assert!(!t.loops.is_empty());
    }

    #[test]
    fn a_disk_is_not_cut() {
        assert!(
            open(&grid_mesh(6, 6), &SeamSpec::Auto, &[], &[], &SeamRules::DEFAULT)
                .unwrap()
                .is_none()
        );
    }

    #[test]
    fn a_sphere_opens_along_a_seam_between_cones() {
        let o = opened(&uv_sphere(16, 24), &[]);
        assert_disk(&o);
        assert_eq!(o.seam.n_handle_edges, 0);
        assert!(o.seam.cones.len() >= 2);
        assert_eq!(o.topology.loops.len(), 1, "one outline: both sides of the seam tree");
    }

    #[test]
    fn a_closed_part_of_few_vertices_opens_along_two_edges_at_least() {
        // An octahedron, with and without landmarks: a seam of one edge
        // would open nothing.
        let mesh = crate::testing::octahedron();
        for landmarks in [vec![], vec![4], vec![4, 0]] {
            let o = opened(&mesh, &landmarks);
            assert_disk(&o);
            assert!(o.seam.edges.len() >= 2, "{:?}", o.seam.edges);
        }
    }

    #[test]
    fn handles_are_cut_open() {
        for (mesh, genus) in [
            (torus(24, 12, 1.0, 0.35), 1),
            (holed_plate(12, 1), 1),
            (holed_plate(10, 2), 2),
        ] {
            let o = opened(&mesh, &[]);
            assert_disk(&o);
            assert!(o.seam.n_handle_edges > 0, "genus {genus}");
        }
    }

    #[test]
    fn the_seam_keeps_clear_of_the_landmarks_and_goes_behind_them() {
        let (head, landmarks) = blob_head(24, 36);
        let o = opened(&head, &landmarks);
        assert_disk(&o);
        let graph = EdgeGraph::new(&head);
        let ring = graph::rings(&graph, &landmarks);
        let seam_vertices: Vec<u32> = o.seam.edges.iter().flatten().copied().collect();
        assert!(
            seam_vertices
                .iter()
                .all(|&v| ring[v as usize] > SeamRules::DEFAULT.margin_rings)
        );
        // The face looks along −y: the seam lies behind (y > 0) on average.
        let mean_y =
            seam_vertices.iter().map(|&v| head.positions[v as usize].y).sum::<f64>() / seam_vertices.len() as f64;
        assert!(mean_y > 0.2, "mean y of the seam {mean_y}");
        let again = opened(&head, &landmarks);
        assert_eq!(again.seam, o.seam, "deterministic");
    }

    #[test]
    fn given_seams_are_checked() {
        let sphere = uv_sphere(8, 12);
        let err = |paths: Vec<Vec<u32>>, landmarks: &[u32]| {
            open(&sphere, &SeamSpec::Edges(paths), landmarks, &[], &SeamRules::DEFAULT).unwrap_err()
        };
        assert_eq!(
            err(vec![vec![0, 1, 50]], &[]),
            CutError::NotAnEdge {
                path: 0,
                step: 1,
                a: 1,
                b: 50
            }
        );
        assert_eq!(
            err(vec![vec![0, 1, 13]], &[13]),
            CutError::ThroughLandmark { path: 0, vertex: 13 }
        );
        assert!(matches!(err(vec![], &[]), CutError::NotOpened { .. }));
        // A meridian from pole to pole opens it.
        let meridian: Vec<u32> = std::iter::once(0)
            .chain((0..7).map(|i| 1 + 12 * i))
            .chain([85])
            .collect();
        let o = open(&sphere, &SeamSpec::Edges(vec![meridian]), &[], &[], &SeamRules::DEFAULT)
            .unwrap()
            .unwrap();
        assert_disk(&o);
        assert_eq!(o.seam.edges.len(), 8);
    }
}
