//! The outer loop of a level as it stands (the filled chart's only
//! boundary: holes are closed by fans), kept so that a vertex put on it or
//! moved along it never makes two of its edges meet: a free chart stays
//! one-to-one (the disk argument of `docs/algorithm.md`).

use super::coarsen::Hierarchy;
use crate::injective::{Contact, segments_meet};
use glam::DVec2;

/// Each loop vertex's neighbours along the loop.
#[derive(Debug, Clone)]
pub struct Outline {
    next: Vec<u32>,
    prev: Vec<u32>,
    members: Vec<u32>,
}

const NONE: u32 = u32::MAX;

impl Outline {
    /// The edges of the hierarchy's level with one living triangle.
    pub fn of(hierarchy: &Hierarchy) -> Self {
        let n = hierarchy.present.len();
        let mut directed = std::collections::HashSet::new();
        for (t, _) in hierarchy.triangles.iter().zip(&hierarchy.alive).filter(|(_, a)| **a) {
            for k in 0..3 {
                directed.insert((t[k], t[(k + 1) % 3]));
            }
        }
        let (mut next, mut prev) = (vec![NONE; n], vec![NONE; n]);
        let mut members = Vec::new();
        for &(a, b) in directed.iter().filter(|&&(a, b)| !directed.contains(&(b, a))) {
            next[a as usize] = b;
            prev[b as usize] = a;
            members.push(a);
        }
        members.sort_unstable();
        Outline { next, prev, members }
    }

    /// Whether `v` is on the loop.
    pub fn contains(&self, v: u32) -> bool {
        self.next[v as usize] != NONE
    }

    /// The loop's edges `a → b`.
    fn edges(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.members
            .iter()
            .map(|&a| (a, self.next[a as usize]))
            .filter(|&(_, b)| b != NONE)
    }

    /// Whether the path `a → p → b` (either way round) meets the loop
    /// anywhere but at `a` and `b` where it joins it, ignoring the edges in
    /// `skip` (the ones it replaces).
    fn path_meets(&self, (a, b): (u32, u32), p: DVec2, skip: &[u32], layout: &[DVec2]) -> bool {
        let (pa, pb) = (layout[a as usize], layout[b as usize]);
        let (lo, hi) = (pa.min(pb).min(p), pa.max(pb).max(p));
        self.edges().any(|(x, y)| {
            let (q0, q1) = (layout[x as usize], layout[y as usize]);
            // Edges clear of the path's box cannot meet it.
            if skip.contains(&x) || q0.max(q1).cmplt(lo).any() || q0.min(q1).cmpgt(hi).any() {
                return false;
            }
            let meets = |s: DVec2, t: DVec2, end: u32| {
                let shared = x == end || y == end;
                let contact = if shared { Contact::Proper } else { Contact::Any };
                segments_meet(s, t, q0, q1, contact)
            };
            meets(pa, p, a) || meets(p, pb, b)
        })
    }

    /// Whether a vertex at `p` between loop neighbours `a` and `b` (the
    /// edge between them split) would make the loop meet itself.
    pub fn crossed_between(&self, (a, b): (u32, u32), p: DVec2, layout: &[DVec2]) -> bool {
        let first = if self.next[a as usize] == b { a } else { b };
        self.path_meets((a, b), p, &[first], layout)
    }

    /// Whether loop vertex `v` moved to `q` would make the loop meet itself.
    pub fn crossed_moving(&self, v: u32, q: DVec2, layout: &[DVec2]) -> bool {
        let (a, b) = (self.prev[v as usize], self.next[v as usize]);
        self.path_meets((a, b), q, &[a, v], layout)
    }

    /// The loop edge between `a` and `b` (either way) becomes a path
    /// through `u`.
    pub fn split(&mut self, (a, b): (u32, u32), u: u32) {
        let (first, second) = if self.next[a as usize] == b { (a, b) } else { (b, a) };
        self.next[first as usize] = u;
        self.next[u as usize] = second;
        self.prev[u as usize] = first;
        self.prev[second as usize] = u;
        if let Err(k) = self.members.binary_search(&u) {
            self.members.insert(k, u);
        }
    }
}

/// Strictly inside the box `(lo, hi)`, as stored (f32) too.
pub fn inside(p: DVec2, (lo, hi): (DVec2, DVec2)) -> bool {
    let stored = crate::guard::stored_uv(p);
    let q = DVec2::new(f64::from(stored[0]), 1.0 - f64::from(stored[1]));
    let vt = crate::guard::stored_vt(p);
    let r = DVec2::new(f64::from(vt[0]), f64::from(vt[1]));
    [p, q, r].iter().all(|x| x.cmpgt(lo).all() && x.cmplt(hi).all())
}
