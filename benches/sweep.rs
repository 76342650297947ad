//! A 100-run sweep of the sample asset (4 settings × 25 target blends, with
//! thumbnails): runs per second with 1 and 2 worker threads.
//! `cargo bench --bench sweep` prints a table; timings are never asserted.

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
    println!("\n100-run sweep of assets/face.uvpin.ron (4 settings x 25 blends 0..1.2, thumbnails)");
    println!("| threads | wall s | runs/s |");
    println!("|---:|---:|---:|");
    let mut summary = String::new();
    for jobs in [1, 2] {
        let t0 = Instant::now();
        let outcome = run_sweep(
            &sweep,
            &SweepOptions {
                force: true,
                jobs: Some(jobs),
                progress: Progress::Quiet,
            },
        )
        .unwrap();
        let s = t0.elapsed().as_secs_f64();
        assert_eq!(outcome.rows.len(), 100);
        println!("| {jobs} | {s:.2} | {:.1} |", 100.0 / s);
        summary = outcome.summary;
    }
    println!("\n{summary}");
    let _ = std::fs::remove_dir_all(&dir);
}
