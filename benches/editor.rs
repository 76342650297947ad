//! Drag-to-redraw latency of the landmark editor: `uvpin edit` on the
//! sample, on the 26k-vertex shared face and on it subdivided to 413k
//! vertices (previewed on its coarse level while dragging), a target marker dragged round
//! a small circle for a few seconds in headless Chromium (a pointer move
//! every 16 ms), the page timing each move to the redraw of its solve.
//! `cargo bench --bench editor [FILTER]`; needs Chromium and playwright-core
//! (as the browser test does).

mod common;
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use uvpin::param::xy_to_uv;
use uvpin::testing::{Rng, smooth_warp};

/// Seconds each drag lasts.
const DRAG_SECONDS: u32 = 5;

/// A constraint file in `dir` for the welded `mesh_file` midpoint-subdivided
/// `levels` times (written as `mesh.glb`), with `k` interior landmarks whose
/// targets are their step-1 positions on the unsubdivided mesh through a
/// smooth warp (a subdivision keeps the original vertices' ids and surface).
fn witnessed_file(dir: &Path, mesh_file: &Path, k: usize, levels: usize) -> PathBuf {
    let asset = uvpin::io::load_asset(mesh_file, None, 0, &Default::default()).expect("mesh");
    let mesh = uvpin::mesh::weld::weld(&asset.primitives).mesh;
    let step1 = uvpin::step_one(&mesh, None).expect("step 1");
    let layout = step1.vertex_layout();
    let interior = step1.interior_vertices();
    let mut rng = Rng::new(11);
    let mut lines = String::new();
    let mut chosen = Vec::new();
    while chosen.len() < k {
        let v = interior[rng.below(interior.len())];
        if chosen.contains(&v) {
            continue;
        }
        chosen.push(v);
        let uv = xy_to_uv(smooth_warp(layout[v as usize].expect("in the chart"), 0.05));
        lines += &format!("        (vertex: {v}, uv: ({:.6}, {:.6})),\n", uv.x, uv.y);
    }
    let fine = (0..levels).fold(mesh, |m, _| uvpin::testing::subdivide_midpoint(&m));
    let positions: Vec<[f32; 3]> = fine.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = fine.triangles.iter().flatten().copied().collect();
    let (json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "bench");
    uvpin::io::gltf_file::write_new_document(&json, &blob, &dir.join("mesh.glb")).expect("mesh.glb");
    let ron = dir.join("mesh.uvpin.ron");
    std::fs::write(
        &ron,
        format!("(\n    asset: \"mesh.glb\",\n    constraints: [\n{lines}    ],\n)\n"),
    )
    .unwrap();
    ron
}

/// Runs `uvpin edit` on `ron`, drags in Chromium; the page's measurements.
fn drag(ron: &Path) -> Value {
    let mut child = Command::new(env!("CARGO_BIN_EXE_uvpin"))
        .args([
            "edit",
            ron.to_str().unwrap(),
            "--addr",
            "127.0.0.1:0",
            "--log",
            "json",
            "--out",
        ])
        .arg(ron.parent().unwrap().join("out"))
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("uvpin edit");
    let stderr = child.stderr.take().expect("stderr");
    let mut lines = BufReader::new(stderr).lines();
    let url = lines
        .by_ref()
        .map_while(Result::ok)
        .find_map(|l| {
            serde_json::from_str::<Value>(&l).ok()?["url"]
                .as_str()
                .map(str::to_string)
        })
        .expect("the editor's address");
    std::thread::spawn(move || lines.for_each(drop));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/helpers/drag.mjs");
    let o = Command::new("node")
        .arg(script)
        .arg(&url)
        .arg(DRAG_SECONDS.to_string())
        .output()
        .expect("node");
    let _ = child.kill();
    let _ = child.wait();
    assert!(o.status.success(), "drag: {}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("the page's measurements")
}

fn percentile(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(((v.len() as f64 - 1.0) * p).round() as usize)
        .copied()
        .unwrap_or(f64::NAN)
}

/// A drag case: the sample as shipped, or a mesh with witnessed landmarks.
enum Case {
    Sample,
    Witnessed {
        mesh: PathBuf,
        landmarks: usize,
        subdivided: usize,
    },
}

impl Case {
    /// The case's files in `dir`: the constraint file and the mesh.
    fn make(&self, dir: &Path) -> (PathBuf, PathBuf) {
        match self {
            Case::Sample => {
                let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
                for f in ["face.glb", "face.uvpin.ron", "face-guide.png"] {
                    std::fs::copy(repo.join("assets").join(f), dir.join(f)).unwrap();
                }
                (dir.join("face.uvpin.ron"), dir.join("face.glb"))
            }
            Case::Witnessed {
                mesh,
                landmarks,
                subdivided,
            } => (witnessed_file(dir, mesh, *landmarks, *subdivided), dir.join("mesh.glb")),
        }
    }
}

fn main() {
    let filter = common::filter();
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    if !Path::new(&chromium).is_file() || !repo.join(".tools/node_modules/playwright-core").is_dir() {
        eprintln!("(Chromium or playwright-core missing: nothing to measure)");
        return;
    }
    let tmp = std::env::temp_dir().join(format!("uvpin-bench-editor-{}", std::process::id()));
    let shared_face = repo.join("../shared/meshes/face.glb");
    let cases = [
        ("sample (assets/face.glb), 12 landmarks", Case::Sample),
        (
            "shared face.glb, 24 landmarks (the spline path stalls)",
            Case::Witnessed {
                mesh: shared_face.clone(),
                landmarks: 24,
                subdivided: 0,
            },
        ),
        (
            "shared face.glb subdivided twice, the same 24 landmarks",
            Case::Witnessed {
                mesh: shared_face.clone(),
                landmarks: 24,
                subdivided: 2,
            },
        ),
    ];
    let mut rows = Vec::new();
    for (name, case) in &cases {
        if filter.as_ref().is_some_and(|f| !name.contains(f.as_str())) {
            continue;
        }
        if matches!(case, Case::Witnessed { mesh, .. } if !mesh.is_file()) {
            eprintln!("{name}: ../shared/meshes not found");
            continue;
        }
        let dir = tmp.join(rows.len().to_string());
        std::fs::create_dir_all(&dir).unwrap();
        let (ron, mesh) = case.make(&dir);
        let asset = uvpin::io::load_asset(&mesh, None, 0, &Default::default()).unwrap();
        let vertices: usize = asset.primitives.iter().map(|p| p.positions.len()).sum();
        let m = drag(&ron);
        let latencies: Vec<f64> = m["latencies"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(Value::as_f64)
            .collect();
        let seconds = m["seconds"].as_f64().unwrap();
        let per_second = m["previews"].as_f64().unwrap() / seconds;
        eprintln!(
            "{name}: {per_second:.1} redraws/s, median {:.0} ms",
            common::median(latencies.clone())
        );
        let shown = match m["level"].as_u64() {
            Some(0) | None => "the chart".to_string(),
            Some(n) => format!("coarse level, {n} vertices"),
        };
        rows.push(format!(
            "| {name} | {vertices} | {shown} | {:.0} | {per_second:.1} | {:.0} | {:.0} |",
            m["moves"].as_f64().unwrap() / seconds,
            common::median(latencies.clone()),
            percentile(latencies, 0.9),
        ));
    }
    let _ = std::fs::remove_dir_all(&tmp);
    let body = format!(
        "A target marker dragged round a circle of radius 0.015 (texture units) for {DRAG_SECONDS} s in headless \
         Chromium (software WebGL); the page solves every new position in memory (the newest drops the one \
         running) and redraws both views; a chart above 6,000 vertices is solved and drawn on its coarse level \
         while dragging (the chart itself on release). Latency: from a pointer move to the redraw of a solve that includes it \
         (median and 90th percentile). `cargo bench --bench editor`.\n\n\
         | case | vertices | shown while dragging | pointer moves/s | redraws/s | median ms | p90 ms |\n\
         |---|---:|---|---:|---:|---:|---:|\n{}\n",
        rows.join("\n")
    );
    common::publish("editor", "Editor drag-to-redraw", &body);
}
