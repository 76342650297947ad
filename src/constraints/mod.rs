//! The constraint file (`*.uvpin.ron`): which asset, which feature vertices go
//! where in the texture, optional corners and solver options.
//!
//! ```ron
//! (
//!     asset: "face.glb",                 // relative to this file
//!     constraints: [
//!         (vertex: 1021, uv: (0.42, 0.61), label: "left eye, outer corner"),
//!         (near: (0.03, 1.62, 0.11), px: (310, 412)),
//!     ],
//!     corners: (top_left: 5, bottom_left: 17, bottom_right: 230, top_right: 301),
//! )
//! ```
//! Every error names the file, line and column, and the field.

//!
//! [`schema`] is what may be written, `parse` reads and locates it,
//! `resolve` finds its vertices in an asset.

mod parse;
mod resolve;
pub mod schema;

pub use schema::{AtlasKeeping, ConstraintFile, ConstraintSpec, CornerSpec, Corners};

use crate::mesh::weld::{PrimitiveGeometry, WeldedMesh};
use crate::options::SolverOptions;
use crate::param::region::Region;
use crate::pins::{BoundaryChoice, PinError, Pins, ResolvedConstraint, SeamsChoice};
use std::path::PathBuf;
use std::sync::Arc;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum ConstraintFileError {
    #[error("{path}: cannot read the constraint file: {source}")]
    Read {
        path: PathBuf,
        source: crate::io::ReadError,
    },
    #[error("{path}: not UTF-8 text (an invalid byte at offset {at})")]
    NotUtf8 { path: PathBuf, at: usize },
    #[error(transparent)]
    Syntax(#[from] crate::ron_file::RonSyntaxError),
    #[error("{path}:{line}:{column}: {field}: {message}")]
    Invalid {
        path: PathBuf,
        line: usize,
        column: usize,
        field: String,
        message: String,
    },
}

/// A parsed constraint file with the source positions of its parts, so that
/// errors found later (against the asset) still point into the file.
#[derive(Debug, Clone)]
pub struct LoadedConstraints {
    pub path: PathBuf,
    pub file: ConstraintFile,
    /// (line, column) of each element of `constraints`.
    pub item_positions: Vec<(usize, usize)>,
    /// (line, column) of the `corners` value, or of the file start.
    pub corners_position: (usize, usize),
    /// (line, column) of the `asset` value.
    pub asset_position: (usize, usize),
    /// (line, column) of the `region` value, or of the file start.
    pub region_position: (usize, usize),
    /// (line, column) of the `seams` value, or of the file start.
    pub seams_position: (usize, usize),
    /// Where the `boundary` value starts (1-based line and column).
    pub boundary_position: (usize, usize),
    /// The solver options in force: the file's `solver`, else the defaults given at load.
    pub solver: SolverOptions,
}

/// A mistake in the constraints, wherever they came from: a file's (with
/// line and column) or in-memory pins' (with the constraint's index).
#[derive(Debug, Error)]
pub enum ConstraintError {
    #[error(transparent)]
    File(#[from] ConstraintFileError),
    #[error(transparent)]
    Pins(#[from] PinError),
}

/// Where a solve's constraints came from. Errors found later, against the
/// mesh or the boundary mapping, point back into it: a file's line and
/// column, or an in-memory constraint's index.
#[derive(Debug, Clone)]
pub enum ConstraintSource {
    File(Arc<LoadedConstraints>),
    Memory(Arc<Pins>),
}

impl ConstraintSource {
    /// What becomes of an atlas in the set written: a file decides by its
    /// `uv_set` ([`ConstraintFile::atlas`]); pins in memory keep it (the
    /// library's atlas solve passes it to be kept).
    pub fn atlas(&self) -> AtlasKeeping {
        match self {
            ConstraintSource::File(loaded) => loaded.file.atlas(),
            ConstraintSource::Memory(_) => AtlasKeeping::Always,
        }
    }

    /// The constraint file's `image:`, if it names one.
    pub fn image_path(&self) -> Option<PathBuf> {
        match self {
            ConstraintSource::File(loaded) => loaded.image_path(),
            ConstraintSource::Memory(_) => None,
        }
    }

    /// How reports name the source: the file's path, or `<memory>`.
    pub fn name(&self) -> String {
        match self {
            ConstraintSource::File(l) => l.path.display().to_string(),
            ConstraintSource::Memory(_) => "<memory>".into(),
        }
    }

    /// The constraints resolved against the asset's primitives and their
    /// welding, and the corners as welded ids.
    ///
    /// # Errors
    /// As [`LoadedConstraints::resolve`] and [`Pins::resolve`].
    pub fn resolve(
        &self,
        primitives: &[PrimitiveGeometry],
        welded: &WeldedMesh,
    ) -> Result<(Vec<ResolvedConstraint>, Option<[u32; 4]>), ConstraintError> {
        match self {
            ConstraintSource::File(l) => Ok((l.resolve(primitives, welded)?, l.resolve_corners(primitives, welded)?)),
            ConstraintSource::Memory(pins) => Ok(pins.resolve(&primitives[0], welded)?),
        }
    }

    /// An error about constraint `index`'s `field`.
    pub fn error_at(&self, index: usize, field: &str, message: String) -> ConstraintError {
        match self {
            ConstraintSource::File(l) => l.error_at(index, field, message).into(),
            ConstraintSource::Memory(_) => PinError::Constraint { index, message }.into(),
        }
    }

    /// An error about the corners.
    pub fn corners_error(&self, message: String) -> ConstraintError {
        match self {
            ConstraintSource::File(l) => l.corners_error(message).into(),
            ConstraintSource::Memory(_) => PinError::Corners { message }.into(),
        }
    }

    /// An error about the boundary.
    pub fn boundary_error(&self, message: String) -> ConstraintError {
        match self {
            ConstraintSource::File(l) => l.boundary_error(message).into(),
            ConstraintSource::Memory(_) => PinError::Boundary { message }.into(),
        }
    }

    /// The requested boundary layout and region.
    pub fn boundary(&self) -> (Option<BoundaryChoice>, Option<Region>) {
        match self {
            ConstraintSource::File(l) => (l.file.boundary, l.file.region),
            ConstraintSource::Memory(p) => (p.boundary, p.region),
        }
    }

    /// The same constraints with no seams at all (`seams: Edges([])`): the
    /// chart laid out as it is, for a disk that was cut only because its
    /// boundary is short for its area.
    pub fn without_seams(&self) -> ConstraintSource {
        match self {
            ConstraintSource::File(l) => {
                let mut l = (**l).clone();
                l.file.seams = Some(SeamsChoice::Edges(Vec::new()));
                ConstraintSource::File(Arc::new(l))
            }
            ConstraintSource::Memory(p) => {
                ConstraintSource::Memory(Arc::new((**p).clone().with_seams(SeamsChoice::Edges(Vec::new()))))
            }
        }
    }

    /// The requested seams, as welded vertex paths (`Auto` when not given).
    ///
    /// # Errors
    /// A seam vertex out of range (located at the `seams` field).
    pub fn seams(&self, primitives: &[PrimitiveGeometry], welded: &WeldedMesh) -> Result<SeamsChoice, ConstraintError> {
        let (given, primitive, fail): (_, usize, Box<dyn Fn(String) -> ConstraintError>) = match self {
            ConstraintSource::File(l) => (
                l.file.seams.clone().unwrap_or_default(),
                primitives.iter().position(|p| p.index == l.file.primitive).unwrap_or(0),
                Box::new(|m| l.seams_error(m).into()),
            ),
            ConstraintSource::Memory(p) => (p.seams.clone(), 0, Box::new(|m| PinError::Seams { message: m }.into())),
        };
        let SeamsChoice::Edges(paths) = given else {
            return Ok(SeamsChoice::Auto);
        };
        let map = &welded.vertex_of[primitive];
        let mut out = Vec::with_capacity(paths.len());
        for (k, path) in paths.iter().enumerate() {
            if path.len() < 2 {
                return Err(fail(format!(
                    "seams[{k}] has {} vertices: a seam path needs at least 2",
                    path.len()
                )));
            }
            let mut ids = Vec::with_capacity(path.len());
            for &v in path {
                let w = map.get(v as usize).copied().ok_or_else(|| {
                    fail(format!(
                        "seams[{k}]: vertex {v} is out of range: the mesh has vertices 0..{}",
                        map.len()
                    ))
                })?;
                ids.push(w);
            }
            out.push(ids);
        }
        Ok(SeamsChoice::Edges(out))
    }

    /// An error about the seams.
    pub fn seams_error(&self, message: String) -> ConstraintError {
        match self {
            ConstraintSource::File(l) => l.seams_error(message).into(),
            ConstraintSource::Memory(_) => PinError::Seams { message }.into(),
        }
    }

    /// An error about the region.
    pub fn region_error(&self, message: String) -> ConstraintError {
        match self {
            ConstraintSource::File(l) => l.region_error(message).into(),
            ConstraintSource::Memory(_) => PinError::Region { message }.into(),
        }
    }

    /// The field constraint `index`'s target is written in (`uv` or `px`).
    pub fn target_field(&self, index: usize) -> &'static str {
        match self {
            ConstraintSource::File(l) => l.target_field(index),
            ConstraintSource::Memory(_) => "uv",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};
    use std::path::Path;

    const GOOD: &str = r#"// a face
(
    asset: "face.glb",   // relative
    constraints: [
        (vertex: 12, uv: (0.25, 0.5), label: "eye"),
        /* a ( tricky ] comment */ (vertex: 3, uv: (1, 0)),
        (near: (0.1, 0.2, 0.3), px: (64, 32)),
    ],
    image_size: (128, 64),
    corners: (top_left: 5, bottom_left: 17, bottom_right: 230, top_right: 301),
)
"#;

    #[test]
    fn parses_the_documented_syntax_and_locates_items() {
        let l = LoadedConstraints::parse(Path::new("dir/f.uvpin.ron"), GOOD).unwrap();
        assert_eq!(l.file.constraints.len(), 3);
        assert_eq!(l.file.constraints[0].vertex, Some(12));
        assert_eq!(l.file.constraints[2].near, Some(DVec3::new(0.1, 0.2, 0.3)));
        assert_eq!(l.item_positions, vec![(5, 9), (6, 36), (7, 9)]);
        assert_eq!(l.corners_position, (10, 14));
        assert_eq!(l.asset_position, (3, 12));
        assert_eq!(l.asset_path(), Path::new("dir/face.glb"));
        assert_eq!(l.target_uv(&l.file.constraints[2]), DVec2::new(0.5, 0.5));
        assert_eq!(l.solver, SolverOptions::DEFAULT);
    }

    fn err(text: &str) -> String {
        LoadedConstraints::parse(Path::new("f.ron"), text)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn corners_may_be_auto_or_given() {
        let auto =
            LoadedConstraints::parse(Path::new("f.ron"), "(asset: \"a\", constraints: [], corners: Auto)").unwrap();
        assert_eq!(auto.file.corners, Some(Corners::Auto));
        let given =
            "(asset: \"a\", constraints: [], corners: (top_left: 1, bottom_left: 2, bottom_right: 3, top_right: 4))";
        let l = LoadedConstraints::parse(Path::new("f.ron"), given).unwrap();
        assert_eq!(
            l.file.corners.and_then(|c| c.given()).map(|c| c.as_array()),
            Some([1, 2, 3, 4])
        );
        let e = err(
            "(asset: \"a\", constraints: [], corners: (top_lft: 1, bottom_left: 2, bottom_right: 3, top_right: 4))",
        );
        assert!(e.starts_with("f.ron:1:") && e.contains("top_lft"), "{e}");
        let e = err("(asset: \"a\", constraints: [], corners: Manual)");
        assert!(e.starts_with("f.ron:1:40: corners: expected `Auto`"), "{e}");
        let bom = "\u{feff}(asset: \"a\", constraints: [], corners: Auto)";
        assert!(LoadedConstraints::parse(Path::new("f.ron"), bom).is_ok());
    }

    #[test]
    fn misspelt_key_names_line_column_and_the_expected_fields() {
        let e = err("(\n  asset: \"a.glb\",\n  constraints: [(vertx: 1, uv: (0.5, 0.5))],\n)");
        assert!(e.starts_with("f.ron:3:18"), "{e}");
        assert!(e.contains("vertx") && e.contains("vertex"), "{e}");
        let e = err("(\n  aset: \"a.glb\",\n  constraints: [],\n)");
        assert!(e.starts_with("f.ron:2:3") && e.contains("aset"), "{e}");
    }

    #[test]
    fn semantic_errors_point_at_the_item() {
        let e = err("(asset: \"a.glb\", constraints: [\n (vertex: 1, uv: (0.5, 0.5)),\n (vertex: 2, uv: (inf, 0.5))])");
        assert!(
            e.starts_with("f.ron:3:2: constraints[1].uv") && e.contains("not a finite point"),
            "{e}"
        );
        let e = err("(asset: \"a.glb\", constraints: [(vertex: 1, px: (3, 4))])");
        assert!(e.contains("image_size"), "{e}");
        let e = err("(asset: \"a.glb\", constraints: [(uv: (0.1, 0.1))])");
        assert!(e.contains("constraints[0].vertex"), "{e}");
        let e = err("(asset: \"a.glb\", constraints: [(vertex: -3, uv: (0.1, 0.1))])");
        assert!(e.starts_with("f.ron:1:"), "{e}");
        let e = err("(asset: \"a.glb\", constraints: [(vertex: 1, uv: (0.1 0.1))])");
        assert!(e.contains("f.ron:1:"), "{e}");
    }

    #[test]
    fn duplicate_vertices_merge_or_conflict() {
        let prim = PrimitiveGeometry {
            index: 0,
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            indices: vec![0, 1, 2],
            uvs: None,
        };
        let welded = crate::mesh::weld::weld(std::slice::from_ref(&prim));
        let same = "(asset: \"a\", constraints: [(vertex: 1, uv: (0.5, 0.5)), (vertex: 1, uv: (0.5, 0.5))])";
        let l = LoadedConstraints::parse(Path::new("f.ron"), same).unwrap();
        assert_eq!(l.resolve(std::slice::from_ref(&prim), &welded).unwrap().len(), 1);
        let diff = "(asset: \"a\", constraints: [(vertex: 1, uv: (0.5, 0.5)),\n (vertex: 1, uv: (0.5, 0.6))])";
        let l = LoadedConstraints::parse(Path::new("f.ron"), diff).unwrap();
        let e = l.resolve(std::slice::from_ref(&prim), &welded).unwrap_err().to_string();
        assert!(
            e.starts_with("f.ron:2:2: constraints[1].uv") && e.contains("already constrained"),
            "{e}"
        );
        let out = "(asset: \"a\", constraints: [(vertex: 7, uv: (0.5, 0.5))])";
        let l = LoadedConstraints::parse(Path::new("f.ron"), out).unwrap();
        let e = l.resolve(std::slice::from_ref(&prim), &welded).unwrap_err().to_string();
        assert!(e.contains("out of range") && e.contains("0..3"), "{e}");
        let near = "(asset: \"a\", constraints: [(near: (0.9, 0.1, 0), uv: (0.5, 0.5))])";
        let l = LoadedConstraints::parse(Path::new("f.ron"), near).unwrap();
        let r = l.resolve(std::slice::from_ref(&prim), &welded).unwrap();
        assert_eq!(r[0].vertex, 1);
    }
}
