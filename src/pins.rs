//! Constraints on a mesh held in memory (the library API): vertex ids and
//! targets, checked as a constraint file's are, with errors naming the
//! constraint's index instead of a line and column.

#![warn(missing_docs)]

use crate::mesh::weld::{PrimitiveGeometry, WeldedMesh};
use crate::param::region::Region;
use glam::DVec2;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Constraints on an in-memory mesh: each `(vertex, target)` puts a vertex
/// of the mesh on a target in glTF texture coordinates ((0, 0) top-left,
/// v down), and `corners` optionally names the outer-boundary vertices that
/// go to the texture's corners (top_left, bottom_left, bottom_right,
/// top_right).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Pins {
    /// Each pinned vertex and its target (glTF texture coordinates).
    pub targets: Vec<(u32, DVec2)>,
    /// The outer-boundary vertices that go to the texture's corners.
    pub corners: Option<[u32; 4]>,
    /// The boundary layout (default as a constraint file's `boundary`).
    pub boundary: Option<BoundaryChoice>,
    /// A free boundary's region (texture coordinates).
    pub region: Option<Region>,
    /// Where a chart that must be opened is cut (default `Auto`).
    pub seams: SeamsChoice,
}

impl Pins {
    /// Pins with automatic corners.
    pub fn new(targets: &[(u32, DVec2)]) -> Self {
        Pins {
            targets: targets.to_vec(),
            ..Pins::default()
        }
    }

    /// The same pins with this boundary layout.
    #[must_use]
    pub fn with_boundary(mut self, boundary: BoundaryChoice) -> Self {
        self.boundary = Some(boundary);
        self
    }

    /// The same pins with a free boundary inside `region`.
    #[must_use]
    pub fn within(mut self, region: Region) -> Self {
        self.region = Some(region);
        self
    }

    /// The same pins with these seams.
    #[must_use]
    pub fn with_seams(mut self, seams: SeamsChoice) -> Self {
        self.seams = seams;
        self
    }

    /// The same pins with these corner vertices.
    #[must_use]
    pub fn with_corners(mut self, corners: [u32; 4]) -> Self {
        self.corners = Some(corners);
        self
    }
}

/// A mistake in [`Pins`]: which constraint (or the corners) and what is wrong.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PinError {
    /// Pin `index` (in [`Pins::targets`]) is wrong.
    #[error("constraints[{index}]: {message}")]
    Constraint {
        /// The pin's index.
        index: usize,
        /// What is wrong.
        message: String,
    },
    /// The corners are wrong.
    #[error("corners: {message}")]
    Corners {
        /// What is wrong.
        message: String,
    },
    /// The region is wrong.
    #[error("region: {message}")]
    Region {
        /// What is wrong.
        message: String,
    },
    /// The boundary cannot be laid out as asked.
    #[error("boundary: {message}")]
    Boundary {
        /// What is wrong.
        message: String,
    },
    /// The seams are wrong.
    #[error("seams: {message}")]
    Seams {
        /// What is wrong.
        message: String,
    },
}

impl Pins {
    /// The pins resolved against the mesh (one primitive) and its welding:
    /// the constraints, and the corners as welded ids. Duplicates naming the
    /// same welded vertex with the same target are merged.
    ///
    /// # Errors
    /// A vertex out of range or used by no triangle, a target outside the
    /// unit square, one vertex given two different targets, a corner out of
    /// range.
    pub fn resolve(
        &self,
        primitive: &PrimitiveGeometry,
        welded: &WeldedMesh,
    ) -> Result<(Vec<ResolvedConstraint>, Option<[u32; 4]>), PinError> {
        let n = primitive.positions.len();
        let mut out: Vec<ResolvedConstraint> = Vec::new();
        for (index, &(vertex, target)) in self.targets.iter().enumerate() {
            let fail = |message: String| PinError::Constraint { index, message };
            // A target must be a finite point (where its chart may be laid
            // out is the boundary's matter: the unit square, a region, an
            // atlas island outside it).
            if !target.is_finite() {
                return Err(fail(format!(
                    "target ({}, {}) in texture coordinates is not a finite point",
                    target.x, target.y
                )));
            }
            if vertex as usize >= n {
                return Err(fail(format!(
                    "vertex {vertex} is out of range: the mesh has vertices 0..{n}"
                )));
            }
            let w = welded.vertex_of[0][vertex as usize];
            if welded.chart_of_vertex[w as usize].is_none() {
                return Err(fail(format!("vertex {vertex} is used by no triangle")));
            }
            if let Some(prev) = out.iter().find(|r| r.welded == w) {
                if prev.target_uv == target {
                    continue;
                }
                return Err(fail(format!(
                    "vertex {vertex} is already constrained by constraints[{}] to ({}, {}); a vertex can have only one target",
                    prev.index, prev.target_uv.x, prev.target_uv.y
                )));
            }
            out.push(ResolvedConstraint {
                index,
                label: None,
                primitive: 0,
                vertex,
                welded: w,
                target_uv: target,
                snapped_distance: None,
            });
        }
        if let Some((a, b)) = coincident_targets(&out) {
            return Err(PinError::Constraint {
                index: out[b].index,
                message: coincident_message(&out[a], &out[b]),
            });
        }
        let corners = self.corners.map(|c| resolve_corners(c, welded, n)).transpose()?;
        Ok((out, corners))
    }
}

fn resolve_corners(corners: [u32; 4], welded: &WeldedMesh, n: usize) -> Result<[u32; 4], PinError> {
    let mut out = [0u32; 4];
    for (k, v) in corners.into_iter().enumerate() {
        if v as usize >= n {
            return Err(PinError::Corners {
                message: format!(
                    "{}: vertex {v} is out of range: the mesh has vertices 0..{n}",
                    crate::param::boundary::CORNER_NAMES[k]
                ),
            });
        }
        out[k] = welded.vertex_of[0][v as usize];
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle() -> (PrimitiveGeometry, WeldedMesh) {
        let prim = PrimitiveGeometry {
            index: 0,
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 5.0]],
            indices: vec![0, 1, 2],
            uvs: None,
        };
        let welded = crate::mesh::weld::weld(std::slice::from_ref(&prim));
        (prim, welded)
    }

    #[test]
    fn mistakes_name_the_constraint() {
        let (prim, welded) = triangle();
        let err = |pins: Pins| pins.resolve(&prim, &welded).unwrap_err().to_string();
        let half = DVec2::splat(0.5);
        assert_eq!(
            err(Pins::new(&[(0, half), (9, half)])),
            "constraints[1]: vertex 9 is out of range: the mesh has vertices 0..4"
        );
        assert!(err(Pins::new(&[(3, half)])).contains("used by no triangle"));
        assert!(err(Pins::new(&[(1, DVec2::NAN)])).contains("not a finite point"));
        assert!(err(Pins::new(&[(1, half), (1, DVec2::ZERO)])).starts_with("constraints[1]: vertex 1 is already"));
        assert!(err(Pins::new(&[]).with_corners([0, 1, 2, 7])).starts_with("corners: top_right: vertex 7"));
        let e = err(Pins::new(&[(0, half), (1, half + DVec2::splat(1e-7))]));
        assert!(
            e.starts_with("constraints[1]: constraints[0] (vertex 0) and constraints[1] (vertex 1)"),
            "{e}"
        );
        let merged = Pins::new(&[(1, half), (1, half)]).resolve(&prim, &welded).unwrap();
        assert_eq!(merged.0.len(), 1);
    }
}

/// The `boundary` field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BoundaryChoice {
    /// The outer loop onto the texture's square (§III.B).
    Square,
    /// The outer loop and holes move freely inside the region; the layout
    /// is globally injective.
    Free,
}

/// The `seams` field: where a chart that must be opened is cut.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum SeamsChoice {
    /// Where it must be opened (closed, or with handles), placed away from
    /// the landmarks.
    #[default]
    Auto,
    /// Along these vertex paths, each step an edge of the mesh (vertex ids
    /// of the file's `primitive`), and nowhere else.
    Edges(Vec<Vec<u32>>),
}

/// A constraint resolved against the asset.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResolvedConstraint {
    /// Index in the file's `constraints` list.
    pub index: usize,
    /// The constraint's name in the file, if it has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// The glTF primitive holding the vertex.
    pub primitive: usize,
    /// glTF vertex index in `primitive`.
    pub vertex: u32,
    /// Welded vertex id (internal).
    #[serde(skip)]
    pub welded: u32,
    /// Target in glTF texture coordinates.
    pub target_uv: DVec2,
    /// For `near` constraints: how far the chosen vertex is from the point.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snapped_distance: Option<f64>,
}

/// Two different vertices whose targets are closer than this (texture units)
/// cannot both be reached without a zero-area triangle between them (f32
/// texture coordinates cannot tell them apart either).
pub const MIN_TARGET_DISTANCE: f64 = 1e-6;

/// Two constraints (positions in `constraints`) on different vertices whose
/// targets are (nearly) the same point, if any: no one-to-one map reaches both.
pub fn coincident_targets(constraints: &[ResolvedConstraint]) -> Option<(usize, usize)> {
    let mut order: Vec<usize> = (0..constraints.len()).collect();
    order.sort_by(|&a, &b| constraints[a].target_uv.x.total_cmp(&constraints[b].target_uv.x));
    for (k, &a) in order.iter().enumerate() {
        let ta = constraints[a].target_uv;
        for &b in &order[k + 1..] {
            let tb = constraints[b].target_uv;
            if tb.x - ta.x > MIN_TARGET_DISTANCE {
                break;
            }
            if ta.distance(tb) <= MIN_TARGET_DISTANCE && constraints[a].welded != constraints[b].welded {
                return Some((a.min(b), a.max(b)));
            }
        }
    }
    None
}

/// The message for two constraints with (nearly) the same target.
pub fn coincident_message(a: &ResolvedConstraint, b: &ResolvedConstraint) -> String {
    format!(
        "constraints[{}] (vertex {}) and constraints[{}] (vertex {}) have the same target ({}, {}){}: two vertices \
         cannot land on one point without a triangle collapsing between them",
        a.index,
        a.vertex,
        b.index,
        b.vertex,
        b.target_uv.x,
        b.target_uv.y,
        if a.target_uv == b.target_uv {
            String::new()
        } else {
            format!(" to within {:.1e}", a.target_uv.distance(b.target_uv))
        }
    )
}
