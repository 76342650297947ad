//! A landmarked chart that must be cut open (closed, or nearly) and is far
//! too large for its targets is split where an artist would split it: at
//! the scale the targets ask for (a face photo
//! spanning most of the texture), a whole figure could only be crushed
//! into the texture's last corners, so the landmarks' surroundings become a
//! chart of their own, as large as the room allows, and the rest is laid
//! out apart (and packed, [`crate::atlas`]). The cut runs where the
//! geodesic distance from the landmarks reaches the size that fits.

use super::graph::{EdgeGraph, shortest_paths};
use crate::mesh::topology::{UnionFind, triangle_components};
use crate::mesh::wedges::split_wedges;
use crate::mesh::weld::Chart;

/// How much layout area the chart may take, and at what scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budget {
    /// Texture units per mesh unit that the targets ask for.
    pub scale: f64,
    /// Layout area of the region the chart must fit in.
    pub room: f64,
}

/// The landmarks' chart is made to take about this share of the room.
const SHARE: f64 = 0.55;

/// The chart split apart: the landmarks' piece (the one holding most of
/// them), the other pieces holding landmarks, the rest's pieces, and the
/// cut's edges (chart-local pairs of `chart`, sorted).
#[derive(Debug, Clone)]
pub struct Separated {
    pub main: Chart,
    pub others: Vec<Chart>,
    pub rest: Vec<Chart>,
    pub edges: Vec<[u32; 2]>,
}

/// `chart` split around `landmarks` (chart-local) to the share of its room
/// that `budget` leaves it; `None` when it is smaller than that already (or
/// the cut would leave nothing apart). Edges in `unseamable` (sorted pairs) are never cut: the
/// polygon across one stays whole.
pub fn separate(chart: &Chart, landmarks: &[u32], budget: Budget, unseamable: &[[u32; 2]]) -> Option<Separated> {
    let mesh = &chart.mesh;
    let area = mesh.area();
    let wanted = SHARE * budget.room / (budget.scale * budget.scale);
    if landmarks.is_empty() || area.partial_cmp(&wanted) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let graph = EdgeGraph::new(mesh);
    let length: Vec<f64> = graph
        .edges
        .iter()
        .map(|e| mesh.positions[e[0] as usize].distance(mesh.positions[e[1] as usize]))
        .collect();
    let paths = shortest_paths(&graph, &length, landmarks);
    let distance = &paths.distance;
    let far = |t: &[u32; 3]| t.iter().map(|&v| distance[v as usize]).fold(0.0, f64::max);
    let mut order: Vec<usize> = (0..mesh.n_triangles()).collect();
    order.sort_by(|&a, &b| {
        far(&mesh.triangles[a])
            .total_cmp(&far(&mesh.triangles[b]))
            .then(a.cmp(&b))
    });
    // At least far enough that the landmarks' balls join into one piece.
    let joined = joining_radius(&graph, &length, &paths, landmarks.len());
    let (mut kept, mut inside) = (0.0, vec![false; mesh.n_triangles()]);
    for &t in &order {
        if kept >= wanted && far(&mesh.triangles[t]) > joined {
            break;
        }
        inside[t] = true;
        kept += crate::mesh::triangle_area_3d(mesh, mesh.triangles[t]);
    }
    fill_in(&graph, &mut inside);
    keep_polygons_whole(&graph, unseamable, &mut inside);
    split_off(chart, &inside, landmarks)
}

/// `chart` split along the border of the triangles `inside` marks: the
/// piece holding most `landmarks` (chart-local), the other pieces inside
/// holding landmarks, the rest, and the cut's edges. `None` when nothing is
/// split off or a landmark is left outside.
pub fn split_off(chart: &Chart, inside: &[bool], landmarks: &[u32]) -> Option<Separated> {
    let mesh = &chart.mesh;
    let graph = EdgeGraph::new(mesh);
    let edges: Vec<[u32; 2]> = (0..graph.edges.len())
        .filter(|&e| {
            let [t0, t1] = graph.faces[e];
            t1 != super::graph::NONE && inside[t0 as usize] != inside[t1 as usize]
        })
        .map(|e| graph.edges[e])
        .collect();
    if edges.is_empty() {
        return None;
    }
    let wedges = split_wedges(mesh, &|e| edges.binary_search(&e).is_ok());
    let opened = chart.opened(&wedges);
    let (n_pieces, piece_of) = triangle_components(&opened.mesh);
    let mut held = vec![0usize; n_pieces];
    for (t, tri) in opened.mesh.triangles.iter().enumerate().filter(|(t, _)| inside[*t]) {
        if tri.iter().any(|&v| landmarks.contains(&wedges.origin[v as usize])) {
            held[piece_of[t] as usize] += 1;
        }
    }
    let main_piece = (0..n_pieces)
        .filter(|&p| held[p] > 0)
        .max_by_key(|&p| (held[p], std::cmp::Reverse(p)))?;
    let (main, others, rest) = super::sorted_pieces(&opened, &piece_of, &held, main_piece);
    let pieces_with = |l: u32| {
        let w = chart.welded_ids[l as usize];
        std::iter::once(&main).chain(&others).any(|c| c.local_of(w).is_some())
    };
    if !landmarks.iter().all(|&l| pieces_with(l)) {
        return None;
    }
    Some(Separated {
        main,
        others,
        rest,
        edges,
    })
}

/// How far from the landmarks their geodesic balls must reach to join into
/// one: half the longest edge of the minimum spanning tree of the
/// landmarks, each pair joined across their Voronoi cells (`paths` from
/// all `n` of them), and a little more.
fn joining_radius(graph: &EdgeGraph, length: &[f64], paths: &super::graph::ShortestPaths, n: usize) -> f64 {
    let mut links: Vec<(f64, u32, u32)> = Vec::new();
    for (e, &[a, b]) in graph.edges.iter().enumerate() {
        let (sa, sb) = (paths.nearest[a as usize], paths.nearest[b as usize]);
        if sa != sb && sa != super::graph::NONE && sb != super::graph::NONE {
            links.push((
                paths.distance[a as usize] + length[e] + paths.distance[b as usize],
                sa,
                sb,
            ));
        }
    }
    links.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut sets = UnionFind::new(n);
    let mut longest: f64 = 0.0;
    for (d, a, b) in links {
        if sets.find(a as usize) != sets.find(b as usize) {
            sets.union(a as usize, b as usize);
            longest = longest.max(d);
        }
    }
    0.5 * longest * 1.05
}

/// Adds to the landmarks' side every piece of the other side but the
/// largest: what it encloses (a nose between its cheeks) stays with it.
fn fill_in(graph: &EdgeGraph, inside: &mut [bool]) {
    let mut outside = UnionFind::new(inside.len());
    for f in &graph.faces {
        if f[1] != super::graph::NONE && !inside[f[0] as usize] && !inside[f[1] as usize] {
            outside.union(f[0] as usize, f[1] as usize);
        }
    }
    let mut size = vec![0usize; inside.len()];
    for t in (0..inside.len()).filter(|&t| !inside[t]) {
        size[outside.find(t)] += 1;
    }
    let Some(largest) = (0..inside.len())
        .filter(|&t| !inside[t])
        .max_by_key(|&t| (size[outside.find(t)], std::cmp::Reverse(t)))
    else {
        return;
    };
    let keep = outside.find(largest);
    for (t, within) in inside.iter_mut().enumerate() {
        if !*within && outside.find(t) != keep {
            *within = true;
        }
    }
}

/// Moves to the landmarks' side every triangle across an unseamable edge
/// from it, until none is cut.
fn keep_polygons_whole(graph: &EdgeGraph, unseamable: &[[u32; 2]], inside: &mut [bool]) {
    loop {
        let mut moved = false;
        for (e, edge) in graph.edges.iter().enumerate() {
            let [t0, t1] = graph.faces[e];
            if t1 != super::graph::NONE
                && inside[t0 as usize] != inside[t1 as usize]
                && unseamable.binary_search(edge).is_ok()
            {
                inside[t0 as usize] = true;
                inside[t1 as usize] = true;
                moved = true;
            }
        }
        if !moved {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::uv_sphere;

    #[test]
    fn a_sphere_whose_targets_ask_for_a_huge_layout_keeps_a_cap_around_its_landmarks() {
        let mesh = uv_sphere(24, 36);
        let welded = crate::mesh::weld::weld(&[crate::mesh::weld::PrimitiveGeometry {
            index: 0,
            positions: mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect(),
            indices: mesh.triangles.iter().flatten().copied().collect(),
            uvs: None,
        }]);
        let chart = welded.chart(0);
        let landmark = 100;
        // At scale 1 the sphere (area 4π) would need 4π layout units: far
        // more than a room of 1.
        let s = separate(&chart, &[landmark], Budget { scale: 1.0, room: 1.0 }, &[]).expect("split");
        let kept = s.main.mesh.area();
        assert!(kept > 0.4 && kept < 1.0, "a cap of about 0.55: {kept}");
        assert_eq!(s.rest.len(), 1);
        assert!(s.main.local_of(chart.welded_ids[landmark as usize]).is_some());
        assert!(
            separate(&chart, &[landmark], Budget { scale: 0.2, room: 1.0 }, &[]).is_none(),
            "fits"
        );
    }
}
