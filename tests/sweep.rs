//! `uvpin sweep` end to end, the pictures (`--preview`, `--render`), and the
//! paper's guard counted as folded.

mod common;

use common::*;
use std::path::Path;
use uvpin::preview::layout::uv_to_pixel;
use uvpin::preview::{REACHED_COLOUR, UNREACHED_COLOUR};
use uvpin::testing::grid_mesh;

const N: usize = 12;
const ROW: u32 = (N / 2 * N) as u32;
const A: u32 = ROW + (N / 2) as u32 - 2;
const B: u32 = ROW + (N / 2) as u32 + 2;

/// uv of grid vertex `v` in the step-1 layout of a flat grid (u = x, v = 1 − y).
fn grid_uv(v: u32) -> (f64, f64) {
    let (i, j) = (v as usize % N, v as usize / N);
    (i as f64 / (N - 1) as f64, 1.0 - j as f64 / (N - 1) as f64)
}

/// A grid asset and two constraint files: `easy` (two small moves) and
/// `swap` (A and B asked to trade places, the paper's Fig. 8 crossing).
fn setup(dir: &TempDir) {
    write_mesh_glb(&dir.path("grid.glb"), &grid_mesh(N, N));
    let (a, b) = (grid_uv(A), grid_uv(B));
    write_constraints(
        &dir.path("easy.uvpin.ron"),
        Path::new("grid.glb"),
        &[(A, a.0 + 0.03, a.1 - 0.02), (B, b.0 - 0.02, b.1 + 0.03)],
        "",
    );
    write_swap(&dir.path("swap.uvpin.ron"), "");
}

/// A constraint file asking A and B to trade places, with `extra` fields.
fn write_swap(path: &Path, extra: &str) {
    let (a, b) = (grid_uv(A), grid_uv(B));
    write_constraints(path, Path::new("grid.glb"), &[(A, b.0, b.1), (B, a.0, a.1)], extra);
}

fn sweep_file(dir: &TempDir, text: &str) -> std::path::PathBuf {
    let p = dir.path("test.sweep.ron");
    std::fs::write(&p, text).unwrap();
    p
}

const SWEEP: &str = r#"(
    constraints: ["*.uvpin.ron"],
    output: "results",
    blend: (from: 0.0, to: 1.0, steps: 3),
    jitter: (seed: 3, amplitude: 0.01, samples: 2),
    settings: [
        (name: "uvpin"),
        (name: "paper guard", solver: (guard: Paper)),
    ],
    thumbnail_size: 64,
)"#;

fn read_csv(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn a_small_sweep_runs_end_to_end_and_reruns_deterministically() {
    let dir = TempDir::new("sweep");
    setup(&dir);
    let sweep = sweep_file(&dir, SWEEP);
    let o = uvpin(&["sweep", sweep.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // 2 files × 2 settings × 2 jitter samples × 3 blends.
    let csv = read_csv(&dir.path("results/runs.csv"));
    assert_eq!(csv[0], uvpin::sweep::COLUMNS.map(String::from).to_vec());
    assert_eq!(csv.len(), 1 + 24);
    let col = |name: &str| uvpin::sweep::COLUMNS.iter().position(|c| *c == name).unwrap();
    let ids: std::collections::HashSet<&String> = csv[1..].iter().map(|r| &r[col("id")]).collect();
    assert_eq!(ids.len(), 24, "run ids are unique");
    for r in &csv[1..] {
        assert!(
            ["reached", "partial", "folded"].contains(&r[col("status")].as_str()),
            "{r:?}"
        );
        if r[col("setting")] == "uvpin" {
            assert_eq!(r[col("flipped")], "0", "{r:?}");
        }
        if r[col("constraint_file")] == "easy.uvpin.ron" && r[col("setting")] == "uvpin" {
            assert_eq!(r[col("status")], "reached", "{r:?}");
        }
    }
    // The summary and the pictures.
    let summary = stdout(&o);
    assert!(
        summary.contains("| uvpin | 12 |") && summary.contains("| paper guard | 12 |"),
        "{summary}"
    );
    assert!(dir.path("results/summary.md").is_file());
    let sheet = image::open(dir.path("results/contact_sheet.png")).unwrap();
    // Row labels on the left, column labels above, the bars' key below (12 px lines).
    let labels = sheet.width() - (3 * (64 + 4) + 4);
    assert!(
        (8 * 8..=45 * 8).contains(&labels),
        "one column per blend value, then labels: {labels}"
    );
    assert_eq!(
        sheet.height(),
        12 + 8 * (64 + 6 + 4) + 4 + 12 + 4,
        "one row per file, setting and sample"
    );
    let thumbs = std::fs::read_dir(dir.path("results/thumbs")).unwrap().count();
    assert_eq!(thumbs, 24);
    let jsonl = std::fs::read_to_string(dir.path("results/runs.jsonl")).unwrap();
    assert_eq!(jsonl.lines().count(), 24);

    // Again: everything is already there, nothing runs, the files are identical.
    let before = std::fs::read_to_string(dir.path("results/runs.csv")).unwrap();
    let o = uvpin(&["sweep", sweep.to_str().unwrap()]);
    assert!(stderr(&o).contains("0 solved now, 24 already done"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(dir.path("results/runs.csv")).unwrap(), before);

    // Forced: every run again, every column but the time identical.
    let o = uvpin(&["sweep", sweep.to_str().unwrap(), "--force", "--quiet"]);
    assert!(o.status.success());
    let again = read_csv(&dir.path("results/runs.csv"));
    let strip = |rows: &[Vec<String>]| -> Vec<Vec<String>> {
        rows.iter()
            .map(|r| {
                r.iter()
                    .enumerate()
                    .filter(|(i, _)| *i != col("time_ms"))
                    .map(|(_, v)| v.clone())
                    .collect()
            })
            .collect()
    };
    assert_eq!(strip(&again), strip(&csv));
}

#[test]
fn the_paper_guard_on_the_crossing_pair_is_counted_as_folded_and_never_written() {
    let dir = TempDir::new("sweep-paper");
    setup(&dir);
    let sweep = sweep_file(
        &dir,
        r#"(
            constraints: ["swap.uvpin.ron"],
            output: "results",
            settings: [(name: "uvpin"), (name: "paper guard", solver: (guard: Paper))],
            thumbnails: false,
        )"#,
    );
    let o = uvpin(&["sweep", sweep.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(dir.path("results/runs.jsonl")).unwrap();
    let rows: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0]["status"], "reached", "{}", rows[0]);
    assert_eq!(rows[0]["flipped"], 0);
    assert_eq!(rows[1]["status"], "folded", "{}", rows[1]);
    assert!(rows[1]["flipped"].as_u64().unwrap() > 0);
    assert!(
        stdout(&o).contains("| paper guard | 1 | 0 | 0 | 1 | 0 |"),
        "{}",
        stdout(&o)
    );

    // The same setting through `uvpin solve`: an error, nothing written.
    let ron = dir.path("swap-paper.uvpin.ron");
    write_swap(&ron, "    solver: (guard: Paper),\n");
    let out = dir.path("never.glb");
    let (o, report) = solve_json(&ron, &out);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(report["message"].as_str().unwrap().contains("folded"), "{report}");
    assert!(!out.exists());
}

#[test]
fn preview_pictures_decode_at_their_size_and_mark_the_constraints() {
    let dir = TempDir::new("preview");
    setup(&dir);
    let (uv, render) = (dir.path("uv.png"), dir.path("render.png"));
    let o = uvpin(&[
        "solve",
        dir.path("easy.uvpin.ron").to_str().unwrap(),
        "--preview",
        uv.to_str().unwrap(),
        "--render",
        render.to_str().unwrap(),
        "--preview-size",
        "400",
        "--report",
        "-",
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let img = image::open(&uv).unwrap().to_rgba8();
    assert_eq!((img.width(), img.height()), (400, 400));
    for c in report["constraints"].as_array().unwrap() {
        let t = glam::DVec2::new(c["target"][0].as_f64().unwrap(), c["target"][1].as_f64().unwrap());
        let (x, y) = uv_to_pixel(t, 400);
        let p = img.get_pixel(x as u32, y as u32).0;
        assert_eq!([p[0], p[1], p[2]], REACHED_COLOUR, "marker at target {t}");
    }
    let r = image::open(&render).unwrap().to_rgba8();
    assert_eq!((r.width(), r.height()), (400, 400));
    assert!(r.pixels().filter(|p| p.0 != [255, 255, 255, 255]).count() > 400 * 400 / 2);

    // An unreached constraint (the crossing without completion) is marked red where it stopped.
    let ron = dir.path("stuck.uvpin.ron");
    write_swap(&ron, "    solver: (completion: Never),\n    boundary: Square,\n");
    let o = uvpin(&[
        "solve",
        ron.to_str().unwrap(),
        "--preview",
        uv.to_str().unwrap(),
        "--report",
        "-",
        "-q",
        "--preview-size",
        "400",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let img = image::open(&uv).unwrap().to_rgba8();
    for c in report["constraints"].as_array().unwrap() {
        assert_eq!(c["reached"], false);
        let r = glam::DVec2::new(c["result"][0].as_f64().unwrap(), c["result"][1].as_f64().unwrap());
        let (x, y) = uv_to_pixel(r, 400);
        let p = img.get_pixel(x as u32, y as u32).0;
        assert_eq!([p[0], p[1], p[2]], UNREACHED_COLOUR, "marker at result {r}");
    }
}

#[test]
fn a_bare_sweep_file_name_finds_its_files_and_a_bad_setting_is_named() {
    let dir = TempDir::new("sweep-bare");
    setup(&dir);
    let text = r#"(constraints: ["*.uvpin.ron"], output: "results", thumbnails: false)"#;
    std::fs::write(dir.path("g.sweep.ron"), text).unwrap();
    let run = |name: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_uvpin"))
            .args(["sweep", name, "--quiet"])
            .current_dir(&dir.0)
            .output()
            .unwrap()
    };
    let o = run("g.sweep.ron");
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = std::fs::read_to_string(dir.path("results/runs.jsonl")).unwrap();
    assert_eq!(rows.lines().count(), 2, "easy and swap: {rows}");
    // A NaN or negative weight is an error that names the setting and the field.
    let bad = r#"(constraints: ["easy.uvpin.ron"], output: "r2", settings: [(name: "heavy", solver: (initial_weight: -1.0))])"#;
    std::fs::write(dir.path("bad.sweep.ron"), bad).unwrap();
    let o = run("bad.sweep.ron");
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("\"heavy\"") && err.contains("solver.initial_weight"),
        "{err}"
    );
    assert!(!dir.path("r2").exists(), "nothing written");
}

/// Every CSV row with its `time_ms` column left out.
fn without_time(rows: &[Vec<String>]) -> Vec<Vec<String>> {
    let time = uvpin::sweep::COLUMNS.iter().position(|c| *c == "time_ms").unwrap();
    rows.iter()
        .map(|r| {
            r.iter()
                .enumerate()
                .filter(|(i, _)| *i != time)
                .map(|(_, v)| v.clone())
                .collect()
        })
        .collect()
}

#[test]
fn shards_run_as_separate_processes_and_merged_give_the_rows_of_one_machine() {
    let dir = TempDir::new("sweep-shards");
    setup(&dir);
    let one = sweep_file(&dir, SWEEP);
    let sharded = dir.path("sharded.sweep.ron");
    std::fs::write(&sharded, SWEEP.replace("\"results\"", "\"sharded\"")).unwrap();
    let o = uvpin(&["sweep", one.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));

    // Two of three shards, at once, as a job array would start them.
    let s = sharded.to_str().unwrap();
    let spawn = |shard: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_uvpin"))
            .args(["sweep", s, "--shard", shard, "--quiet"])
            .output()
    };
    let (a, b) = std::thread::scope(|scope| {
        let a = scope.spawn(|| spawn("0/3"));
        let b = scope.spawn(|| spawn("1/3"));
        (a.join().unwrap().unwrap(), b.join().unwrap().unwrap())
    });
    assert!(a.status.success() && b.status.success(), "{}{}", stderr(&a), stderr(&b));
    assert_eq!(read_csv(&dir.path("sharded/shards/0-of-3/runs.csv")).len(), 1 + 8);
    // A merge with a shard missing names it and writes nothing.
    let o = uvpin(&["sweep", s, "--merge"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("shard 2/3 has no row for 8 run(s)"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path("sharded/runs.csv").exists());

    let c = spawn("2/3").unwrap();
    assert!(c.status.success(), "{}", stderr(&c));
    let o = uvpin(&["sweep", s, "--merge"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let merged = read_csv(&dir.path("sharded/runs.csv"));
    let single = read_csv(&dir.path("results/runs.csv"));
    assert_eq!(merged.len(), 1 + 24);
    assert_eq!(
        without_time(&merged),
        without_time(&single),
        "the same rows but the time"
    );
    let sheet = |p: &str| image::open(dir.path(p)).unwrap().to_rgba8();
    assert!(
        sheet("sharded/contact_sheet.png") == sheet("results/contact_sheet.png"),
        "the same contact sheet"
    );
    assert_eq!(std::fs::read_dir(dir.path("sharded/thumbs")).unwrap().count(), 24);
}

#[test]
fn bad_shards_and_mixed_splits_are_refused_by_name() {
    let dir = TempDir::new("sweep-bad-shards");
    setup(&dir);
    let sweep = sweep_file(&dir, SWEEP);
    let s = sweep.to_str().unwrap();
    for (given, says) in [
        ("3/3", "numbered 0 to 2"),
        ("1/0", "between 1 and"),
        ("x/2", "\"x\" is not a whole number"),
        ("2", "expected I/N"),
    ] {
        let o = uvpin(&["sweep", s, "--shard", given, "--quiet"]);
        assert_eq!(o.status.code(), Some(1), "{given}");
        assert!(stderr(&o).contains(says), "{given}: {}", stderr(&o));
    }
    assert!(!dir.path("results").exists(), "a refused shard writes nothing");
    let o = uvpin(&["sweep", s, "--merge"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--shard I/N"), "{}", stderr(&o));
    for shard in ["0/2", "0/3"] {
        assert!(uvpin(&["sweep", s, "--shard", shard, "--quiet"]).status.success());
    }
    let o = uvpin(&["sweep", s, "--merge"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("shards of different counts ([2, 3])"),
        "{}",
        stderr(&o)
    );
}
