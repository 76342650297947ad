//! The foldover guard: the exact orientation of every triangle.
//!
//! The paper's condition `det(∇U) > 0` (Eq. 3) is what must hold; its
//! pointwise form (Eq. 5/7), checked at constraint points only, lets folds
//! through between them (docs/algorithm.md). uvpin instead checks the
//! sign of every triangle's area, virtual hole triangles included, with an
//! exact orientation predicate.

use glam::DVec2;

/// Twice the signed area of `(a, b, c)` with an exact sign: positive when the
/// triangle is counter-clockwise in layout coordinates (y up).
#[inline]
pub fn orientation(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    use robust::{Coord, orient2d};
    orient2d(
        Coord { x: a.x, y: a.y },
        Coord { x: b.x, y: b.y },
        Coord { x: c.x, y: c.y },
    )
}

/// `true` when every triangle has strictly positive area (Eq. 3 holds on every triangle).
pub fn all_positive(layout: &[DVec2], triangles: &[[u32; 3]]) -> bool {
    first_non_positive(layout, triangles).is_none()
}

/// A layout point as glTF stores it: `(u, v) = (x, 1 − y)` rounded to f32.
#[inline]
pub fn stored_uv(p: DVec2) -> [f32; 2] {
    [p.x as f32, (1.0 - p.y) as f32]
}

/// A layout point as an OBJ `vt` stores it: `(x, y)` rounded to f32 (v up).
#[inline]
pub fn stored_vt(p: DVec2) -> [f32; 2] {
    crate::io::obj::vt_as_stored(p.x, p.y)
}

/// Whether triangle `t` keeps its orientation as stored by `store` (`sign`:
/// the stored orientation's sign that means kept, −1 for glTF's v down).
#[inline]
fn kept_as_stored(layout: &[DVec2], t: [u32; 3], store: fn(DVec2) -> [f32; 2], sign: f64) -> bool {
    let [a, b, c] = t.map(|v| {
        let [u, w] = store(layout[v as usize]);
        DVec2::new(u as f64, w as f64)
    });
    sign * orientation(a, b, c) > 0.0
}

/// Whether triangle `t` keeps its orientation as every output format
/// stores it (f32 glTF texture coordinates, f32 OBJ `vt`).
#[inline]
fn kept_in_every_format(layout: &[DVec2], t: [u32; 3]) -> bool {
    kept_as_stored(layout, t, stored_uv, -1.0) && kept_as_stored(layout, t, stored_vt, 1.0)
}

/// `true` when every triangle keeps its orientation in double precision and
/// as every output format stores it (f32 glTF texture coordinates, f32 OBJ
/// `vt`): the guard every accepted layout must pass, so anything accepted can
/// be written in any format.
pub fn all_positive_as_stored(layout: &[DVec2], triangles: &[[u32; 3]]) -> bool {
    in_parallel(triangles, |part| {
        all_positive(layout, part) && part.iter().all(|&t| kept_in_every_format(layout, t))
    })
}

/// How many of `triangles` are not positive in double precision or lose
/// their orientation as some output format stores them: what a repair of a
/// layout too thin for f32 has left to do.
pub fn count_unstorable(layout: &[DVec2], triangles: &[[u32; 3]]) -> usize {
    triangles
        .iter()
        .filter(|&&t| {
            let [a, b, c] = t.map(|v| layout[v as usize]);
            !(orientation(a, b, c) > 0.0 && kept_in_every_format(layout, t))
        })
        .count()
}

/// Triangle count above which a check is split over rayon's threads.
const PARALLEL_TRIANGLES: usize = 50_000;

/// `check` on all of `triangles`, split over rayon's pool when there are many.
fn in_parallel(triangles: &[[u32; 3]], check: impl Fn(&[[u32; 3]]) -> bool + Sync) -> bool {
    use rayon::prelude::*;
    if triangles.len() < PARALLEL_TRIANGLES {
        return check(triangles);
    }
    let chunk = triangles.len().div_ceil(rayon::current_num_threads()).max(1);
    triangles.par_chunks(chunk).all(&check)
}

/// The guard every step applies: a candidate layout is acceptable if it keeps
/// every triangle positive as stored (f32) when the current layout already is
/// (`storable_now`), or, while a squeezed start is still being spread, at
/// least strictly positive in double precision. So once storable, always
/// storable.
pub fn acceptable(candidate: &[DVec2], triangles: &[[u32; 3]], storable_now: bool) -> bool {
    if storable_now {
        all_positive_as_stored(candidate, triangles)
    } else {
        in_parallel(triangles, |part| all_positive(candidate, part))
    }
}

/// The first triangle whose area is zero or negative.
pub fn first_non_positive(layout: &[DVec2], triangles: &[[u32; 3]]) -> Option<usize> {
    triangles.iter().position(|t| {
        let [a, b, c] = t.map(|v| layout[v as usize]);
        // Fast filter: clearly positive without the exact predicate.
        let det = (b - a).perp_dot(c - a);
        let bound = 1e-12 * ((b - a).length_squared() + (c - a).length_squared());
        !(det > bound || (det.abs() <= bound && orientation(a, b, c) > 0.0))
    })
}

/// The smallest signed area of any triangle of `layout` (layout units).
pub fn smallest_area(layout: &[DVec2], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| layout[v as usize]);
            0.5 * (b - a).perp_dot(c - a)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Flipped and zero-area triangle counts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct OrientationCounts {
    pub flipped: usize,
    /// Triangles without area, a NaN or infinite corner's among them (no
    /// place in the texture at all).
    pub zero_area: usize,
}

impl OrientationCounts {
    pub fn is_clean(&self) -> bool {
        self.flipped == 0 && self.zero_area == 0
    }
}

/// Counts triangles with negative and zero area in layout coordinates (y
/// up); a NaN orientation counts as zero area.
pub fn count_orientations(layout: &[DVec2], triangles: &[[u32; 3]]) -> OrientationCounts {
    let mut counts = OrientationCounts::default();
    for t in triangles {
        let [a, b, c] = t.map(|v| layout[v as usize]);
        let o = orientation(a, b, c);
        if o < 0.0 {
            counts.flipped += 1;
        } else if o == 0.0 || o.is_nan() {
            counts.zero_area += 1;
        }
    }
    counts
}

/// Which way a stored texture coordinate's second axis points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VAxis {
    /// glTF: v grows downward, so a kept triangle has negative stored area.
    Down,
    /// OBJ: v grows upward.
    Up,
}

/// Counts on glTF texture coordinates exactly as stored (f32, v down): a
/// triangle keeps its orientation when `(u1−u0)(v2−v0) − (u2−u0)(v1−v0) < 0`.
pub fn count_uv_orientations(uvs: &[[f32; 2]], triangles: &[[u32; 3]]) -> OrientationCounts {
    count_stored_orientations(uvs, triangles, VAxis::Down)
}

/// Counts on texture coordinates exactly as stored (f32), with `axis` the
/// direction of their second coordinate.
pub fn count_stored_orientations(uvs: &[[f32; 2]], triangles: &[[u32; 3]], axis: VAxis) -> OrientationCounts {
    let sign = match axis {
        VAxis::Down => -1.0,
        VAxis::Up => 1.0,
    };
    let mut counts = OrientationCounts::default();
    for t in triangles {
        let [a, b, c] = t.map(|v| {
            let p = uvs[v as usize];
            DVec2::new(p[0] as f64, p[1] as f64)
        });
        let o = sign * orientation(a, b, c);
        if o < 0.0 {
            counts.flipped += 1;
        } else if o == 0.0 || o.is_nan() {
            counts.zero_area += 1;
        }
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detects_flips_and_slivers_exactly() {
        let layout = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(2.0, 0.0),
        ];
        assert!(all_positive(&layout, &[[0, 1, 2]]));
        assert_eq!(first_non_positive(&layout, &[[0, 1, 2], [0, 2, 1]]), Some(1));
        // Exactly collinear: zero, not positive.
        assert_eq!(first_non_positive(&layout, &[[0, 1, 3]]), Some(0));
        let c = count_orientations(&layout, &[[0, 1, 2], [0, 2, 1], [0, 1, 3]]);
        assert_eq!(
            c,
            OrientationCounts {
                flipped: 1,
                zero_area: 1
            }
        );
        // A tiny but positive triangle passes.
        let tiny = vec![
            DVec2::new(0.5, 0.5),
            DVec2::new(0.5 + 1e-15, 0.5),
            DVec2::new(0.5, 0.5 + 1e-15),
        ];
        assert!(all_positive(&tiny, &[[0, 1, 2]]));
        // A NaN corner is no place at all: counted, never passed as fine.
        let nan = vec![DVec2::ZERO, DVec2::X, DVec2::NAN];
        assert_eq!(count_orientations(&nan, &[[0, 1, 2]]).zero_area, 1);
        let stored = [[0.0f32, 0.0], [1.0, 0.0], [f32::NAN, 1.0]];
        assert_eq!(count_stored_orientations(&stored, &[[0, 1, 2]], VAxis::Up).zero_area, 1);
    }

    #[test]
    fn a_triangle_too_small_for_f32_is_not_storable() {
        let tiny = vec![
            DVec2::new(0.5, 0.5),
            DVec2::new(0.5 + 1e-9, 0.5),
            DVec2::new(0.5, 0.5 + 1e-9),
        ];
        assert!(all_positive(&tiny, &[[0, 1, 2]]));
        assert!(!all_positive_as_stored(&tiny, &[[0, 1, 2]]));
        let fine = vec![
            DVec2::new(0.5, 0.5),
            DVec2::new(0.5 + 1e-5, 0.5),
            DVec2::new(0.5, 0.5 + 1e-5),
        ];
        assert!(all_positive_as_stored(&fine, &[[0, 1, 2]]));
    }

    #[test]
    fn uv_orientation_is_mirrored() {
        // (x, y) CCW ⇒ (u, v) = (x, 1 − y) has negative signed area.
        let uvs = [[0.0f32, 1.0], [1.0, 1.0], [0.0, 0.0]];
        assert!(count_uv_orientations(&uvs, &[[0, 1, 2]]).is_clean());
        assert_eq!(count_uv_orientations(&uvs, &[[0, 2, 1]]).flipped, 1);
    }
}
