//! Atlases as real assets have them: landmarks on several charts of one
//! atlas, a new UV set laid out beside an atlas, and an OBJ atlas (its
//! `vt`, polygons) whose other charts keep their texture coordinates bit
//! for bit. Read back by the independent reader, and the Khronos validator.

mod common;
use common::*;
use serde_json::Value;
use std::path::Path;
use uvpin::mesh::topology::Topology;
use uvpin::mesh::weld::weld;

/// Interior vertices of welded chart `chart` of `asset` (primitive 0 ids),
/// `k` of them spread out, with targets that a fold-free layout reaches:
/// their UVs drawn 3 % toward the chart's centre (the island shrunk about
/// it is such a layout, inside the old one).
fn shrunk_island_targets(asset: &uvpin::io::SourceAsset, chart: u32, k: usize) -> Vec<(u32, f64, f64)> {
    let welded = weld(&asset.primitives);
    let c = welded.chart(chart);
    let topology = Topology::build(&c.mesh).expect("a disk chart");
    let uvs = asset.primitives[0].uvs.as_ref().expect("an atlas");
    let first: Vec<u32> = c
        .welded_ids
        .iter()
        .map(|&w| welded.vertex_of[0].iter().position(|&x| x == w).unwrap() as u32)
        .collect();
    let on_boundary: Vec<bool> = (0..c.mesh.n_vertices() as u32)
        .map(|v| topology.loops.iter().flatten().any(|&b| b == v))
        .collect();
    let interior: Vec<u32> = (0..c.mesh.n_vertices() as u32)
        .filter(|&v| !on_boundary[v as usize])
        .collect();
    let centre = first.iter().fold([0.0, 0.0], |s, &v| {
        let uv = uvs[v as usize];
        [s[0] + uv[0] as f64, s[1] + uv[1] as f64]
    });
    let centre = [centre[0] / first.len() as f64, centre[1] / first.len() as f64];
    (0..k)
        .map(|i| {
            let v = first[interior[i * interior.len() / k] as usize];
            let uv = uvs[v as usize];
            let t = |x: f32, c: f64| c + 0.97 * (x as f64 - c);
            (v, t(uv[0], centre[0]), t(uv[1], centre[1]))
        })
        .collect()
}

fn assert_one_to_one_and_valid(out: &Path, uv_set: u32) {
    assert_read_back_one_to_one(out, uv_set, "the written set");
    let v = &khronos_validate(&[out])[0];
    assert_eq!(v["errors"], 0, "{v}");
}

/// The welded charts of `asset` that `corners` (per corner of primitive 0)
/// belong to, per corner.
fn chart_per_corner(asset: &uvpin::io::SourceAsset) -> Vec<u32> {
    let welded = weld(&asset.primitives);
    asset.primitives[0]
        .indices
        .iter()
        .map(|&v| welded.chart_of_vertex[welded.vertex_of[0][v as usize] as usize].unwrap())
        .collect()
}

fn landmarks_on_two_charts_of_an_atlas_are_solved_each_in_its_island() {
    let duck = shared_mesh("Duck.glb");
    let asset = uvpin::io::load_asset(&duck, None, 0, &Default::default()).unwrap();
    let sizes = weld(&asset.primitives).chart_sizes();
    let mut by_size: Vec<u32> = (0..sizes.len() as u32).collect();
    by_size.sort_by_key(|&c| std::cmp::Reverse(sizes[c as usize].1));
    let (a, b) = (by_size[0], by_size[1]);
    let mut landmarks = shrunk_island_targets(&asset, a, 6);
    landmarks.extend(shrunk_island_targets(&asset, b, 4));
    let tmp = TempDir::new("atlas-two-charts");
    let ron = tmp.path("duck.uvpin.ron");
    write_constraints(&ron, &duck, &landmarks, "");
    let out = tmp.path("duck.glb");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{}{}", stderr(&o), report["explain"]);
    assert_eq!(report["status"], "reached");
    assert!(report["max_residual"].as_f64().unwrap() < 1e-9);
    assert_eq!(
        report["charts"].as_array().map(Vec::len),
        Some(1),
        "one section for the second chart"
    );
    let solved: Vec<u64> = [
        report["counts"]["chart"].as_u64().unwrap(),
        report["charts"][0]["counts"]["chart"].as_u64().unwrap(),
    ]
    .to_vec();
    assert!(
        solved.contains(&(a as u64)) && solved.contains(&(b as u64)),
        "{solved:?}"
    );
    // The Duck's own atlas folds these two charts (each half of the body
    // mirrored onto the other) and overlaps mirrored pairs of the others:
    // the two solved charts come out fold-free and clear of the rest.
    let charts = chart_per_corner(&asset);
    let orientation = python_uv_orientation(&out, 0)[0]["orientation"]
        .as_array()
        .unwrap()
        .clone();
    for (t, o) in orientation.iter().enumerate() {
        if [a, b].contains(&charts[3 * t]) {
            assert_eq!(o, -1, "triangle {t} of a solved chart");
        }
    }
    let checked = uvpin(&["check", out.to_str().unwrap(), "--json"]);
    let checked: Value = serde_json::from_slice(&checked.stdout).unwrap();
    for c in checked["charts"].as_array().unwrap() {
        let id = c["chart"].as_u64().unwrap() as u32;
        if [a, b].contains(&id) {
            assert_eq!(
                (c["flipped"].as_u64(), c["crossings"].as_u64()),
                (Some(0), Some(0)),
                "{c}"
            );
            assert_eq!(c["overlaps"], serde_json::json!([]), "{c}");
        }
    }
    let v = &khronos_validate(&[&out])[0];
    assert_eq!(v["errors"], 0, "{v}");
    // Every other chart keeps its UVs bit for bit, at every corner.
    let (before, after) = (python_corner_values(&duck), python_corner_values(&out));
    let (uv_in, uv_out) = (
        before[0]["TEXCOORD_0"].as_array().unwrap(),
        after[0]["TEXCOORD_0"].as_array().unwrap(),
    );
    for (k, &c) in charts.iter().enumerate() {
        if c != a && c != b {
            assert_eq!(uv_in[k], uv_out[k], "corner {k} of chart {c}");
        }
    }
}

fn a_new_uv_set_beside_an_atlas_lays_out_the_welded_mesh() {
    let duck = shared_mesh("Duck.glb");
    let asset = uvpin::io::load_asset(&duck, None, 1, &Default::default()).unwrap();
    // The duck welded by position alone: a closed surface. Landmarks on
    // its side, as a photo from the left places them.
    let welded = weld(&asset.primitives);
    let landmarks: Vec<(u32, f64, f64)> = [(0.3, 0.4), (0.6, 0.35), (0.45, 0.6), (0.7, 0.65)]
        .iter()
        .enumerate()
        .map(|(i, &(u, v))| {
            let p = &asset.primitives[0].positions;
            // Vertices spread along the body's length, on its +z side.
            let x = -40.0 + 30.0 * i as f32;
            let v_id = (0..p.len())
                .filter(|&j| p[j][2] > 20.0)
                .min_by(|&m, &n| (p[m][0] - x).abs().total_cmp(&(p[n][0] - x).abs()))
                .unwrap();
            let _ = &welded;
            (v_id as u32, u, v)
        })
        .collect();
    let tmp = TempDir::new("atlas-new-set");
    let ron = tmp.path("duck.uvpin.ron");
    write_constraints(&ron, &duck, &landmarks, "    uv_set: 1,\n");
    let out = tmp.path("duck.glb");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{}{}", stderr(&o), report["explain"]);
    assert_eq!(report["status"], "reached");
    assert_one_to_one_and_valid(&out, 1);
    let (before, after) = (python_corner_values(&duck), python_corner_values(&out));
    for (attribute, values) in before[0].as_object().unwrap() {
        assert_eq!(&after[0][attribute], values, "{attribute} per corner, set 0 untouched");
    }
}

/// Per face corner of an OBJ file: its `v` index and its `vt` as stored
/// (f32 bits of u and v), faces in order, with their corner counts.
fn obj_corners(path: &Path) -> Vec<Vec<(usize, [u32; 2])>> {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut n_v, mut vt, mut faces) = (0usize, Vec::<[u32; 2]>::new(), Vec::new());
    for line in text.lines() {
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => n_v += 1,
            Some("vt") => vt.push([0, 1].map(|_| parts.next().unwrap().parse::<f32>().unwrap().to_bits())),
            Some("f") => faces.push(
                parts
                    .map(|c| {
                        let mut f = c.split('/');
                        let v: usize = f.next().unwrap().parse().unwrap();
                        let t: usize = f.next().unwrap().parse().unwrap();
                        (v - 1, vt[t - 1])
                    })
                    .collect(),
            ),
            _ => {}
        }
    }
    let _ = n_v;
    faces
}

fn an_obj_atlas_keeps_its_other_charts_bit_for_bit_and_its_polygons() {
    let beast = shared_mesh("beast.obj");
    let asset = uvpin::io::load_asset(&beast, None, 0, &Default::default()).unwrap();
    // The largest chart the asset's own atlas lays out cleanly (some of its
    // charts fold or overlap others, and leave no room to move in).
    let checked = uvpin(&["check", beast.to_str().unwrap(), "--json"]);
    let checked: Value = serde_json::from_slice(&checked.stdout).unwrap();
    let clean = checked["charts"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["flipped"] == 0 && c["zero_area"] == 0 && c["overlaps"] == serde_json::json!([]))
        .max_by_key(|c| c["triangles"].as_u64())
        .expect("a clean chart");
    let chart = clean["chart"].as_u64().unwrap() as u32;
    let landmarks = shrunk_island_targets(&asset, chart, 8);
    let tmp = TempDir::new("atlas-obj");
    let ron = tmp.path("beast.uvpin.ron");
    write_constraints(&ron, &beast, &landmarks, "");
    let out = tmp.path("beast.obj");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{}{}", stderr(&o), report["explain"]);
    assert_eq!(report["status"], "reached");
    let (before, after) = (obj_corners(&beast), obj_corners(&out));
    assert_eq!(before.len(), after.len(), "the same faces");
    let (mut kept, mut moved) = (0, 0);
    for (f, (b, a)) in before.iter().zip(&after).enumerate() {
        assert_eq!(b.len(), a.len(), "face {f} keeps its corners");
        assert!(b.iter().zip(a).all(|(x, y)| x.0 == y.0), "face {f} keeps its v");
        if b == a {
            kept += 1;
        } else {
            moved += 1;
        }
    }
    assert!(moved > 0 && kept > 0, "{moved} faces moved, {kept} kept");
}

/// A new UV set from an OBJ atlas: glTF out with the OBJ's `vt` as set 0
/// (every vertex's position and `vt` as read) and the new set 1 beside it,
/// fold-free; an OBJ out is refused (it holds one set) with nothing written.
fn a_new_uv_set_beside_an_obj_atlas_is_written_as_gltf() {
    let beast = shared_mesh("beast.obj");
    let source = uvpin::io::load_asset(&beast, None, 0, &Default::default()).unwrap();
    let tmp = TempDir::new("obj-set-1");
    let ron = tmp.path("beast.uvpin.ron");
    // Targets anywhere in the new set (its layout need not resemble the
    // atlas's): reached or partial, never a fold.
    let landmarks: Vec<(u32, f64, f64)> = shrunk_island_targets(&source, 0, 4)
        .iter()
        .enumerate()
        .map(|(k, &(v, _, _))| (v, 0.3 + 0.1 * k as f64, 0.5 + 0.05 * k as f64))
        .collect();
    write_constraints(&ron, &beast, &landmarks, "    uv_set: 1,\n");
    let refused = uvpin(&[
        "solve",
        ron.to_str().unwrap(),
        "-o",
        tmp.path("out.obj").to_str().unwrap(),
    ]);
    assert_eq!(refused.status.code(), Some(1));
    assert!(stderr(&refused).contains("holds one UV set"), "{}", stderr(&refused));
    assert!(!tmp.path("out.obj").exists());
    let out = tmp.path("out.glb");
    let (o, report) = solve_json(&ron, &out);
    assert!(matches!(o.status.code(), Some(0 | 2)), "{}", stderr(&o));
    assert_eq!(report["orientation"]["flipped"], 0);
    let written = uvpin::io::load_asset(&out, None, 0, &Default::default()).unwrap();
    let (src, got) = (&source.primitives[0], &written.primitives[0]);
    assert_eq!(got.indices.len(), src.indices.len(), "the same triangles");
    let key = |p: [f32; 3], uv: [f32; 2]| (p.map(f32::to_bits), uv.map(f32::to_bits));
    let read: std::collections::HashSet<_> = src
        .positions
        .iter()
        .zip(src.uvs.as_ref().unwrap())
        .map(|(&p, &uv)| key(p, uv))
        .collect();
    let set0 = got.uvs.as_ref().expect("set 0 kept");
    for (v, (&p, &uv)) in got.positions.iter().zip(set0).enumerate() {
        assert!(
            read.contains(&key(p, uv)),
            "vertex {v}: position and set 0 as the OBJ has them"
        );
    }
    let (_, bad) = python_uvs(&out, 1);
    assert_eq!(bad, 0, "set 1 fold-free as read back");
    for r in khronos_validate(&[&out]) {
        assert_eq!(r["errors"], 0, "{r}");
    }
}

/// Two 9 × 9 grid islands, pieces of their own: A over u `a.0..a.1`, B
/// over u `b.0..b.1` (v 0.1..0.9 both, stored right side up); corner 0 of
/// B's first triangle NaN when `nan`. Written as a .glb at `path`.
fn two_islands(path: &Path, a: (f32, f32), b: (f32, f32), nan: bool) {
    let grid = uvpin::testing::grid_mesh(9, 9);
    let (mut positions, mut indices, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
    for (k, (u0, u1)) in [a, b].into_iter().enumerate() {
        let base = positions.len() as u32;
        for p in &grid.positions {
            positions.push([p.x as f32 + 2.0 * k as f32, p.y as f32, p.z as f32]);
            uvs.push([u0 + (u1 - u0) * p.x as f32, 0.9 - 0.8 * p.y as f32]);
        }
        indices.extend(grid.triangles.iter().flatten().map(|&v| v + base));
    }
    if nan {
        let first_of_b = indices[3 * grid.triangles.len()] as usize;
        uvs[first_of_b] = [f32::NAN, 0.5];
    }
    let (json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, Some(&uvs), "islands");
    uvpin::io::gltf_file::write_new_document(&json, &blob, path).expect("write glb");
}

fn a_nan_corner_hides_no_overlap_from_check_or_solve() {
    let tmp = TempDir::new("atlas-nan-island");
    // Islands overlapping, a NaN corner on the probe triangle of one: the
    // check still finds the overlap, and counts the NaN triangle.
    let overlapping = tmp.path("overlapping.glb");
    two_islands(&overlapping, (0.05, 0.5), (0.4, 0.9), true);
    let o = uvpin(&["check", overlapping.to_str().unwrap(), "--json"]);
    let checked: Value = serde_json::from_slice(&o.stdout).expect("check --json");
    assert_eq!(checked["atlas"]["injective"], false, "{checked}");
    assert!(checked["atlas"]["overlapping_pairs"].as_u64() >= Some(1), "{checked}");
    assert_eq!((checked["clean"].as_bool(), o.status.code()), (Some(false), Some(2)));
    let zero: u64 = checked["charts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["zero_area"].as_u64().unwrap())
        .sum();
    assert_eq!(zero, 2, "the NaN corner's two triangles are counted: {checked}");
    assert!(
        checked["charts"][1]["stretch_l2"].as_f64().is_some_and(f64::is_finite),
        "{checked}"
    );
    // Islands apart, the NaN in B; A's landmarks ask it to grow over B's
    // place. Whatever the solve writes keeps A off B's finite triangles.
    let apart = tmp.path("apart.glb");
    two_islands(&apart, (0.05, 0.45), (0.55, 0.95), true);
    let grid = uvpin::testing::grid_mesh(9, 9);
    let landmarks: Vec<(u32, f64, f64)> = [(20u32, 0.2, 0.3), (24, 0.5, 0.3), (56, 0.2, 0.7), (60, 0.7, 0.7)]
        .into_iter()
        .filter(|&(v, ..)| (v as usize) < grid.positions.len())
        .collect();
    let ron = tmp.path("apart.uvpin.ron");
    // `uv_set` named: the atlas is kept whatever the targets ask.
    write_constraints(&ron, &apart, &landmarks, "    uv_set: 0,\n    boundary: Free,\n");
    let out = tmp.path("out.glb");
    let (o, report) = solve_json(&ron, &out);
    eprintln!("{}: {}", report["status"], stderr(&o));
    assert!(o.status.code() != Some(101), "{}", stderr(&o));
    if !out.exists() {
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        return;
    }
    let o = uvpin(&["check", out.to_str().unwrap(), "--json"]);
    let checked: Value = serde_json::from_slice(&o.stdout).expect("check --json");
    assert_eq!(checked["atlas"]["overlapping_pairs"], 0, "{checked}\n{report}");
    assert_eq!(checked["atlas"]["crossings"], 0, "{checked}");
}

/// A's landmarks with targets that stretch A to twice its width, over B's
/// island: with `uv_set` left out, the targets prove the atlas cannot be
/// kept, so the whole mesh is laid out afresh in set 0 (reached, one-to-one,
/// and said so); with `uv_set: 0` named, the atlas is kept (B bit for bit)
/// and the report says how to reach them.
fn targets_on_another_island_lay_the_atlas_out_afresh_unless_the_set_is_named() {
    let tmp = TempDir::new("atlas-afresh");
    let islands = tmp.path("islands.glb");
    two_islands(&islands, (0.05, 0.45), (0.55, 0.95), false);
    let grid = uvpin::testing::grid_mesh(9, 9);
    let landmarks: Vec<(u32, f64, f64)> = [20u32, 24, 42, 56, 60, 61]
        .into_iter()
        .map(|v| {
            let p = grid.positions[v as usize];
            (v, 0.05 + 0.8 * p.x, 0.9 - 0.8 * p.y)
        })
        .collect();
    assert!(landmarks.iter().any(|&(_, u, _)| u > 0.6), "a target on B's island");
    let (open, named) = (tmp.path("open.uvpin.ron"), tmp.path("named.uvpin.ron"));
    write_constraints(&open, &islands, &landmarks, "");
    write_constraints(&named, &islands, &landmarks, "    uv_set: 0,\n");

    let out = tmp.path("open.glb");
    let (o, report) = solve_json(&open, &out);
    assert_eq!(o.status.code(), Some(0), "{}{}", stderr(&o), report["explain"]);
    assert!(report["max_residual"].as_f64().unwrap() < 1e-9, "{report}");
    let warned = report["warnings"].as_array().unwrap().iter().any(|w| {
        let w = w.as_str().unwrap();
        w.contains("laid out afresh") && w.contains("uv_set: 0")
    });
    assert!(
        warned,
        "the report says the atlas was laid out afresh: {}",
        report["warnings"]
    );
    let o = uvpin(&["check", out.to_str().unwrap(), "--json"]);
    let checked: Value = serde_json::from_slice(&o.stdout).expect("check --json");
    assert_eq!(checked["atlas"]["injective"], true, "{checked}");
    assert_one_to_one_and_valid(&out, 0);

    let out = tmp.path("named.glb");
    let (o, report) = solve_json(&named, &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let hint = report["hint"].as_str().unwrap_or_default();
    assert!(hint.contains("with `uv_set` left out"), "{hint}");
    let (before, after) = (python_corner_values(&islands), python_corner_values(&out));
    let (uv_in, uv_out) = (
        before[0]["TEXCOORD_0"].as_array().unwrap(),
        after[0]["TEXCOORD_0"].as_array().unwrap(),
    );
    let b_corners = 3 * grid.triangles.len();
    assert_eq!(uv_in[b_corners..], uv_out[b_corners..], "B keeps its UVs bit for bit");
}

/// Landmarks on both islands, one of B's targets over A's island, `uv_set`
/// left out: B is solved beside A as a chart of its own (its targets on a
/// landmarked chart's old island prove nothing), never by laying the whole
/// mesh out again from inside B's solve; the file is one-to-one.
fn a_second_landmarked_chart_is_never_laid_out_afresh_on_its_own() {
    let tmp = TempDir::new("atlas-second-chart");
    let islands = tmp.path("islands.glb");
    two_islands(&islands, (0.05, 0.45), (0.55, 0.95), false);
    let grid = uvpin::testing::grid_mesh(9, 9);
    let n = grid.positions.len() as u32;
    let own = |v: u32, u0: f64| {
        let p = grid.positions[(v % n) as usize];
        (v, u0 + 0.4 * p.x, 0.9 - 0.8 * p.y)
    };
    let landmarks = vec![
        own(20, 0.05),
        own(24, 0.05),
        own(60, 0.05),
        own(n + 40, 0.55),
        (n + 20, 0.3, 0.35),
    ];
    let ron = tmp.path("both.uvpin.ron");
    write_constraints(&ron, &islands, &landmarks, "");
    let out = tmp.path("both.glb");
    let (o, report) = solve_json(&ron, &out);
    assert!(matches!(o.status.code(), Some(0 | 2)), "{}", stderr(&o));
    let text = report.to_string();
    assert!(!text.contains("internal error"), "{text}");
    assert_eq!(
        report["charts"].as_array().map(Vec::len),
        Some(1),
        "B has its own section: {text}"
    );
    let o = uvpin(&["check", out.to_str().unwrap(), "--json"]);
    let checked: Value = serde_json::from_slice(&o.stdout).expect("check --json");
    assert_eq!(checked["atlas"]["injective"], true, "{checked}");
}

fn main() -> std::process::ExitCode {
    run_cases(&[
        (
            "a_nan_corner_hides_no_overlap_from_check_or_solve",
            &[],
            a_nan_corner_hides_no_overlap_from_check_or_solve,
        ),
        (
            "a_second_landmarked_chart_is_never_laid_out_afresh_on_its_own",
            &[],
            a_second_landmarked_chart_is_never_laid_out_afresh_on_its_own,
        ),
        (
            "targets_on_another_island_lay_the_atlas_out_afresh_unless_the_set_is_named",
            &[Needs::Validator],
            targets_on_another_island_lay_the_atlas_out_afresh_unless_the_set_is_named,
        ),
        (
            "landmarks_on_two_charts_of_an_atlas_are_solved_each_in_its_island",
            &[Needs::SharedMeshes, Needs::Validator],
            landmarks_on_two_charts_of_an_atlas_are_solved_each_in_its_island,
        ),
        (
            "a_new_uv_set_beside_an_atlas_lays_out_the_welded_mesh",
            &[Needs::SharedMeshes, Needs::Validator],
            a_new_uv_set_beside_an_atlas_lays_out_the_welded_mesh,
        ),
        (
            "an_obj_atlas_keeps_its_other_charts_bit_for_bit_and_its_polygons",
            &[Needs::SharedMeshes],
            an_obj_atlas_keeps_its_other_charts_bit_for_bit_and_its_polygons,
        ),
        (
            "a_new_uv_set_beside_an_obj_atlas_is_written_as_gltf",
            &[Needs::SharedMeshes, Needs::Validator],
            a_new_uv_set_beside_an_obj_atlas_is_written_as_gltf,
        ),
    ])
}
