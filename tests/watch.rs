//! `uvpin watch` end to end: the real binary on a temp folder, files saved the
//! way editors save them, outputs read back with the independent reader.

mod common;

use common::daemon::{Daemon, WAIT};
use common::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use uvpin::testing::grid_mesh;

const N: usize = 12;
/// Interior grid vertices used as constraints.
const A: u32 = (6 + 6 * N) as u32;
const B: u32 = (4 + 3 * N) as u32;
/// Longer than the debounce window (100 ms) plus a debouncer tick, with margin.
const SETTLE: Duration = Duration::from_millis(700);

/// `assets/grid.glb` + `assets/grid.uvpin.ron` in `dir`.
fn make_assets(dir: &Path) -> PathBuf {
    let assets = dir.join("assets");
    std::fs::create_dir_all(&assets).unwrap();
    write_mesh_glb(&assets.join("grid.glb"), &grid_mesh(N, N));
    let ron = assets.join("grid.uvpin.ron");
    write_constraints(&ron, Path::new("grid.glb"), &targets(0.0), "");
    ron
}

/// Constraint targets, shifted by `s` (a different content per save).
fn targets(s: f64) -> Vec<(u32, f64, f64)> {
    vec![(A, 0.50 + s, 0.45), (B, 0.36, 0.72 - s)]
}

fn constraint_text(s: f64) -> String {
    let dir = TempDir::new(&format!("text-{}", (s * 1e4) as i64));
    let p = dir.path("x.uvpin.ron");
    write_constraints(&p, Path::new("grid.glb"), &targets(s), "");
    std::fs::read_to_string(p).unwrap()
}

/// Asserts the output has the targets of shift `s`, read back independently, and no fold.
fn assert_output(out: &Path, s: f64) {
    let (uvs, bad) = python_uvs(out, 0);
    assert_eq!(bad, 0, "flipped or zero-area triangles in {}", out.display());
    for (v, u, w) in targets(s) {
        let got = uvs[v as usize];
        assert!(
            (got[0] - u).abs() < 1e-6 && (got[1] - w).abs() < 1e-6,
            "vertex {v}: {got:?}, expected ({u}, {w})"
        );
    }
}

/// `uvpin watch --once ARGS` run in `dir`, to its end.
fn watch_once(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_uvpin"))
        .args(["watch", "--once"])
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// The outputs below `dir` (not the status file) with their bytes; with
/// `hidden`, uvpin's temporaries too.
fn output_files(dir: &Path, hidden: bool) -> Vec<(PathBuf, Vec<u8>)> {
    snapshot(dir)
        .into_iter()
        .filter(|(p, _)| {
            let name = p.file_name().unwrap().to_string_lossy();
            name != "uvpin-status.json" && (hidden || !name.starts_with('.'))
        })
        .collect()
}

#[test]
fn a_daemon_killed_between_staging_and_renaming_leaves_the_old_set_and_the_next_run_writes_the_new() {
    let dir = TempDir::new("watch-killed-mid-commit");
    let ron = make_assets(&dir.0);
    let out_dir = dir.path("out");
    // The second commit writing grid.glb stops once its temporaries are
    // written, before any rename (a test hook), where it is killed.
    let hook = [("UVPIN_TEST_HALT_BEFORE_RENAMES", "grid.glb:2")];
    let mut d = Daemon::watch_with_env(&dir.0, &[], &hook);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    let old = output_files(&out_dir, false);
    let names: Vec<String> = old
        .iter()
        .map(|(p, _)| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["grid.glb", "grid.render.png", "grid.uv.png"], "{}", d.dump());
    std::fs::write(&ron, constraint_text(0.02)).unwrap();
    d.wait_count("halted_before_renames", "grid.glb", 1);
    d.child.kill().unwrap();
    d.child.wait().unwrap();
    // The model and both pictures as they were; their new versions only as temporaries.
    assert_eq!(
        output_files(&out_dir, false),
        old,
        "a killed commit changed the outputs"
    );
    let all = output_files(&out_dir, true);
    assert_eq!(
        all.len() - old.len(),
        3,
        "{:?}",
        all.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    // The next run clears them and writes the new set, all of it.
    let d = Daemon::watch(&dir.0, &[]);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    let cleanup = d.log().into_iter().find(|l| l["event"] == "cleanup");
    assert_eq!(cleanup.map(|l| l["removed"].clone()), Some(3.into()), "{}", d.dump());
    assert_output(&out_dir.join("grid.glb"), 0.02);
    let new = output_files(&out_dir, true);
    assert_eq!(
        new.len(),
        3,
        "temporaries left: {:?}",
        new.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for ((path, before), (_, after)) in old.iter().zip(&new) {
        assert_ne!(before, after, "{} was not rewritten", path.display());
    }
}

#[test]
fn a_long_solve_logs_each_stage_it_enters() {
    let dir = TempDir::new("watch-long-solve");
    make_assets(&dir.0);
    // Every solve counts as long (a test hook): its stages are logged.
    let hook = [("UVPIN_TEST_LONG_SOLVE_MS", "0")];
    let d = Daemon::watch_with_env(&dir.0, &[], &hook);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    let stages: Vec<String> = d
        .log()
        .into_iter()
        .filter(|l| l["event"] == "stage")
        .map(|l| l["stage"].as_str().unwrap_or_default().to_string())
        .collect();
    // Each candidate's solve in the solver's order, the planner choosing
    // between them, and the end once.
    let order = ["step_one", "spline_path", "completion", "polish"];
    for run in stages.split(|s| s == "choosing" || s == "finishing") {
        let rank: Vec<usize> = run
            .iter()
            .map(|s| {
                order
                    .iter()
                    .position(|o| o == s)
                    .unwrap_or_else(|| panic!("{s}: {stages:?}"))
            })
            .collect();
        assert!(rank.windows(2).all(|w| w[0] < w[1]), "{stages:?}\n{}", d.dump());
    }
    assert_eq!(stages.last().map(String::as_str), Some("finishing"), "{stages:?}");
    assert_eq!(stages.iter().filter(|s| *s == "finishing").count(), 1, "{stages:?}");
    assert!(stages.iter().any(|s| s == "polish"), "{stages:?}\n{}", d.dump());
}

#[test]
fn a_chart_solved_from_its_coarse_level_gets_no_step_one_of_its_own() {
    // A 60² grid above a lowered multilevel threshold: the daemon, like the
    // CLI, starts it from its coarse level and never factors its bar-net.
    let dir = TempDir::new("watch-coarse");
    let assets = dir.path("assets");
    std::fs::create_dir_all(&assets).unwrap();
    let n = 60;
    let mut mesh = grid_mesh(n, n);
    for p in &mut mesh.positions {
        p.z = 0.2 * (p.x * 4.0).sin() * (p.y * 3.0).cos();
    }
    write_mesh_glb(&assets.join("big.glb"), &mesh);
    let pins: Vec<(u32, f64, f64)> = [(15, 15, 0.2, 0.25), (45, 15, 0.8, 0.2), (30, 40, 0.5, 0.75)]
        .iter()
        .map(|&(x, y, u, v)| ((x + y * n) as u32, u, v))
        .collect();
    let extra = "    boundary: Free,\n    solver: (multilevel_above: 2000, multilevel_coarse: 600),\n";
    write_constraints(&assets.join("big.uvpin.ron"), Path::new("big.glb"), &pins, extra);
    let o = watch_once(&dir.0, &["--log", "json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &stderr(&o);
    let solved: Value = text
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .find(|l| l["event"] == "solved")
        .unwrap_or_else(|| panic!("no solved line: {text}"));
    assert_eq!(solved["status"], "reached", "{solved}");
    assert_eq!(solved["times"]["factor_ms"], 0.0, "{solved}");
    let (uvs, bad) = python_uvs(&dir.path("out/big.glb"), 0);
    assert_eq!(bad, 0);
    for (v, u, w) in pins {
        let got = uvs[v as usize];
        assert!((got[0] - u).abs() < 1e-6 && (got[1] - w).abs() < 1e-6, "{v}: {got:?}");
    }
}

#[test]
fn every_editor_save_pattern_gives_exactly_one_solve_of_the_final_content() {
    let dir = TempDir::new("watch-saves");
    let ron = make_assets(&dir.0);
    let out = dir.path("out/grid.glb");
    let d = Daemon::watch(&dir.0, &[]);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    assert_output(&out, 0.0);
    // Pictures beside the output, refreshed with it.
    for picture in ["out/grid.uv.png", "out/grid.render.png"] {
        let img = image::open(dir.path(picture)).unwrap_or_else(|e| panic!("{picture}: {e}"));
        assert_eq!((img.width(), img.height()), (512, 512), "{picture}");
    }
    let mut solves = 1;

    type Save = fn(&Path, &str);
    let patterns: [(&str, Save); 4] = [
        ("overwrite in place", |p, text| std::fs::write(p, text).unwrap()),
        ("temp file + rename", |p, text| {
            let tmp = p.with_file_name("grid.uvpin.ron.tmp~");
            std::fs::write(&tmp, text).unwrap();
            std::fs::rename(&tmp, p).unwrap();
        }),
        ("vim: backup by rename, write new, delete backup", |p, text| {
            let backup = p.with_file_name("grid.uvpin.ron~");
            std::fs::rename(p, &backup).unwrap();
            std::fs::write(p, text).unwrap();
            std::fs::remove_file(&backup).unwrap();
        }),
        ("several writes in one save", |p, text| {
            use std::io::Write;
            let mut f = std::fs::File::create(p).unwrap();
            let bytes = text.as_bytes();
            for chunk in bytes.chunks(bytes.len() / 3 + 1) {
                f.write_all(chunk).unwrap();
                f.flush().unwrap();
                std::thread::sleep(Duration::from_millis(15));
            }
        }),
    ];
    for (k, (name, save)) in patterns.iter().enumerate() {
        let s = 0.01 * (k + 1) as f64;
        save(&ron, &constraint_text(s));
        solves += 1;
        d.wait_count("solved", "grid.uvpin.ron", solves);
        std::thread::sleep(SETTLE);
        assert_eq!(
            d.count("solving", "grid.uvpin.ron"),
            solves,
            "{name}: expected exactly one solve; log:\n{}",
            d.dump()
        );
        assert_eq!(d.count("error", "grid.uvpin.ron"), 0, "{name}: {}", d.dump());
        assert_output(&out, s);
        // The edit reused the chart, its factorisation and the step-1 layout.
        let last = d.log().into_iter().rev().find(|l| l["event"] == "solving").unwrap();
        assert_eq!(last["reuse_step1"], true, "{name}");
    }

    // A save of identical content (touch, or an editor writing unchanged text) does nothing.
    let same = std::fs::read_to_string(&ron).unwrap();
    std::fs::write(&ron, same).unwrap();
    std::thread::sleep(SETTLE);
    assert_eq!(d.count("solving", "grid.uvpin.ron"), solves, "{}", d.dump());
    // The daemon never re-triggers on its own output or status file.
    assert_eq!(d.count("solving", ""), solves, "{}", d.dump());
}

#[test]
fn broken_edits_keep_the_last_output_and_the_daemon_recovers() {
    let dir = TempDir::new("watch-broken");
    let ron = make_assets(&dir.0);
    let out = dir.path("out/grid.glb");
    let status = dir.path("out/uvpin-status.json");
    let mut d = Daemon::watch(&dir.0, &[]);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    let good = std::fs::read(&out).unwrap();

    // Malformed RON: one error line with line:column, output untouched.
    let broken = constraint_text(0.02).replace("uv: (0.36", "uv: (0.36 0.5");
    std::fs::write(&ron, &broken).unwrap();
    d.wait_count("error", "grid.uvpin.ron", 1);
    let line = d.log().into_iter().rev().find(|l| l["event"] == "error").unwrap();
    let message = line["message"].as_str().unwrap();
    assert!(message.contains("grid.uvpin.ron:5:"), "{message}");
    std::thread::sleep(SETTLE);
    assert_eq!(
        std::fs::read(&out).unwrap(),
        good,
        "output changed during a broken edit"
    );
    let s: Value = serde_json::from_slice(&std::fs::read(&status).unwrap()).unwrap();
    let entry = &s["files"]["assets/grid.uvpin.ron"];
    assert_eq!(entry["state"], "error");
    assert!(entry["last_error"].as_str().unwrap().contains(":5:"));
    assert_eq!(entry["last_solve"]["status"], "reached", "the last good solve is kept");

    // A vertex id out of range: named with the range, output untouched.
    let bad_vertex = constraint_text(0.02).replace(&format!("vertex: {B}"), "vertex: 9999");
    std::fs::write(&ron, bad_vertex).unwrap();
    d.wait_count("error", "grid.uvpin.ron", 2);
    let line = d.log().into_iter().rev().find(|l| l["event"] == "error").unwrap();
    assert!(line["message"].as_str().unwrap().contains("9999"), "{line}");
    std::thread::sleep(SETTLE);
    assert_eq!(std::fs::read(&out).unwrap(), good);

    // Fixed: solved again, with the new targets.
    std::fs::write(&ron, constraint_text(0.02)).unwrap();
    d.wait_count("solved", "grid.uvpin.ron", 2);
    assert_output(&out, 0.02);

    // A corrupt asset: error, output kept; a deleted asset: the same; restored: solved.
    let asset = dir.path("assets/grid.glb");
    let glb = std::fs::read(&asset).unwrap();
    let after_fix = std::fs::read(&out).unwrap();
    std::fs::write(&asset, &glb[..glb.len() / 2]).unwrap();
    d.wait_count("error", "grid.uvpin.ron", 3);
    std::fs::remove_file(&asset).unwrap();
    d.wait_count("error", "grid.uvpin.ron", 4);
    std::thread::sleep(SETTLE);
    assert_eq!(std::fs::read(&out).unwrap(), after_fix);
    std::fs::write(&asset, &glb).unwrap();
    d.wait_count("solved", "grid.uvpin.ron", 3);
    assert_output(&out, 0.02);
    let last = d.log().into_iter().rev().find(|l| l["event"] == "solving").unwrap();
    assert_eq!(last["reuse_geometry"], false, "an asset change redoes everything");

    // SIGTERM: clean exit, status file in place.
    let status_code = d.terminate();
    assert!(status_code.success(), "exit status {status_code:?}");
    assert_eq!(d.count("stop", ""), 0, "stop lines have no file");
    assert!(d.log().iter().any(|l| l["event"] == "stop"));
}

#[test]
fn an_asset_edit_resolves_every_constraint_file_that_names_it() {
    let dir = TempDir::new("watch-asset");
    let ron = make_assets(&dir.0);
    let second = dir.path("assets/sub/other.uvpin.ron");
    std::fs::create_dir_all(second.parent().unwrap()).unwrap();
    write_constraints(&second, Path::new("../grid.glb"), &targets(0.03), "");
    let d = Daemon::watch(&dir.0, &["assets"]);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    d.wait_count("solved", "other.uvpin.ron", 1);
    assert_output(&dir.path("out/sub/other.glb"), 0.03);

    // Re-export the mesh, bent in 3D: both re-solve from scratch.
    let mut mesh = grid_mesh(N, N);
    for p in &mut mesh.positions {
        p.z = 0.3 * (p.x * 3.0).sin();
    }
    let tmp = dir.path("staged-grid.glb");
    write_mesh_glb(&tmp, &mesh);
    std::fs::rename(&tmp, dir.path("assets/grid.glb")).unwrap();
    d.wait_count("solved", "grid.uvpin.ron", 2);
    d.wait_count("solved", "other.uvpin.ron", 2);
    std::thread::sleep(SETTLE);
    assert_eq!(d.count("solving", "grid.uvpin.ron"), 2, "{}", d.dump());
    assert_eq!(d.count("solving", "other.uvpin.ron"), 2, "{}", d.dump());
    assert_output(&dir.path("out/grid.glb"), 0.0);
    let _ = ron;
}

#[test]
fn a_watched_folder_that_appears_later_is_picked_up() {
    let dir = TempDir::new("watch-later");
    let d = Daemon::watch(&dir.0, &["later/assets"]);
    let t0 = Instant::now();
    while !d.log().iter().any(|l| l["event"] == "waiting") {
        assert!(t0.elapsed() < WAIT, "{}", d.dump());
        std::thread::sleep(Duration::from_millis(20));
    }
    // Built elsewhere, then moved into place (as a checkout or sync would).
    let staging = TempDir::new("watch-later-staging");
    make_assets(&staging.0);
    std::fs::create_dir_all(dir.path("later")).unwrap();
    std::fs::rename(staging.path("assets"), dir.path("later/assets")).unwrap();
    d.wait_count("solved", "grid.uvpin.ron", 1);
    assert_output(&dir.path("out/grid.glb"), 0.0);
}

#[test]
fn in_place_mode_writes_the_watched_asset_and_never_retriggers_on_it() {
    let dir = TempDir::new("watch-inplace");
    let ron = make_assets(&dir.0);
    let asset = dir.path("assets/grid.glb");
    let d = Daemon::watch(&dir.0, &["--in-place"]);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    assert_output(&asset, 0.0);
    std::thread::sleep(SETTLE * 2);
    assert_eq!(
        d.count("solving", ""),
        1,
        "re-triggered on its own write:\n{}",
        d.dump()
    );
    std::fs::write(&ron, constraint_text(0.02)).unwrap();
    d.wait_count("solved", "grid.uvpin.ron", 2);
    std::thread::sleep(SETTLE * 2);
    assert_eq!(d.count("solving", ""), 2, "{}", d.dump());
    assert_output(&asset, 0.02);
    assert!(dir.path("uvpin-status.json").is_file());
}

#[test]
fn once_solves_everything_present_and_exits_with_a_summary() {
    let dir = TempDir::new("watch-once");
    make_assets(&dir.0);
    let o = watch_once(&dir.0, &["--log", "json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_output(&dir.path("out/grid.glb"), 0.0);
    // A second, broken constraint file: exit code 1, the good one still written.
    std::fs::write(
        dir.path("assets/bad.uvpin.ron"),
        "(asset: \"grid.glb\", constraints: [(vertex: 1)])",
    )
    .unwrap();
    let o = watch_once(&dir.0, &["--out", "out2"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("2 constraint files: 1 reached, 0 partial, 1 errors"),
        "{err}"
    );
    assert!(err.contains("bad.uvpin.ron:1:"), "{err}");
    assert!(dir.path("out2/grid.glb").is_file());
    assert!(!dir.path("out2/bad.glb").exists());
}

#[test]
fn with_many_watched_assets_only_the_edited_one_is_resolved() {
    let dir = TempDir::new("watch-many");
    let assets = dir.path("assets");
    std::fs::create_dir_all(&assets).unwrap();
    let n_files = 200;
    let small = 5;
    let centre = (2 + 2 * small) as u32;
    write_mesh_glb(&assets.join("g.glb"), &grid_mesh(small, small));
    for k in 0..n_files {
        let mesh_dir = assets.join(format!("m{k:03}"));
        std::fs::create_dir_all(&mesh_dir).unwrap();
        write_mesh_glb(&mesh_dir.join("g.glb"), &grid_mesh(small, small));
        write_constraints(
            &mesh_dir.join("g.uvpin.ron"),
            Path::new("g.glb"),
            &[(centre, 0.5, 0.5)],
            "",
        );
    }
    let d = Daemon::watch(&dir.0, &[]);
    d.wait_count("solved", "", n_files);
    let edited = assets.join("m117/g.uvpin.ron");
    write_constraints(&edited, Path::new("g.glb"), &[(centre, 0.52, 0.49)], "");
    d.wait_count("solved", "m117/g.uvpin.ron", 2);
    std::thread::sleep(SETTLE);
    assert_eq!(d.count("solving", ""), n_files + 1, "{}", d.dump());
    assert_eq!(d.count("solving", "m117/g.uvpin.ron"), 2);
}

#[test]
fn an_asset_outside_the_watched_folders_is_watched_too() {
    let dir = TempDir::new("watch-outside");
    let meshes = dir.path("meshes");
    std::fs::create_dir_all(&meshes).unwrap();
    write_mesh_glb(&meshes.join("grid.glb"), &grid_mesh(N, N));
    std::fs::create_dir_all(dir.path("assets")).unwrap();
    write_constraints(
        &dir.path("assets/grid.uvpin.ron"),
        Path::new("../meshes/grid.glb"),
        &targets(0.0),
        "",
    );
    // Not read unless allowed: an error that says so.
    let o = watch_once(&dir.0, &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("outside the folders uvpin may read"),
        "{}",
        stderr(&o)
    );
    let d = Daemon::watch(&dir.0, &["--allow", "meshes"]);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    // The daemon says when it has armed a watch on meshes/ (after the first solve).
    d.wait_count("asset_folder", "meshes", 1);
    let mut mesh = grid_mesh(N, N);
    for p in &mut mesh.positions {
        p.z = 0.2 * (p.y * 2.0).sin();
    }
    write_mesh_glb(&meshes.join("grid.glb"), &mesh);
    d.wait_count("solved", "grid.uvpin.ron", 2);
    assert_output(&dir.path("out/grid.glb"), 0.0);
}

#[test]
fn the_daemon_writes_what_the_command_line_writes() {
    let dir = TempDir::new("watch-same-as-cli");
    let ron = make_assets(&dir.0);
    // A landmark on the border with its target inside, and no boundary
    // named: the planner lays the chart out free (the square would refuse
    // it). The daemon's schedule must run the same plan as the command line.
    let marks = [(A, 0.50, 0.45), (1, 0.40, 0.30)];
    write_constraints(&ron, Path::new("grid.glb"), &marks, "");
    let cli_out = dir.path("cli.glb");
    let o = uvpin(&["solve", &ron.to_string_lossy(), "-o", &cli_out.to_string_lossy(), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let d = Daemon::watch(&dir.0, &[]);
    d.wait_count("solved", "grid.uvpin.ron", 1);
    let (cli, cli_bad) = python_uvs(&cli_out, 0);
    let (daemon, daemon_bad) = python_uvs(&dir.path("out").join("grid.glb"), 0);
    assert_eq!((cli_bad, daemon_bad), (0, 0), "{}", d.dump());
    assert_eq!(cli.len(), daemon.len());
    for (v, u, w) in marks {
        let got = daemon[v as usize];
        assert!(
            (got[0] - u).abs() < 1e-6 && (got[1] - w).abs() < 1e-6,
            "vertex {v}: {got:?}"
        );
    }
    let apart = cli
        .iter()
        .zip(&daemon)
        .map(|(a, b)| (a[0] - b[0]).abs().max((a[1] - b[1]).abs()))
        .fold(0.0, f64::max);
    assert!(
        apart < 1e-4,
        "the daemon's layout is {apart} from the command line's\n{}",
        d.dump()
    );
}
