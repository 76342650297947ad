//! The free boundary: the chart's outer loop and holes move freely inside a
//! rectangle of the texture (its `region`), never crossing each other or
//! another chart's triangles, so the layout is one-to-one as a whole.
//!
//! [`room`] decides exactly whether a layout is globally injective inside
//! its region and clear of the other islands; [`scaffold`] triangulates the
//! free space around the chart (Jiang, Schaefer and Panozzo 2017), whose
//! triangles join the orientation guard and carry a small energy, so the
//! Newton phases keep the boundary apart. The start layouts and the rules
//! of a free solve are the domain module's.

pub mod room;
pub mod scaffold;

use crate::param::region::Region;
use glam::DVec2;
use serde::Serialize;
use std::sync::Arc;

/// Where a free chart's region came from (for the report).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RegionSource {
    /// The constraint file's `region`.
    Given,
    /// The whole texture (`boundary: Free` without a region).
    Texture,
    /// The chart's own atlas island: its current bounding rectangle, grown
    /// to hold the targets.
    Island,
}

/// The other charts' triangles as they are stored: what a free chart must
/// not overlap. Points are kept as each output format stores them (glTF's
/// `(u, v)`, OBJ's `(u, 1 − v)`, both f32), and in layout coordinates.
#[derive(Debug, Clone, Default)]
pub struct Obstacles {
    /// glTF texture coordinates as stored.
    pub gltf: Vec<DVec2>,
    /// OBJ `vt` as uvpin writes them (`1 − v` in f32).
    pub obj: Vec<DVec2>,
    /// Layout coordinates (x = u, y = 1 − v).
    pub layout: Vec<DVec2>,
    /// Triangles with positive area in the texture (indices into the points).
    pub triangles: Vec<[u32; 3]>,
    /// The triangles' boundary edges.
    pub edges: Vec<[u32; 2]>,
    /// One point inside each connected island (an index into `triangles`).
    pub probes: Vec<u32>,
}

impl Obstacles {
    /// The obstacles made of `triangles` over the stored texture
    /// coordinates `uvs` (glTF convention, f32), keeping only triangles with
    /// area whose bounding box meets `near` (a texture rectangle). A triangle
    /// with a NaN or infinite coordinate has no place to keep clear of and is
    /// left out; the rest of its island still counts (a NaN corner once made
    /// the island's probe fail and hid the whole island).
    pub fn new(uvs: &[[f32; 2]], triangles: &[[u32; 3]], near: Region) -> Obstacles {
        let uv = |v: u32| DVec2::new(uvs[v as usize][0] as f64, uvs[v as usize][1] as f64);
        let mut compact = vec![u32::MAX; uvs.len()];
        let mut out = Obstacles::default();
        for t in triangles {
            let [a, b, c] = t.map(uv);
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                continue;
            }
            let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
            let meets = lo.cmple(near.max).all() && hi.cmpge(near.min).all();
            if !meets || crate::guard::orientation(a, b, c) == 0.0 {
                continue;
            }
            let tri = t.map(|v| {
                if compact[v as usize] == u32::MAX {
                    compact[v as usize] = out.gltf.len() as u32;
                    let [u, w] = uvs[v as usize];
                    out.gltf.push(DVec2::new(u as f64, w as f64));
                    out.obj.push(DVec2::new(u as f64, (1.0f32 - w) as f64));
                    out.layout.push(DVec2::new(u as f64, 1.0 - w as f64));
                }
                compact[v as usize]
            });
            out.triangles.push(tri);
        }
        out.edges = crate::injective::boundary_edges(&out.triangles);
        out.probes = island_probes(&out.triangles, out.gltf.len());
        out
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The triangles among these whose layout box meets `lo..hi` (layout
    /// coordinates), as obstacles of their own: a chart's scaffold needs
    /// only the islands near it (the room's check sees them all).
    pub fn near_layout(&self, lo: DVec2, hi: DVec2) -> Obstacles {
        let mut compact = vec![u32::MAX; self.layout.len()];
        let mut out = Obstacles::default();
        for t in &self.triangles {
            let p = t.map(|v| self.layout[v as usize]);
            let (a, b) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            if !(a.cmple(hi).all() && b.cmpge(lo).all()) {
                continue;
            }
            out.triangles.push(t.map(|v| {
                if compact[v as usize] == u32::MAX {
                    compact[v as usize] = out.layout.len() as u32;
                    out.gltf.push(self.gltf[v as usize]);
                    out.obj.push(self.obj[v as usize]);
                    out.layout.push(self.layout[v as usize]);
                }
                compact[v as usize]
            }));
        }
        out.edges = crate::injective::boundary_edges(&out.triangles);
        out.probes = island_probes(&out.triangles, out.gltf.len());
        out
    }
}

/// The first triangle of each connected set of triangles (sharing vertices).
fn island_probes(triangles: &[[u32; 3]], n: usize) -> Vec<u32> {
    let mut uf = crate::mesh::topology::UnionFind::new(n);
    for t in triangles {
        uf.union(t[0] as usize, t[1] as usize);
        uf.union(t[0] as usize, t[2] as usize);
    }
    let mut seen = vec![false; n];
    let mut probes = Vec::new();
    for (i, t) in triangles.iter().enumerate() {
        let root = uf.find(t[0] as usize);
        if !seen[root] {
            seen[root] = true;
            probes.push(i as u32);
        }
    }
    probes
}

/// A free chart's room: its region, where that came from, the other
/// islands, and the chart's current layout when it had one (the island).
#[derive(Debug, Clone)]
pub struct FreeSetup {
    pub region: Region,
    pub source: RegionSource,
    pub obstacles: Arc<Obstacles>,
    /// The chart's stored UVs as layout coordinates (chart-local real
    /// vertices), when it already had them: the start, if it is injective.
    pub island: Option<Vec<DVec2>>,
    /// A fold-free layout of the filled chart that meets the targets, made
    /// another way (the chart's solve on the square mapped onto the region;
    /// a coarse level's solve prolonged): the start, shrunk just enough to
    /// fit the room.
    pub given: Option<GivenStart>,
    /// The texel density a chart with fewer than two targets is held to
    /// ([`crate::domain::setup::Order::Beside`], or a photo's scale).
    pub density: Option<f64>,
}

impl FreeSetup {
    /// The whole texture with nothing else in it: the room of a chart laid
    /// out on its own.
    pub fn open_texture() -> FreeSetup {
        FreeSetup {
            region: Region::TEXTURE,
            source: RegionSource::Texture,
            obstacles: Arc::new(Obstacles::default()),
            island: None,
            density: None,
            given: None,
        }
    }

    /// This room with a start made outside the free solve: `layout`, made
    /// `kind`'s way.
    pub fn starting_from(&self, layout: Vec<DVec2>, kind: StartKind) -> FreeSetup {
        FreeSetup {
            given: Some(GivenStart {
                layout: Arc::new(layout),
                kind,
            }),
            ..self.clone()
        }
    }
}

/// A start made outside the free solve, and how.
#[derive(Debug, Clone)]
pub struct GivenStart {
    pub layout: Arc<Vec<DVec2>>,
    pub kind: StartKind,
}

/// Which layout a free chart started from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StartKind {
    /// The chart's own UVs (its atlas island), unchanged.
    Island,
    /// Least-squares conformal with the constrained vertices on their
    /// targets: one-to-one inside its room, so the targets are met.
    Through,
    /// Least-squares conformal, fitted to the targets.
    Conformal,
    /// Step 1's square layout, fitted to the targets (the conformal one folded).
    StepOne,
    /// The chart's solve on the square, mapped onto the region: it meets
    /// the targets (the free path from the other starts fell short).
    Square,
    /// A coarse level of the chart solved and prolonged (a large chart).
    Coarse,
    /// The view of a camera fitted to the targets: the part of the surface
    /// it sees facing it, as it sees it ([`crate::cut::facing`]).
    Projection,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_nan_corner_drops_its_triangle_not_its_island() {
        // A quad (two triangles) and a third triangle with a NaN corner, one island.
        let uvs = [[0.2, 0.2], [0.4, 0.2], [0.4, 0.4], [0.2, 0.4], [f32::NAN, 0.3]];
        let triangles = [[0, 1, 2], [0, 2, 3], [1, 4, 2]];
        let o = Obstacles::new(&uvs, &triangles, Region::TEXTURE);
        assert_eq!(o.triangles.len(), 2, "the finite triangles stay obstacles");
        assert!(o.gltf.iter().all(|p| p.is_finite()));
        assert_eq!(o.probes.len(), 1, "the island is still found");
    }
}
