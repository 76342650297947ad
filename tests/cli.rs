//! The binary end to end: the README's demo, exit codes, reports, and bad
//! input that must give a clear error and write nothing.

mod common;
use common::*;
use uvpin::testing::grid_mesh;

/// On a terminal (a pseudo-terminal made by `script`), `uvpin solve`
/// shows a bar with each stage, then clears it; piped, it draws nothing.
#[test]
fn solve_shows_its_stages_on_a_terminal_and_nothing_when_piped() {
    let tmp = TempDir::new("progress");
    let out = tmp.path("face.glb");
    let ron = repo().join("assets/face.uvpin.ron");
    let command = format!(
        "'{}' solve '{}' -o '{}'",
        env!("CARGO_BIN_EXE_uvpin"),
        ron.display(),
        out.display()
    );
    let o = std::process::Command::new("script")
        .args(["-qec", &command, "/dev/null"])
        .output()
        .expect("script (util-linux) runs the solve on a pseudo-terminal");
    let shown = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{shown}");
    for stage in ["loading", "step 1", "polish", "writing"] {
        assert!(shown.contains(stage), "no {stage:?} on the terminal: {shown}");
    }
    let summary = shown.rsplit("\x1b[2K").next().unwrap_or_default();
    assert!(
        summary.starts_with("reached"),
        "the bar is cleared before the summary: {summary:?}"
    );
    let piped = uvpin(&[
        "solve",
        ron.to_str().unwrap(),
        "-o",
        tmp.path("piped.glb").to_str().unwrap(),
    ]);
    assert!(piped.status.success(), "{}", stderr(&piped));
    assert!(!stderr(&piped).contains("step 1"), "{}", stderr(&piped));
}

#[test]
fn readme_demo_solves_the_sample_and_an_independent_reader_agrees() {
    let tmp = TempDir::new("demo");
    // Output folders that do not exist yet are created (the README writes to out/).
    let out = tmp.path("out/nested/face.glb");
    let report = tmp.path("out/report.json");
    let ron = repo().join("assets/face.uvpin.ron");
    let (o, r) = solve_with_report(&ron, &out, &report, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("reached"), "{}", stderr(&o));
    assert_eq!(r["status"], "reached");
    assert_eq!(r["orientation"]["flipped"], 0);
    assert_eq!(r["orientation"]["zero_area"], 0);
    assert_eq!(r["counts"]["holes"], 3);
    let constraints = r["constraints"].as_array().unwrap();
    assert_eq!(constraints.len(), 12);
    for c in constraints {
        assert!(c["residual"].as_f64().unwrap() <= 1e-9, "{c}");
    }
    for stage in [
        "load_ms",
        "topology_ms",
        "boundary_ms",
        "factor_ms",
        "solve_ms",
        "stepping_ms",
        "guard_ms",
        "export_ms",
    ] {
        assert!(r["times"][stage].as_f64().unwrap() >= 0.0, "{stage}");
    }
    // The gltf crate reads the written UVs back; every triangle keeps its orientation.
    let (doc, buffers, _) = gltf_import(&out);
    let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
    let reader = prim.reader(|b| Some(&buffers[b.index()]));
    let uvs: Vec<[f32; 2]> = reader.read_tex_coords(0).unwrap().into_f32().collect();
    let idx: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    let tris: Vec<[u32; 3]> = idx.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
    assert!(uvpin::guard::count_uv_orientations(&uvs, &tris).is_clean());
    // Constrained vertices sit exactly on their targets (f32).
    for c in constraints {
        let v = c["vertex"].as_u64().unwrap() as usize;
        let t = &c["target"];
        assert!((uvs[v][0] as f64 - t[0].as_f64().unwrap()).abs() < 1e-7);
        assert!((uvs[v][1] as f64 - t[1].as_f64().unwrap()).abs() < 1e-7);
    }
    // And so does an independent reader written in Python.
    let py = python_uv_orientation(&out, 0);
    assert_eq!(py[0]["triangles"], tris.len());
    assert_eq!(py[0]["negative"], tris.len(), "{}", py[0]["positive"]);
    // `uvpin check` agrees with the constraint file.
    let o = uvpin(&["check", out.to_str().unwrap(), "--constraints", ron.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("flipped      0"), "{}", stdout(&o));
}

/// Runs `uvpin solve RON -o OUT --report REPORT EXTRA…`; returns the process
/// output and the report it wrote.
fn solve_with_report(
    ron: &std::path::Path,
    out: &std::path::Path,
    report: &std::path::Path,
    extra: &[&str],
) -> (std::process::Output, serde_json::Value) {
    let mut args = vec![
        "solve",
        ron.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = uvpin(&args);
    let text = std::fs::read_to_string(report).unwrap_or_else(|e| panic!("no report ({e}): {}", stderr(&o)));
    (o, serde_json::from_str(&text).unwrap())
}

/// Reads a glTF file with the gltf crate's own buffer loading.
pub fn gltf_import(path: &std::path::Path) -> (gltf::Document, Vec<Vec<u8>>, ()) {
    let bytes = std::fs::read(path).unwrap();
    let g = gltf::Gltf::from_slice(&bytes).unwrap();
    let mut buffers = Vec::new();
    for b in g.document.buffers() {
        match b.source() {
            gltf::buffer::Source::Bin => buffers.push(g.blob.clone().unwrap()),
            gltf::buffer::Source::Uri(uri) => buffers.push(std::fs::read(path.parent().unwrap().join(uri)).unwrap()),
        }
    }
    (g.document, buffers, ())
}

#[test]
fn report_to_stdout_for_scripts() {
    let ron = repo().join("assets/face.uvpin.ron");
    let o = uvpin(&["solve", ron.to_str().unwrap(), "--report", "-", "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON on stdout");
    assert_eq!(r["status"], "reached");
    assert!(stderr(&o).is_empty());
}

fn grid_asset(tmp: &TempDir, n: usize) -> std::path::PathBuf {
    let mut mesh = grid_mesh(n, n);
    for p in &mut mesh.positions {
        p.z = 0.3 * (p.x * 3.0).sin() * p.y;
    }
    let path = tmp.path("grid.glb");
    write_mesh_glb(&path, &mesh);
    path
}

#[test]
fn crossing_constraints_are_reached_by_the_completion_phase() {
    // The paper's Fig. 8: two constraints asked to swap sides. The spline path
    // (straight lines) stalls; the completion phase reaches both exactly.
    let tmp = TempDir::new("crossing");
    let asset = grid_asset(&tmp, 21);
    // Grid vertex (i, j) = i + 21 j sits near (i/20, j/20) in step 1 (corners given).
    let (a, b) = (6 + 21 * 10, 14 + 21 * 10);
    let ron = tmp.path("c.uvpin.ron");
    let corners = "    corners: (top_left: 420, bottom_left: 0, bottom_right: 20, top_right: 440),\n";
    write_constraints(&ron, &asset, &[(a, 0.7, 0.5), (b, 0.3, 0.5)], corners);
    let out = tmp.path("out.glb");
    let report = tmp.path("r.json");
    let (o, r) = solve_with_report(&ron, &out, &report, &["--explain"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("spline path (Eq. 6): stalled"), "{err}");
    assert!(err.contains("snapped onto the targets"), "{err}");
    assert_eq!(r["status"], "reached");
    assert!(r["max_residual"].as_f64().unwrap() <= 1e-9);
    assert_eq!(r["orientation"]["flipped"], 0);
    assert_eq!(r["completion"]["snapped"], true);
    let o = uvpin(&["check", out.to_str().unwrap(), "--constraints", ron.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));

    // Without the completion phase the same case ends Partial: written, fold-free, exit 2.
    write_constraints(
        &ron,
        &asset,
        &[(a, 0.7, 0.5), (b, 0.3, 0.5)],
        &format!("{corners}    solver: (completion: Never),\n"),
    );
    let (o, r) = solve_with_report(&ron, &out, &report, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("unreached: constraints[0]"), "{}", stderr(&o));
    assert_eq!(r["status"], "partial");
    assert!(r["message"].as_str().unwrap().contains("stalled"));
    let o = uvpin(&["check", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

#[test]
fn mirrored_targets_end_partial_with_a_hint_and_exit_code_2() {
    // Three corners of one triangle asked to swap into mirrored order: no
    // fold-free layout can do it. The result is written, fold-free, Partial.
    let tmp = TempDir::new("impossible");
    let asset = grid_asset(&tmp, 21);
    let corners = "    corners: (top_left: 420, bottom_left: 0, bottom_right: 20, top_right: 440),\n";
    // Grid triangle (v+1, v+22, v+21) with v = 9 + 21·10, i.e. grid points
    // (10,10), (10,11), (9,11), counter-clockwise: send it to its mirror image
    // (x reflected about the triangle's centroid), which is clockwise.
    let v = 9 + 21 * 10;
    let ron = tmp.path("m.uvpin.ron");
    let cx = (0.5 + 0.5 + 0.45) / 3.0;
    write_constraints(
        &ron,
        &asset,
        &[
            (v + 1, 2.0 * cx - 0.5, 0.5),
            (v + 22, 2.0 * cx - 0.5, 0.45),
            (v + 21, 2.0 * cx - 0.45, 0.45),
        ],
        corners,
    );
    let out = tmp.path("out.glb");
    let (o, r) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(r["status"], "partial");
    assert_eq!(r["orientation"]["flipped"], 0);
    assert_eq!(r["orientation"]["zero_area"], 0);
    let hint = r["hint"].as_str().unwrap();
    assert!(
        hint.contains("cannot reach their targets") && hint.contains("constraints["),
        "{hint}"
    );
    // Proven, not guessed: the three pinned corners come out flipped.
    let proof = r["unreachable_proof"].as_str().unwrap();
    assert_eq!(
        proof,
        "the triangle of constraints[0], constraints[1] and constraints[2] would be flipped or flat"
    );
    assert!(hint.contains(proof), "{hint}");
    let o = uvpin(&["check", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

/// Runs a solve that must fail: exit 1, the message contains every `needle`,
/// and the existing output file is left exactly as it was.
fn assert_fails_writing_nothing(ron: &std::path::Path, tmp: &TempDir, needles: &[&str]) {
    let out = tmp.path("out.glb");
    std::fs::write(&out, b"previous good output").unwrap();
    let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    for n in needles {
        assert!(err.contains(n), "expected {n:?} in: {err}");
    }
    assert_eq!(std::fs::read(&out).unwrap(), b"previous good output");
    let leftovers: Vec<_> = std::fs::read_dir(&tmp.0)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("uvpin-"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn broken_ron_reports_line_and_column_and_writes_nothing() {
    let tmp = TempDir::new("badron");
    let asset = grid_asset(&tmp, 5);
    let ron = tmp.path("bad.uvpin.ron");
    std::fs::write(
        &ron,
        format!(
            "(\n  asset: {:?},\n  constraints: [\n    (vertex: 6, uv: (0.5 0.5)),\n  ],\n)\n",
            asset
        ),
    )
    .unwrap();
    assert_fails_writing_nothing(&ron, &tmp, &["bad.uvpin.ron:4:", "comma"]);
    std::fs::write(
        &ron,
        format!(
            "(\n  asset: {:?},\n  constraints: [(vertx: 6, uv: (0.5, 0.5))],\n)\n",
            asset
        ),
    )
    .unwrap();
    assert_fails_writing_nothing(&ron, &tmp, &["bad.uvpin.ron:3:18", "vertx"]);
    write_constraints(&ron, &asset, &[(99, 0.5, 0.5)], "");
    assert_fails_writing_nothing(
        &ron,
        &tmp,
        &["bad.uvpin.ron:4:9", "constraints[0].vertex", "out of range", "0..25"],
    );
    write_constraints(&ron, &asset, &[(6, 0.5, 0.5), (6, 0.4, 0.5)], "");
    assert_fails_writing_nothing(&ron, &tmp, &["constraints[1].uv", "already constrained"]);
    write_constraints(&ron, &asset, &[(6, 1.5, 0.5)], "");
    assert_fails_writing_nothing(&ron, &tmp, &["outside the unit square"]);
    // A boundary vertex (1 is on the bottom row) asked to go to the middle,
    // on the square the file asks for.
    write_constraints(&ron, &asset, &[(1, 0.5, 0.5)], "  boundary: Square,\n");
    assert_fails_writing_nothing(&ron, &tmp, &["constraints[0].uv", "outer boundary", "contradicts"]);
    // Corners in mirrored order.
    write_constraints(
        &ron,
        &asset,
        &[],
        "  corners: (top_left: 24, bottom_left: 4, bottom_right: 0, top_right: 20),\n",
    );
    assert_fails_writing_nothing(&ron, &tmp, &["corners", "mirror"]);
    // Missing asset.
    std::fs::write(&ron, "(asset: \"nope.glb\", constraints: [])").unwrap();
    assert_fails_writing_nothing(&ron, &tmp, &["bad.uvpin.ron:1:9", "nope.glb", "does not exist"]);
}

#[test]
fn closed_and_non_manifold_meshes_are_named_errors() {
    let tmp = TempDir::new("topology");
    let ron = tmp.path("t.uvpin.ron");
    // A closed octahedron.
    let octa = uvpin::testing::octahedron();
    // Given seams that leave it closed are refused by name.
    let asset = tmp.path("closed.glb");
    write_mesh_glb(&asset, &octa);
    write_constraints(&ron, &asset, &[(4, 0.5, 0.5)], "seams: Edges([[0, 2]]),");
    assert_fails_writing_nothing(&ron, &tmp, &["closed.glb", "chart 0", "closed"]);
    // A fin: three triangles on one edge.
    let mut fin = grid_mesh(4, 4);
    fin.positions.push(glam::DVec3::new(0.4, 0.4, 1.0));
    fin.triangles.push([5, 6, 16]);
    // A fin (a third triangle on an edge) is split off for the solve,
    // named in the report, and laid out apart.
    let asset = tmp.path("fin.glb");
    write_mesh_glb(&asset, &fin);
    write_constraints(&ron, &asset, &[(10, 0.5, 0.5)], "");
    let out = tmp.path("fin-out.glb");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{} {report}", stderr(&o));
    let warnings = report["warnings"].to_string();
    assert!(
        warnings.contains("edge (5, 6) of triangles [") && warnings.contains("split"),
        "{warnings}"
    );
    assert_eq!(report["rest"]["charts"], 1, "the fin laid out apart");
    // With the landmark on the fin's edge, the fin holds a copy of it: it
    // is solved for that landmark too, and the report counts every copy
    // (the fin cannot sit on the target where the grid already is).
    write_constraints(&ron, &asset, &[(5, 0.5, 0.5)], "");
    let (o, report) = solve_json(&ron, &tmp.path("fin-on-edge.glb"));
    let copies_reached = o.status.code() == Some(0) && report["constraints"][0]["reached"] == true;
    let honest = o.status.code() == Some(2) && report["status"] == "partial";
    assert!(copies_reached || honest, "{} {report}", stderr(&o));
    assert_read_back_one_to_one(&out, 0, "the written set");
}

/// `uvpin check` finds `out` fold-free and one-to-one.
fn assert_checks_clean(out: &std::path::Path) {
    let check = uvpin(&["check", out.to_str().unwrap()]);
    assert_eq!(
        check.status.code(),
        Some(0),
        "fold-free, one-to-one: {}",
        stdout(&check)
    );
}

/// The report's message and hint, and every chart's hint.
fn reasons(report: &serde_json::Value) -> Vec<&str> {
    let mut out = vec![
        report["message"].as_str().unwrap_or_default(),
        report["hint"].as_str().unwrap_or_default(),
    ];
    out.extend(
        report["charts"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|c| c["hint"].as_str()),
    );
    out
}

#[test]
fn a_landmark_short_of_its_target_on_another_piece_is_reported_where_it_was_written() {
    let tmp = TempDir::new("set-aside");
    // A grid, and apart from it a flat triangle (its corners on one line):
    // laid out with area all the same, its landmark reached.
    let mut mesh = grid_mesh(6, 6);
    let n = mesh.positions.len() as u32;
    for x in [2.0, 3.0, 4.0] {
        mesh.positions.push(glam::DVec3::new(x, 0.0, 0.0));
    }
    mesh.triangles.push([n, n + 1, n + 2]);
    let asset = tmp.path("flat.glb");
    write_mesh_glb(&asset, &mesh);
    let ron = tmp.path("flat.uvpin.ron");
    let grid_marks = [(7, 0.3, 0.3), (10, 0.7, 0.3), (25, 0.5, 0.7)];
    let out = tmp.path("flat-out.glb");
    write_constraints(
        &ron,
        &asset,
        &[grid_marks[0], grid_marks[1], grid_marks[2], (n + 1, 0.9, 0.9)],
        "",
    );
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{} {report}", stderr(&o));
    assert_checks_clean(&out);
    // Three landmarks that mirror the triangle: each is reported where it
    // was written.
    let mirrored = [(n, 0.1, 0.85), (n + 1, 0.3, 0.85), (n + 2, 0.2, 0.95)];
    let marks: Vec<(u32, f64, f64)> = grid_marks.iter().chain(&mirrored).copied().collect();
    write_constraints(&ron, &asset, &marks, "");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(2), "{} {report}", stderr(&o));
    // The reason names the mirrored triangle, not how a solve failed:
    // in the message when the piece is laid out without its landmarks,
    // else in its chart's hint.
    assert!(
        reasons(&report).iter().any(|r| r.contains("flipped or flat")),
        "{report}"
    );
    let every: Vec<&serde_json::Value> = report["constraints"]
        .as_array()
        .into_iter()
        .flatten()
        .chain(
            report["charts"]
                .as_array()
                .into_iter()
                .flatten()
                .flat_map(|c| c["constraints"].as_array().into_iter().flatten()),
        )
        .collect();
    let unreached: Vec<_> = every.iter().filter(|c| c["reached"] == false).collect();
    assert!(!unreached.is_empty(), "{report}");
    for c in unreached {
        // Its place as written, not NaN, and its residual measured from there.
        let index = c["index"].as_u64().expect("index") as usize;
        let (_, tu, tv) = marks[index];
        let at = [c["result"][0].as_f64(), c["result"][1].as_f64()];
        let [Some(u), Some(v)] = at else {
            panic!("no place reported for the landmark short of its target: {c}");
        };
        let residual = c["residual"].as_f64().expect("residual");
        let d = ((u - tu).powi(2) + (v - tv).powi(2)).sqrt();
        assert!((d - residual).abs() < 1e-6, "at ({u}, {v}), residual {residual}");
        assert!(
            residual > 0.0 && (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v),
            "{c}"
        );
    }
}

#[test]
fn non_triangle_primitives_and_missing_meshes_are_named_errors() {
    let tmp = TempDir::new("lines");
    let mesh = grid_mesh(4, 4);
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (mut json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "lines");
    json["meshes"][0]["primitives"][0]["mode"] = serde_json::json!(1);
    let asset = tmp.path("lines.glb");
    uvpin::io::gltf_file::write_new_document(&json, &blob, &asset).unwrap();
    let ron = tmp.path("l.uvpin.ron");
    write_constraints(&ron, &asset, &[(5, 0.5, 0.5)], "");
    assert_fails_writing_nothing(
        &ron,
        &tmp,
        &["lines.glb", "mesh 0 primitive 0", "LINES", "only TRIANGLES"],
    );
    write_constraints(&ron, &repo().join("assets/face.glb"), &[], "  mesh: 3,\n");
    assert_fails_writing_nothing(&ron, &tmp, &["mesh 3 does not exist", "0..1"]);
    write_constraints(&ron, &repo().join("assets/face.glb"), &[], "  mesh: \"Head\",\n");
    assert_fails_writing_nothing(&ron, &tmp, &["no mesh named \"Head\"", "face"]);
}

#[test]
fn corrupt_glb_files_are_named_errors() {
    let tmp = TempDir::new("corrupt");
    let good = std::fs::read(repo().join("assets/face.glb")).unwrap();
    let ron = tmp.path("c.uvpin.ron");
    let asset = tmp.path("broken.glb");
    write_constraints(&ron, &asset, &[(0, 0.5, 0.5)], "");
    std::fs::write(&asset, &good[..good.len() / 2]).unwrap();
    assert_fails_writing_nothing(&ron, &tmp, &["broken.glb", "corrupt GLB", "truncated"]);
    let mut bad = good.clone();
    bad[12..16].copy_from_slice(&(1u32 << 30).to_le_bytes());
    std::fs::write(&asset, &bad).unwrap();
    assert_fails_writing_nothing(&ron, &tmp, &["broken.glb", "chunk 0", "length"]);
    std::fs::write(&asset, b"not a glb at all").unwrap();
    assert_fails_writing_nothing(&ron, &tmp, &["broken.glb"]);
    let mut nan = good.clone();
    // First POSITION float of the sample (buffer view 0 starts the BIN chunk).
    let json_len = u32::from_le_bytes(nan[12..16].try_into().unwrap()) as usize;
    let at = 12 + 8 + json_len + 8;
    nan[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(&asset, &nan).unwrap();
    assert_fails_writing_nothing(&ron, &tmp, &["broken.glb", "vertex 0", "not finite"]);
}

#[test]
fn gltf_with_external_buffer_round_trips_to_gltf_and_bin() {
    let tmp = TempDir::new("gltf");
    let mesh = grid_mesh(9, 9);
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (mut json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "g");
    std::fs::create_dir_all(tmp.path("in")).unwrap();
    std::fs::write(tmp.path("in/geometry data.bin"), &blob).unwrap();
    json["buffers"][0]["uri"] = serde_json::json!("geometry%20data.bin");
    json["extras"] = serde_json::json!({"studio": "kept"});
    json["x_unknown_field"] = serde_json::json!([1, 2, 3]);
    std::fs::write(tmp.path("in/g.gltf"), serde_json::to_vec_pretty(&json).unwrap()).unwrap();
    let ron = tmp.path("in/g.uvpin.ron");
    write_constraints(&ron, std::path::Path::new("g.gltf"), &[(40, 0.5, 0.5)], "");
    std::fs::create_dir_all(tmp.path("out")).unwrap();
    let out = tmp.path("out/result.gltf");
    let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let written: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    // The UVs are in a content-named buffer beside the output, which names it.
    let bin = written["buffers"].as_array().unwrap().last().unwrap()["uri"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(bin.starts_with("result.uvpin-") && bin.ends_with(".bin"), "{bin}");
    assert!(tmp.path("out").join(&bin).is_file());
    assert_eq!(written["extras"]["studio"], "kept");
    assert_eq!(written["x_unknown_field"], serde_json::json!([1, 2, 3]));
    // The original buffer is referenced from the output's folder.
    assert_eq!(written["buffers"][0]["uri"], "../in/geometry%20data.bin");
    let py = python_uv_orientation(&out, 0);
    assert_eq!(py[0]["negative"], mesh.n_triangles());
    // .glb in → .gltf out is refused (nothing but the UVs may change).
    let ron2 = tmp.path("s.uvpin.ron");
    write_constraints(&ron2, &repo().join("assets/face.glb"), &[], "");
    let o = uvpin(&[
        "solve",
        ron2.to_str().unwrap(),
        "-o",
        tmp.path("x.gltf").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!tmp.path("x.gltf").exists());
}

#[test]
fn obj_input_writes_obj_or_glb() {
    let tmp = TempDir::new("obj");
    let mesh = grid_mesh(6, 6);
    let mut text = String::from("# a grid\n");
    for p in &mesh.positions {
        text += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in &mesh.triangles {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(tmp.path("g.obj"), text).unwrap();
    let ron = tmp.path("g.uvpin.ron");
    write_constraints(&ron, std::path::Path::new("g.obj"), &[(14, 0.45, 0.5)], "");
    for out in ["out.obj", "out.glb"] {
        let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", tmp.path(out).to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let obj = std::fs::read_to_string(tmp.path("out.obj")).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("vt ")).count(), 36);
    assert!(obj.contains("f 1/1 2/2 8/8") || obj.contains("f 1/1"), "{obj}");
    let o = uvpin(&["check", tmp.path("out.glb").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    // Quads, as modelling tools export them: solved as triangles, written back as quads.
    let mut quads = String::new();
    for j in 0..6 {
        for i in 0..6 {
            quads += &format!(
                "v {} {} {}\n",
                i as f64 / 5.0,
                j as f64 / 5.0,
                0.1 * (i * j) as f64 / 25.0
            );
        }
    }
    for j in 0..5 {
        for i in 0..5 {
            let v = 1 + i + 6 * j;
            quads += &format!("f {} {} {} {}\n", v, v + 1, v + 7, v + 6);
        }
    }
    std::fs::write(tmp.path("q.obj"), quads).unwrap();
    write_constraints(&ron, std::path::Path::new("q.obj"), &[(14, 0.45, 0.5)], "");
    let o = uvpin(&[
        "solve",
        ron.to_str().unwrap(),
        "-o",
        tmp.path("q-out.obj").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let written = std::fs::read_to_string(tmp.path("q-out.obj")).unwrap();
    let faces: Vec<&str> = written.lines().filter(|l| l.starts_with("f ")).collect();
    assert_eq!(faces.len(), 25);
    assert!(
        faces.iter().all(|f| f.split_whitespace().count() == 5),
        "every face a quad: {written}"
    );
    assert!(faces.contains(&"f 1/1 2/2 8/8 7/7"), "{written}");
}

#[test]
fn config_file_supplies_solver_defaults_unless_the_constraint_file_has_its_own() {
    let tmp = TempDir::new("config");
    let asset = grid_asset(&tmp, 21);
    let ron = tmp.path("c.uvpin.ron");
    // The crossing case stalls; with max_halvings 0 it stalls at the first fold.
    let corners = "    corners: (top_left: 420, bottom_left: 0, bottom_right: 20, top_right: 440),\n";
    write_constraints(
        &ron,
        &asset,
        &[(6 + 21 * 10, 0.7, 0.5), (14 + 21 * 10, 0.3, 0.5)],
        corners,
    );
    let config = tmp.path("uvpin.ron");
    std::fs::write(&config, "(solver: (max_halvings: 0))").unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["solve", ron.to_str().unwrap(), "--report", "-", "--quiet"];
        args.extend_from_slice(extra);
        let o = uvpin(&args);
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap_or_else(|_| panic!("{}", stderr(&o)))
    };
    let default = run(&[]);
    let configured = run(&["--config", config.to_str().unwrap()]);
    assert!(default["halvings"].as_u64().unwrap() > 1);
    assert_eq!(configured["halvings"], 1, "{configured}");
    // The constraint file's own `solver` wins over the configuration.
    write_constraints(
        &ron,
        &asset,
        &[(6 + 21 * 10, 0.7, 0.5), (14 + 21 * 10, 0.3, 0.5)],
        &format!("{corners}    solver: (max_halvings: 3, completion: Never),\n"),
    );
    let own = run(&["--config", config.to_str().unwrap()]);
    assert!(own["halvings"].as_u64().unwrap() >= 4, "{own}");
    // A broken configuration is a located error.
    std::fs::write(&config, "(solver: (max_halvingz: 0))").unwrap();
    let o = uvpin(&["solve", ron.to_str().unwrap(), "--config", config.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("uvpin.ron:1:11") && stderr(&o).contains("max_halvingz"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_time_budget_stops_the_completion_with_the_best_fold_free_layout() {
    let tmp = TempDir::new("budget");
    let asset = grid_asset(&tmp, 21);
    let corners = "    corners: (top_left: 420, bottom_left: 0, bottom_right: 20, top_right: 440),\n";
    let ron = tmp.path("b.uvpin.ron");
    let pair = [(6 + 21 * 10, 0.7, 0.5), (14 + 21 * 10, 0.3, 0.5)];
    write_constraints(
        &ron,
        &asset,
        &pair,
        &format!("{corners}    solver: (time_budget_ms: 1),\n"),
    );
    let out = tmp.path("out.glb");
    let (o, r) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(r["status"], "partial");
    assert_eq!(r["completion"]["out_of_time"], true);
    assert!(r["message"].as_str().unwrap().contains("time budget"), "{r}");
    assert_eq!(r["orientation"]["flipped"], 0);
    let o = uvpin(&["check", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

#[test]
fn inspect_lists_charts_the_outer_loop_in_order_and_the_nearest_vertices() {
    let face = repo().join("assets/face.glb");
    let o = uvpin(&[
        "inspect",
        face.to_str().unwrap(),
        "--boundary",
        "--near",
        "0,0.1,0.55",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["charts"].as_array().unwrap().len(), 1);
    assert_eq!(v["charts"][0]["boundary_loops"], 4);
    let outer: Vec<u64> = v["charts"][0]["outer_loop"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p[1].as_u64().unwrap())
        .collect();
    // The sample's corners follow each other along the loop in this order.
    let at = |id: u64| outer.iter().position(|&w| w == id).expect("a corner on the loop");
    let n = outer.len();
    let from_top_left = |id: u64| (at(id) + n - at(1711)) % n;
    assert!(from_top_left(168) < from_top_left(199) && from_top_left(199) < from_top_left(1742));
    let nearest = v["near"]["nearest"].as_array().unwrap();
    assert_eq!(nearest.len(), 5);
    assert!(v["near"]["too_far"].is_null());
    let text = uvpin(&["inspect", face.to_str().unwrap()]);
    assert!(
        stdout(&text).contains("4 boundary loops (1 outer, 3 holes)"),
        "{}",
        stdout(&text)
    );
    let missing = uvpin(&["inspect", "no/such.glb"]);
    assert_eq!(missing.status.code(), Some(1));
}

#[test]
fn a_near_point_off_the_mesh_is_an_error_that_suggests_the_y_up_reading() {
    let tmp = TempDir::new("near-far");
    std::fs::copy(repo().join("assets/face.glb"), tmp.path("face.glb")).unwrap();
    // Vertex 820 (the nose tip) of the sample is at (0, y, z) in glTF's Y-up;
    // a Z-up tool shows it as (0, -z, y).
    let asset = uvpin::io::load_asset(&tmp.path("face.glb"), None, 0, &Default::default()).unwrap();
    let p = asset.primitives[0].positions[820];
    let ron = tmp.path("far.uvpin.ron");
    let text = format!(
        "(asset: \"face.glb\", constraints: [(near: ({}, {}, {}), uv: (0.5, 0.6))])",
        p[0], -p[2], p[1]
    );
    std::fs::write(&ron, text).unwrap();
    let o = uvpin(&[
        "solve",
        ron.to_str().unwrap(),
        "-o",
        tmp.path("out.glb").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("far.uvpin.ron:1:") && err.contains("from the mesh"),
        "{err}"
    );
    assert!(err.contains("Z-up tool such as Blender"), "{err}");
    assert!(!tmp.path("out.glb").exists());
    // On the mesh, it snaps and says how far.
    std::fs::write(
        &ron,
        format!(
            "(asset: \"face.glb\", constraints: [(near: ({}, {}, {}), uv: (0.5, 0.58))])",
            p[0], p[1], p[2]
        ),
    )
    .unwrap();
    let (o, report) = solve_json(&ron, &tmp.path("out.glb"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(report["constraints"][0]["vertex"], 820);
}

/// A 10 × 10 grid and, apart from it, one triangle 10 long and 1e-7 thick
/// (an OBJ); the landmark on the grid.
fn grid_and_sliver(tmp: &TempDir) -> std::path::PathBuf {
    let mut mesh = grid_mesh(10, 10);
    let base = mesh.positions.len() as u32;
    let sliver = [(0.0, -20.0, 1.0), (10.0, -20.0, 1.0), (5.0, -20.0, 1.0000001)];
    mesh.positions.extend(sliver.map(|(x, y, z)| glam::DVec3::new(x, y, z)));
    mesh.triangles.push([base, base + 1, base + 2]);
    std::fs::write(tmp.path("g.obj"), obj_text(&mesh)).unwrap();
    tmp.path("g.obj")
}

#[test]
fn a_sliver_piece_without_landmarks_is_laid_out_not_refused() {
    // Packed at its own shape the sliver has no area once stored as f32:
    // it is laid out fat instead, and the solve succeeds.
    let tmp = TempDir::new("sliver-piece");
    grid_and_sliver(&tmp);
    let ron = tmp.path("g.uvpin.ron");
    write_constraints(&ron, std::path::Path::new("g.obj"), &[(44, 0.45, 0.5)], "");
    let out = tmp.path("out.glb");
    let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = uvpin(&["check", out.to_str().unwrap(), "--constraints", ron.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

/// A refusal (two targets for one vertex) says why on standard error even
/// with `-q`, and writes nothing: exit 1 always comes with its reason.
#[test]
fn a_quiet_refusal_still_says_why() {
    let tmp = TempDir::new("quiet-refusal");
    grid_and_sliver(&tmp);
    let ron = tmp.path("g.uvpin.ron");
    write_constraints(
        &ron,
        std::path::Path::new("g.obj"),
        &[(44, 0.45, 0.5), (44, 0.55, 0.5)],
        "",
    );
    let out = tmp.path("out.glb");
    let o = uvpin(&["solve", ron.to_str().unwrap(), "-o", out.to_str().unwrap(), "-q"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.starts_with("error: ") && err.lines().count() == 1, "{err:?}");
    assert!(!out.exists());
}

#[test]
fn a_closed_mesh_with_a_three_vertex_hole_is_cut_like_a_closed_one() {
    // One triangle missing: the one boundary loop has three vertices, too
    // few for the square's corners; the automatic seams open it.
    let tmp = TempDir::new("three-vertex-hole");
    let mut sphere = uvpin::testing::uv_sphere(24, 36);
    sphere.triangles.remove(400);
    std::fs::write(tmp.path("holed.obj"), obj_text(&sphere)).unwrap();
    let ron = tmp.path("holed.uvpin.ron");
    write_constraints(
        &ron,
        std::path::Path::new("holed.obj"),
        &[(300, 0.4, 0.5), (310, 0.6, 0.5)],
        "",
    );
    let out = tmp.path("out.glb");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(report["status"], "reached");
    let o = uvpin(&["check", out.to_str().unwrap(), "--constraints", ron.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

#[test]
fn a_one_triangle_piece_holding_landmarks_is_solved_as_its_own_chart() {
    let tmp = TempDir::new("one-triangle-piece");
    let mut grid = grid_mesh(10, 10);
    let base = grid.positions.len() as u32;
    grid.positions.extend([
        glam::DVec3::new(0.0, -20.0, 0.0),
        glam::DVec3::new(3.0, -20.0, 0.0),
        glam::DVec3::new(1.0, -18.0, 0.0),
    ]);
    grid.triangles.push([base, base + 1, base + 2]);
    std::fs::write(tmp.path("soup.obj"), obj_text(&grid)).unwrap();
    let solve = |landmarks: &[(u32, f64, f64)], extra: &str| {
        let ron = tmp.path("soup.uvpin.ron");
        write_constraints(&ron, std::path::Path::new("soup.obj"), landmarks, extra);
        let out = tmp.path("out.glb");
        let (o, report) = solve_json(&ron, &out);
        assert_checks_clean(&out);
        (o, report)
    };
    // One landmark or two on the triangle (its outer loop has 3 vertices,
    // no 4 corners for the square): reached, by default and free.
    for extra in ["", "    boundary: Free,\n"] {
        for on_triangle in [&[(base, 0.1, 0.1)][..], &[(base, 0.05, 0.1), (base + 1, 0.15, 0.1)]] {
            let mut landmarks = vec![(44, 0.45, 0.5)];
            landmarks.extend_from_slice(on_triangle);
            let (o, report) = solve(&landmarks, extra);
            assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
            assert_eq!(report["status"], "reached", "{report}");
        }
    }
    // Three landmarks whose targets mirror the triangle: partial, with the
    // triangle named as the proof, written fold-free.
    let mirrored = [
        (44, 0.45, 0.5),
        (base, 0.05, 0.1),
        (base + 1, 0.15, 0.1),
        (base + 2, 0.1, 0.15),
    ];
    let (o, report) = solve(&mirrored, "");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(report["status"], "partial", "{report}");
    assert!(
        reasons(&report).iter().any(|r| r.contains("flipped or flat")),
        "{report}"
    );
    let (mut held, _) = solve(&mirrored[..3], "");
    assert_eq!(held.status.code(), Some(0), "{}", stderr(&held));
    held = solve(
        &[
            (44, 0.45, 0.5),
            (base, 0.05, 0.1),
            (base + 1, 0.15, 0.1),
            (base + 2, 0.1, 0.05),
        ],
        "",
    )
    .0;
    assert_eq!(
        held.status.code(),
        Some(0),
        "the same three, not mirrored: {}",
        stderr(&held)
    );
}

#[test]
fn a_photo_over_a_soup_of_triangles_reaches_every_piece_it_lands_on() {
    // Thirty separate triangles, turned every way, spread over a plane and
    // tilted a little out of it; a photo from above lands one or two
    // landmarks on ten of them. Each piece is solved beside the others at
    // the photo's scale, clear of what is laid out before it.
    let tmp = TempDir::new("photo-soup");
    let mut rng = uvpin::testing::Rng::new(7);
    let mut mesh = uvpin::mesh::TriMesh {
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    for k in 0..30u32 {
        let centre = glam::DVec2::new((k % 6) as f64 * 2.0, (k / 6) as f64 * 2.0);
        let (size, turn) = (0.4 + rng.f64(), std::f64::consts::TAU * rng.f64());
        for j in 0..3 {
            let a = turn + j as f64 * std::f64::consts::TAU / 3.0;
            let p = centre + 0.6 * size * glam::DVec2::new(a.cos(), a.sin());
            mesh.positions.push(glam::DVec3::new(p.x, p.y, 0.2 * (rng.f64() - 0.5)));
        }
        mesh.triangles.push([3 * k, 3 * k + 1, 3 * k + 2]);
    }
    std::fs::write(tmp.path("soup.obj"), obj_text(&mesh)).unwrap();
    let photo = |v: u32| {
        let p = mesh.positions[v as usize];
        (v, 0.05 + 0.08 * (p.x + 1.0), 0.95 - 0.08 * (p.y + 1.0))
    };
    let on: Vec<u32> = [0, 4, 7, 11, 15, 19, 22, 26].iter().map(|k| 3 * k).collect();
    let mut landmarks: Vec<(u32, f64, f64)> = on.iter().map(|&v| photo(v)).collect();
    landmarks.extend([photo(3 * 7 + 1), photo(3 * 19 + 2)]);
    let ron = tmp.path("soup.uvpin.ron");
    write_constraints(&ron, std::path::Path::new("soup.obj"), &landmarks, "");
    let out = tmp.path("out.glb");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(0), "{} {report}", stderr(&o));
    assert_eq!(report["status"], "reached", "{report}");
    assert_checks_clean(&out);
}

#[test]
fn a_one_triangle_mesh_on_the_square_is_an_error_at_the_boundary_field() {
    let tmp = TempDir::new("one-triangle-square");
    std::fs::write(tmp.path("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let ron = tmp.path("tri.uvpin.ron");
    write_constraints(&ron, std::path::Path::new("tri.obj"), &[(0, 0.5, 0.5)], "");
    let (o, report) = solve_json(&ron, &tmp.path("tri.glb"));
    assert_eq!(o.status.code(), Some(0), "free by default: {} {report}", stderr(&o));
    write_constraints(
        &ron,
        std::path::Path::new("tri.obj"),
        &[(0, 0.5, 0.5)],
        "    boundary: Square,\n",
    );
    assert_fails_writing_nothing(&ron, &tmp, &["tri.uvpin.ron:", "boundary:", "only 3 vertices"]);
}

#[test]
fn a_double_sided_face_has_its_back_laid_out_apart_with_a_warning() {
    let tmp = TempDir::new("double-sided");
    let mut grid = grid_mesh(10, 10);
    // Three faces given again wound the other way (a double-sided patch):
    // one layout cannot keep both windings.
    for k in [30, 31, 64] {
        let [a, b, c] = grid.triangles[k];
        grid.triangles.push([a, c, b]);
    }
    std::fs::write(tmp.path("two.obj"), obj_text(&grid)).unwrap();
    for (name, extra) in [("out.glb", ""), ("out.obj", "    boundary: Free,\n")] {
        let ron = tmp.path("two.uvpin.ron");
        write_constraints(
            &ron,
            std::path::Path::new("two.obj"),
            &[(44, 0.45, 0.5), (56, 0.6, 0.62)],
            extra,
        );
        let out = tmp.path(name);
        let (o, report) = solve_json(&ron, &out);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let warned = report["warnings"].as_array().unwrap().iter().any(|w| {
            let w = w.as_str().unwrap_or_default();
            w.contains("3 double-sided faces") && w.contains("laid out apart")
        });
        assert!(warned, "{}", report["warnings"]);
        let o = uvpin(&["check", out.to_str().unwrap(), "--constraints", ron.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stdout(&o));
    }
}
