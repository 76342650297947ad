//! Closed meshes and meshes with handles, as real assets come: cut open
//! automatically, given landmarks the way a photo places them (an
//! orthographic front view of visible vertices), solved, and read back by
//! the independent reader: every landmark exact, no flipped or zero-area
//! triangle, no two parts of the UV set overlapping, the 3D surface and
//! every other vertex attribute (normals, colours, the other UV set,
//! joints, weights, morph targets) unchanged at every corner, Khronos
//! validator clean.

mod common;
use common::*;
use glam::{DVec3, Vec3};
use serde_json::{Value, json};
use std::path::Path;
use uvpin::mesh::TriMesh;

use uvpin::testing::{photo_landmarks, photo_landmarks_anywhere, photo_landmarks_on, photo_landmarks_unhidden};

/// Appends `data` as a new view (optionally strided) and accessor; its index.
fn push(doc: &mut Value, blob: &mut Vec<u8>, data: &[u8], accessor: Value, stride: Option<usize>) -> usize {
    while !blob.len().is_multiple_of(4) {
        blob.push(0);
    }
    let mut view = json!({ "buffer": 0, "byteOffset": blob.len(), "byteLength": data.len() });
    if let Some(s) = stride {
        view["byteStride"] = json!(s);
    }
    blob.extend_from_slice(data);
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(view);
    let mut accessor = accessor;
    accessor["bufferView"] = json!(views.len() - 1);
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(accessor);
    accessors.len() - 1
}

fn f32s(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// A skinned, morphing GLB of `mesh` with every kind of vertex attribute:
/// normals and colours interleaved in one strided view, TEXCOORD_0 as
/// normalised 16-bit integers, JOINTS_0, WEIGHTS_0, and a morph target.
fn write_rich_glb(path: &Path, mesh: &TriMesh) {
    let n = mesh.n_vertices();
    let normals = uvpin::cut::cost::vertex_normals(mesh);
    let mut doc = json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [{ "mesh": 0, "skin": 0 }, { "name": "root joint" }],
        "skins": [{ "joints": [1] }],
        "buffers": [{}], "bufferViews": [], "accessors": [],
    });
    let mut blob = Vec::new();
    let p: Vec<Vec3> = mesh.positions.iter().map(|p| p.as_vec3()).collect();
    let (lo, hi) = p.iter().fold((Vec3::MAX, Vec3::MIN), |(a, b), &q| (a.min(q), b.max(q)));
    let vec3 = |lo: Vec3, hi: Vec3| json!({ "componentType": 5126, "count": n, "type": "VEC3", "min": lo.to_array(), "max": hi.to_array() });
    let pos = push(
        &mut doc,
        &mut blob,
        &f32s(p.iter().flat_map(|q| q.to_array())),
        vec3(lo, hi),
        None,
    );
    // Normal (12 bytes) and colour (4 bytes) interleaved, 16 bytes a vertex.
    let mut inter = Vec::new();
    for (v, nv) in normals.iter().enumerate() {
        inter.extend(f32s(nv.as_vec3().to_array()));
        inter.extend([(v % 251) as u8, 128, 255 - (v % 200) as u8, 255]);
    }
    let nrm = push(
        &mut doc,
        &mut blob,
        &inter,
        json!({ "componentType": 5126, "count": n, "type": "VEC3" }),
        Some(16),
    );
    let view = doc["accessors"][nrm]["bufferView"].clone();
    doc["accessors"].as_array_mut().unwrap().push(
        json!({ "bufferView": view, "byteOffset": 12, "componentType": 5121, "normalized": true, "count": n, "type": "VEC4" }),
    );
    let col = doc["accessors"].as_array().unwrap().len() - 1;
    let uv0: Vec<u8> = (0..n)
        .flat_map(|v| [((v * 7919) % 65536) as u16, ((v * 104729) % 65536) as u16])
        .flat_map(u16::to_le_bytes)
        .collect();
    let uv = push(
        &mut doc,
        &mut blob,
        &uv0,
        json!({ "componentType": 5123, "normalized": true, "count": n, "type": "VEC2" }),
        None,
    );
    let joints = push(
        &mut doc,
        &mut blob,
        &vec![0u8; 4 * n],
        json!({ "componentType": 5121, "count": n, "type": "VEC4" }),
        None,
    );
    let weights = push(
        &mut doc,
        &mut blob,
        &f32s((0..n).flat_map(|_| [1.0, 0.0, 0.0, 0.0])),
        json!({ "componentType": 5126, "count": n, "type": "VEC4" }),
        None,
    );
    let delta: Vec<Vec3> = p.iter().map(|q| Vec3::new(0.0, 0.0, 0.05 * q.x)).collect();
    let (dlo, dhi) = delta
        .iter()
        .fold((Vec3::MAX, Vec3::MIN), |(a, b), &q| (a.min(q), b.max(q)));
    let morph = push(
        &mut doc,
        &mut blob,
        &f32s(delta.iter().flat_map(|q| q.to_array())),
        vec3(dlo, dhi),
        None,
    );
    let indices: Vec<u8> = mesh.triangles.iter().flatten().flat_map(|&i| i.to_le_bytes()).collect();
    let idx = push(
        &mut doc,
        &mut blob,
        &indices,
        json!({ "componentType": 5125, "count": 3 * mesh.n_triangles(), "type": "SCALAR" }),
        None,
    );
    doc["meshes"] = json!([{
        "primitives": [{
            "attributes": { "POSITION": pos, "NORMAL": nrm, "COLOR_0": col, "TEXCOORD_0": uv, "JOINTS_0": joints, "WEIGHTS_0": weights },
            "targets": [{ "POSITION": morph }],
            "indices": idx,
        }],
        "weights": [0.0],
    }]);
    doc["buffers"][0]["byteLength"] = json!(blob.len());
    let json_bytes = serde_json::to_vec(&doc).unwrap();
    std::fs::write(path, uvpin::io::glb::build_with(&json_bytes, Some(&blob), &[])).unwrap();
}

/// Solves `mesh` (written rich) with photo landmarks into TEXCOORD_1 and
/// checks everything the module docs promise; the report.
fn solve_closed(name: &str, mesh: &TriMesh, k: usize, span: f64) -> Value {
    let tmp = TempDir::new(&format!("closed-{name}"));
    let asset = tmp.path("in.glb");
    write_rich_glb(&asset, mesh);
    let landmarks = photo_landmarks(mesh, DVec3::Y, DVec3::Z, k, span);
    let ron = tmp.path("in.uvpin.ron");
    write_constraints(&ron, Path::new("in.glb"), &landmarks, "    uv_set: 1,\n");
    let out = tmp.path("out.glb");
    // Where it would cut, printed and drawn before any solve.
    let preview = tmp.path("seams.png");
    let shown = uvpin(&[
        "inspect",
        asset.to_str().unwrap(),
        "--seams",
        ron.to_str().unwrap(),
        "--preview",
        preview.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(shown.status.code(), Some(0), "{name}: {}", stderr(&shown));
    let shown: Value = serde_json::from_slice(&shown.stdout).unwrap();
    assert!(shown["seam"].is_object(), "{name}: {shown}");
    let png = std::fs::read(&preview).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "{name}: a picture");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
    assert_eq!(
        report["seam"]["n_edges"], shown["seam"]["n_edges"],
        "{name}: the solve cuts where inspect said"
    );
    assert_eq!(report["status"], "reached", "{name}");
    assert!(
        report["max_residual"].as_f64().unwrap() < 1e-9,
        "{name}: {}",
        report["max_residual"]
    );
    let seam = &report["seam"];
    let separated = seam["separation_edges"].as_u64().unwrap() > 0;
    assert!(
        separated || seam["vertices_split"].as_u64().unwrap() > 0,
        "{name}: {seam}"
    );
    assert_eq!(
        report["boundary_mode"], "free",
        "{name}: a cut chart is free by default"
    );
    assert_read_back_one_to_one(&out, 1, name);
    // Every corner keeps every attribute but the new UV set.
    let (before, after) = (python_corner_values(&asset), python_corner_values(&out));
    for (b, a) in before.as_array().unwrap().iter().zip(after.as_array().unwrap()) {
        for (attribute, values) in b.as_object().unwrap() {
            assert_eq!(&a[attribute], values, "{name}: {attribute} per corner");
        }
        assert!(a.get("TEXCOORD_1").is_some());
    }
    let checked = uvpin(&["check", out.to_str().unwrap(), "--uv-set", "1", "--json"]);
    assert_eq!(
        checked.status.code(),
        Some(0),
        "{name}: uvpin check: {}",
        stdout(&checked)
    );
    if validator_module().is_some() || std::env::var_os("CI").is_some() {
        let v = &khronos_validate(&[&out])[0];
        assert_eq!(v["errors"], 0, "{name}: {v}");
    }
    report
}

fn a_closed_sphere_is_cut_behind_its_landmarks_and_solved() {
    // A photo spanning 40 % of the texture: the whole sphere fits beside it.
    let report = solve_closed("sphere", &uvpin::testing::uv_sphere(24, 36), 24, 0.4);
    assert_eq!(report["seam"]["source"], "auto");
    assert_eq!(report["seam"]["handle_edges"], 0);
    assert_eq!(report["seam"]["separation_edges"], 0);
    assert!(report["rest"].is_null());
    // Spanning 70 %: laid out whole, the back is pressed into the texture's
    // corners. The chart is kept whole only if its stretch measured within
    // 1.5× its own free layout's; else the front is split off as its own
    // chart and the back packed beside it.
    let report = solve_closed("sphere-photo", &uvpin::testing::uv_sphere(24, 36), 24, 0.7);
    let plan = &report["plan"];
    let kept = &plan["tried"][plan["chosen"].as_u64().unwrap() as usize];
    assert_eq!(kept["reached"], true, "{plan}");
    let split = report["seam"]["separation_edges"].as_u64().unwrap_or(0) > 0;
    if split {
        assert_eq!(report["rest"]["charts"], 1, "{}", report["rest"]);
    } else {
        let (l2, own) = (
            kept["stretch"]["l2"].as_f64().unwrap(),
            kept["own"]["l2"].as_f64().unwrap(),
        );
        assert!(l2 <= 1.5 * own, "kept whole at {l2}, its own {own}: {plan}");
    }
}

fn a_torus_and_a_double_torus_have_their_handles_cut() {
    for (name, mesh) in [
        ("torus", uvpin::testing::torus(48, 24, 1.0, 0.4)),
        ("double-torus", uvpin::testing::holed_plate(16, 2)),
    ] {
        let report = solve_closed(name, &mesh, 16, 0.4);
        assert!(report["seam"]["handle_edges"].as_u64().unwrap() > 0, "{name}");
    }
}

/// A chain link seen from its side, a little above, shows parts of it
/// apart: its near bar, and past it the inside of its far bar's ends. A
/// photo's landmarks on them are each laid out where the photo shows them:
/// every target reached, the landmarks' chart hardly stretched (cut open
/// whole instead, it was stretched 4×), the whole UV set one-to-one.
fn a_ring_seen_through_its_hole_has_both_parts_it_shows_reached() {
    let mut mesh = uvpin::testing::torus(96, 24, 1.0, 0.35);
    for p in &mut mesh.positions {
        p.x *= 2.5;
    }
    let view = DVec3::new(0.0, 1.0, -0.2).normalize();
    let landmarks = photo_landmarks_anywhere(&mesh, view, DVec3::Z, 12, 0.7);
    let far = landmarks
        .iter()
        .filter(|(v, ..)| mesh.positions[*v as usize].dot(view) > 0.0)
        .count();
    assert!(
        (2..=10).contains(&far),
        "landmarks on both sides: {far} of 12 on the far one"
    );
    let report = solve_obj_reached("ring", &mesh, &landmarks);
    let explain = report["explain"].to_string();
    assert!(explain.contains("more part(s) holding landmarks"), "{explain}");
    let l2 = report["stretch_final"]["l2"].as_f64().unwrap();
    assert!(l2 < 1.5, "stretch L2 {l2}: {explain}");
}

/// `mesh` written as `NAME.obj` with `landmarks` (`(vertex, u, v)`), solved:
/// exit 0 and reached, the written set read back one-to-one, and `uvpin
/// check` finding every landmark on target. The report.
fn solve_obj_reached(name: &str, mesh: &TriMesh, landmarks: &[(u32, f64, f64)]) -> Value {
    let tmp = TempDir::new(&format!("closed-{name}"));
    let obj = format!("{name}.obj");
    std::fs::write(tmp.path(&obj), obj_text(mesh)).unwrap();
    let ron = tmp.path(&format!("{name}.uvpin.ron"));
    write_constraints(&ron, Path::new(&obj), landmarks, "");
    let out = tmp.path("out.glb");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{name}: {}{}", stderr(&o), report["explain"]);
    assert_eq!(report["status"], "reached", "{name}: {}", report["explain"]);
    assert_read_back_one_to_one(&out, 0, "the written set");
    let check = uvpin(&["check", out.to_str().unwrap(), "--constraints", ron.to_str().unwrap()]);
    assert_eq!(check.status.code(), Some(0), "{name}: {}", stderr(&check));
    report
}

/// A square frame as a CAD tool writes it (flat faces in long facets,
/// genus 1), photographed from above at a slant: the photo shows its top,
/// two outer walls and, through the hole, two inner walls. Its landmarks
/// (vertices no surface hides, [`photo_landmarks_unhidden`]) are reached
/// and the written set is one-to-one.
fn a_cad_frame_seen_at_a_slant_lands_on_the_photo() {
    let mesh = uvpin::testing::square_frame(0.6, 2);
    let view = DVec3::new(0.45, 0.6, -1.0).normalize();
    let landmarks = photo_landmarks_unhidden(&mesh, view, DVec3::Y, 12, 0.7);
    solve_obj_reached("frame", &mesh, &landmarks);
}

fn a_head_is_cut_at_the_back_and_its_face_lands_on_the_photo() {
    let (head, _) = uvpin::testing::blob_head(40, 60);
    let report = solve_closed("head", &head, 32, 0.7);
    assert!(
        report["seam"]["relative_length"].as_f64().unwrap() < 3.0,
        "{}",
        report["seam"]
    );
}

/// Per face of an OBJ file, read as any reader does (each corner names
/// its own `vt`): how many faces are flipped or flat in their `vt` (fan
/// triangles, v up), and how many faces there are.
fn obj_faces_flipped(path: &Path) -> (usize, usize) {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut n_v, mut vt, mut bad, mut faces) = (0usize, Vec::<[f64; 2]>::new(), 0, 0);
    let index = |s: &str, n: usize| -> usize {
        let i: i64 = s.parse().unwrap();
        if i > 0 { i as usize - 1 } else { (n as i64 + i) as usize }
    };
    for line in text.lines() {
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => n_v += 1,
            Some("vt") => vt.push([
                parts.next().unwrap().parse().unwrap(),
                parts.next().unwrap().parse().unwrap(),
            ]),
            Some("f") => {
                faces += 1;
                let uv: Vec<[f64; 2]> = parts
                    .map(|c| {
                        let mut f = c.split('/');
                        let _ = index(f.next().unwrap(), n_v);
                        vt[index(f.next().expect("a vt"), vt.len())]
                    })
                    .collect();
                let area: f64 = (1..uv.len() - 1)
                    .map(|k| {
                        let (a, b, c) = (uv[0], uv[k], uv[k + 1]);
                        (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
                    })
                    .fold(f64::MAX, f64::min);
                if area <= 0.0 {
                    bad += 1;
                }
            }
            _ => {}
        }
    }
    (bad, faces)
}

/// A shared OBJ solved from a photo (`view`, `up`, `k` landmarks spanning
/// `span`) into OBJ and GLB, both read back: exact, fold-free and, for the
/// GLB, one-to-one and Khronos-valid. The reports (OBJ's, GLB's).
fn solve_shared_obj(name: &str, view: DVec3, up: DVec3, k: usize, span: f64) -> (Value, Value) {
    solve_shared_obj_on(name, None, view, up, k, span)
}

/// As [`solve_shared_obj`]; with `largest`, the landmarks on the largest
/// piece only, and above `above` (along `up`).
fn solve_shared_obj_on(
    name: &str,
    largest: Option<f64>,
    view: DVec3,
    up: DVec3,
    k: usize,
    span: f64,
) -> (Value, Value) {
    let path = shared_mesh(name);
    let asset = uvpin::io::load_asset(&path, None, 0, &Default::default()).unwrap();
    let prim = &asset.primitives[0];
    let mesh = TriMesh {
        positions: prim.positions.iter().map(|p| Vec3::from(*p).as_dvec3()).collect(),
        triangles: prim.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    };
    let mut allowed = vec![true; mesh.n_vertices()];
    if let Some(above) = largest {
        let welded = uvpin::mesh::weld::weld(&asset.primitives);
        let sizes = welded.chart_sizes();
        let big = (0..sizes.len()).max_by_key(|&c| sizes[c].1).unwrap() as u32;
        for (v, a) in allowed.iter_mut().enumerate() {
            *a = welded.chart_of_vertex[welded.vertex_of[0][v] as usize] == Some(big)
                && mesh.positions[v].dot(up) > above;
        }
    }
    let landmarks = photo_landmarks_on(&mesh, &allowed, view, up, k, span);
    let tmp = TempDir::new(&format!("closed-{name}"));
    let ron = tmp.path("photo.uvpin.ron");
    write_constraints(&ron, &path, &landmarks, "");
    if let Ok(keep) = std::env::var("UVPIN_KEEP") {
        std::fs::copy(&ron, Path::new(&keep).join(format!("{name}.uvpin.ron"))).unwrap();
    }
    let mut reports = Vec::new();
    for out in ["out.obj", "out.glb"] {
        let out = tmp.path(out);
        let (o, report) = solve_json(&ron, &out);
        assert_eq!(o.status.code(), Some(0), "{name}: {}{}", stderr(&o), report["explain"]);
        assert_eq!(report["status"], "reached");
        eprintln!(
            "{name}: stretch {} seam {} rest {}",
            report["stretch_final"], report["seam"]["length"], report["rest"]
        );
        reports.push(report);
    }
    let (bad, faces) = obj_faces_flipped(&tmp.path("out.obj"));
    assert_eq!(bad, 0, "{name}: of {faces} faces");
    let glb = tmp.path("out.glb");
    assert_read_back_one_to_one(&glb, 0, name);
    let v = &khronos_validate(&[&glb])[0];
    assert_eq!(v["errors"], 0, "{name}: {v}");
    let glb_report = reports.pop().unwrap();
    (reports.pop().unwrap(), glb_report)
}

/// The shared closed cow (a pinch vertex where two fans meet), from above:
/// its back is a height field (from the side its near legs would cover its
/// belly, which no one-to-one layout can match).
fn the_shared_cow_is_repaired_cut_and_solved() {
    let (obj, _) = solve_shared_obj("cow.obj", DVec3::NEG_Y, DVec3::X, 24, 0.6);
    assert!(obj["warnings"].to_string().contains("pinched"), "{}", obj["warnings"]);
    assert!(obj["seam"]["n_edges"].as_u64().unwrap() > 0);
}

/// The shared ogre scan in 44 pieces, open and closed: its body (open only
/// at a small hole) is cut and solved from a photo of its face, and every
/// other piece is unwrapped and packed around it.
fn the_shared_ogre_gets_every_piece_laid_out() {
    let (_, glb) = solve_shared_obj_on("ogre.obj", Some(25.0), DVec3::NEG_Z, DVec3::Y, 24, 0.6);
    // Its 43 other pieces, and at least the body below the head (every
    // triangle laid out fold-free is checked above).
    assert!(glb["rest"]["charts"].as_u64().unwrap() >= 44, "{}", glb["rest"]);
    assert!(glb["seam"]["separation_edges"].as_u64().unwrap() > 0);
}

fn main() -> std::process::ExitCode {
    run_cases(&[
        (
            "a_closed_sphere_is_cut_behind_its_landmarks_and_solved",
            &[],
            a_closed_sphere_is_cut_behind_its_landmarks_and_solved,
        ),
        (
            "a_torus_and_a_double_torus_have_their_handles_cut",
            &[],
            a_torus_and_a_double_torus_have_their_handles_cut,
        ),
        (
            "a_ring_seen_through_its_hole_has_both_parts_it_shows_reached",
            &[],
            a_ring_seen_through_its_hole_has_both_parts_it_shows_reached,
        ),
        (
            "a_cad_frame_seen_at_a_slant_lands_on_the_photo",
            &[],
            a_cad_frame_seen_at_a_slant_lands_on_the_photo,
        ),
        (
            "a_head_is_cut_at_the_back_and_its_face_lands_on_the_photo",
            &[],
            a_head_is_cut_at_the_back_and_its_face_lands_on_the_photo,
        ),
        (
            "the_shared_cow_is_repaired_cut_and_solved",
            &[Needs::SharedMeshes, Needs::Validator],
            the_shared_cow_is_repaired_cut_and_solved,
        ),
        (
            "the_shared_ogre_gets_every_piece_laid_out",
            &[Needs::SharedMeshes, Needs::Validator],
            the_shared_ogre_gets_every_piece_laid_out,
        ),
    ])
}
