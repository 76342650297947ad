//! One-call solving for Rust users and the CLI: load, run the ECS schedule to
//! convergence, write the output atomically, return the report.

use crate::chart::{self, PrimitiveUvs};
use crate::constraints::LoadedConstraints;
use crate::constraints::{ConstraintFile, ConstraintSpec, CornerSpec};
use crate::ecs::{self, ChartData, Exported, Failed, Layout, PreviewRequest, SolveJob, Timings};
use crate::error::Error;
use crate::io::{self, SourceAsset};
use crate::mesh::TriMesh;
use crate::options::SolverOptions;
use crate::report::Report;
use bevy_ecs::prelude::*;
use glam::DVec2;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Upper bound on schedule ticks for one solve (each tick is one proposal).
pub const MAX_TICKS: usize = 1_000_000;

/// Loads a constraint file and its asset.
///
/// # Errors
/// Constraint-file and asset errors.
pub fn load(constraints_path: &Path) -> Result<(LoadedConstraints, SourceAsset), Error> {
    load_with_defaults(constraints_path, &SolverOptions::DEFAULT)
}

/// As [`load`], with solver `defaults` for a constraint file without `solver`.
///
/// # Errors
/// Constraint-file and asset errors.
pub fn load_with_defaults(
    constraints_path: &Path,
    defaults: &SolverOptions,
) -> Result<(LoadedConstraints, SourceAsset), Error> {
    let loaded = LoadedConstraints::load_with_defaults(constraints_path, defaults)?;
    let asset_path = loaded.asset_path();
    let asset = io::load_asset(&asset_path, loaded.file.mesh.as_ref(), loaded.file.uv_set).map_err(|e| match e {
        io::AssetError::Read { source, .. } if source.kind() == std::io::ErrorKind::NotFound => loaded
            .asset_error("asset", format!("{} does not exist", asset_path.display()))
            .into(),
        e => Error::from(e),
    })?;
    Ok((loaded, asset))
}

/// Spawns the chart entity for a loaded job into `world`.
///
/// # Errors
/// Errors of [`chart::prepare`].
pub fn spawn_job(
    world: &mut World,
    loaded: LoadedConstraints,
    asset: SourceAsset,
    output: Option<PathBuf>,
    load_ms: f64,
) -> Result<Entity, Error> {
    spawn_shared_job(world, loaded, Arc::new(asset), output, load_ms)
}

/// As [`spawn_job`], with the asset shared.
///
/// # Errors
/// Errors of [`chart::prepare`].
pub fn spawn_shared_job(
    world: &mut World,
    loaded: LoadedConstraints,
    asset: Arc<SourceAsset>,
    output: Option<PathBuf>,
    load_ms: f64,
) -> Result<Entity, Error> {
    let t0 = Instant::now();
    let prepared = chart::prepare(&loaded, &asset)?;
    let mut timings = Timings::default();
    timings.0.load_ms = load_ms;
    timings.0.topology_ms = t0.elapsed().as_secs_f64() * 1e3;
    let job = SolveJob {
        constraints: Arc::new(loaded),
        asset,
        output,
    };
    Ok(world.spawn((job, ChartData(Arc::new(prepared)), timings)).id())
}

/// Solves `constraints_path` and writes `output` (if given). Returns the
/// report: `Reached` or `Partial` (written, fold-free), or `Error` when the
/// final write failed. Input errors come back as `Err` with nothing written.
///
/// # Errors
/// Any input error: constraint file, asset, topology.
pub fn solve_file(constraints_path: &Path, output: Option<&Path>) -> Result<Report, Error> {
    solve_file_with_defaults(constraints_path, output, &SolverOptions::DEFAULT)
}

/// As [`solve_file`], with solver `defaults` (e.g. from `config/uvpin.ron`)
/// for a constraint file without `solver`.
///
/// # Errors
/// Any input error: constraint file, asset, topology.
pub fn solve_file_with_defaults(
    constraints_path: &Path,
    output: Option<&Path>,
    defaults: &SolverOptions,
) -> Result<Report, Error> {
    solve_file_with_previews(constraints_path, output, defaults, PreviewRequest::default())
}

/// As [`solve_file_with_defaults`], also drawing the pictures `previews`
/// asks for (the UV layout, the 3D render) once the solve is over.
///
/// # Errors
/// Any input error: constraint file, asset, topology.
pub fn solve_file_with_previews(
    constraints_path: &Path,
    output: Option<&Path>,
    defaults: &SolverOptions,
    previews: PreviewRequest,
) -> Result<Report, Error> {
    let t0 = Instant::now();
    let (loaded, asset) = load_with_defaults(constraints_path, defaults)?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut world = World::new();
    let entity = spawn_job(&mut world, loaded, asset, output.map(Path::to_path_buf), load_ms)?;
    if previews.layout.is_some() || previews.render.is_some() {
        world.entity_mut(entity).insert(previews);
    }
    run_job(world, entity).map(|(report, _)| report)
}

/// Solves an already loaded constraint file and asset (e.g. with edited
/// targets, as a sweep does), writing `output` if given and the pictures
/// `previews` asks for. Returns the report; input errors as `Err`.
///
/// # Errors
/// Topology and constraint errors against the asset.
pub fn solve_loaded(
    loaded: LoadedConstraints,
    asset: SourceAsset,
    output: Option<&Path>,
    previews: PreviewRequest,
) -> Result<Report, Error> {
    solve_loaded_shared(loaded, Arc::new(asset), output, previews)
}

/// As [`solve_loaded`], with the asset shared (many solves of one asset).
///
/// # Errors
/// Topology and constraint errors against the asset.
pub fn solve_loaded_shared(
    loaded: LoadedConstraints,
    asset: Arc<SourceAsset>,
    output: Option<&Path>,
    previews: PreviewRequest,
) -> Result<Report, Error> {
    let mut world = World::new();
    let entity = spawn_shared_job(&mut world, loaded, asset, output.map(Path::to_path_buf), 0.0)?;
    if previews.layout.is_some() || previews.render.is_some() {
        world.entity_mut(entity).insert(previews);
    }
    run_job(world, entity).map(|(report, _)| report)
}

/// The error a job failed with, if it did (taken out of the world).
fn take_failure(world: &mut World, entity: Entity) -> Option<Error> {
    let failed = world.entity_mut(entity).take::<Failed>()?;
    Some(Arc::try_unwrap(failed.0).unwrap_or_else(|e| Error::Internal(e.to_string())))
}

/// Runs the schedule on a spawned job and returns its report and final UVs
/// (per primitive, glTF texture coordinates).
fn run_job(mut world: World, entity: Entity) -> Result<(Report, PrimitiveUvs), Error> {
    let mut schedule = ecs::solve_schedule();
    ecs::run_to_convergence(&mut world, &mut schedule, MAX_TICKS);
    if let Some(error) = take_failure(&mut world, entity) {
        return Err(error);
    }
    let report = world
        .get::<Exported>(entity)
        .map(|e| e.0.clone())
        .ok_or_else(|| Error::Internal(format!("the solve did not finish within {MAX_TICKS} ticks")))?;
    let (job, data, layout) = (
        world.get::<SolveJob>(entity).expect("job"),
        world.get::<ChartData>(entity).expect("chart"),
        world.get::<Layout>(entity).expect("layout"),
    );
    let uvs = chart::assemble_uvs(&job.asset, &data.0, &layout.0);
    Ok((report, uvs))
}

/// Solves a mesh held in memory: `constraints` are `(vertex, target uv)` in
/// glTF texture coordinates, `corners` optional corner vertices (top_left,
/// bottom_left, bottom_right, top_right). Returns the report and one UV per
/// vertex of `mesh` (vertices outside the solved chart get (0, 0)).
///
/// The same ECS schedule as [`solve_file`] runs; nothing is written.
///
/// # Errors
/// Invalid constraints (out of range, outside the square, conflicting
/// duplicates) and topology errors.
pub fn solve_mesh(
    mesh: &TriMesh,
    constraints: &[(u32, DVec2)],
    corners: Option<[u32; 4]>,
    options: SolverOptions,
) -> Result<(Report, Vec<[f32; 2]>), Error> {
    let t0 = Instant::now();
    let loaded = memory_constraints(constraints, corners, options)?;
    let asset = io::SourceAsset::from_mesh(mesh);
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut world = World::new();
    let entity = spawn_job(&mut world, loaded, asset, None, load_ms)?;
    let (report, mut uvs) = run_job(world, entity)?;
    Ok((report, uvs.swap_remove(0)))
}

/// Constraints held in memory as a constraint file would give them.
fn memory_constraints(
    constraints: &[(u32, DVec2)],
    corners: Option<[u32; 4]>,
    options: SolverOptions,
) -> Result<LoadedConstraints, Error> {
    let file = ConstraintFile {
        asset: "<memory>".into(),
        mesh: None,
        primitive: 0,
        uv_set: 0,
        image_size: None,
        constraints: constraints
            .iter()
            .map(|&(v, uv)| ConstraintSpec {
                vertex: Some(v),
                uv: Some(uv),
                ..Default::default()
            })
            .collect(),
        corners: corners.map(|c| CornerSpec {
            top_left: c[0],
            bottom_left: c[1],
            bottom_right: c[2],
            top_right: c[3],
        }),
        solver: Some(options),
    };
    Ok(LoadedConstraints::from_file(Path::new("<memory>"), file)?)
}

/// Whether `constraints` (as for [`solve_mesh`]) are provably unreachable on
/// `mesh`, without solving them: step 1 puts the boundary on the square,
/// then [`crate::complete::obstruction`] looks for pieces pinned in place
/// (by the boundary and the targets) that already fold or overlap.
/// `Some(reason)` says what would have to happen for every target to be
/// reached; `None` proves nothing either way.
///
/// # Errors
/// As [`solve_mesh`].
pub fn unreachable_proof(
    mesh: &TriMesh,
    constraints: &[(u32, DVec2)],
    corners: Option<[u32; 4]>,
) -> Result<Option<String>, Error> {
    let loaded = memory_constraints(constraints, corners, SolverOptions::DEFAULT)?;
    let mut world = World::new();
    let entity = spawn_job(&mut world, loaded, io::SourceAsset::from_mesh(mesh), None, 0.0)?;
    let mut schedule = ecs::solve_schedule();
    // Step 1 and the stepping set-up take a few ticks.
    for _ in 0..16 {
        schedule.run(&mut world);
        if let Some(error) = take_failure(&mut world, entity) {
            return Err(error);
        }
        let entity = world.entity(entity);
        let (Some(data), Some(step1), Some(stepping), Some(boundary)) = (
            entity.get::<ChartData>(),
            entity.get::<ecs::Step1Layout>(),
            entity.get::<ecs::Stepping>(),
            entity.get::<ecs::BoundaryLayout>(),
        ) else {
            continue;
        };
        let mut on_outer = vec![false; data.0.filled.mesh.n_vertices()];
        boundary
            .0
            .loop_vertices
            .iter()
            .for_each(|&v| on_outer[v as usize] = true);
        let certificate = crate::complete::find_obstruction(&data.0.filled, &step1.0, &stepping.problem);
        return Ok(certificate.map(|c| c.describe(crate::report::vertex_namer(&data.0, &on_outer))));
    }
    Err(Error::Internal("step 1 did not finish".into()))
}
