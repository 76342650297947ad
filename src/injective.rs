//! Global injectivity, decided exactly: boundary edges that meet, points
//! inside loops or triangles. With every triangle positive (the
//! [`crate::guard`]), a chart is one-to-one exactly when its boundary loops
//! are disjoint simple curves, holes inside the outer loop; two charts
//! overlap exactly when their boundaries cross or one lies inside the other.
//! Every predicate is the exact orientation test on the given coordinates.

use crate::guard::orientation;
use glam::DVec2;

/// The bounding box `(lo, hi)` of `points` (inverted, ∞ to −∞, when
/// there are none).
pub fn bounds(points: impl IntoIterator<Item = impl std::borrow::Borrow<DVec2>>) -> (DVec2, DVec2) {
    points
        .into_iter()
        .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p.borrow()), hi.max(*p.borrow()))
        })
}

/// What counts as two edges meeting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Contact {
    /// Interiors crossing at one point, or overlapping along a stretch of
    /// both (what a checker of other tools' layouts reports: touching is not
    /// overlapping).
    Proper,
    /// Any common point except a shared endpoint of adjacent edges (what the
    /// solver's own layouts must avoid: it keeps everything apart).
    Any,
}

fn sign(x: f64) -> i8 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// `p` lies on the closed segment `a b`, given that the three are collinear.
fn on_segment(a: DVec2, b: DVec2, p: DVec2) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

/// Whether the closed segments `a b` and `c d` meet as `contact` says:
/// `Any`, a common point; `Proper`, interiors crossing at one point, or a
/// common stretch of positive length.
pub fn segments_meet(a: DVec2, b: DVec2, c: DVec2, d: DVec2, contact: Contact) -> bool {
    let o1 = sign(orientation(a, b, c));
    let o2 = sign(orientation(a, b, d));
    let o3 = sign(orientation(c, d, a));
    let o4 = sign(orientation(c, d, b));
    if o1 * o2 < 0 && o3 * o4 < 0 {
        return true;
    }
    if o1 == 0 && o2 == 0 {
        return collinear_overlap(a, b, c, d) >= Overlap::Point
            && (contact == Contact::Any || collinear_overlap(a, b, c, d) == Overlap::Stretch);
    }
    contact == Contact::Any
        && ((o1 == 0 && on_segment(a, b, c))
            || (o2 == 0 && on_segment(a, b, d))
            || (o3 == 0 && on_segment(c, d, a))
            || (o4 == 0 && on_segment(c, d, b)))
}

/// How much two collinear segments have in common.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Overlap {
    Nothing,
    Point,
    Stretch,
}

fn collinear_overlap(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> Overlap {
    // Project on an axis the segments are not perpendicular to: exact, as
    // the points are collinear.
    let vertical = a.x == b.x && c.x == d.x;
    let axis = |p: DVec2| if vertical { p.y } else { p.x };
    let lo = axis(a).min(axis(b)).max(axis(c).min(axis(d)));
    let hi = axis(a).max(axis(b)).min(axis(c).max(axis(d)));
    if hi > lo {
        Overlap::Stretch
    } else if hi == lo {
        Overlap::Point
    } else {
        Overlap::Nothing
    }
}

/// Edges `(from, to)` indexing `points`.
pub type Edge = [u32; 2];

/// Pairs of edges that meet (indices into `edges`), at most `limit` of
/// them. Pairs that share a vertex index are adjacent along a loop and meet
/// only if they fold back onto each other. Edges from `apart` on are never
/// tested against each other (other islands, which are known not to meet):
/// only against the edges before it.
///
/// A sweep over x: edges sorted by their left end, each tested against the
/// edges that start before it ends (exactly, with the orientation test).
pub fn meeting_pairs(
    points: &[DVec2],
    edges: &[Edge],
    contact: Contact,
    limit: usize,
    apart: usize,
) -> Vec<(usize, usize)> {
    meeting_pairs_within(points, edges, contact, limit, u64::MAX, apart).0
}

/// As [`meeting_pairs`], testing at most `budget` pairs (edges that overlap
/// in x); `false` with the pairs when the budget ran out first.
pub fn meeting_pairs_within(
    points: &[DVec2],
    edges: &[Edge],
    contact: Contact,
    limit: usize,
    budget: u64,
    apart: usize,
) -> (Vec<(usize, usize)>, bool) {
    let span = |e: &Edge| {
        let (a, b) = (points[e[0] as usize], points[e[1] as usize]);
        (a.x.min(b.x), a.x.max(b.x), a.y.min(b.y), a.y.max(b.y))
    };
    let spans: Vec<(f64, f64, f64, f64)> = edges.iter().map(span).collect();
    let sorted = |range: std::ops::Range<usize>| {
        let mut order: Vec<usize> = range.collect();
        order.sort_unstable_by(|&i, &j| spans[i].0.total_cmp(&spans[j].0));
        order
    };
    let apart = apart.min(edges.len());
    let (own, fixed) = (sorted(0..apart), sorted(apart..edges.len()));
    let mut sweep = Sweep {
        points,
        edges,
        spans: &spans,
        contact,
        limit,
        budget,
        tested: 0,
        out: Vec::new(),
    };
    // Each pair once: the one whose left end comes first (ties: the own
    // edge) tests the other.
    for (k, &i) in own.iter().enumerate() {
        let x0 = spans[i].0;
        let from = fixed.partition_point(|&j| spans[j].0 < x0);
        if !sweep.test(i, &own[k + 1..]) || !sweep.test(i, &fixed[from..]) {
            return (sweep.out, sweep.tested <= budget);
        }
    }
    for &j in &fixed {
        let x0 = spans[j].0;
        let from = own.partition_point(|&i| spans[i].0 <= x0);
        if !sweep.test(j, &own[from..]) {
            return (sweep.out, sweep.tested <= budget);
        }
    }
    (sweep.out, true)
}

/// The state of [`meeting_pairs_within`]'s sweep.
struct Sweep<'a> {
    points: &'a [DVec2],
    edges: &'a [Edge],
    spans: &'a [(f64, f64, f64, f64)],
    contact: Contact,
    limit: usize,
    budget: u64,
    tested: u64,
    out: Vec<(usize, usize)>,
}

impl Sweep<'_> {
    /// Tests edge `i` against `later` (sorted by left end, none starting
    /// left of `i`) until one starts right of `i`'s right end; `false` once
    /// the limit or the budget is reached.
    fn test(&mut self, i: usize, later: &[usize]) -> bool {
        let (_, x1, y0, y1) = self.spans[i];
        for &j in later {
            let (jx0, _, jy0, jy1) = self.spans[j];
            if jx0 > x1 {
                break;
            }
            self.tested += 1;
            if self.tested > self.budget {
                return false;
            }
            if jy0 > y1 || jy1 < y0 {
                continue;
            }
            if edges_meet(self.points, self.edges[i], self.edges[j], self.contact) {
                self.out.push((i.min(j), i.max(j)));
                if self.out.len() >= self.limit {
                    return false;
                }
            }
        }
        true
    }
}

/// Whether two edges meet; edges sharing a vertex index meet only if they
/// overlap along a stretch (an edge folded back onto its neighbour).
fn edges_meet(points: &[DVec2], e: Edge, f: Edge, contact: Contact) -> bool {
    let p = |v: u32| points[v as usize];
    let shares = e[0] == f[0] || e[0] == f[1] || e[1] == f[0] || e[1] == f[1];
    if shares {
        if e == f || e == [f[1], f[0]] {
            return true;
        }
        let (a, b, c, d) = (p(e[0]), p(e[1]), p(f[0]), p(f[1]));
        return orientation(a, b, c) == 0.0
            && orientation(a, b, d) == 0.0
            && collinear_overlap(a, b, c, d) == Overlap::Stretch;
    }
    segments_meet(p(e[0]), p(e[1]), p(f[0]), p(f[1]), contact)
}

/// Winding number of the closed polylines `edges` around `q` (0 outside
/// all of them; a point on an edge counts by the half-open rule).
pub fn winding_number(q: DVec2, points: &[DVec2], edges: &[Edge]) -> i32 {
    let mut w = 0;
    for e in edges {
        let (a, b) = (points[e[0] as usize], points[e[1] as usize]);
        if a.y <= q.y {
            if b.y > q.y && orientation(a, b, q) > 0.0 {
                w += 1;
            }
        } else if b.y <= q.y && orientation(a, b, q) < 0.0 {
            w -= 1;
        }
    }
    w
}

/// Whether `q` lies strictly inside triangle `t` (either orientation).
pub fn strictly_inside(q: DVec2, t: [DVec2; 3]) -> bool {
    let s = [
        sign(orientation(t[0], t[1], q)),
        sign(orientation(t[1], t[2], q)),
        sign(orientation(t[2], t[0], q)),
    ];
    s.iter().all(|&x| x > 0) || s.iter().all(|&x| x < 0)
}

/// The boundary edges of a triangle set, directed as the triangles wind
/// them: every directed edge whose reverse no triangle uses, each once
/// (an edge used twice in one direction counts once).
pub fn boundary_edges(triangles: &[[u32; 3]]) -> Vec<Edge> {
    use rayon::slice::ParallelSliceMut;
    // Each directed edge as its undirected key and whether it runs from the
    // lower end: sorted, an edge's uses lie together (no search per edge).
    let mut uses: Vec<(u64, bool)> = triangles
        .iter()
        .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
        // An edge from a vertex to itself is its own reverse.
        .filter(|[a, b]| a != b)
        .map(|[a, b]| ((u64::from(a.min(b)) << 32) | u64::from(a.max(b)), a < b))
        .collect();
    uses.par_sort_unstable();
    uses.dedup();
    let mut out: Vec<Edge> = uses
        .chunk_by(|x, y| x.0 == y.0)
        .filter(|run| run.len() == 1)
        .map(|run| {
            let (key, up) = run[0];
            let (lo, hi) = ((key >> 32) as u32, key as u32);
            if up { [lo, hi] } else { [hi, lo] }
        })
        .collect();
    out.par_sort_unstable();
    out
}

/// Where the charts of an atlas overlap (see [`atlas_overlaps`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AtlasOverlaps {
    /// Per chart: pairs of its own boundary edges that cross.
    pub self_crossings: Vec<usize>,
    /// Pairs of charts `(a, b)`, `a < b`, whose triangles overlap.
    pub overlapping: Vec<(u32, u32)>,
    /// Every pair of boundary edges was looked at (false: the budget of
    /// pair tests ran out, on a pathological atlas of long edges).
    pub complete: bool,
}

/// Pair tests [`atlas_overlaps`] makes at most (about a second).
pub const ATLAS_BUDGET: u64 = 100_000_000;

/// Global injectivity of an atlas, exactly: `triangles` over `points`, each
/// in chart `chart_of[t]` (charts share no vertex). Two charts overlap when
/// boundary edges of theirs cross (touching does not count) or a point
/// inside one lies strictly inside a triangle of the other; a chart crosses
/// itself when two of its boundary edges cross. Crossing pairs beyond
/// `limit` are not looked for.
pub fn atlas_overlaps(
    points: &[DVec2],
    triangles: &[[u32; 3]],
    chart_of: &[u32],
    n_charts: usize,
    limit: usize,
) -> AtlasOverlaps {
    let mut out = AtlasOverlaps {
        self_crossings: vec![0; n_charts],
        overlapping: Vec::new(),
        complete: true,
    };
    // A triangle with a NaN or infinite corner has no place in the texture:
    // the rest of its chart is judged without it (it is counted as broken
    // where orientations are counted).
    let (triangles, chart_of): (Vec<[u32; 3]>, Vec<u32>) = triangles
        .iter()
        .zip(chart_of)
        .filter(|(t, _)| t.iter().all(|&v| points[v as usize].is_finite()))
        .map(|(t, &c)| (*t, c))
        .unzip();
    let (triangles, chart_of) = (&triangles[..], &chart_of[..]);
    let edges = boundary_edges(triangles);
    // Every vertex is in one chart: the chart of an edge is its first vertex's.
    let mut chart_of_vertex = vec![u32::MAX; points.len()];
    for (t, &c) in triangles.iter().zip(chart_of) {
        t.iter().for_each(|&v| chart_of_vertex[v as usize] = c);
    }
    let edge_chart = |e: &Edge| chart_of_vertex[e[0] as usize];
    let (pairs, complete) = meeting_pairs_within(points, &edges, Contact::Proper, limit, ATLAS_BUDGET, edges.len());
    out.complete = complete;
    for (i, j) in pairs {
        let (a, b) = (edge_chart(&edges[i]), edge_chart(&edges[j]));
        if a == b {
            out.self_crossings[a as usize] += 1;
        } else {
            out.overlapping.push((a.min(b), a.max(b)));
        }
    }
    out.overlapping
        .extend(containments(points, triangles, chart_of, n_charts));
    out.overlapping.sort_unstable();
    out.overlapping.dedup();
    out
}

/// Pairs of charts one of which has a point strictly inside the other's
/// triangles (one chart inside another, boundaries apart).
fn containments(points: &[DVec2], triangles: &[[u32; 3]], chart_of: &[u32], n_charts: usize) -> Vec<(u32, u32)> {
    let corners = |t: &[u32; 3]| t.map(|v| points[v as usize]);
    // A probe per chart: the centroid of its first triangle with area.
    let mut probe: Vec<Option<DVec2>> = vec![None; n_charts];
    for (t, &c) in triangles.iter().zip(chart_of) {
        let [a, b, d] = corners(t);
        if probe[c as usize].is_none() && orientation(a, b, d) != 0.0 {
            probe[c as usize] = Some((a + b + d) / 3.0);
        }
    }
    // Probes bucketed by a uniform grid over their bounding box.
    let probes: Vec<(u32, DVec2)> = probe
        .iter()
        .enumerate()
        .filter_map(|(c, p)| p.map(|p| (c as u32, p)))
        .collect();
    let Some((lo, hi)) = probes
        .iter()
        .map(|&(_, p)| (p, p))
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    else {
        return Vec::new();
    };
    let side = ((probes.len() as f64).sqrt().ceil() as usize).clamp(1, 1024);
    let cell = ((hi - lo) / side as f64).max(DVec2::splat(1e-300));
    let index = |p: DVec2| {
        let q = ((p - lo) / cell).floor();
        let clamp = |x: f64| (x.max(0.0) as usize).min(side - 1);
        (clamp(q.x), clamp(q.y))
    };
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); side * side];
    for (k, &(_, p)) in probes.iter().enumerate() {
        let (x, y) = index(p);
        cells[y * side + x].push(k as u32);
    }
    let mut out = Vec::new();
    for (t, &c) in triangles.iter().zip(chart_of) {
        let tri = corners(t);
        let (tlo, thi) = (tri[0].min(tri[1]).min(tri[2]), tri[0].max(tri[1]).max(tri[2]));
        if thi.cmplt(lo).any() || tlo.cmpgt(hi).any() {
            continue;
        }
        let ((x0, y0), (x1, y1)) = (index(tlo), index(thi));
        for y in y0..=y1 {
            for x in x0..=x1 {
                for &k in &cells[y * side + x] {
                    let (other, p) = probes[k as usize];
                    if other != c && strictly_inside(p, tri) {
                        out.push((c.min(other), c.max(other)));
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> DVec2 {
        DVec2::new(x, y)
    }

    #[test]
    fn crossing_touching_and_collinear_segments() {
        let (a, b) = (p(0.0, 0.0), p(1.0, 1.0));
        assert!(segments_meet(a, b, p(0.0, 1.0), p(1.0, 0.0), Contact::Proper));
        // T-junction: touching, not crossing.
        assert!(!segments_meet(a, b, p(0.5, 0.5), p(1.0, 0.0), Contact::Proper));
        assert!(segments_meet(a, b, p(0.5, 0.5), p(1.0, 0.0), Contact::Any));
        // A common endpoint is a contact, not a crossing.
        assert!(segments_meet(a, b, b, p(2.0, 0.0), Contact::Any));
        assert!(!segments_meet(a, b, b, p(2.0, 0.0), Contact::Proper));
        // Collinear: a stretch in common, one point in common, apart.
        assert!(segments_meet(a, b, p(0.5, 0.5), p(2.0, 2.0), Contact::Proper));
        assert!(!segments_meet(a, b, b, p(2.0, 2.0), Contact::Proper));
        assert!(segments_meet(a, b, b, p(2.0, 2.0), Contact::Any));
        assert!(!segments_meet(a, b, p(1.5, 1.5), p(2.0, 2.0), Contact::Any));
        // Vertical collinear overlap (the y axis decides).
        assert!(segments_meet(
            p(0.0, 0.0),
            p(0.0, 1.0),
            p(0.0, 0.5),
            p(0.0, 2.0),
            Contact::Proper
        ));
        assert!(!segments_meet(
            p(0.0, 0.0),
            p(0.0, 1.0),
            p(0.0, 1.5),
            p(0.0, 2.0),
            Contact::Any
        ));
    }

    #[test]
    fn meeting_pairs_finds_a_bow_tie_and_skips_neighbours() {
        // A square traversed as a bow tie: edges 0-1-2-3 with 1 and 3 swapped.
        let pts = [p(0.0, 0.0), p(1.0, 1.0), p(1.0, 0.0), p(0.0, 1.0)];
        let edges = [[0, 1], [1, 2], [2, 3], [3, 0]];
        let pairs = meeting_pairs(&pts, &edges, Contact::Any, 10, edges.len());
        assert_eq!(pairs, vec![(0, 2)]);
        let square = [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)];
        assert!(meeting_pairs(&square, &edges, Contact::Any, 10, edges.len()).is_empty());
    }

    #[test]
    fn atlas_overlaps_find_crossing_and_nested_charts() {
        // Chart 0: a unit square; chart 1: a small square inside it; chart
        // 2: a square half over chart 0's right edge; chart 3: far away.
        let square = |o: DVec2, s: f64| [o, o + DVec2::new(s, 0.0), o + DVec2::splat(s), o + DVec2::new(0.0, s)];
        let mut points = Vec::new();
        let mut triangles = Vec::new();
        let mut chart_of = Vec::new();
        for (c, (o, s)) in [
            (p(0.0, 0.0), 1.0),
            (p(0.4, 0.4), 0.2),
            (p(0.8, 0.3), 0.4),
            (p(3.0, 3.0), 1.0),
        ]
        .into_iter()
        .enumerate()
        {
            let base = points.len() as u32;
            points.extend(square(o, s));
            triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
            chart_of.extend([c as u32, c as u32]);
        }
        let found = atlas_overlaps(&points, &triangles, &chart_of, 4, 100);
        assert_eq!(found.overlapping, vec![(0, 1), (0, 2)]);
        assert_eq!(found.self_crossings, vec![0, 0, 0, 0]);
        // A NaN corner in the nested and the crossing chart (on the
        // triangle listed first, the probe's): their finite triangles
        // still count.
        let nan = points.len() as u32;
        points.push(DVec2::NAN);
        for c in [1u32, 2] {
            let base = 4 * c;
            triangles.insert(0, [base, base + 1, nan]);
            chart_of.insert(0, c);
        }
        let found = atlas_overlaps(&points, &triangles, &chart_of, 4, 100);
        assert_eq!(found.overlapping, vec![(0, 1), (0, 2)]);
        assert_eq!(found.self_crossings, vec![0, 0, 0, 0]);
    }

    #[test]
    fn the_sweep_finds_every_meeting_pair_but_those_among_the_fixed_edges() {
        // Random segments on a coarse grid (shared ends, collinear runs,
        // equal left ends): the sweep against every pair tested directly.
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 6) as f64
        };
        for _ in 0..200 {
            let mut points: Vec<DVec2> = (0..24).map(|_| p(next(), next())).collect();
            for k in (1..24).step_by(2) {
                // No zero-length edge.
                while points[k] == points[k - 1] {
                    points[k] = p(next(), next());
                }
            }
            let edges: Vec<Edge> = (0..12).map(|k| [2 * k, 2 * k + 1]).collect();
            let apart = (next() * 2.0) as usize;
            let mut found = meeting_pairs(&points, &edges, Contact::Any, usize::MAX, apart);
            found.sort_unstable();
            let mut direct = Vec::new();
            for i in 0..edges.len() {
                for j in i + 1..edges.len() {
                    if j >= apart && i >= apart {
                        continue;
                    }
                    if edges_meet(&points, edges[i], edges[j], Contact::Any) {
                        direct.push((i, j));
                    }
                }
            }
            assert_eq!(found, direct, "apart {apart}: {points:?}");
        }
    }

    #[test]
    fn winding_and_triangles() {
        let square = [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)];
        let ccw = [[0, 1], [1, 2], [2, 3], [3, 0]];
        assert_eq!(winding_number(p(0.5, 0.5), &square, &ccw), 1);
        assert_eq!(winding_number(p(1.5, 0.5), &square, &ccw), 0);
        let cw: Vec<Edge> = ccw.iter().map(|e| [e[1], e[0]]).collect();
        assert_eq!(winding_number(p(0.5, 0.5), &square, &cw), -1);
        assert!(strictly_inside(p(0.6, 0.2), [square[0], square[1], square[2]]));
        assert!(!strictly_inside(p(0.5, 0.0), [square[0], square[1], square[2]]));
        let tris = [[0, 1, 2], [0, 2, 3]];
        let mut b = boundary_edges(&tris);
        b.sort_unstable();
        assert_eq!(b, vec![[0, 1], [1, 2], [2, 3], [3, 0]]);
    }
}
