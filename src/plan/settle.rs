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
    let Some(own) = own_shape(prepared, step_one, solver) else {
        return;
    };
    let yardstick = stretch(&own.shape);
    solver.note_own_stretch(yardstick);
    let bound = crate::solver::SETTLE_FACTOR * yardstick.l2;
    let storable = |l: &[DVec2]| crate::guard::all_positive_as_stored(l, &prepared.filled.mesh.triangles);
    if now.l2 <= bound && storable(solver.layout()) {
        return;
    }
    let best = own
        .fitted
        .into_iter()
        .map(|c| (stretch(&c).l2, c))
        .filter(|(l2, _)| l2.is_finite())
        .find(|(l2, _)| *l2 <= bound)
        .or_else(|| {
            own.centred
                .map(|c| (stretch(&c).l2, c))
                .filter(|(l2, c)| l2.is_finite() && storable(c))
        });
    if let Some((_, layout)) = best {
        solver.settle_for(layout, now);
    }
}

/// The chart's own shape and where it may be written instead.
struct OwnShape {
    /// The yardstick layout: its free layout without landmarks (centred
    /// in its region), or step 1's square.
    shape: Vec<DVec2>,
    /// That shape fitted to the targets, when its room admits it.
    fitted: Option<Vec<DVec2>>,
    /// That shape centred in its region, when its room admits it.
    centred: Option<Vec<DVec2>>,
}

/// The chart's own shape ([`OwnShape`]), each placement fold-free as
/// stored and admitted by its room; `None` when there is none.
fn own_shape(prepared: &PreparedChart, step_one: Option<&[DVec2]>, solver: &ChartSolver) -> Option<OwnShape> {
    let f = &prepared.filled;
    let Some(free) = solver.free() else {
        let shape = step_one?.to_vec();
        return Some(OwnShape {
            centred: Some(shape.clone()),
            shape,
            fitted: None,
        });
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
    Some(OwnShape {
        fitted,
        centred: fits(&centred).then(|| centred.clone()),
        shape: centred,
    })
}
