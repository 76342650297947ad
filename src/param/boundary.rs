//! The outer boundary loop `B` onto the unit square (§III.B): four corner
//! vertices on the square's corners, the rest on its sides by 3D arc length.
//!
//! The square has a trap (docs/algorithm.md): a triangle whose three vertices lie on
//! one side, or an interior edge joining two vertices of one side, gets zero
//! area. Automatic corners are searched to avoid it; when no corner choice
//! (or the user's corners) can, the sides are bowed outward into a strictly
//! convex shape inside the square, which has no collinear boundary vertices.

use crate::mesh::TriMesh;
use crate::mesh::topology::Topology;
use glam::DVec2;
use thiserror::Error;

/// Which corner of the texture a corner vertex goes to, in the order the
/// corners appear along the outer loop following the faces' winding.
pub const CORNER_NAMES: [&str; 4] = ["top_left", "bottom_left", "bottom_right", "top_right"];

/// Layout positions (x, y; y up) of the texture corners, same order as [`CORNER_NAMES`].
pub const SQUARE_CORNERS: [DVec2; 4] = [
    DVec2::new(0.0, 1.0),
    DVec2::new(0.0, 0.0),
    DVec2::new(1.0, 0.0),
    DVec2::new(1.0, 1.0),
];

/// Relative outward bow of each side in the fallback shape.
const BULGE: f64 = 0.02;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum BoundaryError {
    #[error(
        "corner {corner}: vertex {vertex} is not on the outer boundary (the longest boundary loop, {n_loop} vertices)"
    )]
    CornerNotOnBoundary {
        corner: &'static str,
        vertex: u32,
        n_loop: usize,
    },
    #[error("corners {first} and {second} are the same vertex {vertex}")]
    RepeatedCorner {
        first: &'static str,
        second: &'static str,
        vertex: u32,
    },
    #[error(
        "corners are in the wrong cyclic order: following the outer boundary in the faces' winding they come as {found}; \
         they must come top_left → bottom_left → bottom_right → top_right{mirror}"
    )]
    CornerOrder { found: String, mirror: &'static str },
    #[error(
        "the outer boundary has only 3 vertices, and the square needs 4 for its corners: give `boundary: Free`, or \
         `seams` that open the chart"
    )]
    ThreeCorneredLoop,
}

/// How the boundary was laid out.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundaryShape {
    /// Exactly the unit square.
    Square,
    /// Sides bowed outward (strictly convex), fitted inside the unit square:
    /// used only when every corner choice would give zero-area triangles.
    BulgedSquare,
    /// An outer loop of 3 vertices on three of the square's corners (top
    /// left, bottom left, bottom right; the top-right corner repeats the
    /// bottom-right one): a start for a free chart only, since it leaves
    /// part of the square empty.
    Triangle,
}

/// Where the corners came from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CornerSource {
    /// The constraint file's `corners`.
    Given,
    /// Arc-length quarters; `shift` = how many candidate starts were rejected
    /// because they hit the zero-area trap.
    Automatic { shift: usize },
}

/// The outer loop placed on the square.
#[derive(Debug, Clone)]
pub struct BoundaryMap {
    /// Outer loop vertices (chart-local ids), following the faces' winding.
    pub loop_vertices: Vec<u32>,
    /// Layout position of each loop vertex (same order).
    pub positions: Vec<DVec2>,
    /// Loop indices of the corner vertices: top_left, bottom_left, bottom_right, top_right.
    pub corners: [usize; 4],
    pub shape: BoundaryShape,
    pub corner_source: CornerSource,
    /// Triangles or chords the plain square would have flattened (0 unless the fallback was used).
    pub trapped_on_square: usize,
}

impl BoundaryMap {
    /// Corner vertices (chart-local ids) in [`CORNER_NAMES`] order.
    pub fn corner_vertices(&self) -> [u32; 4] {
        self.corners.map(|i| self.loop_vertices[i])
    }

    /// Per vertex of a chart of `n_vertices`, whether it is on the outer loop.
    pub fn on_loop(&self, n_vertices: usize) -> Vec<bool> {
        crate::mesh::marked(n_vertices, &self.loop_vertices)
    }
}

/// Triangles and interior edges whose vertices all lie on the outer loop: the
/// only places the zero-area trap can bite. Precomputed once per chart.
#[derive(Debug, Clone, Default)]
pub struct TrapCandidates {
    /// Loop indices of triangles with all three vertices on the outer loop.
    pub triangles: Vec<[usize; 3]>,
    /// Loop indices of interior edges with both ends on the outer loop.
    pub chords: Vec<[usize; 2]>,
}

impl TrapCandidates {
    pub fn find(mesh: &TriMesh, topology: &Topology) -> Self {
        let outer = topology.outer_loop();
        let mut loop_index = vec![usize::MAX; mesh.n_vertices()];
        for (i, &v) in outer.iter().enumerate() {
            loop_index[v as usize] = i;
        }
        let on = |v: u32| loop_index[v as usize] != usize::MAX;
        let triangles = mesh
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&v| on(v)))
            .map(|t| t.map(|v| loop_index[v as usize]))
            .collect();
        let chords = topology
            .edges
            .iter()
            .zip(&topology.edge_is_boundary)
            .filter(|(e, b)| !**b && on(e[0]) && on(e[1]))
            .map(|(e, _)| e.map(|v| loop_index[v as usize]))
            .collect();
        TrapCandidates { triangles, chords }
    }

    /// Whether a triangle or chord would be flattened with these corners on
    /// the square ([`TrapCandidates::count_trapped`] above zero), stopping
    /// at the first.
    pub fn any_trapped(&self, n_loop: usize, corners: &[usize; 4]) -> bool {
        let sides = |i: usize| side_mask(i, n_loop, corners);
        self.triangles
            .iter()
            .any(|t| sides(t[0]) & sides(t[1]) & sides(t[2]) != 0)
            || self.chords.iter().any(|e| sides(e[0]) & sides(e[1]) != 0)
    }

    /// How many triangles/chords would be flattened with these corners on the square.
    pub fn count_trapped(&self, n_loop: usize, corners: &[usize; 4]) -> usize {
        let sides = |i: usize| side_mask(i, n_loop, corners);
        let tris = self
            .triangles
            .iter()
            .filter(|t| sides(t[0]) & sides(t[1]) & sides(t[2]) != 0)
            .count();
        let chords = self.chords.iter().filter(|e| sides(e[0]) & sides(e[1]) != 0).count();
        tris + chords
    }
}

impl TrapCandidates {
    /// Loop indices of "ear tips": the middle vertex of a triangle made of
    /// three consecutive loop vertices. Such a triangle keeps its area only if
    /// its tip is a corner.
    fn ear_tips(&self, n: usize) -> Vec<usize> {
        let mut tips: Vec<usize> = self
            .triangles
            .iter()
            .filter_map(|t| {
                (0..3)
                    .map(|k| t[k])
                    .find(|&m| t.contains(&((m + 1) % n)) && t.contains(&((m + n - 1) % n)))
            })
            .collect();
        tips.sort_unstable();
        tips.dedup();
        tips
    }
}

/// Moves each corner onto the nearest ear tip within an eighth of the loop,
/// keeping the corners distinct and in cyclic order.
fn snap_to_ear_tips(mut corners: [usize; 4], tips: &[usize], n: usize) -> [usize; 4] {
    let dist = |a: usize, b: usize| (a + n - b) % n;
    let cyclic = |a: usize, b: usize| dist(a, b).min(dist(b, a));
    for &tip in tips {
        let (k, d) = (0..4)
            .map(|k| (k, cyclic(corners[k], tip)))
            .min_by_key(|&(_, d)| d)
            .expect("four corners");
        if d == 0 || d > n / 8 {
            continue;
        }
        let mut moved = corners;
        moved[k] = tip;
        let rel = |x: usize| dist(x, moved[0]);
        let ordered = rel(moved[1]) > 0 && rel(moved[1]) < rel(moved[2]) && rel(moved[2]) < rel(moved[3]);
        if ordered {
            corners = moved;
        }
    }
    corners
}

/// Bit `k` set when loop index `i` lies on side `k` (from corner k to corner k+1, inclusive).
fn side_mask(i: usize, n: usize, corners: &[usize; 4]) -> u8 {
    let rel = |x: usize| (x + n - corners[0]) % n;
    let ri = rel(i);
    let mut mask = 0u8;
    for k in 0..4 {
        let (a, b) = (rel(corners[k]), if k == 3 { n } else { rel(corners[k + 1]) });
        if ri >= a && ri <= b {
            mask |= 1 << k;
        }
    }
    // Index 0 is corner 0, which also ends side 3.
    if ri == 0 {
        mask |= 1 << 3;
    }
    mask
}

/// Cumulative 3D arc length at each loop vertex (arc[0] = 0) and the total.
fn arc_lengths(mesh: &TriMesh, lp: &[u32]) -> (Vec<f64>, f64) {
    let mut arc = Vec::with_capacity(lp.len());
    let mut s = 0.0;
    for i in 0..lp.len() {
        arc.push(s);
        s += mesh.positions[lp[i] as usize].distance(mesh.positions[lp[(i + 1) % lp.len()] as usize]);
    }
    (arc, s)
}

/// Corners at the arc-length quarters starting from loop index `start`.
fn quarter_corners(arc: &[f64], total: f64, start: usize) -> Option<[usize; 4]> {
    let n = arc.len();
    let mut corners = [start; 4];
    for (k, c) in corners.iter_mut().enumerate().skip(1) {
        let want = arc[start] + total * k as f64 / 4.0;
        // Walk forward from start to the vertex nearest to `want` (cyclic arc).
        let mut best = start;
        let mut best_d = f64::INFINITY;
        for step in 1..n {
            let i = (start + step) % n;
            let a = if i >= start { arc[i] } else { arc[i] + total };
            let d = (a - want).abs();
            if d < best_d {
                best_d = d;
                best = i;
            }
        }
        *c = best;
    }
    let rel = |x: usize| (x + n - start) % n;
    (rel(corners[1]) > 0 && rel(corners[1]) < rel(corners[2]) && rel(corners[2]) < rel(corners[3])).then_some(corners)
}

/// Places the outer loop on the unit square (§III.B).
///
/// `given` are the user's corner vertices (chart-local, [`CORNER_NAMES`] order).
/// Without them, corners start at the arc-length quarters from the loop's
/// lowest vertex id and shift along the loop until no triangle or chord is
/// flattened. If none works, the strictly convex bulged square is used.
///
/// # Errors
/// A given corner not on the outer loop, repeated, or in an order that would
/// mirror the texture.
pub fn map_outer_boundary(
    mesh: &TriMesh,
    topology: &Topology,
    traps: &TrapCandidates,
    given: Option<[u32; 4]>,
) -> Result<BoundaryMap, BoundaryError> {
    // Start the loop at its lowest vertex id so the layout is deterministic.
    let raw = topology.outer_loop();
    let start = (0..raw.len()).min_by_key(|&i| raw[i]).expect("non-empty loop");
    let loop_vertices: Vec<u32> = raw[start..].iter().chain(&raw[..start]).copied().collect();
    let n = loop_vertices.len();
    // TrapCandidates index the topology's own loop order: rotate them.
    let rotate = |i: usize| (i + n - start) % n;
    let traps = TrapCandidates {
        triangles: traps.triangles.iter().map(|t| t.map(rotate)).collect(),
        chords: traps.chords.iter().map(|e| e.map(rotate)).collect(),
    };
    if n == 3 {
        return three_cornered(loop_vertices, given);
    }
    let (arc, total) = arc_lengths(mesh, &loop_vertices);

    let (corners, source, trapped) = match given {
        Some(vertices) => {
            let corners = given_corners(&loop_vertices, vertices)?;
            (corners, CornerSource::Given, traps.count_trapped(n, &corners))
        }
        None => {
            let ear_tips = traps.ear_tips(n);
            let mut first: Option<([usize; 4], usize)> = None;
            let mut found = None;
            // Candidate starts ordered by distance from loop index 0, both ways.
            for shift in 0..n {
                let s = if shift % 2 == 0 { shift / 2 } else { n - 1 - shift / 2 };
                let Some(c) = quarter_corners(&arc, total, s).map(|c| snap_to_ear_tips(c, &ear_tips, n)) else {
                    continue;
                };
                // Counted for the first corners only (the fallback's);
                // the others need only whether one is trapped.
                let trapped = match first {
                    None => {
                        let count = traps.count_trapped(n, &c);
                        first = Some((c, count));
                        count > 0
                    }
                    Some(_) => traps.any_trapped(n, &c),
                };
                if !trapped {
                    found = Some((c, CornerSource::Automatic { shift }, 0));
                    break;
                }
            }
            match found {
                Some(f) => f,
                None => {
                    // No arc-length quarters at all (one edge longer than the
                    // rest of the loop together): fall back to vertex-count quarters.
                    let (c, t) = first.unwrap_or_else(|| {
                        let c = [0, n / 4, n / 2, 3 * n / 4];
                        (c, traps.count_trapped(n, &c))
                    });
                    (c, CornerSource::Automatic { shift: n }, t)
                }
            }
        }
    };
    let shape = if trapped == 0 {
        BoundaryShape::Square
    } else {
        BoundaryShape::BulgedSquare
    };
    let positions = place_on_square(&arc, total, &corners, shape);
    Ok(BoundaryMap {
        loop_vertices,
        positions,
        corners,
        shape,
        corner_source: source,
        trapped_on_square: trapped,
    })
}

/// An outer loop of 3 vertices (a chart of one triangle, a fan of three)
/// on three of the square's corners, counter-clockwise as its winding: a
/// convex polygon, so the bar-net of Eq. 1 keeps every triangle inside
/// positive. The square cannot take it ([`BoundaryShape::Triangle`]).
fn three_cornered(loop_vertices: Vec<u32>, given: Option<[u32; 4]>) -> Result<BoundaryMap, BoundaryError> {
    if given.is_some() {
        return Err(BoundaryError::ThreeCorneredLoop);
    }
    Ok(BoundaryMap {
        loop_vertices,
        positions: SQUARE_CORNERS[..3].to_vec(),
        corners: [0, 1, 2, 2],
        shape: BoundaryShape::Triangle,
        corner_source: CornerSource::Automatic { shift: 0 },
        trapped_on_square: 0,
    })
}

fn given_corners(loop_vertices: &[u32], vertices: [u32; 4]) -> Result<[usize; 4], BoundaryError> {
    let n = loop_vertices.len();
    let mut idx = [0usize; 4];
    for k in 0..4 {
        idx[k] = loop_vertices
            .iter()
            .position(|&v| v == vertices[k])
            .ok_or(BoundaryError::CornerNotOnBoundary {
                corner: CORNER_NAMES[k],
                vertex: vertices[k],
                n_loop: n,
            })?;
        for j in 0..k {
            if vertices[j] == vertices[k] {
                return Err(BoundaryError::RepeatedCorner {
                    first: CORNER_NAMES[j],
                    second: CORNER_NAMES[k],
                    vertex: vertices[k],
                });
            }
        }
    }
    let rel = |x: usize| (x + n - idx[0]) % n;
    if rel(idx[1]) < rel(idx[2]) && rel(idx[2]) < rel(idx[3]) {
        return Ok(idx);
    }
    let mut order: Vec<usize> = (0..4).collect();
    order.sort_by_key(|&k| rel(idx[k]));
    let found = order.iter().map(|&k| CORNER_NAMES[k]).collect::<Vec<_>>().join(" → ");
    let mirrored = rel(idx[3]) < rel(idx[2]) && rel(idx[2]) < rel(idx[1]);
    Err(BoundaryError::CornerOrder {
        found,
        mirror: if mirrored {
            " (this order would mirror the texture)"
        } else {
            ""
        },
    })
}

/// Positions of the loop vertices: each side by 3D arc length between its corners.
fn place_on_square(arc: &[f64], total: f64, corners: &[usize; 4], shape: BoundaryShape) -> Vec<DVec2> {
    let n = arc.len();
    let mut out = vec![DVec2::ZERO; n];
    // A tiny index term keeps vertices distinct even across zero-length edges.
    let delta = 1e-9 * total.max(f64::MIN_POSITIVE);
    for k in 0..4 {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let len = (b + n - a) % n;
        let arc_at = |step: usize| {
            let i = (a + step) % n;
            let base = if i >= a {
                arc[i] - arc[a]
            } else {
                arc[i] + total - arc[a]
            };
            base + delta * step as f64
        };
        let side_len = arc_at(len);
        let (p0, p1) = (SQUARE_CORNERS[k], SQUARE_CORNERS[(k + 1) % 4]);
        for step in 0..len {
            let s = arc_at(step) / side_len;
            let mut p = p0.lerp(p1, s);
            if shape == BoundaryShape::BulgedSquare {
                // Outward normal of side k for a counter-clockwise square.
                let d = p1 - p0;
                let outward = DVec2::new(d.y, -d.x);
                p += outward * (4.0 * BULGE * s * (1.0 - s));
            }
            out[(a + step) % n] = p;
        }
    }
    if shape == BoundaryShape::BulgedSquare {
        let scale = 1.0 / (1.0 + 2.0 * BULGE);
        for p in &mut out {
            *p = (*p + DVec2::splat(BULGE)) * scale;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::grid_mesh;

    fn setup(nx: usize, ny: usize) -> (TriMesh, Topology, TrapCandidates) {
        let m = grid_mesh(nx, ny);
        let t = Topology::build(&m).unwrap();
        let c = TrapCandidates::find(&m, &t);
        (m, t, c)
    }

    /// One boundary vertex far away makes a single edge longer than the rest
    /// of the loop together; corners then fall back to vertex-count quarters.
    #[test]
    fn one_huge_boundary_edge_still_gets_four_corners() {
        let (mut m, _, _) = setup(7, 7);
        m.positions[3].y = -1.7e16;
        let t = Topology::build(&m).unwrap();
        let c = TrapCandidates::find(&m, &t);
        let b = map_outer_boundary(&m, &t, &c, None).unwrap();
        let mut corners = b.corners;
        corners.sort_unstable();
        assert!(corners.windows(2).all(|w| w[0] < w[1]), "{:?}", b.corners);
        assert!(b.positions.iter().all(|p| p.is_finite()));
    }

    #[test]
    fn grid_corners_land_on_square_corners_counter_clockwise() {
        let (m, t, c) = setup(5, 5);
        let b = map_outer_boundary(&m, &t, &c, Some([20, 0, 4, 24])).unwrap();
        assert_eq!(b.shape, BoundaryShape::Square);
        // The grid's own corners: vertex 20 = (0,1), 0 = (0,0), 4 = (1,0), 24 = (1,1).
        for (k, &v) in [20u32, 0, 4, 24].iter().enumerate() {
            let i = b.loop_vertices.iter().position(|&x| x == v).unwrap();
            assert!(b.positions[i].distance(SQUARE_CORNERS[k]) < 1e-12);
        }
        // Every boundary vertex of the unit grid lands on its own position.
        for (i, &v) in b.loop_vertices.iter().enumerate() {
            let p = m.positions[v as usize].truncate();
            assert!(
                b.positions[i].distance(p) < 1e-9,
                "vertex {v}: {:?} vs {p:?}",
                b.positions[i]
            );
        }
    }

    #[test]
    fn a_loop_of_three_goes_on_three_corners_counter_clockwise() {
        // Three triangles around an apex: the outer loop has 3 vertices.
        let m = TriMesh {
            positions: vec![
                glam::DVec3::ZERO,
                glam::DVec3::X,
                glam::DVec3::Y,
                glam::DVec3::new(0.3, 0.3, 0.5),
            ],
            triangles: vec![[0, 1, 3], [1, 2, 3], [2, 0, 3]],
        };
        let t = Topology::build(&m).unwrap();
        assert_eq!(t.outer_loop().len(), 3);
        let c = TrapCandidates::find(&m, &t);
        let b = map_outer_boundary(&m, &t, &c, None).unwrap();
        assert_eq!(b.shape, BoundaryShape::Triangle);
        let p = &b.positions;
        assert!((p[1] - p[0]).perp_dot(p[2] - p[0]) > 0.0, "counter-clockwise: {p:?}");
        let e = map_outer_boundary(&m, &t, &c, Some([0, 1, 2, 3])).unwrap_err();
        assert_eq!(e, BoundaryError::ThreeCorneredLoop);
    }

    #[test]
    fn mirrored_corners_are_rejected_with_a_reason() {
        let (m, t, c) = setup(4, 4);
        let e = map_outer_boundary(&m, &t, &c, Some([15, 3, 0, 12])).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("mirror"), "{msg}");
        let e = map_outer_boundary(&m, &t, &c, Some([12, 0, 5, 15])).unwrap_err();
        assert!(matches!(
            e,
            BoundaryError::CornerNotOnBoundary {
                corner: "bottom_right",
                vertex: 5,
                ..
            }
        ));
    }

    #[test]
    fn ear_triangle_forces_a_corner_shift_or_the_bulge() {
        // An "ear": one triangle glued on boundary edge 0→1 adds vertex 16 to the
        // outer loop, and triangle (1, 0, 16) has all three vertices on the loop.
        let (mut m, _, _) = setup(4, 4);
        m.positions.push(glam::DVec3::new(0.5 / 3.0, -0.2, 0.0));
        m.triangles.push([1, 0, 16]);
        let t = Topology::build(&m).unwrap();
        let c = TrapCandidates::find(&m, &t);
        // The ear, plus the grid's own corner triangles at (1,0) and (0,1).
        assert_eq!(c.triangles.len(), 3);
        let b = map_outer_boundary(&m, &t, &c, None).unwrap();
        assert_eq!(b.shape, BoundaryShape::Square);
        assert_eq!(b.trapped_on_square, 0);
        assert!(
            b.corner_vertices().contains(&16),
            "the ear tip must be a corner: {:?}",
            b.corner_vertices()
        );
        // Given corners that leave the ear on one side: the strictly convex fallback.
        let b = map_outer_boundary(&m, &t, &c, Some([12, 0, 3, 15])).unwrap();
        assert_eq!(b.shape, BoundaryShape::BulgedSquare);
        assert!(b.trapped_on_square > 0);
    }

    #[test]
    fn bulged_shape_is_strictly_convex_and_inside() {
        let arc: Vec<f64> = (0..16).map(|i| i as f64).collect();
        let p = place_on_square(&arc, 16.0, &[0, 4, 8, 12], BoundaryShape::BulgedSquare);
        for i in 0..16 {
            let (a, b, c) = (p[i], p[(i + 1) % 16], p[(i + 2) % 16]);
            assert!((b - a).perp_dot(c - b) > 0.0, "not strictly convex at {i}");
            assert!(p[i].cmpge(DVec2::ZERO).all() && p[i].cmple(DVec2::ONE).all());
        }
    }
}
