//! The Khronos glTF validator (an independent reader) on uvpin's outputs:
//! the sample, real assets (Duck, DamagedHelmet), and .gltf + .bin output.
//! Needs `node` and `gltf-validator` (the README's test command installs it
//! into `.tools/`): ignored when absent outside CI, a failure in CI.

mod common;
use common::*;
use std::path::{Path, PathBuf};

fn validate(files: &[&Path]) -> Vec<serde_json::Value> {
    khronos_validate(files)
}

fn solve(ron: &Path, out: &Path) {
    let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", out.to_str().unwrap(), "--quiet"]);
    assert!(matches!(o.status.code(), Some(0 | 2)), "{}", stderr(&o));
}

/// The validator's report on `outputs`: zero errors each.
fn assert_valid(outputs: &[PathBuf]) {
    let refs: Vec<&Path> = outputs.iter().map(PathBuf::as_path).collect();
    let reports = validate(&refs);
    assert_eq!(reports.len(), outputs.len());
    for r in &reports {
        assert_eq!(r["errors"], 0, "{r}");
        eprintln!(
            "{}: {} errors, {} warnings, {} infos",
            r["file"], r["errors"], r["warnings"], r["infos"]
        );
    }
}

/// The sample's output, and a .gltf output with its external .bin.
fn sample_and_gltf_outputs_pass_the_khronos_validator() {
    let tmp = TempDir::new("validator");
    let sample = tmp.path("face.glb");
    solve(&repo().join("assets/face.uvpin.ron"), &sample);
    let mesh = uvpin::testing::grid_mesh(10, 10);
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "grid");
    uvpin::io::gltf_file::write_new_document(&json, &blob, &tmp.path("grid.gltf")).unwrap();
    let ron = tmp.path("grid.uvpin.ron");
    write_constraints(&ron, Path::new("grid.gltf"), &[(45, 0.52, 0.47)], "");
    let gltf_out = tmp.path("grid-out.gltf");
    solve(&ron, &gltf_out);
    assert_valid(&[sample, gltf_out]);
}

/// A chart of `asset` solved with a vertex of a disk-like chart constrained
/// where no move is needed (the largest chart may not be a disk).
fn solve_real(asset: &Path, ron: &Path, out: &Path) {
    std::fs::write(
        ron,
        format!("(asset: {:?}, constraints: [])", asset.display().to_string()),
    )
    .unwrap();
    let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", out.to_str().unwrap(), "--quiet"]);
    if o.status.code() != Some(1) {
        return;
    }
    let asset_data = uvpin::io::load_asset(asset, None, 0, &Default::default()).unwrap();
    let welded = uvpin::mesh::weld::weld(&asset_data.primitives);
    let (p, v) = (0..welded.n_charts as u32)
        .filter(|&c| uvpin::mesh::topology::Topology::build(&welded.chart(c).mesh).is_ok())
        .find_map(|c| {
            welded.vertex_of.iter().enumerate().find_map(|(p, m)| {
                m.iter()
                    .position(|&w| welded.chart_of_vertex[w as usize] == Some(c))
                    .map(|i| (p, i as u32))
            })
        })
        .unwrap_or((0, 0));
    std::fs::write(
        ron,
        format!(
            "(asset: {:?}, primitive: {}, constraints: [(vertex: {v}, uv: (0.5, 0.5))])",
            asset.display().to_string(),
            asset_data.primitives[p].index
        ),
    )
    .unwrap();
    solve(ron, out);
}

/// Real assets with materials, textures and extensions (Duck, DamagedHelmet).
fn real_asset_outputs_pass_the_khronos_validator() {
    let tmp = TempDir::new("validator-real");
    let outputs: Vec<PathBuf> = ["Duck.glb", "DamagedHelmet.glb"]
        .iter()
        .map(|name| {
            let out = tmp.path(name);
            solve_real(&shared_mesh(name), &tmp.path(&format!("{name}.uvpin.ron")), &out);
            out
        })
        .collect();
    assert_valid(&outputs);
}

/// A mesh with a LINES primitive beside its triangles: the triangles are
/// solved, the lines kept as they were; a `uv_set` past the next free one
/// is an error that says why (glTF numbers the sets without gaps).
fn lines_beside_triangles_are_kept_and_uv_sets_stay_contiguous() {
    let tmp = TempDir::new("validator-lines");
    let mesh = uvpin::testing::grid_mesh(6, 6);
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (mut json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "grid");
    let mut lines = json["meshes"][0]["primitives"][0].clone();
    lines["mode"] = serde_json::json!(1);
    json["meshes"][0]["primitives"] = serde_json::json!([lines, json["meshes"][0]["primitives"][0].clone()]);
    let asset = tmp.path("mixed.glb");
    uvpin::io::gltf_file::write_new_document(&json, &blob, &asset).unwrap();
    let ron = tmp.path("mixed.uvpin.ron");
    write_constraints(&ron, Path::new("mixed.glb"), &[(14, 0.45, 0.55)], "    primitive: 1,\n");
    let out = tmp.path("mixed-out.glb");
    solve(&ron, &out);
    let written = uvpin::io::load_asset(&out, None, 0, &Default::default()).unwrap();
    assert_eq!(written.primitives.len(), 1, "the lines are not read as triangles");
    assert_eq!(written.primitives[0].index, 1);
    assert_valid(&[out]);
    // TEXCOORD_7 on a primitive with no sets: refused, nothing written.
    write_constraints(
        &ron,
        Path::new("mixed.glb"),
        &[(14, 0.45, 0.55)],
        "    primitive: 1,\n    uv_set: 7,\n",
    );
    let gap = tmp.path("gap.glb");
    let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", gap.to_str().unwrap(), "--quiet"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("give uv_set: 0"), "{}", stderr(&o));
    assert!(!gap.exists());
}

fn main() -> std::process::ExitCode {
    run_cases(&[
        (
            "sample_and_gltf_outputs_pass_the_khronos_validator",
            &[Needs::Validator],
            sample_and_gltf_outputs_pass_the_khronos_validator,
        ),
        (
            "lines_beside_triangles_are_kept_and_uv_sets_stay_contiguous",
            &[Needs::Validator],
            lines_beside_triangles_are_kept_and_uv_sets_stay_contiguous,
        ),
        (
            "real_asset_outputs_pass_the_khronos_validator",
            &[Needs::Validator, Needs::SharedMeshes],
            real_asset_outputs_pass_the_khronos_validator,
        ),
    ])
}
