//! `uvpin inspect`: what writing a constraint file needs to know about an
//! asset. Its meshes, primitives and charts with their counts; the bounding
//! box and which way is up; each chart's outer boundary loop as glTF vertex
//! ids in order (for `corners`); the vertices nearest a point.

use crate::io::MeshSelector;
use crate::io::{self, AssetError, InputRules, SourceAsset};
use crate::mesh::nearest::{self, Bounds, Nearest, UpAxis};
use crate::mesh::topology::Topology;
use crate::mesh::weld::{WeldedMesh, weld};
use glam::DVec3;
use serde::Serialize;
use std::path::Path;

/// Nearest vertices listed for `--near`.
pub const NEAREST_LISTED: usize = 5;

/// One mesh of the file.
#[derive(Debug, Clone, Serialize)]
pub struct MeshInfo {
    pub index: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// TRIANGLES primitives, vertices and triangles; or why it cannot be read.
    pub primitives: usize,
    pub vertices: usize,
    pub triangles: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// A primitive of the inspected mesh.
#[derive(Debug, Clone, Serialize)]
pub struct PrimitiveInfo {
    pub index: usize,
    pub vertices: usize,
    pub triangles: usize,
    /// Whether it has the inspected UV set.
    pub has_uvs: bool,
}

/// A chart: a connected piece after welding equal positions (and UVs).
#[derive(Debug, Clone, Serialize)]
pub struct ChartInfo {
    pub id: u32,
    pub vertices: usize,
    pub triangles: usize,
    /// Boundary loops (the outer one and the holes); `None` when the chart
    /// is not a manifold disk (then `problem` says why).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub boundary_loops: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub problem: Option<String>,
    /// The outer loop in the faces' winding: (primitive, vertex) glTF ids.
    /// Corners must follow this order: top_left, bottom_left, bottom_right,
    /// top_right.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outer_loop: Option<Vec<(usize, u32)>>,
}

/// The vertices nearest a point.
#[derive(Debug, Clone, Serialize)]
pub struct NearQuery {
    pub point: DVec3,
    /// How far the point is from the surface.
    pub surface_distance: f64,
    pub nearest: Vec<Nearest>,
    /// Set when a `near:` constraint at this point would be refused.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub too_far: Option<String>,
}

/// Everything `uvpin inspect` prints.
#[derive(Debug, Clone, Serialize)]
pub struct Inspection {
    pub asset: String,
    pub meshes: Vec<MeshInfo>,
    /// The mesh the rest describes.
    pub mesh: usize,
    pub uv_set: u32,
    pub primitives: Vec<PrimitiveInfo>,
    pub charts: Vec<ChartInfo>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounds: Option<Bounds>,
    pub up_hint: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub near: Option<NearQuery>,
}

/// What to inspect.
#[derive(Debug, Clone, Default)]
pub struct InspectRequest {
    pub mesh: Option<MeshSelector>,
    pub uv_set: u32,
    pub near: Option<DVec3>,
    /// List each chart's outer loop.
    pub boundary: bool,
}

/// Inspects the asset at `path`.
///
/// # Errors
/// The asset cannot be read, or the selected mesh does not exist.
pub fn inspect(path: &Path, request: &InspectRequest, rules: &InputRules) -> Result<Inspection, AssetError> {
    let asset = io::load_asset(path, request.mesh.as_ref(), request.uv_set, rules)?;
    let meshes = (0..asset.n_meshes).map(|i| mesh_info(path, &asset, i, rules)).collect();
    let welded = weld(&asset.primitives);
    let bounds = nearest::bounds(&asset.primitives);
    let near = request.near.map(|p| NearQuery {
        point: p,
        surface_distance: nearest::surface_distance(&asset.primitives, None, p),
        nearest: nearest::nearest_vertices(&asset.primitives, None, p, NEAREST_LISTED),
        too_far: nearest::too_far(&asset.primitives, None, p, nearest::FarReader::Inspect),
    });
    Ok(Inspection {
        asset: path.display().to_string(),
        meshes,
        mesh: asset.mesh_index,
        uv_set: asset.uv_set,
        primitives: asset
            .primitives
            .iter()
            .map(|p| PrimitiveInfo {
                index: p.index,
                vertices: p.positions.len(),
                triangles: p.indices.len() / 3,
                has_uvs: p.uvs.is_some(),
            })
            .collect(),
        charts: charts(&asset, &welded, request.boundary),
        up_hint: up_hint(bounds),
        bounds,
        near,
    })
}

/// Mesh `index` of the file (the inspected one is already loaded).
fn mesh_info(path: &Path, loaded: &SourceAsset, index: usize, rules: &InputRules) -> MeshInfo {
    let other;
    let asset = if index == loaded.mesh_index {
        Ok(loaded)
    } else {
        other = io::load_asset(path, Some(&MeshSelector::Index(index)), loaded.uv_set, rules);
        other.as_ref().map_err(ToString::to_string)
    };
    match asset {
        Ok(a) => MeshInfo {
            index,
            name: a.mesh_name.clone(),
            primitives: a.primitives.len(),
            vertices: a.primitives.iter().map(|p| p.positions.len()).sum(),
            triangles: a.primitives.iter().map(|p| p.indices.len() / 3).sum(),
            error: None,
        },
        Err(e) => MeshInfo {
            index,
            name: None,
            primitives: 0,
            vertices: 0,
            triangles: 0,
            error: Some(e),
        },
    }
}

/// The charts, largest first, with their loops.
fn charts(asset: &SourceAsset, welded: &WeldedMesh, with_loops: bool) -> Vec<ChartInfo> {
    // A welded vertex's first glTF (primitive, vertex).
    let mut gltf_id = vec![(0usize, 0u32); welded.mesh.n_vertices()];
    for (p, map) in welded.vertex_of.iter().enumerate().rev() {
        for (v, &w) in map.iter().enumerate().rev() {
            gltf_id[w as usize] = (asset.primitives[p].index, v as u32);
        }
    }
    let sizes = welded.chart_sizes();
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&c| (std::cmp::Reverse(sizes[c].1), c));
    let order: Vec<u32> = order.into_iter().map(|c| c as u32).collect();
    welded
        .charts(&order)
        .into_iter()
        .map(|chart| {
            let c = chart.id as usize;
            let topology = Topology::build(&chart.mesh);
            let outer_loop = topology.as_ref().ok().filter(|_| with_loops).map(|t| {
                t.outer_loop()
                    .iter()
                    .map(|&l| gltf_id[chart.welded_ids[l as usize] as usize])
                    .collect()
            });
            ChartInfo {
                id: c as u32,
                vertices: sizes[c].0,
                triangles: sizes[c].1,
                boundary_loops: topology.as_ref().ok().map(|t| t.loops.len()),
                problem: topology.as_ref().err().map(ToString::to_string),
                outer_loop,
            }
        })
        .collect()
}

/// Which way the mesh stands: glTF is Y-up.
fn up_hint(bounds: Option<Bounds>) -> String {
    let Some(b) = bounds else {
        return "no triangles".into();
    };
    let s = b.size();
    if b.up_axis() == UpAxis::Z {
        "tallest along Z: it may have been exported Z-up (glTF is Y-up; Blender shows glTF's (x, y, z) as (x, -z, y))"
            .into()
    } else if s.y >= s.x.max(s.z) {
        "tallest along Y: upright in glTF's Y-up (Blender shows glTF's (x, y, z) as (x, -z, y))".into()
    } else {
        "glTF is Y-up (Blender shows glTF's (x, y, z) as (x, -z, y))".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sample_face_is_one_disk_with_holes_and_its_loop_is_in_order() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/face.glb");
        let request = InspectRequest {
            boundary: true,
            near: Some(DVec3::new(0.0, 0.0, 0.0)),
            ..Default::default()
        };
        let i = inspect(&path, &request, &InputRules::default()).unwrap();
        assert_eq!(i.meshes.len(), 1);
        assert_eq!(i.charts.len(), 1);
        let chart = &i.charts[0];
        assert_eq!(chart.boundary_loops, Some(4));
        let outer = chart.outer_loop.as_ref().unwrap();
        // The sample's corners (assets/face.uvpin.ron) follow each other in this order.
        let at = |v: u32| outer.iter().position(|&(_, w)| w == v).unwrap();
        let (a, b, c, d) = (at(1711), at(168), at(199), at(1742));
        let n = outer.len();
        let turn = |x: usize, y: usize| (y + n - x) % n;
        assert!(turn(a, b) < turn(a, c) && turn(a, c) < turn(a, d), "{a} {b} {c} {d}");
        let near = i.near.unwrap();
        assert_eq!(near.nearest.len(), NEAREST_LISTED);
        assert!(near.nearest.windows(2).all(|w| w[0].distance <= w[1].distance));
    }
}
