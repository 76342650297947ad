//! Mesh data and topology: plain triangle meshes, welding of glTF vertices into
//! charts, and the topology checks (manifold edges and vertices, boundary loops,
//! disk topology) that the force-density solve of §III needs.

pub mod topology;
pub mod weld;

use glam::DVec3;

/// A triangle soup with shared vertices: `positions[i]` is vertex `i`, every
/// triangle lists three vertex indices counter-clockwise seen from its front.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }
    pub fn n_triangles(&self) -> usize {
        self.triangles.len()
    }

    /// Sum of the 3D areas of all triangles.
    pub fn area(&self) -> f64 {
        self.triangles.iter().map(|t| triangle_area_3d(self, *t)).sum()
    }
}

/// 3D area of triangle `t` of `mesh`.
pub fn triangle_area_3d(mesh: &TriMesh, t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
    0.5 * (b - a).cross(c - a).length()
}
