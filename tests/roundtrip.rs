//! Real assets in and out: only the UV set may change. The JSON is compared
//! object by object, every original buffer view's bytes are compared, and the
//! UVs of every chart but the solved one must be bit-identical.

mod common;
use common::*;
use serde_json::Value;
use std::path::Path;
use uvpin::io::SourceAsset;
use uvpin::mesh::topology::Topology;
use uvpin::mesh::weld::{Chart, WeldedMesh, weld};

/// JSON and BIN chunk of a GLB file.
fn glb_parts(path: &Path) -> (Value, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    let g = uvpin::io::glb::parse(&bytes).unwrap();
    (
        serde_json::from_slice(g.json).unwrap(),
        g.bin.unwrap_or_default().to_vec(),
    )
}

/// The largest chart of `welded` that is a disk, and an interior vertex of it (welded id).
fn disk_chart_and_interior(welded: &WeldedMesh) -> (Chart, u32) {
    let sizes = welded.chart_sizes();
    let mut order: Vec<u32> = (0..welded.n_charts as u32).collect();
    order.sort_by_key(|&c| std::cmp::Reverse(sizes[c as usize].1));
    order
        .iter()
        .find_map(|&c| {
            let chart = welded.chart(c);
            let topo = Topology::build(&chart.mesh).ok()?;
            let mut on_boundary = vec![false; chart.mesh.n_vertices()];
            topo.loops
                .iter()
                .flatten()
                .for_each(|&v| on_boundary[v as usize] = true);
            let v = (0..chart.mesh.n_vertices()).find(|&v| !on_boundary[v])?;
            let w = chart.welded_ids[v];
            Some((chart, w))
        })
        .expect("a disk-like chart")
}

/// The output's JSON is the input's but for the UV attribute, the new
/// accessors and views and the buffer length.
fn assert_json_changes_only_uvs(json_in: &Value, mut json_out: Value, source: &SourceAsset, uv_set: u32) {
    let mut expected = json_in.clone();
    let n_acc = json_in["accessors"].as_array().unwrap().len();
    let n_views = json_in["bufferViews"].as_array().unwrap().len();
    let attribute = format!("TEXCOORD_{uv_set}");
    let mesh = source.mesh_index;
    for prim in &source.primitives {
        let a = json_out["meshes"][mesh]["primitives"][prim.index]["attributes"][&attribute]
            .as_u64()
            .unwrap() as usize;
        assert!(a >= n_acc, "TEXCOORD must point at a new accessor");
        expected["meshes"][mesh]["primitives"][prim.index]["attributes"][&attribute] = Value::Null;
        json_out["meshes"][mesh]["primitives"][prim.index]["attributes"][&attribute] = Value::Null;
    }
    json_out["accessors"].as_array_mut().unwrap().truncate(n_acc);
    json_out["bufferViews"].as_array_mut().unwrap().truncate(n_views);
    assert!(json_out["buffers"][0]["byteLength"].as_u64() > json_in["buffers"][0]["byteLength"].as_u64());
    json_out["buffers"][0]["byteLength"] = json_in["buffers"][0]["byteLength"].clone();
    assert_eq!(
        json_out, expected,
        "only the UV attribute, new accessors/views and the buffer length may differ"
    );
}

/// Every original buffer view (so every original accessor) keeps its bytes.
fn assert_views_keep_bytes(json_in: &Value, bin_in: &[u8], bin_out: &[u8]) {
    for (i, view) in json_in["bufferViews"].as_array().unwrap().iter().enumerate() {
        let off = view["byteOffset"].as_u64().unwrap_or(0) as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        assert_eq!(
            &bin_in[off..off + len],
            &bin_out[off..off + len],
            "buffer view {i} changed"
        );
    }
}

/// Other charts keep their UVs bit for bit; the solved chart is fold-free.
fn assert_uvs(source: &SourceAsset, written: &SourceAsset, welded: &WeldedMesh, chart: &Chart) {
    let mut changed = 0;
    for (p, (before, after)) in source.primitives.iter().zip(&written.primitives).enumerate() {
        assert_eq!(before.positions, after.positions);
        assert_eq!(before.indices, after.indices);
        let (old, new) = (before.uvs.as_ref(), after.uvs.as_ref().unwrap());
        for (i, &w) in welded.vertex_of[p].iter().enumerate() {
            if chart.local_of(w).is_some() {
                changed += 1;
            } else if let Some(old) = old {
                assert_eq!(
                    old[i].map(f32::to_bits),
                    new[i].map(f32::to_bits),
                    "vertex {i} of primitive {p} is outside the solved chart"
                );
            }
        }
    }
    assert!(changed > 0);
    let local_uvs: Vec<[f32; 2]> = chart
        .welded_ids
        .iter()
        .map(|&w| {
            let (p, i) = welded
                .vertex_of
                .iter()
                .enumerate()
                .find_map(|(p, m)| m.iter().position(|&x| x == w).map(|i| (p, i)))
                .unwrap();
            written.primitives[p].uvs.as_ref().unwrap()[i]
        })
        .collect();
    assert!(uvpin::guard::count_uv_orientations(&local_uvs, &chart.mesh.triangles).is_clean());
}

/// Solves `asset` with one constraint at an interior vertex of its largest
/// disk-like chart and checks that nothing but TEXCOORD_`uv_set` changed.
fn round_trip(name: &str, uv_set: u32) {
    let asset = shared_mesh(name);
    let tmp = TempDir::new(&format!("rt-{name}"));
    let source = uvpin::io::load_asset(&asset, None, uv_set, &Default::default()).unwrap();
    let welded = weld(&source.primitives);
    let (chart, interior) = disk_chart_and_interior(&welded);
    let (prim_pos, gltf_vertex) = welded
        .vertex_of
        .iter()
        .enumerate()
        .find_map(|(p, map)| map.iter().position(|&w| w == interior).map(|i| (p, i as u32)))
        .unwrap();
    let ron = tmp.path("c.uvpin.ron");
    std::fs::write(
        &ron,
        format!(
            "(asset: {:?}, uv_set: {uv_set}, primitive: {}, constraints: [(vertex: {gltf_vertex}, uv: (0.5, 0.5))])",
            asset.display().to_string(),
            source.primitives[prim_pos].index
        ),
    )
    .unwrap();
    let out = tmp.path(name);
    let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(matches!(o.status.code(), Some(0 | 2)), "{}", stderr(&o));
    let (json_in, bin_in) = glb_parts(&asset);
    let (json_out, bin_out) = glb_parts(&out);
    assert_json_changes_only_uvs(&json_in, json_out, &source, uv_set);
    assert_views_keep_bytes(&json_in, &bin_in, &bin_out);
    let written = uvpin::io::load_asset(&out, None, uv_set, &Default::default()).unwrap();
    assert_uvs(&source, &written, &welded, &chart);
}

fn duck_round_trip_changes_only_the_uv_set() {
    round_trip("Duck.glb", 0);
}

fn damaged_helmet_round_trip_changes_only_the_uv_set() {
    round_trip("DamagedHelmet.glb", 0);
}

fn a_new_uv_set_can_be_added_beside_the_existing_one() {
    let asset = shared_mesh("Duck.glb");
    let tmp = TempDir::new("uvset1");
    // TEXCOORD_1 does not exist: charts are welded by position only.
    let ron = tmp.path("c.uvpin.ron");
    std::fs::write(
        &ron,
        format!("(asset: {:?}, uv_set: 1, constraints: [])", asset.display().to_string()),
    )
    .unwrap();
    let out = tmp.path("duck1.glb");
    let (o, r) = solve_json(&ron, &out);
    // The Duck welded by position alone is closed (no boundary): a named error, nothing written.
    if o.status.code() == Some(1) {
        assert!(
            stderr(&o).contains("closed") || stderr(&o).contains("not a disk"),
            "{}",
            stderr(&o)
        );
        assert!(!out.exists());
    } else {
        assert_eq!(r["status"], "reached", "{}", stderr(&o));
        let (json, _) = glb_parts(&out);
        assert!(json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"].is_u64());
        assert!(json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"].is_u64());
    }
}

fn main() -> std::process::ExitCode {
    run_cases(&[
        (
            "duck_round_trip_changes_only_the_uv_set",
            &[Needs::SharedMeshes],
            duck_round_trip_changes_only_the_uv_set,
        ),
        (
            "damaged_helmet_round_trip_changes_only_the_uv_set",
            &[Needs::SharedMeshes],
            damaged_helmet_round_trip_changes_only_the_uv_set,
        ),
        (
            "a_new_uv_set_can_be_added_beside_the_existing_one",
            &[Needs::SharedMeshes],
            a_new_uv_set_can_be_added_beside_the_existing_one,
        ),
    ])
}
