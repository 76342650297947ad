//! The cuts that open a surface's handles: a tree–cotree decomposition (as
//! libigl's `cut_to_disk` and Boundary First Flattening use). Each boundary
//! loop is capped by a fan to a new vertex, so the surface is closed; `T`
//! is the tree of cheapest paths from the root (caps cost nothing, so it
//! runs through every boundary), `C` the dual tree of the dearest edges not
//! in `T` (those are never cut), and each of the `2g` edges in neither
//! closes a loop through `T` around a handle. Those loops, pruned of `T`'s
//! dangling branches and with the caps taken off, are the cut.

use super::graph::{EdgeGraph, NONE, shortest_paths};
use crate::mesh::TriMesh;
use crate::mesh::topology::UnionFind;

/// The surface with every boundary loop capped, for the decomposition.
struct Capped {
    graph: EdgeGraph,
    /// The seam cost of every edge of the capped graph (caps cost 0).
    cost: Vec<f64>,
    /// Number of the input's vertices (the caps' centres come after).
    n_real: usize,
}

/// Caps each boundary loop of `mesh` with a fan to a new vertex.
fn capped(mesh: &TriMesh, graph: &EdgeGraph, cost: &[f64]) -> Capped {
    let mut closed = mesh.clone();
    let mut next = vec![NONE; mesh.n_vertices()];
    for (e, edge) in graph.edges.iter().enumerate() {
        if graph.is_boundary(e as u32) {
            // The boundary runs along the triangle's winding.
            let t = graph.faces[e][0] as usize;
            let tri = mesh.triangles[t];
            let k = (0..3)
                .find(|&k| graph.triangle_edges[t][k] == e as u32)
                .expect("side of its triangle");
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            debug_assert!(edge.contains(&a) && edge.contains(&b));
            next[a as usize] = b;
        }
    }
    let mut seen = vec![false; mesh.n_vertices()];
    for start in 0..mesh.n_vertices() {
        if next[start] == NONE || seen[start] {
            continue;
        }
        let centre = closed.positions.len() as u32;
        closed.positions.push(mesh.positions[start]);
        let mut v = start as u32;
        // A boundary that does not close (a vertex where the surface is
        // pinched) ends its fan where it stops.
        while v != NONE && !seen[v as usize] {
            seen[v as usize] = true;
            let w = next[v as usize];
            if w == NONE {
                break;
            }
            // The cap lies on the other side of the boundary edge v → w.
            closed.triangles.push([w, v, centre]);
            v = w;
        }
    }
    let capped_graph = EdgeGraph::new(&closed);
    let capped_cost = capped_graph
        .edges
        .iter()
        .map(|e| {
            match graph
                .edge_between(e[0], e[1])
                .filter(|_| (e[1] as usize) < mesh.n_vertices())
            {
                Some(old) => cost[old as usize],
                None => 0.0,
            }
        })
        .collect();
    Capped {
        graph: capped_graph,
        cost: capped_cost,
        n_real: mesh.n_vertices(),
    }
}

/// The edges (of `graph`, the graph of `mesh`) to cut so that no handle is
/// left: empty for a surface of genus 0. `root` is where the tree starts
/// (the place farthest from what the seam avoids); `cost` the seam cost of
/// each edge.
pub fn handle_cuts(mesh: &TriMesh, graph: &EdgeGraph, cost: &[f64], root: u32) -> Vec<u32> {
    let capped = capped(mesh, graph, cost);
    let g = &capped.graph;
    let tree = shortest_paths(g, &capped.cost, &[root]);
    let mut in_tree = vec![false; g.edges.len()];
    for &e in tree.parent.iter().filter(|&&e| e != NONE) {
        in_tree[e as usize] = true;
    }
    // The dual tree over the dearest edges first (Kruskal on triangles).
    let mut order: Vec<u32> = (0..g.edges.len() as u32).filter(|&e| !in_tree[e as usize]).collect();
    order.sort_by(|&a, &b| {
        capped.cost[b as usize]
            .total_cmp(&capped.cost[a as usize])
            .then(a.cmp(&b))
    });
    let n_triangles = g.triangle_edges.len();
    let mut dual = UnionFind::new(n_triangles);
    let mut cut = in_tree.clone();
    for e in order {
        let [t0, t1] = g.faces[e as usize];
        if t1 == NONE {
            continue;
        }
        if dual.find(t0 as usize) != dual.find(t1 as usize) {
            dual.union(t0 as usize, t1 as usize);
        } else {
            cut[e as usize] = true;
        }
    }
    prune(g, &mut cut);
    (0..g.edges.len())
        .filter(|&e| cut[e])
        .filter_map(|e| {
            let [a, b] = g.edges[e];
            ((b as usize) < capped.n_real)
                .then(|| graph.edge_between(a, b))
                .flatten()
        })
        .filter(|&e| !graph.is_boundary(e))
        .collect()
}

/// Removes, again and again, every cut edge with an end no other cut edge
/// touches: what is left are the loops.
fn prune(graph: &EdgeGraph, cut: &mut [bool]) {
    let mut degree = vec![0u32; graph.n_vertices()];
    for (e, edge) in graph.edges.iter().enumerate() {
        if cut[e] {
            degree[edge[0] as usize] += 1;
            degree[edge[1] as usize] += 1;
        }
    }
    let mut leaves: Vec<u32> = (0..graph.n_vertices() as u32)
        .filter(|&v| degree[v as usize] == 1)
        .collect();
    while let Some(v) = leaves.pop() {
        if degree[v as usize] != 1 {
            continue;
        }
        let Some(&(w, e)) = graph.around(v).iter().find(|(_, e)| cut[*e as usize]) else {
            continue;
        };
        cut[e as usize] = false;
        degree[v as usize] -= 1;
        degree[w as usize] -= 1;
        if degree[w as usize] == 1 {
            leaves.push(w);
        }
    }
}
