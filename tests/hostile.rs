//! Hostile and broken input, one test per category: every run of the binary
//! is under an address-space limit of 1 GiB and must end within 5 s without
//! a panic; refused inputs exit 1 with a clear message and change no file.

mod common;
use common::daemon::Daemon;
use common::*;
use serde_json::{Value, json};
use std::path::Path;
use std::process::Command;
use uvpin::testing::grid_mesh;

/// A 6 × 6 grid as glTF JSON and its binary buffer (positions, then u32 indices).
/// One way of saving a bad asset over a good one.
type Save = Box<dyn Fn(&Path)>;

fn grid_document() -> (Value, Vec<u8>) {
    let mesh = grid_mesh(6, 6);
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    uvpin::io::gltf_file::new_document(&positions, &indices, None, "grid")
}

fn write_glb(path: &Path, json: &Value, bin: &[u8]) {
    std::fs::write(
        path,
        uvpin::io::glb::build(&serde_json::to_vec(json).unwrap(), Some(bin)),
    )
    .unwrap();
}

/// A folder with `grid.glb` (edited by `edit`), a constraint file naming
/// it, and a previous output and report that must survive a refusal.
fn setup(name: &str, edit: impl Fn(&mut Value, &mut Vec<u8>)) -> TempDir {
    let tmp = TempDir::new(name);
    let (mut json, mut bin) = grid_document();
    edit(&mut json, &mut bin);
    write_glb(&tmp.path("grid.glb"), &json, &bin);
    write_constraints(&tmp.path("c.uvpin.ron"), Path::new("grid.glb"), &[(14, 0.45, 0.55)], "");
    std::fs::write(tmp.path("out.glb"), b"previous output").unwrap();
    std::fs::write(tmp.path("report.json"), b"previous report").unwrap();
    tmp
}

/// `uvpin solve c.uvpin.ron -o out.glb --report report.json` must exit 1
/// with every needle in its message, and leave every file as it was.
fn assert_refused(tmp: &TempDir, needles: &[&str]) {
    let before = snapshot(&tmp.0);
    let o = uvpin_limited(
        &["solve", "c.uvpin.ron", "-o", "out.glb", "--report", "report.json"],
        &tmp.0,
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    for n in needles {
        assert!(err.contains(n), "expected {n:?} in: {err}");
    }
    assert!(err.lines().count() <= 3 && err.len() < 1000, "a short message: {err}");
    assert_eq!(snapshot(&tmp.0), before, "nothing may be written");
}

fn gltf_indices_types_and_strides_are_checked_before_reading() {
    type Edit = fn(&mut Value, &mut Vec<u8>);
    let cases: [(&str, Edit, &str); 8] = [
        (
            "missing accessor",
            |j, _| j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99),
            "accessors[99] does not exist",
        ),
        (
            "signed indices",
            |j, _| j["accessors"][1]["componentType"] = json!(5122),
            "unsigned integers",
        ),
        (
            "float indices",
            |j, _| j["accessors"][1]["componentType"] = json!(5126),
            "unsigned integers",
        ),
        (
            "indices out of bounds",
            |j, _| j["meshes"][0]["primitives"][0]["indices"] = json!(7),
            "accessors[7] does not exist",
        ),
        (
            "short stride",
            |j, _| j["bufferViews"][0]["byteStride"] = json!(4),
            "smaller than one VEC3",
        ),
        (
            "VEC2 positions",
            |j, _| j["accessors"][0]["type"] = json!("VEC2"),
            "not allowed for POSITION",
        ),
        (
            "byte positions",
            |j, _| j["accessors"][0]["componentType"] = json!(5121),
            "not allowed for POSITION",
        ),
        (
            "view past its buffer",
            |j, _| j["bufferViews"][1]["byteLength"] = json!(1 << 20),
            "outside buffers[0]",
        ),
    ];
    for (name, edit, needle) in cases {
        let tmp = setup(&format!("h-gltf-{}", name.replace(' ', "-")), edit);
        assert_refused(&tmp, &["grid.glb", "invalid glTF", needle]);
        let o = uvpin_limited(&["check", "grid.glb"], &tmp.0);
        assert_eq!(o.status.code(), Some(1), "check, {name}: {}", stderr(&o));
    }
}

fn declared_sizes_are_checked_before_anything_is_allocated() {
    type Edit = fn(&mut Value, &mut Vec<u8>);
    let cases: [(&str, Edit, &str); 3] = [
        (
            "sparse 2^31",
            |j, _| {
                j["accessors"][0] = json!({"componentType": 5126, "count": 2147483648u64, "type": "VEC3",
                "min": [0, 0, 0], "max": [1, 1, 1],
                "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5125}, "values": {"bufferView": 0}}});
            },
            "input limits",
        ),
        (
            "index count 2^32",
            |j, _| j["accessors"][1]["count"] = json!(4294967296u64),
            "input limits",
        ),
        (
            "buffer of a terabyte",
            |j, _| j["buffers"][0]["byteLength"] = json!(1u64 << 40),
            "input limit",
        ),
    ];
    for (name, edit, needle) in cases {
        let tmp = setup(&format!("h-size-{}", name.replace(' ', "-")), edit);
        assert_refused(&tmp, &["grid.glb", needle]);
    }
}

/// Makes a FIFO at `path`.
fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
}

fn fifos_and_devices_are_refused_at_once() {
    // The asset itself a FIFO, or a link to a device.
    for (name, make) in [
        ("fifo", (|p: &Path| mkfifo(p)) as fn(&Path)),
        ("zero", |p: &Path| std::os::unix::fs::symlink("/dev/zero", p).unwrap()),
        ("urandom", |p: &Path| {
            std::os::unix::fs::symlink("/dev/urandom", p).unwrap()
        }),
    ] {
        let tmp = setup(&format!("h-special-{name}"), |_, _| {});
        std::fs::remove_file(tmp.path("grid.glb")).unwrap();
        make(&tmp.path("grid.glb"));
        assert_refused(&tmp, &["grid.glb", "not a regular file"]);
        let o = uvpin_limited(&["check", "grid.glb"], &tmp.0);
        assert!(stderr(&o).contains("not a regular file"), "{}", stderr(&o));
    }
    // A .gltf whose buffer is a FIFO.
    let tmp = TempDir::new("h-special-buffer");
    let (mut json, _) = grid_document();
    json["buffers"][0]["uri"] = json!("data.bin");
    std::fs::write(tmp.path("grid.gltf"), serde_json::to_vec(&json).unwrap()).unwrap();
    mkfifo(&tmp.path("data.bin"));
    write_constraints(&tmp.path("c.uvpin.ron"), Path::new("grid.gltf"), &[], "");
    let o = uvpin_limited(&["solve", "c.uvpin.ron", "-o", "out.gltf"], &tmp.0);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("buffer 0") && stderr(&o).contains("not a regular file"),
        "{}",
        stderr(&o)
    );
    // A texture image that is a FIFO: the solve goes on, the picture has no texture.
    let tmp = setup("h-special-image", |j, _| textured(j, "tex.png"));
    mkfifo(&tmp.path("tex.png"));
    let o = uvpin_limited(
        &["solve", "c.uvpin.ron", "-o", "out.glb", "--preview", "uv.png"],
        &tmp.0,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(tmp.path("uv.png").is_file());
    // A constraint file that is a FIFO.
    std::fs::remove_file(tmp.path("c.uvpin.ron")).unwrap();
    mkfifo(&tmp.path("c.uvpin.ron"));
    let o = uvpin_limited(&["solve", "c.uvpin.ron"], &tmp.0);
    assert!(stderr(&o).contains("not a regular file"), "{}", stderr(&o));
}

/// Gives the document a material whose base colour is the image at `uri`.
fn textured(json: &mut Value, uri: &str) {
    json["images"] = json!([{ "uri": uri }]);
    json["textures"] = json!([{ "source": 0 }]);
    json["materials"] = json!([{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
    json["meshes"][0]["primitives"][0]["material"] = json!(0);
}

fn exit_1_writes_nothing() {
    // A report that cannot be written: the output is not replaced either.
    let tmp = setup("h-exit-report", |_, _| {});
    std::fs::write(tmp.path("blocker"), b"a file, not a folder").unwrap();
    let before = snapshot(&tmp.0);
    let o = uvpin_limited(
        &["solve", "c.uvpin.ron", "-o", "out.glb", "--report", "blocker/r.json"],
        &tmp.0,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("nothing was replaced"), "{}", stderr(&o));
    assert_eq!(snapshot(&tmp.0), before);
    // Device nodes and FIFOs are never replaced.
    for target in ["/dev/null", "fifo.json"] {
        if target == "fifo.json" {
            mkfifo(&tmp.path(target));
        }
        for flag in ["-o", "--report"] {
            let o = uvpin_limited(&["solve", "c.uvpin.ron", flag, target], &tmp.0);
            assert_eq!(o.status.code(), Some(1), "{flag} {target}: {}", stderr(&o));
            assert!(stderr(&o).contains("refusing to replace it"), "{}", stderr(&o));
        }
    }
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
}

/// Exit 1 leaves every named output and folder as it was: outputs that name
/// one file, a write the export refuses, a usage error, an option out of range.
fn exit_1_replaces_no_named_output_and_leaves_no_folder() {
    let tmp = setup("h-exit-named", |_, _| {});
    std::fs::write(tmp.path("p.png"), b"previous picture").unwrap();
    let refused = |args: &[&str], needle: &str| {
        let before = snapshot(&tmp.0);
        let o = uvpin_limited(args, &tmp.0);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert_eq!(snapshot(&tmp.0), before, "{args:?}: nothing may be written");
    };
    // The model and the report naming one file (by name, or through `..`).
    refused(
        &["solve", "c.uvpin.ron", "-o", "out.glb", "--report", "out.glb"],
        "two outputs",
    );
    refused(
        &["solve", "c.uvpin.ron", "-o", "out.glb", "--report", "new/../out.glb"],
        "two outputs",
    );
    // The layout picture and the render naming one file.
    let both = [
        "solve",
        "c.uvpin.ron",
        "-o",
        "out.glb",
        "--preview",
        "p.png",
        "--render",
        "p.png",
    ];
    refused(&both, "two outputs");
    // A write the export refuses (a .gltf for a .glb input): no report, no
    // picture, no folder made for the output.
    let gltf = [
        "solve",
        "c.uvpin.ron",
        "-o",
        "new/deeper/out.gltf",
        "--report",
        "report.json",
        "--preview",
        "p.png",
    ];
    refused(&gltf, "gltf");
    // A usage error exits 1 (2 means "partial, written").
    refused(&["solve", "c.uvpin.ron", "--no-such-flag"], "--no-such-flag");
    refused(&["frobnicate"], "frobnicate");
    let help = uvpin_limited(&["--help"], &tmp.0);
    assert_eq!(help.status.code(), Some(0));
    // A NaN or negative solver weight is named, with where it is.
    for (field, value) in [
        ("initial_weight", "-1.0"),
        ("weight_growth", "NaN"),
        ("tolerance", "0.0"),
    ] {
        let text = std::fs::read_to_string(tmp.path("c.uvpin.ron")).unwrap();
        let bad = text.replacen(
            "constraints:",
            &format!("solver: ({field}: {value}),\n    constraints:"),
            1,
        );
        std::fs::write(tmp.path("bad.uvpin.ron"), bad).unwrap();
        refused(
            &["solve", "bad.uvpin.ron", "-o", "out.glb", "--report", "report.json"],
            &format!("solver.{field}"),
        );
    }
}

/// Outputs that stand alone: a .gltf's buffer is cleaned up by its exact
/// name only, URIs stay relative when the output's folder is new, and GLB
/// bytes under a .gltf name are written as a GLB (never a .gltf without its
/// geometry).
fn gltf_outputs_keep_other_outputs_buffers_and_relative_uris() {
    let tmp = TempDir::new("h-gltf-names");
    let (mut json, bin) = grid_document();
    json["buffers"][0]["uri"] = json!("geometry.bin");
    std::fs::write(tmp.path("grid.gltf"), serde_json::to_vec(&json).unwrap()).unwrap();
    std::fs::write(tmp.path("geometry.bin"), &bin).unwrap();
    write_constraints(
        &tmp.path("c.uvpin.ron"),
        Path::new("grid.gltf"),
        &[(14, 0.45, 0.55)],
        "",
    );
    let solve = |out: &str| {
        let o = uvpin_limited(&["solve", "c.uvpin.ron", "-o", out], &tmp.0);
        assert_eq!(o.status.code(), Some(0), "{out}: {}", stderr(&o));
    };
    let buffer_of = |gltf: &str| -> String {
        let written: Value = serde_json::from_slice(&std::fs::read(tmp.path(gltf)).unwrap()).unwrap();
        let uris: Vec<String> = written["buffers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|b| b["uri"].as_str().unwrap().to_string())
            .collect();
        assert!(
            uris.iter().all(|u| !u.starts_with('/') && !u.contains(':')),
            "{gltf}: {uris:?}"
        );
        uris.last().unwrap().clone()
    };
    solve("out/a.uvpinned.gltf");
    let earlier = buffer_of("out/a.uvpinned.gltf");
    solve("out/a.gltf");
    assert!(
        tmp.path("out").join(&earlier).is_file(),
        "a.gltf removed a.uvpinned.gltf's buffer"
    );
    for out in ["out/a.uvpinned.gltf", "out/a.gltf"] {
        let o = uvpin_limited(&["check", out], &tmp.0);
        assert_eq!(o.status.code(), Some(0), "{out}: {}", stderr(&o));
    }
    // Into folders that do not exist yet: relative URIs, readable as written.
    solve("new/deeper/o.gltf");
    buffer_of("new/deeper/o.gltf");
    let o = uvpin_limited(&["check", "new/deeper/o.gltf"], &tmp.0);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // GLB bytes named .gltf: read as GLB, written only as .glb.
    let (json, bin) = grid_document();
    write_glb(&tmp.path("glb-inside.gltf"), &json, &bin);
    write_constraints(
        &tmp.path("g.uvpin.ron"),
        Path::new("glb-inside.gltf"),
        &[(14, 0.45, 0.55)],
        "",
    );
    let o = uvpin_limited(&["solve", "g.uvpin.ron", "-o", "g-out.gltf"], &tmp.0);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("GLB bytes"), "{}", stderr(&o));
    assert!(!tmp.path("g-out.gltf").exists());
    let o = uvpin_limited(&["solve", "g.uvpin.ron", "-o", "g-out.glb"], &tmp.0);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (uvs, bad) = python_uvs(&tmp.path("g-out.glb"), 0);
    assert_eq!((uvs.len(), bad), (36, 0));
}

/// Every file and folder under `dir`, files with their bytes.
fn tree(dir: &Path) -> Vec<(std::path::PathBuf, Option<Vec<u8>>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if e.file_type().unwrap().is_dir() {
                out.push((p.clone(), None));
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).ok()));
            }
        }
    }
    out.sort();
    out
}

/// Output paths in every combination (the same name twice, a folder where a
/// file goes, folders not made yet, a file where a folder goes): exit 0 means
/// every named output reads back as its kind; exit 1 means every file and
/// folder is as it was. Seeded, a fixed number of rounds.
fn output_path_combinations_write_all_or_nothing() {
    const NAMES: [&str; 12] = [
        "out.glb",
        "out.gltf",
        "r.json",
        "p.png",
        "q.png",
        "sub/out.glb",
        "sub",
        "new/x/o.glb",
        "blocker/in.png",
        "blocker",
        "new/r.json",
        "out.glb/inner.png",
    ];
    let tmp = setup("h-out-combos", |_, _| {});
    std::fs::create_dir_all(tmp.path("sub")).unwrap();
    std::fs::write(tmp.path("blocker"), b"a file where a folder would go").unwrap();
    std::fs::write(tmp.path("p.png"), b"previous picture").unwrap();
    let mut rng = uvpin::testing::Rng::new(26);
    let (mut written, mut refused) = (0, 0);
    for round in 0..40 {
        let mut args = vec!["solve".to_string(), "c.uvpin.ron".into()];
        let mut named = Vec::new();
        for flag in ["-o", "--report", "--preview", "--render"] {
            if rng.below(3) > 0 {
                let name = NAMES[rng.below(NAMES.len())];
                args.extend([flag.to_string(), name.to_string()]);
                named.push((flag, name));
            }
        }
        let before = tree(&tmp.0);
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = uvpin_limited(&refs, &tmp.0);
        match o.status.code() {
            Some(0 | 2) => {
                written += 1;
                for (flag, name) in &named {
                    let bytes =
                        std::fs::read(tmp.path(name)).unwrap_or_else(|e| panic!("round {round} {args:?}: {name}: {e}"));
                    match *flag {
                        "--report" => drop(serde_json::from_slice::<Value>(&bytes).expect("a JSON report")),
                        "--preview" | "--render" => drop(image::load_from_memory(&bytes).expect("a picture")),
                        _ => assert_eq!(python_uvs(&tmp.path(name), 0).1, 0, "round {round}: {name} folds"),
                    }
                }
            }
            Some(1) => {
                refused += 1;
                assert_eq!(
                    tree(&tmp.0),
                    before,
                    "round {round} {args:?}: exit 1 changed files: {}",
                    stderr(&o)
                );
            }
            other => panic!("round {round} {args:?}: exit {other:?}: {}", stderr(&o)),
        }
    }
    assert!(
        written > 5 && refused > 5,
        "both kinds exercised: {written} written, {refused} refused"
    );
}

/// A GLB's JSON and chunks come back as read: integers past 64 bits exact,
/// chunks of extensions kept; a key given twice (which could not be kept)
/// is an error that names it.
fn gltf_json_and_chunks_are_kept_as_read() {
    let tmp = TempDir::new("h-kept");
    let (mut json, bin) = grid_document();
    json["meshes"][0]["extras"] = serde_json::from_str(r#"{"id": 18446744073709551617, "scale": 1.5e-7}"#).unwrap();
    let text = serde_json::to_vec(&json).unwrap();
    let custom = (0x5858_5858u32, b"custom chunk".to_vec());
    std::fs::write(
        tmp.path("grid.glb"),
        uvpin::io::glb::build_with(&text, Some(&bin), std::slice::from_ref(&custom)),
    )
    .unwrap();
    write_constraints(&tmp.path("c.uvpin.ron"), Path::new("grid.glb"), &[(14, 0.45, 0.55)], "");
    let o = uvpin_limited(&["solve", "c.uvpin.ron", "-o", "out.glb"], &tmp.0);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let written = std::fs::read(tmp.path("out.glb")).unwrap();
    let glb = uvpin::io::glb::parse(&written).unwrap();
    let out_text = String::from_utf8_lossy(glb.json);
    assert!(
        out_text.contains("18446744073709551617") && out_text.contains("1.5e-7"),
        "{out_text}"
    );
    assert_eq!(
        glb.others,
        vec![(custom.0, &custom.1[..])],
        "the extension's chunk is kept"
    );
    // The same key twice in one object.
    let text = String::from_utf8(text)
        .unwrap()
        .replacen("\"extras\":{", "\"extras\":{\"dup\":1,\"dup\":2,", 1);
    std::fs::write(tmp.path("grid.glb"), uvpin::io::glb::build(text.as_bytes(), Some(&bin))).unwrap();
    let before = snapshot(&tmp.0);
    let o = uvpin_limited(&["solve", "c.uvpin.ron", "-o", "out.glb"], &tmp.0);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("\"dup\" appears twice"), "{}", stderr(&o));
    assert_eq!(snapshot(&tmp.0), before);
}

fn gltf_outputs_name_their_buffer_and_glb_outputs_are_complete() {
    // .gltf twice: one content-named buffer remains, the one the .gltf names.
    let tmp = TempDir::new("h-gltf-bin");
    let (mut json, bin) = grid_document();
    json["buffers"][0]["uri"] = json!("geometry.bin");
    std::fs::write(tmp.path("grid.gltf"), serde_json::to_vec(&json).unwrap()).unwrap();
    std::fs::write(tmp.path("geometry.bin"), &bin).unwrap();
    std::fs::create_dir_all(tmp.path("out")).unwrap();
    for u in [0.45, 0.5] {
        write_constraints(&tmp.path("c.uvpin.ron"), Path::new("grid.gltf"), &[(14, u, 0.55)], "");
        let o = uvpin_limited(&["solve", "c.uvpin.ron", "-o", "out/r.gltf"], &tmp.0);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let written: Value = serde_json::from_slice(&std::fs::read(tmp.path("out/r.gltf")).unwrap()).unwrap();
    let named = written["buffers"].as_array().unwrap().last().unwrap()["uri"]
        .as_str()
        .unwrap()
        .to_string();
    let bins: Vec<String> = std::fs::read_dir(tmp.path("out"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".bin"))
        .collect();
    assert_eq!(bins, vec![named]);
    // A GLB whose buffer is an external file, written to another folder, is complete.
    let tmp = TempDir::new("h-glb-external");
    let (mut json, bin) = grid_document();
    json["buffers"][0]["uri"] = json!("geometry.bin");
    std::fs::create_dir_all(tmp.path("in")).unwrap();
    std::fs::write(tmp.path("in/geometry.bin"), &bin).unwrap();
    std::fs::write(
        tmp.path("in/grid.glb"),
        uvpin::io::glb::build(&serde_json::to_vec(&json).unwrap(), None),
    )
    .unwrap();
    write_constraints(
        &tmp.path("in/c.uvpin.ron"),
        Path::new("grid.glb"),
        &[(14, 0.45, 0.55)],
        "",
    );
    let o = uvpin_limited(&["solve", "in/c.uvpin.ron", "-o", "elsewhere/out.glb"], &tmp.0);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::remove_dir_all(tmp.path("in")).unwrap();
    let o = uvpin_limited(&["check", "elsewhere/out.glb"], &tmp.0);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// A grid with one vertex pulled far out of its plane: long edges, thin
/// triangles in the layout.
fn far_out_obj(seed: u64) -> String {
    let mut rng = uvpin::testing::Rng::new(seed);
    let mut mesh = grid_mesh(8, 8);
    let v = 9 + rng.below(40);
    mesh.positions[v].z += 10f64.powf(rng.range(1.0, 4.0));
    obj_text(&mesh)
}

fn obj_outputs_are_fold_free_as_stored() {
    let tmp = TempDir::new("h-obj");
    // Seeds 59, 87 and 91 wrote flipped OBJ faces before the guard checked
    // OBJ's storage (`vt` rounded to f32) as well as glTF's.
    let mut solved = 0;
    for seed in 40..100u64 {
        std::fs::write(tmp.path("m.obj"), far_out_obj(seed)).unwrap();
        let mut rng = uvpin::testing::Rng::new(seed + 1000);
        // Interior vertices of the 8 × 8 grid.
        let targets: Vec<(u32, f64, f64)> = [10u32, 27, 44]
            .iter()
            .map(|&v| (v, rng.range(0.2, 0.8), rng.range(0.2, 0.8)))
            .collect();
        write_constraints(&tmp.path("c.uvpin.ron"), Path::new("m.obj"), &targets, "");
        let o = uvpin_limited(&["solve", "c.uvpin.ron", "-o", "out.obj", "-q"], &tmp.0);
        match o.status.code() {
            Some(0 | 2) => {
                solved += 1;
                let check = uvpin_limited(&["check", "out.obj"], &tmp.0);
                let text = stdout(&check);
                assert!(text.contains("flipped      0  zero-area      0"), "seed {seed}: {text}");
                let _ = std::fs::remove_file(tmp.path("out.obj"));
            }
            Some(1) => assert!(!tmp.path("out.obj").exists(), "seed {seed}"),
            other => panic!("seed {seed}: {other:?}"),
        }
    }
    assert!(solved > 45, "{solved} of 60 solved");
}

fn mistakes_are_errors_up_front() {
    // Two vertices, one target.
    let tmp = setup("h-mistakes", |_, _| {});
    write_constraints(
        &tmp.path("c.uvpin.ron"),
        Path::new("grid.glb"),
        &[(14, 0.5, 0.5), (21, 0.5, 0.5)],
        "",
    );
    assert_refused(
        &tmp,
        &[
            "constraints[0] (vertex 14) and constraints[1] (vertex 21)",
            "same target",
        ],
    );
    write_constraints(
        &tmp.path("c.uvpin.ron"),
        Path::new("grid.glb"),
        &[(14, 0.5, 0.5), (21, 0.5, 0.5000001)],
        "",
    );
    assert_refused(&tmp, &["same target"]);
    // Sizes.
    write_constraints(&tmp.path("c.uvpin.ron"), Path::new("grid.glb"), &[(14, 0.45, 0.55)], "");
    for size in ["4294967295", "100000", "0"] {
        let o = uvpin_limited(
            &["solve", "c.uvpin.ron", "--preview", "p.png", "--preview-size", size],
            &tmp.0,
        );
        assert_eq!(o.status.code(), Some(1), "{size}: {}", stderr(&o));
        assert!(stderr(&o).contains("--preview-size"), "{}", stderr(&o));
    }
    std::fs::write(
        tmp.path("big.sweep.ron"),
        "(constraints: [\"c.uvpin.ron\"], output: \"sw\", blend: (from: 0.0, to: 1.0, steps: 4000000000))",
    )
    .unwrap();
    let o = uvpin_limited(&["sweep", "big.sweep.ron", "-q"], &tmp.0);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("blend.steps"), "{}", stderr(&o));
    // A byte-order mark and `corners: Auto` are accepted.
    let text = std::fs::read_to_string(tmp.path("c.uvpin.ron")).unwrap();
    let with = text.replacen("constraints:", "corners: Auto,\n    constraints:", 1);
    std::fs::write(tmp.path("c.uvpin.ron"), format!("\u{feff}{with}")).unwrap();
    let o = uvpin_limited(&["solve", "c.uvpin.ron", "-o", "ok.glb"], &tmp.0);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // A closed pipe ends the output quietly.
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "{} check ok.glb | head -c 10 > /dev/null; echo done",
            env!("CARGO_BIN_EXE_uvpin")
        ))
        .current_dir(&tmp.0)
        .output()
        .unwrap();
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
}

/// A small watched project: `assets/` with a grid and its constraint file.
fn watched_project(name: &str) -> TempDir {
    let tmp = TempDir::new(name);
    std::fs::create_dir_all(tmp.path("assets")).unwrap();
    let (json, bin) = grid_document();
    write_glb(&tmp.path("assets/grid.glb"), &json, &bin);
    write_constraints(
        &tmp.path("assets/grid.uvpin.ron"),
        Path::new("grid.glb"),
        &[(14, 0.45, 0.55)],
        "",
    );
    tmp
}

/// Runs uvpin with `args` in `cwd`: its exit code, standard error and peak
/// resident memory (kB, from the kernel's accounting of this child alone).
#[allow(
    clippy::zombie_processes,
    reason = "waited for with wait4, which also gives its peak memory"
)]
fn run_with_peak(cwd: &Path, args: &[&str]) -> (Option<i32>, String, i64) {
    let child = Command::new(env!("CARGO_BIN_EXE_uvpin"))
        .args(args)
        .current_dir(cwd)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn uvpin");
    let pid = child.id() as libc::pid_t;
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.unwrap(), &mut err).unwrap();
    let mut status = 0;
    // SAFETY: plain system calls on our own child, with valid out-pointers.
    let usage = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        assert_eq!(libc::wait4(pid, &mut status, 0, &mut usage), pid);
        usage
    };
    let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
    (code, err, usage.ru_maxrss)
}

/// Folders and constraint files swapped for links to outside while the
/// daemon solves in place, a bounded number of rounds: nothing outside is
/// read (its secret never reaches the log or the status file) or written
/// (its files stay byte-identical).
fn swaps_under_a_running_daemon_never_reach_outside() {
    let tmp = TempDir::new("h-swaps");
    std::fs::create_dir_all(tmp.path("assets/sub")).unwrap();
    std::fs::create_dir_all(tmp.path("outside")).unwrap();
    let (json, bin) = grid_document();
    write_glb(&tmp.path("assets/sub/grid.glb"), &json, &bin);
    write_glb(&tmp.path("outside/grid.glb"), &json, &bin);
    let secret = "hunter2-outside-secret";
    std::fs::write(
        tmp.path("outside/grid.uvpin.ron"),
        format!("// {secret}\n(asset: \"grid.glb\", constraints: [])"),
    )
    .unwrap();
    std::fs::write(tmp.path("outside/token"), secret).unwrap();
    let ron = tmp.path("assets/sub/grid.uvpin.ron");
    write_constraints(&ron, Path::new("grid.glb"), &[(14, 0.45, 0.55)], "");
    let outside = tree(&tmp.path("outside"));
    /// The daemon, killed if the test ends early.
    struct Running(std::process::Child);
    impl Drop for Running {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let mut running = Running(
        Command::new(env!("CARGO_BIN_EXE_uvpin"))
            .args(["watch", "assets", "--in-place", "--log", "json", "--debounce-ms", "20"])
            .current_dir(&tmp.0)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut rng = uvpin::testing::Rng::new(7);
    for round in 0..30 {
        let u = 0.40 + 0.005 * round as f64;
        write_constraints(&ron, Path::new("grid.glb"), &[(14, u, 0.55)], "");
        std::thread::sleep(std::time::Duration::from_millis(rng.below(40) as u64));
        if round % 2 == 0 {
            // The folder being solved, swapped for a link to outside.
            std::fs::rename(tmp.path("assets/sub"), tmp.path("assets/held")).unwrap();
            std::os::unix::fs::symlink(tmp.path("outside"), tmp.path("assets/sub")).unwrap();
            std::thread::sleep(std::time::Duration::from_millis(rng.below(40) as u64));
            std::fs::remove_file(tmp.path("assets/sub")).unwrap();
            std::fs::rename(tmp.path("assets/held"), tmp.path("assets/sub")).unwrap();
        } else {
            // The constraint file, swapped for a link to a secret outside.
            std::fs::rename(&ron, tmp.path("assets/sub/held.txt")).unwrap();
            std::os::unix::fs::symlink(tmp.path("outside/token"), &ron).unwrap();
            std::thread::sleep(std::time::Duration::from_millis(rng.below(40) as u64));
            std::fs::remove_file(&ron).unwrap();
            std::fs::rename(tmp.path("assets/sub/held.txt"), &ron).unwrap();
        }
    }
    let child = &mut running.0;
    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let mut log = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut log).unwrap();
    assert_eq!(child.wait().unwrap().code(), Some(0), "{log}");
    assert_eq!(tree(&tmp.path("outside")), outside, "nothing outside is written");
    assert!(!log.contains("hunter2"), "an outside file was read: {log}");
    let status = std::fs::read_to_string(tmp.path("uvpin-status.json")).unwrap_or_default();
    assert!(!status.contains("hunter2"), "{status}");
}

fn once(tmp: &TempDir, args: &[&str]) -> std::process::Output {
    let mut all = vec!["watch", "--once", "--no-previews"];
    all.extend_from_slice(args);
    uvpin_limited(&all, &tmp.0)
}

fn paths_outside_are_neither_read_nor_written() {
    // In place, an asset outside the watched folders is never written.
    let tmp = watched_project("h-paths");
    std::fs::create_dir_all(tmp.path("elsewhere")).unwrap();
    std::fs::copy(tmp.path("assets/grid.glb"), tmp.path("elsewhere/x.glb")).unwrap();
    let elsewhere = snapshot(&tmp.path("elsewhere"));
    for asset in [
        "../elsewhere/x.glb".to_string(),
        tmp.path("elsewhere/x.glb").display().to_string(),
    ] {
        write_constraints(
            &tmp.path("assets/grid.uvpin.ron"),
            Path::new(&asset),
            &[(14, 0.45, 0.55)],
            "",
        );
        let o = once(&tmp, &["--in-place", "--allow", "elsewhere"]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("in-place mode writes only assets inside the watched folders"),
            "{}",
            stderr(&o)
        );
        assert_eq!(snapshot(&tmp.path("elsewhere")), elsewhere);
    }
    // An asset outside them (300 MB) is refused before a byte is read: the
    // daemon's peak memory stays far below its size.
    let tmp = watched_project("h-paths-big");
    std::fs::create_dir_all(tmp.path("secret")).unwrap();
    std::fs::File::create(tmp.path("secret/big.glb"))
        .unwrap()
        .set_len(300 << 20)
        .unwrap();
    std::os::unix::fs::symlink(tmp.path("secret/big.glb"), tmp.path("assets/link.glb")).unwrap();
    for asset in ["../secret/big.glb", "link.glb"] {
        write_constraints(
            &tmp.path("assets/grid.uvpin.ron"),
            Path::new(asset),
            &[(14, 0.45, 0.55)],
            "",
        );
        let (code, err, peak_kb) = run_with_peak(&tmp.0, &["watch", "--once", "--no-previews"]);
        assert_eq!(code, Some(1), "{asset}: {err}");
        assert!(err.contains("outside the folders"), "{asset}: {err}");
        assert!(
            peak_kb < 150 * 1024,
            "{asset}: peak resident {peak_kb} kB: the outside file was read"
        );
    }
    // A texture outside the watched folders is not read into the pictures.
    let tmp = watched_project("h-paths-image");
    std::fs::write(tmp.path("secret.png"), red_png()).unwrap();
    let (mut json, bin) = grid_document();
    textured(&mut json, "../secret.png");
    write_glb(&tmp.path("assets/grid.glb"), &json, &bin);
    let o = uvpin_limited(&["watch", "--once"], &tmp.0);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let picture = image::open(tmp.path("out/grid.uv.png")).unwrap().to_rgba8();
    let reddish = picture
        .pixels()
        .filter(|p| p[0] > 200 && p[1] < 60 && p[2] < 60)
        .count();
    assert!(
        reddish < picture.pixels().len() / 50,
        "the secret texture was drawn: {reddish} red pixels"
    );
    // A linked constraint file's target does not leak into the log.
    let tmp = watched_project("h-paths-link");
    std::fs::write(tmp.path("token"), "hunter2-secret-token").unwrap();
    std::os::unix::fs::symlink(tmp.path("token"), tmp.path("assets/leak.uvpin.ron")).unwrap();
    let o = once(&tmp, &[]);
    assert!(!stderr(&o).contains("hunter2"), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("leak.uvpin.ron") && stderr(&o).contains("outside the folders"),
        "{}",
        stderr(&o)
    );
    // A file name with a newline cannot forge a log line.
    let tmp = watched_project("h-paths-newline");
    std::fs::write(tmp.path("assets/a\n[00:00:00.000] forged.uvpin.ron"), "(broken").unwrap();
    let o = once(&tmp, &[]);
    assert!(
        !stderr(&o).lines().any(|l| l.starts_with("[00:00:00.000] forged")),
        "{}",
        stderr(&o)
    );
    assert!(
        stderr(&o).contains("a\\n[00:00:00.000] forged.uvpin.ron"),
        "{}",
        stderr(&o)
    );
}

/// An 8 × 8 PNG, pure red.
fn red_png() -> Vec<u8> {
    let image = image::RgbaImage::from_pixel(8, 8, image::Rgba([255, 0, 0, 255]));
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// What the daemon tests add to `uvpin watch`.
const DAEMON_ARGS: &[&str] = &["--no-previews"];

fn daemon_survives_hostile_input_and_recovers() {
    let tmp = watched_project("h-daemon");
    let mut daemon = Daemon::watch(&tmp.0, DAEMON_ARGS);
    daemon.wait_count("solved", "grid.uvpin.ron", 1);
    let good = std::fs::read(tmp.path("out/grid.glb")).unwrap();
    let (json, bin) = grid_document();
    let hostile: Vec<Save> = vec![
        Box::new(|p| {
            let (mut j, b) = grid_document();
            j["accessors"][1]["componentType"] = json!(5126);
            write_glb(p, &j, &b);
        }),
        Box::new(|p| {
            let (mut j, b) = grid_document();
            j["accessors"][0]["count"] = json!(1u64 << 33);
            write_glb(p, &j, &b);
        }),
        Box::new(|p| std::fs::write(p, b"glTF\x02\0\0\0garbage").unwrap()),
        Box::new(|p| {
            std::fs::remove_file(p).unwrap();
            mkfifo(p);
        }),
    ];
    for (k, make) in hostile.iter().enumerate() {
        make(&tmp.path("assets/grid.glb"));
        daemon.wait_count("error", "grid.uvpin.ron", k + 1);
        if k == 3 {
            // A FIFO where the asset was: unreadable, not "removed".
            let message = daemon.last_message("error");
            assert!(
                message.contains("cannot be read") && !message.contains("removed"),
                "{message}"
            );
            assert_eq!(message.matches("output is kept").count(), 1, "said once: {message}");
        }
        assert!(daemon.alive(), "the daemon died on hostile input {k}");
        assert_eq!(
            std::fs::read(tmp.path("out/grid.glb")).unwrap(),
            good,
            "the last good output is kept"
        );
        let _ = std::fs::remove_file(tmp.path("assets/grid.glb"));
        write_glb(&tmp.path("assets/grid.glb"), &json, &bin);
        std::thread::sleep(std::time::Duration::from_millis(300));
    }
    // A burst of truncate-and-write saves gives no error line.
    let errors = daemon.count("error", "grid.uvpin.ron");
    let solved = daemon.count("solved", "grid.uvpin.ron");
    let text = std::fs::read_to_string(tmp.path("assets/grid.uvpin.ron")).unwrap();
    for k in 0..50 {
        let t = text.replace("0.45", &format!("{:.3}", 0.40 + 0.001 * k as f64));
        let mut f = std::fs::File::create(tmp.path("assets/grid.uvpin.ron")).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(10));
        std::io::Write::write_all(&mut f, t.as_bytes()).unwrap();
        drop(f);
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    daemon.wait_count("solved", "grid.uvpin.ron", solved + 1);
    std::thread::sleep(std::time::Duration::from_millis(500));
    assert_eq!(daemon.count("error", "grid.uvpin.ron"), errors, "{}", daemon.dump());
    // Deleting the asset and writing the same bytes back solves nothing.
    let solving = daemon.count("solving", "grid.uvpin.ron");
    let bytes = std::fs::read(tmp.path("assets/grid.glb")).unwrap();
    std::fs::remove_file(tmp.path("assets/grid.glb")).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(400));
    std::fs::write(tmp.path("assets/grid.glb"), &bytes).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(600));
    assert_eq!(daemon.count("solving", "grid.uvpin.ron"), solving, "{}", daemon.dump());
    assert!(daemon.alive());
    assert_eq!(daemon.terminate().code(), Some(0));
}

/// As an unprivileged user (run as root: under `setpriv` as nobody), an
/// asset made unreadable or replaced by a FIFO is "cannot be read", never
/// "removed", and the kept output is said once.
fn an_unprivileged_daemon_names_unreadable_assets() {
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 || !Path::new("/usr/bin/setpriv").exists() {
        eprintln!("SKIPPED: needs root and setpriv to run the daemon as another user");
        return;
    }
    let tmp = watched_project("h-unprivileged");
    let bin = tmp.path("uvpin");
    std::fs::copy(env!("CARGO_BIN_EXE_uvpin"), &bin).unwrap();
    let open_up = |p: &Path, mode: u32| {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
    };
    for p in [
        tmp.0.clone(),
        tmp.path("assets"),
        tmp.path("assets/grid.glb"),
        tmp.path("assets/grid.uvpin.ron"),
    ] {
        open_up(&p, 0o777);
    }
    let mut command = Command::new("/usr/bin/setpriv");
    command
        .args(["--reuid=65534", "--regid=65534", "--clear-groups"])
        .arg(&bin);
    let mut daemon = Daemon::watch_via(command, &tmp.0, DAEMON_ARGS);
    daemon.wait_count("solved", "grid.uvpin.ron", 1);
    let good = std::fs::read(tmp.path("out/grid.glb")).unwrap();
    let asset = tmp.path("assets/grid.glb");
    open_up(&asset, 0o000);
    daemon.wait_count("error", "grid.uvpin.ron", 1);
    let message = daemon.last_message("error");
    assert!(
        message.contains("cannot be read") && message.contains("ermission denied") && !message.contains("removed"),
        "{message}"
    );
    assert_eq!(message.matches("output is kept").count(), 1, "said once: {message}");
    open_up(&asset, 0o644);
    daemon.wait_count("unchanged", "grid.uvpin.ron", 1);
    std::fs::remove_file(&asset).unwrap();
    mkfifo(&asset);
    daemon.wait_count("error", "grid.uvpin.ron", 2);
    let message = daemon.last_message("error");
    assert!(message.contains("a FIFO") && !message.contains("removed"), "{message}");
    assert_eq!(message.matches("output is kept").count(), 1, "said once: {message}");
    assert!(daemon.alive());
    assert_eq!(
        std::fs::read(tmp.path("out/grid.glb")).unwrap(),
        good,
        "the output is kept"
    );
    assert_eq!(daemon.terminate().code(), Some(0));
}

fn a_killed_daemons_temporaries_are_removed_at_start() {
    let tmp = watched_project("h-stale");
    std::fs::create_dir_all(tmp.path("out/sub")).unwrap();
    let stale = tmp.path("out/sub/.grid.glb.uvpin-999999999.tmp");
    std::fs::write(&stale, b"half").unwrap();
    let o = once(&tmp, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stale.exists());
    assert!(stderr(&o).contains("removed 1 temporary files"), "{}", stderr(&o));
}

fn main() -> std::process::ExitCode {
    run_cases(&[
        (
            "gltf_indices_types_and_strides_are_checked_before_reading",
            &[],
            gltf_indices_types_and_strides_are_checked_before_reading,
        ),
        (
            "declared_sizes_are_checked_before_anything_is_allocated",
            &[],
            declared_sizes_are_checked_before_anything_is_allocated,
        ),
        (
            "fifos_and_devices_are_refused_at_once",
            &[],
            fifos_and_devices_are_refused_at_once,
        ),
        ("exit_1_writes_nothing", &[], exit_1_writes_nothing),
        (
            "gltf_json_and_chunks_are_kept_as_read",
            &[],
            gltf_json_and_chunks_are_kept_as_read,
        ),
        (
            "swaps_under_a_running_daemon_never_reach_outside",
            &[],
            swaps_under_a_running_daemon_never_reach_outside,
        ),
        (
            "output_path_combinations_write_all_or_nothing",
            &[],
            output_path_combinations_write_all_or_nothing,
        ),
        (
            "gltf_outputs_keep_other_outputs_buffers_and_relative_uris",
            &[],
            gltf_outputs_keep_other_outputs_buffers_and_relative_uris,
        ),
        (
            "exit_1_replaces_no_named_output_and_leaves_no_folder",
            &[],
            exit_1_replaces_no_named_output_and_leaves_no_folder,
        ),
        (
            "gltf_outputs_name_their_buffer_and_glb_outputs_are_complete",
            &[],
            gltf_outputs_name_their_buffer_and_glb_outputs_are_complete,
        ),
        (
            "obj_outputs_are_fold_free_as_stored",
            &[],
            obj_outputs_are_fold_free_as_stored,
        ),
        ("mistakes_are_errors_up_front", &[], mistakes_are_errors_up_front),
        (
            "paths_outside_are_neither_read_nor_written",
            &[],
            paths_outside_are_neither_read_nor_written,
        ),
        (
            "daemon_survives_hostile_input_and_recovers",
            &[],
            daemon_survives_hostile_input_and_recovers,
        ),
        (
            "an_unprivileged_daemon_names_unreadable_assets",
            &[],
            an_unprivileged_daemon_names_unreadable_assets,
        ),
        (
            "a_killed_daemons_temporaries_are_removed_at_start",
            &[],
            a_killed_daemons_temporaries_are_removed_at_start,
        ),
    ])
}
