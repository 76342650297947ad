//! A large free chart's start from a coarse level of it ([`crate::multilevel`]):
//! the filled chart coarsened to about `multilevel_coarse` vertices, that
//! level solved in full (step 1, the spline path, completion, polish), then
//! prolonged back stage by stage, each stage settled by local sweeps. The
//! landmarks are coarse vertices, so the prolonged layout meets the targets
//! exactly; every triangle is kept positive on the way. The chart's own
//! free solve then starts from it (its polish, where the chart is small
//! enough for one). `None` whenever a level cannot be made or solved: the
//! chart is then solved at its own level as it always was.

use super::{ChartSolver, SolverInputs, step_one};
use crate::chart::PreparedChart;
use crate::complete::energy::{RestTriangle, rest_shapes};
use crate::domain::Domain;
use crate::domain::solve::{ChartParts, SolveDomain};
use crate::domain::start::StartKind;
use crate::free::{FreeSetup, GivenStart};
use crate::mesh::TriMesh;
use crate::mesh::topology::Topology;
use crate::multilevel::coarsen::{Hierarchy, Role, coarsen};
use crate::multilevel::prolong::prolong;
use crate::multilevel::smooth::smooth;
use crate::param::bar_net::{FilledChart, fill_holes};
use crate::param::boundary::TrapCandidates;
use crate::rbf::stepping::StepProblem;
use glam::DVec2;
use std::sync::Arc;
use std::time::Instant;

/// What the coarse level did, for the report.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct MultilevelStats {
    /// Vertices of the coarse level (of the filled chart).
    pub coarse_vertices: usize,
    /// Milliseconds: coarsening, the coarse solve, prolonging with sweeps.
    pub coarsen_ms: f64,
    pub coarse_solve_ms: f64,
    pub prolong_ms: f64,
    /// Vertices put back in their ring's kernel, not where their star placed them.
    pub in_kernel: usize,
    /// Local sweeps, over every stage.
    pub sweeps: u32,
}

/// Each stage of the prolongation brings back this many times the
/// vertices present before it, then sweeps.
const STAGE_GROWTH: usize = 4;

/// Local sweeps per stage, at most.
const SWEEPS: u32 = 8;

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// Whether `inputs`' chart is solved from a coarse level: free, and
/// larger than `multilevel_above`.
pub fn applies(inputs: &SolverInputs) -> bool {
    inputs.prepared.domain.free().is_some()
        && inputs.prepared.filled.mesh.n_vertices() > inputs.options.multilevel_above
}

/// The start of `inputs`' chart from its coarse level (see the module
/// docs), or `None` when it does not [`apply`](applies) or a level fails.
pub fn coarse_start(inputs: &SolverInputs) -> Option<(Vec<DVec2>, MultilevelStats)> {
    let prepared = inputs.prepared;
    let filled = &prepared.filled;
    let options = inputs.options;
    let n = filled.mesh.n_vertices();
    if !applies(inputs) {
        return None;
    }
    let t0 = Instant::now();
    let (roles, outer) = roles(prepared);
    let mut hierarchy = coarsen(
        &filled.mesh,
        &roles,
        outer,
        filled.n_real_vertices,
        options.multilevel_coarse,
    );
    let mut stats = MultilevelStats {
        coarse_vertices: hierarchy.n_coarse(),
        coarsen_ms: ms(t0),
        ..MultilevelStats::default()
    };
    let t1 = Instant::now();
    let (coarse, fine_of) = coarse_chart(prepared, &hierarchy)?;
    let coarse_layout = solve_coarse(inputs, &coarse)?;
    stats.coarse_solve_ms = ms(t1);
    let t2 = Instant::now();
    let mut layout = vec![DVec2::splat(f64::NAN); n];
    for (k, &v) in fine_of.iter().enumerate() {
        layout[v as usize] = coarse_layout[k];
    }
    let held: Vec<bool> = roles
        .iter()
        .map(|&r| r == Role::Kept || r == Role::Loop(outer))
        .collect();
    settle_stages(&mut hierarchy, filled, &held, &mut layout, &mut stats)?;
    stats.prolong_ms = ms(t2);
    Some((layout, stats))
}

/// The free domain of `inputs`' chart started from the prolonged `layout`
/// (shrunk just enough to fit its room); `None` if its room admits no such
/// placement.
pub fn start_in(
    inputs: &SolverInputs,
    chart: &ChartParts,
    problem: &StepProblem,
    layout: Vec<DVec2>,
) -> Option<(Vec<DVec2>, SolveDomain)> {
    let Domain::Free(setup) = &inputs.prepared.domain else {
        return None;
    };
    let given = Domain::Free(Arc::new(FreeSetup {
        given: Some(GivenStart {
            layout: Arc::new(layout),
            kind: StartKind::Coarse,
        }),
        ..(**setup).clone()
    }));
    SolveDomain::start(&given, chart, problem).ok()
}

/// What each filled vertex may do in the coarsening: the landmarks and the
/// virtual hole centres stay; loop vertices move along their loop.
fn roles(prepared: &PreparedChart) -> (Vec<Role>, u32) {
    let filled = &prepared.filled;
    let mut roles = vec![Role::Inner; filled.mesh.n_vertices()];
    for (k, l) in prepared.topology.loops.iter().enumerate() {
        l.iter().for_each(|&v| roles[v as usize] = Role::Loop(k as u32));
    }
    for &v in &prepared.constraint_vertices {
        roles[v as usize] = Role::Kept;
    }
    roles[filled.n_real_vertices..].fill(Role::Kept);
    (roles, prepared.topology.outer as u32)
}

/// The coarse level as a chart of its own (its real vertices and
/// triangles, its holes filled anew), and each of its filled vertices'
/// fine id. `None` if it is not a disk with the same holes.
fn coarse_chart(prepared: &PreparedChart, hierarchy: &Hierarchy) -> Option<(PreparedChart, Vec<u32>)> {
    let filled = &prepared.filled;
    let n_real = filled.n_real_vertices as u32;
    let (mesh, fine_of) = hierarchy.coarse_mesh(&filled.mesh.positions);
    let n_real_coarse = fine_of.iter().take_while(|&&v| v < n_real).count();
    let real = TriMesh {
        positions: mesh.positions[..n_real_coarse].to_vec(),
        triangles: mesh
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&v| (v as usize) < n_real_coarse))
            .copied()
            .collect(),
    };
    let topology = Topology::build(&real).ok()?;
    if topology.loops.len() != prepared.topology.loops.len() {
        return None;
    }
    let coarse_filled = fill_holes(&real, &topology);
    let mut fine_ids = fine_of[..n_real_coarse].to_vec();
    fine_ids.extend(virtual_ids(filled, &coarse_filled, &fine_of)?);
    let coarse_of_fine = |v: u32| fine_of.binary_search(&v).ok().map(|k| k as u32);
    let constraint_vertices = prepared
        .constraint_vertices
        .iter()
        .map(|&v| coarse_of_fine(v))
        .collect::<Option<Vec<u32>>>()?;
    let chart = prepared.chart.subset(&fine_of[..n_real_coarse], real.triangles.clone());
    let coarse = PreparedChart {
        chart: Arc::new(chart),
        traps: Arc::new(TrapCandidates::find(&real, &topology)),
        topology: Arc::new(topology),
        filled: Arc::new(coarse_filled),
        constraint_vertices,
        corners: None,
        ..prepared.clone()
    };
    Some((coarse, fine_ids))
}

/// The fine virtual vertex of each of the coarse level's holes: the fine
/// hole holding its loop's first vertex.
fn virtual_ids(filled: &FilledChart, coarse: &FilledChart, fine_of: &[u32]) -> Option<Vec<u32>> {
    let mut hole_of = vec![u32::MAX; filled.n_real_vertices];
    for (h, hole) in filled.holes.iter().enumerate() {
        hole.iter().for_each(|&v| hole_of[v as usize] = h as u32);
    }
    coarse
        .holes
        .iter()
        .map(|hole| {
            let h = hole_of[fine_of[*hole.first()? as usize] as usize];
            (h != u32::MAX).then(|| (filled.n_real_vertices + h as usize) as u32)
        })
        .collect()
}

/// The coarse chart solved in full; its layout if it reached the targets.
fn solve_coarse(inputs: &SolverInputs, coarse: &PreparedChart) -> Option<Vec<DVec2>> {
    let boundary = step_one::map_boundary(coarse, inputs.source).ok()?;
    let net = step_one::factor_bar_net(coarse, &boundary, std::path::Path::new("")).ok()?;
    let step1 = step_one::solve_force_density(coarse, &boundary, &net);
    let options = super::SolverOptions {
        multilevel_above: usize::MAX,
        ..*inputs.options
    };
    let mut solver = ChartSolver::new(SolverInputs {
        prepared: coarse,
        options: &options,
        boundary: &boundary,
        step1: &step1,
        bar_net: Some(&net),
        pattern: None,
        ..*inputs
    })
    .ok()?;
    solver.run().ok()?;
    let reached = solver.max_residual() <= options.tolerance;
    reached.then(|| solver.layout().to_vec())
}

/// Undoes the collapses in stages of [`STAGE_GROWTH`], each settled by
/// local sweeps of the stage's own shapes, the vertices `held` marks (the
/// landmarks, the hole centres, the outer loop) in place.
fn settle_stages(
    hierarchy: &mut Hierarchy,
    filled: &FilledChart,
    held: &[bool],
    layout: &mut [DVec2],
    stats: &mut MultilevelStats,
) -> Option<()> {
    let n = filled.mesh.n_vertices();
    while !hierarchy.collapses.is_empty() {
        let until = (hierarchy.n_coarse() * STAGE_GROWTH).min(n);
        let p = prolong(hierarchy, &filled.mesh.positions, layout, until).ok()?;
        stats.in_kernel += p.in_kernel;
        let (triangles, rest) = stage_shapes(hierarchy, filled, layout);
        let movable: Vec<bool> = (0..n).map(|v| hierarchy.present[v] && !held[v]).collect();
        stats.sweeps += smooth(layout, &triangles, &rest, &movable, SWEEPS).sweeps;
    }
    Some(())
}

/// The triangles present at this stage (real ones first) and their rest
/// shapes at the scale of their layout.
fn stage_shapes(hierarchy: &Hierarchy, filled: &FilledChart, layout: &[DVec2]) -> (Vec<[u32; 3]>, Vec<RestTriangle>) {
    let n_real = filled.n_real_vertices as u32;
    let alive = || {
        hierarchy
            .triangles
            .iter()
            .zip(&hierarchy.alive)
            .filter(|(_, a)| **a)
            .map(|(t, _)| *t)
    };
    let mut triangles: Vec<[u32; 3]> = alive().filter(|t| t.iter().all(|&v| v < n_real)).collect();
    let n_real_triangles = triangles.len();
    triangles.extend(alive().filter(|t| t.iter().any(|&v| v >= n_real)));
    let area: f64 = triangles[..n_real_triangles]
        .iter()
        .map(|t| 0.5 * crate::guard::orientation(layout[t[0] as usize], layout[t[1] as usize], layout[t[2] as usize]))
        .sum();
    let rest = rest_shapes(
        &filled.mesh.positions,
        &triangles,
        n_real_triangles,
        crate::complete::VIRTUAL_WEIGHT,
    );
    (triangles, crate::complete::context::scaled(rest, area))
}
