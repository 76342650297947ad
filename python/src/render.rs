//! `render_view`: the library's z-buffered render, for finding things on a
//! mesh (the photo workflow finds a face on it and carries each point back
//! to the surface through the triangle buffer).

use crate::{finite_rows, input_error, mesh_of};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use uvpin::preview::render::{RenderScene, render_view as render};

/// The largest picture side rendered: a square image of this side is
/// 256 MB of RGBA.
const MAX_SIZE: u32 = 8192;

/// Renders `vertices`/`faces` orthographically, looking along `view` with
/// `up` shown up, `size` × `size` pixels over white: flat-shaded grey, or
/// `texture` (h, w, 3 uint8) through `uvs` (n, 2, glTF). Returns the image
/// (size, size, 3 uint8), the triangle each pixel shows (size, size; -1
/// for none) and each vertex's pixel position (n, 2; x right, y down,
/// pixel (i, j) spanning i..i+1, j..j+1).
#[pyfunction]
#[pyo3(signature = (vertices, faces, view, up, size=512, uvs=None, texture=None))]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn render_view<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    view: [f64; 3],
    up: [f64; 3],
    size: u32,
    uvs: Option<PyReadonlyArray2<'py, f64>>,
    texture: Option<PyReadonlyArray3<'py, u8>>,
) -> PyResult<(
    Bound<'py, PyArray3<u8>>,
    Bound<'py, PyArray2<i64>>,
    Bound<'py, PyArray2<f64>>,
)> {
    let mesh = mesh_of(&vertices, &faces)?;
    if size == 0 || size > MAX_SIZE {
        return Err(input_error(format!("size must be 1..={MAX_SIZE} pixels, not {size}")));
    }
    let [view, up] = [view, up].map(glam::DVec3::from_array);
    if !view.is_finite() || view.length() == 0.0 || !up.is_finite() {
        return Err(input_error("view must be a finite, non-zero direction and up finite"));
    }
    let n = mesh.positions.len();
    let uvs: Vec<glam::DVec2> = match &uvs {
        Some(u) => {
            let a = u.as_array();
            if finite_rows("uvs", &a, 2)? != n {
                return Err(input_error(format!("uvs has {} rows for {n} vertices", a.nrows())));
            }
            a.outer_iter().map(|r| glam::DVec2::new(r[0], r[1])).collect()
        }
        None => vec![glam::DVec2::splat(0.5); n],
    };
    let texture = match &texture {
        Some(t) => Some(rgba_of(&t.as_array())?),
        None => None,
    };
    let texture = texture.or_else(|| Some(image::RgbaImage::from_pixel(1, 1, image::Rgba([200, 200, 200, 255]))));
    let scene = RenderScene {
        positions: &mesh.positions,
        triangles: &mesh.triangles,
        uvs: &uvs,
        texture: texture.as_ref(),
        marks: &[],
        lines: &[],
        view: Some(view),
        up: Some(up),
    };
    let drawn = py.detach(|| render(&scene, size));
    let side = size as usize;
    let rgb: Vec<u8> = drawn.image.pixels().flat_map(|p| [p.0[0], p.0[1], p.0[2]]).collect();
    let fail = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(e.to_string());
    let image = Array3::from_shape_vec((side, side, 3), rgb).map_err(fail)?;
    let ids: Vec<i64> = drawn.triangle.iter().map(|t| t.map_or(-1, i64::from)).collect();
    let triangle = Array2::from_shape_vec((side, side), ids).map_err(fail)?;
    let screen: Vec<f64> = drawn.screen.iter().flat_map(|p| [p.x, p.y]).collect();
    let screen = Array2::from_shape_vec((n, 2), screen).map_err(fail)?;
    Ok((
        image.into_pyarray(py),
        triangle.into_pyarray(py),
        screen.into_pyarray(py),
    ))
}

/// An (h, w, 3) uint8 array as an RGBA image.
fn rgba_of(a: &numpy::ndarray::ArrayView3<'_, u8>) -> PyResult<image::RgbaImage> {
    let (h, w, c) = a.dim();
    if c != 3 || h == 0 || w == 0 || h > MAX_SIZE as usize || w > MAX_SIZE as usize {
        return Err(input_error(format!(
            "texture must have shape (h, w, 3) with sides 1..={MAX_SIZE}, not {:?}",
            a.shape()
        )));
    }
    let mut image = image::RgbaImage::new(w as u32, h as u32);
    for (x, y, p) in image.enumerate_pixels_mut() {
        let (i, j) = (y as usize, x as usize);
        *p = image::Rgba([a[[i, j, 0]], a[[i, j, 1]], a[[i, j, 2]], 255]);
    }
    Ok(image)
}
