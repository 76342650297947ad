//! The constraint file's schema: what may be written in a `*.uvpin.ron`.

use crate::io::MeshSelector;
use crate::options::SolverOptions;
use crate::param::region::Region;
use crate::pins::{BoundaryChoice, SeamsChoice};
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

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
    /// The UV set written, TEXCOORD_<uv_set> (default 0). Left out, an
    /// atlas already in set 0 is kept only where the targets allow it
    /// ([`AtlasKeeping`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uv_set: Option<u32>,
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
    /// Where a chart that must be opened to a disk (closed, or with
    /// handles) is cut: `Auto` (default: away from the landmarks, behind
    /// them, short, along creases) or `Edges([[a, b, c, …], …])`, vertex
    /// paths along mesh edges (ids of the file's `primitive`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seams: Option<SeamsChoice>,
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

/// What becomes of an atlas already in the UV set written, when the chart
/// holding the landmarks is laid out again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AtlasKeeping {
    /// Every other chart keeps its UVs (the file names the set, or a
    /// library call passes the atlas): a target on another chart's island
    /// cannot be reached.
    Always,
    /// Kept unless a target lies on another chart's island, which proves
    /// that no layout keeping it reaches the targets: then the whole mesh
    /// is laid out afresh in the set (the file names no `uv_set`).
    WhereTargetsAllow,
}

impl ConstraintFile {
    /// The UV set written (0 when the file names none).
    pub fn uv_set(&self) -> u32 {
        self.uv_set.unwrap_or(0)
    }

    /// What becomes of an atlas in the set written ([`AtlasKeeping`]).
    pub fn atlas(&self) -> AtlasKeeping {
        match self.uv_set {
            Some(_) => AtlasKeeping::Always,
            None => AtlasKeeping::WhereTargetsAllow,
        }
    }
}
