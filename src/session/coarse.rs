//! A chart's coarse level standing in for it while its targets move (the
//! editor's drag). The chart is coarsened once to as many vertices as asked
//! with its landmarks (and on the square its corners) kept as vertices
//! ([`crate::solver::multilevel::coarse_level`]); that level's step 1
//! (Eq. 1–2) is computed once, and each move solves it from its last layout
//! (the spline path of Eq. 6, the guard, the completion) without the
//! polish. An answer meets the targets exactly where the chart would, is
//! fold-free as stored, and costs a small fraction of the chart's solve,
//! whatever the chart's size; the chart itself is solved when the move ends.

use super::ChartSession;
use crate::chart::PreparedChart;
use crate::complete::pattern::PendingNewtonPattern;
use crate::domain::Domain;
use crate::domain::start::StartKind;
use crate::error::Error;
use crate::options::SolverOptions;
use crate::param::bar_net::BarNet;
use crate::param::boundary::BoundaryMap;
use crate::report::{self, Report};
use crate::solver::step_one;
use crate::solver::{ChartSolver, SolverInputs};
use glam::DVec2;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// A chart's coarse level, ready to solve (see the module docs).
#[derive(Debug, Clone)]
pub struct CoarseView {
    /// Names this level among every level made in this process.
    key: u64,
    made_for: MadeFor,
    prepared: PreparedChart,
    boundary: Arc<BoundaryMap>,
    bar_net: Arc<BarNet>,
    step_one: Arc<Vec<DVec2>>,
    pattern: Option<Arc<PendingNewtonPattern>>,
    /// The last layout reached: the next solve's start.
    last: Option<Arc<Vec<DVec2>>>,
}

/// What a level was made from: another chart, other landmarks, corners or
/// region need a level of their own.
#[derive(Debug, Clone, PartialEq)]
struct MadeFor {
    filled: usize,
    landmarks: Vec<u32>,
    corners: Option<[u32; 4]>,
    region: Option<crate::param::region::Region>,
}

impl MadeFor {
    fn of(prepared: &PreparedChart) -> Self {
        MadeFor {
            filled: Arc::as_ptr(&prepared.filled) as usize,
            landmarks: prepared.constraint_vertices.clone(),
            corners: prepared.corners,
            region: prepared.domain.free().map(|f| f.region),
        }
    }
}

/// A solve of the coarse level.
#[derive(Debug, Clone)]
pub struct CoarseSolution {
    /// The coarse level's layout (its filled vertices).
    pub layout: Vec<DVec2>,
    /// Its report: the landmarks' results are the chart's.
    pub report: Report,
}

/// The coarse level's triangles as the asset's vertices: what a viewer
/// draws in the chart's place.
#[derive(Debug, Clone, PartialEq)]
pub struct CoarseMesh {
    /// Each coarse vertex as `(k, vertex)`: a vertex of the asset's `k`-th
    /// primitive (in the asset's order).
    pub vertices: Vec<(u32, u32)>,
    /// Its triangles (the holes' fill left out).
    pub triangles: Vec<[u32; 3]>,
}

static LEVELS: AtomicU64 = AtomicU64::new(1);

impl ChartSession {
    /// This chart's coarse level of about `vertices` vertices for its
    /// current landmarks, its step 1 solved; `None` when the chart is not
    /// larger than that or its level is not a disk with the chart's holes.
    ///
    /// # Errors
    /// The chart's boundary cannot be mapped (as [`Self::map_boundary`]), or
    /// the level's step 1 fails.
    pub fn coarse_view(&mut self, vertices: usize) -> Result<Option<CoarseView>, Error> {
        if self.prepared.filled.mesh.n_vertices() <= vertices {
            return Ok(None);
        }
        self.map_boundary()?;
        let boundary = self.mapped_boundary()?;
        let Some((prepared, _)) = crate::solver::multilevel::coarse_level(&self.prepared, boundary, vertices) else {
            return Ok(None);
        };
        let (boundary, bar_net, step_one) = step_one::run(&prepared, &self.source, &self.asset.path)?;
        Ok(Some(CoarseView {
            key: LEVELS.fetch_add(1, Ordering::Relaxed),
            made_for: MadeFor::of(&self.prepared),
            prepared,
            boundary: Arc::new(boundary),
            bar_net: Arc::new(bar_net),
            step_one: Arc::new(step_one),
            pattern: None,
            last: None,
        }))
    }
}

impl CoarseView {
    /// Names this level (a new level, a new key).
    pub fn key(&self) -> u64 {
        self.key
    }

    /// Whether this level stands for `session`'s chart as it is now (the
    /// same chart, landmarks, corners and region: only targets moved).
    pub fn fits(&self, session: &ChartSession) -> bool {
        self.made_for == MadeFor::of(&session.prepared)
    }

    /// Vertices of the level (its real ones, without the holes' fill).
    pub fn n_vertices(&self) -> usize {
        self.prepared.filled.n_real_vertices
    }

    /// The level's triangles as its asset's vertices.
    pub fn mesh(&self) -> CoarseMesh {
        let welded = &self.prepared.welded;
        let mut first = vec![(u32::MAX, u32::MAX); welded.mesh.n_vertices()];
        for (p, map) in welded.vertex_of.iter().enumerate().rev() {
            for (v, &w) in map.iter().enumerate().rev() {
                first[w as usize] = (p as u32, v as u32);
            }
        }
        let f = &self.prepared.filled;
        CoarseMesh {
            vertices: (0..f.n_real_vertices)
                .map(|v| first[self.prepared.chart.welded_ids[v] as usize])
                .collect(),
            triangles: f.mesh.triangles[..f.n_real_triangles].to_vec(),
        }
    }

    /// Solves the level for `session`'s current targets (it must
    /// [`fit`](Self::fits)) from its last layout, without the polish; `stop`
    /// is asked between ticks (`None` when it says so).
    ///
    /// # Errors
    /// A solver of the level could not be built (a bug: the level fits).
    pub fn solve_until(
        &mut self,
        session: &ChartSession,
        options: &SolverOptions,
        stop: &dyn Fn() -> bool,
    ) -> Result<Option<CoarseSolution>, Error> {
        self.prepared.constraints = session.prepared.constraints.clone();
        let options = SolverOptions {
            polish: false,
            multilevel_above: usize::MAX,
            ..*options
        };
        let warm = self.last.clone();
        let mut solver = match warm.and_then(|last| self.solver(session, &options, Some(&last)).ok()) {
            Some(solver) => solver,
            None => self.solver(session, &options, None)?,
        };
        while !solver.is_done() {
            if stop() {
                return Ok(None);
            }
            solver.tick()?;
        }
        let report = report::build(&report::SolveSummary {
            constraint_file: session.source.name(),
            asset: &session.asset,
            prepared: &self.prepared,
            boundary: &self.boundary,
            step1: &self.step_one,
            solver: &solver,
            times: report::StageTimes::default().with_solver(solver.times()),
        });
        let layout = solver.layout().to_vec();
        self.pattern = Some(solver.pattern().clone());
        self.last = Some(Arc::new(layout.clone()));
        Ok(Some(CoarseSolution { layout, report }))
    }

    /// Whether `layout` of this level is fold-free as glTF and OBJ store it.
    pub fn stored_clean(&self, layout: &[DVec2]) -> bool {
        crate::chart::written_orientation(&self.prepared, layout).is_clean()
    }

    /// A solver of the level, started from `last` (else its own start).
    fn solver(
        &self,
        session: &ChartSession,
        options: &SolverOptions,
        last: Option<&[DVec2]>,
    ) -> Result<ChartSolver, Error> {
        let mut prepared = self.prepared.clone();
        let mut step1: &[DVec2] = &self.step_one;
        match (&self.prepared.domain, last) {
            (Domain::Free(setup), Some(last)) => {
                prepared.domain = Domain::Free(Arc::new(setup.starting_from(last.to_vec(), StartKind::Coarse)));
            }
            (_, Some(last)) => step1 = last,
            (_, None) => {}
        }
        ChartSolver::new(SolverInputs {
            prepared: &prepared,
            source: &session.source,
            options,
            boundary: &self.boundary,
            step1,
            bar_net: Some(&self.bar_net),
            pattern: self.pattern.as_ref(),
            elapsed_ms: 0.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constraints::ConstraintSource;
    use crate::io::SourceAsset;
    use crate::pins::{BoundaryChoice, Pins};
    use crate::testing::{Rng, grid_mesh, smooth_warp};

    const N: usize = 90;

    /// `k` interior grid vertices with targets where a warped, shrunk copy of
    /// the grid has them, moved by `shift` (texture units).
    fn pins(landmarks: &[u32], shift: DVec2, boundary: BoundaryChoice) -> ConstraintSource {
        let targets: Vec<(u32, DVec2)> = landmarks
            .iter()
            .map(|&v| {
                let p = DVec2::new((v as usize % N) as f64, (v as usize / N) as f64) / (N - 1) as f64;
                (v, crate::param::xy_to_uv(smooth_warp(0.2 + 0.6 * p, 0.03)) + shift)
            })
            .collect();
        ConstraintSource::Memory(Arc::new(Pins::new(&targets).with_boundary(boundary)))
    }

    #[test]
    fn a_coarse_level_follows_moved_targets_exactly_and_fold_free() {
        let mesh = grid_mesh(N, N);
        let mut rng = Rng::new(5);
        let landmarks: Vec<u32> = (0..8)
            .map(|_| (10 + rng.below(N - 20) + (10 + rng.below(N - 20)) * N) as u32)
            .collect();
        for boundary in [BoundaryChoice::Square, BoundaryChoice::Free] {
            let asset = Arc::new(SourceAsset::from_mesh(&mesh));
            let source = pins(&landmarks, DVec2::ZERO, boundary);
            let mut session = ChartSession::open(source, asset, 0.0).unwrap();
            let mut view = session.coarse_view(1500).unwrap().expect("a level");
            assert!((1000..=1600).contains(&view.n_vertices()), "{}", view.n_vertices());
            let coarse = view.mesh();
            assert_eq!(coarse.vertices.len(), view.n_vertices());
            assert!(coarse.vertices.iter().all(|&(k, v)| k == 0 && (v as usize) < N * N));
            for v in &landmarks {
                assert!(coarse.vertices.contains(&(0, *v)), "landmark {v} is a coarse vertex");
            }
            for step in 0..6 {
                let shift = DVec2::new(0.004 * step as f64, -0.003 * step as f64);
                session.retarget(pins(&landmarks, shift, boundary), 0.0).unwrap();
                assert!(view.fits(&session));
                let solved = view
                    .solve_until(&session, &SolverOptions::DEFAULT, &|| false)
                    .unwrap()
                    .expect("not stopped");
                assert_eq!(solved.report.status, crate::Status::Reached, "{boundary:?} step {step}");
                assert!(solved.report.constraints.iter().all(|c| c.residual <= 1e-9));
                assert!(view.stored_clean(&solved.layout), "{boundary:?} step {step}");
            }
            // Another landmark set needs another level; a stop is honoured.
            let fewer = pins(&landmarks[1..], DVec2::ZERO, boundary);
            session.retarget(fewer, 0.0).unwrap();
            assert!(!view.fits(&session));
            let mut other = session.coarse_view(1500).unwrap().expect("a level");
            assert_ne!(other.key(), view.key());
            assert!(
                other
                    .solve_until(&session, &SolverOptions::DEFAULT, &|| true)
                    .unwrap()
                    .is_none()
            );
        }
    }

    #[test]
    fn a_chart_no_larger_than_its_level_has_none() {
        let source = pins(&[N as u32 * 45 + 45], DVec2::ZERO, BoundaryChoice::Square);
        let asset = Arc::new(SourceAsset::from_mesh(&grid_mesh(N, N)));
        let mut session = ChartSession::open(source, asset, 0.0).unwrap();
        assert!(session.coarse_view(N * N).unwrap().is_none());
    }
}
