//! Triangulating a polygon face (quads and n-gons as modelling tools
//! export them, non-convex ones too) by ear clipping in its own plane.

use glam::{DVec2, DVec3};

/// Triangles `[a, b, c]` (positions in `points`, the polygon's corners in
/// order) covering the polygon, wound as it is. Ear clipping in the plane
/// of the polygon's Newell normal; a polygon with no ear to clip (self
/// intersecting, or flat to a line) is fanned from its first corner.
pub fn triangulate(points: &[DVec3]) -> Vec<[usize; 3]> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    if n == 3 {
        return vec![[0, 1, 2]];
    }
    let flat = project(points);
    ear_clip(&flat).unwrap_or_else(|| (1..n - 1).map(|i| [0, i, i + 1]).collect())
}

/// The corners in the polygon's plane, counter-clockwise when the polygon
/// is wound counter-clockwise about its normal.
fn project(points: &[DVec3]) -> Vec<DVec2> {
    let n = points.len();
    let mut normal = DVec3::ZERO;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        normal += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    let normal = normal.normalize_or(DVec3::Z);
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    points.iter().map(|p| DVec2::new(p.dot(u), p.dot(v))).collect()
}

fn cross(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    (a - o).perp_dot(b - o)
}

/// Whether `p` lies inside or on triangle `abc` (counter-clockwise).
fn inside(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0
}

/// Ear clipping of a simple counter-clockwise polygon; `None` when it
/// finds no ear (the polygon is not simple).
fn ear_clip(flat: &[DVec2]) -> Option<Vec<[usize; 3]>> {
    let mut left: Vec<usize> = (0..flat.len()).collect();
    let mut out = Vec::with_capacity(flat.len() - 2);
    while left.len() > 3 {
        let m = left.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
            let (pa, pb, pc) = (flat[a], flat[b], flat[c]);
            cross(pa, pb, pc) > 0.0
                && left
                    .iter()
                    .filter(|&&k| k != a && k != b && k != c)
                    .all(|&k| !inside(flat[k], pa, pb, pc) || flat[k] == pa || flat[k] == pb || flat[k] == pc)
        })?;
        out.push([left[(ear + m - 1) % m], left[ear], left[(ear + 1) % m]]);
        left.remove(ear);
    }
    let [a, b, c] = [left[0], left[1], left[2]];
    (cross(flat[a], flat[b], flat[c]) > 0.0).then(|| {
        out.push([a, b, c]);
        out
    })
}

/// The diagonals a triangulation adds inside its polygon: its triangles'
/// edges that are not sides of the polygon (`n` corners), as corner pairs.
pub fn diagonals(triangles: &[[usize; 3]], n: usize) -> Vec<[usize; 2]> {
    let side = |a: usize, b: usize| (a + 1) % n == b || (b + 1) % n == a;
    let mut out: Vec<[usize; 2]> = triangles
        .iter()
        .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
        .filter(|e| !side(e[0], e[1]))
        .map(|e| [e[0].min(e[1]), e[0].max(e[1])])
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(points: &[DVec3], tris: &[[usize; 3]]) -> f64 {
        let flat = project(points);
        tris.iter()
            .map(|t| 0.5 * cross(flat[t[0]], flat[t[1]], flat[t[2]]))
            .sum()
    }

    #[test]
    fn a_quad_is_two_triangles_wound_its_way() {
        let quad = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let t = triangulate(&quad);
        assert_eq!(t.len(), 2);
        assert!((area(&quad, &t) - 1.0).abs() < 1e-12);
        assert_eq!(diagonals(&t, 4).len(), 1);
    }

    #[test]
    fn a_non_convex_polygon_is_cut_inside_itself() {
        // An L shape (its reflex corner at index 3).
        let l: Vec<DVec3> = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)]
            .iter()
            .map(|&(x, y)| DVec3::new(x, y, 0.0))
            .collect();
        let t = triangulate(&l);
        assert_eq!(t.len(), 4);
        assert!((area(&l, &t) - 3.0).abs() < 1e-12, "covers the L exactly once");
        let flat = project(&l);
        assert!(t.iter().all(|t| cross(flat[t[0]], flat[t[1]], flat[t[2]]) > 0.0));
    }

    #[test]
    fn a_polygon_wound_the_other_way_keeps_its_winding() {
        let quad = [DVec3::ZERO, DVec3::Y, DVec3::new(1.0, 1.0, 0.0), DVec3::X];
        let t = triangulate(&quad);
        // Seen from +z the quad turns clockwise, and so do its triangles.
        for tri in t {
            let [a, b, c] = tri.map(|i| quad[i]);
            assert!((b - a).cross(c - a).z < 0.0);
        }
    }
}
