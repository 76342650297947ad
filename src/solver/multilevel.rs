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
use crate::mesh::TriMesh;
use crate::mesh::topology::Topology;
use crate::multilevel::coarsen::{Hierarchy, Plan, Role, coarsen};
use crate::multilevel::outline::Outline;
use crate::multilevel::prolong::{LoopRule, ProlongError, prolong};
use crate::multilevel::smooth::{LoopRoom, smooth, smooth_near};
use crate::param::bar_net::{FilledChart, fill_holes};
use crate::param::boundary::{BoundaryMap, TrapCandidates};
use crate::rbf::stepping::StepProblem;
use glam::DVec2;
use std::sync::Arc;
use std::time::Instant;

/// What the coarse level did, for the report.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
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
    /// The first vertex the prolongation found no place for until the level
    /// swept on.
    pub stuck: Option<String>,
    /// `time_budget_ms` ran out while prolonging: the stages after it were
    /// put back without their sweeps (still fold-free, less polished).
    pub out_of_time: bool,
}

/// Why a large chart's coarse level was not used (it was then solved at
/// its own level).
#[derive(Debug, Clone, PartialEq, thiserror::Error, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Missed {
    #[error("the coarse level is not a disk with the chart's holes")]
    NotADisk,
    #[error("the coarse level's solve failed: {0}")]
    SolveFailed(String),
    #[error("the coarse level's solve ended {0:.1e} short of the targets")]
    Short(f64),
    #[error("prolonging it: {0}")]
    Prolong(String),
    #[error("its room does not admit the prolonged layout: {0}")]
    NoRoom(String),
}

/// A chart's coarse level has this share of its vertices (up to
/// `multilevel_coarse`): small enough to solve in a fraction of the time.
const COARSENING: usize = 16;

/// Each stage of the prolongation brings back this many times the
/// vertices present before it, then sweeps.
const STAGE_GROWTH: usize = 4;

/// Local sweeps per stage, at most.
const SWEEPS: u32 = 8;

/// A prolongation that finds a vertex no place is swept this many times
/// more, and tried again, at most this many times.
const STUCK_SWEEPS: u32 = 40;
const STUCK: u32 = 8;

/// ... over the vertices this many edges around the ring.
const STUCK_RINGS: usize = 4;

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// Whether `inputs`' chart is solved from a coarse level: larger than
/// `multilevel_above`, and free or on the square without a landmark on its
/// outer loop (which the boundary map places).
pub fn applies(inputs: &SolverInputs) -> bool {
    let p = inputs.prepared;
    let on_loop = |v: &u32| inputs.boundary.loop_vertices.contains(v);
    p.filled.mesh.n_vertices() > inputs.options.multilevel_above
        && (p.domain.free().is_some() || !p.constraint_vertices.iter().any(on_loop))
}

/// A chart's coarse level, made and not yet solved: the coarse chart, and
/// how to undo the collapses that made it.
#[derive(Debug, Clone)]
pub struct Level {
    hierarchy: Hierarchy,
    roles: Vec<Role>,
    outer: u32,
    /// The coarse level as a chart of its own.
    pub coarse: PreparedChart,
    /// Each of its filled vertices' fine id.
    pub fine_of: Vec<u32>,
    /// Milliseconds the coarsening took.
    pub coarsen_ms: f64,
}

impl Level {
    /// `inputs`' chart coarsened to about `target` vertices, its landmarks
    /// (and on the square the corners its boundary map placed) kept.
    ///
    /// # Errors
    /// The coarse level is not a disk with the chart's holes.
    pub fn make(inputs: &SolverInputs, target: usize) -> Result<Level, Missed> {
        let t0 = Instant::now();
        let prepared = inputs.prepared;
        let corners = prepared
            .domain
            .free()
            .is_none()
            .then(|| inputs.boundary.corner_vertices());
        let (hierarchy, roles, outer) = level(prepared, corners, target);
        let (coarse, fine_of) = coarse_chart(prepared, &hierarchy, corners).ok_or(Missed::NotADisk)?;
        Ok(Level {
            hierarchy,
            roles,
            outer,
            coarse,
            fine_of,
            coarsen_ms: ms(t0),
        })
    }

    /// The fine chart's layout from the coarse level's `coarse_layout`
    /// (meeting the targets): the collapses undone stage by stage, each
    /// settled by local sweeps, every triangle kept positive.
    ///
    /// # Errors
    /// A stage that could not be put back.
    pub fn prolong(
        mut self,
        inputs: &SolverInputs,
        coarse_layout: &[DVec2],
    ) -> Result<(Vec<DVec2>, MultilevelStats), Missed> {
        let t0 = Instant::now();
        let prepared = inputs.prepared;
        let filled = &prepared.filled;
        let n = filled.mesh.n_vertices();
        let mut stats = MultilevelStats {
            coarse_vertices: self.hierarchy.n_coarse(),
            coarsen_ms: self.coarsen_ms,
            ..MultilevelStats::default()
        };
        let mut layout = vec![DVec2::splat(f64::NAN); n];
        for (k, &v) in self.fine_of.iter().enumerate() {
            layout[v as usize] = coarse_layout[k];
        }
        // A free outer loop moves in the sweeps unless other islands are near:
        // then it stays where the prolongation put it; on the square it stays.
        let free = prepared.domain.free();
        let square = free.is_none();
        let loop_moves = free.is_some_and(|f| f.obstacles.is_empty());
        let held: Vec<bool> = self
            .roles
            .iter()
            .map(|&r| r == Role::Kept || (!loop_moves && r == Role::Loop(self.outer)))
            .collect();
        let region = free.map_or((DVec2::ZERO, DVec2::ONE), |f| f.region.layout_box());
        let deadline = inputs
            .options
            .time_budget_ms
            .map(|budget| t0 + std::time::Duration::from_secs_f64((budget - inputs.elapsed_ms).max(0.0) * 1e-3));
        settle_stages(
            &mut self.hierarchy,
            filled,
            (&held, loop_moves, square),
            (region, deadline),
            &mut layout,
            &mut stats,
        )?;
        stats.prolong_ms = ms(t0);
        Ok((layout, stats))
    }
}

/// The coarse level's size for a chart of `n` filled vertices: a
/// sixteenth of it, within 500 and `multilevel_coarse`.
pub fn coarse_size(n: usize, options: &super::SolverOptions) -> usize {
    (n / COARSENING).clamp(options.multilevel_coarse.min(500), options.multilevel_coarse)
}

/// The start of `inputs`' chart from its coarse level (see the module
/// docs); it must [`apply`](applies).
///
/// # Errors
/// Why a level could not be made, solved or prolonged.
pub fn coarse_start(inputs: &SolverInputs) -> Result<(Vec<DVec2>, MultilevelStats), Missed> {
    let n = inputs.prepared.filled.mesh.n_vertices();
    let level = Level::make(inputs, coarse_size(n, inputs.options))?;
    let t1 = Instant::now();
    let coarse_layout = solve_coarse(inputs, &level.coarse)?;
    let solve_ms = ms(t1);
    let (layout, mut stats) = level.prolong(inputs, &coarse_layout)?;
    stats.coarse_solve_ms = solve_ms;
    Ok((layout, stats))
}

/// The free domain of `inputs`' chart started from the prolonged `layout`
/// as it is.
///
/// # Errors
/// Why not: its room does not admit it, a triangle folds (in double
/// precision or as stored), or the domain cannot start from it.
pub fn start_in(
    inputs: &SolverInputs,
    chart: &ChartParts,
    problem: &StepProblem,
    layout: Vec<DVec2>,
) -> Result<(Vec<DVec2>, SolveDomain), Missed> {
    let Domain::Free(setup) = &inputs.prepared.domain else {
        return Err(Missed::NoRoom("not a free chart".into()));
    };
    let room = crate::free::room::Room::new(setup.clone(), chart.topology, &chart.filled.mesh.triangles);
    if let Err(v) = room.admits(&layout) {
        return Err(Missed::NoRoom(v.to_string()));
    }
    if let Some(t) = crate::guard::first_non_positive(&layout, &chart.filled.mesh.triangles) {
        return Err(Missed::NoRoom(format!("triangle {t} folds")));
    }
    if !crate::guard::all_positive_as_stored(&layout, &chart.filled.mesh.triangles) {
        return Err(Missed::NoRoom("a triangle folds as stored (f32)".into()));
    }
    let given = Domain::Free(Arc::new(setup.starting_from(layout, StartKind::Coarse)));
    SolveDomain::start(&given, chart, problem).map_err(|e| Missed::NoRoom(e.to_string()))
}

/// `prepared`'s filled chart coarsened to about `target` vertices (on the
/// square with its `corners` kept), with each vertex's [`roles`] and the
/// outer loop's index.
fn level(prepared: &PreparedChart, corners: Option<[u32; 4]>, target: usize) -> (Hierarchy, Vec<Role>, u32) {
    let filled = &prepared.filled;
    let (roles, outer) = roles(prepared, corners);
    let plan = Plan {
        role: &roles,
        outer,
        virtual_from: filled.n_real_vertices,
        target,
        square: corners.is_some(),
    };
    (coarsen(&filled.mesh, plan), roles, outer)
}

/// A coarse level of `prepared` with about `target` vertices, as a chart
/// of its own (its landmarks and, on the square, the corners `boundary`
/// placed are kept), and each of its filled vertices' fine id: a quick
/// stand-in for the chart while its targets move. Exact where it matters
/// to the eye: the landmarks are its vertices. `None` if it is not a disk
/// with the chart's holes.
pub fn coarse_level(
    prepared: &PreparedChart,
    boundary: &BoundaryMap,
    target: usize,
) -> Option<(PreparedChart, Vec<u32>)> {
    let corners = prepared.domain.free().is_none().then(|| boundary.corner_vertices());
    let (hierarchy, ..) = level(prepared, corners, target);
    coarse_chart(prepared, &hierarchy, corners)
}

/// What each filled vertex may do in the coarsening: the landmarks, the
/// virtual hole centres and the square's `corners` stay; loop vertices
/// move along their loop.
fn roles(prepared: &PreparedChart, corners: Option<[u32; 4]>) -> (Vec<Role>, u32) {
    let filled = &prepared.filled;
    let mut roles = vec![Role::Inner; filled.mesh.n_vertices()];
    for (k, l) in prepared.topology.loops.iter().enumerate() {
        l.iter().for_each(|&v| roles[v as usize] = Role::Loop(k as u32));
    }
    for &v in &prepared.constraint_vertices {
        roles[v as usize] = Role::Kept;
    }
    roles[filled.n_real_vertices..].fill(Role::Kept);
    corners
        .into_iter()
        .flatten()
        .for_each(|v| roles[v as usize] = Role::Kept);
    (roles, prepared.topology.outer as u32)
}

/// The coarse level as a chart of its own (its real vertices and
/// triangles, its holes filled anew), and each of its filled vertices'
/// fine id. `None` if it is not a disk with the same holes.
fn coarse_chart(
    prepared: &PreparedChart,
    hierarchy: &Hierarchy,
    corners: Option<[u32; 4]>,
) -> Option<(PreparedChart, Vec<u32>)> {
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
    let domain = coarse_domain(prepared, &fine_ids, &coarse_filled);
    let coarse = PreparedChart {
        domain,
        chart: Arc::new(chart),
        traps: Arc::new(TrapCandidates::find(&real, &topology)),
        topology: Arc::new(topology),
        filled: Arc::new(coarse_filled),
        constraint_vertices,
        corners: corners
            .map(|c| c.map(coarse_of_fine))
            .map(|c| c.map(Option::unwrap_or_default)),
        ..prepared.clone()
    };
    Some((coarse, fine_ids))
}

/// The fine chart's domain for its coarse level: free in the same region
/// (a level solved in a room inset from it falls short of targets the
/// chart reaches, while a fine loop put back outside the region is caught
/// where the level is prolonged), a given start taken at the coarse
/// vertices (`fine_ids`), its few triangles the collapses turned over
/// (slivers of a camera's view) settled ([`crate::domain::unfold::settle`]),
/// and left out where it still folds there.
fn coarse_domain(prepared: &PreparedChart, fine_ids: &[u32], coarse: &FilledChart) -> Domain {
    let Domain::Free(setup) = &prepared.domain else {
        return Domain::Square;
    };
    let mut setup = (**setup).clone();
    if let Some(given) = &setup.given {
        let mut layout: Vec<DVec2> = fine_ids.iter().map(|&f| given.layout[f as usize]).collect();
        let landmark = crate::domain::unfold::pinned(prepared.filled.mesh.n_vertices(), &prepared.constraint_vertices);
        let pinned: Vec<bool> = fine_ids.iter().map(|&f| landmark[f as usize]).collect();
        crate::domain::unfold::settle(&mut layout, &coarse.mesh.triangles, &pinned);
        setup.given = crate::guard::all_positive(&layout, &coarse.mesh.triangles).then(|| crate::free::GivenStart {
            layout: Arc::new(layout),
            kind: given.kind,
        });
    }
    Domain::Free(Arc::new(setup))
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
fn solve_coarse(inputs: &SolverInputs, coarse: &PreparedChart) -> Result<Vec<DVec2>, Missed> {
    let failed = |e: crate::error::Error| Missed::SolveFailed(e.to_string());
    let (boundary, net, step1) = step_one::run(coarse, inputs.source, std::path::Path::new("")).map_err(failed)?;
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
    .map_err(failed)?;
    solver.run().map_err(failed)?;
    let short = solver.max_residual();
    if short > options.tolerance {
        return Err(Missed::Short(short));
    }
    Ok(solver.layout().to_vec())
}

/// Undoes the collapses in stages of [`STAGE_GROWTH`], each settled by
/// local sweeps of the stage's own shapes, the vertices `held` marks (the
/// landmarks, the hole centres) in place; the outer loop moves with
/// `loop_moves` (inside `region`, never meeting itself), else stays. Past
/// `deadline` (the time budget) the stages are put back without sweeps.
fn settle_stages(
    hierarchy: &mut Hierarchy,
    filled: &FilledChart,
    (held, loop_moves, square): (&[bool], bool, bool),
    (region, deadline): ((DVec2, DVec2), Option<Instant>),
    layout: &mut [DVec2],
    stats: &mut MultilevelStats,
) -> Result<(), Missed> {
    let n = filled.mesh.n_vertices();
    let mut stuck = 0;
    let mut rule = if square {
        LoopRule::OnSide
    } else {
        LoopRule::Free {
            outline: Outline::of(hierarchy),
            region,
        }
    };
    while !hierarchy.collapses.is_empty() {
        let until = (hierarchy.n_coarse() * STAGE_GROWTH).min(n);
        let prolonged = prolong(hierarchy, &filled.mesh.positions, layout, until, &mut rule);
        stats.out_of_time |= deadline.is_some_and(|d| Instant::now() >= d);
        if let (true, Ok(p)) = (stats.out_of_time, &prolonged) {
            stats.in_kernel += p.in_kernel;
            continue;
        }
        let (triangles, rest) = stage_shapes(hierarchy, filled, layout);
        let movable: Vec<bool> = (0..n).map(|v| hierarchy.present[v] && !held[v]).collect();
        let room = match &rule {
            LoopRule::Free { outline, region } if loop_moves => Some(LoopRoom {
                outline,
                region: *region,
            }),
            _ => None,
        };
        match prolonged {
            Ok(p) => {
                stats.in_kernel += p.in_kernel;
                stats.sweeps += smooth(layout, &triangles, &rest, &movable, SWEEPS, room).sweeps;
            }
            // A ring with no place for its vertex: its surroundings sweep
            // on, which reshapes it, and it is tried again.
            Err(ProlongError::NoKernel { vertex, ring }) if stuck < STUCK => {
                stuck += 1;
                stats
                    .stuck
                    .get_or_insert_with(|| format!("vertex {vertex} found no place"));
                let shapes = (&triangles[..], &rest[..]);
                smooth_near(layout, shapes, &movable, (&ring, STUCK_RINGS), STUCK_SWEEPS, room);
            }
            Err(e) => return Err(Missed::Prolong(e.to_string())),
        }
    }
    Ok(())
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
