//! A constraint file's constraints resolved against an asset: each item's
//! vertex (given, or the nearest to a 3D point), its welded id and target.

use super::ConstraintFileError;
use super::LoadedConstraints;
use crate::mesh::nearest::{FarReader, nearest_vertices, too_far};
use crate::mesh::weld::{PrimitiveGeometry, WeldedMesh};
use crate::pins::{ResolvedConstraint, coincident_message, coincident_targets};

impl LoadedConstraints {
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
    pub(super) fn target_field(&self, index: usize) -> &'static str {
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
