//! Scanner and CAD formats read as meshes: PLY (ASCII and binary, faces
//! and triangle strips), STL (ASCII and binary) and OFF. Each becomes the
//! text of an OBJ file (`v` then `f` lines) that the OBJ reader takes from
//! there, so vertex `i` of a PLY or OFF file is vertex `i` in a constraint
//! file, and an STL's corners are numbered in order of first appearance
//! (corners at the same position are one vertex).

use std::fmt::Write as _;
use thiserror::Error;

/// What is wrong with a scanner-format file: where, and what.
#[derive(Debug, Error, PartialEq)]
pub enum ScanError {
    /// A header line or a value of the body that cannot be read.
    #[error("line {line}: {message}")]
    Line { line: usize, message: String },
    /// A binary body that ends early or holds what its header denies.
    #[error("{element} {index}: {message}")]
    Element {
        element: String,
        index: usize,
        message: String,
    },
    /// The header declares more than the file can hold.
    #[error("{0}")]
    Header(String),
}

/// The scanner formats, by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanFormat {
    Ply,
    Stl,
    Off,
}

impl ScanFormat {
    /// The format a file's extension names, if it is one of these.
    pub fn of(path: &std::path::Path) -> Option<ScanFormat> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "ply" => Some(ScanFormat::Ply),
            "stl" => Some(ScanFormat::Stl),
            "off" => Some(ScanFormat::Off),
            _ => None,
        }
    }
}

/// A mesh as read: positions and polygons (vertex indices, checked).
#[derive(Debug, Default, PartialEq)]
pub struct Polygons {
    pub positions: Vec<[f64; 3]>,
    pub faces: Vec<Vec<u32>>,
}

impl Polygons {
    /// The mesh as OBJ text (1-based `f` lines).
    pub fn to_obj(&self) -> String {
        let mut out = String::with_capacity(32 * (self.positions.len() + self.faces.len()));
        for p in &self.positions {
            let _ = writeln!(out, "v {} {} {}", p[0], p[1], p[2]);
        }
        for f in &self.faces {
            out.push('f');
            for v in f {
                let _ = write!(out, " {}", v + 1);
            }
            out.push('\n');
        }
        out
    }

    /// Adds a face after checking its indices; faces with fewer than three
    /// distinct corners are dropped.
    fn push_face(&mut self, face: Vec<u32>, element: &str, index: usize) -> Result<(), ScanError> {
        if let Some(&v) = face.iter().find(|&&v| v as usize >= self.positions.len()) {
            return Err(ScanError::Element {
                element: element.into(),
                index,
                message: format!("vertex {v} does not exist ({} vertices)", self.positions.len()),
            });
        }
        if face.len() >= 3 {
            self.faces.push(face);
        }
        Ok(())
    }
}

/// Reads `bytes` as `format`.
///
/// # Errors
/// Anything unreadable, with its line or element; counts the file cannot
/// hold are refused before anything is allocated for them.
pub fn read(format: ScanFormat, bytes: &[u8]) -> Result<Polygons, ScanError> {
    match format {
        ScanFormat::Ply => ply::read(bytes),
        ScanFormat::Stl => stl::read(bytes),
        ScanFormat::Off => off::read(bytes),
    }
}

/// A count from a header, refused when the `bytes` left could not hold
/// that many items of at least `min_size` bytes each.
fn bounded(count: usize, min_size: usize, bytes: usize, what: &str) -> Result<usize, ScanError> {
    if count.saturating_mul(min_size) > bytes {
        return Err(ScanError::Header(format!(
            "the header declares {count} {what}, more than the file's {bytes} bytes can hold"
        )));
    }
    Ok(count)
}

mod off {
    use super::{Polygons, ScanError, bounded};

    /// OFF (and COFF, NOFF…), line by line: the header, counts, one vertex
    /// per line, then one face per line, `n i0 … in-1` (colours after it
    /// ignored).
    pub fn read(bytes: &[u8]) -> Result<Polygons, ScanError> {
        let text = String::from_utf8_lossy(bytes);
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(k, l)| {
                (
                    k + 1,
                    l.split('#').next().unwrap_or("").split_whitespace().collect::<Vec<_>>(),
                )
            })
            .filter(|(_, w)| !w.is_empty());
        let bad = |line: usize, message: String| ScanError::Line { line, message };
        let (line, mut words) = lines.next().ok_or_else(|| bad(1, "empty file".into()))?;
        if !words[0].ends_with("OFF") {
            return Err(bad(line, format!("`{}` is not an OFF header", words[0])));
        }
        words.remove(0);
        let (line, words) = match words.is_empty() {
            true => lines.next().ok_or_else(|| bad(line, "no counts".into()))?,
            false => (line, words),
        };
        let count = |w: Option<&&str>, what: &str| -> Result<usize, ScanError> {
            w.and_then(|w| w.parse::<usize>().ok())
                .ok_or_else(|| bad(line, format!("{what} is not a count")))
        };
        let nv = bounded(count(words.first(), "the vertex count")?, 6, bytes.len(), "vertices")?;
        let nf = bounded(count(words.get(1), "the face count")?, 6, bytes.len(), "faces")?;
        let mut mesh = Polygons {
            positions: Vec::with_capacity(nv),
            faces: Vec::with_capacity(nf),
        };
        for v in 0..nv {
            let (line, words) = lines
                .next()
                .ok_or_else(|| bad(line, format!("the file ends before vertex {v}")))?;
            let p: Vec<f64> = words.iter().take(3).filter_map(|w| w.parse::<f64>().ok()).collect();
            if p.len() < 3 || p.iter().any(|x| !x.is_finite()) {
                return Err(bad(line, format!("vertex {v} needs three finite coordinates")));
            }
            mesh.positions.push([p[0], p[1], p[2]]);
        }
        for f in 0..nf {
            let (line, words) = lines
                .next()
                .ok_or_else(|| bad(line, format!("the file ends before face {f}")))?;
            let n = count(words.first(), &format!("face {f}'s corner count"))?;
            let face: Option<Vec<u32>> = (1..=n).map(|k| words.get(k)?.parse::<u32>().ok()).collect();
            let face = face.ok_or_else(|| bad(line, format!("face {f} needs {n} vertex indices")))?;
            mesh.push_face(face, "face", f)?;
        }
        Ok(mesh)
    }
}

mod stl {
    use super::{Polygons, ScanError};
    use std::collections::HashMap;

    /// Binary STL when its size matches its triangle count, else ASCII.
    pub fn read(bytes: &[u8]) -> Result<Polygons, ScanError> {
        if bytes.len() >= 84 {
            let n = u32::from_le_bytes(bytes[80..84].try_into().expect("four bytes")) as usize;
            if n.checked_mul(50).and_then(|b| b.checked_add(84)) == Some(bytes.len()) {
                return Ok(binary(bytes, n));
            }
        }
        if !bytes.trim_ascii_start().starts_with(b"solid") {
            return Err(ScanError::Header(
                "neither a binary STL (its size does not match its triangle count) nor an ASCII one (no `solid`)"
                    .into(),
            ));
        }
        ascii(&String::from_utf8_lossy(bytes))
    }

    /// Corners at the same position (bit for bit) are one vertex.
    #[derive(Default)]
    struct Corners {
        mesh: Polygons,
        index: HashMap<[u64; 3], u32>,
    }

    impl Corners {
        fn vertex(&mut self, p: [f64; 3]) -> u32 {
            let key = p.map(|x| (x + 0.0).to_bits());
            *self.index.entry(key).or_insert_with(|| {
                self.mesh.positions.push(p);
                (self.mesh.positions.len() - 1) as u32
            })
        }
    }

    fn binary(bytes: &[u8], n: usize) -> Polygons {
        let mut corners = Corners::default();
        for t in 0..n {
            let at = 84 + 50 * t + 12;
            let face: Vec<u32> = (0..3)
                .map(|k| {
                    let p: [f64; 3] = std::array::from_fn(|i| {
                        let o = at + 12 * k + 4 * i;
                        f64::from(f32::from_le_bytes(bytes[o..o + 4].try_into().expect("four bytes")))
                    });
                    corners.vertex(p)
                })
                .collect();
            if face[0] != face[1] && face[1] != face[2] && face[0] != face[2] {
                corners.mesh.faces.push(face);
            }
        }
        corners.mesh
    }

    fn ascii(text: &str) -> Result<Polygons, ScanError> {
        let mut corners = Corners::default();
        let mut face = Vec::with_capacity(3);
        for (k, line) in text.lines().enumerate() {
            let mut words = line.split_whitespace();
            match words.next() {
                Some("vertex") => {
                    let mut p = [0.0; 3];
                    for x in &mut p {
                        *x = words
                            .next()
                            .and_then(|w| w.parse::<f64>().ok())
                            .filter(|x| x.is_finite())
                            .ok_or_else(|| ScanError::Line {
                                line: k + 1,
                                message: "a vertex needs three finite coordinates".into(),
                            })?;
                    }
                    face.push(corners.vertex(p));
                }
                Some("endloop") => {
                    let f = std::mem::take(&mut face);
                    if f.len() >= 3 && f.iter().enumerate().all(|(i, v)| !f[..i].contains(v)) {
                        corners.mesh.faces.push(f);
                    }
                }
                _ => {}
            }
        }
        Ok(corners.mesh)
    }
}

mod ply {
    use super::{Polygons, ScanError, bounded};

    /// A PLY scalar type.
    #[derive(Debug, Clone, Copy, PartialEq)]
    enum Scalar {
        I8,
        U8,
        I16,
        U16,
        I32,
        U32,
        F32,
        F64,
    }

    impl Scalar {
        fn parse(name: &str) -> Option<Scalar> {
            Some(match name {
                "char" | "int8" => Scalar::I8,
                "uchar" | "uint8" => Scalar::U8,
                "short" | "int16" => Scalar::I16,
                "ushort" | "uint16" => Scalar::U16,
                "int" | "int32" => Scalar::I32,
                "uint" | "uint32" => Scalar::U32,
                "float" | "float32" => Scalar::F32,
                "double" | "float64" => Scalar::F64,
                _ => return None,
            })
        }

        fn size(self) -> usize {
            match self {
                Scalar::I8 | Scalar::U8 => 1,
                Scalar::I16 | Scalar::U16 => 2,
                Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
                Scalar::F64 => 8,
            }
        }
    }

    /// A property: a scalar, or a list (count type, item type).
    #[derive(Debug, Clone)]
    struct Property {
        name: String,
        count: Option<Scalar>,
        item: Scalar,
    }

    #[derive(Debug, Clone)]
    struct Element {
        name: String,
        count: usize,
        properties: Vec<Property>,
    }

    #[derive(Debug, Clone, Copy, PartialEq)]
    enum Encoding {
        Ascii,
        Little,
        Big,
    }

    /// The values of one element's properties, read one at a time.
    trait Values {
        fn next(&mut self, scalar: Scalar, element: &str, index: usize) -> Result<f64, ScanError>;
    }

    struct Ascii<'a> {
        words: std::iter::Peekable<Box<dyn Iterator<Item = (usize, &'a str)> + 'a>>,
    }

    impl Values for Ascii<'_> {
        fn next(&mut self, _: Scalar, element: &str, index: usize) -> Result<f64, ScanError> {
            let (line, word) = self.words.next().ok_or_else(|| ScanError::Element {
                element: element.into(),
                index,
                message: "the file ends inside it".into(),
            })?;
            word.parse::<f64>().map_err(|_| ScanError::Line {
                line,
                message: format!("{element} {index}: `{word}` is not a number"),
            })
        }
    }

    struct Binary<'a> {
        bytes: &'a [u8],
        at: usize,
        big: bool,
    }

    impl Values for Binary<'_> {
        fn next(&mut self, scalar: Scalar, element: &str, index: usize) -> Result<f64, ScanError> {
            let n = scalar.size();
            let Some(raw) = self.bytes.get(self.at..self.at + n) else {
                return Err(ScanError::Element {
                    element: element.into(),
                    index,
                    message: "the file ends inside it".into(),
                });
            };
            self.at += n;
            let mut b = [0u8; 8];
            b[..n].copy_from_slice(raw);
            if self.big {
                b[..n].reverse();
            }
            Ok(match scalar {
                Scalar::I8 => f64::from(b[0] as i8),
                Scalar::U8 => f64::from(b[0]),
                Scalar::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                Scalar::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                Scalar::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                Scalar::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                Scalar::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                Scalar::F64 => f64::from_le_bytes(b),
            })
        }
    }

    /// The header's elements, its encoding and where the body starts.
    fn header(bytes: &[u8]) -> Result<(Vec<Element>, Encoding, usize), ScanError> {
        let bad = |line: usize, message: &str| ScanError::Line {
            line,
            message: message.into(),
        };
        let end = bytes
            .windows(10)
            .position(|w| w == b"end_header")
            .ok_or_else(|| bad(1, "no `end_header`"))?;
        let body = end + 10 + bytes[end + 10..].iter().take_while(|&&b| b == b'\r').count() + 1;
        let text = String::from_utf8_lossy(&bytes[..end]);
        let mut lines = text.lines().enumerate().map(|(k, l)| (k + 1, l.trim()));
        if lines.next().map(|(_, l)| l) != Some("ply") {
            return Err(bad(1, "not a PLY file (no `ply` first line)"));
        }
        let (mut elements, mut encoding) = (Vec::<Element>::new(), None);
        for (line, l) in lines {
            let words: Vec<&str> = l.split_whitespace().collect();
            match words.as_slice() {
                ["format", "ascii", _] => encoding = Some(Encoding::Ascii),
                ["format", "binary_little_endian", _] => encoding = Some(Encoding::Little),
                ["format", "binary_big_endian", _] => encoding = Some(Encoding::Big),
                ["element", name, count] => elements.push(Element {
                    name: (*name).into(),
                    count: count
                        .parse()
                        .map_err(|_| bad(line, "an element count is not a number"))?,
                    properties: Vec::new(),
                }),
                ["property", "list", count, item, name] => {
                    let (Some(count), Some(item)) = (Scalar::parse(count), Scalar::parse(item)) else {
                        return Err(bad(line, "unknown list property type"));
                    };
                    let element = elements
                        .last_mut()
                        .ok_or_else(|| bad(line, "a property before any element"))?;
                    element.properties.push(Property {
                        name: (*name).into(),
                        count: Some(count),
                        item,
                    });
                }
                ["property", item, name] => {
                    let item = Scalar::parse(item).ok_or_else(|| bad(line, "unknown property type"))?;
                    let element = elements
                        .last_mut()
                        .ok_or_else(|| bad(line, "a property before any element"))?;
                    element.properties.push(Property {
                        name: (*name).into(),
                        count: None,
                        item,
                    });
                }
                ["comment", ..] | ["obj_info", ..] | [] => {}
                _ => return Err(bad(line, &format!("cannot read header line `{l}`"))),
            }
        }
        let encoding = encoding.ok_or_else(|| bad(2, "no `format` line"))?;
        Ok((elements, encoding, body.min(bytes.len())))
    }

    pub fn read(bytes: &[u8]) -> Result<Polygons, ScanError> {
        let (elements, encoding, body) = header(bytes)?;
        let left = bytes.len() - body;
        for e in &elements {
            bounded(e.count, 1, left, &format!("{} elements", e.name))?;
        }
        let text;
        let mut values: Box<dyn Values> = match encoding {
            Encoding::Ascii => {
                text = String::from_utf8_lossy(&bytes[body..]).into_owned();
                let first_line = String::from_utf8_lossy(&bytes[..body]).lines().count() + 1;
                let words: Box<dyn Iterator<Item = (usize, &str)>> = Box::new(
                    text.lines()
                        .enumerate()
                        .flat_map(move |(k, l)| l.split_whitespace().map(move |w| (first_line + k, w))),
                );
                Box::new(Ascii {
                    words: words.peekable(),
                })
            }
            Encoding::Little | Encoding::Big => Box::new(Binary {
                bytes,
                at: body,
                big: encoding == Encoding::Big,
            }),
        };
        let mut mesh = Polygons::default();
        for e in &elements {
            read_element(e, values.as_mut(), &mut mesh, left)?;
        }
        Ok(mesh)
    }

    /// Reads every item of `e`: vertices' x, y, z; faces' index lists;
    /// triangle strips (split at −1) as triangles; anything else skipped.
    fn read_element(e: &Element, values: &mut dyn Values, mesh: &mut Polygons, left: usize) -> Result<(), ScanError> {
        let xyz: Vec<Option<usize>> = ["x", "y", "z"]
            .iter()
            .map(|n| e.properties.iter().position(|p| p.name == *n && p.count.is_none()))
            .collect();
        let indices = e
            .properties
            .iter()
            .position(|p| p.count.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"));
        let kind = e.name.as_str();
        if kind == "vertex" {
            mesh.positions.reserve(e.count);
        }
        for i in 0..e.count {
            let mut p = [0.0; 3];
            let mut list = Vec::new();
            for (k, prop) in e.properties.iter().enumerate() {
                match prop.count {
                    None => {
                        let x = values.next(prop.item, kind, i)?;
                        if let Some(axis) = xyz.iter().position(|&a| a == Some(k)) {
                            p[axis] = x;
                        }
                    }
                    Some(count) => {
                        let n = values.next(count, kind, i)?;
                        if !(n >= 0.0 && n.fract() == 0.0) {
                            return Err(ScanError::Element {
                                element: kind.into(),
                                index: i,
                                message: format!("list length {n}"),
                            });
                        }
                        let n = bounded(n as usize, 1, left, "list items")?;
                        for _ in 0..n {
                            let x = values.next(prop.item, kind, i)?;
                            if Some(k) == indices {
                                list.push(x);
                            }
                        }
                    }
                }
            }
            match kind {
                "vertex" => {
                    if p.iter().any(|x| !x.is_finite()) || xyz.contains(&None) {
                        return Err(ScanError::Element {
                            element: kind.into(),
                            index: i,
                            message: "a vertex needs finite x, y and z".into(),
                        });
                    }
                    mesh.positions.push(p);
                }
                "face" => mesh.push_face(as_indices(&list, kind, i)?, kind, i)?,
                "tristrips" => {
                    for strip in list.split(|&x| x < 0.0) {
                        let strip = as_indices(strip, kind, i)?;
                        for (k, w) in strip.windows(3).enumerate() {
                            // Every other triangle of a strip turns the other way.
                            let t = if k % 2 == 0 {
                                vec![w[0], w[1], w[2]]
                            } else {
                                vec![w[1], w[0], w[2]]
                            };
                            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                                mesh.push_face(t, kind, i)?;
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn as_indices(list: &[f64], element: &str, index: usize) -> Result<Vec<u32>, ScanError> {
        list.iter()
            .map(|&x| {
                (x >= 0.0 && x.fract() == 0.0 && x < 4e9)
                    .then_some(x as u32)
                    .ok_or_else(|| ScanError::Element {
                        element: element.into(),
                        index,
                        message: format!("{x} is not a vertex index"),
                    })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles of a unit square as the OBJ reader will see them.
    fn square() -> Polygons {
        Polygons {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            faces: vec![vec![0, 1, 2], vec![0, 2, 3]],
        }
    }

    #[test]
    fn ascii_and_binary_ply_with_faces_and_strips() {
        let ascii = "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n3 0 1 2\n3 0 2 3\n";
        assert_eq!(read(ScanFormat::Ply, ascii.as_bytes()).unwrap(), square());
        // The same as a strip 1 2 0 3 (0-1-2 is wrong way round: 1 2 0 is
        // the first triangle, then 2 1... turned), in big-endian binary.
        let mut bytes = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n".to_vec();
        for p in &square().positions {
            for x in p {
                bytes.extend(x.to_be_bytes());
            }
        }
        let strip: [i32; 6] = [1, 2, 0, -1, 0, 2];
        bytes.extend((strip.len() as i32).to_be_bytes());
        for s in strip {
            bytes.extend(s.to_be_bytes());
        }
        let read_back = read(ScanFormat::Ply, &bytes).unwrap();
        assert_eq!(read_back.positions, square().positions);
        assert_eq!(read_back.faces, vec![vec![1, 2, 0]]);
    }

    #[test]
    fn binary_and_ascii_stl_weld_equal_corners() {
        let mut bytes = vec![0u8; 80];
        bytes.extend(2u32.to_le_bytes());
        for f in &square().faces {
            bytes.extend([0u8; 12]);
            for &v in f {
                for x in square().positions[v as usize] {
                    bytes.extend((x as f32).to_le_bytes());
                }
            }
            bytes.extend([0u8; 2]);
        }
        assert_eq!(
            read(ScanFormat::Stl, &bytes).unwrap().faces,
            vec![vec![0, 1, 2], vec![0, 2, 3]]
        );
        let ascii = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n";
        assert_eq!(read(ScanFormat::Stl, ascii.as_bytes()).unwrap(), square());
    }

    #[test]
    fn off_with_comments_colours_and_a_quad() {
        let off = "OFF\n# a square\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n";
        // Colours after a face's indices are not read as the next face.
        let m = read(ScanFormat::Off, off.as_bytes());
        assert_eq!(m.unwrap().faces, vec![vec![0, 1, 2, 3]]);
    }

    #[test]
    fn hostile_headers_and_indices_are_named_errors() {
        let huge = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nend_header\n";
        assert!(matches!(
            read(ScanFormat::Ply, huge.as_bytes()),
            Err(ScanError::Header(_))
        ));
        let off = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
        assert_eq!(
            read(ScanFormat::Off, off.as_bytes()).unwrap_err().to_string(),
            "face 0: vertex 7 does not exist (3 vertices)"
        );
        let short = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 1\n";
        assert!(read(ScanFormat::Ply, short.as_bytes()).is_err());
        assert!(read(ScanFormat::Stl, b"not a mesh").is_err());
        assert!(read(ScanFormat::Off, b"").is_err());
    }
}
