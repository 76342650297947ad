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

#![warn(missing_docs)]

use crate::assembly;
use crate::chart::{self, PreparedChart};
use crate::constraints::{ConstraintSource, LoadedConstraints};
use crate::error::Error;
pub use crate::export::OnError;
use crate::export::Outputs;
use crate::io::{self, SourceAsset};
use crate::mesh::TriMesh;
use crate::options::SolverOptions;
use crate::pins::Pins;
use crate::report::{self, Report};
use crate::session::ChartSession;
use crate::solver::step_one::StepOne;
use crate::solver::{Progress, Stage};
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
    /// Told where a solve stands as it goes (`None`: nobody is told).
    pub progress: Option<ProgressSink>,
}

/// Receives a solve's [`Progress`]: each stage as it begins, and after
/// every tick of the solver (often: a display throttles itself).
#[derive(Clone)]
pub struct ProgressSink(pub Arc<dyn Fn(Progress) + Send + Sync>);

impl std::fmt::Debug for ProgressSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ProgressSink")
    }
}

impl ProgressSink {
    fn tell(sink: Option<&ProgressSink>, progress: Progress) {
        if let Some(sink) = sink {
            (sink.0)(progress);
        }
    }
}

impl Options {
    /// These options, writing the asset to `output`.
    #[must_use]
    pub fn with_output(mut self, output: impl Into<PathBuf>) -> Self {
        self.output = Some(output.into());
        self
    }

    /// What a solve with these options writes.
    pub fn outputs(&self) -> Outputs {
        Outputs {
            model: self.output.clone(),
            report: self.report.clone(),
            #[cfg(feature = "pictures")]
            pictures: self.pictures.clone(),
            writing: io::atomic::Writing::default(),
            on_error: self.on_error,
        }
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

/// A solved in-memory mesh: the report and its texture coordinates (glTF
/// convention, f32 as a file would store them), per vertex and per face
/// corner. A vertex on a seam has one UV per side: `corner_uvs` has them
/// all, `uvs` the first corner's. Every triangle has UVs (pieces without
/// pins are unwrapped and packed around the pinned chart); when the
/// layout is refused (status error) both are zeros and empty.
#[derive(Debug, Clone)]
pub struct MeshSolution {
    /// What was reached, how far, and the layout's stretch.
    pub report: Report,
    /// One texture coordinate per vertex of the mesh.
    pub uvs: Vec<[f32; 2]>,
    /// One texture coordinate per corner of each triangle, in triangle order.
    pub corner_uvs: Vec<[f32; 2]>,
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
        io::load_asset(&asset_path, loaded.file.mesh.as_ref(), loaded.file.uv_set(), input).map_err(|e| match e {
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
    ProgressSink::tell(options.progress.as_ref(), Progress::at(Stage::Loading));
    let (loaded, asset) = load(constraints_path, &options.solver, &options.input)?;
    if let Some(out) = &options.output {
        io::gltf_file::check_output_kind(&asset, out)?;
    }
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    solve_loaded_in(loaded, &Arc::new(asset), options, load_ms)
}

/// Solves an already loaded constraint file and asset (e.g. with edited
/// targets, as a sweep does); `options.solver` is not used (the loaded
/// file's options are in force).
///
/// # Errors
/// Topology and constraint errors against the asset.
pub fn solve_loaded(loaded: LoadedConstraints, asset: &Arc<SourceAsset>, options: &Options) -> Result<Report, Error> {
    solve_loaded_in(loaded, asset, options, 0.0)
}

/// The one path from a loaded file to written outputs: a chart session
/// opened, solved and exported.
fn solve_loaded_in(
    loaded: LoadedConstraints,
    asset: &Arc<SourceAsset>,
    options: &Options,
    load_ms: f64,
) -> Result<Report, Error> {
    let solver_options = loaded.solver;
    let source = ConstraintSource::File(Arc::new(loaded));
    let sink = options.progress.as_ref();
    ProgressSink::tell(sink, Progress::at(Stage::Opening));
    let mut session = ChartSession::open(source, asset.clone(), load_ms)?;
    let solved = assembly::solve_watching(&mut session, &solver_options, &mut |p| ProgressSink::tell(sink, p))?;
    ProgressSink::tell(sink, Progress::at(Stage::Writing));
    Ok(assembly::export(&session, &solved, &options.outputs()).report)
}

/// Solves a mesh held in memory with `pins` and `options.solver`; nothing
/// is written.
///
/// # Errors
/// Invalid pins (out of range, outside the square, conflicting duplicates)
/// and topology errors.
pub fn solve_mesh(mesh: &TriMesh, pins: &Pins, options: &Options) -> Result<MeshSolution, Error> {
    solve_memory(SourceAsset::from_mesh(mesh), pins, options)
}

/// Solves a mesh held in memory that already has texture coordinates, one
/// per vertex (an atlas; glTF's convention, v down): vertices with the same
/// position and UV are one, the chart holding the pins is laid out again
/// (a free boundary keeps clear of the other charts), and every other vertex
/// keeps its UV.
///
/// # Errors
/// As [`solve_mesh`]; `uvs` not one per vertex.
pub fn solve_atlas(mesh: &TriMesh, uvs: &[[f32; 2]], pins: &Pins, options: &Options) -> Result<MeshSolution, Error> {
    let mut asset = SourceAsset::from_mesh(mesh);
    if uvs.len() != mesh.n_vertices() {
        return Err(Error::Asset(io::AssetError::Primitive {
            path: asset.path,
            mesh: 0,
            primitive: 0,
            message: format!("has {} UVs for {} vertices", uvs.len(), mesh.n_vertices()),
        }));
    }
    asset.primitives[0].uvs = Some(uvs.to_vec());
    solve_memory(asset, pins, options)
}

/// A session on an in-memory asset, solved; nothing written.
fn solve_memory(asset: SourceAsset, pins: &Pins, options: &Options) -> Result<MeshSolution, Error> {
    let source = ConstraintSource::Memory(Arc::new(pins.clone()));
    let mut session = ChartSession::open(source, Arc::new(asset), 0.0)?;
    let solved = assembly::solve(&mut session, &options.solver)?;
    let (report, corners) = assembly::final_uvs(&session, &solved);
    let asset = session.asset();
    let prim = &asset.primitives[0];
    let (uvs, corner_uvs) = match corners {
        Some(mut c) => {
            let c = c.swap_remove(0);
            let mut per_vertex = c.split(&prim.indices).uvs;
            per_vertex.truncate(prim.positions.len());
            (per_vertex, c.corners)
        }
        None => (vec![[0.0; 2]; prim.positions.len()], Vec::new()),
    };
    Ok(MeshSolution {
        report,
        uvs,
        corner_uvs,
    })
}

/// Step 1 of a mesh held in memory: the chart, the boundary on the square,
/// the bar-net factor and the layout.
#[derive(Debug, Clone)]
pub struct MeshStepOne {
    /// The chart: weld, topology, hole fill.
    pub prepared: PreparedChart,
    /// The boundary on the square, the factor and the step-1 layout.
    pub step_one: StepOne,
}

impl MeshStepOne {
    /// The step-1 position (layout coordinates, y up) of every vertex of
    /// the mesh; `None` outside the chart.
    pub fn vertex_layout(&self) -> Vec<Option<DVec2>> {
        let p = &self.prepared;
        p.welded.vertex_of[0]
            .iter()
            .map(|&w| p.chart.local_of(w).map(|local| self.step_one.layout[local as usize]))
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
pub fn step_one(mesh: &TriMesh, corners: Option<[u32; 4]>) -> Result<MeshStepOne, Error> {
    let pins = Pins {
        corners,
        ..Pins::default()
    };
    let mut session = ChartSession::of_mesh(mesh, pins)?;
    session.run_step_one()?;
    let step_one = session
        .step_one()
        .ok_or_else(|| Error::Internal("step 1 was not solved".into()))?;
    Ok(MeshStepOne {
        prepared: session.prepared().clone(),
        step_one,
    })
}

/// Whether `pins` are provably unreachable on `mesh`, without solving them:
/// step 1 puts the boundary on the square, then
/// [`crate::complete::obstruction`] looks for pieces pinned in place (by the
/// targets and, on the square, the boundary) that already fold or overlap. `Some(reason)`
/// says what would have to happen for every target to be reached; `None`
/// proves nothing either way.
///
/// # Errors
/// As [`solve_mesh`].
pub fn unreachable_proof(mesh: &TriMesh, pins: &Pins) -> Result<Option<String>, Error> {
    let mut session = ChartSession::of_mesh(mesh, pins.clone())?;
    session.run_step_one()?;
    let (Some(boundary), Some(layout)) = (session.boundary(), session.step_one_layout()) else {
        return Err(Error::Internal("step 1 was not solved".into()));
    };
    let prepared = session.prepared();
    let max_centres = SolverOptions::DEFAULT.max_boundary_centres;
    let problem = chart::step_problem(prepared, session.source(), boundary, max_centres)?;
    let on_outer = boundary.on_loop(prepared.filled.mesh.n_vertices());
    let pinned = crate::complete::Pinned::for_boundary(prepared.domain.free().is_some());
    let certificate = crate::complete::find_obstruction(&prepared.filled, (layout, pinned), &problem);
    Ok(certificate.map(|c| c.describe(report::vertex_namer(prepared, &on_outer))))
}
