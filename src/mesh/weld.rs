//! Welding of glTF vertices into charts.
//!
//! glTF splits vertices wherever any attribute differs (normals at creases, UVs
//! at seams). uvpin welds vertices that share their position and, when the
//! primitive already has UVs in the written set, the same UV: the connected
//! components of the welded triangles are the charts. A chart is solved or kept
//! as a whole.

use super::topology::UnionFind;
use super::{FxHashMap, TriMesh};
use glam::DVec3;

/// Geometry of one TRIANGLES primitive as read from the file.
#[derive(Debug, Clone, Default)]
pub struct PrimitiveGeometry {
    /// Primitive index inside its glTF mesh.
    pub index: usize,
    pub positions: Vec<[f32; 3]>,
    /// Triangle list indices (length divisible by 3, every index < positions.len()).
    pub indices: Vec<u32>,
    /// Existing UVs of the written set, if the primitive has that set.
    pub uvs: Option<Vec<[f32; 2]>>,
}

/// All primitives of a mesh, welded.
#[derive(Debug, Clone)]
pub struct WeldedMesh {
    /// Welded vertices and triangles of every primitive, in primitive order.
    pub mesh: TriMesh,
    /// Per primitive (same order as the input), the welded id of each glTF vertex.
    pub vertex_of: Vec<Vec<u32>>,
    /// Chart id of every welded vertex; `None` for vertices no triangle uses.
    pub chart_of_vertex: Vec<Option<u32>>,
    /// Number of charts.
    pub n_charts: usize,
}

/// A chart cut out of a [`WeldedMesh`], with chart-local vertex numbering.
/// Once opened along seams or repaired ([`Chart::opened`]), a welded vertex
/// may have several chart vertices (one per side of a seam): its first
/// keeps the chart-local id it had.
#[derive(Debug, Clone)]
pub struct Chart {
    pub id: u32,
    pub mesh: TriMesh,
    /// Chart-local vertex → welded vertex.
    pub welded_ids: Vec<u32>,
    /// Chart triangle → welded triangle (the primitives' triangles in order).
    pub triangle_ids: Vec<u32>,
    /// Welded vertex → chart-local vertex; `None` outside this chart.
    local_of: LocalIds,
}

/// Welded vertex → the first chart vertex standing for it, sorted by
/// welded id: a chart holds a share of the mesh, and a table the mesh's
/// size in every chart cost a soup of ten thousand pieces gigabytes.
#[derive(Debug, Clone, Default)]
struct LocalIds(Vec<(u32, u32)>);

impl LocalIds {
    /// Each welded id of `welded_ids` (chart-local order) at its first place.
    fn of(welded_ids: &[u32]) -> LocalIds {
        let mut pairs: Vec<(u32, u32)> = welded_ids.iter().enumerate().map(|(l, &w)| (w, l as u32)).collect();
        pairs.sort_unstable();
        pairs.dedup_by_key(|p| p.0);
        LocalIds(pairs)
    }

    fn get(&self, welded: u32) -> Option<u32> {
        self.0.binary_search_by_key(&welded, |p| p.0).ok().map(|k| self.0[k].1)
    }
}

impl Chart {
    /// Chart-local id of welded vertex `welded`, if it belongs to this chart
    /// (its first copy, if it was split).
    #[inline]
    pub fn local_of(&self, welded: u32) -> Option<u32> {
        self.local_of.get(welded)
    }

    /// This chart with its vertices split as `wedges` (made from this
    /// chart's mesh) says: the same triangles, the copies after the
    /// vertices, each copy standing for its original's welded vertex.
    pub fn opened(&self, wedges: &super::wedges::Wedges) -> Chart {
        debug_assert_eq!(wedges.mesh.triangles.len(), self.mesh.triangles.len());
        Chart {
            id: self.id,
            mesh: wedges.mesh.clone(),
            welded_ids: wedges.origin.iter().map(|&o| self.welded_ids[o as usize]).collect(),
            triangle_ids: self.triangle_ids.clone(),
            local_of: self.local_of.clone(),
        }
    }

    /// The piece of this chart made of the triangles `keep` marks, its
    /// vertices renumbered in order (those no kept triangle uses dropped);
    /// a welded vertex's local id is its first vertex in the piece.
    pub fn piece(&self, keep: &[bool]) -> Chart {
        let kept: Vec<usize> = (0..keep.len()).filter(|&k| keep[k]).collect();
        self.piece_of_triangles(&kept, &mut vec![u32::MAX; self.mesh.n_vertices()])
    }

    /// Every piece `piece_of` names (each triangle's, `0..n`), as
    /// [`Self::piece`] makes each, in one pass: a chart repaired into
    /// thousands of pieces cost a pass over it per piece.
    pub fn pieces(&self, piece_of: &[u32], n: usize) -> Vec<Chart> {
        let mut triangles: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (k, &p) in piece_of.iter().enumerate() {
            triangles[p as usize].push(k);
        }
        let mut new_id = vec![u32::MAX; self.mesh.n_vertices()];
        triangles
            .iter()
            .map(|kept| self.piece_of_triangles(kept, &mut new_id))
            .collect()
    }

    /// The piece of triangles `kept` (ascending); `new_id` is all `u32::MAX`
    /// on entry and is left so.
    fn piece_of_triangles(&self, kept: &[usize], new_id: &mut [u32]) -> Chart {
        let (mut positions, mut welded_ids, mut old) = (Vec::new(), Vec::new(), Vec::new());
        let (mut triangles, mut triangle_ids) = (Vec::with_capacity(kept.len()), Vec::with_capacity(kept.len()));
        for &k in kept {
            triangles.push(self.mesh.triangles[k].map(|v| {
                if new_id[v as usize] == u32::MAX {
                    new_id[v as usize] = positions.len() as u32;
                    positions.push(self.mesh.positions[v as usize]);
                    welded_ids.push(self.welded_ids[v as usize]);
                    old.push(v);
                }
                new_id[v as usize]
            }));
            triangle_ids.push(self.triangle_ids[k]);
        }
        old.iter().for_each(|&v| new_id[v as usize] = u32::MAX);
        let local_of = LocalIds::of(&welded_ids);
        Chart {
            id: self.id,
            mesh: TriMesh { positions, triangles },
            welded_ids,
            triangle_ids,
            local_of,
        }
    }

    /// A chart on some of this chart's vertices (`vertices[k]`: this
    /// chart's id of new vertex `k`) with triangles of its own (a coarse
    /// level of it); each new triangle stands for this chart's first.
    pub fn subset(&self, vertices: &[u32], triangles: Vec<[u32; 3]>) -> Chart {
        let welded_ids: Vec<u32> = vertices.iter().map(|&v| self.welded_ids[v as usize]).collect();
        let local_of = LocalIds::of(&welded_ids);
        Chart {
            id: self.id,
            mesh: TriMesh {
                positions: vertices.iter().map(|&v| self.mesh.positions[v as usize]).collect(),
                triangles: triangles.clone(),
            },
            welded_ids,
            triangle_ids: vec![self.triangle_ids.first().copied().unwrap_or(0); triangles.len()],
            local_of,
        }
    }

    /// This chart with only the triangles `keep` marks (same vertices).
    pub fn with_triangles(&self, keep: &[bool]) -> Chart {
        let pick = |k: &usize| keep[*k];
        Chart {
            id: self.id,
            mesh: TriMesh {
                positions: self.mesh.positions.clone(),
                triangles: (0..keep.len()).filter(pick).map(|k| self.mesh.triangles[k]).collect(),
            },
            welded_ids: self.welded_ids.clone(),
            triangle_ids: (0..keep.len()).filter(pick).map(|k| self.triangle_ids[k]).collect(),
            local_of: self.local_of.clone(),
        }
    }
}

/// Position and (optional) UV bits of a glTF vertex, packed for hashing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct WeldKey([u64; 3]);

impl std::hash::Hash for WeldKey {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        for w in self.0 {
            state.write_u64(w);
        }
    }
}

fn weld_key(p: [f32; 3], uv: Option<[f32; 2]>) -> WeldKey {
    // +0.0 and -0.0 are the same position.
    let bits = |x: f32| if x == 0.0 { 0u64 } else { x.to_bits() as u64 };
    let (uvw, flag) = match uv {
        Some([u, v]) => (bits(u) << 32 | bits(v), 1u64 << 32),
        None => (0, 0),
    };
    WeldKey([bits(p[0]) << 32 | bits(p[1]), bits(p[2]) | flag, uvw])
}

/// Welds the primitives' vertices (same position, and same UV when the
/// primitive has UVs in the written set) and labels connected components.
/// Inputs must already be validated (finite positions, indices in range).
pub fn weld(primitives: &[PrimitiveGeometry]) -> WeldedMesh {
    let n_total: usize = primitives.iter().map(|p| p.positions.len()).sum();
    let mut ids: FxHashMap<WeldKey, u32> = FxHashMap::with_capacity_and_hasher(n_total, Default::default());
    let mut positions = Vec::new();
    let mut vertex_of = Vec::with_capacity(primitives.len());
    let mut triangles = Vec::new();
    for prim in primitives {
        let mut map = Vec::with_capacity(prim.positions.len());
        for (i, p) in prim.positions.iter().enumerate() {
            let key = weld_key(*p, prim.uvs.as_ref().map(|u| u[i]));
            let id = *ids.entry(key).or_insert_with(|| {
                positions.push(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
                (positions.len() - 1) as u32
            });
            map.push(id);
        }
        for t in prim.indices.chunks_exact(3) {
            triangles.push([map[t[0] as usize], map[t[1] as usize], map[t[2] as usize]]);
        }
        vertex_of.push(map);
    }
    let mut uf = UnionFind::new(positions.len());
    for t in &triangles {
        uf.union(t[0] as usize, t[1] as usize);
        uf.union(t[1] as usize, t[2] as usize);
    }
    let mut chart_of_root: Vec<Option<u32>> = vec![None; positions.len()];
    let mut n_charts = 0u32;
    let mut chart_of_vertex = vec![None; positions.len()];
    for t in &triangles {
        let root = uf.find(t[0] as usize);
        let c = *chart_of_root[root].get_or_insert_with(|| {
            n_charts += 1;
            n_charts - 1
        });
        for &v in t {
            chart_of_vertex[v as usize] = Some(c);
        }
    }
    WeldedMesh {
        n_charts: n_charts as usize,
        mesh: TriMesh { positions, triangles },
        vertex_of,
        chart_of_vertex,
    }
}

impl WeldedMesh {
    /// Cuts chart `id` out with its own vertex numbering (welded order).
    pub fn chart(&self, id: u32) -> Chart {
        self.charts(&[id]).pop().expect("one chart asked for")
    }

    /// Charts `ids` (distinct) cut out as [`Self::chart`] does, in one pass
    /// over the mesh: a soup's thousands of pieces each cut out by a pass
    /// of its own took most of a solve.
    pub fn charts(&self, ids: &[u32]) -> Vec<Chart> {
        let mut slot = vec![u32::MAX; self.n_charts];
        for (k, &id) in ids.iter().enumerate() {
            slot[id as usize] = k as u32;
        }
        let mut out: Vec<Chart> = ids
            .iter()
            .map(|&id| Chart {
                id,
                mesh: TriMesh {
                    positions: Vec::new(),
                    triangles: Vec::new(),
                },
                welded_ids: Vec::new(),
                triangle_ids: Vec::new(),
                local_of: LocalIds::default(),
            })
            .collect();
        let mut local = vec![u32::MAX; self.chart_of_vertex.len()];
        for (v, c) in self.chart_of_vertex.iter().enumerate() {
            if let Some(chart) = c.and_then(|c| out.get_mut(slot[c as usize] as usize)) {
                local[v] = chart.welded_ids.len() as u32;
                chart.welded_ids.push(v as u32);
                chart.mesh.positions.push(self.mesh.positions[v]);
            }
        }
        for (k, t) in self.mesh.triangles.iter().enumerate() {
            if let Some(chart) =
                self.chart_of_vertex[t[0] as usize].and_then(|c| out.get_mut(slot[c as usize] as usize))
            {
                chart.mesh.triangles.push(t.map(|v| local[v as usize]));
                chart.triangle_ids.push(k as u32);
            }
        }
        for chart in &mut out {
            chart.local_of = LocalIds::of(&chart.welded_ids);
        }
        out
    }

    /// Number of triangles and vertices in each chart.
    pub fn chart_sizes(&self) -> Vec<(usize, usize)> {
        let mut sizes = vec![(0usize, 0usize); self.n_charts];
        for c in self.chart_of_vertex.iter().flatten() {
            sizes[*c as usize].0 += 1;
        }
        for t in &self.mesh.triangles {
            if let Some(c) = self.chart_of_vertex[t[0] as usize] {
                sizes[c as usize].1 += 1;
            }
        }
        sizes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(offset: f32, uv: Option<f32>) -> PrimitiveGeometry {
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
            .into_iter()
            .map(|p: [f32; 3]| [p[0] + offset, p[1], p[2]])
            .collect();
        PrimitiveGeometry {
            index: 0,
            positions,
            indices: vec![0, 1, 2, 0, 2, 3],
            uvs: uv.map(|u| vec![[u, 0.0], [u, 0.0], [u, 1.0], [u, 1.0]]),
        }
    }

    #[test]
    fn shared_positions_weld_across_primitives() {
        let w = weld(&[quad(0.0, None), quad(1.0, None)]);
        assert_eq!(w.mesh.n_vertices(), 6);
        assert_eq!(w.n_charts, 1);
    }

    #[test]
    fn different_uvs_split_charts() {
        let w = weld(&[quad(0.0, Some(0.0)), quad(1.0, Some(0.5))]);
        assert_eq!(w.mesh.n_vertices(), 8);
        assert_eq!(w.n_charts, 2);
        let c = w.chart(1);
        assert_eq!(c.mesh.n_triangles(), 2);
        assert_eq!(c.welded_ids, vec![4, 5, 6, 7]);
    }

    #[test]
    fn charts_cut_out_together_are_each_as_cut_out_alone() {
        let quads: Vec<PrimitiveGeometry> = (0..6).map(|k| quad(2.0 * k as f32, Some(0.1 * k as f32))).collect();
        let w = weld(&quads);
        assert_eq!(w.n_charts, 6);
        let ids = [4, 1, 5];
        let together = w.charts(&ids);
        for (chart, &id) in together.iter().zip(&ids) {
            let alone = w.chart(id);
            assert_eq!((chart.id, &chart.mesh.triangles), (id, &alone.mesh.triangles));
            assert_eq!(
                (&chart.welded_ids, &chart.triangle_ids),
                (&alone.welded_ids, &alone.triangle_ids)
            );
            for v in 0..w.mesh.n_vertices() as u32 {
                assert_eq!(chart.local_of(v), alone.local_of(v), "welded vertex {v}");
            }
        }
        assert!(
            together[0].local_of(together[1].welded_ids[0]).is_none(),
            "another chart's vertex"
        );
        // Pieces cut out together are each as cut out alone.
        let all = w.chart(0);
        let piece_of = [1, 0];
        let pieces = all.pieces(&piece_of, 2);
        for (p, piece) in pieces.iter().enumerate() {
            let alone = all.piece(&piece_of.map(|q| q as usize == p));
            assert_eq!(
                (&piece.mesh.triangles, &piece.welded_ids),
                (&alone.mesh.triangles, &alone.welded_ids)
            );
            assert_eq!(piece.triangle_ids, vec![p as u32 ^ 1]);
            for v in 0..w.mesh.n_vertices() as u32 {
                assert_eq!(piece.local_of(v), alone.local_of(v), "welded vertex {v}");
            }
        }
    }
}
