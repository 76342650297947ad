//! The domain of a running solve: on the square nothing but step 1's
//! layout; free, the chart's room and scaffold and the start fitted to the
//! targets. The chart solver asks its domain where to start, what it
//! admits, which Newton context to use and how to end.

use super::Domain;
use super::start::{ChosenStart, Fit, StartKind, choose_start};
use crate::complete::context::{FreeDomain, NewtonContext};
use crate::complete::pattern::PendingNewtonPattern;
use crate::error::Error;
use crate::free::room::Room;
use crate::free::scaffold::Scaffold;
use crate::free::{FreeSetup, Obstacles};
use crate::mesh::topology::Topology;
use crate::param::bar_net::FilledChart;
use crate::rbf::stepping::StepProblem;
use glam::DVec2;
use std::sync::Arc;
use std::time::Instant;

/// A chart as its domain needs it to start a solve.
#[derive(Debug, Clone, Copy)]
pub struct ChartParts<'a> {
    /// The chart's id (named in errors).
    pub id: u32,
    pub filled: &'a Arc<FilledChart>,
    pub topology: &'a Topology,
    /// The step-1 layout of the filled chart.
    pub step1: &'a [DVec2],
    pub pattern: &'a PendingNewtonPattern,
}

/// Where a running solve's layout lives.
#[derive(Debug, Clone)]
pub enum SolveDomain {
    /// The outer loop on the square, where step 1 put it.
    Square,
    /// Free inside a region: the room, scaffold and start.
    Free(FreeSolve),
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

impl SolveDomain {
    /// The domain of `domain` for `chart` and its start layout: step 1's on
    /// the square; free, the start fitted to the targets (relaxed when it
    /// was not laid through them) with the scaffold's fixed points appended.
    ///
    /// # Errors
    /// The free start cannot be built (no placement fits its region).
    pub fn start(domain: &Domain, chart: &ChartParts, problem: &StepProblem) -> Result<(Vec<DVec2>, Self), Error> {
        match domain {
            Domain::Square => Ok((chart.step1.to_vec(), SolveDomain::Square)),
            Domain::Free(setup) => {
                let (layout, solve) = open_free(chart, setup, problem)?;
                Ok((layout, SolveDomain::Free(solve)))
            }
        }
    }

    /// A free chart's room, scaffold and start (`None` on the square).
    pub fn free(&self) -> Option<&FreeSolve> {
        match self {
            SolveDomain::Square => None,
            SolveDomain::Free(f) => Some(f),
        }
    }

    /// Whether `layout` stays in the domain: on the square always (its
    /// loop does not move); free, one-to-one inside the region and clear of
    /// the other islands.
    pub fn admits(&self, layout: &[DVec2]) -> bool {
        self.free().is_none_or(|f| f.domain.room.admits(layout).is_ok())
    }

    /// The Newton context of the completion and polish over this domain.
    pub fn newton_context(
        &self,
        filled: &FilledChart,
        problem: &StepProblem,
        pattern: Arc<crate::complete::newton::NewtonPattern>,
        layout: &[DVec2],
    ) -> NewtonContext {
        match self {
            SolveDomain::Square => NewtonContext::new(filled, problem, pattern, layout),
            SolveDomain::Free(f) => NewtonContext::free(filled, pattern, layout, f.domain.clone(), f.rest_area),
        }
    }

    /// Before the polish of a free chart on two or more targets: its rest
    /// shapes take the scale its layout fits best, the scale the targets
    /// made, so the polish does not press it larger or smaller than they allow.
    pub fn fit_rest_scale(&mut self, context: &mut NewtonContext, layout: &[DVec2], problem: &StepProblem) {
        if let SolveDomain::Free(free) = self
            && problem.targets.len() >= 2
        {
            free.rest_area = context.fit_rest_scale(layout);
        }
    }

    /// Once the solve is done: a free chart that no two targets size is
    /// scaled up to the largest that fits its room
    /// ([`super::start::fill_region`]); an island keeps its size.
    pub fn finish(&self, layout: &mut [DVec2], shape: &super::start::Shape, problem: &StepProblem) {
        let SolveDomain::Free(free) = self else {
            return;
        };
        if free.start == StartKind::Island || problem.targets.len() >= 2 {
            return;
        }
        let pivot = problem.targets.first().copied();
        super::start::fill_region(&free.domain.room, layout, shape, pivot);
    }
}

/// A free chart's solve: its room and scaffold, where it started.
#[derive(Debug, Clone)]
pub struct FreeSolve {
    /// The room (global injectivity inside the region) and the scaffold.
    pub domain: FreeDomain,
    /// Which layout it started from.
    pub start: StartKind,
    /// The layout area the rest shapes are scaled to.
    pub rest_area: f64,
    /// How much the start was shrunk to fit its room (1: not at all).
    pub shrink: f64,
    /// Newton steps that relaxed the start before the spline path.
    pub relax_steps: u32,
    /// Milliseconds spent on the start (conformal solve, fitting) and on
    /// triangulating scaffolds.
    pub start_ms: f64,
}

/// Newton steps at most that relax a free start before the spline path:
/// a conformal start is near its shape already; step 1's square (the
/// conformal layout folded: a chart cut open along a seam tree, a long
/// thin one) is far from it.
const fn relax_steps(kind: StartKind) -> u32 {
    match kind {
        StartKind::StepOne => 100,
        _ => 3,
    }
}

/// Relaxing stops once a step gains less than this (relative): soon for a
/// conformal start, late for step 1's, whose energy first falls slowly.
const fn relax_gain(kind: StartKind) -> f64 {
    match kind {
        StartKind::StepOne => 0.002,
        _ => 0.05,
    }
}

/// A free chart's start ([`choose_start`]) with its scaffold's fixed points
/// appended, and its room.
///
/// # Errors
/// The Newton pattern could not be built, or no placement fits the region
/// (other islands fill it).
fn open_free(
    chart: &ChartParts,
    setup: &Arc<FreeSetup>,
    problem: &StepProblem,
) -> Result<(Vec<DVec2>, FreeSolve), Error> {
    let t0 = Instant::now();
    let filled = chart.filled;
    let triangles = &filled.mesh.triangles;
    let room = Arc::new(Room::new(setup.clone(), chart.topology, triangles));
    let no_room = || Error::NoRoom {
        chart: chart.id,
        region: setup.region,
    };
    // A given start needs no Newton system (a large chart's may never); one
    // that does not fit (other islands where it lies) falls back to the
    // chart's own start.
    let given = setup
        .given
        .as_ref()
        .and_then(|_| super::start::given_start(&room, filled, problem));
    let chosen = match given {
        Some(start) => start,
        None => {
            let system = newton_system(chart)?;
            let rest = crate::complete::energy::rest_shapes(
                &filled.mesh.positions,
                triangles,
                filled.n_real_triangles,
                crate::complete::VIRTUAL_WEIGHT,
            );
            choose_start(&room, filled, &rest, &system, chart.step1, problem).ok_or_else(no_room)?
        }
    };
    let ChosenStart {
        mut layout,
        kind,
        rest_area,
        shrink,
    } = chosen;
    let (lo, hi) = setup.region.layout_box();
    let scaffold = Arc::new(Scaffold::new(
        lo,
        hi,
        &nearby(&setup.obstacles, &layout),
        room.boundary_vertices().len(),
    ));
    let offset = layout.len() as u32;
    layout.extend_from_slice(scaffold.fixed_points());
    let domain = FreeDomain::new(room, scaffold, offset);
    let (mut rest_area, mut shrink, mut relax_steps) = (rest_area, shrink, 0);
    let far_from_shape = kind == StartKind::StepOne || (kind == StartKind::Conformal && problem.targets.len() >= 2);
    if far_from_shape {
        let pattern = newton_system(chart)?.pattern().clone();
        let relaxed = relax(filled, &pattern, &mut layout, &domain, rest_area, problem, kind);
        if let Some((refit, steps)) = relaxed {
            layout[..refit.layout.len()].copy_from_slice(&refit.layout);
            (rest_area, shrink, relax_steps) = (refit.rest_area, refit.shrink, steps);
        }
    }
    let solve = FreeSolve {
        domain,
        start: kind,
        rest_area,
        shrink,
        relax_steps,
        start_ms: ms(t0),
    };
    Ok((layout, solve))
}

/// The islands within the chart's start box widened by its size on every
/// side: the scaffold keeps the chart's steps off them; farther ones are
/// kept off by the room's check alone (a scaffold over every island of a
/// large atlas would be rebuilt at every Newton step).
fn nearby(obstacles: &Arc<Obstacles>, layout: &[DVec2]) -> Obstacles {
    let (lo, hi) = crate::injective::bounds(layout);
    let reach = (hi - lo).max_element();
    obstacles.near_layout(lo - reach, hi + reach)
}

/// The Newton system over the chart's vertices (its pattern built now if
/// it was not).
///
/// # Errors
/// The pattern could not be built (never for a valid mesh).
fn newton_system(chart: &ChartParts) -> Result<crate::complete::newton::NewtonSystem, Error> {
    let pattern = chart
        .pattern
        .get()
        .map_err(|e| Error::Internal(format!("free-boundary system: {e}")))?;
    Ok(crate::complete::newton::NewtonSystem::new(pattern))
}

/// Relaxes a free start toward its own low-distortion shape (symmetric
/// Dirichlet, nothing held, [`relax_steps`] Newton steps at most), then fits
/// it to the targets again: the spline path then only has to bend it a
/// little, and the fit's scale is the one the targets ask for. `None` if no
/// step gained or the refit does not fit the room.
fn relax(
    filled: &FilledChart,
    pattern: &Arc<crate::complete::newton::NewtonPattern>,
    layout: &mut [DVec2],
    domain: &FreeDomain,
    rest_area: f64,
    problem: &StepProblem,
    kind: StartKind,
) -> Option<(ChosenStart, u32)> {
    let mut context = NewtonContext::free(filled, pattern.clone(), layout, domain.clone(), rest_area);
    let mut steps = 0;
    while steps < relax_steps(kind) {
        let request = crate::complete::context::StepRequest {
            reference: None,
            soft: None,
            held: None,
            tolerance: relax_gain(kind),
        };
        let step = context.step(layout, request);
        steps += u32::from(step.alpha > 0.0);
        if step.converged || step.alpha == 0.0 || step.energy_after > (1.0 - relax_gain(kind)) * step.energy_before {
            break;
        }
    }
    if steps == 0 {
        return None;
    }
    let n = filled.mesh.n_vertices();
    let shape = super::start::Shape::of(filled);
    let refit = super::start::fit_into_room(
        &domain.room,
        &shape,
        &layout[..n],
        problem,
        kind,
        Fit::ToTargetsAsShaped,
    )?;
    Some((refit, steps))
}
