//! Mesh data and topology: plain triangle meshes, welding of glTF vertices into
//! charts, and the topology checks (manifold edges and vertices, boundary loops,
//! disk topology) that the force-density solve of §III needs.

pub mod nearest;
pub mod polygon;
pub mod topology;
pub mod wedges;
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

/// Which of `n` vertices are among `ids`.
pub fn marked(n: usize, ids: &[u32]) -> Vec<bool> {
    let mut out = vec![false; n];
    ids.iter().for_each(|&v| out[v as usize] = true);
    out
}

/// 3D area of triangle `t` of `mesh`.
pub fn triangle_area_3d(mesh: &TriMesh, t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// A fast, non-cryptographic hasher (multiply-rotate, as in rustc's FxHash)
/// for integer keys of mesh data: welding a million vertices with the
/// default SipHash costs several times more.
#[derive(Debug, Default, Clone, Copy)]
pub struct FxHasher(u64);

impl std::hash::Hasher for FxHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.write_u64(i as u64);
    }
    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
}

/// `HashMap` with [`FxHasher`].
pub type FxHashMap<K, V> = std::collections::HashMap<K, V, std::hash::BuildHasherDefault<FxHasher>>;
