//! `uvpin._native`: the Python extension. Thin adapters over the library
//! API (`uvpin::api`, `uvpin::check`, `uvpin::inspect`, `uvpin::sweep`): arrays
//! are checked and copied in, the GIL is released while a solve runs, and
//! reports cross as JSON text (the same JSON the CLI writes). The Python
//! package (`uvpin/__init__.py`) shapes them into its `Result` and dicts.

use numpy::ndarray::{Array2, ArrayView2};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::path::PathBuf;
use uvpin::mesh::TriMesh;
use uvpin::options::SolverOptions;
use uvpin::param::region::Region;
use uvpin::pins::{BoundaryChoice, Pins};

mod render;

create_exception!(
    _native,
    InputError,
    PyValueError,
    "Bad input: a mesh, pins, options or file uvpin cannot use. The message names the offending index, or line:column in a file."
);

fn input_error(message: impl Into<String>) -> PyErr {
    InputError::new_err(message.into())
}

/// uvpin's own errors: a bug is a RuntimeError, everything else bad input.
fn uvpin_error(e: uvpin::Error) -> PyErr {
    match e {
        uvpin::Error::Internal(m) => PyRuntimeError::new_err(m),
        e => input_error(e.to_string()),
    }
}

/// `name` has shape (rows, `columns`) with every entry finite.
fn finite_rows<'a>(name: &str, a: &'a ArrayView2<'a, f64>, columns: usize) -> PyResult<usize> {
    if a.ncols() != columns {
        return Err(input_error(format!(
            "{name} must have shape (n, {columns}), not {:?}",
            a.shape()
        )));
    }
    if let Some((row, _)) = a
        .outer_iter()
        .enumerate()
        .find(|(_, r)| r.iter().any(|x| !x.is_finite()))
    {
        return Err(input_error(format!("{name}[{row}] is not finite: {}", a.row(row))));
    }
    Ok(a.nrows())
}

/// Vertex ids (checked in range of `n`); `name(i)` names entry `i`.
fn vertex_ids<'a>(
    name: impl Fn(usize) -> String,
    ids: impl IntoIterator<Item = &'a i64>,
    n: usize,
) -> PyResult<Vec<u32>> {
    ids.into_iter()
        .enumerate()
        .map(|(i, &v)| {
            u32::try_from(v).ok().filter(|&v| (v as usize) < n).ok_or_else(|| {
                input_error(format!(
                    "{} = {v} is out of range: the mesh has vertices 0..{n}",
                    name(i)
                ))
            })
        })
        .collect()
}

/// The mesh of `vertices` (n, 3) and `faces` (m, 3).
fn mesh_of(vertices: &PyReadonlyArray2<'_, f64>, faces: &PyReadonlyArray2<'_, i64>) -> PyResult<TriMesh> {
    let v = vertices.as_array();
    let n = finite_rows("vertices", &v, 3)?;
    let f = faces.as_array();
    if f.ncols() != 3 {
        return Err(input_error(format!(
            "faces must have shape (m, 3) (triangles), not {:?}",
            f.shape()
        )));
    }
    if f.nrows() == 0 {
        return Err(input_error("faces is empty: there is nothing to lay out"));
    }
    let corners = vertex_ids(|i| format!("faces[{}][{}]", i / 3, i % 3), f.iter(), n)?;
    Ok(TriMesh {
        positions: v.outer_iter().map(|r| glam::DVec3::new(r[0], r[1], r[2])).collect(),
        triangles: corners.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    })
}

/// Texture coordinates (n, 2) as glTF stores them (f32).
fn uvs_of(uvs: &PyReadonlyArray2<'_, f64>, n: usize) -> PyResult<Vec<[f32; 2]>> {
    let a = uvs.as_array();
    if finite_rows("uvs", &a, 2)? != n {
        return Err(input_error(format!("uvs has {} rows for {n} vertices", a.nrows())));
    }
    Ok(a.outer_iter().map(|r| [r[0] as f32, r[1] as f32]).collect())
}

/// Solver settings from JSON (the `solver` section's fields), checked.
fn solver_options(json: Option<&str>) -> PyResult<SolverOptions> {
    let options: SolverOptions = match json {
        None => SolverOptions::default(),
        Some(text) => serde_json::from_str(text).map_err(|e| input_error(format!("options: {e}")))?,
    };
    options.check().map_err(|e| input_error(format!("options: {e}")))?;
    Ok(options)
}

/// The pins: ids, targets (k, 2), a boundary choice and a region.
fn pins_of(
    ids: &PyReadonlyArray1<'_, i64>,
    targets: &PyReadonlyArray2<'_, f64>,
    n: usize,
    boundary: &str,
    region: Option<[f64; 4]>,
    corners: Option<[i64; 4]>,
) -> PyResult<Pins> {
    let t = targets.as_array();
    let k = finite_rows("pin targets", &t, 2)?;
    let ids = vertex_ids(|i| format!("pin ids[{i}]"), ids.as_array().iter(), n)?;
    if ids.len() != k {
        return Err(input_error(format!("{} pin ids for {k} targets", ids.len())));
    }
    let targets: Vec<(u32, glam::DVec2)> = ids
        .iter()
        .zip(t.outer_iter())
        .map(|(&v, r)| (v, glam::DVec2::new(r[0], r[1])))
        .collect();
    let mut pins = Pins::new(&targets);
    if let Some(c) = corners {
        let c = vertex_ids(|i| format!("corners[{i}]"), c.iter(), n)?;
        pins.corners = Some([c[0], c[1], c[2], c[3]]);
    }
    pins.boundary = match boundary {
        "auto" => None,
        "square" => Some(BoundaryChoice::Square),
        "free" => Some(BoundaryChoice::Free),
        other => {
            return Err(input_error(format!(
                "boundary must be \"auto\", \"square\" or \"free\", not {other:?}"
            )));
        }
    };
    if let Some([u0, v0, u1, v1]) = region {
        let region = Region {
            min: glam::DVec2::new(u0, v0),
            max: glam::DVec2::new(u1, v1),
        };
        if let Some(why) = region.problem() {
            return Err(input_error(format!("region {region:?}: {why}")));
        }
        pins.region = Some(region);
    }
    Ok(pins)
}

/// Solves an in-memory mesh; returns the UVs per vertex (n, 2) and per
/// face corner (m, 3, 2), or None when nothing could be laid out, and the
/// report as JSON.
#[pyfunction]
#[pyo3(signature = (vertices, faces, pin_ids, pin_targets, uvs=None, boundary="auto", region=None, corners=None, options=None))]
#[allow(clippy::too_many_arguments)]
fn solve_mesh<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    pin_ids: PyReadonlyArray1<'py, i64>,
    pin_targets: PyReadonlyArray2<'py, f64>,
    uvs: Option<PyReadonlyArray2<'py, f64>>,
    boundary: &str,
    region: Option<[f64; 4]>,
    corners: Option<[i64; 4]>,
    options: Option<&str>,
) -> PyResult<(
    Option<Bound<'py, PyArray2<f64>>>,
    Option<Bound<'py, PyArray3<f64>>>,
    String,
)> {
    let mesh = mesh_of(&vertices, &faces)?;
    let n = mesh.n_vertices();
    let pins = pins_of(&pin_ids, &pin_targets, n, boundary, region, corners)?;
    let uvs = uvs.map(|u| uvs_of(&u, n)).transpose()?;
    let options = uvpin::Options::from(solver_options(options)?);
    let solved = py
        .detach(|| match &uvs {
            Some(uvs) => uvpin::api::solve_atlas(&mesh, uvs, &pins, &options),
            None => uvpin::solve_mesh(&mesh, &pins, &options),
        })
        .map_err(uvpin_error)?;
    let report = serde_json::to_string(&solved.report).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let laid_out = solved.report.status != uvpin::Status::Error;
    let layout = laid_out.then(|| {
        let flat: Vec<f64> = solved.uvs.iter().flat_map(|uv| [uv[0] as f64, uv[1] as f64]).collect();
        Array2::from_shape_vec((n, 2), flat)
            .expect("one uv per vertex")
            .into_pyarray(py)
    });
    let corners = (laid_out && solved.corner_uvs.len() == 3 * mesh.n_triangles()).then(|| {
        let flat: Vec<f64> = solved
            .corner_uvs
            .iter()
            .flat_map(|uv| [uv[0] as f64, uv[1] as f64])
            .collect();
        numpy::ndarray::Array3::from_shape_vec((mesh.n_triangles(), 3, 2), flat)
            .expect("one uv per corner")
            .into_pyarray(py)
    });
    Ok((layout, corners, report))
}

/// Solves a constraint file and writes `output` and `report` (all or none);
/// returns the report as JSON.
#[pyfunction]
#[pyo3(signature = (path, output=None, report=None))]
fn solve_file(py: Python<'_>, path: PathBuf, output: Option<PathBuf>, report: Option<PathBuf>) -> PyResult<String> {
    let options = uvpin::Options {
        output,
        report,
        ..Default::default()
    };
    let report = py.detach(|| uvpin::solve_file(&path, &options)).map_err(uvpin_error)?;
    serde_json::to_string(&report).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// Reads a constraint file as the solver does (errors with line:column) and
/// returns its fields as JSON; relative `asset` and `image` paths stay as
/// written (relative to the file).
#[pyfunction]
fn read_constraints(path: PathBuf) -> PyResult<String> {
    let loaded = uvpin::constraints::LoadedConstraints::load(&path).map_err(|e| input_error(e.to_string()))?;
    serde_json::to_string(&loaded.file).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

fn selector(mesh: Option<&str>) -> Option<uvpin::io::MeshSelector> {
    mesh.map(|m| {
        m.parse::<usize>()
            .map(uvpin::io::MeshSelector::Index)
            .unwrap_or_else(|_| uvpin::io::MeshSelector::Name(m.into()))
    })
}

/// `uvpin check` of a file, as JSON.
#[pyfunction]
#[pyo3(signature = (path, uv_set=0, mesh=None, constraints=None))]
fn check_file(
    py: Python<'_>,
    path: PathBuf,
    uv_set: u32,
    mesh: Option<&str>,
    constraints: Option<PathBuf>,
) -> PyResult<String> {
    let mesh = selector(mesh);
    let checked = py
        .detach(|| uvpin::check::check_file(&path, uv_set, mesh.as_ref(), constraints.as_deref()))
        .map_err(uvpin_error)?;
    serde_json::to_string(&checked).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// The same check of UVs held in memory (glTF's convention, v down), as JSON.
#[pyfunction]
fn check_mesh<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    uvs: PyReadonlyArray2<'py, f64>,
) -> PyResult<String> {
    let mesh = mesh_of(&vertices, &faces)?;
    let uvs = uvs_of(&uvs, mesh.n_vertices())?;
    let checked = py.detach(|| uvpin::check::check_mesh(&mesh, &uvs));
    serde_json::to_string(&checked).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// `uvpin inspect` of a file, as JSON.
#[pyfunction]
#[pyo3(signature = (path, mesh=None, uv_set=0, near=None, boundary=false))]
fn inspect(
    py: Python<'_>,
    path: PathBuf,
    mesh: Option<&str>,
    uv_set: u32,
    near: Option<[f64; 3]>,
    boundary: bool,
) -> PyResult<String> {
    let request = uvpin::inspect::InspectRequest {
        mesh: selector(mesh),
        uv_set,
        near: near.map(glam::DVec3::from_array),
        boundary,
    };
    let found = py
        .detach(|| uvpin::inspect::inspect(&path, &request, &uvpin::io::InputRules::default()))
        .map_err(|e| input_error(e.to_string()))?;
    serde_json::to_string(&found).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// A mesh of a glTF or OBJ file as arrays: positions (n, 3), triangles
/// (m, 3) over all its primitives, and UV set `uv_set` (n, 2) when every
/// primitive has it.
#[pyfunction]
#[pyo3(signature = (path, mesh=None, uv_set=0))]
#[allow(clippy::type_complexity)]
fn read_mesh<'py>(
    py: Python<'py>,
    path: PathBuf,
    mesh: Option<&str>,
    uv_set: u32,
) -> PyResult<(
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<i64>>,
    Option<Bound<'py, PyArray2<f64>>>,
)> {
    let rules = uvpin::io::InputRules::default();
    let asset = py
        .detach(|| uvpin::io::load_asset(&path, selector(mesh).as_ref(), uv_set, &rules))
        .map_err(|e| input_error(e.to_string()))?;
    let (mut positions, mut faces, mut uvs) = (Vec::new(), Vec::new(), Some(Vec::new()));
    for p in &asset.primitives {
        let offset = (positions.len() / 3) as i64;
        positions.extend(p.positions.iter().flatten().map(|&x| f64::from(x)));
        faces.extend(p.indices.iter().map(|&i| offset + i64::from(i)));
        uvs = uvs.zip(p.uvs.as_ref()).map(|(mut all, u)| {
            all.extend(u.iter().flatten().map(|&x| f64::from(x)));
            all
        });
    }
    let n = positions.len() / 3;
    let array = |flat: Vec<f64>, columns: usize| Array2::from_shape_vec((flat.len() / columns, columns), flat);
    let fail = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(e.to_string());
    let uvs = uvs
        .filter(|u| u.len() == 2 * n)
        .map(|u| array(u, 2))
        .transpose()
        .map_err(fail)?;
    Ok((
        array(positions, 3).map_err(fail)?.into_pyarray(py),
        Array2::from_shape_vec((faces.len() / 3, 3), faces)
            .map_err(fail)?
            .into_pyarray(py),
        uvs.map(|u| u.into_pyarray(py)),
    ))
}

mod sweep;

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add_function(wrap_pyfunction!(solve_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(solve_file, m)?)?;
    m.add_function(wrap_pyfunction!(check_file, m)?)?;
    m.add_function(wrap_pyfunction!(check_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(inspect, m)?)?;
    m.add_function(wrap_pyfunction!(read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_view, m)?)?;
    m.add_function(wrap_pyfunction!(read_constraints, m)?)?;
    m.add_class::<sweep::Sweep>()?;
    Ok(())
}
