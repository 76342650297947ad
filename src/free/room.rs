//! Whether a free chart's layout is one-to-one inside its region and clear
//! of the other islands, exactly as each output format stores it.
//!
//! With every triangle of the filled chart positive (the [`crate::guard`];
//! holes are closed by fans of virtual triangles), the filled chart is a
//! disk mapped locally one-to-one, so the layout is globally injective
//! when its outer loop is a simple counter-clockwise curve. It stays clear
//! of the other islands when no edge of theirs meets a boundary edge, no
//! island lies inside the chart and the chart does not lie inside an
//! island. (The checks also take hole loops, for layouts without fans.)

use super::{FreeSetup, Region};
use crate::injective::{Contact, Edge, bounds, meeting_pairs, winding_number};
use crate::mesh::topology::Topology;
use glam::DVec2;
use std::ops::Range;
use std::sync::Arc;

/// Why a layout does not fit its room (chart-local vertex ids). The region
/// is open: a vertex on its border is outside.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Violation {
    OutsideRegion {
        vertex: u32,
    },
    /// Two boundary edges of the chart meet.
    SelfCrossing {
        first: Edge,
        second: Edge,
    },
    /// A boundary edge of the chart meets another island's edge.
    IslandCrossing {
        edge: Edge,
    },
    /// A loop winds the wrong way (`None`: the outer loop).
    Orientation {
        hole: Option<usize>,
    },
    /// A hole is outside the outer loop or inside another hole.
    HoleOutside {
        hole: usize,
    },
    /// Another island lies inside the chart.
    CoversIsland {
        island: usize,
    },
    /// The chart lies inside another island.
    InsideIsland,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Violation::OutsideRegion { vertex } => write!(f, "vertex {vertex} is outside the region"),
            Violation::SelfCrossing { first, second } => write!(
                f,
                "boundary edges ({}, {}) and ({}, {}) meet",
                first[0], first[1], second[0], second[1]
            ),
            Violation::IslandCrossing { edge } => {
                write!(f, "boundary edge ({}, {}) meets another island", edge[0], edge[1])
            }
            Violation::Orientation { hole: None } => write!(f, "the outer boundary winds clockwise"),
            Violation::Orientation { hole: Some(h) } => write!(f, "hole {h} winds counter-clockwise"),
            Violation::HoleOutside { hole } => write!(f, "hole {hole} is not inside the chart"),
            Violation::CoversIsland { island } => write!(f, "another island ({island}) lies inside the chart"),
            Violation::InsideIsland => write!(f, "the chart lies inside another island"),
        }
    }
}

/// An output format's stored coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    /// glTF `(u, v)`, v down: layouts appear mirrored.
    Gltf,
    /// OBJ `vt`, v up.
    Obj,
}

impl Encoding {
    fn store(self, p: DVec2) -> DVec2 {
        let [u, v] = match self {
            Encoding::Gltf => crate::guard::stored_uv(p),
            Encoding::Obj => crate::guard::stored_vt(p),
        };
        DVec2::new(u as f64, v as f64)
    }

    /// The region's corners in these coordinates.
    fn region(self, r: &Region) -> (DVec2, DVec2) {
        match self {
            Encoding::Gltf => (r.min, r.max),
            Encoding::Obj => r.layout_box(),
        }
    }

    /// The sign of a counter-clockwise layout loop's orientation here.
    fn ccw(self) -> f64 {
        match self {
            Encoding::Gltf => -1.0,
            Encoding::Obj => 1.0,
        }
    }
}

/// A free chart's boundary against its region and the other islands.
#[derive(Debug, Clone)]
pub struct Room {
    setup: Arc<FreeSetup>,
    /// The chart's boundary vertices (chart-local ids); edges index this.
    vertices: Vec<u32>,
    /// Every boundary loop's edges, loop after loop.
    edges: Vec<Edge>,
    /// Each loop's range in `edges`; the first is the outer loop.
    loops: Vec<Range<usize>>,
    /// A real triangle: its centroid is inside the chart.
    probe: [u32; 3],
}

impl Room {
    /// The room of a chart with `topology` (its real triangles `triangles`).
    pub fn new(setup: Arc<FreeSetup>, topology: &Topology, triangles: &[[u32; 3]]) -> Room {
        let mut vertices = Vec::new();
        let mut edges = Vec::new();
        let mut loops = Vec::new();
        // The outer loop only: the holes stay fan-filled, and with every
        // fan triangle positive they cannot leave the chart.
        for l in [topology.outer] {
            let lp = &topology.loops[l];
            let first = vertices.len() as u32;
            let start = edges.len();
            for (i, &v) in lp.iter().enumerate() {
                vertices.push(v);
                let next = if i + 1 == lp.len() { first } else { first + i as u32 + 1 };
                edges.push([first + i as u32, next]);
            }
            loops.push(start..edges.len());
        }
        Room {
            setup,
            vertices,
            edges,
            loops,
            probe: triangles.first().copied().unwrap_or([0, 0, 0]),
        }
    }

    pub fn setup(&self) -> &FreeSetup {
        &self.setup
    }

    /// The chart's boundary vertices (chart-local), loop after loop, outer first.
    pub fn boundary_vertices(&self) -> &[u32] {
        &self.vertices
    }

    /// Each loop's edges as pairs of chart-local vertices.
    pub fn boundary_edges(&self) -> impl Iterator<Item = Edge> + '_ {
        self.edges
            .iter()
            .map(|e| [self.vertices[e[0] as usize], self.vertices[e[1] as usize]])
    }

    /// `Ok` when `layout` (real triangles positive) is one-to-one inside the
    /// region and clear of the other islands, as glTF and as OBJ store it.
    ///
    /// # Errors
    /// The first violation found.
    pub fn admits(&self, layout: &[DVec2]) -> Result<(), Violation> {
        self.check(layout, Encoding::Gltf)?;
        self.check(layout, Encoding::Obj)
    }

    /// Whether `layout`'s boundary loops alone are disjoint simple curves
    /// wound as they must be (in double precision; region and islands
    /// aside): with positive triangles, whether it is one-to-one at all.
    pub fn embeds(&self, layout: &[DVec2]) -> bool {
        let points: Vec<DVec2> = self.vertices.iter().map(|&v| layout[v as usize]).collect();
        meeting_pairs(&points, &self.edges, Contact::Any, 1, self.edges.len()).is_empty()
            && self.check_loops(&points, &self.edges, Encoding::Obj).is_ok()
    }

    fn check(&self, layout: &[DVec2], enc: Encoding) -> Result<(), Violation> {
        let mut points: Vec<DVec2> = self.vertices.iter().map(|&v| enc.store(layout[v as usize])).collect();
        let (lo, hi) = enc.region(&self.setup.region);
        if let Some(i) = points.iter().position(|p| !(p.cmpgt(lo).all() && p.cmplt(hi).all())) {
            return Err(Violation::OutsideRegion {
                vertex: self.vertices[i],
            });
        }
        let obstacles = &self.setup.obstacles;
        let n = points.len() as u32;
        points.extend(match enc {
            Encoding::Gltf => &obstacles.gltf,
            Encoding::Obj => &obstacles.obj,
        });
        let n_chart = self.edges.len();
        let mut edges = self.edges.clone();
        // Only islands' edges that reach the chart's box can meet it.
        let (lo, hi) = bounds(&points[..n as usize]);
        let reaches = |e: &&[u32; 2]| {
            let (a, b) = (points[(e[0] + n) as usize], points[(e[1] + n) as usize]);
            a.min(b).cmple(hi).all() && a.max(b).cmpge(lo).all()
        };
        edges.extend(obstacles.edges.iter().filter(reaches).map(|e| [e[0] + n, e[1] + n]));
        let pairs = meeting_pairs(&points, &edges, Contact::Any, 1, n_chart);
        if let Some(&(i, j)) = pairs.first() {
            let named = |e: Edge| [self.vertices[e[0] as usize], self.vertices[e[1] as usize]];
            return Err(if j < n_chart {
                Violation::SelfCrossing {
                    first: named(edges[i]),
                    second: named(edges[j]),
                }
            } else {
                Violation::IslandCrossing { edge: named(edges[i]) }
            });
        }
        let chart_edges = &edges[..n_chart];
        self.check_loops(&points, chart_edges, enc)?;
        let stored = AsStored {
            points: &points,
            chart_edges,
            offset: n,
            lo,
            hi,
        };
        self.check_islands(layout, &stored, enc)
    }

    /// Loop orientations, and every hole inside the outer loop and outside the others.
    fn check_loops(&self, points: &[DVec2], edges: &[Edge], enc: Encoding) -> Result<(), Violation> {
        for (k, range) in self.loops.iter().enumerate() {
            let hole = (k > 0).then(|| k - 1);
            let want = if k == 0 { enc.ccw() } else { -enc.ccw() };
            if loop_orientation(points, &edges[range.clone()]) * want <= 0.0 {
                return Err(Violation::Orientation { hole });
            }
            if let Some(h) = hole {
                let q = points[edges[range.start][0] as usize];
                let others: Vec<Edge> = self
                    .loops
                    .iter()
                    .filter(|r| *r != range)
                    .flat_map(|r| edges[r.clone()].iter().copied())
                    .collect();
                if f64::from(winding_number(q, points, &others)) != enc.ccw() {
                    return Err(Violation::HoleOutside { hole: h });
                }
            }
        }
        Ok(())
    }

    /// No island inside the chart, the chart not inside an island.
    fn check_islands(&self, layout: &[DVec2], stored: &AsStored, enc: Encoding) -> Result<(), Violation> {
        let AsStored {
            points,
            chart_edges: edges,
            offset,
            lo,
            hi,
        } = *stored;
        let obstacles = &self.setup.obstacles;
        let corner = |t: [u32; 3]| t.map(|v| points[(v + offset) as usize]);
        for (island, &t) in obstacles.probes.iter().enumerate() {
            let c = corner(obstacles.triangles[t as usize]).iter().sum::<DVec2>() / 3.0;
            // Outside the chart's box the winding number is 0.
            let in_box = c.cmpge(lo).all() && c.cmple(hi).all();
            if in_box && winding_number(c, points, edges) != 0 {
                return Err(Violation::CoversIsland { island });
            }
        }
        // The chart's probe inside an island: inside its outline (islands do
        // not overlap, so a winding number other than 0 is inside one).
        let c = self.probe.map(|v| enc.store(layout[v as usize])).iter().sum::<DVec2>() / 3.0;
        if winding_number(c, &points[offset as usize..], &obstacles.edges) != 0 {
            return Err(Violation::InsideIsland);
        }
        Ok(())
    }

    /// How many pairs of boundary edges cross (glTF as stored; touching
    /// does not count), at most `limit`: 0 for every layout uvpin writes.
    pub fn crossings(&self, layout: &[DVec2], limit: usize) -> usize {
        let points: Vec<DVec2> = self
            .vertices
            .iter()
            .map(|&v| Encoding::Gltf.store(layout[v as usize]))
            .collect();
        meeting_pairs(&points, &self.edges, Contact::Proper, limit, self.edges.len()).len()
    }
}

/// A chart's boundary as stored with the islands' points after it, for
/// [`Room::check`]'s island tests.
#[derive(Clone, Copy)]
struct AsStored<'a> {
    /// The chart's boundary points, then the islands'.
    points: &'a [DVec2],
    /// The chart's boundary edges.
    chart_edges: &'a [Edge],
    /// Where the islands' points begin.
    offset: u32,
    /// The chart's box.
    lo: DVec2,
    hi: DVec2,
}

/// The orientation of a simple closed loop: the sign of the turn at its
/// lowest (then leftmost) vertex, which is convex (exact).
fn loop_orientation(points: &[DVec2], edges: &[Edge]) -> f64 {
    let key = |e: &Edge| {
        let p = points[e[0] as usize];
        (p.y, p.x)
    };
    let Some(k) = (0..edges.len()).min_by(|&a, &b| key(&edges[a]).partial_cmp(&key(&edges[b])).expect("finite")) else {
        return 0.0;
    };
    let prev = edges[(k + edges.len() - 1) % edges.len()][0];
    let [v, next] = edges[k];
    crate::guard::orientation(points[prev as usize], points[v as usize], points[next as usize])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::free::{Obstacles, RegionSource};
    use crate::mesh::TriMesh;
    use crate::testing::grid_mesh;

    fn room(obstacles: Obstacles) -> (Room, TriMesh) {
        let mesh = grid_mesh(4, 4);
        let topology = Topology::build(&mesh).unwrap();
        let setup = FreeSetup {
            region: Region::TEXTURE,
            source: RegionSource::Texture,
            obstacles: Arc::new(obstacles),
            island: None,
            given: None,
            density: None,
        };
        (Room::new(Arc::new(setup), &topology, &mesh.triangles), mesh)
    }

    fn scaled(mesh: &TriMesh, s: f64, at: DVec2) -> Vec<DVec2> {
        mesh.positions.iter().map(|p| at + p.truncate() * s).collect()
    }

    #[test]
    fn a_grid_fits_and_a_pinched_one_does_not() {
        let (room, mesh) = room(Obstacles::default());
        let layout = scaled(&mesh, 0.5, DVec2::splat(0.25));
        assert_eq!(room.admits(&layout), Ok(()));
        assert_eq!(room.crossings(&layout, 10), 0);
        // Outside the texture.
        let far = scaled(&mesh, 0.5, DVec2::splat(0.75));
        assert!(matches!(room.admits(&far), Err(Violation::OutsideRegion { .. })));
        // Mirrored: the outer loop winds clockwise.
        let mirrored: Vec<DVec2> = layout.iter().map(|p| DVec2::new(1.0 - p.x, p.y)).collect();
        assert_eq!(room.admits(&mirrored), Err(Violation::Orientation { hole: None }));
        // A boundary vertex pushed across the opposite side: the loop crosses itself.
        let mut crossed = layout.clone();
        crossed[1] = DVec2::new(0.4, 0.9);
        assert!(matches!(room.admits(&crossed), Err(Violation::SelfCrossing { .. })));
        assert!(room.crossings(&crossed, 10) > 0);
    }

    #[test]
    fn other_islands_are_obstacles() {
        // An island (one triangle, in texture coordinates) near the top left.
        let uvs = [[0.05f32, 0.05], [0.2, 0.05], [0.05, 0.2]];
        let obstacles = Obstacles::new(&uvs, &[[0, 1, 2]], Region::TEXTURE);
        assert_eq!(obstacles.triangles.len(), 1);
        let (room, mesh) = room(obstacles);
        // Bottom right: clear.
        assert_eq!(room.admits(&scaled(&mesh, 0.3, DVec2::splat(0.5))), Ok(()));
        // Covering the whole texture: the island is inside the chart.
        let all = scaled(&mesh, 0.98, DVec2::splat(0.01));
        assert_eq!(room.admits(&all), Err(Violation::CoversIsland { island: 0 }));
        // Half over it: edges meet.
        let half = scaled(&mesh, 0.25, DVec2::new(0.1, 0.7));
        assert!(matches!(room.admits(&half), Err(Violation::IslandCrossing { .. })));
        // Inside it.
        let tiny = scaled(&mesh, 0.01, DVec2::new(0.07, 0.88));
        assert_eq!(room.admits(&tiny), Err(Violation::InsideIsland));
    }
}
