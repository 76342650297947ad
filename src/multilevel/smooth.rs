//! Local sweeps of the symmetric Dirichlet energy: each movable vertex in
//! turn takes the projected Newton step of its own star's energy (a 2 × 2
//! system), cut short where a triangle of the star would reach zero area
//! and halved until the star's energy falls. Every triangle stays positive,
//! so the layout stays fold-free; the held vertices (landmarks, the outer
//! loop) do not move. After a prolongation the fine vertices sit where
//! their coarse triangles put them: these sweeps give them their own shape
//! at linear cost per sweep. Vertices of one colour share no triangle, so
//! each colour moves in parallel; then the vertices around the worst
//! triangles sweep on alone until they settle.

use super::outline::{Outline, inside};
use crate::complete::energy::{RestTriangle, corner_terms, jacobian, psi};
use crate::guard::orientation;
use glam::DVec2;
use rayon::prelude::*;

/// What the sweeps did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SmoothStats {
    pub sweeps: u32,
    pub energy_before: f64,
    pub energy_after: f64,
}

/// A sweep that lowers the energy by less than this share ends the sweeps.
const GAIN: f64 = 1e-3;

/// A triangle whose energy per unit area (ψ, 4 for an isometry) is above
/// this is one of the worst: its vertices and their neighbours sweep on.
const WORST_PSI: f64 = 40.0;

/// A vertex whose step lowers its star's energy by more than this share
/// wakes its neighbours for the next sweep; one that stays quieter, with
/// quiet neighbours, is not swept again.
const LIVELY: f64 = 1e-5;

/// Sweeps of the vertices around the worst triangles, at most.
const WORST_SWEEPS: u32 = 40;

/// Vertex → its triangles, as offsets into one list.
#[derive(Debug, Clone)]
pub struct Stars {
    offsets: Vec<u32>,
    triangles: Vec<u32>,
}

impl Stars {
    pub fn new(n_vertices: usize, triangles: &[[u32; 3]]) -> Self {
        let mut count = vec![0u32; n_vertices + 1];
        for t in triangles {
            t.iter().for_each(|&v| count[v as usize + 1] += 1);
        }
        for i in 0..n_vertices {
            count[i + 1] += count[i];
        }
        let mut next = count.clone();
        let mut list = vec![0u32; count[n_vertices] as usize];
        for (k, t) in triangles.iter().enumerate() {
            for &v in t {
                list[next[v as usize] as usize] = k as u32;
                next[v as usize] += 1;
            }
        }
        Stars {
            offsets: count,
            triangles: list,
        }
    }

    fn of(&self, v: usize) -> &[u32] {
        &self.triangles[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }
}

/// The shapes a sweep works on.
struct Sweep<'a> {
    triangles: &'a [[u32; 3]],
    rest: &'a [RestTriangle],
    stars: Stars,
}

/// The outer loop a sweep may move, and the box it stays strictly inside.
#[derive(Debug, Clone, Copy)]
pub struct LoopRoom<'a> {
    pub outline: &'a Outline,
    pub region: (DVec2, DVec2),
}

/// Up to `max_sweeps` sweeps over the vertices `movable` marks, then the
/// worst triangles' surroundings on their own. `layout` must have every
/// triangle positive; it still has after. Vertices on the outer loop move
/// only with `room`, one at a time, their edges kept off the rest of the
/// loop and inside its box.
pub fn smooth(
    layout: &mut [DVec2],
    triangles: &[[u32; 3]],
    rest: &[RestTriangle],
    movable: &[bool],
    max_sweeps: u32,
    room: Option<LoopRoom>,
) -> SmoothStats {
    let sweep = Sweep {
        triangles,
        rest,
        stars: Stars::new(layout.len(), triangles),
    };
    let on_loop = |v: u32| room.is_some_and(|r| r.outline.contains(v));
    let inner: Vec<bool> = (0..movable.len()).map(|v| movable[v] && !on_loop(v as u32)).collect();
    let loop_vertices: Vec<u32> = (0..movable.len() as u32)
        .filter(|&v| movable[v as usize] && on_loop(v))
        .collect();
    let classes = sweep.colour_classes(&inner);
    let mut stats = SmoothStats {
        energy_before: sweep.energy(layout),
        ..SmoothStats::default()
    };
    let mut last = stats.energy_before;
    // Vertices whose star changed enough since they last moved; the rest
    // would barely move (a step depends only on the star's corners).
    let mut next = vec![true; layout.len()];
    while stats.sweeps < max_sweeps {
        let mut now_active = std::mem::replace(&mut next, vec![false; layout.len()]);
        for class in &classes {
            let moved: Vec<(u32, DVec2, bool)> = class
                .par_iter()
                .filter(|&&v| now_active[v as usize])
                .filter_map(|&v| {
                    let (p, gain, e0) = sweep.relaxed_gain(v as usize, layout)?;
                    Some((v, p, gain > LIVELY * e0))
                })
                .collect();
            for (v, p, lively) in moved {
                layout[v as usize] = p;
                if lively {
                    sweep.mark_star(v, &mut now_active);
                    sweep.mark_star(v, &mut next);
                }
            }
        }
        if let Some(room) = room {
            for &v in &loop_vertices {
                if let Some(p) = sweep.relaxed_on_loop(v, layout, room) {
                    layout[v as usize] = p;
                }
            }
        }
        stats.sweeps += 1;
        let now = sweep.energy(layout);
        let gained = last - now;
        last = now;
        if gained.is_nan() || gained <= GAIN * now {
            break;
        }
    }
    let worst = sweep.around_worst(layout, movable);
    for _ in 0..WORST_SWEEPS {
        let mut any = false;
        for &v in &worst {
            if let Some(p) = sweep.relaxed_in(v, layout, room) {
                any |= p.distance(layout[v as usize]) > 1e-6 * p.length().max(1.0);
                layout[v as usize] = p;
            }
        }
        if !any {
            break;
        }
    }
    stats.energy_after = sweep.energy(layout);
    stats
}

/// Up to `max_sweeps` sweeps, one vertex at a time, of the movable vertices
/// within `rings` edges of `seeds`: a ring with no place for its vertex
/// reshaped where it is, at a cost that does not grow with the level.
pub fn smooth_near(
    layout: &mut [DVec2],
    (triangles, rest): (&[[u32; 3]], &[RestTriangle]),
    movable: &[bool],
    (seeds, rings): (&[u32], usize),
    max_sweeps: u32,
    room: Option<LoopRoom>,
) {
    let sweep = Sweep {
        triangles,
        rest,
        stars: Stars::new(layout.len(), triangles),
    };
    let mut near: Vec<u32> = seeds.to_vec();
    let mut seen: std::collections::HashSet<u32> = near.iter().copied().collect();
    let mut frontier = near.clone();
    for _ in 0..rings {
        let mut next = Vec::new();
        for &v in &frontier {
            for &t in sweep.stars.of(v as usize) {
                for w in triangles[t as usize] {
                    if seen.insert(w) {
                        next.push(w);
                    }
                }
            }
        }
        near.extend(&next);
        frontier = next;
    }
    near.retain(|&v| movable[v as usize]);
    for _ in 0..max_sweeps {
        for &v in &near {
            if let Some(p) = sweep.relaxed_in(v, layout, room) {
                layout[v as usize] = p;
            }
        }
    }
}

impl Sweep<'_> {
    fn energy(&self, layout: &[DVec2]) -> f64 {
        self.triangles
            .par_iter()
            .zip(self.rest)
            .map(|(t, r)| value(r, t.map(|v| layout[v as usize])))
            .sum()
    }

    /// The movable vertices in classes that share no triangle (greedy
    /// colouring in vertex order).
    fn colour_classes(&self, movable: &[bool]) -> Vec<Vec<u32>> {
        let mut colour = vec![u8::MAX; movable.len()];
        let mut classes: Vec<Vec<u32>> = Vec::new();
        for v in (0..movable.len()).filter(|&v| movable[v]) {
            let mut used = 0u64;
            for &t in self.stars.of(v) {
                for w in self.triangles[t as usize] {
                    let c = colour[w as usize];
                    if c < 64 {
                        used |= 1 << c;
                    }
                }
            }
            let c = (!used).trailing_zeros() as usize;
            if c >= 64 {
                continue;
            }
            colour[v] = c as u8;
            if classes.len() <= c {
                classes.resize(c + 1, Vec::new());
            }
            classes[c].push(v as u32);
        }
        classes
    }

    /// The movable vertices of the triangles above [`WORST_PSI`], and
    /// their movable neighbours.
    fn around_worst(&self, layout: &[DVec2], movable: &[bool]) -> Vec<u32> {
        let mut mark = vec![false; layout.len()];
        for (t, r) in self.triangles.iter().zip(self.rest) {
            if psi(jacobian(r, t.map(|v| layout[v as usize]))) > WORST_PSI {
                for &v in t {
                    for &s in self.stars.of(v as usize) {
                        self.triangles[s as usize].iter().for_each(|&w| mark[w as usize] = true);
                    }
                }
            }
        }
        (0..layout.len() as u32)
            .filter(|&v| mark[v as usize] && movable[v as usize])
            .collect()
    }

    /// Marks `v` and the other corners of its star.
    fn mark_star(&self, v: u32, mark: &mut [bool]) {
        for &t in self.stars.of(v as usize) {
            self.triangles[t as usize].iter().for_each(|&w| mark[w as usize] = true);
        }
    }

    /// Where one vertex's projected Newton step on its star's energy takes
    /// it; `None` if it stays.
    fn relaxed(&self, v: usize, layout: &[DVec2]) -> Option<DVec2> {
        self.relaxed_gain(v, layout).map(|(q, _, _)| q)
    }

    /// [`Self::relaxed`], with how much the star's energy fell and what it
    /// was.
    fn relaxed_gain(&self, v: usize, layout: &[DVec2]) -> Option<(DVec2, f64, f64)> {
        let star = self.stars.of(v);
        let p = layout[v];
        let (mut e0, mut g, mut h) = (0.0, DVec2::ZERO, [0.0; 3]);
        for &t in star {
            let tri = self.triangles[t as usize];
            let k = tri.iter().position(|&w| w as usize == v)?;
            let (e, grad, hess) = corner_terms(&self.rest[t as usize], tri.map(|w| layout[w as usize]), k)?;
            e0 += e;
            g += grad;
            h = [h[0] + hess[0], h[1] + hess[1], h[2] + hess[2]];
        }
        let d = newton_direction(g, h)?;
        let mut alpha = (0.9 * self.safe_step(v, p, d, layout)).min(1.0);
        for _ in 0..10 {
            let q = p + d * alpha;
            let e = self.star_energy(v, q, layout);
            if e < e0 && self.keeps_positive(v, q, layout) {
                return Some((q, e0 - e, e0));
            }
            alpha *= 0.5;
        }
        None
    }

    /// Where `v` goes: [`Self::relaxed`], or on the outer loop
    /// [`Self::relaxed_on_loop`].
    fn relaxed_in(&self, v: u32, layout: &[DVec2], room: Option<LoopRoom>) -> Option<DVec2> {
        match room {
            Some(room) if room.outline.contains(v) => self.relaxed_on_loop(v, layout, room),
            _ => self.relaxed(v as usize, layout),
        }
    }

    /// [`Self::relaxed`] for a vertex of the outer loop, cut back while its
    /// edges would meet the rest of the loop or leave the box.
    fn relaxed_on_loop(&self, v: u32, layout: &[DVec2], room: LoopRoom) -> Option<DVec2> {
        let (p, q) = (layout[v as usize], self.relaxed(v as usize, layout)?);
        [1.0, 0.5, 0.25].into_iter().map(|t| p + (q - p) * t).find(|&q| {
            inside(q, room.region)
                && self.keeps_positive(v as usize, q, layout)
                && !room.outline.crossed_moving(v, q, layout)
        })
    }

    fn star_energy(&self, v: usize, p: DVec2, layout: &[DVec2]) -> f64 {
        self.stars
            .of(v)
            .iter()
            .map(|&t| {
                let tri = self.triangles[t as usize];
                value(
                    &self.rest[t as usize],
                    tri.map(|w| if w as usize == v { p } else { layout[w as usize] }),
                )
            })
            .sum()
    }

    /// The largest step along `d` before a triangle of `v`'s star reaches
    /// zero area (each area is linear in the step).
    fn safe_step(&self, v: usize, p: DVec2, d: DVec2, layout: &[DVec2]) -> f64 {
        self.stars
            .of(v)
            .iter()
            .map(|&t| {
                let tri = self.triangles[t as usize];
                let k = tri.iter().position(|&w| w as usize == v).unwrap_or(0);
                let (a, b) = (layout[tri[(k + 1) % 3] as usize], layout[tri[(k + 2) % 3] as usize]);
                // (a − p − αd) × (b − p − αd) = area + α (b − a) × d.
                let area = (a - p).perp_dot(b - p);
                let rate = (b - a).perp_dot(d);
                if rate < 0.0 { area / -rate } else { f64::INFINITY }
            })
            .fold(f64::INFINITY, f64::min)
    }

    fn keeps_positive(&self, v: usize, q: DVec2, layout: &[DVec2]) -> bool {
        self.stars.of(v).iter().all(|&t| {
            let x = self.triangles[t as usize].map(|w| if w as usize == v { q } else { layout[w as usize] });
            orientation(x[0], x[1], x[2]) > 0.0
        })
    }
}

/// A triangle's weighted energy; +∞ when folded.
#[inline]
fn value(rest: &RestTriangle, x: [DVec2; 3]) -> f64 {
    rest.weight * psi(jacobian(rest, x))
}

/// `−H⁻¹ g` for the symmetric 2 × 2 `h` = [h00, h01, h11], its eigenvalues
/// clamped to a small positive floor (projected Newton); `None` at a
/// stationary point.
fn newton_direction(g: DVec2, h: [f64; 3]) -> Option<DVec2> {
    let (a, b, c) = (h[0], h[1], h[2]);
    let mean = 0.5 * (a + c);
    let radius = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let (l1, l2) = (mean + radius, mean - radius);
    let floor = 1e-8 * l1.abs().max(1e-300);
    // The eigenvector of the larger eigenvalue, then its normal.
    let e1 = DVec2::new(b, l1 - a)
        .try_normalize()
        .unwrap_or(if a >= c { DVec2::X } else { DVec2::Y });
    let e2 = e1.perp();
    let d = -(e1 * (e1.dot(g) / l1.max(floor)) + e2 * (e2.dot(g) / l2.max(floor)));
    (d.is_finite() && d != DVec2::ZERO).then_some(d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::complete::energy::{rest_shapes, triangle_terms, twist_mode};
    use crate::testing::{Rng, grid_mesh, smooth_warp};

    #[test]
    fn a_corners_terms_are_its_share_of_the_triangles() {
        let mesh = grid_mesh(3, 3);
        let rest = rest_shapes(&mesh.positions, &mesh.triangles, mesh.n_triangles(), 0.01);
        // A fair triangle, and one pressed flat (its twist mode projected).
        let mut twisted = 0;
        for x in [
            [DVec2::new(0.1, 0.0), DVec2::new(0.9, 0.2), DVec2::new(0.3, 0.7)],
            [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.1), DVec2::new(0.6, 0.15)],
        ] {
            let (e, g, h) = triangle_terms(&rest[0], x).unwrap();
            let f = jacobian(&rest[0], x);
            let j = f[0] * f[3] - f[1] * f[2];
            twisted += usize::from(twist_mode(f, f.iter().map(|v| v * v).sum(), j).is_some());
            for k in 0..3 {
                let (ek, gk, hk) = corner_terms(&rest[0], x, k).unwrap();
                assert!((ek - e).abs() < 1e-12 * e.abs());
                assert!((gk - DVec2::new(g[2 * k], g[2 * k + 1])).length() < 1e-9 * (1.0 + gk.length()));
                let (r, c) = (2 * k, 2 * k + 1);
                for (got, want) in hk.iter().zip([h[r * 6 + r], h[r * 6 + c], h[c * 6 + c]]) {
                    assert!((got - want).abs() < 1e-9 * (1.0 + want.abs()), "{got} {want}");
                }
            }
        }
        assert_eq!(twisted, 1);
    }

    #[test]
    fn sweeps_lower_the_energy_and_never_fold() {
        let mesh = grid_mesh(30, 30);
        let rest = rest_shapes(&mesh.positions, &mesh.triangles, mesh.n_triangles(), 0.01);
        let mut rng = Rng::new(3);
        // The plane, warped and jittered: fold-free, distorted.
        let mut layout: Vec<DVec2> = mesh
            .positions
            .iter()
            .map(|p| smooth_warp(DVec2::new(p.x, p.y), 0.1))
            .collect();
        let topology = crate::mesh::topology::Topology::build(&mesh).unwrap();
        let mut movable = vec![true; layout.len()];
        topology.loops[0].iter().for_each(|&v| movable[v as usize] = false);
        for (v, p) in layout.iter_mut().enumerate() {
            if movable[v] {
                *p += DVec2::new(rng.range(-0.004, 0.004), rng.range(-0.004, 0.004));
            }
        }
        assert!(crate::guard::all_positive(&layout, &mesh.triangles));
        let stats = smooth(&mut layout, &mesh.triangles, &rest, &movable, 20, None);
        // 4 per unit area is an isometry: most of the excess goes.
        let excess = |e: f64| e - 4.0;
        assert!(
            excess(stats.energy_after) < 0.6 * excess(stats.energy_before),
            "{stats:?}"
        );
        assert!(crate::guard::all_positive(&layout, &mesh.triangles));
    }
}
