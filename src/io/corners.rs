//! Texture coordinates per face corner, and the vertices a file needs to
//! store them: a vertex whose corners get different UVs (it lies on a seam)
//! is split, one copy per UV beyond its first. With no seam every vertex
//! keeps its index and nothing is added.

use crate::mesh::FxHashMap;

/// One primitive's new texture coordinates: one per corner (per index, in
/// index order), and for vertices that no corner names, the UV they keep.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CornerUvs {
    pub corners: Vec<[f32; 2]>,
    /// Per vertex: its UV when no corner names it (its old one, or (0, 0)).
    pub unused: Vec<[f32; 2]>,
}

/// The vertices a primitive needs for its corner UVs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VertexSplit {
    /// The UV of every vertex: the input's, then the copies'.
    pub uvs: Vec<[f32; 2]>,
    /// The vertex each corner names (an input vertex or a copy).
    pub indices: Vec<u32>,
    /// For each copy (vertex `n + k`), the input vertex it copies.
    pub copies: Vec<u32>,
}

impl VertexSplit {
    /// No vertex was split: the indices are the input's.
    pub fn is_identity(&self) -> bool {
        self.copies.is_empty()
    }
}

fn bits(uv: [f32; 2]) -> u64 {
    (uv[0].to_bits() as u64) << 32 | uv[1].to_bits() as u64
}

impl CornerUvs {
    /// Per vertex UVs as a primitive without seams stores them: each
    /// vertex's first corner's, or its `unused` one.
    pub fn split(&self, indices: &[u32]) -> VertexSplit {
        debug_assert_eq!(indices.len(), self.corners.len());
        let n = self.unused.len();
        let mut uvs = self.unused.clone();
        let mut named = vec![false; n];
        let mut copy_of: FxHashMap<(u32, u64), u32> = FxHashMap::default();
        let mut copies = Vec::new();
        let mut out = Vec::with_capacity(indices.len());
        for (&v, &uv) in indices.iter().zip(&self.corners) {
            let vi = v as usize;
            if !named[vi] {
                named[vi] = true;
                uvs[vi] = uv;
                out.push(v);
            } else if bits(uvs[vi]) == bits(uv) {
                out.push(v);
            } else {
                let id = *copy_of.entry((v, bits(uv))).or_insert_with(|| {
                    copies.push(v);
                    uvs.push(uv);
                    (n + copies.len() - 1) as u32
                });
                out.push(id);
            }
        }
        VertexSplit {
            uvs,
            indices: out,
            copies,
        }
    }

    /// Every corner of a vertex has one UV (as [`Self::split`] keeps it),
    /// per vertex; `None` if some vertex would be split.
    pub fn per_vertex(&self, indices: &[u32]) -> Option<Vec<[f32; 2]>> {
        let split = self.split(indices);
        split.is_identity().then_some(split.uvs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_uv_per_vertex_splits_nothing() {
        let c = CornerUvs {
            corners: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 1.0]],
            unused: vec![[9.0, 9.0]; 4],
        };
        let s = c.split(&[0, 1, 2, 1, 2]);
        assert!(s.is_identity());
        assert_eq!(s.uvs, vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [9.0, 9.0]]);
        assert_eq!(s.indices, vec![0, 1, 2, 1, 2]);
    }

    #[test]
    fn a_vertex_with_two_uvs_gets_one_copy_shared_by_its_corners() {
        let c = CornerUvs {
            corners: vec![[0.0, 0.0], [0.5, 0.5], [0.0, 1.0], [0.9, 0.0], [0.5, 0.5], [0.9, 0.0]],
            unused: vec![[0.0, 0.0]; 3],
        };
        let s = c.split(&[0, 1, 2, 0, 1, 0]);
        assert_eq!(s.copies, vec![0]);
        assert_eq!(s.indices, vec![0, 1, 2, 3, 1, 3]);
        assert_eq!(s.uvs[3], [0.9, 0.0]);
    }
}
