//! Prolongation: the collapses of a [`Hierarchy`] undone in reverse, each
//! vertex put back where its ring's layout places it. A vertex goes where
//! its star, flattened from the surface (angles scaled to a full turn, 3D
//! lengths), puts it among its neighbours: mean value coordinates for a
//! vertex inside the disk (Floater), the similarity of its two loop
//! neighbours for one on the outer loop. Where that would turn a triangle
//! of its star over, it goes to the centre of its ring's kernel (the points
//! from which every triangle of the star is positive), else right beside
//! the vertex it was collapsed into (the split undone as a thin sliver,
//! which the sweeps then open); a vertex with no place even there ends
//! the prolongation. So every layout on the way, and the last,
//! has every triangle positive.

use super::coarsen::Hierarchy;
use super::outline::{Outline, inside};
use crate::guard::orientation;
use glam::{DVec2, DVec3};
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum ProlongError {
    /// No point keeps every triangle around the vertex positive.
    #[error("no place for vertex {vertex} keeps its triangles positive")]
    NoKernel { vertex: u32, ring: Vec<u32> },
}

/// Where a vertex of the outer loop goes back.
#[derive(Debug, Clone)]
pub enum LoopRule {
    /// A free chart's: where its star puts it (or nearer its neighbours),
    /// strictly inside `region`, its edges clear of the rest of `outline`
    /// (the level's outer loop, kept up to date).
    Free { outline: Outline, region: (DVec2, DVec2) },
    /// On the square: on the segment between its loop neighbours (a side
    /// of the square), as far along as its 3D distances say.
    OnSide,
}

/// How the vertices were put back.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ProlongStats {
    pub splits: usize,
    /// Vertices the star's own shape could not place: put in their kernel.
    pub in_kernel: usize,
}

/// Undoes the collapses of `hierarchy` on `layout`, last first, until
/// `until` vertices are present (entries of vertices present are read; the
/// others written): [`usize::MAX`] goes back to the fine level. A vertex
/// of the outer loop goes where `rule` says.
///
/// # Errors
/// [`ProlongError::NoKernel`]: a vertex with no place; the hierarchy is
/// left at the level before it (the ring may take a shape that has one
/// after a sweep).
pub fn prolong(
    hierarchy: &mut Hierarchy,
    positions: &[DVec3],
    layout: &mut [DVec2],
    until: usize,
    rule: &mut LoopRule,
) -> Result<ProlongStats, ProlongError> {
    let mut stats = ProlongStats::default();
    let mut ring = Vec::new();
    while hierarchy.n_coarse() < until
        && let Some((c, star)) = hierarchy.split_last()
    {
        let closed = ring_of(
            c.u,
            star.iter().map(|&s| hierarchy.triangles[(s / 4) as usize]),
            &mut ring,
        );
        let (first, last) = (ring[0], ring[ring.len() - 1]);
        let fits = |p: DVec2| {
            keeps_positive(p, &ring, closed, layout)
                && match &*rule {
                    _ if closed => true,
                    LoopRule::Free { outline, region } => {
                        inside(p, *region) && !outline.crossed_between((last, first), p, layout)
                    }
                    LoopRule::OnSide => true,
                }
        };
        let on_side = !closed && matches!(rule, LoopRule::OnSide);
        let p = if on_side {
            on_segment(c.u, (first, last), positions, layout)
        } else {
            place(c.u, &ring, closed, positions, layout)
        };
        let p = match p.filter(|&p| fits(p)) {
            Some(p) => p,
            None => {
                stats.in_kernel += 1;
                let region = match &*rule {
                    LoopRule::Free { region, .. } => *region,
                    LoopRule::OnSide => (DVec2::splat(f64::NEG_INFINITY), DVec2::splat(f64::INFINITY)),
                };
                let moved = (!on_side)
                    .then(|| {
                        let drawn_in = p.and_then(|p| towards_chord(p, &ring, layout).find(|&q| fits(q)));
                        drawn_in.or_else(|| kernel_centre(&ring, closed, layout, region).filter(|&q| fits(q)))
                    })
                    .flatten()
                    .or_else(|| {
                        let along = on_side.then(|| layout[(if c.v == first { last } else { first }) as usize]);
                        beside_survivor(c.v, (&ring, closed), along, layout).find(|&q| fits(q))
                    });
                let Some(p) = moved else {
                    hierarchy.collapse_again(c, star);
                    return Err(ProlongError::NoKernel {
                        vertex: c.u,
                        ring: ring.clone(),
                    });
                };
                p
            }
        };
        layout[c.u as usize] = p;
        if let (false, LoopRule::Free { outline, .. }) = (closed, &mut *rule) {
            outline.split((last, first), c.u);
        }
        stats.splits += 1;
    }
    Ok(stats)
}

/// Points ever nearer `v`, the vertex `u` was collapsed into, in the wedge
/// the split needs, then in every direction (or only towards `along`, on a
/// side of the square): the split of `v` into `u` and `v` with `u` close
/// enough to `v` keeps every triangle positive, since `u`'s other
/// triangles were `v`'s and the one or two new ones are thin, not turned
/// over, when `u` sits in the wedge between their far corners.
fn beside_survivor(
    v: u32,
    (ring, closed): (&[u32], bool),
    along: Option<DVec2>,
    layout: &[DVec2],
) -> impl Iterator<Item = DVec2> {
    const DIRECTIONS: usize = 32;
    const HALVINGS: i32 = 40;
    let at = layout[v as usize];
    let reach = ring
        .iter()
        .filter(|&&b| b != v)
        .map(|&b| layout[b as usize].distance(at))
        .fold(f64::INFINITY, f64::min)
        * 0.5;
    let directions: Vec<DVec2> = match along {
        Some(q) => vec![(q - at).normalize_or_zero()],
        None => wedge(v, (ring, closed), layout)
            .into_iter()
            .chain((0..DIRECTIONS).map(|k| DVec2::from_angle(std::f64::consts::TAU * k as f64 / DIRECTIONS as f64)))
            .collect(),
    };
    (0..HALVINGS).flat_map(move |h| {
        let step = reach * 0.5f64.powi(h);
        directions.clone().into_iter().map(move |d| at + step * d)
    })
}

/// The direction halving the wedge at `v` between the far corners of the
/// triangles a split of `v` brings back: the ring's vertex after `v` lies
/// clockwise of it, the one before counter-clockwise.
fn wedge(v: u32, (ring, closed): (&[u32], bool), layout: &[DVec2]) -> Option<DVec2> {
    let i = ring.iter().position(|&b| b == v)?;
    let k = ring.len();
    let at = layout[v as usize];
    let towards = |j: usize| (layout[ring[j] as usize] - at).try_normalize();
    let next = (closed || i + 1 < k).then(|| towards((i + 1) % k)).flatten();
    let prev = (closed || i > 0).then(|| towards((i + k - 1) % k)).flatten();
    match (next, prev) {
        (Some(n), Some(p)) => {
            let mut angle = n.angle_to(p);
            if angle <= 0.0 {
                angle += std::f64::consts::TAU;
            }
            Some(DVec2::from_angle(0.5 * angle).rotate(n))
        }
        (Some(n), None) => Some(n.perp()),
        (None, Some(p)) => Some(-p.perp()),
        (None, None) => None,
    }
}

/// A loop vertex between its loop neighbours `a` and `b`, as far from `a`
/// as its 3D distances to the two say.
fn on_segment(u: u32, (a, b): (u32, u32), positions: &[DVec3], layout: &[DVec2]) -> Option<DVec2> {
    let (da, db) = (
        positions[u as usize].distance(positions[a as usize]),
        positions[u as usize].distance(positions[b as usize]),
    );
    let t = da / (da + db);
    let (pa, pb) = (layout[a as usize], layout[b as usize]);
    (t > 0.0 && t < 1.0).then(|| pa + (pb - pa) * t)
}

/// Points from `p` toward the middle of an open ring's chord (its two loop
/// neighbours), for a loop vertex its star's shape put too far out.
fn towards_chord(p: DVec2, ring: &[u32], layout: &[DVec2]) -> impl Iterator<Item = DVec2> {
    let m = 0.5 * (layout[ring[0] as usize] + layout[ring[ring.len() - 1] as usize]);
    [0.5, 0.25, 0.1, 0.02].into_iter().map(move |t| m + (p - m) * t)
}

/// `u`'s neighbours in counter-clockwise order, from its star's triangles;
/// `true` when they close around it (it is inside the disk), else the
/// chain runs from one loop neighbour to the other.
fn ring_of(u: u32, star: impl Iterator<Item = [u32; 3]>, ring: &mut Vec<u32>) -> bool {
    let mut next = Vec::new();
    for t in star {
        let k = t.iter().position(|&w| w == u).expect("u in its star");
        next.push((t[(k + 1) % 3], t[(k + 2) % 3]));
    }
    ring.clear();
    let starts_chain = |a: u32| next.iter().all(|&(_, b)| b != a);
    let first = next
        .iter()
        .map(|&(a, _)| a)
        .find(|&a| starts_chain(a))
        .unwrap_or(next[0].0);
    let mut at = first;
    for _ in 0..=next.len() {
        ring.push(at);
        match next.iter().find(|&&(a, _)| a == at) {
            Some(&(_, b)) if b != first => at = b,
            Some(_) => return true,
            None => return false,
        }
    }
    true
}

/// Where `u`'s flattened star puts it among its ring's current places.
fn place(u: u32, ring: &[u32], closed: bool, positions: &[DVec3], layout: &[DVec2]) -> Option<DVec2> {
    let centre = positions[u as usize];
    let spokes: Vec<DVec3> = ring.iter().map(|&b| positions[b as usize] - centre).collect();
    let n_angles = if closed { ring.len() } else { ring.len() - 1 };
    let angles: Vec<f64> = (0..n_angles)
        .map(|i| spokes[i].angle_between(spokes[(i + 1) % ring.len()]))
        .collect();
    let total: f64 = angles.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let scale = if closed { std::f64::consts::TAU / total } else { 1.0 };
    let mut flat = Vec::with_capacity(ring.len());
    let mut phi = 0.0;
    for (i, s) in spokes.iter().enumerate() {
        flat.push(DVec2::from_angle(phi) * s.length());
        if i < n_angles {
            phi += angles[i] * scale;
        }
    }
    if closed {
        mean_value_point(&flat, ring, layout)
    } else {
        similarity_point(&flat, ring, layout)
    }
}

/// The point with the origin's mean value coordinates in the flattened
/// ring `flat`, taken on the ring's places.
fn mean_value_point(flat: &[DVec2], ring: &[u32], layout: &[DVec2]) -> Option<DVec2> {
    let k = flat.len();
    let half_tan = |i: usize| {
        let (a, b) = (flat[i], flat[(i + 1) % k]);
        let angle = a.angle_to(b);
        (0.5 * angle).tan()
    };
    let (mut sum, mut total) = (DVec2::ZERO, 0.0);
    for i in 0..k {
        let w = (half_tan((i + k - 1) % k) + half_tan(i)) / flat[i].length();
        sum += w * layout[ring[i] as usize];
        total += w;
    }
    let p = sum / total;
    (total > 0.0 && p.is_finite()).then_some(p)
}

/// The origin moved by the similarity that takes the flattened chain's
/// ends to their places.
fn similarity_point(flat: &[DVec2], ring: &[u32], layout: &[DVec2]) -> Option<DVec2> {
    let (f0, f1) = (flat[0], flat[flat.len() - 1]);
    let (p0, p1) = (layout[ring[0] as usize], layout[ring[ring.len() - 1] as usize]);
    let (df, dp) = (f1 - f0, p1 - p0);
    let len2 = df.length_squared();
    if len2.is_nan() || len2 <= 0.0 {
        return None;
    }
    // The complex ratio dp / df, a rotation and scale.
    let z = DVec2::new(dp.x * df.x + dp.y * df.y, dp.y * df.x - dp.x * df.y) / len2;
    let rotate = |v: DVec2| DVec2::new(z.x * v.x - z.y * v.y, z.x * v.y + z.y * v.x);
    let p = p0 + rotate(-f0);
    p.is_finite().then_some(p)
}

/// Every triangle (p, b_i, b_{i+1}) of the star strictly positive.
fn keeps_positive(p: DVec2, ring: &[u32], closed: bool, layout: &[DVec2]) -> bool {
    let n_edges = if closed { ring.len() } else { ring.len() - 1 };
    (0..n_edges).all(|i| {
        let (a, b) = (layout[ring[i] as usize], layout[ring[(i + 1) % ring.len()] as usize]);
        orientation(p, a, b) > 0.0
    })
}

/// The centroid of the ring's kernel: the part of its bounding box (within
/// `region`) left of every ring edge. `None` when empty.
fn kernel_centre(ring: &[u32], closed: bool, layout: &[DVec2], region: (DVec2, DVec2)) -> Option<DVec2> {
    let points: Vec<DVec2> = ring.iter().map(|&b| layout[b as usize]).collect();
    let (lo, hi) = crate::injective::bounds(&points);
    let (lo, hi) = (lo.max(region.0), hi.min(region.1));
    let mut polygon = vec![lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    let n_edges = if closed { points.len() } else { points.len() - 1 };
    for i in 0..n_edges {
        polygon = clip_left(&polygon, points[i], points[(i + 1) % points.len()]);
        if polygon.len() < 3 {
            return None;
        }
    }
    centroid(&polygon)
}

/// The part of convex `polygon` strictly left of the line a → b
/// (Sutherland–Hodgman).
fn clip_left(polygon: &[DVec2], a: DVec2, b: DVec2) -> Vec<DVec2> {
    let side = |p: DVec2| (b - a).perp_dot(p - a);
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for i in 0..polygon.len() {
        let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
        let (sp, sq) = (side(p), side(q));
        if sp > 0.0 {
            out.push(p);
        }
        if (sp > 0.0) != (sq > 0.0) && sp != sq {
            out.push(p + (q - p) * (sp / (sp - sq)));
        }
    }
    out
}

fn centroid(polygon: &[DVec2]) -> Option<DVec2> {
    let (mut area, mut c) = (0.0, DVec2::ZERO);
    for i in 0..polygon.len() {
        let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
        let cross = p.perp_dot(q);
        area += cross;
        c += (p + q) * cross;
    }
    (area > 0.0).then(|| c / (3.0 * area)).filter(|c| c.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multilevel::coarsen::{Role, coarsen};
    use crate::multilevel::outline::Outline;
    use crate::testing::grid_mesh;

    #[test]
    fn a_grid_coarsened_and_prolonged_from_its_own_layout_is_fold_free() {
        let mesh = grid_mesh(40, 40);
        let topology = crate::mesh::topology::Topology::build(&mesh).unwrap();
        let mut role = vec![Role::Inner; mesh.n_vertices()];
        for &v in &topology.loops[0] {
            role[v as usize] = Role::Loop(0);
        }
        let plan = crate::multilevel::coarsen::Plan {
            role: &role,
            outer: 0,
            virtual_from: mesh.n_vertices(),
            target: 150,
            square: false,
        };
        let mut h = coarsen(&mesh, plan);
        // The coarse level laid out as the grid's plane, warped.
        let mut layout: Vec<DVec2> = mesh
            .positions
            .iter()
            .map(|p| crate::testing::smooth_warp(DVec2::new(p.x, p.y), 0.08))
            .collect();
        let (coarse, fine_of) = h.coarse_mesh(&mesh.positions);
        let coarse_layout: Vec<DVec2> = fine_of.iter().map(|&v| layout[v as usize]).collect();
        assert!(crate::guard::all_positive(&coarse_layout, &coarse.triangles));
        for (v, present) in h.present.iter().enumerate() {
            if !present {
                layout[v] = DVec2::splat(f64::NAN);
            }
        }
        let n_coarse = h.n_coarse();
        assert!(n_coarse < 200, "{n_coarse} left");
        let region = (DVec2::splat(-1.0), DVec2::splat(2.0));
        let mut rule = LoopRule::Free {
            outline: Outline::of(&h),
            region,
        };
        let stats = prolong(&mut h, &mesh.positions, &mut layout, usize::MAX, &mut rule).unwrap();
        assert_eq!(stats.splits, mesh.n_vertices() - n_coarse);
        assert!(h.collapses.is_empty());
        assert_eq!(h.triangles, mesh.triangles);
        assert!(crate::guard::all_positive(&layout, &mesh.triangles));
    }

    #[test]
    fn a_split_vertex_always_has_a_place_beside_its_survivor() {
        // A valid fan around v (angles each under a half turn, any radii,
        // even needle-thin): the ring of a vertex split off v is v and a
        // run of v's neighbours; a place beside v keeps that star positive.
        let mut rng = crate::testing::Rng::new(29);
        for _ in 0..2000 {
            let k = 3 + rng.below(10);
            let mut layout = vec![DVec2::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0))];
            let mut angle = rng.range(0.0, 6.0);
            let mut total = 0.0;
            let mut gaps: Vec<f64> = (0..k).map(|_| rng.range(1e-4, 1.0)).collect();
            let sum: f64 = gaps.iter().sum();
            let turn = std::f64::consts::TAU;
            gaps.iter_mut().for_each(|g| *g *= turn / sum);
            if gaps.iter().any(|&g| g >= 0.99 * std::f64::consts::PI) {
                continue;
            }
            for g in &gaps {
                let r = 10f64.powf(rng.range(-3.0, 0.0));
                layout.push(layout[0] + r * DVec2::from_angle(angle));
                angle += g;
                total += g;
            }
            assert!((total - turn).abs() < 1e-9);
            let fan: Vec<u32> = (1..=k as u32).collect();
            let run = 1 + rng.below(k - 1);
            let start = rng.below(k);
            // Inside the disk, or on its outer loop with v its neighbour
            // there (first or last of the open ring).
            let run: Vec<u32> = (0..=run).map(|i| fan[(start + i) % k]).collect();
            let rings = [
                ([&[0u32][..], &run].concat(), true),
                ([&[0u32][..], &run].concat(), false),
                ([&run[..], &[0u32][..]].concat(), false),
            ];
            for (ring, closed) in rings {
                let p = beside_survivor(0, (&ring, closed), None, &layout)
                    .find(|&q| keeps_positive(q, &ring, closed, &layout));
                assert!(p.is_some(), "no place beside the survivor: ring {ring:?} in {layout:?}");
            }
        }
    }
}
