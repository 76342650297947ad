//! A 100-run sweep of the sample asset (4 settings × 25 target blends, with
//! thumbnails): runs per second with one worker thread and with one per core.
//! `cargo bench --bench sweep` prints a table and writes it into
//! `docs/benchmarks.md`; timings are never asserted.

mod common;

use std::path::Path;
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
         | threads | wall s | runs/s |\n|---:|---:|---:|\n",
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
        body += &format!("| {jobs} | {s:.2} | {:.1} |\n", 100.0 / s);
        summary = outcome.summary;
    }
    body += &format!("\nPer setting:\n\n{summary}");
    common::publish("sweep", "Sweeps", &body);
    let _ = std::fs::remove_dir_all(&dir);
}
