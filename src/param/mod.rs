//! Step 1 of the paper (§III): the outer boundary onto the unit square and the
//! force-density ("bar-net") solve for everything else (Eq. 1–2).
//!
//! Layout coordinates: internally every layout is in `(x, y)` with `y` up,
//! where a triangle that keeps its orientation has positive signed area.
//! glTF texture coordinates are `(u, v) = (x, 1 − y)` (v down, (0,0) = image
//! top-left), see [`xy_to_uv`].

pub mod bar_net;
pub mod boundary;
pub mod region;

use glam::DVec2;

/// Layout `(x, y)` (y up) → glTF texture coordinates `(u, v)` (v down).
pub fn xy_to_uv(p: DVec2) -> DVec2 {
    DVec2::new(p.x, 1.0 - p.y)
}

/// glTF texture coordinates `(u, v)` → layout `(x, y)`.
pub fn uv_to_xy(uv: DVec2) -> DVec2 {
    DVec2::new(uv.x, 1.0 - uv.y)
}
