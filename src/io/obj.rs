//! Wavefront OBJ as artists export it: `v` positions, `vt` texture
//! coordinates and `f` faces of three or more corners (triangulated for
//! the solve, written back as the polygons they were). With `vt` on every
//! corner, the `v`/`vt` pairs give the charts of an atlas as glTF's split
//! vertices do. Vertex ids in constraint files are 0-based `v` indices.
//! Output keeps every line but `vt`, writes the `vt` of each `v`'s corners
//! right after it and points each face corner at its own. OBJ texture
//! coordinates have `v` up: a layout point `(x, y)` is stored as `vt x y`,
//! each rounded to f32 (the guard checks that form too).

use super::AssetError;
use super::read::InputLimits;
use crate::mesh::weld::PrimitiveGeometry;
use std::collections::HashMap;
use std::path::Path;

/// One face corner: its `v` index and, if given, its `vt` index (0-based).
type Corner = (u32, Option<u32>);

/// What an OBJ file holds that uvpin reads: its faces as written.
struct ObjData {
    positions: Vec<[f32; 3]>,
    tex_coords: Vec<[f32; 2]>,
    /// Every face's corners, faces in file order.
    faces: Vec<Vec<Corner>>,
}

/// How an OBJ's faces became the triangles uvpin solves, for writing its
/// texture coordinates back per face corner.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ObjFaces {
    /// For each corner of the primitive's triangles (index order), the face
    /// corner it is: corners of all faces numbered in file order.
    pub face_corner: Vec<u32>,
    /// Number of face corners.
    pub n_face_corners: usize,
    /// The edges triangulation added inside polygons (primitive vertex
    /// pairs): seams never run along them.
    pub diagonals: Vec<[u32; 2]>,
    /// The `vt` of each primitive vertex as stored (v up), when they were
    /// read as its UVs: what corners outside the solved chart keep.
    pub vt: Option<TexCoords>,
}

/// An OBJ mesh as uvpin solves it.
#[derive(Debug, Clone)]
pub struct ObjMesh {
    pub primitive: PrimitiveGeometry,
    pub faces: ObjFaces,
    /// The `vt` of each primitive vertex as stored (v up), when the faces
    /// name them and they were read as the primitive's UVs.
    pub tex_coords: Option<TexCoords>,
}

/// What is wrong with one line of an OBJ file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ObjLineError {
    #[error("bad face index {text:?}: {reason}")]
    BadIndex {
        text: String,
        reason: std::num::ParseIntError,
    },
    #[error("face index {index} out of range (1..={n})")]
    IndexOutOfRange { index: i64, n: usize },
    #[error("bad {what}: {reason}")]
    BadNumber {
        what: &'static str,
        reason: std::num::ParseFloatError,
    },
    #[error("a {what} needs {n} numbers")]
    TooFewNumbers { what: &'static str, n: usize },
    #[error("a {what} has a non-finite coordinate")]
    NonFinite { what: &'static str },
    #[error("face with {n} corners: a face needs at least 3")]
    TooFewCorners { n: usize },
    #[error("face names vertex {vertex} twice")]
    RepeatedVertex { vertex: u32 },
    #[error("no faces")]
    NoFaces,
}

/// A 1-based (or negative, relative) OBJ index into a list of `n` as 0-based.
fn resolve_index(text: &str, n: usize) -> Result<u32, ObjLineError> {
    let v: i64 = text.parse().map_err(|reason| ObjLineError::BadIndex {
        text: text.to_string(),
        reason,
    })?;
    let idx = if v > 0 { v - 1 } else { n as i64 + v };
    if idx < 0 || idx as usize >= n || v == 0 {
        return Err(ObjLineError::IndexOutOfRange { index: v, n });
    }
    Ok(idx as u32)
}

/// `count` finite numbers from `parts`.
fn numbers<const N: usize>(parts: std::str::SplitWhitespace, what: &'static str) -> Result<[f32; N], ObjLineError> {
    let xs: Vec<f32> = parts
        .take(N)
        .map(str::parse::<f32>)
        .collect::<Result<_, _>>()
        .map_err(|reason| ObjLineError::BadNumber { what, reason })?;
    let xs: [f32; N] = xs.try_into().map_err(|_| ObjLineError::TooFewNumbers { what, n: N })?;
    if xs.iter().any(|x| !x.is_finite()) {
        return Err(ObjLineError::NonFinite { what });
    }
    Ok(xs)
}

/// Reads the `v`, `vt` and `f` lines, within `limits`.
fn read(path: &Path, text: &str, limits: &InputLimits) -> Result<ObjData, AssetError> {
    let mut data = ObjData {
        positions: Vec::new(),
        tex_coords: Vec::new(),
        faces: Vec::new(),
    };
    let err = |line: usize, error: ObjLineError| AssetError::Obj {
        path: path.to_path_buf(),
        line,
        error,
    };
    let mut n_triangles = 0usize;
    // A byte-order mark is not part of the first line's keyword.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    for (ln, line) in text.lines().enumerate() {
        let ln = ln + 1;
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => data
                .positions
                .push(numbers::<3>(parts, "vertex").map_err(|m| err(ln, m))?),
            Some("vt") => data
                .tex_coords
                .push(numbers::<2>(parts, "texture coordinate").map_err(|m| err(ln, m))?),
            Some("f") => {
                let face = face(&data, parts).map_err(|m| err(ln, m))?;
                n_triangles += face.len() - 2;
                data.faces.push(face);
            }
            _ => {}
        }
        if data.positions.len() > limits.max_vertices || n_triangles > limits.max_triangles {
            return Err(AssetError::TooLarge {
                path: path.to_path_buf(),
                message: format!(
                    "line {ln}: more than {} vertices or {} triangles",
                    limits.max_vertices, limits.max_triangles
                ),
            });
        }
    }
    if data.faces.is_empty() {
        return Err(err(0, ObjLineError::NoFaces));
    }
    Ok(data)
}

/// One `f` line's corners (three or more).
fn face(data: &ObjData, parts: std::str::SplitWhitespace) -> Result<Vec<Corner>, ObjLineError> {
    let fields: Vec<&str> = parts.collect();
    if fields.len() < 3 {
        return Err(ObjLineError::TooFewCorners { n: fields.len() });
    }
    let mut corners = Vec::with_capacity(fields.len());
    for c in fields {
        let mut f = c.split('/');
        let v = resolve_index(f.next().unwrap_or(""), data.positions.len())?;
        let vt = match f.next().filter(|s| !s.is_empty()) {
            Some(t) => Some(resolve_index(t, data.tex_coords.len())?),
            None => None,
        };
        if corners.iter().any(|&(w, _)| w == v) {
            return Err(ObjLineError::RepeatedVertex { vertex: v + 1 });
        }
        corners.push((v, vt));
    }
    Ok(corners)
}

/// Parses OBJ text into one primitive: polygons triangulated (ear clipping
/// in their plane), one vertex per `v` or, with `tex_coords` and a `vt` on
/// every face corner, one per distinct (`v`, `vt`) pair with its UVs in
/// glTF's convention, f32 of `(u, 1 − v)` (the atlas, as glTF's split
/// vertices give it).
///
/// # Errors
/// Bad numbers or indices (with the line), faces of fewer than 3 corners
/// or naming a vertex twice, no faces, more than the limits.
pub fn read_mesh(path: &Path, text: &str, limits: &InputLimits, tex_coords: bool) -> Result<ObjMesh, AssetError> {
    let data = read(path, text, limits)?;
    let atlas = tex_coords && data.faces.iter().flatten().all(|c| c.1.is_some());
    // Vertex i is `v` i (with its first `vt`), so constraint files name `v`
    // lines; a `v` with other `vt`s too gets a vertex per extra one after them.
    let mut positions = data.positions.clone();
    let mut vt = vec![[0.0f32, 0.0]; positions.len()];
    let mut first_vt: Vec<Option<u32>> = vec![None; positions.len()];
    let mut extra: HashMap<Corner, u32> = HashMap::new();
    let mut faces = ObjFaces::default();
    let mut indices = Vec::new();
    let mut diagonals = Vec::new();
    for face in &data.faces {
        let ids: Vec<u32> = face
            .iter()
            .map(|&(v, t)| {
                if !atlas {
                    return v;
                }
                let t = t.expect("every corner has a vt");
                match first_vt[v as usize] {
                    None => {
                        first_vt[v as usize] = Some(t);
                        vt[v as usize] = data.tex_coords[t as usize];
                        v
                    }
                    Some(f) if data.tex_coords[f as usize] == data.tex_coords[t as usize] => v,
                    Some(_) => *extra.entry((v, Some(t))).or_insert_with(|| {
                        positions.push(data.positions[v as usize]);
                        vt.push(data.tex_coords[t as usize]);
                        (positions.len() - 1) as u32
                    }),
                }
            })
            .collect();
        let points: Vec<glam::DVec3> = face
            .iter()
            .map(|c| glam::Vec3::from(data.positions[c.0 as usize]).as_dvec3())
            .collect();
        let triangles = crate::mesh::polygon::triangulate(&points);
        for t in &triangles {
            for &k in t {
                indices.push(ids[k]);
                faces.face_corner.push((faces.n_face_corners + k) as u32);
            }
        }
        diagonals.extend(
            crate::mesh::polygon::diagonals(&triangles, face.len())
                .iter()
                .map(|d| [ids[d[0]], ids[d[1]]]),
        );
        faces.n_face_corners += face.len();
    }
    faces.diagonals = diagonals;
    let uvs = atlas.then(|| vt.iter().map(|t| [t[0], 1.0 - t[1]]).collect());
    faces.vt = atlas.then(|| vt.clone());
    Ok(ObjMesh {
        primitive: PrimitiveGeometry {
            index: 0,
            positions,
            indices,
            uvs,
        },
        faces,
        tex_coords: atlas.then_some(vt),
    })
}

/// OBJ texture coordinates as stored (`vt`, f32, v up), one per vertex.
pub type TexCoords = Vec<[f32; 2]>;

/// How a layout point `(x, y)` is stored as an OBJ `vt`: `(x, y)` in f32.
#[inline]
pub fn vt_as_stored(x: f64, y: f64) -> [f32; 2] {
    [x as f32, y as f32]
}

/// Each face corner's texture coordinate from its triangles' corners
/// (`corner_vt`, in the primitive's index order).
///
/// # Errors
/// A face corner whose triangles disagree (a seam would run inside the
/// polygon).
fn face_corner_vt(faces: &ObjFaces, corner_vt: &[[f32; 2]]) -> Result<Vec<[f32; 2]>, SeamInPolygon> {
    let mut out: Vec<Option<[f32; 2]>> = vec![None; faces.n_face_corners];
    for (&fc, &uv) in faces.face_corner.iter().zip(corner_vt) {
        let slot = &mut out[fc as usize];
        match slot {
            None => *slot = Some(uv),
            Some(seen) if seen.map(f32::to_bits) == uv.map(f32::to_bits) => {}
            Some(_) => {
                return Err(SeamInPolygon { face_corner: fc });
            }
        }
    }
    Ok(out.into_iter().map(|uv| uv.unwrap_or([0.0, 0.0])).collect())
}

/// A face corner whose triangles were laid out apart: an OBJ face corner
/// has one texture coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("face corner {face_corner} would need two texture coordinates: a seam runs inside its polygon")]
pub struct SeamInPolygon {
    pub face_corner: u32,
}

/// The OBJ file with texture coordinates per face corner: the old `vt`
/// lines go; after each `v` line, one `vt` line for each texture
/// coordinate its face corners have (so every face, wherever it stands,
/// names `vt` already defined), and every face's corners point at theirs,
/// their `v` and `vn` as written, the polygons as they were. Every other
/// line is kept byte for byte, its line ending and encoding (Latin-1 names
/// in `mtllib`, a byte-order mark) included.
///
/// # Errors
/// A face corner whose triangles were laid out apart (a seam inside its polygon).
pub fn with_tex_coords(bytes: &[u8], faces: &ObjFaces, corner_vt: &[[f32; 2]]) -> Result<Vec<u8>, SeamInPolygon> {
    let fc_uv = face_corner_vt(faces, corner_vt)?;
    let plan = VtPlan::new(bytes, &fc_uv);
    let mut out = Vec::with_capacity(bytes.len() + plan.n_vt * 24);
    let (mut n_v, mut corner) = (0usize, 0usize);
    for (k, line) in bytes.split_inclusive(|&b| b == b'\n').enumerate() {
        let (content, ending) = split_ending(line);
        let keyword_at = if k == 0 && content.starts_with(BOM) {
            BOM.len()
        } else {
            0
        };
        let text = String::from_utf8_lossy(&content[keyword_at..]);
        let mut parts = text.split_whitespace();
        match parts.next() {
            Some("vt") => continue,
            Some("v") => {
                out.extend_from_slice(line);
                // A last line without an ending gets one before its `vt`.
                let ending: &[u8] = if ending.is_empty() {
                    out.push(b'\n');
                    b"\n"
                } else {
                    ending
                };
                for uv in plan.per_v.get(n_v).into_iter().flatten() {
                    out.extend_from_slice(format!("vt {} {}", uv[0], uv[1]).as_bytes());
                    out.extend_from_slice(ending);
                }
                n_v += 1;
            }
            Some("f") => {
                out.extend_from_slice(&content[..keyword_at]);
                out.extend_from_slice(b"f");
                for field in parts {
                    let mut rest = field.splitn(3, '/');
                    let v = rest.next().unwrap_or("");
                    let vt = plan.vt_of_corner[corner];
                    corner += 1;
                    match rest.nth(1).filter(|s| !s.is_empty()) {
                        Some(n) => out.extend_from_slice(format!(" {v}/{vt}/{n}").as_bytes()),
                        None => out.extend_from_slice(format!(" {v}/{vt}").as_bytes()),
                    }
                }
                out.extend_from_slice(ending);
            }
            _ => out.extend_from_slice(line),
        }
    }
    Ok(out)
}

/// Where each `vt` goes: the distinct texture coordinates of each `v`'s
/// face corners (first-seen order), and each face corner's `vt` number.
struct VtPlan {
    per_v: Vec<Vec<[f32; 2]>>,
    vt_of_corner: Vec<usize>,
    n_vt: usize,
}

impl VtPlan {
    fn new(bytes: &[u8], fc_uv: &[[f32; 2]]) -> Self {
        let text = String::from_utf8_lossy(bytes);
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let mut per_v: Vec<Vec<[f32; 2]>> = Vec::new();
        let mut slot_of_corner: Vec<(usize, usize)> = Vec::with_capacity(fc_uv.len());
        let mut n_v = 0usize;
        for line in text.lines() {
            let mut parts = line.split_whitespace();
            match parts.next() {
                Some("v") => {
                    n_v += 1;
                    per_v.push(Vec::new());
                }
                Some("f") => {
                    for field in parts {
                        let v = field
                            .split('/')
                            .next()
                            .and_then(|s| resolve_index(s, n_v).ok())
                            .unwrap_or(0) as usize;
                        let uv = fc_uv.get(slot_of_corner.len()).copied().unwrap_or([0.0, 0.0]);
                        let list = &mut per_v[v];
                        let j = match list.iter().position(|u| u.map(f32::to_bits) == uv.map(f32::to_bits)) {
                            Some(j) => j,
                            None => {
                                list.push(uv);
                                list.len() - 1
                            }
                        };
                        slot_of_corner.push((v, j));
                    }
                }
                _ => {}
            }
        }
        let mut first = Vec::with_capacity(per_v.len());
        let mut n_vt = 0usize;
        for list in &per_v {
            first.push(n_vt);
            n_vt += list.len();
        }
        let vt_of_corner = slot_of_corner.iter().map(|&(v, j)| first[v] + j + 1).collect();
        VtPlan {
            per_v,
            vt_of_corner,
            n_vt,
        }
    }
}

/// UTF-8's byte-order mark.
const BOM: &[u8] = b"\xef\xbb\xbf";

/// A line's content and its ending (`\r\n`, `\n`, or none at the end).
fn split_ending(line: &[u8]) -> (&[u8], &[u8]) {
    let cut = if line.ends_with(b"\r\n") {
        2
    } else {
        usize::from(line.ends_with(b"\n"))
    };
    line.split_at(line.len() - cut)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(text: &str) -> ObjMesh {
        read_mesh(Path::new("t.obj"), text, &InputLimits::DEFAULT, true).unwrap()
    }

    /// Per triangle corner, the value `f` gives its face corner.
    fn corners_of(m: &ObjMesh, f: impl Fn(u32) -> [f32; 2]) -> Vec<[f32; 2]> {
        m.faces.face_corner.iter().map(|&fc| f(fc)).collect()
    }

    #[test]
    fn texture_coordinates_are_read_per_corner_and_written_as_given() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.5\nvt 0.75 0.5\nvt 0.25 1\nf 1/1 2/2 3/3\n";
        let m = mesh(text);
        assert_eq!(
            m.tex_coords.clone().unwrap(),
            vec![[0.25, 0.5], [0.75, 0.5], [0.25, 1.0]]
        );
        assert_eq!(m.primitive.uvs.clone().unwrap()[2], [0.25, 0.0]);
        let vt = [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]];
        let written = with_tex_coords(text.as_bytes(), &m.faces, &corners_of(&m, |fc| vt[fc as usize])).unwrap();
        let written = String::from_utf8(written).unwrap();
        assert!(
            written.contains("vt 0.1 0.2\n") && written.contains("f 1/1 2/2 3/3"),
            "{written}"
        );
        assert!(mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").tex_coords.is_none());
        let small = InputLimits {
            max_vertices: 2,
            ..InputLimits::DEFAULT
        };
        assert!(matches!(
            read_mesh(Path::new("t.obj"), text, &small, true),
            Err(AssetError::TooLarge { .. })
        ));
        let bad = |t: &str| read_mesh(Path::new("t.obj"), t, &InputLimits::DEFAULT, true).is_err();
        assert!(bad("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n"));
        assert!(bad("v nan 0 0\n"));
        assert!(bad("v 0 0 0\nv 1 0 0\nf 1 2\n"), "a face of two corners");
        assert!(
            bad("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1\n"),
            "a face naming a vertex twice"
        );
    }

    #[test]
    fn unchanged_lines_keep_their_bytes_and_faces_between_vertices_stay_readable() {
        // A BOM, CRLF endings, a Latin-1 material name, faces between `v` lines.
        let mut text: Vec<u8> =
            b"\xef\xbb\xbfv 0 0 0\r\nmtllib caf\xe9.mtl\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n".to_vec();
        text.extend_from_slice(b"vt 9 9\r\nv 1 1 0\r\nf 2 4 3\r\n# caf\xe9 end");
        let lossy = String::from_utf8_lossy(&text);
        let m = mesh(&lossy);
        assert_eq!(m.primitive.positions.len(), 4, "the BOM hides no `v`");
        let vt = [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6], [0.7, 0.8]];
        let per_corner: Vec<[f32; 2]> = m.primitive.indices.iter().map(|&v| vt[v as usize]).collect();
        let written = with_tex_coords(&text, &m.faces, &per_corner).unwrap();
        for kept in [
            &b"\xef\xbb\xbfv 0 0 0\r\n"[..],
            b"mtllib caf\xe9.mtl\r\n",
            b"# caf\xe9 end",
            b"v 1 1 0\r\n",
        ] {
            assert!(
                written.windows(kept.len()).any(|w| w == kept),
                "{:?} kept",
                String::from_utf8_lossy(kept)
            );
        }
        assert!(!written.windows(6).any(|w| w == b"vt 9 9"), "the old vt goes");
        assert!(!written.windows(2).any(|w| w == b"\n\n"), "no bare line ending added");
        let read = mesh(&String::from_utf8_lossy(&written));
        assert_eq!(
            read.tex_coords.unwrap(),
            vt.to_vec(),
            "every face names a vt defined before it"
        );
        assert_eq!(read.primitive.indices.len(), 6);
    }

    #[test]
    fn quads_and_n_gons_are_triangulated_and_written_back_as_polygons() {
        // A quad and a non-convex pentagon sharing an edge, with normals.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 2 0\nv 1.5 0.5 0\nvn 0 0 1\n\
                    f 1//1 2//1 3//1 4//1\nf 2//1 5//1 6//1 3//1 7//1\n";
        let m = mesh(text);
        assert_eq!(m.primitive.indices.len(), 3 * (2 + 3));
        assert_eq!(m.faces.n_face_corners, 9);
        assert_eq!(m.faces.diagonals.len(), 1 + 2);
        // Each polygon corner one UV: its vertex's x, y.
        let per_corner: Vec<[f32; 2]> = m
            .primitive
            .indices
            .iter()
            .map(|&v| {
                [
                    m.primitive.positions[v as usize][0],
                    m.primitive.positions[v as usize][1],
                ]
            })
            .collect();
        let written = String::from_utf8(with_tex_coords(text.as_bytes(), &m.faces, &per_corner).unwrap()).unwrap();
        assert!(written.contains("f 1/1/1 2/2/1 3/3/1 4/4/1\n"), "{written}");
        assert!(written.contains("f 2/2/1 5/5/1 6/6/1 3/3/1 7/7/1\n"), "{written}");
        // Two UVs for one polygon corner (a seam inside the quad) is refused.
        let mut split = per_corner.clone();
        split[3] = [0.9, 0.9];
        assert!(with_tex_coords(text.as_bytes(), &m.faces, &split).is_err());
    }

    #[test]
    fn a_vertex_on_a_seam_gets_a_vt_per_side_right_after_it() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
        let m = mesh(text);
        // Vertex 2 (the second `v`) has another UV in the second face.
        let per_corner = vec![[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [0.7, 0.1], [0.6, 0.6], [0.0, 0.5]];
        let written = String::from_utf8(with_tex_coords(text.as_bytes(), &m.faces, &per_corner).unwrap()).unwrap();
        assert!(
            written.starts_with("v 0 0 0\nvt 0 0\nv 1 0 0\nvt 0.5 0\nvt 0.7 0.1\n"),
            "{written}"
        );
        assert!(written.contains("f 1/1 2/2 3/4\nf 2/3 4/5 3/4\n"), "{written}");
    }
}
