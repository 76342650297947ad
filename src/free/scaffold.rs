//! The scaffold (Jiang, Schaefer and Panozzo 2017, "Simplicial complex
//! augmentation framework for bijective maps"): the free space between a
//! chart's boundary and its region's border, less the other islands, cut
//! into triangles by a constrained Delaunay triangulation. Chart and
//! scaffold together tile the region with its border and the islands held:
//! while every triangle of both stays positive, the chart cannot leave the
//! region, cross itself or overlap an island. The chart moves, so the
//! scaffold is triangulated anew after every accepted step.

use super::Obstacles;
use crate::injective::{Edge, strictly_inside};
use glam::DVec2;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// Points per side of the region's border at least and at most.
const BORDER_POINTS: (usize, usize) = (4, 64);

/// The fixed part of a chart's scaffold: the region's border and the other
/// islands' edges (split where they cross), in layout coordinates.
#[derive(Debug, Clone)]
pub struct Scaffold {
    /// Fixed points: the border, then the islands' boundary points and splits.
    fixed: Vec<DVec2>,
    /// Constraint edges between fixed points (pairwise non-crossing).
    fixed_edges: Vec<[usize; 2]>,
    lo: DVec2,
    hi: DVec2,
    /// The islands' triangles (layout coordinates), bucketed by a grid.
    islands: IslandGrid,
}

impl Scaffold {
    /// The scaffold of a chart inside the layout box `lo..hi` with
    /// `obstacles`, for a chart with `n_boundary` boundary vertices.
    pub fn new(lo: DVec2, hi: DVec2, obstacles: &Obstacles, n_boundary: usize) -> Scaffold {
        let per_side = ((n_boundary as f64).sqrt().ceil() as usize).clamp(BORDER_POINTS.0, BORDER_POINTS.1);
        let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
        let mut border = Vec::with_capacity(4 * per_side);
        for k in 0..4 {
            let (a, b) = (corners[k], corners[(k + 1) % 4]);
            border.extend((0..per_side).map(|i| a.lerp(b, i as f64 / per_side as f64)));
        }
        let mut cdt = Cdt::new();
        let handles: Vec<_> = border
            .iter()
            .filter_map(|p| cdt.insert(Point2::new(p.x, p.y)).ok())
            .collect();
        for i in 0..handles.len() {
            cdt.add_constraint_and_split(handles[i], handles[(i + 1) % handles.len()], |p| p);
        }
        let island: Vec<_> = obstacles
            .layout
            .iter()
            .map(|p| cdt.insert(Point2::new(p.x, p.y)).ok())
            .collect();
        // Islands as they come may cross or overlap one another (an atlas
        // need not be one-to-one): an edge that would cross a constraint
        // already in is left out (the island grid still keeps the chart
        // clear of its triangles), never split (which the CDT cannot always do).
        for e in &obstacles.edges {
            if let (Some(a), Some(b)) = (island[e[0] as usize], island[e[1] as usize])
                && a != b
                && cdt.can_add_constraint(a, b)
            {
                cdt.add_constraint(a, b);
            }
        }
        let fixed = cdt
            .vertices()
            .map(|v| DVec2::new(v.position().x, v.position().y))
            .collect();
        let fixed_edges = cdt
            .undirected_edges()
            .filter(|e| cdt.is_constraint_edge(e.fix()))
            .map(|e| e.vertices().map(|v| v.fix().index()))
            .collect();
        Scaffold {
            fixed,
            fixed_edges,
            lo,
            hi,
            islands: IslandGrid::new(obstacles, lo, hi),
        }
    }

    /// The fixed points, to be appended to the layout (vertex
    /// `offset + i` is fixed point `i` in [`Scaffold::triangulate`]).
    pub fn fixed_points(&self) -> &[DVec2] {
        &self.fixed
    }

    /// The scaffold triangles for the chart's boundary where `layout` has
    /// it: `boundary` the chart's boundary vertices, `edges` its loops'
    /// edges (chart-local ids), the fixed points at `offset` on. Counter-
    /// clockwise, as the chart's triangles. `None` when the boundary cannot
    /// be triangulated around (it meets itself, the border or an island).
    pub fn triangulate(
        &self,
        layout: &[DVec2],
        boundary: &[u32],
        edges: &[Edge],
        offset: u32,
    ) -> Option<Vec<[u32; 3]>> {
        let n_fixed = self.fixed.len();
        let mut points: Vec<Point2<f64>> = self.fixed.iter().map(|p| Point2::new(p.x, p.y)).collect();
        let mut slot = std::collections::HashMap::with_capacity(boundary.len());
        for &v in boundary {
            let p = layout[v as usize];
            if !(p.cmpgt(self.lo).all() && p.cmplt(self.hi).all()) {
                return None;
            }
            slot.insert(v, points.len());
            points.push(Point2::new(p.x, p.y));
        }
        let mut constraints = self.fixed_edges.clone();
        constraints.extend(edges.iter().map(|e| [slot[&e[0]], slot[&e[1]]]));
        let n_points = points.len();
        let mut conflict = false;
        let cdt = Cdt::try_bulk_load_cdt(points, constraints, |_| conflict = true).ok()?;
        if conflict || cdt.num_vertices() != n_points {
            return None;
        }
        let name = |i: usize| {
            if i < n_fixed {
                offset + i as u32
            } else {
                boundary[i - n_fixed]
            }
        };
        let outside = outside_chart(&cdt, n_fixed);
        let mut out = Vec::new();
        for face in cdt.inner_faces() {
            if !outside[face.fix().index()] {
                continue;
            }
            let c = face.positions().iter().map(|p| DVec2::new(p.x, p.y)).sum::<DVec2>() / 3.0;
            if c.cmpgt(self.lo).all() && c.cmplt(self.hi).all() && !self.islands.contains(c) {
                out.push(face.vertices().map(|v| name(v.fix().index())));
            }
        }
        Some(out)
    }
}

/// Per face (by index): whether it lies outside the chart, by the parity
/// of chart edges crossed from the faces on the convex hull (the chart is
/// strictly inside the region, so those are outside it).
fn outside_chart(cdt: &Cdt, n_fixed: usize) -> Vec<bool> {
    let mut outside: Vec<Option<bool>> = vec![None; cdt.num_all_faces()];
    let mut queue = std::collections::VecDeque::new();
    for e in cdt.convex_hull() {
        for f in [e.face(), e.rev().face()] {
            if let Some(inner) = f.as_inner()
                && outside[inner.fix().index()].is_none()
            {
                outside[inner.fix().index()] = Some(true);
                queue.push_back(inner.fix());
            }
        }
    }
    while let Some(f) = queue.pop_front() {
        let here = outside[f.index()].unwrap_or(true);
        for e in cdt.face(f).adjacent_edges() {
            let Some(next) = e.rev().face().as_inner() else {
                continue;
            };
            if outside[next.fix().index()].is_some() {
                continue;
            }
            let [a, b] = e.vertices().map(|v| v.fix().index());
            let chart_edge = a >= n_fixed && b >= n_fixed && cdt.is_constraint_edge(e.fix().as_undirected());
            outside[next.fix().index()] = Some(here != chart_edge);
            queue.push_back(next.fix());
        }
    }
    outside.into_iter().map(|p| p.unwrap_or(true)).collect()
}

/// The islands' triangles bucketed by a uniform grid over the region.
#[derive(Debug, Clone)]
struct IslandGrid {
    triangles: Vec<[DVec2; 3]>,
    cells: Vec<Vec<u32>>,
    side: usize,
    lo: DVec2,
    cell: DVec2,
}

impl IslandGrid {
    fn new(obstacles: &Obstacles, lo: DVec2, hi: DVec2) -> IslandGrid {
        let triangles: Vec<[DVec2; 3]> = obstacles
            .triangles
            .iter()
            .map(|t| t.map(|v| obstacles.layout[v as usize]))
            .collect();
        let side = ((triangles.len() as f64).sqrt().ceil() as usize).clamp(1, 256);
        let cell = (hi - lo) / side as f64;
        let mut grid = IslandGrid {
            triangles,
            cells: vec![Vec::new(); side * side],
            side,
            lo,
            cell,
        };
        for (i, t) in grid.triangles.iter().enumerate() {
            let (a, b) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            let (c0, c1) = (grid.cell_of(a), grid.cell_of(b));
            for y in c0.1..=c1.1 {
                for x in c0.0..=c1.0 {
                    grid.cells[y * side + x].push(i as u32);
                }
            }
        }
        grid
    }

    fn cell_of(&self, p: DVec2) -> (usize, usize) {
        let q = ((p - self.lo) / self.cell).floor();
        let clamp = |x: f64| (x.max(0.0) as usize).min(self.side - 1);
        (clamp(q.x), clamp(q.y))
    }

    fn contains(&self, p: DVec2) -> bool {
        if self.triangles.is_empty() {
            return false;
        }
        let (x, y) = self.cell_of(p);
        self.cells[y * self.side + x]
            .iter()
            .any(|&t| strictly_inside(p, self.triangles[t as usize]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guard;
    use crate::testing::grid_mesh;

    #[test]
    fn chart_and_scaffold_tile_the_region() {
        let mesh = grid_mesh(5, 5);
        let topology = crate::mesh::topology::Topology::build(&mesh).unwrap();
        let boundary = topology.outer_loop().to_vec();
        let edges: Vec<Edge> = (0..boundary.len())
            .map(|i| [boundary[i], boundary[(i + 1) % boundary.len()]])
            .collect();
        let mut layout: Vec<DVec2> = mesh.positions.iter().map(|p| 0.2 + 0.5 * p.truncate()).collect();
        let scaffold = Scaffold::new(DVec2::ZERO, DVec2::ONE, &Obstacles::default(), boundary.len());
        let offset = layout.len() as u32;
        layout.extend_from_slice(scaffold.fixed_points());
        let tris = scaffold.triangulate(&layout, &boundary, &edges, offset).unwrap();
        assert!(guard::all_positive(&layout, &tris));
        let area = |ts: &[[u32; 3]]| -> f64 {
            ts.iter()
                .map(|t| 0.5 * guard::orientation(layout[t[0] as usize], layout[t[1] as usize], layout[t[2] as usize]))
                .sum()
        };
        // Chart (0.25) and scaffold together cover the unit square.
        assert!(
            (area(&tris) + area(&mesh.triangles) - 1.0).abs() < 1e-12,
            "{}",
            area(&tris)
        );
        // A boundary vertex outside the region: no scaffold.
        layout[boundary[0] as usize] = DVec2::new(1.5, 0.5);
        assert!(scaffold.triangulate(&layout, &boundary, &edges, offset).is_none());
    }

    #[test]
    fn islands_that_cross_each_other_make_a_scaffold() {
        // Two islands overlapping, edges crossing and collinear (an atlas
        // that is not one-to-one): built, no panic, its edges uncrossed.
        let uvs = [
            [0.1f32, 0.1],
            [0.5, 0.1],
            [0.1, 0.5],
            [0.3, 0.05],
            [0.3, 0.4],
            [0.05, 0.3],
            [0.2, 0.1],
            [0.4, 0.1],
            [0.3, 0.3],
        ];
        let triangles = [[0, 1, 2], [3, 4, 5], [6, 7, 8]];
        let obstacles = Obstacles::new(&uvs, &triangles, crate::param::region::Region::TEXTURE);
        let scaffold = Scaffold::new(DVec2::ZERO, DVec2::ONE, &obstacles, 16);
        let p = scaffold.fixed_points();
        for (i, a) in scaffold.fixed_edges.iter().enumerate() {
            for b in &scaffold.fixed_edges[i + 1..] {
                let shared = a.iter().any(|v| b.contains(v));
                let crossing = |[x, y]: [usize; 2], [u, w]: [usize; 2]| {
                    let o = |a: usize, b: usize, c: usize| guard::orientation(p[a], p[b], p[c]);
                    o(x, y, u) * o(x, y, w) < 0.0 && o(u, w, x) * o(u, w, y) < 0.0
                };
                assert!(shared || !crossing(*a, *b), "{a:?} crosses {b:?}");
            }
        }
    }

    #[test]
    fn random_overlapping_sliver_islands_make_a_scaffold() {
        // Slivers from corners on a 1/16 grid, their third corner near the
        // first edge's line: crossings, near-collinear and overlapping
        // edges (splitting such crossings panicked inside the CDT).
        let mut rng = crate::testing::Rng::new(5);
        for _ in 0..3000 {
            let n = 2 + rng.below(40);
            let mut uvs = Vec::new();
            let mut triangles = Vec::new();
            for t in 0..n as u32 {
                let at = |rng: &mut crate::testing::Rng| (1 + rng.below(15)) as f32 / 16.0;
                let a = [at(&mut rng), at(&mut rng)];
                let b = [at(&mut rng), at(&mut rng)];
                // Thin: the third corner near the first edge's line.
                let s = rng.f64() as f32;
                let e = (rng.f64() as f32 - 0.5) * 1e-3;
                let c = [a[0] + s * (b[0] - a[0]) + e, a[1] + s * (b[1] - a[1]) - e];
                uvs.extend([a, b, c]);
                triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
            }
            let obstacles = Obstacles::new(&uvs, &triangles, crate::param::region::Region::TEXTURE);
            let scaffold = Scaffold::new(DVec2::ZERO, DVec2::ONE, &obstacles, 16);
            assert!(!scaffold.fixed_points().is_empty());
        }
    }

    #[test]
    fn islands_are_left_out() {
        let uvs = [[0.05f32, 0.05], [0.3, 0.05], [0.05, 0.3]];
        let obstacles = Obstacles::new(&uvs, &[[0, 1, 2]], crate::param::region::Region::TEXTURE);
        let mesh = grid_mesh(3, 3);
        let topology = crate::mesh::topology::Topology::build(&mesh).unwrap();
        let boundary = topology.outer_loop().to_vec();
        let edges: Vec<Edge> = (0..boundary.len())
            .map(|i| [boundary[i], boundary[(i + 1) % boundary.len()]])
            .collect();
        let mut layout: Vec<DVec2> = mesh.positions.iter().map(|p| 0.5 + 0.3 * p.truncate()).collect();
        let scaffold = Scaffold::new(DVec2::ZERO, DVec2::ONE, &obstacles, boundary.len());
        let offset = layout.len() as u32;
        layout.extend_from_slice(scaffold.fixed_points());
        let tris = scaffold.triangulate(&layout, &boundary, &edges, offset).unwrap();
        assert!(guard::all_positive(&layout, &tris));
        let area: f64 = tris
            .iter()
            .map(|t| 0.5 * guard::orientation(layout[t[0] as usize], layout[t[1] as usize], layout[t[2] as usize]))
            .sum();
        // Square minus chart (0.09) minus island (0.03125).
        assert!((area - (1.0 - 0.09 - 0.03125)).abs() < 1e-6, "{area}");
    }
}
