//! Local sweeps of the symmetric Dirichlet energy: each movable vertex in
//! turn takes the projected Newton step of its own star's energy (a 2 × 2
//! system), cut short where a triangle of the star would reach zero area
//! and halved until the star's energy falls. Every triangle stays positive,
//! so the layout stays fold-free; the held vertices (landmarks, the outer
//! loop) do not move. After a prolongation the fine vertices sit where
//! their coarse triangles put them: these sweeps give them their own shape
//! at linear cost per sweep.

use crate::complete::energy::{RestTriangle, triangle_terms};
use crate::guard::orientation;
use glam::DVec2;

/// What the sweeps did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SmoothStats {
    pub sweeps: u32,
    pub energy_before: f64,
    pub energy_after: f64,
}

/// A sweep that lowers the energy by less than this share ends the sweeps.
const GAIN: f64 = 1e-3;

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

/// Up to `max_sweeps` sweeps over the vertices `movable` marks, in order.
/// `layout` must have every triangle positive; it still has after.
pub fn smooth(
    layout: &mut [DVec2],
    triangles: &[[u32; 3]],
    rest: &[RestTriangle],
    movable: &[bool],
    max_sweeps: u32,
) -> SmoothStats {
    let stars = Stars::new(layout.len(), triangles);
    let energy = |layout: &[DVec2]| -> f64 {
        triangles
            .iter()
            .zip(rest)
            .map(|(t, r)| triangle_terms(r, t.map(|v| layout[v as usize])).map_or(f64::INFINITY, |e| e.0))
            .sum()
    };
    let mut stats = SmoothStats {
        energy_before: energy(layout),
        ..SmoothStats::default()
    };
    let mut last = stats.energy_before;
    while stats.sweeps < max_sweeps {
        for v in (0..layout.len()).filter(|&v| movable[v]) {
            relax_vertex(v, layout, triangles, rest, &stars);
        }
        stats.sweeps += 1;
        let now = energy(layout);
        let gained = last - now;
        last = now;
        if gained.is_nan() || gained <= GAIN * now {
            break;
        }
    }
    stats.energy_after = last;
    stats
}

/// One vertex's projected Newton step on its star's energy.
fn relax_vertex(v: usize, layout: &mut [DVec2], triangles: &[[u32; 3]], rest: &[RestTriangle], stars: &Stars) {
    let star = stars.of(v);
    let star_energy = |p: DVec2, layout: &[DVec2]| -> f64 {
        star.iter()
            .map(|&t| {
                let tri = triangles[t as usize];
                let x = tri.map(|w| if w as usize == v { p } else { layout[w as usize] });
                triangle_terms(&rest[t as usize], x).map_or(f64::INFINITY, |e| e.0)
            })
            .sum()
    };
    let p = layout[v];
    let (mut e0, mut g, mut h) = (0.0, DVec2::ZERO, [0.0; 3]);
    for &t in star {
        let tri = triangles[t as usize];
        let k = tri.iter().position(|&w| w as usize == v).expect("in its star");
        let Some((e, grad, hess)) = triangle_terms(&rest[t as usize], tri.map(|w| layout[w as usize])) else {
            return;
        };
        e0 += e;
        g += DVec2::new(grad[2 * k], grad[2 * k + 1]);
        let (r, c) = (2 * k, 2 * k + 1);
        h[0] += hess[r * 6 + r];
        h[1] += hess[r * 6 + c];
        h[2] += hess[c * 6 + c];
    }
    let Some(d) = newton_direction(g, h) else {
        return;
    };
    let mut alpha = 0.9 * safe_step(v, p, d, star, triangles, layout).min(1.0 / 0.9);
    for _ in 0..10 {
        let q = p + d * alpha;
        if star_energy(q, layout) < e0 && keeps_positive(v, q, star, triangles, layout) {
            layout[v] = q;
            return;
        }
        alpha *= 0.5;
    }
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
    let (l1, l2) = (l1.max(floor), l2.max(floor));
    // Eigenvector of l1.
    let e1 = if radius > 0.0 {
        DVec2::new(b, l1.max(mean + radius) - a)
            .try_normalize()
            .unwrap_or(DVec2::X)
    } else {
        DVec2::X
    };
    let e2 = e1.perp();
    let d = -(e1 * (e1.dot(g) / l1) + e2 * (e2.dot(g) / l2));
    (d.is_finite() && d != DVec2::ZERO).then_some(d)
}

/// The largest step along `d` before a triangle of `v`'s star reaches zero
/// area (each area is linear in the step).
fn safe_step(v: usize, p: DVec2, d: DVec2, star: &[u32], triangles: &[[u32; 3]], layout: &[DVec2]) -> f64 {
    star.iter()
        .map(|&t| {
            let tri = triangles[t as usize];
            let k = tri.iter().position(|&w| w as usize == v).expect("in its star");
            let (a, b) = (layout[tri[(k + 1) % 3] as usize], layout[tri[(k + 2) % 3] as usize]);
            // (a − p − αd) × (b − p − αd) = area + α (b − a) × d.
            let area = (a - p).perp_dot(b - p);
            let rate = (b - a).perp_dot(d);
            if rate < 0.0 { area / -rate } else { f64::INFINITY }
        })
        .fold(f64::INFINITY, f64::min)
}

fn keeps_positive(v: usize, q: DVec2, star: &[u32], triangles: &[[u32; 3]], layout: &[DVec2]) -> bool {
    star.iter().all(|&t| {
        let tri = triangles[t as usize];
        let x = tri.map(|w| if w as usize == v { q } else { layout[w as usize] });
        orientation(x[0], x[1], x[2]) > 0.0
    })
}
