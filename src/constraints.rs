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

use crate::io::MeshSelector;
use crate::mesh::nearest::{FarReader, nearest_vertices, too_far};
use crate::mesh::weld::{PrimitiveGeometry, WeldedMesh};
use crate::options::SolverOptions;
use crate::param::region::Region;
use crate::pins::{BoundaryChoice, PinError, Pins, ResolvedConstraint, coincident_message, coincident_targets};
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;

/// One constraint: a vertex (by id or nearest to a 3D point) and its target
/// (in texture coordinates or in pixels of `image_size`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstraintSpec {
    /// glTF vertex index in `primitive` (default: the file's `primitive`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vertex: Option<u32>,
    /// Or: the vertex nearest to this 3D point (mesh coordinates).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub near: Option<DVec3>,
    /// Target in glTF texture coordinates: (0, 0) is the image's top-left, v down.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uv: Option<DVec2>,
    /// Or: target in pixels of the file's `image_size`, (0, 0) = top-left corner
    /// of the image; pixel (i, j)'s centre is (i + 0.5, j + 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub px: Option<DVec2>,
    /// A name for reports ("left eye, outer corner").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// Primitive that `vertex` indexes (default: the file's `primitive`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub primitive: Option<usize>,
}

/// The outer-boundary vertices that go to the texture's corners (glTF vertex
/// ids in the file's `primitive`). Following the outer loop in the faces'
/// winding they must come top_left → bottom_left → bottom_right → top_right.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CornerSpec {
    pub top_left: u32,
    pub bottom_left: u32,
    pub bottom_right: u32,
    pub top_right: u32,
}

impl CornerSpec {
    pub fn as_array(&self) -> [u32; 4] {
        [self.top_left, self.bottom_left, self.bottom_right, self.top_right]
    }
}

/// The `corners` field: `Auto` (as if absent: arc-length quarters), or the
/// four corner vertices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Corners {
    Auto,
    Given(CornerSpec),
}

impl Corners {
    /// The given corners, if any.
    pub fn given(&self) -> Option<CornerSpec> {
        match self {
            Corners::Auto => None,
            Corners::Given(c) => Some(*c),
        }
    }
}

impl Serialize for Corners {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Corners::Auto => s.serialize_unit_struct("Auto"),
            Corners::Given(c) => c.serialize(s),
        }
    }
}

/// Reads `Auto` or a corner struct, keeping the struct's own error messages
/// (a misspelt corner name is named).
struct CornersVisitor;

impl<'de> serde::de::Visitor<'de> for CornersVisitor {
    type Value = Corners;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("`Auto` or `(top_left: …, bottom_left: …, bottom_right: …, top_right: …)`")
    }

    fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Corners, E> {
        match v {
            "Auto" => Ok(Corners::Auto),
            other => Err(E::invalid_value(serde::de::Unexpected::Str(other), &self)),
        }
    }

    /// RON reads the bare word `Auto` as a unit value.
    fn visit_unit<E: serde::de::Error>(self) -> Result<Corners, E> {
        Ok(Corners::Auto)
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Corners, A::Error> {
        CornerSpec::deserialize(serde::de::value::MapAccessDeserializer::new(map)).map(Corners::Given)
    }
}

impl<'de> Deserialize<'de> for Corners {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(CornersVisitor)
    }
}

/// The whole constraint file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstraintFile {
    /// The glTF (.glb/.gltf) or .obj file, relative to the constraint file.
    pub asset: String,
    /// Mesh of the asset, by index or name (default: 0, the first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshSelector>,
    /// Primitive that `vertex` ids and `corners` refer to (default 0).
    #[serde(default)]
    pub primitive: usize,
    /// The UV set written, TEXCOORD_<uv_set> (default 0).
    #[serde(default)]
    pub uv_set: u32,
    /// Image size in pixels (width, height), for `px` targets.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image_size: Option<(u32, u32)>,
    /// An image to place the targets on in the editor (PNG or JPEG,
    /// relative to the constraint file; default: the material's
    /// base-colour texture).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image: Option<String>,
    pub constraints: Vec<ConstraintSpec>,
    /// Corner vertices (default: chosen automatically at arc-length quarters).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub corners: Option<Corners>,
    /// How the outer boundary is laid out (default: `Free` inside the
    /// chart's own island when it already has UVs, else `Square`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub boundary: Option<BoundaryChoice>,
    /// With a free boundary, the rectangle of the texture the chart stays
    /// inside (default: the whole texture, or the chart's island). Giving
    /// one makes the boundary free unless `boundary: Square` says otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<Region>,
    /// Spline stepping limits (see [`SolverOptions`] for the defaults; a
    /// configuration file's `solver` applies when this is absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver: Option<SolverOptions>,
}

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
    /// The solver options in force: the file's `solver`, else the defaults given at load.
    pub solver: SolverOptions,
}

impl LoadedConstraints {
    /// Reads and parses a constraint file (solver defaults for a file without
    /// `solver`; read from anywhere, within the default limits).
    ///
    /// # Errors
    /// Unreadable file; RON syntax errors and unknown or missing fields (with
    /// line:column); a constraint with both or neither of `vertex`/`near` or
    /// `uv`/`px`; `px` without `image_size`; a target outside the unit square;
    /// one vertex given two different targets.
    pub fn load(path: &Path) -> Result<Self, ConstraintFileError> {
        Self::load_within(path, &SolverOptions::DEFAULT, &crate::io::InputRules::default())
    }

    /// As [`LoadedConstraints::load`], with `defaults` for a file without
    /// `solver`, read within `rules` (a regular file, at most
    /// `max_text_bytes`, inside the scope).
    ///
    /// # Errors
    /// As [`LoadedConstraints::load`].
    pub fn load_within(
        path: &Path,
        defaults: &SolverOptions,
        rules: &crate::io::InputRules,
    ) -> Result<Self, ConstraintFileError> {
        let bytes =
            crate::io::read::read_regular(path, rules.limits.max_text_bytes, &rules.scope).map_err(|source| {
                ConstraintFileError::Read {
                    path: path.to_path_buf(),
                    source,
                }
            })?;
        let text = String::from_utf8(bytes).map_err(|e| ConstraintFileError::NotUtf8 {
            path: path.to_path_buf(),
            at: e.utf8_error().valid_up_to(),
        })?;
        Self::parse_with_defaults(path, &text, defaults)
    }

    /// Wraps an in-memory constraint file (for the library API); `path` names it in messages.
    ///
    /// # Errors
    /// The same checks as [`LoadedConstraints::load`] after parsing.
    pub fn from_file(path: &Path, file: ConstraintFile) -> Result<Self, ConstraintFileError> {
        let loaded = LoadedConstraints {
            solver: file.solver.unwrap_or_default(),
            path: path.to_path_buf(),
            item_positions: vec![(1, 1); file.constraints.len()],
            corners_position: (1, 1),
            asset_position: (1, 1),
            region_position: (1, 1),
            file,
        };
        loaded.validate()?;
        Ok(loaded)
    }

    /// Parses constraint-file text; `path` is used for messages and to resolve `asset`.
    pub fn parse(path: &Path, text: &str) -> Result<Self, ConstraintFileError> {
        Self::parse_with_defaults(path, text, &SolverOptions::DEFAULT)
    }

    /// As [`LoadedConstraints::parse`], with `defaults` for a file without `solver`.
    pub fn parse_with_defaults(path: &Path, text: &str, defaults: &SolverOptions) -> Result<Self, ConstraintFileError> {
        let file: ConstraintFile = crate::ron_file::parse_ron(path, text)?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let scan = scan_positions(text);
        if file.corners == Some(Corners::Auto)
            && let Some((line, column)) = scan.corners
            && !text.lines().nth(line - 1).is_some_and(|l| {
                let rest: String = l.chars().skip(column - 1).collect();
                rest.starts_with("Auto") && !rest[4..].starts_with(|c: char| c.is_alphanumeric() || c == '_')
            })
        {
            return Err(ConstraintFileError::Invalid {
                path: path.to_path_buf(),
                line,
                column,
                field: "corners".into(),
                message: "expected `Auto` or `(top_left: …, bottom_left: …, bottom_right: …, top_right: …)`".into(),
            });
        }
        let mut item_positions = scan.items;
        item_positions.resize(file.constraints.len(), scan.constraints.unwrap_or((1, 1)));
        let loaded = LoadedConstraints {
            solver: file.solver.unwrap_or(*defaults),
            path: path.to_path_buf(),
            item_positions,
            corners_position: scan.corners.unwrap_or((1, 1)),
            asset_position: scan.asset.unwrap_or((1, 1)),
            region_position: scan.region.unwrap_or((1, 1)),
            file,
        };
        loaded.validate()?;
        Ok(loaded)
    }

    /// The asset's path (relative paths are relative to the constraint file).
    pub fn asset_path(&self) -> PathBuf {
        let asset = Path::new(&self.file.asset);
        if asset.is_absolute() {
            asset.to_path_buf()
        } else {
            self.path.parent().unwrap_or(Path::new(".")).join(asset)
        }
    }

    /// The file's `image:` (the picture its targets are placed on), beside
    /// the file unless absolute.
    pub fn image_path(&self) -> Option<PathBuf> {
        let image = Path::new(self.file.image.as_deref()?);
        Some(if image.is_absolute() {
            image.to_path_buf()
        } else {
            self.path.parent().unwrap_or(Path::new(".")).join(image)
        })
    }

    /// An error located at constraint `index`.
    pub fn error_at(&self, index: usize, field: &str, message: impl Into<String>) -> ConstraintFileError {
        let (line, column) = self.item_positions.get(index).copied().unwrap_or((1, 1));
        ConstraintFileError::Invalid {
            path: self.path.clone(),
            line,
            column,
            field: format!("constraints[{index}].{field}"),
            message: message.into(),
        }
    }

    /// An error located at the `region` value.
    pub fn region_error(&self, message: impl Into<String>) -> ConstraintFileError {
        let (line, column) = self.region_position;
        ConstraintFileError::Invalid {
            path: self.path.clone(),
            line,
            column,
            field: "region".into(),
            message: message.into(),
        }
    }

    /// An error located at the `corners` value.
    pub fn corners_error(&self, message: impl Into<String>) -> ConstraintFileError {
        let (line, column) = self.corners_position;
        ConstraintFileError::Invalid {
            path: self.path.clone(),
            line,
            column,
            field: "corners".into(),
            message: message.into(),
        }
    }

    /// An error located at the `asset` value.
    pub fn asset_error(&self, field: &str, message: impl Into<String>) -> ConstraintFileError {
        let (line, column) = self.asset_position;
        ConstraintFileError::Invalid {
            path: self.path.clone(),
            line,
            column,
            field: field.into(),
            message: message.into(),
        }
    }

    /// Target of constraint `c` in texture coordinates (after validation).
    pub fn target_uv(&self, c: &ConstraintSpec) -> DVec2 {
        match (c.uv, c.px, self.file.image_size) {
            (Some(uv), _, _) => uv,
            (None, Some(px), Some((w, h))) => DVec2::new(px.x / w as f64, px.y / h as f64),
            _ => unreachable!("validated"),
        }
    }

    fn validate(&self) -> Result<(), ConstraintFileError> {
        let f = &self.file;
        if let Some((w, h)) = f.image_size
            && (w == 0 || h == 0)
        {
            return Err(self.asset_error("image_size", format!("image size must be positive, got ({w}, {h})")));
        }
        if let Err(e) = self.solver.check() {
            return Err(self.asset_error(&format!("solver.{}", e.field), format!("{}, got {}", e.why, e.value)));
        }
        for (i, c) in f.constraints.iter().enumerate() {
            match (c.vertex, c.near) {
                (None, None) => {
                    return Err(self.error_at(i, "vertex", "give `vertex: <id>` or `near: (x, y, z)`"));
                }
                (Some(_), Some(_)) => {
                    return Err(self.error_at(i, "near", "give either `vertex` or `near`, not both"));
                }
                (None, Some(p)) if !p.is_finite() => {
                    return Err(self.error_at(i, "near", format!("not a finite point: {p:?}")));
                }
                _ => {}
            }
            match (c.uv, c.px) {
                (None, None) => {
                    return Err(self.error_at(i, "uv", "give a target: `uv: (u, v)` or `px: (x, y)`"));
                }
                (Some(_), Some(_)) => {
                    return Err(self.error_at(i, "px", "give either `uv` or `px`, not both"));
                }
                (None, Some(_)) if f.image_size.is_none() => {
                    return Err(self.error_at(i, "px", "pixel targets need `image_size: (width, height)` in the file"));
                }
                _ => {}
            }
            let field = if c.uv.is_some() { "uv" } else { "px" };
            let t = self.target_uv(c);
            if !(t.is_finite() && t.x >= 0.0 && t.x <= 1.0 && t.y >= 0.0 && t.y <= 1.0) {
                return Err(self.error_at(
                    i,
                    field,
                    format!(
                        "target ({}, {}) in texture coordinates is outside the unit square [0, 1] × [0, 1]",
                        t.x, t.y
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Resolves every constraint against the asset's primitives (the ones of
    /// the selected mesh, in mesh order) and their welding.
    ///
    /// Duplicates that name the same welded vertex with the same target are
    /// merged; with different targets they are an error.
    ///
    /// # Errors
    /// Primitive or vertex id out of range (with the valid range), a vertex
    /// used by no triangle, conflicting duplicates.
    pub fn resolve(
        &self,
        primitives: &[PrimitiveGeometry],
        welded: &WeldedMesh,
    ) -> Result<Vec<ResolvedConstraint>, ConstraintFileError> {
        let mut out: Vec<ResolvedConstraint> = Vec::new();
        for (i, c) in self.file.constraints.iter().enumerate() {
            let prim_index = c.primitive.unwrap_or(self.file.primitive);
            let (prim_pos, vertex, snapped) = match (c.vertex, c.near) {
                (Some(v), _) => {
                    let p = self.primitive_position(primitives, prim_index, Some(i))?;
                    let n = primitives[p].positions.len();
                    if v as usize >= n {
                        return Err(self.error_at(
                            i,
                            "vertex",
                            format!(
                                "vertex {v} is out of range: primitive {prim_index} has vertices 0..{n} (0 to {})",
                                n.saturating_sub(1)
                            ),
                        ));
                    }
                    (p, v, None)
                }
                (None, Some(point)) => {
                    if let Some(pi) = c.primitive {
                        self.primitive_position(primitives, pi, Some(i))?;
                    }
                    let Some(best) = nearest_vertices(primitives, c.primitive, point, 1).pop() else {
                        return Err(self.error_at(i, "near", "the mesh has no vertices to snap to"));
                    };
                    if let Some(why) = too_far(primitives, c.primitive, point, FarReader::ConstraintFile) {
                        return Err(self.error_at(i, "near", why));
                    }
                    let p = self.primitive_position(primitives, best.primitive, Some(i))?;
                    (p, best.vertex, Some(best.distance))
                }
                (None, None) => unreachable!("validated"),
            };
            let w = welded.vertex_of[prim_pos][vertex as usize];
            if welded.chart_of_vertex[w as usize].is_none() {
                return Err(self.error_at(i, "vertex", format!("vertex {vertex} is used by no triangle")));
            }
            let target_uv = self.target_uv(c);
            if let Some(prev) = out.iter().find(|r| r.welded == w) {
                if prev.target_uv == target_uv {
                    continue;
                }
                return Err(self.error_at(
                    i,
                    if c.uv.is_some() { "uv" } else { "px" },
                    format!(
                        "vertex {vertex} (primitive {}) is already constrained by constraints[{}] to ({}, {}); a vertex can have only one target",
                        primitives[prim_pos].index, prev.index, prev.target_uv.x, prev.target_uv.y
                    ),
                ));
            }
            out.push(ResolvedConstraint {
                index: i,
                label: c.label.clone(),
                primitive: primitives[prim_pos].index,
                vertex,
                welded: w,
                target_uv,
                snapped_distance: snapped,
            });
        }
        if let Some((a, b)) = coincident_targets(&out) {
            let (ca, cb) = (&out[a], &out[b]);
            return Err(self.error_at(cb.index, self.target_field(cb.index), coincident_message(ca, cb)));
        }
        Ok(out)
    }

    /// The field constraint `index`'s target is written in.
    fn target_field(&self, index: usize) -> &'static str {
        if self.file.constraints.get(index).is_some_and(|c| c.uv.is_none()) {
            "px"
        } else {
            "uv"
        }
    }

    /// Position in `primitives` of glTF primitive `index`.
    fn primitive_position(
        &self,
        primitives: &[PrimitiveGeometry],
        index: usize,
        item: Option<usize>,
    ) -> Result<usize, ConstraintFileError> {
        primitives.iter().position(|p| p.index == index).ok_or_else(|| {
            let msg = format!(
                "primitive {index} does not exist (the mesh has TRIANGLES primitives {:?})",
                primitives.iter().map(|p| p.index).collect::<Vec<_>>()
            );
            match item {
                Some(i) => self.error_at(i, "primitive", msg),
                None => self.asset_error("primitive", msg),
            }
        })
    }

    /// The corner vertices as welded ids.
    ///
    /// # Errors
    /// A corner id out of range of the file's `primitive`.
    pub fn resolve_corners(
        &self,
        primitives: &[PrimitiveGeometry],
        welded: &WeldedMesh,
    ) -> Result<Option<[u32; 4]>, ConstraintFileError> {
        let Some(corners) = self.file.corners.and_then(|c| c.given()) else {
            return Ok(None);
        };
        let p = self.primitive_position(primitives, self.file.primitive, None)?;
        let n = primitives[p].positions.len();
        let mut out = [0u32; 4];
        for (k, v) in corners.as_array().into_iter().enumerate() {
            if v as usize >= n {
                return Err(self.corners_error(format!(
                    "{}: vertex {v} is out of range: primitive {} has vertices 0..{n}",
                    crate::param::boundary::CORNER_NAMES[k],
                    self.file.primitive
                )));
            }
            out[k] = welded.vertex_of[p][v as usize];
        }
        Ok(Some(out))
    }
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

    /// The requested boundary layout and region.
    pub fn boundary(&self) -> (Option<BoundaryChoice>, Option<Region>) {
        match self {
            ConstraintSource::File(l) => (l.file.boundary, l.file.region),
            ConstraintSource::Memory(p) => (p.boundary, p.region),
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

/// Source positions found by [`scan_positions`].
#[derive(Debug, Default)]
struct ScannedPositions {
    asset: Option<(usize, usize)>,
    constraints: Option<(usize, usize)>,
    items: Vec<(usize, usize)>,
    corners: Option<(usize, usize)>,
    region: Option<(usize, usize)>,
}

/// A position in RON text, moved one character at a time (1-based line and column).
struct Cursor {
    chars: Vec<char>,
    i: usize,
    line: usize,
    col: usize,
}

impl Cursor {
    fn peek(&self, k: usize) -> Option<char> {
        self.chars.get(self.i + k).copied()
    }

    fn bump(&mut self) {
        if self.peek(0) == Some('\n') {
            self.line += 1;
            self.col = 1;
        } else {
            self.col += 1;
        }
        self.i += 1;
    }

    /// Skips a comment (`//` to the end of the line, or a nestable `/* */`)
    /// if one starts here; whether it did.
    fn skip_comment(&mut self) -> bool {
        match (self.peek(0), self.peek(1)) {
            (Some('/'), Some('/')) => {
                while self.peek(0).is_some_and(|c| c != '\n') {
                    self.bump();
                }
                true
            }
            (Some('/'), Some('*')) => {
                let mut nest = 0;
                while self.peek(0).is_some() {
                    match (self.peek(0), self.peek(1)) {
                        (Some('/'), Some('*')) => {
                            nest += 1;
                            self.bump();
                        }
                        (Some('*'), Some('/')) => {
                            nest -= 1;
                            self.bump();
                            if nest == 0 {
                                self.bump();
                                return true;
                            }
                        }
                        _ => {}
                    }
                    self.bump();
                }
                true
            }
            _ => false,
        }
    }

    /// Skips a string literal starting here (escapes included).
    fn skip_string(&mut self) {
        self.bump();
        while self.peek(0).is_some_and(|c| c != '"') {
            if self.peek(0) == Some('\\') {
                self.bump();
            }
            if self.peek(0).is_some() {
                self.bump();
            }
        }
        if self.peek(0).is_some() {
            self.bump();
        }
    }

    /// Whether the next character after whitespace is `:` (an identifier
    /// followed by whitespace then `:` is still a field name).
    fn colon_follows(&self) -> bool {
        let mut j = self.i;
        while self.chars.get(j).is_some_and(|c| c.is_whitespace()) {
            j += 1;
        }
        self.chars.get(j) == Some(&':')
    }
}

/// The scanner's state between characters.
#[derive(Default)]
struct Scan {
    out: ScannedPositions,
    depth: usize,
    ident: String,
    /// The top-level field whose value comes next.
    pending: Option<String>,
    /// Inside the `constraints` list, at this bracket depth.
    list_depth: Option<usize>,
}

impl Scan {
    /// A top-level field's value starts at `here` with `c`.
    fn value_starts(&mut self, field: &str, c: char, here: (usize, usize)) {
        match field {
            "asset" => self.out.asset = Some(here),
            "corners" => self.out.corners = Some(here),
            "region" => self.out.region = Some(here),
            "constraints" => {
                self.out.constraints = Some(here);
                if c == '[' {
                    self.list_depth = Some(self.depth + 1);
                }
            }
            _ => {}
        }
    }

    /// Punctuation `c` at `here`: field names, brackets, list items.
    fn punctuation(&mut self, c: char, here: (usize, usize)) {
        if c == ':' && self.depth == 1 && !self.ident.is_empty() {
            self.pending = Some(std::mem::take(&mut self.ident));
        } else if !c.is_whitespace() {
            self.ident.clear();
        }
        match c {
            '(' | '[' | '{' => {
                if self.list_depth == Some(self.depth) {
                    self.out.items.push(here);
                }
                self.depth += 1;
            }
            ')' | ']' | '}' => {
                self.depth = self.depth.saturating_sub(1);
                if self.list_depth.is_some_and(|d| self.depth < d) {
                    self.list_depth = None;
                }
            }
            _ => {}
        }
    }
}

/// Finds where the top-level `asset`, `constraints` (and each of its
/// elements) and `corners` values start (1-based line and column). Only run
/// on text RON already accepted, so it can be simple: it skips comments and
/// strings and tracks bracket depth.
fn scan_positions(text: &str) -> ScannedPositions {
    let mut cur = Cursor {
        chars: text.chars().collect(),
        i: 0,
        line: 1,
        col: 1,
    };
    let mut scan = Scan::default();
    while let Some(c) = cur.peek(0) {
        if cur.skip_comment() {
            continue;
        }
        let here = (cur.line, cur.col);
        if let Some(field) = scan.pending.take_if(|_| !c.is_whitespace() && c != ':') {
            scan.value_starts(&field, c, here);
        }
        if c == '"' {
            cur.skip_string();
            scan.ident.clear();
            continue;
        }
        if c.is_alphanumeric() || c == '_' {
            scan.ident.push(c);
        } else {
            scan.punctuation(c, here);
        }
        if c.is_whitespace() && !scan.ident.is_empty() && scan.pending.is_none() && !cur.colon_follows() {
            scan.ident.clear();
        }
        cur.bump();
    }
    scan.out
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let e = err("(asset: \"a.glb\", constraints: [\n (vertex: 1, uv: (0.5, 0.5)),\n (vertex: 2, uv: (1.5, 0.5))])");
        assert!(
            e.starts_with("f.ron:3:2: constraints[1].uv") && e.contains("outside the unit square"),
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
