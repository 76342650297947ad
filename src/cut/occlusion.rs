//! Which triangles a camera sees whole: turned towards it (positive in
//! its projection) and overlapped, where it projects, by nothing nearer.
//! The triangles seen whole are one-to-one in the projection by
//! construction — no two overlap, none is turned over — so the camera's
//! view of them is a fold-free layout with every landmark they hold on
//! its projected target, and no depth tolerance is guessed.

use crate::mesh::TriMesh;
use glam::DVec2;

/// A triangle counts as turned towards the camera when its projection
/// covers more than this share of its longest side squared: a wall seen
/// edge-on is no part of the view.
const MIN_AREA: f64 = 1e-6;

/// At most this many grid cells per triangle, on the mean.
const CELLS_PER_TRIANGLE: usize = 24;

/// Whether each triangle of `mesh` is seen whole: positive in the
/// projection `projected` (vertex positions in view) and behind no other
/// positive triangle that overlaps it, nearer meaning a larger `depth`.
pub fn seen_whole(mesh: &TriMesh, projected: &[DVec2], depth: &[f64]) -> Vec<bool> {
    let n_t = mesh.triangles.len();
    let corners = |t: usize| mesh.triangles[t].map(|v| projected[v as usize]);
    let (lo, hi) = projected.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(a, b), &p| (a.min(p), b.max(p)),
    );
    let span = (hi - lo).max_element();
    if !(span.is_finite() && span > 0.0) {
        return vec![false; n_t];
    }
    // Edge-on by its own shape: area against its longest side squared.
    let mut seen: Vec<bool> = (0..n_t)
        .map(|t| {
            let [a, b, c] = corners(t);
            let longest = a
                .distance_squared(b)
                .max(b.distance_squared(c))
                .max(c.distance_squared(a));
            crate::guard::orientation(a, b, c) > 2.0 * MIN_AREA * longest
        })
        .collect();
    let front: Vec<usize> = (0..n_t).filter(|&t| seen[t]).collect();
    // The grid over the triangles turned towards the camera only: a far
    // vertex behind would coarsen it for all.
    let (lo, hi) = front.iter().flat_map(|&t| corners(t)).fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(a, b), p| (a.min(p), b.max(p)),
    );
    let grid = Grid::new(&front, &corners, (lo, hi));
    let mut hidden = vec![false; n_t];
    grid.for_each_pair(|s, t| {
        let (ts, tt) = (mesh.triangles[s], mesh.triangles[t]);
        let shared = ts.iter().filter(|v| tt.contains(v)).count();
        if shared >= 2 {
            return;
        }
        let (a, b) = (corners(s), corners(t));
        let Some(at) = overlap_point(&a, &b) else {
            return;
        };
        let ds = depth_at(&a, ts.map(|v| depth[v as usize]), at);
        let dt = depth_at(&b, tt.map(|v| depth[v as usize]), at);
        // The farther is hidden; a tie (coplanar overlap) hides the later.
        if ds < dt || (ds == dt && s > t) {
            hidden[s] = true;
        } else {
            hidden[t] = true;
        }
    });
    for (s, h) in seen.iter_mut().zip(&hidden) {
        *s &= !h;
    }
    seen
}

/// A uniform grid over the view, each cell listing the triangles whose
/// bounding box covers it.
struct Grid {
    cells: Vec<Vec<u32>>,
    boxes: Vec<(usize, [usize; 4])>,
}

impl Grid {
    fn new(front: &[usize], corners: &impl Fn(usize) -> [DVec2; 3], (lo, hi): (DVec2, DVec2)) -> Grid {
        let span = (hi - lo).max(DVec2::splat(f64::MIN_POSITIVE));
        let budget = CELLS_PER_TRIANGLE * front.len().max(1);
        let mut side = ((front.len() as f64).sqrt().ceil() as usize).clamp(1, 1024);
        loop {
            let cell = span / side as f64;
            let at = |p: DVec2| {
                let q = (p - lo) / cell;
                [
                    (q.x.max(0.0) as usize).min(side - 1),
                    (q.y.max(0.0) as usize).min(side - 1),
                ]
            };
            let boxes: Vec<(usize, [usize; 4])> = front
                .iter()
                .map(|&t| {
                    let [a, b, c] = corners(t);
                    let (l, h) = (at(a.min(b).min(c)), at(a.max(b).max(c)));
                    (t, [l[0], l[1], h[0], h[1]])
                })
                .collect();
            let covered: usize = boxes.iter().map(|(_, b)| (b[2] - b[0] + 1) * (b[3] - b[1] + 1)).sum();
            if covered > budget && side > 1 {
                side = side.div_ceil(2);
                continue;
            }
            let mut cells = vec![Vec::new(); side * side];
            for (k, b) in boxes.iter().enumerate() {
                for y in b.1[1]..=b.1[3] {
                    for x in b.1[0]..=b.1[2] {
                        cells[y * side + x].push(k as u32);
                    }
                }
            }
            return Grid { cells, boxes };
        }
    }

    /// Calls `f(s, t)` once for every pair of triangles whose boxes share
    /// a cell (in the first cell they share).
    fn for_each_pair(&self, mut f: impl FnMut(usize, usize)) {
        let side = (self.cells.len() as f64).sqrt() as usize;
        for (c, list) in self.cells.iter().enumerate() {
            let (x, y) = (c % side, c / side);
            for (i, &p) in list.iter().enumerate() {
                let bp = self.boxes[p as usize].1;
                for &q in &list[i + 1..] {
                    let bq = self.boxes[q as usize].1;
                    // The first shared cell is the corner of the boxes' overlap.
                    if bp[0].max(bq[0]) == x && bp[1].max(bq[1]) == y {
                        f(self.boxes[p as usize].0, self.boxes[q as usize].0);
                    }
                }
            }
        }
    }
}

/// A point in both (positive) triangles `a` and `b` when their insides
/// meet: where an edge of one crosses an edge of the other, or a corner of
/// one strictly inside the other (exact orientation tests: triangles that
/// only touch, along an edge or at a corner, do not meet).
fn overlap_point(a: &[DVec2; 3], b: &[DVec2; 3]) -> Option<DVec2> {
    let orient = crate::guard::orientation;
    for i in 0..3 {
        let (p, q) = (a[i], a[(i + 1) % 3]);
        for j in 0..3 {
            let (r, s) = (b[j], b[(j + 1) % 3]);
            let (d1, d2) = (orient(p, q, r), orient(p, q, s));
            let (d3, d4) = (orient(r, s, p), orient(r, s, q));
            let apart = |x: f64, y: f64| (x < 0.0 && y > 0.0) || (x > 0.0 && y < 0.0);
            if apart(d1, d2) && apart(d3, d4) {
                // Just inside both, beside the crossing.
                let t = d3 / (d3 - d4);
                return Some(p + (q - p) * t);
            }
        }
    }
    let inside = |x: DVec2, tri: &[DVec2; 3]| (0..3).all(|k| orient(tri[k], tri[(k + 1) % 3], x) > 0.0);
    a.iter()
        .find(|&&x| inside(x, b))
        .or_else(|| b.iter().find(|&&x| inside(x, a)))
        .copied()
        .or_else(|| {
            // Nested or equal along shared lines: neither crosses the other
            // nor holds a corner of it strictly, but holds its centre.
            let (ca, cb) = ((a[0] + a[1] + a[2]) / 3.0, (b[0] + b[1] + b[2]) / 3.0);
            [ca, cb].into_iter().find(|&c| inside(c, a) && inside(c, b))
        })
}

/// The depth at `p` of the triangle with projected corners `c` and corner
/// depths `d` (barycentric).
fn depth_at(c: &[DVec2; 3], d: [f64; 3], p: DVec2) -> f64 {
    let twice = (c[1] - c[0]).perp_dot(c[2] - c[0]);
    let wa = (c[1] - p).perp_dot(c[2] - p) / twice;
    let wb = (c[2] - p).perp_dot(c[0] - p) / twice;
    wa * d[0] + wb * d[1] + (1.0 - wa - wb) * d[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn view(mesh: &TriMesh) -> (Vec<DVec2>, Vec<f64>) {
        // Looking down −z: (x, y) seen, z nearer.
        (
            mesh.positions.iter().map(|p| DVec2::new(p.x, p.y)).collect(),
            mesh.positions.iter().map(|p| p.z).collect(),
        )
    }

    #[test]
    fn a_triangle_half_behind_another_is_hidden_and_the_front_one_seen() {
        let mesh = TriMesh {
            positions: vec![
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(1.0, 0.0, 1.0),
                DVec3::new(0.0, 1.0, 1.0),
                DVec3::new(0.5, 0.2, 0.0),
                DVec3::new(2.0, 0.2, 0.0),
                DVec3::new(0.5, 2.0, 0.0),
                // Beside both, touching nothing.
                DVec3::new(3.0, 3.0, 0.0),
                DVec3::new(4.0, 3.0, 0.0),
                DVec3::new(3.0, 4.0, 0.0),
            ],
            triangles: vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]],
        };
        let (p, d) = view(&mesh);
        assert_eq!(seen_whole(&mesh, &p, &d), vec![true, false, true]);
    }

    #[test]
    fn a_cad_frame_at_a_slant_is_seen_whole_without_two_triangles_overlapping() {
        // Its long facets: an inner wall shows through the hole only in
        // part, and a depth tolerance would take in what lies behind a rim.
        let mut frame = crate::testing::square_frame(0.6, 2);
        let tilt = glam::DQuat::from_rotation_x(0.5) * glam::DQuat::from_rotation_y(-0.3);
        frame.positions.iter_mut().for_each(|p| *p = tilt * *p);
        let (p, d) = view(&frame);
        let seen = seen_whole(&frame, &p, &d);
        let kept: Vec<usize> = (0..seen.len()).filter(|&t| seen[t]).collect();
        assert!(kept.len() > frame.n_triangles() / 5, "{} seen", kept.len());
        for (i, &s) in kept.iter().enumerate() {
            let a = frame.triangles[s].map(|v| p[v as usize]);
            assert!(crate::guard::orientation(a[0], a[1], a[2]) > 0.0, "{s} turned over");
            for &t in &kept[i + 1..] {
                let b = frame.triangles[t].map(|v| p[v as usize]);
                assert_eq!(overlap_point(&a, &b), None, "{s} and {t} overlap in the view");
            }
        }
        // Every triangle of the top (turned most towards the camera, in
        // front of everything) is seen whole.
        let up = tilt * DVec3::Z;
        for (t, tri) in frame.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|v| frame.positions[v as usize]);
            if (b - a).cross(c - a).normalize().dot(up) > 0.99 && a.dot(up) > 0.5 {
                assert!(seen[t], "top triangle {t} hidden");
            }
        }
    }

    #[test]
    fn a_triangle_nested_in_another_along_its_sides_overlaps_it() {
        let a = [DVec2::ZERO, DVec2::new(2.0, 0.0), DVec2::new(0.0, 2.0)];
        let b = [DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0)];
        assert!(overlap_point(&a, &b).is_some());
        assert!(overlap_point(&b, &a).is_some());
        let apart = [DVec2::new(2.0, 0.0), DVec2::new(3.0, 0.0), DVec2::new(2.0, 1.0)];
        assert_eq!(overlap_point(&a, &apart), None, "touching at a corner");
    }

    #[test]
    fn a_sphere_is_seen_whole_on_its_near_side_only_and_without_overlaps() {
        let sphere = crate::testing::uv_sphere(16, 24);
        let (p, d) = view(&sphere);
        let seen = seen_whole(&sphere, &p, &d);
        for (t, tri) in sphere.triangles.iter().enumerate().filter(|(t, _)| seen[*t]) {
            let z: f64 = tri.iter().map(|&v| sphere.positions[v as usize].z).sum();
            assert!(z > 0.0, "triangle {t} is on the far side");
        }
        let n = seen.iter().filter(|&&s| s).count();
        assert!(n > sphere.n_triangles() / 3, "{n} seen");
    }
}
