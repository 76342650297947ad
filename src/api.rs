//! The library API: solve a constraint file, or a mesh held in memory; step
//! 1 alone; the check that targets are provably unreachable. One options
//! struct, [`Options`], serves them all. No ECS World is involved: these
//! run the chart solver ([`crate::solver`]) directly.
//!
//! ```
//! use glam::DVec2;
//! use uvpin::{Options, Pins};
//!
//! // A 20 × 20 grid patch; vertex 210 (inside) goes to (0.4, 0.5).
//! let mesh = uvpin::testing::grid_mesh(20, 20);
//! let pins = Pins::new(&[(210, DVec2::new(0.4, 0.5))]);
//! let solved = uvpin::solve_mesh(&mesh, &pins, &Options::default())?;
//! assert_eq!(solved.report.status, uvpin::Status::Reached);
//! assert!(solved.report.orientation.is_clean());
//! assert_eq!(solved.uvs.len(), mesh.n_vertices());
//!
//! // Targets no fold-free layout can reach are found without solving (None proves nothing).
//! assert_eq!(uvpin::unreachable_proof(&mesh, &pins)?, None);
//! # Ok::<(), uvpin::Error>(())
//! ```

use crate::chart::{self, PreparedChart, PrimitiveUvs};
use crate::constraints::{ConstraintSource, LoadedConstraints};
use crate::error::Error;
use crate::io::{self, SourceAsset};
use crate::mesh::TriMesh;
use crate::options::SolverOptions;
use crate::pins::Pins;
use crate::report::{self, Report, StageTimes, Status};
use crate::solver::step1::{self, Step1};
use crate::solver::{ChartSolver, SolveStart};
use glam::DVec2;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// How to solve, and what to write.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Solver settings. For a constraint file these are the defaults; the
    /// file's own `solver` section replaces them.
    pub solver: SolverOptions,
    /// Where [`solve_file`] writes the asset with the new UVs (`None`:
    /// nothing is written).
    pub output: Option<PathBuf>,
    /// Where [`solve_file`] writes the JSON report (`None`: not written).
    pub report: Option<PathBuf>,
    /// Pictures to draw once the solve is over.
    #[cfg(feature = "pictures")]
    pub pictures: crate::preview::Pictures,
    /// What input may be read: size limits, and from where.
    pub input: io::InputRules,
    /// What is written when the result is an error (the model never is).
    pub on_error: OnError,
}

/// What [`SolvedChart::export`] writes when the layout is refused or the
/// model cannot be written.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum OnError {
    /// Nothing: every named output (report, pictures) stays as it was, as the
    /// command line promises for exit code 1.
    #[default]
    WriteNothing,
    /// The pictures, which show what failed (a sweep's thumbnails of the
    /// paper guard's folds).
    DrawPictures,
}

impl Options {
    /// These options, writing the asset to `output`.
    #[must_use]
    pub fn with_output(mut self, output: impl Into<PathBuf>) -> Self {
        self.output = Some(output.into());
        self
    }
}

impl From<SolverOptions> for Options {
    /// Options with these solver settings, writing nothing.
    fn from(solver: SolverOptions) -> Self {
        Options {
            solver,
            ..Options::default()
        }
    }
}

/// A solved in-memory mesh: the report and one UV per vertex of the mesh
/// (glTF texture coordinates, f32 as a file would store them; vertices
/// outside the solved chart get (0, 0)).
#[derive(Debug, Clone)]
pub struct MeshSolution {
    pub report: Report,
    pub uvs: Vec<[f32; 2]>,
}

/// Reads a constraint file and the asset it names, within `input`;
/// `defaults` apply when the file has no `solver` section.
///
/// # Errors
/// Constraint-file and asset errors.
pub fn load(
    constraints_path: &Path,
    defaults: &SolverOptions,
    input: &io::InputRules,
) -> Result<(LoadedConstraints, SourceAsset), Error> {
    let loaded = LoadedConstraints::load_within(constraints_path, defaults, input)?;
    let asset_path = loaded.asset_path();
    let asset =
        io::load_asset(&asset_path, loaded.file.mesh.as_ref(), loaded.file.uv_set, input).map_err(|e| match e {
            io::AssetError::Read { source, .. } if source.is_not_found() => loaded
                .asset_error("asset", format!("{} does not exist", asset_path.display()))
                .into(),
            e => Error::from(e),
        })?;
    Ok((loaded, asset))
}

/// Solves `constraints_path` and writes `options.output`, the report and the
/// pictures (those asked for) together: all or none. Returns the report:
/// `Reached` or `Partial` (written, fold-free), or `Error` when nothing
/// could be written. Input errors come back as `Err` with nothing written.
///
/// # Errors
/// Any input error: constraint file, asset, topology; an output path that is
/// not a regular file.
pub fn solve_file(constraints_path: &Path, options: &Options) -> Result<Report, Error> {
    let t0 = Instant::now();
    let named = options.output.iter().chain(&options.report);
    #[cfg(feature = "pictures")]
    let named = named.chain(&options.pictures.layout).chain(&options.pictures.render);
    io::atomic::check_distinct(named.clone().map(PathBuf::as_path)).map_err(|e| {
        Error::Asset(io::AssetError::Write {
            path: e.path,
            message: e.message,
        })
    })?;
    for target in named {
        io::read::check_output_target(target).map_err(|e| {
            Error::Asset(io::AssetError::Write {
                path: target.clone(),
                message: format!("refusing to replace it: {e}"),
            })
        })?;
    }
    let (loaded, asset) = load(constraints_path, &options.solver, &options.input)?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    solve_loaded_timed(loaded, &Arc::new(asset), options, load_ms)
}

/// Solves an already loaded constraint file and asset (e.g. with edited
/// targets, as a sweep does); `options.solver` is not used (the loaded
/// file's options are in force).
///
/// # Errors
/// Topology and constraint errors against the asset.
pub fn solve_loaded(loaded: LoadedConstraints, asset: &Arc<SourceAsset>, options: &Options) -> Result<Report, Error> {
    solve_loaded_timed(loaded, asset, options, 0.0)
}

fn solve_loaded_timed(
    loaded: LoadedConstraints,
    asset: &Arc<SourceAsset>,
    options: &Options,
    load_ms: f64,
) -> Result<Report, Error> {
    let solver_options = loaded.solver;
    let source = ConstraintSource::File(Arc::new(loaded));
    let solved = solve_chart_timed(&source, asset, &solver_options, load_ms)?;
    // The pictures show the layout over the file's `image:` when it names one.
    #[cfg(feature = "pictures")]
    {
        let background = options.pictures.background.clone().or_else(|| source.image_path());
        if options.pictures.any() && background != options.pictures.background {
            let mut options = options.clone();
            options.pictures.background = background;
            return Ok(solved.export(asset, &options));
        }
    }
    Ok(solved.export(asset, options))
}

/// Solves a mesh held in memory with `pins` and `options.solver`; nothing
/// is written.
///
/// # Errors
/// Invalid pins (out of range, outside the square, conflicting duplicates)
/// and topology errors.
pub fn solve_mesh(mesh: &TriMesh, pins: &Pins, options: &Options) -> Result<MeshSolution, Error> {
    let asset = SourceAsset::from_mesh(mesh);
    let source = ConstraintSource::Memory(Arc::new(pins.clone()));
    let solved = solve_chart(&source, &asset, &options.solver)?;
    let mut uvs = solved.uvs(&asset);
    Ok(MeshSolution {
        report: solved.report,
        uvs: uvs.swap_remove(0),
    })
}

/// Step 1 of a mesh held in memory: the chart, the boundary on the square,
/// the bar-net factor and the layout.
#[derive(Debug, Clone)]
pub struct MeshStep1 {
    pub prepared: PreparedChart,
    pub step1: Step1,
}

impl MeshStep1 {
    /// The step-1 position (layout coordinates, y up) of every vertex of
    /// the mesh; `None` outside the chart.
    pub fn vertex_layout(&self) -> Vec<Option<DVec2>> {
        let p = &self.prepared;
        p.welded.vertex_of[0]
            .iter()
            .map(|&w| p.chart.local_of(w).map(|local| self.step1.layout[local as usize]))
            .collect()
    }

    /// The mesh's vertices in the chart but not on its outer boundary.
    pub fn interior_vertices(&self) -> Vec<u32> {
        let p = &self.prepared;
        let outer = p.topology.outer_loop();
        (0..p.welded.vertex_of[0].len() as u32)
            .filter(|&v| {
                let w = p.welded.vertex_of[0][v as usize];
                p.chart.local_of(w).is_some_and(|local| !outer.contains(&local))
            })
            .collect()
    }
}

/// Step 1 alone (§III) on a mesh held in memory, with `corners` (top_left,
/// bottom_left, bottom_right, top_right) or automatic ones.
///
/// # Errors
/// Corners out of range or not on the outer loop; topology errors.
pub fn step1(mesh: &TriMesh, corners: Option<[u32; 4]>) -> Result<MeshStep1, Error> {
    let asset = SourceAsset::from_mesh(mesh);
    let pins = Pins {
        corners,
        ..Pins::default()
    };
    let source = ConstraintSource::Memory(Arc::new(pins));
    let prepared = chart::prepare(&source, &asset)?;
    let step1 = step1::step1(&prepared, &source, &asset.path)?;
    Ok(MeshStep1 { prepared, step1 })
}

/// Whether `pins` are provably unreachable on `mesh`, without solving them:
/// step 1 puts the boundary on the square, then
/// [`crate::complete::obstruction`] looks for pieces pinned in place (by the
/// boundary and the targets) that already fold or overlap. `Some(reason)`
/// says what would have to happen for every target to be reached; `None`
/// proves nothing either way.
///
/// # Errors
/// As [`solve_mesh`].
pub fn unreachable_proof(mesh: &TriMesh, pins: &Pins) -> Result<Option<String>, Error> {
    let asset = SourceAsset::from_mesh(mesh);
    let source = ConstraintSource::Memory(Arc::new(pins.clone()));
    let prepared = chart::prepare(&source, &asset)?;
    let step1 = step1::step1(&prepared, &source, &asset.path)?;
    let problem = chart::step_problem(
        &prepared,
        &source,
        &step1.boundary,
        SolverOptions::DEFAULT.max_boundary_centres,
    )?;
    let on_outer = step1.boundary.on_loop(prepared.filled.mesh.n_vertices());
    let certificate = crate::complete::find_obstruction(&prepared.filled, &step1.layout, &problem);
    Ok(certificate.map(|c| c.describe(report::vertex_namer(&prepared, &on_outer))))
}

/// A finished chart solve and its report, with everything it went
/// through: the chart, step 1, the solver (its final layout and record).
/// Nothing is written.
#[derive(Debug, Clone)]
pub struct SolvedChart {
    pub prepared: PreparedChart,
    pub step1: Step1,
    pub solver: ChartSolver,
    pub report: Report,
}

/// Solves the chart that `source`'s constraints pick in `asset` with
/// `options`, writing nothing: for callers who want the intermediate
/// results (step 1's layout, the final layout of the filled chart).
///
/// # Errors
/// Constraint and topology errors against the asset.
pub fn solve_chart(
    source: &ConstraintSource,
    asset: &SourceAsset,
    options: &SolverOptions,
) -> Result<SolvedChart, Error> {
    solve_chart_timed(source, asset, options, 0.0)
}

/// As [`solve_chart`], `load_ms` already spent on loading.
fn solve_chart_timed(
    source: &ConstraintSource,
    asset: &SourceAsset,
    options: &SolverOptions,
    load_ms: f64,
) -> Result<SolvedChart, Error> {
    let solved = solve_chart_reusing(source, asset, options, Reuse::Nothing, &|| false, load_ms)?;
    Ok(solved.expect("never stopped"))
}

/// What a solve may take from an earlier solve of the same asset content.
#[derive(Debug, Clone, Copy)]
pub enum Reuse<'a> {
    /// Nothing: everything from scratch.
    Nothing,
    /// The weld, the chart's topology and hole fill, step 1 when the corners
    /// are the same, and the Newton pattern.
    Setup(&'a SolvedChart),
    /// As `Setup`, and the spline path starts from that solve's final layout
    /// instead of step 1's when the chart's boundary is on the square (a
    /// dragged target moves a little from where it was: the spline path
    /// then rarely stalls).
    SetupAndLayout(&'a SolvedChart),
}

impl<'a> Reuse<'a> {
    fn solved(self) -> Option<&'a SolvedChart> {
        match self {
            Reuse::Nothing => None,
            Reuse::Setup(s) | Reuse::SetupAndLayout(s) => Some(s),
        }
    }
}

/// As [`solve_chart`], reusing what `previous` computed that still applies
/// (see [`Reuse`]). `stop` is asked between ticks; when it says so the
/// solve is dropped (`Ok(None)`). The editor solves dragged targets this way.
///
/// # Errors
/// As [`solve_chart`].
pub fn solve_chart_reusing(
    source: &ConstraintSource,
    asset: &SourceAsset,
    options: &SolverOptions,
    reuse: Reuse,
    stop: &dyn Fn() -> bool,
    load_ms: f64,
) -> Result<Option<SolvedChart>, Error> {
    let previous = reuse.solved();
    let t0 = Instant::now();
    let prepared = chart::prepare_reusing(source, asset, previous.map(|p| &p.prepared))?;
    let topology_ms = t0.elapsed().as_secs_f64() * 1e3;
    let same = previous.filter(|p| prepared.same_geometry(&p.prepared));
    let same_step1 = previous.filter(|p| prepared.same_step1(&p.prepared));
    let step1 = match same_step1 {
        Some(p) => p.step1.clone(),
        None => step1::step1(&prepared, source, &asset.path)?,
    };
    let t = step1.times;
    let times = StageTimes {
        load_ms,
        topology_ms,
        boundary_ms: t.boundary_ms,
        factor_ms: t.factor_ms,
        solve_ms: t.solve_ms,
        ..StageTimes::default()
    };
    let warm = match reuse {
        // Both on the square: a free layout's boundary is not on it.
        Reuse::SetupAndLayout(p)
            if matches!(prepared.boundary, crate::free::BoundarySetup::Square)
                && matches!(p.prepared.boundary, crate::free::BoundarySetup::Square) =>
        {
            same_step1.map(|_| p.solver.layout())
        }
        _ => None,
    };
    let mut solver = ChartSolver::start(SolveStart {
        prepared: &prepared,
        source,
        options,
        boundary: &step1.boundary,
        step1: warm.unwrap_or(&step1.layout),
        bar_net: Some(&step1.bar_net),
        pattern: same.map(|p| p.solver.pattern()),
        elapsed_ms: times.total_ms(),
    })?;
    while !solver.is_done() {
        if stop() {
            return Ok(None);
        }
        solver.tick()?;
    }
    let report = report::build(&report::SolveSummary {
        constraint_file: source.name(),
        asset,
        prepared: &prepared,
        boundary: &step1.boundary,
        step1: &step1.layout,
        solver: &solver,
        times: times.with_solver(solver.times()),
    });
    Ok(Some(SolvedChart {
        prepared,
        step1,
        solver,
        report,
    }))
}

impl SolvedChart {
    /// The final UVs per primitive of `asset`.
    pub fn uvs(&self, asset: &SourceAsset) -> PrimitiveUvs {
        chart::assemble_uvs(asset, &self.prepared, self.solver.layout())
    }

    /// Checks the layout as stored, then writes `options.output`, the
    /// pictures and the report together (all or none); the final report.
    /// A refused layout writes nothing (or only the pictures, as
    /// `options.on_error` says).
    pub fn export(self, asset: &SourceAsset, options: &Options) -> Report {
        let t0 = Instant::now();
        let output = options.output.as_deref();
        let guard = self.solver.options().guard;
        let mut report = self.report.clone();
        let layout = self.solver.layout();
        let mut staged = crate::export::stage_chart(asset, &self.prepared, layout, &mut report, output, guard);
        report.times.export_ms = t0.elapsed().as_secs_f64() * 1e3;
        report.total_ms = report.times.total_ms();
        let refused = report.status == Status::Error;
        if refused && options.on_error == OnError::WriteNothing {
            return report;
        }
        #[cfg(feature = "pictures")]
        {
            let outer = &self.step1.boundary.loop_vertices;
            match crate::preview::render_chart(asset, &self.prepared, outer, layout, &report, &options.pictures) {
                Ok(pictures) => pictures.into_iter().for_each(|(path, png)| staged.add(path, png)),
                Err(e) => report.warnings.push(format!("preview: {e}")),
            }
        }
        if let Some(path) = options.report.as_ref().filter(|_| !refused) {
            let json = serde_json::to_string_pretty(&report).expect("the report serialises");
            staged.add(path.clone(), format!("{json}\n").into_bytes());
        }
        crate::export::commit(staged, &mut report);
        report
    }
}
