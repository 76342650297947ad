//! Distortion metrics: Sander et al. 2001 L2 and L∞ stretch (the paper's §V.B
//! table), normalised so an isometry scores 1.

use glam::{DVec2, DVec3};

/// Sander stretch of a layout.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Stretch {
    /// Area-weighted root-mean-square stretch (1 = isometry).
    pub l2: f64,
    /// Worst singular value over triangles (1 = isometry).
    pub linf: f64,
}

/// Sander L2/L∞ stretch of `layout` against the 3D `positions` over `triangles`.
///
/// The layout is first scaled so its total area equals the total 3D area. Per
/// triangle with layout corners (s, t), signed area A and 3D corners q:
/// `S_s = (q1(t2−t3) + q2(t3−t1) + q3(t1−t2)) / 2A`,
/// `S_t = (q1(s3−s2) + q2(s1−s3) + q3(s2−s1)) / 2A`, `a = S_s·S_s`, `b = S_s·S_t`,
/// `c = S_t·S_t`, `L2(T) = sqrt((a+c)/2)`, `L∞(T) = sqrt(((a+c) + sqrt((a−c)² + 4b²))/2)`.
/// Infinite when a triangle has zero or negative area. Triangles with zero 3D
/// area are skipped.
pub fn sander_stretch(positions: &[DVec3], layout: &[DVec2], triangles: &[[u32; 3]]) -> Stretch {
    let (area_3d, area_2d) = total_areas(positions, layout, triangles);
    if area_3d <= 0.0 {
        return Stretch {
            l2: f64::NAN,
            linf: f64::NAN,
        };
    }
    if area_2d <= 0.0 {
        return Stretch {
            l2: f64::INFINITY,
            linf: f64::INFINITY,
        };
    }
    // Scaling the layout by k divides S_s, S_t by k.
    let k = (area_3d / area_2d).sqrt();
    let mut sum = 0.0;
    let mut linf: f64 = 0.0;
    for t in triangles {
        let [q1, q2, q3] = t.map(|v| positions[v as usize]);
        let a3 = 0.5 * (q2 - q1).cross(q3 - q1).length();
        if a3 <= 0.0 {
            continue;
        }
        let Some((a, b, c)) = metric_terms([q1, q2, q3], t.map(|v| layout[v as usize]), k) else {
            return Stretch {
                l2: f64::INFINITY,
                linf: f64::INFINITY,
            };
        };
        sum += (a + c) / 2.0 * a3;
        linf = linf.max((((a + c) + ((a - c).powi(2) + 4.0 * b * b).sqrt()) / 2.0).sqrt());
    }
    Stretch {
        l2: (sum / area_3d).sqrt(),
        linf,
    }
}

/// Texture length per mesh length of `layout`: the square root of its
/// area over the 3D area (the texel density of a chart, up to the texture's size).
pub fn texture_per_mesh_length(positions: &[DVec3], layout: &[DVec2], triangles: &[[u32; 3]]) -> f64 {
    let (area_3d, area_2d) = total_areas(positions, layout, triangles);
    (area_2d / area_3d).sqrt()
}

/// Total 3D area and signed layout area of `triangles`.
fn total_areas(positions: &[DVec3], layout: &[DVec2], triangles: &[[u32; 3]]) -> (f64, f64) {
    let (mut area_3d, mut area_2d) = (0.0, 0.0);
    for t in triangles {
        let [q1, q2, q3] = t.map(|v| positions[v as usize]);
        let [p1, p2, p3] = t.map(|v| layout[v as usize]);
        area_3d += 0.5 * (q2 - q1).cross(q3 - q1).length();
        area_2d += 0.5 * (p2 - p1).perp_dot(p3 - p1);
    }
    (area_3d, area_2d)
}

/// The metric terms `(a, b, c)` of one triangle (3D corners `q`, layout
/// corners `p`, layout scale `k`); `None` when its layout area is not positive.
fn metric_terms(q: [DVec3; 3], p: [DVec2; 3], k: f64) -> Option<(f64, f64, f64)> {
    let [q1, q2, q3] = q;
    let (s1, t1, s2, t2, s3, t3) = (p[0].x, p[0].y, p[1].x, p[1].y, p[2].x, p[2].y);
    let area = 0.5 * ((s2 - s1) * (t3 - t1) - (s3 - s1) * (t2 - t1));
    if area <= 0.0 {
        return None;
    }
    let ss = (q1 * (t2 - t3) + q2 * (t3 - t1) + q3 * (t1 - t2)) / (2.0 * area * k);
    let st = (q1 * (s3 - s2) + q2 * (s1 - s3) + q3 * (s2 - s1)) / (2.0 * area * k);
    Some((ss.dot(ss), ss.dot(st), st.dot(st)))
}

/// Sander L2 stretch of each triangle (the layout scaled to the 3D area as
/// in [`sander_stretch`]): 1 = isometric; infinite for a flipped or
/// zero-area layout triangle; NaN for a zero-area 3D triangle.
pub fn triangle_stretch(positions: &[DVec3], layout: &[DVec2], triangles: &[[u32; 3]]) -> Vec<f64> {
    let (area_3d, area_2d) = total_areas(positions, layout, triangles);
    let k = if area_2d > 0.0 { (area_3d / area_2d).sqrt() } else { 1.0 };
    triangles
        .iter()
        .map(|t| {
            let q = t.map(|v| positions[v as usize]);
            if (q[1] - q[0]).cross(q[2] - q[0]).length() <= 0.0 {
                return f64::NAN;
            }
            metric_terms(q, t.map(|v| layout[v as usize]), k).map_or(f64::INFINITY, |(a, _, c)| ((a + c) / 2.0).sqrt())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::grid_mesh;

    #[test]
    fn isometry_and_uniform_scale_score_one() {
        let m = grid_mesh(5, 5);
        let layout: Vec<DVec2> = m
            .positions
            .iter()
            .map(|p| p.truncate() * 0.37 + DVec2::new(0.1, 0.2))
            .collect();
        let s = sander_stretch(&m.positions, &layout, &m.triangles);
        assert!((s.l2 - 1.0).abs() < 1e-12 && (s.linf - 1.0).abs() < 1e-12, "{s:?}");
    }

    #[test]
    fn anisotropic_stretch_is_measured() {
        let m = grid_mesh(4, 4);
        // Squash y by 2 and widen x by 2: areas match, singular values 2 and 1/2 of the inverse map.
        let layout: Vec<DVec2> = m.positions.iter().map(|p| DVec2::new(p.x * 2.0, p.y * 0.5)).collect();
        let s = sander_stretch(&m.positions, &layout, &m.triangles);
        assert!((s.linf - 2.0).abs() < 1e-12, "{s:?}");
        assert!((s.l2 - ((4.0 + 0.25) / 2.0f64).sqrt()).abs() < 1e-12, "{s:?}");
        let per = triangle_stretch(&m.positions, &layout, &m.triangles);
        assert!(per.iter().all(|&x| (x - s.l2).abs() < 1e-12), "{per:?}");
        let mut flipped = layout.clone();
        flipped[5].x += 10.0;
        assert!(sander_stretch(&m.positions, &flipped, &m.triangles).l2.is_infinite());
    }
}
