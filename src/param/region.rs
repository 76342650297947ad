//! A rectangle of the texture: where a free chart lies.

use glam::DVec2;
use serde::{Deserialize, Serialize};

/// The smallest side of a region (texture units).
pub const MIN_REGION_SIDE: f64 = 1e-4;

/// A rectangle of the texture in glTF texture coordinates ((0, 0) top-left, v down).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Region {
    pub min: DVec2,
    pub max: DVec2,
}

impl Region {
    /// The whole texture.
    pub const TEXTURE: Region = Region {
        min: DVec2::ZERO,
        max: DVec2::ONE,
    };

    /// Why `self` is not a usable region, if it is not.
    pub fn problem(&self) -> Option<String> {
        let finite = self.min.is_finite() && self.max.is_finite();
        if !finite {
            return Some("region corners must be finite numbers".into());
        }
        let size = self.max - self.min;
        if size.x < MIN_REGION_SIDE || size.y < MIN_REGION_SIDE {
            return Some(format!(
                "region min ({}, {}) must be below max ({}, {}) by at least {MIN_REGION_SIDE} in u and v",
                self.min.x, self.min.y, self.max.x, self.max.y
            ));
        }
        None
    }

    /// Whether the texture point `uv` is inside (closed).
    pub fn contains_uv(&self, uv: DVec2) -> bool {
        uv.cmpge(self.min).all() && uv.cmple(self.max).all()
    }

    /// The rectangle in layout coordinates (x = u, y = 1 − v): (lower left, upper right).
    pub fn layout_box(&self) -> (DVec2, DVec2) {
        (
            DVec2::new(self.min.x, 1.0 - self.max.y),
            DVec2::new(self.max.x, 1.0 - self.min.y),
        )
    }

    /// The smallest region holding `self` and the texture points `uvs`.
    #[must_use]
    pub fn grown_to(mut self, uvs: impl IntoIterator<Item = DVec2>) -> Region {
        for p in uvs {
            self.min = self.min.min(p);
            self.max = self.max.max(p);
        }
        self
    }

    /// The bounding rectangle of the texture points `uvs` (`None` if empty).
    pub fn bounding(uvs: impl IntoIterator<Item = DVec2>) -> Option<Region> {
        let mut it = uvs.into_iter();
        let first = it.next()?;
        Some(Region { min: first, max: first }.grown_to(it))
    }
}
