//! The photo step end to end: `uvpin photo HEAD PHOTO -o OUT.glb` on the
//! shared heads and the sample mask, with scikit-image's `astronaut` photo:
//! wall time (median of runs), what was kept, the solve's status and the
//! check (the photo's landmarks against the textured render's).
//! `cargo bench --bench photo [FILTER]`; needs the photo environment
//! (`UVPIN_PYTHON`, default `.tools/photo/bin/python`, made by
//! `python/run-tests`) and `../shared/meshes`.

mod common;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const RUNS: usize = 3;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The photo environment's interpreter.
fn python() -> PathBuf {
    std::env::var_os("UVPIN_PYTHON").map_or_else(|| repo().join(".tools/photo/bin/python"), PathBuf::from)
}

/// The astronaut photo, written by scikit-image into `dir`.
fn astronaut(python: &Path, dir: &Path) -> PathBuf {
    let path = dir.join("astronaut.png");
    let script = format!(
        "import skimage.data as d; from PIL import Image; Image.fromarray(d.astronaut()).save({:?})",
        path.display().to_string()
    );
    let ok = Command::new(python).args(["-c", &script]).status();
    assert!(ok.is_ok_and(|s| s.success()), "{}: no scikit-image", python.display());
    path
}

/// One run: seconds and the report.
fn run(python: &Path, head: &Path, photo: &Path, dir: &Path) -> (f64, Value) {
    let (out, report) = (dir.join("out.glb"), dir.join("out.json"));
    let t0 = Instant::now();
    let status = Command::new(env!("CARGO_BIN_EXE_uvpin"))
        .env("UVPIN_PYTHON", python)
        .arg("photo")
        .args([head, photo])
        .arg("-o")
        .arg(&out)
        .arg("--report")
        .arg(&report)
        .arg("-q")
        .status()
        .expect("uvpin photo");
    let seconds = t0.elapsed().as_secs_f64();
    assert!(
        status.code().is_some_and(|c| c != 1),
        "{}: exit {status}",
        head.display()
    );
    let report = serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("JSON");
    (seconds, report)
}

fn vertices(head: &Path) -> usize {
    let asset = uvpin::io::load_asset(head, None, 0, &Default::default()).expect("mesh");
    uvpin::mesh::weld::weld(&asset.primitives).mesh.positions.len()
}

fn main() {
    let python = python();
    if !python.exists() {
        eprintln!(
            "{} is absent: run python/run-tests once (it makes .tools/photo), or set UVPIN_PYTHON",
            python.display()
        );
        std::process::exit(1);
    }
    let dir = std::env::temp_dir().join(format!("uvpin-bench-photo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let photo = astronaut(&python, &dir);
    let shared = repo().join("../shared/meshes");
    let heads = [
        ("sample mask", repo().join("assets/face.glb")),
        ("shared face", shared.join("face.glb")),
        ("ogre (scan, 44 pieces)", shared.join("ogre.obj")),
    ];
    let mut body = String::from(
        "| head | vertices | time (median) | kept / dropped | status | check: median px | check: worst px |\n\
         |---|---:|---:|---:|---|---:|---:|\n",
    );
    for (name, head) in heads {
        if common::filter().is_some_and(|f| !name.contains(&f)) {
            continue;
        }
        if !head.is_file() {
            eprintln!("{} is absent: row skipped", head.display());
            continue;
        }
        let runs: Vec<(f64, Value)> = (0..RUNS).map(|_| run(&python, &head, &photo, &dir)).collect();
        let report = &runs[0].1;
        let info = &report["photo"];
        body += &format!(
            "| {name} | {} | {:.2} s | {} / {} | {} | {:.1} | {:.1} |\n",
            vertices(&head),
            common::median(runs.iter().map(|r| r.0).collect()),
            info["kept"].as_array().map_or(0, Vec::len),
            info["dropped"].as_object().map_or(0, serde_json::Map::len),
            report["status"].as_str().unwrap_or("?"),
            info["check"]["median_px"].as_f64().unwrap_or(f64::NAN),
            info["check"]["worst_px"].as_f64().unwrap_or(f64::NAN),
        );
    }
    body += &format!(
        "\nPhoto: scikit-image's `astronaut` (512 × 512). Time: the whole command (Python start, MediaPipe, \
         the facing search, the solve, the check), median of {RUNS} runs."
    );
    common::publish("photo", "A photo onto a head (`uvpin photo`)", &body);
    let _ = std::fs::remove_dir_all(&dir);
}
