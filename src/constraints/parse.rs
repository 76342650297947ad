//! Reading a constraint file: RON text parsed, its parts located (line and
//! column, for every later error) and its contents checked.

use super::schema::{ConstraintFile, ConstraintSpec, Corners};
use super::{ConstraintFileError, LoadedConstraints};
use crate::options::SolverOptions;
use crate::ron_file::tokens::{groups_inside, line_column, tokens, top_fields};
use glam::DVec2;
use std::path::{Path, PathBuf};

impl LoadedConstraints {
    /// Reads and parses a constraint file (solver defaults for a file without
    /// `solver`; read from anywhere, within the default limits).
    ///
    /// # Errors
    /// Unreadable file; RON syntax errors and unknown or missing fields (with
    /// line:column); a constraint with both or neither of `vertex`/`near` or
    /// `uv`/`px`; `px` without `image_size`; a target that is not a finite point;
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
            seams_position: (1, 1),
            boundary_position: (1, 1),
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
        let scan = positions(text);
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
            seams_position: scan.seams.unwrap_or((1, 1)),
            boundary_position: scan.boundary.unwrap_or((1, 1)),
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

    /// An error located at the `seams` value.
    pub fn seams_error(&self, message: impl Into<String>) -> ConstraintFileError {
        let (line, column) = self.seams_position;
        ConstraintFileError::Invalid {
            path: self.path.clone(),
            line,
            column,
            field: "seams".into(),
            message: message.into(),
        }
    }

    /// An error located at the `boundary` value.
    pub fn boundary_error(&self, message: impl Into<String>) -> ConstraintFileError {
        let (line, column) = self.boundary_position;
        ConstraintFileError::Invalid {
            path: self.path.clone(),
            line,
            column,
            field: "boundary".into(),
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
            if !t.is_finite() {
                return Err(self.error_at(
                    i,
                    field,
                    format!("target ({}, {}) in texture coordinates is not a finite point", t.x, t.y),
                ));
            }
        }
        Ok(())
    }
}

/// Where the top-level `asset`, `constraints` (and each of its items),
/// `corners`, `region`, `seams` and `boundary` values start (1-based line and column).
#[derive(Debug, Default)]
struct Positions {
    asset: Option<(usize, usize)>,
    constraints: Option<(usize, usize)>,
    items: Vec<(usize, usize)>,
    corners: Option<(usize, usize)>,
    region: Option<(usize, usize)>,
    seams: Option<(usize, usize)>,
    boundary: Option<(usize, usize)>,
}

/// Locates the parts of constraint-file text the RON parser accepted.
fn positions(text: &str) -> Positions {
    let tokens = tokens(text);
    let at = |token: usize| line_column(text, tokens[token].span.start);
    let mut out = Positions::default();
    for (name, value) in top_fields(text, &tokens) {
        let here = Some(at(value.start));
        match name.as_str() {
            "asset" => out.asset = here,
            "corners" => out.corners = here,
            "region" => out.region = here,
            "seams" => out.seams = here,
            "boundary" => out.boundary = here,
            "constraints" => {
                out.constraints = here;
                if &text[tokens[value.start].span.clone()] == "[" {
                    out.items = groups_inside(&tokens, value.start)
                        .into_iter()
                        .map(|r| at(r.start))
                        .collect();
                }
            }
            _ => {}
        }
    }
    out
}
