//! Wavefront OBJ as a convenience input: `v` positions and triangular `f`
//! faces. Vertex ids in constraint files are 0-based `v` indices. Output keeps
//! every line but `vt`, writes one `vt` per vertex and points `f` at them.
//! OBJ texture coordinates have `v` up: a layout point `(x, y)` is stored as
//! `vt x y`, each rounded to f32 (the guard checks that form too).

use super::AssetError;
use super::read::InputLimits;
use crate::mesh::weld::PrimitiveGeometry;
use std::collections::HashMap;
use std::path::Path;

/// One face corner: its `v` index and, if given, its `vt` index (0-based).
type Corner = (u32, Option<u32>);

/// What an OBJ file holds that uvpin reads.
struct ObjData {
    positions: Vec<[f32; 3]>,
    tex_coords: Vec<[f32; 2]>,
    corners: Vec<Corner>,
}

/// A 1-based (or negative, relative) OBJ index into a list of `n` as 0-based.
fn resolve_index(text: &str, n: usize) -> Result<u32, String> {
    let v: i64 = text.parse().map_err(|e| format!("bad face index {text:?}: {e}"))?;
    let idx = if v > 0 { v - 1 } else { n as i64 + v };
    if idx < 0 || idx as usize >= n || v == 0 {
        return Err(format!("face index {v} out of range (1..={n})"));
    }
    Ok(idx as u32)
}

/// `count` finite numbers from `parts`.
fn numbers<const N: usize>(parts: std::str::SplitWhitespace, what: &str) -> Result<[f32; N], String> {
    let xs: Vec<f32> = parts
        .take(N)
        .map(str::parse::<f32>)
        .collect::<Result<_, _>>()
        .map_err(|e| format!("bad {what}: {e}"))?;
    let xs: [f32; N] = xs.try_into().map_err(|_| format!("a {what} needs {N} numbers"))?;
    if xs.iter().any(|x| !x.is_finite()) {
        return Err(format!("a {what} has a non-finite coordinate"));
    }
    Ok(xs)
}

/// Reads the `v`, `vt` and triangular `f` lines, within `limits`.
fn read(path: &Path, text: &str, limits: &InputLimits) -> Result<ObjData, AssetError> {
    let mut data = ObjData {
        positions: Vec::new(),
        tex_coords: Vec::new(),
        corners: Vec::new(),
    };
    let err = |line: usize, message: String| AssetError::Obj {
        path: path.to_path_buf(),
        line,
        message,
    };
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
            Some("f") => face(&mut data, parts).map_err(|m| err(ln, m))?,
            _ => {}
        }
        if data.positions.len() > limits.max_vertices || data.corners.len() / 3 > limits.max_triangles {
            return Err(AssetError::TooLarge {
                path: path.to_path_buf(),
                message: format!(
                    "line {ln}: more than {} vertices or {} triangles",
                    limits.max_vertices, limits.max_triangles
                ),
            });
        }
    }
    if data.corners.is_empty() {
        return Err(err(0, "no triangles".into()));
    }
    Ok(data)
}

/// One `f` line (a triangle) appended to `data`.
fn face(data: &mut ObjData, parts: std::str::SplitWhitespace) -> Result<(), String> {
    let fields: Vec<&str> = parts.collect();
    if fields.len() != 3 {
        return Err(format!(
            "face with {} corners: only triangles are supported",
            fields.len()
        ));
    }
    for c in fields {
        let mut f = c.split('/');
        let v = resolve_index(f.next().unwrap_or(""), data.positions.len())?;
        let vt = match f.next().filter(|s| !s.is_empty()) {
            Some(t) => Some(resolve_index(t, data.tex_coords.len())?),
            None => None,
        };
        data.corners.push((v, vt));
    }
    Ok(())
}

/// Parses OBJ text into one primitive (positions and triangles; `vt` is not
/// used for solving).
///
/// # Errors
/// Bad numbers or indices (with the line), non-triangular faces, no
/// triangles, more than the limits.
pub fn parse(path: &Path, text: &str, limits: &InputLimits) -> Result<PrimitiveGeometry, AssetError> {
    let data = read(path, text, limits)?;
    Ok(PrimitiveGeometry {
        index: 0,
        positions: data.positions,
        indices: data.corners.iter().map(|c| c.0).collect(),
        uvs: None,
    })
}

/// Parses OBJ text with its texture coordinates, for checking them: one
/// vertex per distinct (`v`, `vt`) pair of the faces, its UVs in glTF's
/// convention as f32 of `(u, 1 − v)` (see [`vt_as_stored`] for the exact
/// stored values). `None` for the UVs when a face corner has no `vt`.
///
/// # Errors
/// As [`parse`].
pub fn parse_with_tex_coords(
    path: &Path,
    text: &str,
    limits: &InputLimits,
) -> Result<(PrimitiveGeometry, Option<TexCoords>), AssetError> {
    let data = read(path, text, limits)?;
    if data.corners.iter().any(|c| c.1.is_none()) {
        return Ok((parse(path, text, limits)?, None));
    }
    let mut id_of: HashMap<Corner, u32> = HashMap::new();
    let (mut positions, mut vt, mut indices) = (Vec::new(), Vec::new(), Vec::new());
    for &corner in &data.corners {
        let id = *id_of.entry(corner).or_insert_with(|| {
            positions.push(data.positions[corner.0 as usize]);
            vt.push(data.tex_coords[corner.1.expect("checked") as usize]);
            (positions.len() - 1) as u32
        });
        indices.push(id);
    }
    let uvs = vt.iter().map(|t| [t[0], 1.0 - t[1]]).collect();
    let prim = PrimitiveGeometry {
        index: 0,
        positions,
        indices,
        uvs: Some(uvs),
    };
    Ok((prim, Some(vt)))
}

/// OBJ texture coordinates as stored (`vt`, f32, v up), one per vertex.
pub type TexCoords = Vec<[f32; 2]>;

/// How a layout point `(x, y)` is stored as an OBJ `vt`: `(x, y)` in f32.
#[inline]
pub fn vt_as_stored(x: f64, y: f64) -> [f32; 2] {
    [x as f32, y as f32]
}

/// The OBJ file with `vt` lines (one per `v`, OBJ convention: v up, as
/// given), each right after its `v` so that every face, wherever it stands,
/// names texture coordinates already defined; the faces point at them, the
/// old `vt` lines go. Every other line is kept byte for byte, its line ending
/// and encoding (Latin-1 names in `mtllib`, a byte-order mark) included.
pub fn with_tex_coords(bytes: &[u8], vt: &[[f32; 2]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len() + vt.len() * 24);
    let mut n_v = 0i64;
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
                if let Some(t) = vt.get(n_v as usize) {
                    out.extend_from_slice(format!("vt {} {}", t[0], t[1]).as_bytes());
                    out.extend_from_slice(ending);
                }
                n_v += 1;
            }
            Some("f") => {
                out.extend_from_slice(&content[..keyword_at]);
                out.extend_from_slice(face_line(parts, n_v).as_bytes());
                out.extend_from_slice(ending);
            }
            _ => out.extend_from_slice(line),
        }
    }
    out
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

/// An `f` line whose corners name their `v` and the `vt` of the same number
/// (`n_v` vertices defined before it), normals kept.
fn face_line(parts: std::str::SplitWhitespace, n_v: i64) -> String {
    let mut out = String::from("f");
    for c in parts {
        let mut fields = c.split('/');
        let v: i64 = fields.next().unwrap_or("0").parse().unwrap_or(0);
        let abs = if v > 0 { v } else { n_v + v + 1 };
        match fields.nth(1).filter(|s| !s.is_empty()) {
            Some(n) => out.push_str(&format!(" {abs}/{abs}/{n}")),
            None => out.push_str(&format!(" {abs}/{abs}")),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_coordinates_are_read_per_corner_and_written_as_given() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.5\nvt 0.75 0.5\nvt 0.25 1\nf 1/1 2/2 3/3\n";
        let limits = InputLimits::DEFAULT;
        let (prim, vt) = parse_with_tex_coords(Path::new("t.obj"), text, &limits).unwrap();
        assert_eq!(vt.unwrap(), vec![[0.25, 0.5], [0.75, 0.5], [0.25, 1.0]]);
        assert_eq!(prim.uvs.unwrap()[2], [0.25, 0.0]);
        let written = with_tex_coords(text.as_bytes(), &[[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]]);
        let written = String::from_utf8(written).unwrap();
        assert!(
            written.contains("vt 0.1 0.2\n") && written.contains("f 1/1 2/2 3/3"),
            "{written}"
        );
        let (_, none) =
            parse_with_tex_coords(Path::new("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", &limits).unwrap();
        assert!(none.is_none());
        let small = InputLimits {
            max_vertices: 2,
            ..InputLimits::DEFAULT
        };
        assert!(matches!(
            parse(Path::new("t.obj"), text, &small),
            Err(AssetError::TooLarge { .. })
        ));
        assert!(parse(Path::new("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", &limits).is_err());
        assert!(parse(Path::new("t.obj"), "v nan 0 0\n", &limits).is_err());
    }

    #[test]
    fn unchanged_lines_keep_their_bytes_and_faces_between_vertices_stay_readable() {
        // A BOM, CRLF endings, a Latin-1 material name, faces between `v` lines.
        let mut text: Vec<u8> =
            b"\xef\xbb\xbfv 0 0 0\r\nmtllib caf\xe9.mtl\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n".to_vec();
        text.extend_from_slice(b"vt 9 9\r\nv 1 1 0\r\nf 2 4 3\r\n# caf\xe9 end");
        let limits = InputLimits::DEFAULT;
        let lossy = String::from_utf8_lossy(&text);
        assert_eq!(
            parse(Path::new("t.obj"), &lossy, &limits).unwrap().positions.len(),
            4,
            "the BOM hides no `v`"
        );
        let vt = [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6], [0.7, 0.8]];
        let written = with_tex_coords(&text, &vt);
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
        let (prim, read) =
            parse_with_tex_coords(Path::new("t.obj"), &String::from_utf8_lossy(&written), &limits).unwrap();
        assert_eq!(read.unwrap(), vt.to_vec(), "every face names a vt defined before it");
        assert_eq!(prim.indices.len(), 6);
    }
}
