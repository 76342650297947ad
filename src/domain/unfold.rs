//! A projection's turned-over fans opened out. Where a chart takes in
//! every triangle around a landmark on a silhouette (a CAD part's edge, a
//! chin seen from the front), the triangles behind it project turned over,
//! folded back onto the ones in front. Around such a vertex the triangles
//! seen positive leave an angular gap; the turned-over run between them
//! is fanned out across that gap, its free corners on a small circle, so
//! the run turns positive without moving anything the camera placed.

use crate::guard;
use glam::DVec2;
use std::f64::consts::TAU;

/// The share of the distance to the nearest placed neighbour or edge at
/// which a run's free corners are put about the vertex they turn around.
const FAN_RADIUS: f64 = 0.4;

/// Opens out, about every vertex on a `kept` triangle (one placed where
/// it is: positive, and clear of the others), each run of the other
/// triangles around it whose inner corners lie on no kept triangle: those
/// corners go evenly across the angular gap between the run's two ends. A
/// run whose gap leaves a triangle half a turn or more is left as it is.
pub fn unfold_fans(layout: &mut [DVec2], triangles: &[[u32; 3]], kept: &[bool]) {
    if kept.iter().all(|&k| k) {
        return;
    }
    let mut placed = vec![false; layout.len()];
    for (t, _) in triangles.iter().zip(kept).filter(|(_, k)| **k) {
        t.iter().for_each(|&v| placed[v as usize] = true);
    }
    // Each hub's fan as (from, to) corner pairs, counter-clockwise about it.
    let mut around: Vec<Vec<(u32, u32, bool)>> = vec![Vec::new(); layout.len()];
    for (t, &is_kept) in triangles.iter().zip(kept) {
        for k in 0..3 {
            around[t[k] as usize].push((t[(k + 1) % 3], t[(k + 2) % 3], is_kept));
        }
    }
    let segments = Segments::new(layout, triangles, kept);
    for hub in 0..layout.len() {
        if placed[hub] && around[hub].iter().any(|&(_, _, p)| !p) {
            open_runs(hub, &around[hub], (&placed, &segments), layout);
        }
    }
}

/// An edge whose box covers more grid cells than this is kept apart.
const LONG_EDGE_CELLS: usize = 64;

/// The edges of the kept triangles in a grid over the layout: how
/// near a vertex the nearest edge not its own passes (a CAD part's long
/// facet passes a fanned-out landmark closer than any vertex does).
struct Segments {
    edges: Vec<[u32; 2]>,
    cells: Vec<Vec<u32>>,
    /// Edges across more than [`LONG_EDGE_CELLS`] cells, in none.
    long: Vec<u32>,
    side: usize,
    lo: DVec2,
    cell: f64,
}

impl Segments {
    fn new(layout: &[DVec2], triangles: &[[u32; 3]], kept: &[bool]) -> Segments {
        let mut edges: Vec<[u32; 2]> = triangles
            .iter()
            .zip(kept)
            .filter(|(_, k)| **k)
            .flat_map(|(t, _)| (0..3).map(move |k| [t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])]))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let (lo, hi) = layout.iter().fold(
            (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
            |(a, b), &p| (a.min(p), b.max(p)),
        );
        let side = ((edges.len() as f64).sqrt() as usize).clamp(1, 512);
        let cell = ((hi - lo).max_element() / side as f64).max(f64::MIN_POSITIVE);
        let mut segments = Segments {
            edges,
            cells: vec![Vec::new(); side * side],
            long: Vec::new(),
            side,
            lo,
            cell,
        };
        for i in 0..segments.edges.len() {
            let e = segments.edges[i];
            let (a, b) = (layout[e[0] as usize], layout[e[1] as usize]);
            let ((x0, y0), (x1, y1)) = (segments.at(a.min(b)), segments.at(a.max(b)));
            // An edge across many cells (a CAD part's long facet) is
            // looked at on every query instead.
            if (x1 - x0 + 1) * (y1 - y0 + 1) > LONG_EDGE_CELLS {
                segments.long.push(i as u32);
                continue;
            }
            for y in y0..=y1 {
                for x in x0..=x1 {
                    segments.cells[y * side + x].push(i as u32);
                }
            }
        }
        segments
    }

    /// The grid cell (column, row) of `p`, clamped to the grid.
    fn at(&self, p: DVec2) -> (usize, usize) {
        let q = (p - self.lo) / self.cell;
        (
            (q.x.max(0.0) as usize).min(self.side - 1),
            (q.y.max(0.0) as usize).min(self.side - 1),
        )
    }

    /// The distance from `v` to the nearest edge not at `v`, looked for
    /// within `within` (`within` itself when none is nearer).
    fn clearance(&self, v: u32, layout: &[DVec2], within: f64) -> f64 {
        let p = layout[v as usize];
        let ((x0, y0), (x1, y1)) = (self.at(p - DVec2::splat(within)), self.at(p + DVec2::splat(within)));
        let cells = (y0..=y1).flat_map(|y| (x0..=x1).map(move |x| &self.cells[y * self.side + x]));
        cells
            .chain(std::iter::once(&self.long))
            .flatten()
            .map(|&i| self.edges[i as usize])
            .filter(|e| !e.contains(&v))
            .map(|e| {
                let (a, b) = (layout[e[0] as usize], layout[e[1] as usize]);
                let t = ((p - a).dot(b - a) / (b - a).length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                p.distance(a + (b - a) * t)
            })
            .fold(within, f64::min)
    }
}

/// The runs of non-positive triangles about `hub` (its fan `fan`), each
/// from a placed corner to a placed corner over unplaced ones, fanned out.
fn open_runs(hub: usize, fan: &[(u32, u32, bool)], (placed, segments): (&[bool], &Segments), layout: &mut [DVec2]) {
    let next = |v: u32| fan.iter().find(|&&(a, _, _)| a == v);
    let centre = layout[hub];
    let reach = fan
        .iter()
        .flat_map(|&(a, b, _)| [a, b])
        .filter(|&v| placed[v as usize])
        .map(|v| layout[v as usize].distance(centre))
        .filter(|&d| d > 0.0)
        .fold(f64::INFINITY, f64::min);
    if !reach.is_finite() {
        return;
    }
    let reach = segments.clearance(hub as u32, layout, reach);
    for &(start, _, p) in fan {
        // A run starts at a placed corner whose triangle is not positive.
        if p || !placed[start as usize] {
            continue;
        }
        let mut run = vec![start];
        let mut at = start;
        while let Some(&(_, b, false)) = next(at) {
            run.push(b);
            at = b;
            if placed[b as usize] || run.len() > fan.len() {
                break;
            }
        }
        let end = *run.last().expect("a corner");
        let inner = &run[1..run.len() - 1];
        if run.len() < 3 || !placed[end as usize] || inner.iter().any(|&v| placed[v as usize]) {
            continue;
        }
        let angle = |v: u32| {
            let d = layout[v as usize] - centre;
            d.y.atan2(d.x)
        };
        let from = angle(start);
        let gap = (angle(end) - from).rem_euclid(TAU);
        let steps = (run.len() - 1) as f64;
        if gap <= 0.0 || gap / steps >= std::f64::consts::PI {
            continue;
        }
        for (i, &v) in inner.iter().enumerate() {
            let a = from + gap * (i + 1) as f64 / steps;
            layout[v as usize] = centre + FAN_RADIUS * reach * DVec2::new(a.cos(), a.sin());
        }
    }
}

/// Rounds of [`settle`] at most.
const SETTLE_ROUNDS: usize = 16;

/// [`settle`] moves no corner of more triangles than this.
const MAX_VALENCE: usize = 32;

/// Which of `n` vertices are `landmarks`: those [`settle`] and the
/// untangle keep where they are.
pub fn pinned(n: usize, landmarks: &[u32]) -> Vec<bool> {
    crate::mesh::marked(n, landmarks)
}

/// Moves a corner of every non-positive triangle of `layout` (a sliver
/// seen edge-on between two faces, all its corners placed) to where the
/// smallest of the triangles around it is largest, among points towards
/// each neighbour and towards their mean: a sliver is turned the right way
/// by a nudge its neighbours have room for. Round by round, until none is
/// left or a round moves nothing. The `pinned` vertices (landmarks on
/// their targets) stay.
pub fn settle(layout: &mut [DVec2], triangles: &[[u32; 3]], pinned: &[bool]) {
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); layout.len()];
    for (t, tri) in triangles.iter().enumerate() {
        tri.iter().for_each(|&v| around[v as usize].push(t as u32));
    }
    let area = |l: &[DVec2], t: u32| {
        let [a, b, c] = triangles[t as usize].map(|v| l[v as usize]);
        guard::orientation(a, b, c)
    };
    for _ in 0..SETTLE_ROUNDS {
        let bad: Vec<u32> = (0..triangles.len() as u32)
            .filter(|&t| area(layout, t) <= 0.0)
            .collect();
        if bad.is_empty() {
            return;
        }
        let mut moved = false;
        for t in bad {
            if area(layout, t) > 0.0 {
                continue;
            }
            // A corner of many triangles (a pole, a cap's centre) is left
            // to the untangle: its spots cost its valence squared.
            let best = triangles[t as usize]
                .iter()
                .filter(|&&v| around[v as usize].len() <= MAX_VALENCE && !pinned[v as usize])
                .filter_map(|&v| best_spot(v, &around[v as usize], layout, triangles).map(|p| (v, p)))
                .max_by(|a, b| a.1.1.total_cmp(&b.1.1));
            if let Some((v, (p, _))) = best {
                layout[v as usize] = p;
                moved = true;
            }
        }
        if !moved {
            return;
        }
    }
}

/// The spot for `v` (on the triangles `fan`) that makes the smallest of
/// them largest, with that smallest signed area, when it beats where `v` is.
fn best_spot(v: u32, fan: &[u32], layout: &[DVec2], triangles: &[[u32; 3]]) -> Option<(DVec2, f64)> {
    let here = layout[v as usize];
    let smallest = |p: DVec2| {
        fan.iter()
            .map(|&t| {
                let [a, b, c] = triangles[t as usize].map(|w| if w == v { p } else { layout[w as usize] });
                guard::orientation(a, b, c)
            })
            .fold(f64::INFINITY, f64::min)
    };
    let mut ids: Vec<u32> = fan
        .iter()
        .flat_map(|&t| triangles[t as usize])
        .filter(|&w| w != v)
        .collect();
    ids.sort_unstable();
    ids.dedup();
    let mut neighbours: Vec<DVec2> = ids.iter().map(|&w| layout[w as usize]).collect();
    let mean = neighbours.iter().sum::<DVec2>() / neighbours.len().max(1) as f64;
    neighbours.push(mean);
    let now = smallest(here);
    neighbours
        .iter()
        .flat_map(|&q| [0.05, 0.15, 0.35, 0.6].map(|f| here + (q - here) * f))
        .map(|p| (p, smallest(p)))
        .filter(|&(_, s)| s > now)
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_folded_back_over_its_neighbours_is_fanned_across_the_gap() {
        // Hub 0 at the origin; 1, 2, 3 placed by positive triangles on the
        // right half; 4 and 5 folded back onto them.
        let mut layout = vec![
            DVec2::ZERO,
            DVec2::new(0.0, -1.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(0.5, 0.5),
            DVec2::new(0.5, -0.4),
        ];
        let triangles = vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5], [0, 5, 1]];
        let kept: Vec<bool> = triangles
            .iter()
            .map(|t| guard::orientation(layout[t[0] as usize], layout[t[1] as usize], layout[t[2] as usize]) > 0.0)
            .collect();
        unfold_fans(&mut layout, &triangles, &kept);
        for t in &triangles {
            let [a, b, c] = t.map(|v| layout[v as usize]);
            assert!(guard::orientation(a, b, c) > 0.0, "{t:?} at {layout:?}");
        }
        assert_eq!(layout[2], DVec2::new(1.0, 0.0), "a placed corner stays");
        assert!(layout[4].x < 0.0 && layout[5].x < 0.0, "fanned into the left half");
    }

    #[test]
    fn a_flat_sliver_between_placed_triangles_is_nudged_positive() {
        // Vertex 2 on the segment 0–1: the sliver (0, 1, 2) has no area,
        // the two triangles above it leave room to lift 2.
        let mut layout = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
        ];
        let triangles = [[0, 1, 2], [0, 2, 3], [2, 1, 3]];
        settle(&mut layout, &triangles, &[false; 4]);
        for t in &triangles {
            let [a, b, c] = t.map(|v| layout[v as usize]);
            assert!(guard::orientation(a, b, c) > 0.0, "{t:?} at {layout:?}");
        }
    }
}
