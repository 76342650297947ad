//! The chart session: one chart of one asset, with everything a solve
//! computes once and every later solve of new landmarks reuses (as
//! geometry-central's precomputing solvers do). It is a cache and nothing
//! more: what to try is the planner's ([`crate::plan`]), what is written
//! beside the chart the assembly's ([`crate::assembly`]). The CLI, the
//! sweep, the editor's previews, the daemon's chart entities and the
//! library all hold one:
//!
//! ```text
//! open(source, asset) ─ retarget(source) ─┐
//!        │                                │  keeps the weld; the chart's topology and hole
//!        ▼                                │  fill for the same chart; step 1 for the same corners
//! map_boundary → factor_bar_net → solve_force_density     (step 1, §III, Eq. 1–2)
//!        ▼
//! reshaped(form, boundary), coarse levels, last layout, Newton pattern,
//! the rest's unwrap (for the planner and the assembly)
//! ```
//!
//! Cloning a session is cheap: its geometry, factor and Newton pattern are
//! shared behind `Arc`s.

#![warn(missing_docs)]

use crate::chart::{self, PreparedChart, PrimitiveUvs};
use crate::complete::pattern::PendingNewtonPattern;
use crate::constraints::ConstraintSource;
use crate::domain::Domain;
use crate::error::Error;
use crate::io::SourceAsset;
use crate::options::SolverOptions;
use crate::param::bar_net::BarNet;
use crate::param::boundary::BoundaryMap;
use crate::report::StageTimes;
use crate::solver::ChartSolver;
use crate::solver::step_one::{self, StepOne, StepOneTimes};
use glam::DVec2;
use std::sync::Arc;
use std::time::Instant;

mod coarse;
pub use coarse::{CoarseMesh, CoarseSolution, CoarseView};

/// A chart of an asset and what its solves share (see the module docs).
#[derive(Debug, Clone)]
pub struct ChartSession {
    asset: Arc<SourceAsset>,
    source: ConstraintSource,
    prepared: PreparedChart,
    /// The outer loop on the square (§III.B): depends on the corners.
    boundary: Option<Arc<BoundaryMap>>,
    /// `D` of Eq. 1 factored: depends on the chart only.
    bar_net: Option<Arc<BarNet>>,
    /// The step-1 layout of the filled chart: depends on the boundary.
    step_one: Option<Arc<Vec<DVec2>>>,
    /// The Newton pattern of the last solver started on this chart.
    pattern: Option<Arc<PendingNewtonPattern>>,
    /// The last finished layout of a chart on the square with these
    /// corners: the start of a [`StartFrom::LastLayout`] solve.
    last_layout: Option<Arc<Vec<DVec2>>>,
    /// Milliseconds spent on the current constraints' solve so far.
    times: StageTimes,
    /// Counts every change of what a solver would start from, so a running
    /// solver of an older revision is known to be stale.
    revision: u64,
    /// The other charts that need UVs, unwrapped on first export: depends
    /// on the geometry only (the packing around the chart is done anew).
    rest: Arc<std::sync::OnceLock<Arc<crate::atlas::Rest>>>,
    /// How the chart was picked and made ([`Self::reshaped`] keeps it).
    pick: chart::Pick,
    /// Whether `asset` is the asset as read, or that asset without the
    /// atlas its targets contradict.
    atlas: AtlasUse,
}

/// What a session did with an atlas in the set it writes
/// ([`crate::constraints::AtlasKeeping`]).
#[derive(Debug, Clone, Default)]
enum AtlasUse {
    /// The session's asset is the asset as read.
    #[default]
    AsRead,
    /// The file left the set open, and keeping the atlas was proven short
    /// (`on_islands`: the constraints whose targets lie on the islands of
    /// charts without landmarks) or measured short (`on_islands` empty;
    /// that holds for later targets of the session): the session lays out
    /// `as_read` without its UVs. `chart` is the chart prepared on
    /// `as_read`, kept to judge new targets cheaply.
    Dropped {
        as_read: Arc<SourceAsset>,
        chart: Box<PreparedChart>,
        on_islands: Vec<usize>,
    },
}

/// What a [`ChartSession::retarget`] kept of the session's earlier work.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kept {
    /// Nothing but the weld: the constraints are in another chart.
    Weld,
    /// The chart, its topology and hole fill, the bar-net factor and the
    /// Newton pattern (the corners moved: a new boundary map and step 1).
    Geometry,
    /// All that and step 1: only the spline path and completion run.
    StepOne,
}

/// Where a solver starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StartFrom {
    /// Step 1's layout (or a free chart's own start).
    #[default]
    StepOne,
    /// The last finished layout of this chart, when it was on the square
    /// with the same corners (dragged targets move a little from where they
    /// were: the spline path then rarely stalls); else step 1's.
    LastLayout,
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// The constraints that prove the atlas of `asset` cannot be kept, when
/// `source` leaves the set open, the chart prepared on it (`on_read`) is
/// free (kept clear of the other islands; on the square it is not, and a
/// mesh laid out afresh on the square leaves no room for the rest) and
/// targets lie on the islands of charts without landmarks
/// ([`chart::on_kept_islands`]); `None` keeps the asset as read.
fn atlas_against(source: &ConstraintSource, asset: &SourceAsset, on_read: &PreparedChart) -> Option<Vec<usize>> {
    let open = source.atlas() == crate::constraints::AtlasKeeping::WhereTargetsAllow;
    if !(open && asset.has_uvs() && on_read.domain.free().is_some()) {
        return None;
    }
    let (all, _) = source.resolve(&asset.primitives, &on_read.welded).ok()?;
    chart::on_kept_islands(asset, &on_read.welded, &all).filter(|on| !on.is_empty())
}

impl AtlasUse {
    fn dropped(as_read: Arc<SourceAsset>, chart: PreparedChart, on_islands: Vec<usize>) -> Self {
        AtlasUse::Dropped {
            as_read,
            chart: Box::new(chart),
            on_islands,
        }
    }
}

impl ChartSession {
    /// The session of `mesh`, held in memory, with `pins`.
    ///
    /// # Errors
    /// As [`Self::open`].
    pub fn of_mesh(mesh: &crate::mesh::TriMesh, pins: crate::pins::Pins) -> Result<Self, Error> {
        let source = ConstraintSource::Memory(Arc::new(pins));
        ChartSession::open(source, Arc::new(SourceAsset::from_mesh(mesh)), 0.0)
    }

    /// The chart of `asset` that `source`'s constraints pick, prepared
    /// ([`chart::prepare`]); `load_ms` is the time already spent loading.
    ///
    /// # Errors
    /// Constraint and topology errors against the asset.
    pub fn open(source: ConstraintSource, asset: Arc<SourceAsset>, load_ms: f64) -> Result<Self, Error> {
        let t0 = Instant::now();
        let on_read = chart::prepare(&source, &asset)?;
        let (asset, prepared, atlas) = match atlas_against(&source, &asset, &on_read) {
            Some(on) => {
                let fresh = Arc::new(asset.without_uvs());
                let prepared = chart::prepare(&source, &fresh)?;
                (fresh, prepared, AtlasUse::dropped(asset, on_read, on))
            }
            None => (asset, on_read, AtlasUse::AsRead),
        };
        let mut session = ChartSession::from_prepared(source, asset, prepared, chart::Pick::default());
        session.atlas = atlas;
        session.times = StageTimes {
            load_ms,
            topology_ms: ms(t0),
            ..StageTimes::default()
        };
        Ok(session)
    }

    /// A session on a chart already prepared as `pick` says (another form
    /// of a chart, or another chart or piece solved beside it).
    pub fn from_prepared(
        source: ConstraintSource,
        asset: Arc<SourceAsset>,
        prepared: PreparedChart,
        pick: chart::Pick,
    ) -> Self {
        ChartSession {
            asset,
            source,
            prepared,
            boundary: None,
            bar_net: None,
            step_one: None,
            pattern: None,
            last_layout: None,
            times: StageTimes::default(),
            revision: 0,
            rest: Arc::default(),
            pick,
            atlas: AtlasUse::AsRead,
        }
    }

    /// The same asset and constraints with the chart made as `pick` says
    /// (another form, or another boundary where the file names none; `None`
    /// keeps this session's pick's, such as a piece's free boundary), on
    /// this session's weld: a candidate of [`crate::plan`].
    ///
    /// # Errors
    /// As [`ChartSession::open`].
    pub fn reshaped(
        &self,
        form: &crate::cut::prepare::Form,
        boundary: Option<crate::pins::BoundaryChoice>,
    ) -> Result<ChartSession, Error> {
        let t0 = Instant::now();
        let pick = chart::Pick {
            form: Some(form.clone()),
            boundary: boundary.or(self.pick.boundary),
            ..self.pick.clone()
        };
        let prepared = self.prepared.repicked(&self.source, &self.asset, &pick)?;
        let mut session = ChartSession::from_prepared(self.source.clone(), self.asset.clone(), prepared, pick);
        session.atlas = self.atlas.clone();
        session.times = StageTimes {
            load_ms: self.times.load_ms,
            topology_ms: self.times.topology_ms + ms(t0),
            ..StageTimes::default()
        };
        session.revision = self.revision;
        Ok(session)
    }

    /// The same asset and constraints with the chart prepared anew as
    /// `pick` says, on this session's weld (made anew: pieces this session
    /// set aside with the rest are not inherited).
    ///
    /// # Errors
    /// As [`ChartSession::open`].
    pub fn picked(&self, pick: chart::Pick) -> Result<ChartSession, Error> {
        let prepared = chart::prepare_pick(&self.source, &self.asset, self.prepared.welded.clone(), &pick)?;
        let mut session = ChartSession::from_prepared(self.source.clone(), self.asset.clone(), prepared, pick);
        session.atlas = self.atlas.clone();
        session.revision = self.revision;
        Ok(session)
    }

    /// The last finished layout on the square with these corners, the warm
    /// start of a [`StartFrom::LastLayout`] solve.
    pub fn last_layout(&self) -> Option<Arc<Vec<DVec2>>> {
        self.last_layout.clone().filter(|_| self.on_square())
    }

    /// Keeps what a finished `solver` of this chart gives the next solve:
    /// its Newton pattern, and its layout as the warm start when on the square.
    pub fn keep(&mut self, solver: &ChartSolver) {
        self.pattern = Some(solver.pattern().clone());
        if self.on_square() {
            self.last_layout = Some(Arc::new(solver.layout().to_vec()));
        }
    }

    /// New constraints on the same asset: resolved again, keeping what
    /// still applies ([`Kept`]); `load_ms` is the time spent reading them.
    ///
    /// # Errors
    /// As [`ChartSession::open`]; the session is unchanged then.
    pub fn retarget(&mut self, source: ConstraintSource, load_ms: f64) -> Result<Kept, Error> {
        let t0 = Instant::now();
        let (asset, prepared, atlas) = self.retargeted(&source)?;
        let kept = if !prepared.same_geometry(&self.prepared) {
            Kept::Weld
        } else if prepared.corners != self.prepared.corners {
            Kept::Geometry
        } else {
            Kept::StepOne
        };
        if kept != Kept::StepOne {
            (self.boundary, self.step_one, self.last_layout) = (None, None, None);
        }
        if kept == Kept::Weld {
            (self.bar_net, self.pattern) = (None, None);
            self.rest = Arc::default();
        }
        (self.asset, self.source, self.prepared, self.atlas) = (asset, source, prepared, atlas);
        self.times = StageTimes {
            load_ms,
            topology_ms: ms(t0),
            ..StageTimes::default()
        };
        self.revision += 1;
        Ok(kept)
    }

    /// The asset, chart and atlas use for new constraints `source`: judged
    /// on the asset as read (its chart retargeted), and on the asset
    /// without its atlas when the targets contradict it, or when this
    /// session measured keeping it short and the file still leaves the set
    /// open (a decision measured holds for the session's later targets:
    /// an editor's drag is not solved twice a frame). This session's chart
    /// is retargeted when it was laid out afresh already.
    fn retargeted(&self, source: &ConstraintSource) -> Result<(Arc<SourceAsset>, PreparedChart, AtlasUse), Error> {
        let (as_read, on_read) = match &self.atlas {
            AtlasUse::AsRead => (&self.asset, self.prepared.retargeted(source, &self.asset)?),
            AtlasUse::Dropped { as_read, chart, .. } => (as_read, chart.retargeted(source, as_read)?),
        };
        let measured = matches!(&self.atlas, AtlasUse::Dropped { on_islands, .. } if on_islands.is_empty())
            && source.atlas() == crate::constraints::AtlasKeeping::WhereTargetsAllow;
        let on = match atlas_against(source, as_read, &on_read) {
            Some(on) => on,
            None if measured => Vec::new(),
            None => return Ok((as_read.clone(), on_read, AtlasUse::AsRead)),
        };
        let (asset, prepared) = match &self.atlas {
            AtlasUse::Dropped { .. } => (self.asset.clone(), self.prepared.retargeted(source, &self.asset)?),
            AtlasUse::AsRead => {
                let fresh = Arc::new(as_read.without_uvs());
                let prepared = chart::prepare(source, &fresh)?;
                (fresh, prepared)
            }
        };
        Ok((asset, prepared, AtlasUse::dropped(as_read.clone(), on_read, on)))
    }

    /// This session's chart laid out afresh on the asset without its atlas,
    /// for [`crate::assembly::finish`] to measure against keeping it:
    /// `None` unless the source leaves the set open, the asset has UVs in
    /// it, this session keeps them, its chart is free (on the square, a
    /// mesh laid out afresh leaves no room for the rest) and it is the
    /// solve's first chart (another chart or piece solved beside it is not
    /// the whole mesh's to lay out again).
    ///
    /// # Errors
    /// As [`ChartSession::open`].
    pub fn afresh(&self) -> Option<Result<ChartSession, Error>> {
        let open = self.source.atlas() == crate::constraints::AtlasKeeping::WhereTargetsAllow;
        let has_atlas = self.asset.has_uvs();
        let first = self.pick.chart.is_none() && self.pick.piece.is_none();
        let free = self.prepared.domain.free().is_some();
        if !(open && has_atlas && first && free && matches!(self.atlas, AtlasUse::AsRead)) {
            return None;
        }
        let fresh = Arc::new(self.asset.without_uvs());
        Some(chart::prepare(&self.source, &fresh).map(|prepared| {
            let mut session = ChartSession::from_prepared(self.source.clone(), fresh, prepared, chart::Pick::default());
            session.atlas = AtlasUse::dropped(self.asset.clone(), self.prepared.clone(), Vec::new());
            session.times.load_ms = self.times.load_ms;
            session.revision = self.revision;
            session
        }))
    }

    /// What the report says when the atlas in the set written was laid out
    /// afresh, and why; `None` when it was kept.
    pub fn atlas_note(&self) -> Option<String> {
        let AtlasUse::Dropped { on_islands, .. } = &self.atlas else {
            return None;
        };
        let set = self.asset.uv_set;
        let keep = format!(
            "write `uv_set: {set}` to keep the atlas, or `uv_set: {}` to write the new layout beside it",
            set + 1
        );
        let on: Vec<String> = on_islands.iter().map(|i| format!("constraints[{i}]")).collect();
        Some(if on.is_empty() {
            format!(
                "keeping the atlas in TEXCOORD_{set} reached fewer targets than laying the whole mesh out afresh: it was \
                 laid out afresh in that set ({keep})"
            )
        } else {
            format!(
                "{} have targets on the islands of charts without landmarks in TEXCOORD_{set}, so no layout keeping the \
                 atlas reaches them: the whole mesh was laid out afresh in that set ({keep})",
                on.join(", ")
            )
        })
    }

    /// Places the outer loop on the square (§III.B), unless it is placed.
    ///
    /// # Errors
    /// Corners that are not on the outer loop, are mirrored, or trap a
    /// triangle (located at the `corners` field).
    pub fn map_boundary(&mut self) -> Result<(), Error> {
        if self.boundary.is_none() {
            let t0 = Instant::now();
            self.boundary = Some(Arc::new(step_one::map_boundary(&self.prepared, &self.source)?));
            self.times.boundary_ms += ms(t0);
        }
        Ok(())
    }

    /// Builds and factors `D = CᵀQC` (Eq. 1–2), unless it is factored.
    ///
    /// # Errors
    /// The boundary is not mapped yet (a bug), or `D` is singular.
    pub fn factor_bar_net(&mut self) -> Result<(), Error> {
        if self.bar_net.is_none() {
            let t0 = Instant::now();
            let boundary = self.mapped_boundary()?;
            let net = step_one::factor_bar_net(&self.prepared, boundary, &self.asset.path)?;
            self.bar_net = Some(Arc::new(net));
            self.times.factor_ms += ms(t0);
        }
        Ok(())
    }

    /// Solves Eq. 1 for the nodes off the outer loop, unless solved: the
    /// step-1 layout.
    ///
    /// # Errors
    /// The boundary is not mapped or `D` not factored yet (a bug).
    pub fn solve_force_density(&mut self) -> Result<(), Error> {
        if self.step_one.is_none() {
            let t0 = Instant::now();
            let net = self.bar_net.as_ref().ok_or_else(|| not_yet("the bar-net factor"))?;
            let layout = step_one::solve_force_density(&self.prepared, self.mapped_boundary()?, net);
            self.step_one = Some(Arc::new(layout));
            self.times.solve_ms += ms(t0);
        }
        Ok(())
    }

    /// Step 1 in a row: [`Self::map_boundary`], [`Self::factor_bar_net`],
    /// [`Self::solve_force_density`], each only if not done.
    ///
    /// # Errors
    /// As those methods.
    pub fn run_step_one(&mut self) -> Result<(), Error> {
        self.map_boundary()?;
        self.factor_bar_net()?;
        self.solve_force_density()
    }

    /// Whether a solve with `options` starts from the chart's coarse level,
    /// without step 1 of its own (which it runs only if that level fails):
    /// a caller stepping through the stages skips step 1 then.
    pub fn starts_coarse(&self, options: &SolverOptions) -> bool {
        self.prepared.filled.mesh.n_vertices() > options.multilevel_above
    }

    /// The other charts that need UVs, each unwrapped on its own
    /// ([`crate::atlas::unwrap_all`]): once per session, since it depends on
    /// the geometry only.
    pub fn rest(&self, options: &SolverOptions) -> Arc<crate::atlas::Rest> {
        self.rest
            .get_or_init(|| {
                let charts = crate::atlas::rest_charts(&self.asset, &self.prepared);
                Arc::new(crate::atlas::unwrap_all(&self.asset, &self.prepared, charts, options))
            })
            .clone()
    }

    /// Lays `pieces` (of the chart, holding landmarks that could not be
    /// solved) out with the rest from now on, and no longer as pieces
    /// solved beside the chart: a later solve of this session (new
    /// targets) lays each out once, packed.
    pub fn lay_with_rest(&mut self, pieces: impl IntoIterator<Item = Arc<crate::mesh::weld::Chart>>) {
        let mut opening = (*self.prepared.opening).clone();
        let pieces: Vec<_> = pieces.into_iter().collect();
        opening.pieces.retain(|p| !pieces.iter().any(|q| Arc::ptr_eq(p, q)));
        opening.rest.extend(pieces);
        self.prepared.opening = Arc::new(opening);
        self.rest = Arc::default();
    }

    /// The session of the `k`-th other chart or piece holding landmarks,
    /// solved after this chart (chart `id`, or `piece` of it): free, clear
    /// of the `placed` triangles and of where the camera shows the pieces
    /// after it ([`PreparedChart::reserved_after`]).
    ///
    /// # Errors
    /// As [`ChartSession::open`].
    pub fn beside(
        &self,
        k: usize,
        item: (u32, Option<Arc<crate::mesh::weld::Chart>>),
        (placed, density): (&[[DVec2; 3]], f64),
    ) -> Result<ChartSession, Error> {
        let form = self.pick.form.as_ref();
        let mut obstacles = placed.to_vec();
        obstacles.extend(self.prepared.reserved_after(form, k));
        let density = (density.is_finite() && density > 0.0).then_some(density);
        let pick = self.prepared.pick_beside(item, form, obstacles, density);
        let prepared = chart::prepare_pick(&self.source, &self.asset, self.prepared.welded.clone(), &pick)?;
        Ok(ChartSession::from_prepared(
            self.source.clone(),
            self.asset.clone(),
            prepared,
            pick,
        ))
    }

    /// Forgets the triangles this chart was kept clear of (room kept for
    /// other pieces in one solve, [`crate::assembly::finish`]): a later
    /// solve, on new targets, starts without them.
    pub fn forget_placed(&mut self) {
        self.pick.placed = Arc::default();
    }

    /// How the chart was picked and made.
    pub fn pick(&self) -> &chart::Pick {
        &self.pick
    }

    /// The final UVs per primitive of the asset with `layout` on this chart.
    pub fn uvs(&self, layout: &[DVec2]) -> PrimitiveUvs {
        chart::assemble_uvs(&self.asset, &self.prepared, layout)
    }

    /// The asset the chart is from.
    pub fn asset(&self) -> &Arc<SourceAsset> {
        &self.asset
    }

    /// Where the current constraints came from.
    pub fn source(&self) -> &ConstraintSource {
        &self.source
    }

    /// The chart: weld, topology, hole fill, resolved constraints.
    pub fn prepared(&self) -> &PreparedChart {
        &self.prepared
    }

    /// The outer loop on the square, once mapped.
    pub fn boundary(&self) -> Option<&BoundaryMap> {
        self.boundary.as_deref()
    }

    /// The bar-net factor, once factored.
    pub fn bar_net(&self) -> Option<&Arc<BarNet>> {
        self.bar_net.as_ref()
    }

    /// The step-1 layout of the filled chart, once solved.
    pub fn step_one_layout(&self) -> Option<&[DVec2]> {
        self.step_one.as_deref().map(Vec::as_slice)
    }

    /// Step 1's results together (`None` until solved), with this
    /// solve's step-1 times.
    pub fn step_one(&self) -> Option<StepOne> {
        Some(StepOne {
            boundary: self.boundary.as_deref()?.clone(),
            bar_net: self.bar_net.clone()?,
            layout: self.step_one.as_deref()?.clone(),
            times: StepOneTimes {
                boundary_ms: self.times.boundary_ms,
                factor_ms: self.times.factor_ms,
                solve_ms: self.times.solve_ms,
            },
        })
    }

    /// The Newton pattern of the last solver started (kept for the same chart).
    pub fn pattern(&self) -> Option<&Arc<PendingNewtonPattern>> {
        self.pattern.as_ref()
    }

    /// This solve's times so far (load, topology, step 1).
    pub fn times(&self) -> StageTimes {
        self.times
    }

    /// Changes with every new starting point of a solve.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Puts the outer loop where `boundary` says (same loop, new positions):
    /// step 1 is solved again on the same factor.
    pub fn replace_boundary(&mut self, boundary: BoundaryMap) {
        self.boundary = Some(Arc::new(boundary));
        (self.step_one, self.last_layout) = (None, None);
        self.revision += 1;
    }

    fn on_square(&self) -> bool {
        matches!(self.prepared.domain, Domain::Square)
    }

    fn mapped_boundary(&self) -> Result<&BoundaryMap, Error> {
        self.boundary.as_deref().ok_or_else(|| not_yet("the boundary map"))
    }
}

/// A step asked for before the one it needs (a bug of the caller).
fn not_yet(what: &str) -> Error {
    Error::Internal(format!("{what} is needed first"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pins::Pins;

    #[test]
    fn a_piece_laid_out_with_the_rest_is_no_longer_solved_beside_the_chart() {
        // Two sheets meeting at one corner (a pinched vertex), a landmark
        // on each: the chart is split there, the second sheet a piece.
        let grid = crate::testing::grid_mesh(6, 6);
        let n = grid.n_vertices() as u32;
        let mut mesh = grid.clone();
        let corner = grid.positions[(n - 1) as usize];
        mesh.positions.extend(grid.positions.iter().map(|p| *p + corner));
        mesh.triangles.extend(
            grid.triangles
                .iter()
                .map(|t| t.map(|v| if v == 0 { n - 1 } else { v + n })),
        );
        let pins = Pins::new(&[
            (7, DVec2::new(0.2, 0.3)),
            (14, DVec2::new(0.35, 0.45)),
            (n + 21, DVec2::new(0.7, 0.75)),
            (n + 28, DVec2::new(0.8, 0.8)),
        ]);
        let mut session = ChartSession::of_mesh(&mesh, pins).expect("a session");
        let pieces = session.prepared().opening.pieces.clone();
        assert_eq!(pieces.len(), 1, "the second sheet is a piece of its own");
        let rest = session.prepared().opening.rest.len();
        session.lay_with_rest(pieces.clone());
        let opening = &session.prepared().opening;
        assert!(opening.pieces.is_empty(), "it is not solved beside the chart again");
        assert_eq!(opening.rest.len(), rest + 1, "it is laid out once, with the rest");
        assert!(opening.rest.iter().any(|p| Arc::ptr_eq(p, &pieces[0])));
    }

    /// A .glb of two 5 × 5 grid islands side by side in the texture (A
    /// over u 0.05..0.45, B over 0.55..0.95) in `dir`, and a constraint
    /// file leaving the set open with A's vertex 12 (its centre) at `u`,
    /// and B's (vertex 37) at `b` if given.
    fn two_islands_with_target(dir: &std::path::Path, u: f64, b: Option<f64>) -> ConstraintSource {
        two_islands_file(dir, u, b, "")
    }

    /// As [`two_islands_with_target`], with `extra` fields in the file.
    fn two_islands_file(dir: &std::path::Path, u: f64, b: Option<f64>, extra: &str) -> ConstraintSource {
        let grid = crate::testing::grid_mesh(5, 5);
        let (mut positions, mut indices, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
        for (k, u0) in [0.05f32, 0.55].into_iter().enumerate() {
            let base = positions.len() as u32;
            for p in &grid.positions {
                positions.push([p.x as f32 + 2.0 * k as f32, p.y as f32, 0.0]);
                uvs.push([u0 + 0.4 * p.x as f32, 0.9 - 0.8 * p.y as f32]);
            }
            indices.extend(grid.triangles.iter().flatten().map(|&v| v + base));
        }
        let asset = dir.join("islands.glb");
        let (json, blob) = crate::io::gltf_file::new_document(&positions, &indices, Some(&uvs), "islands");
        crate::io::gltf_file::write_new_document(&json, &blob, &asset).expect("write glb");
        let ron = dir.join(format!("at-{u}-{b:?}-{}.uvpin.ron", extra.len()));
        let on_b = b.map_or(String::new(), |b| format!(", (vertex: 37, uv: ({b}, 0.5))"));
        let text = format!("(asset: \"islands.glb\", {extra} constraints: [(vertex: 12, uv: ({u}, 0.5)){on_b}])");
        std::fs::write(&ron, text).expect("write ron");
        let loaded =
            crate::constraints::LoadedConstraints::load_within(&ron, &SolverOptions::default(), &Default::default())
                .expect("the file reads");
        ConstraintSource::File(Arc::new(loaded))
    }

    #[test]
    fn the_atlas_is_dropped_while_a_target_lies_on_another_island_and_kept_again_after() {
        let dir = crate::testing::fresh_dir("session-atlas");
        let (inside, over_b) = (
            two_islands_with_target(&dir, 0.3, None),
            two_islands_with_target(&dir, 0.7, None),
        );
        let asset = |source: &ConstraintSource| {
            let ConstraintSource::File(l) = source else {
                unreachable!()
            };
            Arc::new(crate::io::load_asset(&l.asset_path(), None, 0, &Default::default()).expect("the asset"))
        };
        let has_uvs = |s: &ChartSession| s.asset().primitives[0].uvs.is_some();
        let mut session = ChartSession::open(inside.clone(), asset(&inside), 0.0).expect("a session");
        assert!(
            has_uvs(&session) && session.atlas_note().is_none(),
            "kept: the target is on A's own island"
        );
        session.retarget(over_b.clone(), 0.0).expect("retargeted");
        assert!(!has_uvs(&session), "laid out afresh: the target is on B's island");
        let note = session.atlas_note().expect("a note");
        assert!(
            note.starts_with("constraints[0] have targets on the islands of charts without landmarks"),
            "{note}"
        );
        assert!(session.afresh().is_none(), "nothing more to try afresh");
        session.retarget(inside, 0.0).expect("retargeted back");
        assert!(
            has_uvs(&session) && session.atlas_note().is_none(),
            "the atlas kept again"
        );
        assert!(session.afresh().is_some(), "afresh is still a candidate to measure");
        let opened = ChartSession::open(over_b.clone(), asset(&over_b), 0.0).expect("a session");
        assert!(!has_uvs(&opened), "opened on B's island: laid out afresh at once");
        // B holds a landmark too: its island is laid out again, so a target
        // on it proves nothing (keeping the atlas is measured instead).
        let both = two_islands_with_target(&dir, 0.7, Some(0.3));
        let opened = ChartSession::open(both.clone(), asset(&both), 0.0).expect("a session");
        assert!(
            has_uvs(&opened) && opened.afresh().is_some(),
            "kept, afresh left to measure"
        );
        // On the square the chart does not keep clear of B's island: the
        // target proves nothing, and a mesh laid out afresh on the square
        // would leave no room for the rest.
        let square = two_islands_file(&dir, 0.7, None, "boundary: Square,");
        let opened = ChartSession::open(square.clone(), asset(&square), 0.0).expect("a session");
        assert!(has_uvs(&opened) && opened.afresh().is_none(), "kept on the square");
        let _ = std::fs::remove_dir_all(dir);
    }
}
