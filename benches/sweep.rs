//! A 100-run sweep of the sample asset (4 settings × 25 target blends, with
//! thumbnails): runs per second in one process (one worker thread, one per
//! core), as 2 shards in 2 processes merged, and as Ray tasks on 2 local
//! workers; and the cost per run of the Python call against the CLI.
//! `cargo bench --bench sweep` prints the tables and writes them into
//! `docs/benchmarks.md`; timings are never asserted. The Python rows need a
//! Python with the uvpin wheel and Ray (`UVPIN_PYTHON`, else the
//! `.tools/venv` that `python/run-tests` makes).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use uvpin::sweep::{Progress, SweepOptions, run_sweep};

fn main() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("uvpin-bench-sweep-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for f in ["face.glb", "face.uvpin.ron"] {
        std::fs::copy(repo.join("assets").join(f), dir.join(f)).unwrap();
    }
    let sweep = dir.join("bench.sweep.ron");
    std::fs::write(
        &sweep,
        r#"(
    constraints: ["face.uvpin.ron"],
    output: "out",
    blend: (from: 0.0, to: 1.2, steps: 25),
    settings: [
        (name: "uvpin"),
        (name: "polish off", solver: (polish: false)),
        (name: "no completion", solver: (completion: Never, polish: false)),
        (name: "paper guard", solver: (guard: Paper)),
    ],
    thumbnail_size: 128,
)"#,
    )
    .unwrap();
    let mut body = String::from(
        "A 100-run sweep of `assets/face.uvpin.ron` (4 settings × 25 target blends 0…1.2, thumbnails).\n\n\
         | how | wall s | runs/s |\n|---|---:|---:|\n",
    );
    let mut summary = String::new();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    for jobs in [1, cores.max(2)] {
        let t0 = Instant::now();
        let outcome = run_sweep(
            &sweep,
            &SweepOptions {
                force: true,
                jobs: Some(jobs),
                progress: Progress::Quiet,
                shard: None,
            },
        )
        .unwrap();
        let s = t0.elapsed().as_secs_f64();
        assert_eq!(outcome.rows.len(), 100);
        body += &format!("| 1 process, {jobs} thread(s) | {s:.2} | {:.1} |\n", 100.0 / s);
        summary = outcome.summary;
    }
    body += &shards_row(&sweep, 2);
    let python = python_with_uvpin();
    body += &ray_row(python.as_deref(), &sweep, 2);
    body += &format!("\nPer setting:\n\n{summary}");
    body += &overhead_table(python.as_deref(), &dir);
    common::publish("sweep", "Sweeps", &body);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The grid as `n` shards, each a `uvpin sweep --shard I/n --jobs 1`
/// process, all at once, then the merge: wall time from the first start to
/// the merged files.
fn shards_row(sweep: &Path, n: usize) -> String {
    let uvpin = env!("CARGO_BIN_EXE_uvpin");
    let _ = std::fs::remove_dir_all(sweep.with_file_name("out"));
    let t0 = Instant::now();
    let children: Vec<_> = (0..n)
        .map(|i| {
            Command::new(uvpin)
                .arg("sweep")
                .arg(sweep)
                .args(["--shard", &format!("{i}/{n}"), "--jobs", "1", "--quiet"])
                .spawn()
                .expect("spawn a shard")
        })
        .collect();
    for mut child in children {
        assert!(child.wait().expect("a shard").success());
    }
    let merged = Command::new(uvpin)
        .arg("sweep")
        .arg(sweep)
        .arg("--merge")
        .output()
        .expect("merge");
    assert!(merged.status.success(), "{}", String::from_utf8_lossy(&merged.stderr));
    let s = t0.elapsed().as_secs_f64();
    format!(
        "| {n} shards (processes, 1 thread each), merged | {s:.2} | {:.1} |\n",
        100.0 / s
    )
}

/// A Python that imports uvpin and ray: `UVPIN_PYTHON`, else `.tools/venv`.
fn python_with_uvpin() -> Result<PathBuf, String> {
    let python = std::env::var_os("UVPIN_PYTHON").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join(".tools/venv/bin/python"),
        PathBuf::from,
    );
    let ok = Command::new(&python)
        .args(["-c", "import uvpin._native, ray"])
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        Ok(python)
    } else {
        Err(format!(
            "no Python with uvpin and ray at {} (python/run-tests makes one)",
            python.display()
        ))
    }
}

fn helper(python: &Path, args: &[&str]) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/helpers/sweep_python.py");
    let out = Command::new(python)
        .arg(script)
        .args(args)
        .output()
        .expect("run the Python helper");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("the helper's JSON")
}

/// The grid as Ray tasks on a local Ray of `workers` CPUs (started before
/// the clock starts; its start time is given apart).
fn ray_row(python: Result<&Path, &String>, sweep: &Path, workers: usize) -> String {
    let python = match python {
        Ok(p) => p,
        Err(why) => return format!("| Ray, {workers} workers | not measured: {why} | |\n"),
    };
    let r = helper(python, &["ray", sweep.to_str().unwrap(), &workers.to_string()]);
    assert_eq!(r["runs"], 100);
    let s = r["sweep_s"].as_f64().unwrap();
    format!(
        "| Ray tasks, {workers} local workers (Ray's start, {:.1} s, apart) | {s:.2} | {:.1} |\n",
        r["start_s"].as_f64().unwrap(),
        100.0 / s
    )
}

/// One solve of the sample, per run: `uvpin solve` as a process against the
/// Python calls, interleaved round by round, with the library's own time.
fn overhead_table(python: Result<&Path, &String>, dir: &Path) -> String {
    let python = match python {
        Ok(p) => p,
        Err(why) => return format!("\nThe Python call against the CLI: not measured: {why}.\n"),
    };
    let out = dir.join("overhead");
    std::fs::create_dir_all(&out).unwrap();
    let constraints = dir.join("face.uvpin.ron");
    let r = helper(
        python,
        &[
            "overhead",
            constraints.to_str().unwrap(),
            env!("CARGO_BIN_EXE_uvpin"),
            "41",
            out.to_str().unwrap(),
        ],
    );
    let ms = |k: &str| r[k].as_f64().unwrap();
    let lib = ms("library");
    let row = |name: &str, k: &str| format!("| {name} | {:.1} | {:+.1} |\n", ms(k), ms(k) - lib);
    format!(
        "\nOne solve of the sample (`assets/face.uvpin.ron`, 12 landmarks, polished), per run, \
         medians of 41 interleaved rounds:\n\n| call | ms | over the library's own time |\n|---|---:|---:|\n\
         | the library's own time (report `total_ms`) | {lib:.1} | |\n{}{}{}",
        row("`uvpin.solve_file` (Python, writes the .glb)", "solve_file"),
        row("`uvpin.solve` (Python, numpy arrays in and out)", "solve"),
        row("`uvpin solve` (a process, writes the .glb)", "cli"),
    )
}
