//! A free chart's start: the island as it was when it fits; else the
//! least-squares conformal layout (Lévy et al. 2002) through the targets
//! (the constrained vertices held on them) when it is one-to-one inside its
//! room, which reaches them at once; else the least-squares conformal layout
//! if it is injective, moved by the similarity that best fits its
//! constrained vertices to their targets and gathered in or shrunk until it
//! fits its room; else step 1's where it lies, to be relaxed toward the
//! chart's shape before it is fitted so. A chart whose free path fell short
//! of its targets starts again from its solve on the square, mapped onto
//! the region: a square layout inside the region is a free layout.

use crate::complete::energy::RestTriangle;
use crate::complete::newton::NewtonSystem;
use crate::cut::facing::Sight;
pub use crate::free::StartKind;
use crate::free::room::{Room, Violation};
use crate::guard;
use crate::injective::bounds;
use crate::param::bar_net::FilledChart;
use crate::rbf::stepping::StepProblem;
use glam::{DVec2, DVec3};

/// The start of a free chart's solve.
#[derive(Debug, Clone)]
pub struct ChosenStart {
    /// Layout of the filled chart (virtual hole vertices where step 1 had them).
    pub layout: Vec<DVec2>,
    pub kind: StartKind,
    /// The layout area the chart's rest shapes are scaled to: the fitted
    /// start's before any shrinking, the scale the targets ask for.
    pub rest_area: f64,
    /// How much the start was shrunk to fit its room (1: not at all).
    pub shrink: f64,
}

/// A start without two targets to fit spans this much of the region's
/// width or height: room for the polish to find its shape, which
/// [`fill_region`] then scales up.
const FIRST_FILL: f64 = 0.6;

/// How much of the region a chart without two targets fills at the end (at most).
pub const FINAL_FILL: f64 = 0.98;

/// Shrink factors tried, in order, to fit a start into its room.
const SHRINKS: [f64; 12] = [1.0, 1.0 - 1e-6, 0.99, 0.9, 0.75, 0.5, 0.25, 0.1, 0.03, 1e-2, 1e-3, 1e-4];

/// How far inside its region's border a start moved into it keeps its
/// bounding box, relative to the region's size.
const INSIDE_MARGIN: f64 = 0.01;

/// A start must span at least this much of its region's diagonal: smaller
/// ones (the gaps between other islands) would leave an absurdly small
/// chart, so the chart does not fit.
const MIN_SPAN: f64 = 0.1;

/// A given start ([`crate::free::GivenStart`]) where it is, shrunk just
/// enough to fit its room if it does not.
pub fn given_start(room: &Room, filled: &FilledChart, problem: &StepProblem) -> Option<ChosenStart> {
    let given = room.setup().given.as_ref()?;
    fit_into_room(
        room,
        &Shape::of(filled),
        &given.layout,
        problem,
        given.kind,
        Fit::InPlace,
    )
}

/// The start of a free chart: see the module docs. `rest` are the filled
/// chart's rest shapes (real area 1, virtual triangles light), `system` the
/// Newton system over every vertex, `step1` step 1's layout. `None` when no
/// placement fits (the region is full of other islands).
pub fn choose_start(
    room: &Room,
    filled: &FilledChart,
    rest: &[RestTriangle],
    system: &NewtonSystem,
    step1: &[DVec2],
    problem: &StepProblem,
) -> Option<ChosenStart> {
    let shape = Shape::of(filled);
    if let Some(island) = &room.setup().island {
        let layout = island_layout(filled, island, step1);
        if let Some(start) = fit_into_room(room, &shape, &layout, problem, StartKind::Island, Fit::InPlace) {
            return Some(start);
        }
    }
    if let Some(start) = through_targets(room, &shape, rest, system, step1, problem) {
        return Some(start);
    }
    let mut conformal = step1.to_vec();
    let conformal_fits =
        conformal_layout(&mut conformal, &shape, rest, system, room.boundary_vertices()) && room.embeds(&conformal);
    // Else step 1's square, far from the chart's shape: it is relaxed where
    // it is first, then fitted to the targets (`domain::solve`).
    conformal_fits
        .then(|| fit_into_room(room, &shape, &conformal, problem, StartKind::Conformal, Fit::ToTargets))
        .flatten()
        .or_else(|| {
            fit_into_room(
                room,
                &shape,
                &roomy(room, step1),
                problem,
                StartKind::StepOne,
                Fit::InPlace,
            )
        })
        .or_else(|| fit_into_room(room, &shape, step1, problem, StartKind::StepOne, Fit::ToTargets))
}

/// The least-squares conformal layout with every constrained vertex held on
/// its target, when it is one-to-one and its room admits it as stored (it
/// then needs no spline path and no completion). `None` with fewer than two
/// targets, or when it folds, overlaps itself or leaves its room.
fn through_targets(
    room: &Room,
    shape: &Shape,
    rest: &[RestTriangle],
    system: &NewtonSystem,
    step1: &[DVec2],
    problem: &StepProblem,
) -> Option<ChosenStart> {
    if problem.targets.len() < 2 {
        return None;
    }
    let mut layout = step1.to_vec();
    let mut held = vec![false; layout.len()];
    for (&v, &t) in problem.constraint_vertices.iter().zip(&problem.targets) {
        held[v as usize] = true;
        layout[v as usize] = t;
    }
    let fits = system.solve_conformal(&mut layout, rest, shape.triangles, &held)
        && guard::all_positive_as_stored(&layout, shape.triangles)
        && room.admits(&layout).is_ok();
    fits.then(|| ChosenStart {
        rest_area: layout_area(&layout, &shape.triangles[..shape.n_real_triangles]),
        layout,
        kind: StartKind::Through,
        shrink: 1.0,
    })
}

/// The filled chart as `camera` sees it: its real vertices projected, each
/// hole's virtual vertex where its fan keeps every triangle positive (the
/// loop's mean, its area centroid, or a point between the mean and a loop
/// vertex). Seen whole ([`Sight::Whole`]), the triangles around a landmark
/// that the camera does not see whole (behind it on a silhouette, or half
/// behind another part) are fanned out across the gap the seen ones leave
/// ([`super::unfold`]); slivers are nudged positive in either view. A hole seen at a slant
/// (a bore's rim and the part of its wall the camera sees) need not be
/// star-shaped about any point: its fan and the loop are then untangled
/// with the rest. The landmarks (`landmarks`, local vertices) stay where the
/// camera puts them — on their targets — while their neighbours can make
/// room; they move only when nothing else untangles. `None` when a
/// triangle still folds.
pub fn projection_start(
    (camera, sight): (&crate::cut::facing::Camera, Sight),
    filled: &FilledChart,
    landmarks: &[u32],
) -> Option<Vec<DVec2>> {
    let n = filled.n_real_vertices;
    let real = &filled.mesh.triangles[..filled.n_real_triangles];
    let mut layout = crate::cut::facing::projection(camera, &filled.mesh.positions[..n]);
    let pinned = super::unfold::pinned(filled.mesh.n_vertices(), landmarks);
    if sight == Sight::Whole {
        let towards = camera.towards();
        let chart = crate::mesh::TriMesh {
            positions: filled.mesh.positions[..n].to_vec(),
            triangles: real.to_vec(),
        };
        let depth: Vec<f64> = chart.positions.iter().map(|p| p.dot(towards)).collect();
        let whole = crate::cut::occlusion::seen_whole(&chart, &layout, &depth);
        super::unfold::unfold_fans(&mut layout, real, &whole);
    }
    super::unfold::settle(&mut layout, real, &pinned);
    untangle_around(&mut layout, real, &pinned);
    layout.resize(filled.mesh.n_vertices(), DVec2::ZERO);
    let fans = &filled.mesh.triangles[filled.n_real_triangles..];
    for (k, hole) in filled.holes.iter().enumerate() {
        let centre = (n + k) as u32;
        let points: Vec<DVec2> = hole.iter().map(|&v| layout[v as usize]).collect();
        let mean = points.iter().sum::<DVec2>() / points.len().max(1) as f64;
        let centroid = polygon_centroid(&points).unwrap_or(mean);
        let between = points
            .iter()
            .step_by((points.len() / 16).max(1))
            .flat_map(|&p| [0.25, 0.5, 0.75].map(|t| mean + (p - mean) * t));
        let fan: Vec<&[u32; 3]> = fans.iter().filter(|t| t.contains(&centre)).collect();
        let positive = |at: DVec2, layout: &[DVec2]| {
            fan.iter().all(|t| {
                let [a, b, c] = t.map(|v| if v == centre { at } else { layout[v as usize] });
                guard::orientation(a, b, c) > 0.0
            })
        };
        layout[centre as usize] = [mean, centroid]
            .into_iter()
            .chain(between)
            .find(|&p| positive(p, &layout))
            .unwrap_or(centroid);
    }
    super::unfold::settle(&mut layout, &filled.mesh.triangles, &pinned);
    untangle_around(&mut layout, &filled.mesh.triangles, &pinned).then_some(layout)
}

/// [`untangle`] with the `pinned` vertices kept in place or, when that
/// leaves a triangle folded, with every vertex free to move.
fn untangle_around(layout: &mut [DVec2], triangles: &[[u32; 3]], pinned: &[bool]) -> bool {
    let mut kept = layout.to_vec();
    if untangle(&mut kept, triangles, pinned) {
        layout.copy_from_slice(&kept);
        return true;
    }
    untangle(layout, triangles, &vec![false; layout.len()])
}

/// Rounds of [`untangle`] at most.
const UNTANGLE_ROUNDS: usize = 64;

/// Moves the corners of every triangle of `layout` that is not positive
/// (a sliver of the mesh seen edge-on, flat or just turned over) to the
/// mean of their neighbours, round by round, until none is left or the
/// rounds run out: the few vertices of a projection that slivers flatten.
/// The `pinned` vertices stay. Whether every triangle is positive at the end.
fn untangle(layout: &mut [DVec2], triangles: &[[u32; 3]], pinned: &[bool]) -> bool {
    // The movable corners of the triangles not positive; `None` when none is left.
    let bad = |layout: &[DVec2]| -> Option<Vec<u32>> {
        let folded: Vec<&[u32; 3]> = triangles
            .iter()
            .filter(|t| guard::orientation(layout[t[0] as usize], layout[t[1] as usize], layout[t[2] as usize]) <= 0.0)
            .collect();
        if folded.is_empty() {
            return None;
        }
        let mut out: Vec<u32> = folded
            .into_iter()
            .flatten()
            .copied()
            .filter(|&v| !pinned[v as usize])
            .collect();
        out.sort_unstable();
        out.dedup();
        Some(out)
    };
    let Some(mut vertices) = bad(layout) else {
        return true;
    };
    let around = Around::new(layout.len(), triangles);
    for _ in 0..UNTANGLE_ROUNDS {
        for &v in &vertices {
            if let Some(mean) = around.mean(v, layout) {
                layout[v as usize] = mean;
            }
        }
        match bad(layout) {
            None => return true,
            Some(v) if v.is_empty() => return false,
            Some(v) => vertices = v,
        }
    }
    false
}

/// The area centroid of a simple polygon (`None` for no area).
fn polygon_centroid(points: &[DVec2]) -> Option<DVec2> {
    let (mut area, mut c) = (0.0, DVec2::ZERO);
    for (i, &p) in points.iter().enumerate() {
        let q = points[(i + 1) % points.len()];
        let cross = p.perp_dot(q);
        area += cross;
        c += (p + q) * cross;
    }
    (area.abs() > 0.0).then(|| c / (3.0 * area))
}

/// The chart's own UVs, each hole's virtual vertex at the mean of its loop.
fn island_layout(filled: &FilledChart, island: &[DVec2], step1: &[DVec2]) -> Vec<DVec2> {
    let mut layout = step1.to_vec();
    let n = filled.n_real_vertices;
    layout[..n].copy_from_slice(&island[..n]);
    for (k, hole) in filled.holes.iter().enumerate() {
        let centre = hole.iter().map(|&v| island[v as usize]).sum::<DVec2>() / hole.len().max(1) as f64;
        layout[n + k] = centre;
    }
    layout
}

/// What the start's fitting needs of the chart.
#[derive(Debug, Clone, Copy)]
pub struct Shape<'a> {
    pub positions: &'a [DVec3],
    /// The filled chart's triangles (virtual ones last).
    pub triangles: &'a [[u32; 3]],
    pub n_real_triangles: usize,
}

impl<'a> Shape<'a> {
    pub fn of(filled: &'a FilledChart) -> Self {
        Shape {
            positions: &filled.mesh.positions,
            triangles: &filled.mesh.triangles,
            n_real_triangles: filled.n_real_triangles,
        }
    }

    /// The real triangles' 3D area.
    fn area(&self) -> f64 {
        self.triangles[..self.n_real_triangles]
            .iter()
            .map(|t| {
                let [p, q, r] = t.map(|v| self.positions[v as usize]);
                0.5 * (q - p).cross(r - p).length()
            })
            .sum()
    }
}

/// How a start is placed before it is shrunk to fit its room.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fit {
    /// Where it is (an island); its area is its rest area.
    InPlace,
    /// Moved by the similarity that fits it to the targets; the rest area
    /// estimated from the targets' spread against their 3D distances.
    ToTargets,
    /// Moved by that similarity; its fitted area is its rest area (a start
    /// already relaxed to its own shape).
    ToTargetsAsShaped,
}

/// The least-squares conformal layout, two far-apart boundary vertices
/// pinned at their 3D distance (in rest units), written into `layout`;
/// `false` if it folds or the solve fails.
fn conformal_layout(
    layout: &mut [DVec2],
    shape: &Shape,
    rest: &[RestTriangle],
    system: &NewtonSystem,
    boundary: &[u32],
) -> bool {
    let positions = shape.positions;
    let Some(&a) = boundary.first() else {
        return false;
    };
    let pa = positions[a as usize];
    let Some(&b) = boundary.iter().max_by(|&&x, &&y| {
        pa.distance(positions[x as usize])
            .total_cmp(&pa.distance(positions[y as usize]))
    }) else {
        return false;
    };
    let d = pa.distance(positions[b as usize]) / shape.area().sqrt().max(1e-300);
    if a == b || !d.is_finite() || d <= 0.0 {
        return false;
    }
    let mut held = vec![false; layout.len()];
    held[a as usize] = true;
    held[b as usize] = true;
    layout[a as usize] = DVec2::ZERO;
    layout[b as usize] = DVec2::new(d, 0.0);
    system.solve_conformal(layout, rest, shape.triangles, &held) && guard::all_positive(layout, shape.triangles)
}

/// `base` placed as `fit` says, then shrunk about the targets' centre, or
/// moved elsewhere in the region, until it fits its room.
pub fn fit_into_room(
    room: &Room,
    shape: &Shape,
    base: &[DVec2],
    problem: &StepProblem,
    kind: StartKind,
    fit: Fit,
) -> Option<ChosenStart> {
    let triangles = shape.triangles;
    let placed: Vec<DVec2> = if fit == Fit::InPlace {
        base.to_vec()
    } else {
        let t = similarity(room, base, problem, shape);
        base.iter().map(|&p| t.apply(p)).collect()
    };
    let estimate = (fit == Fit::ToTargets).then(|| target_scale(problem, shape)).flatten();
    let rest_area = estimate.unwrap_or_else(|| layout_area(&placed, &triangles[..shape.n_real_triangles]));
    let start = |layout, shrink| ChosenStart {
        layout,
        kind,
        rest_area,
        shrink,
    };
    let region = room.setup().region.layout_box();
    if kind == StartKind::Projection
        && let Some(layout) = [boxed_in(&placed, problem, region), drawn_in(&placed, region)]
            .into_iter()
            .flatten()
            .chain(uncrossed(room, &placed, triangles, &problem.constraint_vertices))
            .filter_map(|layout| mended(layout, triangles, &problem.constraint_vertices))
            .find(|layout| room.admits(layout).is_ok() && guard::all_positive_as_stored(layout, triangles))
    {
        return Some(start(layout, 1.0));
    }
    if fit != Fit::InPlace
        && let Some(layout) = gathered(room, &placed, problem, triangles)
    {
        return Some(start(layout, 1.0));
    }
    // Step 1 where it lies is relaxed before anything is stored: double
    // precision is enough (its thinnest triangles may be too thin for f32).
    let unstored = kind == StartKind::StepOne && fit == Fit::InPlace;
    let (shrink, layout) = shrunk_into_room(room, triangles, &placed, problem, unstored)?;
    Some(start(layout, shrink))
}

/// `placed` shrunk into its room, as the first of these that fits: with
/// one target, the largest shrink about it that keeps the box inside the
/// region (a landmark near the region's border starts on its target);
/// then each of [`SHRINKS`] about the targets' centre, in place or moved
/// the least that brings the box inside the region (constrained vertices
/// stay near their targets), then about the layout's own centre placed at
/// points spread over the region. The shrink and the layout; `None` once
/// it would span less than [`MIN_SPAN`] of the region (or, for a chart
/// held to a texel density, half its span at it). `unstored`: fitting is
/// judged in double precision.
fn shrunk_into_room(
    room: &Room,
    triangles: &[[u32; 3]],
    placed: &[DVec2],
    problem: &StepProblem,
    unstored: bool,
) -> Option<(f64, Vec<DVec2>)> {
    let (lo, hi) = room.setup().region.layout_box();
    let (blo, bhi) = bounds(placed);
    let span = (bhi - blo).length();
    let held = room.setup().density.is_some() && problem.targets.len() < 2;
    let least = if held {
        (MIN_SPAN * (hi - lo).length()).min(0.5 * span)
    } else {
        MIN_SPAN * (hi - lo).length()
    };
    // The room first: it looks at the boundary only.
    let at = |shrink: f64, from: DVec2, to: DVec2| {
        let layout: Vec<DVec2> = placed.iter().map(|&p| to + (p - from) * shrink).collect();
        let fits = if unstored {
            inside_region(room, &layout) && room.embeds(&layout) && guard::all_positive(&layout, triangles)
        } else {
            room.admits(&layout).is_ok() && guard::all_positive_as_stored(&layout, triangles)
        };
        fits.then_some((shrink, layout))
    };
    let centre =
        (!problem.targets.is_empty()).then(|| problem.targets.iter().sum::<DVec2>() / problem.targets.len() as f64);
    if let (Some(c), 1) = (centre, problem.targets.len())
        && let Some(s) = widest_shrink_inside((blo, bhi), c, (lo, hi))
        && span * s >= least
        && let Some(found) = at(s, c, c)
    {
        return Some(found);
    }
    let middle = 0.5 * (blo + bhi);
    let mut anchors = vec![(middle, 0.5 * (lo + hi))];
    for j in 0..5 {
        for i in 0..5 {
            anchors.push((
                middle,
                lo + (hi - lo) * DVec2::new((2 * i + 1) as f64, (2 * j + 1) as f64) / 10.0,
            ));
        }
    }
    for &shrink in &SHRINKS {
        if span * shrink < least {
            return None;
        }
        let near = centre.map_or(Vec::new(), |c| {
            vec![(c, c), (c, c + least_move_inside((blo, bhi), c, shrink, (lo, hi)))]
        });
        if let Some(found) = near.iter().chain(&anchors).find_map(|&(from, to)| at(shrink, from, to)) {
            return Some(found);
        }
    }
    None
}

/// Rounds of [`uncrossed`] at most.
const UNCROSS_ROUNDS: usize = 32;

/// A camera's view whose outline crosses itself (a fan opened out over a
/// neighbour, a sliver untangled across the outline), the corners of each
/// crossing pair of edges other than the `landmarks` drawn halfway to
/// their neighbours' mean, round by round, while every triangle stays
/// positive: `None` when it needs no uncrossing, or does not come clear.
fn uncrossed(room: &Room, layout: &[DVec2], triangles: &[[u32; 3]], landmarks: &[u32]) -> Option<Vec<DVec2>> {
    let mut verdict = room.admits(layout);
    let Err(Violation::SelfCrossing { .. }) = verdict else {
        return None;
    };
    let pinned = super::unfold::pinned(layout.len(), landmarks);
    let around = Around::new(layout.len(), triangles);
    let mut layout = layout.to_vec();
    for _ in 0..UNCROSS_ROUNDS {
        let (first, second) = match verdict {
            Ok(()) => return Some(layout),
            Err(Violation::SelfCrossing { first, second }) => (first, second),
            Err(_) => return None,
        };
        let before = layout.clone();
        for v in first.into_iter().chain(second).filter(|&v| !pinned[v as usize]) {
            if let Some(mean) = around.mean(v, &before) {
                layout[v as usize] = 0.5 * (before[v as usize] + mean);
            }
        }
        if layout == before || !guard::all_positive(&layout, triangles) {
            return None;
        }
        verdict = room.admits(&layout);
    }
    None
}

/// Each vertex's neighbours, once for every triangle they share.
struct Around(Vec<Vec<u32>>);

impl Around {
    fn new(n: usize, triangles: &[[u32; 3]]) -> Self {
        let mut around = vec![Vec::new(); n];
        for t in triangles {
            for k in 0..3 {
                around[t[k] as usize].push(t[(k + 1) % 3]);
                around[t[k] as usize].push(t[(k + 2) % 3]);
            }
        }
        Around(around)
    }

    /// The mean of `v`'s neighbours in `layout`; `None` on no triangle.
    fn mean(&self, v: u32, layout: &[DVec2]) -> Option<DVec2> {
        let around = &self.0[v as usize];
        (!around.is_empty()).then(|| around.iter().map(|&w| layout[w as usize]).sum::<DVec2>() / around.len() as f64)
    }
}

/// `layout` with the few triangles a squeeze turned over nudged positive
/// ([`super::unfold::settle`], then [`untangle`]), the `landmarks` kept on
/// their targets; `None` when one still folds.
fn mended(mut layout: Vec<DVec2>, triangles: &[[u32; 3]], landmarks: &[u32]) -> Option<Vec<DVec2>> {
    if guard::all_positive(&layout, triangles) {
        return Some(layout);
    }
    let pinned = super::unfold::pinned(layout.len(), landmarks);
    super::unfold::settle(&mut layout, triangles, &pinned);
    untangle(&mut layout, triangles, &pinned).then_some(layout)
}

/// A camera's view that reaches past its region drawn in about the
/// targets' centre `c` along rays, by the room's gauge from `c` (1 on the
/// room's border, kept [`INSIDE_MARGIN`] inside): every point no farther
/// out than the farthest target stays, so the constrained vertices stay on
/// their targets, and beyond it the gauge grows logarithmically up to the
/// border, so that nothing far out is crushed flat (a ray map that grows
/// with the gauge keeps small triangles' orientation; the caller checks).
/// `None` when nothing reaches out, or a target is on the border.
fn boxed_in(layout: &[DVec2], problem: &StepProblem, (lo, hi): (DVec2, DVec2)) -> Option<Vec<DVec2>> {
    if problem.targets.is_empty() {
        return None;
    }
    let margin = (hi - lo) * INSIDE_MARGIN;
    let (lo, hi) = (lo + margin, hi - margin);
    let c = problem.targets.iter().sum::<DVec2>() / problem.targets.len() as f64;
    let gauge = |p: DVec2| {
        let d = p - c;
        let x = if d.x >= 0.0 {
            d.x / (hi.x - c.x)
        } else {
            d.x / (lo.x - c.x)
        };
        let y = if d.y >= 0.0 {
            d.y / (hi.y - c.y)
        } else {
            d.y / (lo.y - c.y)
        };
        x.max(y)
    };
    if !(c.cmpgt(lo).all() && c.cmplt(hi).all()) {
        return None;
    }
    let inner = problem.targets.iter().map(|&t| gauge(t)).fold(0.0, f64::max) * 1.02;
    let far = layout.iter().map(|&p| gauge(p)).fold(0.0, f64::max);
    if far < 1.0 || inner >= 1.0 || !far.is_finite() {
        return None;
    }
    let w = 1.0 - inner;
    let norm = (1.0 + (far - inner) / w).ln().max(1e-300);
    Some(
        layout
            .iter()
            .map(|&p| {
                let g = gauge(p);
                if g <= inner {
                    p
                } else {
                    c + (p - c) * ((inner + w * (1.0 + (g - inner) / w).ln() / norm) / g)
                }
            })
            .collect(),
    )
}

/// A camera's view that reaches past its region (a CAD part's long facet
/// from a landmark out to the silhouette) drawn in by a map that leaves
/// the region's inner part as it is and squeezes each axis monotonically
/// into the margin: landmarks away from the border stay on their targets;
/// a triangle may still turn over where the squeeze flattens it (the
/// caller checks). `None` when nothing reaches out.
fn drawn_in(layout: &[DVec2], (lo, hi): (DVec2, DVec2)) -> Option<Vec<DVec2>> {
    let margin = (hi - lo) * INSIDE_MARGIN * 4.0;
    let (ilo, ihi) = (lo + margin, hi - margin);
    if layout.iter().all(|p| p.cmpgt(ilo).all() && p.cmplt(ihi).all()) {
        return None;
    }
    let squeeze = |x: f64, a: f64, b: f64, m: f64| {
        if x > b {
            b + m * (1.0 - (-(x - b) / m).exp()) * 0.5
        } else if x < a {
            a - m * (1.0 - (-(a - x) / m).exp()) * 0.5
        } else {
            x
        }
    };
    Some(
        layout
            .iter()
            .map(|p| {
                DVec2::new(
                    squeeze(p.x, ilo.x, ihi.x, margin.x),
                    squeeze(p.y, ilo.y, ihi.y, margin.y),
                )
            })
            .collect(),
    )
}

/// Step 1's square drawn in to [`FIRST_FILL`] of the region about its
/// centre: room for its boundary to move while it relaxes.
fn roomy(room: &Room, step1: &[DVec2]) -> Vec<DVec2> {
    let (lo, hi) = room.setup().region.layout_box();
    let (blo, bhi) = bounds(step1);
    let k = FIRST_FILL * ((hi - lo) / (bhi - blo).max(DVec2::splat(1e-300))).min_element();
    let (from, to) = (0.5 * (blo + bhi), 0.5 * (lo + hi));
    step1.iter().map(|&p| to + (p - from) * k).collect()
}

/// Whether every point of `layout` lies strictly inside the room's region
/// and no other island is in it (double precision).
fn inside_region(room: &Room, layout: &[DVec2]) -> bool {
    let (lo, hi) = room.setup().region.layout_box();
    room.setup().obstacles.is_empty() && layout.iter().all(|p| p.cmpgt(lo).all() && p.cmplt(hi).all())
}

/// A start fitted to the targets that is larger than its region, gathered
/// in: every point within the targets' reach of their centre stays (the
/// constrained vertices on or near their targets, at the scale the targets
/// ask for), and the rest is drawn in radially, logarithmically, the
/// farthest point to the region's border. A radial map that grows with the
/// radius keeps every small triangle's orientation; the layout is checked
/// as stored and in its room all the same. `None` when it needs no
/// gathering, has too few targets, or is not admitted.
fn gathered(room: &Room, placed: &[DVec2], problem: &StepProblem, triangles: &[[u32; 3]]) -> Option<Vec<DVec2>> {
    if problem.targets.len() < 2 || room.admits(placed).is_ok() {
        return None;
    }
    let (lo, hi) = room.setup().region.layout_box();
    let centre = problem.targets.iter().sum::<DVec2>() / problem.targets.len() as f64;
    let inner = problem.targets.iter().map(|t| t.distance(centre)).fold(0.0, f64::max) * 1.05;
    let room_left = (centre - lo).min(hi - centre).min_element() * (1.0 - 2.0 * INSIDE_MARGIN);
    let outer = problem
        .constraint_vertices
        .iter()
        .map(|&v| placed[v as usize].distance(centre))
        .fold(inner, f64::max)
        .max(inner);
    if room_left <= outer * 1.001 {
        return None;
    }
    // φ(r) = r up to `outer`, then outer + w · ln(1 + (r − outer)/w) / ln(1 + (far − outer)/w):
    // the farthest point lands on `room_left`; the map grows with r all the
    // way (a logarithm compresses far parts gently, where an exponential
    // saturation crushed them below f32).
    let w = room_left - outer;
    let far = placed.iter().map(|p| p.distance(centre)).fold(outer, f64::max);
    let norm = (1.0 + (far - outer) / w).ln().max(1e-300);
    let layout: Vec<DVec2> = placed
        .iter()
        .map(|&p| {
            let d = p - centre;
            let r = d.length();
            if r <= outer {
                p
            } else {
                centre + d * ((outer + w * (1.0 + (r - outer) / w).ln() / norm) / r)
            }
        })
        .collect();
    (guard::all_positive_as_stored(&layout, triangles) && room.admits(&layout).is_ok()).then_some(layout)
}

/// The layout area the targets ask for: the chart's 3D area scaled by the
/// square of how far apart the targets are relative to their vertices in
/// 3D (sums over all pairs). `None` with fewer than two targets.
fn target_scale(problem: &StepProblem, shape: &Shape) -> Option<f64> {
    let k = problem.targets.len();
    if k < 2 {
        return None;
    }
    let (mut uv, mut xyz) = (0.0, 0.0);
    for i in 0..k {
        for j in i + 1..k {
            uv += problem.targets[i].distance(problem.targets[j]);
            let (a, b) = (problem.constraint_vertices[i], problem.constraint_vertices[j]);
            xyz += shape.positions[a as usize].distance(shape.positions[b as usize]);
        }
    }
    let s = uv / xyz;
    let area = shape.area();
    (s.is_finite() && s > 0.0 && area > 0.0).then_some(s * s * area)
}

/// The least move that brings the box `lo..hi`, shrunk by `shrink` about
/// `centre`, inside `region` ([`INSIDE_MARGIN`] from its border) along each
/// axis where it fits (zero along the others). Moving a start that sticks
/// out to the region's centre instead left every constrained vertex ~0.1
/// from its target, for the completion to carry the whole chart back.
fn least_move_inside((lo, hi): (DVec2, DVec2), centre: DVec2, shrink: f64, region: (DVec2, DVec2)) -> DVec2 {
    let (lo, hi) = (centre + (lo - centre) * shrink, centre + (hi - centre) * shrink);
    let margin = (region.1 - region.0) * INSIDE_MARGIN;
    let (min, max) = (region.0 + margin, region.1 - margin);
    let mut d = DVec2::ZERO;
    for k in 0..2 {
        if hi[k] - lo[k] <= max[k] - min[k] {
            d[k] = (min[k] - lo[k]).max(0.0) + (max[k] - hi[k]).min(0.0);
        }
    }
    d
}

/// The largest shrink below 1 of the box `lo..hi` about `centre` that
/// brings it inside `region` ([`INSIDE_MARGIN`] from its border); `None`
/// when `centre` is outside that or no shrink below 1 is needed.
fn widest_shrink_inside((lo, hi): (DVec2, DVec2), centre: DVec2, region: (DVec2, DVec2)) -> Option<f64> {
    let margin = (region.1 - region.0) * INSIDE_MARGIN;
    let (min, max) = (region.0 + margin, region.1 - margin);
    if !(centre.cmpgt(min).all() && centre.cmplt(max).all()) {
        return None;
    }
    let mut s: f64 = 1.0;
    for k in 0..2 {
        if lo[k] < min[k] {
            s = s.min((centre[k] - min[k]) / (centre[k] - lo[k]));
        }
        if hi[k] > max[k] {
            s = s.min((max[k] - centre[k]) / (hi[k] - centre[k]));
        }
    }
    (s > 0.0 && s < 1.0).then_some(s * (1.0 - 1e-9))
}

/// Total signed area of the triangles in `layout`.
pub fn layout_area(layout: &[DVec2], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| layout[v as usize]);
            0.5 * (b - a).perp_dot(c - a)
        })
        .sum()
}

/// The scale that brings `layout` to its room's texel density
/// ([`crate::free::FreeSetup::density`]), when the room holds it to one.
fn density_scale(room: &Room, layout: &[DVec2], shape: &Shape) -> Option<f64> {
    let density = room.setup().density?;
    let now = (layout_area(layout, &shape.triangles[..shape.n_real_triangles]) / shape.area()).sqrt();
    let s = density / now;
    (s.is_finite() && s > 0.0).then_some(s)
}

/// The similarity (rotation, uniform scale, translation) taking the
/// constrained vertices of `layout` closest to their targets; with fewer
/// than two distinct ones, the scale that fills [`FIRST_FILL`] of the region
/// (or, smaller, brings it to the room's texel density) and the
/// translation onto the one target (or the region's centre).
fn similarity(room: &Room, layout: &[DVec2], problem: &StepProblem, shape: &Shape) -> Similarity {
    let from: Vec<DVec2> = problem
        .constraint_vertices
        .iter()
        .map(|&v| layout[v as usize])
        .collect();
    let to = &problem.targets;
    let k = from.len() as f64;
    let (fc, tc) = if from.is_empty() {
        (DVec2::ZERO, DVec2::ZERO)
    } else {
        (from.iter().sum::<DVec2>() / k, to.iter().sum::<DVec2>() / k)
    };
    // z = Σ conj(p̃) q̃ / Σ |p̃|² as a complex number (scale · rotation).
    let (mut num, mut den) = (DVec2::ZERO, 0.0);
    for (p, q) in from.iter().zip(to) {
        let (p, q) = (*p - fc, *q - tc);
        num += DVec2::new(p.dot(q), p.perp_dot(q));
        den += p.length_squared();
    }
    let (blo, bhi) = bounds(layout);
    let size = (bhi - blo).max(DVec2::splat(1e-300));
    if from.len() >= 2 && den > 1e-24 * size.length_squared() && num.length() > 0.0 {
        return Similarity {
            z: num / den,
            from: fc,
            to: tc,
        };
    }
    let (lo, hi) = room.setup().region.layout_box();
    let filled = FIRST_FILL * ((hi - lo) / size).min_element();
    let s = density_scale(room, layout, shape).map_or(filled, |d| d.min(filled));
    let centre = 0.5 * (blo + bhi);
    let (pivot, at) = if from.is_empty() {
        (centre, 0.5 * (lo + hi))
    } else {
        (fc, tc)
    };
    Similarity {
        z: DVec2::new(s, 0.0),
        from: pivot,
        to: at,
    }
}

/// `p ↦ to + z · (p − from)`, `z` a complex number (scale and rotation).
#[derive(Debug, Clone, Copy)]
struct Similarity {
    z: DVec2,
    from: DVec2,
    to: DVec2,
}

impl Similarity {
    fn apply(&self, p: DVec2) -> DVec2 {
        let (z, d) = (self.z, p - self.from);
        self.to + DVec2::new(z.x * d.x - z.y * d.y, z.y * d.x + z.x * d.y)
    }
}

/// A finished layout without two targets to set its size, scaled up about
/// `pivot` (its one target, or its own centre) as far as its room admits,
/// up to [`FINAL_FILL`] of the region and the room's texel density: the
/// largest island that fits.
pub fn fill_region(room: &Room, layout: &mut [DVec2], shape: &Shape, pivot: Option<DVec2>) {
    let triangles = shape.triangles;
    let (lo, hi) = room.setup().region.layout_box();
    let (blo, bhi) = bounds(&*layout);
    let size = (bhi - blo).max(DVec2::splat(1e-300));
    let filled = FINAL_FILL * ((hi - lo) / size).min_element();
    let most = density_scale(room, layout, shape).map_or(filled, |d| d.min(filled));
    if most.is_nan() || most <= 1.0 {
        return;
    }
    let centre = pivot.unwrap_or(0.5 * (blo + bhi));
    // With no target, the centre may move to the region's centre.
    let to = if pivot.is_some() { centre } else { 0.5 * (lo + hi) };
    let scaled = |s: f64| -> Vec<DVec2> { layout.iter().map(|&p| to + (p - centre) * s).collect() };
    let fits = |l: &[DVec2]| room.admits(l).is_ok() && guard::all_positive_as_stored(l, triangles);
    let (mut good, mut bad) = (1.0, most);
    let mut best = None;
    if fits(&scaled(most)) {
        best = Some(scaled(most));
    } else {
        for _ in 0..16 {
            let mid = 0.5 * (good + bad);
            let candidate = scaled(mid);
            if fits(&candidate) {
                good = mid;
                best = Some(candidate);
            } else {
                bad = mid;
            }
        }
    }
    if let Some(b) = best {
        layout.copy_from_slice(&b);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::grid_mesh;

    #[test]
    fn a_view_whose_tip_crosses_its_own_outline_is_drawn_back_clear() {
        // A strip bent into a ring open by a few degrees, its last outer
        // corner pushed across the gap onto the strip's first end.
        let strip = grid_mesh(16, 2);
        let centre = DVec2::splat(0.5);
        let mut layout: Vec<DVec2> = strip
            .positions
            .iter()
            .map(|p| {
                let (angle, radius) = (p.x * 6.1, 0.3 - 0.1 * p.y);
                centre + radius * DVec2::new(angle.cos(), angle.sin())
            })
            .collect();
        let tip = 15;
        layout[tip] = centre + 0.3 * DVec2::new(0.08f64.cos(), 0.08f64.sin());
        assert!(guard::all_positive(&layout, &strip.triangles), "a fold-free start");
        let topology = crate::mesh::topology::Topology::build(&strip).expect("a disk");
        let setup = crate::free::FreeSetup {
            region: crate::param::region::Region::TEXTURE,
            source: crate::free::RegionSource::Texture,
            obstacles: std::sync::Arc::new(crate::free::Obstacles::default()),
            island: None,
            given: None,
            density: None,
        };
        let room = Room::new(std::sync::Arc::new(setup), &topology, &strip.triangles);
        assert!(matches!(room.admits(&layout), Err(Violation::SelfCrossing { .. })));
        let landmarks = [0, 20];
        let clear = uncrossed(&room, &layout, &strip.triangles, &landmarks).expect("drawn back");
        assert!(room.admits(&clear).is_ok() && guard::all_positive(&clear, &strip.triangles));
        for l in landmarks {
            assert_eq!(clear[l as usize], layout[l as usize], "a landmark stays");
        }
        // A layout already clear needs no uncrossing.
        assert_eq!(uncrossed(&room, &clear, &strip.triangles, &landmarks), None);
    }

    #[test]
    fn the_widest_shrink_about_a_target_near_the_border_just_fits() {
        let region = (DVec2::ZERO, DVec2::new(0.5, 1.0));
        let (lo, hi) = (DVec2::new(0.3, 0.35), DVec2::new(0.6, 0.65));
        let centre = DVec2::new(0.45, 0.5);
        let s = widest_shrink_inside((lo, hi), centre, region).expect("a shrink");
        let right = centre.x + (hi.x - centre.x) * s;
        assert!((right - 0.495).abs() < 1e-6, "the right side on the margin: {right}");
        assert!(centre.x + (lo.x - centre.x) * s > 0.0);
        // Inside already: no shrink; the centre outside the region: none.
        assert_eq!(widest_shrink_inside((lo, DVec2::new(0.49, 0.6)), centre, region), None);
        assert_eq!(widest_shrink_inside((lo, hi), DVec2::new(0.499, 0.5), region), None);
    }

    #[test]
    fn a_view_past_the_texture_is_drawn_in_near_the_border_only() {
        let mesh = grid_mesh(12, 9);
        // The grid spread over -0.3..1.4: past the texture on every side.
        let layout: Vec<DVec2> = mesh
            .positions
            .iter()
            .map(|p| DVec2::new(-0.3 + 1.7 * p.x, -0.3 + 1.7 * p.y))
            .collect();
        assert!(guard::all_positive(&layout, &mesh.triangles));
        let room = (DVec2::ZERO, DVec2::ONE);
        let drawn = drawn_in(&layout, room).expect("it reaches out");
        assert!(drawn.iter().all(|p| p.cmpgt(room.0).all() && p.cmplt(room.1).all()));
        assert!(guard::all_positive(&drawn, &mesh.triangles), "no triangle turns over");
        let inner = |p: &DVec2| p.cmpgt(DVec2::splat(0.1)).all() && p.cmplt(DVec2::splat(0.9)).all();
        for (a, b) in layout.iter().zip(&drawn).filter(|(a, _)| inner(a)) {
            assert_eq!(a, b, "the inner part stays where the camera put it");
        }
        let inside: Vec<DVec2> = layout.iter().map(|p| 0.5 + (*p - 0.5) * 0.5).collect();
        assert_eq!(drawn_in(&inside, room), None, "a view inside is left alone");
    }

    #[test]
    fn a_view_past_the_texture_on_one_side_is_boxed_in_with_its_targets_kept() {
        let mesh = grid_mesh(12, 9);
        // A photo cropped at the bottom and the right: the view reaches to
        // -0.25 and 1.2 there, and the targets lie 0.15 off the border.
        let layout: Vec<DVec2> = mesh
            .positions
            .iter()
            .map(|p| DVec2::new(0.1 + 1.1 * p.x, -0.25 + 1.2 * p.y))
            .collect();
        let inside = |p: &DVec2, m: f64| p.cmpgt(DVec2::splat(m)).all() && p.cmplt(DVec2::splat(1.0 - m)).all();
        let constraint_vertices: Vec<u32> = (0..mesh.n_vertices() as u32)
            .filter(|&v| inside(&layout[v as usize], 0.15))
            .step_by(7)
            .collect();
        let targets = constraint_vertices.iter().map(|&v| layout[v as usize]).collect();
        let problem = StepProblem {
            constraint_vertices: constraint_vertices.clone(),
            targets,
            anchors: Vec::new(),
            movable: Vec::new(),
        };
        let room = (DVec2::ZERO, DVec2::ONE);
        let boxed = boxed_in(&layout, &problem, room).expect("it reaches out");
        assert!(boxed.iter().all(|p| inside(p, 0.0)), "everything inside the texture");
        assert!(guard::all_positive(&boxed, &mesh.triangles), "no triangle turns over");
        for &v in &constraint_vertices {
            assert_eq!(boxed[v as usize], layout[v as usize], "a landmark stays on its target");
        }
        let small: Vec<DVec2> = layout.iter().map(|p| 0.5 + (*p - 0.5) * 0.5).collect();
        assert_eq!(boxed_in(&small, &problem, room), None, "a view inside is left alone");
    }

    #[test]
    fn a_sliver_next_to_a_landmark_is_untangled_with_the_landmark_kept() {
        let mesh = grid_mesh(8, 8);
        let mut layout: Vec<DVec2> = mesh.positions.iter().map(|p| p.truncate()).collect();
        // A landmark inside and its right-hand neighbour pushed past it: the
        // triangles between them turn over, as an edge seen side-on does.
        let (landmark, neighbour) = (3 * 8 + 3, 3 * 8 + 4);
        layout[neighbour] = layout[landmark] - DVec2::new(0.02, 0.0);
        assert!(!guard::all_positive(&layout, &mesh.triangles));
        let mut pinned = vec![false; layout.len()];
        pinned[landmark] = true;
        let target = layout[landmark];
        assert!(untangle_around(&mut layout, &mesh.triangles, &pinned));
        assert!(
            guard::all_positive(&layout, &mesh.triangles),
            "every triangle turned back"
        );
        assert_eq!(layout[landmark], target, "the landmark stays on its target");
    }
}
