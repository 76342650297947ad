//! A finished solve short of its targets keeps a usable layout: when its
//! stretch is more than [`crate::solver::SETTLE_FACTOR`] times the
//! yardstick (the chart's own free layout without landmarks, or step 1's
//! on the square), or it would not keep every triangle once stored as f32
//! (squeezed too thin to be written), that shape is placed for the targets
//! (fitted to them, or failing that centred in the region) and written
//! instead.

use crate::chart::PreparedChart;
use crate::domain::start::{Fit, Shape, StartKind, fit_into_room};
use crate::solver::ChartSolver;
use glam::DVec2;

/// Settles `solver` (finished, of `prepared`'s chart) as the module docs
/// say; `step_one` is the chart's step-1 layout, the yardstick on the square.
pub fn settle(prepared: &PreparedChart, step_one: Option<&[DVec2]>, solver: &mut ChartSolver) {
    let problem = solver.problem();
    let tolerance = solver.options().tolerance;
    let layout = solver.layout();
    let short = problem
        .constraint_vertices
        .iter()
        .zip(&problem.targets)
        .any(|(&v, &t)| layout[v as usize].distance(t) > tolerance);
    if !short {
        return;
    }
    let stretch = |l: &[DVec2]| crate::solver::own::stretch(prepared, l);
    let now = stretch(layout);
    let Some((yardstick, candidates)) = own_shape(prepared, step_one, solver) else {
        return;
    };
    let own = stretch(&yardstick);
    solver.note_own_stretch(own);
    let bound = crate::solver::SETTLE_FACTOR * own.l2;
    let storable = |l: &[DVec2]| crate::guard::all_positive_as_stored(l, &prepared.filled.mesh.triangles);
    if now.l2 <= bound && storable(solver.layout()) {
        return;
    }
    let best = candidates
        .into_iter()
        .map(|c| (stretch(&c).l2, c))
        .filter(|(l2, _)| l2.is_finite())
        .find(|(l2, _)| *l2 <= bound)
        .or_else(|| Some((stretch(&yardstick).l2, yardstick)).filter(|(l2, y)| l2.is_finite() && storable(y)));
    if let Some((_, layout)) = best {
        solver.settle_for(layout, now);
    }
}

/// The chart's own shape: the yardstick layout (its free layout without
/// landmarks, centred in its region, or step 1's square) and the
/// placements to try first (that shape fitted to the targets), each
/// fold-free as stored and admitted by its room; `None` when there is
/// none.
fn own_shape(
    prepared: &PreparedChart,
    step_one: Option<&[DVec2]>,
    solver: &ChartSolver,
) -> Option<(Vec<DVec2>, Vec<Vec<DVec2>>)> {
    let f = &prepared.filled;
    let Some(free) = solver.free() else {
        return Some((step_one?.to_vec(), Vec::new()));
    };
    let base = crate::solver::own::free_layout(prepared, solver.options())?;
    let room = &free.domain.room;
    let fits = |layout: &[DVec2]| {
        crate::guard::all_positive_as_stored(layout, &f.mesh.triangles) && room.admits(layout).is_ok()
    };
    let (lo, hi) = room.setup().region.layout_box();
    let (blo, bhi) = crate::injective::bounds(&base);
    let k = 0.9 * ((hi - lo) / (bhi - blo).max(DVec2::splat(1e-300))).min_element();
    let centred: Vec<DVec2> = base
        .iter()
        .map(|&p| 0.5 * (lo + hi) + (p - 0.5 * (blo + bhi)) * k)
        .collect();
    if !fits(&centred) {
        return None;
    }
    let shape = Shape::of(f);
    let fitted = fit_into_room(
        room,
        &shape,
        &base,
        solver.problem(),
        StartKind::Conformal,
        Fit::ToTargetsAsShaped,
    )
    .map(|c| c.layout)
    .filter(|l| fits(l));
    Some((centred, fitted.into_iter().collect()))
}
