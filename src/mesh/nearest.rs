//! Points against a mesh's primitives: the bounding box, the vertices
//! nearest a point, and how far the point is from the surface. `near:`
//! constraints and `uvpin inspect` use them.

use super::weld::PrimitiveGeometry;
use glam::DVec3;
use serde::Serialize;

/// A `near:` point farther than this fraction of the bounding box's
/// diagonal from the surface is an error (it was almost certainly given in
/// other coordinates).
pub const NEAR_TOLERANCE: f64 = 0.05;

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

/// The axis a mesh stands along (see [`Bounds::up_axis`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UpAxis {
    Y,
    Z,
}

impl UpAxis {
    pub fn vector(self) -> DVec3 {
        match self {
            UpAxis::Y => DVec3::Y,
            UpAxis::Z => DVec3::Z,
        }
    }
}

impl Bounds {
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }

    /// Which way the mesh most likely stands: Z when it is tallest along Z
    /// by a clear margin (exported Z-up, as from a scanner or a CAD tool),
    /// else glTF's Y.
    pub fn up_axis(&self) -> UpAxis {
        let s = self.size();
        if s.z > 1.5 * s.y && s.z >= s.x {
            UpAxis::Z
        } else {
            UpAxis::Y
        }
    }

    pub fn size(&self) -> DVec3 {
        self.max - self.min
    }
}

/// A vertex near a point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Nearest {
    /// glTF primitive index.
    pub primitive: usize,
    pub vertex: u32,
    pub position: DVec3,
    pub distance: f64,
}

fn point(p: [f32; 3]) -> DVec3 {
    DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
}

/// Which vertices of `prim` some triangle uses.
pub fn used_vertices(prim: &PrimitiveGeometry) -> Vec<bool> {
    let mut used = vec![false; prim.positions.len()];
    for &i in &prim.indices {
        if let Some(u) = used.get_mut(i as usize) {
            *u = true;
        }
    }
    used
}

/// The primitives to search: all, or only glTF primitive `only`.
fn selected(primitives: &[PrimitiveGeometry], only: Option<usize>) -> impl Iterator<Item = &PrimitiveGeometry> {
    primitives.iter().filter(move |p| only.is_none_or(|i| p.index == i))
}

/// The box around every vertex a triangle uses (`None`: no triangles).
pub fn bounds(primitives: &[PrimitiveGeometry]) -> Option<Bounds> {
    let mut out: Option<Bounds> = None;
    for prim in primitives {
        for &i in &prim.indices {
            let p = point(prim.positions[i as usize]);
            out = Some(match out {
                None => Bounds { min: p, max: p },
                Some(b) => Bounds {
                    min: b.min.min(p),
                    max: b.max.max(p),
                },
            });
        }
    }
    out
}

/// The `k` used vertices of `primitives` (or of glTF primitive `only`)
/// nearest `p`, nearest first.
pub fn nearest_vertices(primitives: &[PrimitiveGeometry], only: Option<usize>, p: DVec3, k: usize) -> Vec<Nearest> {
    let mut all: Vec<Nearest> = Vec::new();
    for prim in selected(primitives, only) {
        let used = used_vertices(prim);
        for (v, pos) in prim.positions.iter().enumerate().filter(|(v, _)| used[*v]) {
            let position = point(*pos);
            all.push(Nearest {
                primitive: prim.index,
                vertex: v as u32,
                position,
                distance: position.distance(p),
            });
        }
    }
    let k = k.min(all.len());
    if k == 0 {
        return Vec::new();
    }
    all.select_nth_unstable_by(k - 1, |a, b| a.distance.total_cmp(&b.distance));
    all.truncate(k);
    all.sort_by(|a, b| a.distance.total_cmp(&b.distance));
    all
}

/// Distance from `p` to triangle `abc` (Ericson, Real-Time Collision
/// Detection, §5.1.5: the closest point by Voronoi regions).
fn triangle_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return p.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return p.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return p.distance(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        return p.distance(a).min(p.distance(b)).min(p.distance(c));
    }
    p.distance(a + ab * (vb / denom) + ac * (vc / denom))
}

/// How far `p` is from the surface of `primitives` (or of glTF primitive
/// `only`; infinite without triangles).
pub fn surface_distance(primitives: &[PrimitiveGeometry], only: Option<usize>, p: DVec3) -> f64 {
    let mut best = f64::INFINITY;
    for prim in selected(primitives, only) {
        for t in prim.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| point(prim.positions[i as usize]));
            best = best.min(triangle_distance(p, a, b, c));
        }
    }
    best
}

/// Who reads a [`too_far`] message, and so what it advises beyond the
/// Y-up reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FarReader {
    /// A constraint file's author: `uvpin inspect --near` lists the nearest vertices.
    ConstraintFile,
    /// `uvpin inspect --near` itself, which has just listed them.
    Inspect,
}

/// Why a `near:` point is too far from the mesh (or glTF primitive
/// `only`), if it is: how far, and the Y-up reading of the point when that
/// one lies on the mesh.
pub fn too_far(primitives: &[PrimitiveGeometry], only: Option<usize>, p: DVec3, reader: FarReader) -> Option<String> {
    let diagonal = bounds(primitives)?.diagonal();
    let limit = NEAR_TOLERANCE * diagonal;
    // The surface is no farther than the nearest vertex: most points need
    // no scan of the triangles.
    if nearest_vertices(primitives, only, p, 1)
        .first()
        .is_some_and(|v| v.distance <= limit)
    {
        return None;
    }
    let distance = surface_distance(primitives, only, p);
    if distance <= limit {
        return None;
    }
    // `+ 0.0` writes -0 as 0.
    let swapped = DVec3::new(p.x, p.z, -p.y + 0.0);
    let hint = if surface_distance(primitives, only, swapped) <= limit {
        format!(
            "; glTF is Y-up: a point copied from a Z-up tool such as Blender is ({}, {}, {}) here, which lies on the mesh",
            swapped.x, swapped.y, swapped.z
        )
    } else {
        let next = match reader {
            FarReader::ConstraintFile => "`uvpin inspect ASSET --near X,Y,Z` lists the nearest vertices",
            FarReader::Inspect => "the vertices listed above are the nearest, by `vertex:` id",
        };
        format!("; glTF is Y-up (Blender shows it Z-up: (x, y, z) there is (x, z, -y) here); {next}")
    };
    Some(format!(
        "the point ({}, {}, {}) is {distance:.4} from the mesh, more than {} of its bounding box's diagonal ({diagonal:.4}){hint}",
        p.x,
        p.y,
        p.z,
        format_args!("{:.0} %", NEAR_TOLERANCE * 100.0)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Vec<PrimitiveGeometry> {
        vec![PrimitiveGeometry {
            index: 0,
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [9.0, 9.0, 9.0],
            ],
            indices: vec![0, 1, 2, 0, 2, 3],
            uvs: None,
        }]
    }

    #[test]
    fn bounds_and_nearest_skip_unused_vertices() {
        let q = quad();
        let b = bounds(&q).unwrap();
        assert_eq!((b.min, b.max), (DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0)));
        let n = nearest_vertices(&q, None, DVec3::new(0.9, 0.8, 0.1), 2);
        assert_eq!(n.iter().map(|n| n.vertex).collect::<Vec<_>>(), vec![2, 1]);
        assert!(
            nearest_vertices(&q, None, DVec3::new(9.0, 9.0, 9.0), 10)
                .iter()
                .all(|n| n.vertex != 4)
        );
    }

    #[test]
    fn surface_distance_is_to_the_triangles() {
        let q = quad();
        assert!((surface_distance(&q, None, DVec3::new(0.5, 0.5, 0.25)) - 0.25).abs() < 1e-12);
        assert!((surface_distance(&q, None, DVec3::new(2.0, 0.5, 0.0)) - 1.0).abs() < 1e-12);
        assert!((surface_distance(&q, None, DVec3::new(-1.0, -1.0, 0.0)) - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn far_points_are_named_with_the_y_up_reading() {
        let q = quad();
        assert_eq!(
            too_far(&q, None, DVec3::new(0.5, 0.5, 0.05), FarReader::ConstraintFile),
            None
        );
        // (0.5, 0.0, 0.5) in Z-up is (0.5, 0.5, 0.0) in Y-up: on the quad.
        let m = too_far(&q, None, DVec3::new(0.5, 0.0, 0.5), FarReader::ConstraintFile).unwrap();
        assert!(
            m.contains("is 0.5000 from the mesh") && m.contains("(0.5, 0.5, 0)"),
            "{m}"
        );
        let m = too_far(&q, None, DVec3::new(40.0, 0.0, 0.0), FarReader::ConstraintFile).unwrap();
        assert!(m.contains("uvpin inspect"), "{m}");
        // `uvpin inspect` itself points at its own list instead.
        let m = too_far(&q, None, DVec3::new(40.0, 0.0, 0.0), FarReader::Inspect).unwrap();
        assert!(!m.contains("uvpin inspect") && m.contains("listed above"), "{m}");
    }
}
