//! Hot-reload benchmark of `uvpin watch` (the release binary, a real file
//! watcher): latency from a constraint file's rename to the output's rename,
//! median over 25 edits, for the sample asset and a 100k-vertex mesh; idle
//! CPU over 10 s; 200 watched assets with one edited.
//!
//! `cargo bench --bench watch` prints a table and writes it into
//! `docs/benchmarks.md`. Not a test: timings on a shared machine are noisy,
//! so they are quoted as medians, never asserted.

mod common;

use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use uvpin::mesh::TriMesh;
use uvpin::testing::grid_mesh;

const DEBOUNCE_MS: u64 = 100;
const EDITS: usize = 25;

struct Daemon {
    child: Child,
    lines: Arc<Mutex<Vec<Value>>>,
}

impl Daemon {
    fn start(cwd: &Path) -> Daemon {
        let mut child = Command::new(env!("CARGO_BIN_EXE_uvpin"))
            .args(["watch", "--log", "json", "--debounce-ms", &DEBOUNCE_MS.to_string()])
            .current_dir(cwd)
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn");
        let lines = Arc::new(Mutex::new(Vec::new()));
        let sink = lines.clone();
        let stderr = child.stderr.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Ok(v) = serde_json::from_str(&line) {
                    sink.lock().unwrap().push(v);
                }
            }
        });
        Daemon { child, lines }
    }

    fn count(&self, event: &str) -> usize {
        self.lines
            .lock()
            .unwrap()
            .iter()
            .filter(|l| l["event"] == event)
            .count()
    }

    fn wait(&self, event: &str, n: usize) {
        let t0 = Instant::now();
        while self.count(event) < n {
            assert!(t0.elapsed() < Duration::from_secs(600), "timed out waiting for {event}");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn last(&self, event: &str) -> Value {
        self.lines
            .lock()
            .unwrap()
            .iter()
            .rev()
            .find(|l| l["event"] == event)
            .cloned()
            .unwrap()
    }

    /// CPU seconds used so far (user + system), from /proc.
    fn cpu_seconds(&self) -> f64 {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.child.id())).unwrap();
        let after = &stat[stat.rfind(')').unwrap() + 2..];
        let fields: Vec<&str> = after.split_whitespace().collect();
        let ticks: f64 = fields[11].parse::<f64>().unwrap() + fields[12].parse::<f64>().unwrap();
        ticks / 100.0
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

use common::median;

fn write_glb(path: &Path, mesh: &TriMesh) {
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "bench");
    uvpin::io::gltf_file::write_new_document(&json, &blob, path).unwrap();
}

/// Saves `text` as `path` the way most editors do (temp file + rename) and
/// returns the time from the rename to the rename of `output`.
fn timed_save(path: &Path, text: &str, output: &Path) -> f64 {
    let before = std::fs::metadata(output).map(|m| m.ino()).unwrap_or(0);
    let tmp = path.with_extension("ron.tmp");
    std::fs::write(&tmp, text).unwrap();
    let t0 = Instant::now();
    std::fs::rename(&tmp, path).unwrap();
    loop {
        if std::fs::metadata(output).is_ok_and(|m| m.ino() != before) {
            return t0.elapsed().as_secs_f64() * 1e3;
        }
        assert!(t0.elapsed() < Duration::from_secs(600), "no output");
        std::thread::sleep(Duration::from_micros(200));
    }
}

struct Row {
    name: String,
    vertices: usize,
    latency: f64,
    solve: f64,
    reached: usize,
}

/// Runs `EDITS` timed edits of `ron` (texts from `text_of(k)`).
fn hot_reload(
    name: &str,
    dir: &Path,
    ron: &Path,
    output: &Path,
    vertices: usize,
    text_of: impl Fn(usize) -> String,
) -> (Row, Daemon) {
    let d = Daemon::start(dir);
    d.wait("solved", 1);
    let mut latencies = Vec::new();
    let mut solves = Vec::new();
    let mut reached = 0;
    for k in 0..EDITS {
        latencies.push(timed_save(ron, &text_of(k + 1), output));
        d.wait("solved", k + 2);
        let last = d.last("solved");
        solves.push(last["time_ms"].as_f64().unwrap());
        reached += usize::from(last["status"] == "reached");
        std::thread::sleep(Duration::from_millis(50));
    }
    let row = Row {
        name: name.into(),
        vertices,
        latency: median(latencies),
        solve: median(solves),
        reached,
    };
    (row, d)
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("uvpin-bench-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("assets")).unwrap();
    dir
}

/// The sample asset: the nose tip's target nudged back and forth; then the
/// daemon's idle CPU over 10 s (% of one core).
fn sample_case(repo: &Path) -> (Row, f64) {
    let dir = temp("sample");
    std::fs::copy(repo.join("assets/face.glb"), dir.join("assets/face.glb")).unwrap();
    let original = std::fs::read_to_string(repo.join("assets/face.uvpin.ron")).unwrap();
    let ron = dir.join("assets/face.uvpin.ron");
    std::fs::write(&ron, &original).unwrap();
    let vertices = uvpin::io::load_asset(&repo.join("assets/face.glb"), None, 0, &Default::default())
        .unwrap()
        .primitives[0]
        .positions
        .len();
    let (row, sample) = hot_reload(
        "sample (face.glb)",
        &dir,
        &ron,
        &dir.join("out/face.glb"),
        vertices,
        |k| nudged(&original, "nose tip", 0.004 * ((k % 5) as f64 - 2.0)),
    );
    std::thread::sleep(Duration::from_millis(500));
    let c0 = sample.cpu_seconds();
    std::thread::sleep(Duration::from_secs(10));
    let idle_cpu = (sample.cpu_seconds() - c0) / 10.0 * 100.0;
    (row, idle_cpu)
}

/// `text` with the target of the constraint labelled `label` moved by
/// `du` along u; the edit must change the text (an unchanged file is not
/// solved again, and its save would wait for an output that never comes).
fn nudged(text: &str, label: &str, du: f64) -> String {
    let lines: Vec<String> = text
        .lines()
        .map(|line| {
            let Some(at) = line.find("uv: (").filter(|_| line.contains(&format!("\"{label}\""))) else {
                return line.to_string();
            };
            let open = at + "uv: (".len();
            let close = open + line[open..].find(')').expect("a closed uv");
            let (u, v) = line[open..close].split_once(',').expect("u, v");
            let u: f64 = u.trim().parse().expect("a number");
            format!("{}{:.3},{}{}", &line[..open], u + du, v, &line[close..])
        })
        .collect();
    assert!(
        text.lines()
            .any(|l| l.contains(&format!("\"{label}\"")) && l.contains("uv: (")),
        "no constraint labelled {label}"
    );
    lines.join("\n") + "\n"
}

/// A 100k-vertex bent grid with 8 constraints, one of them nudged.
fn big_case() -> Row {
    let n = 317;
    let dir = temp("100k");
    let mut mesh = grid_mesh(n, n);
    for p in &mut mesh.positions {
        p.z = 0.15 * (p.x * 5.0).sin() * (p.y * 3.0).cos();
    }
    write_glb(&dir.join("assets/big.glb"), &mesh);
    let ron = dir.join("assets/big.uvpin.ron");
    let lattice = [
        (80, 80),
        (160, 80),
        (240, 80),
        (80, 160),
        (240, 160),
        (80, 240),
        (160, 240),
        (240, 240),
    ];
    let text_of = |k: usize| {
        let s = 0.003 * ((k % 5) as f64 - 2.0);
        let mut t = String::from("(\n    asset: \"big.glb\",\n    constraints: [\n");
        for (i, &(x, y)) in lattice.iter().enumerate() {
            let v = x + y * n;
            let (u, w) = (x as f64 / (n - 1) as f64, 1.0 - y as f64 / (n - 1) as f64);
            let d = if i == 0 { s } else { 0.0 };
            t += &format!("        (vertex: {v}, uv: ({:.5}, {:.5})),\n", u + d, w);
        }
        t + "    ],\n)\n"
    };
    std::fs::write(&ron, text_of(0)).unwrap();
    hot_reload("100k-vertex grid", &dir, &ron, &dir.join("out/big.glb"), n * n, text_of).0
}

/// 200 watched assets, one edited: seconds until all are solved at start,
/// re-solves after the edit, and its latency (ms).
fn many_case() -> (f64, usize, f64) {
    let dir = temp("many");
    let small = 20;
    let centre = (10 + 10 * small) as u32;
    for k in 0..200 {
        let sub = dir.join(format!("assets/m{k:03}"));
        std::fs::create_dir_all(&sub).unwrap();
        write_glb(&sub.join("g.glb"), &grid_mesh(small, small));
        std::fs::write(
            sub.join("g.uvpin.ron"),
            format!("(asset: \"g.glb\", constraints: [(vertex: {centre}, uv: (0.5, 0.5))])\n"),
        )
        .unwrap();
    }
    let t0 = Instant::now();
    let d = Daemon::start(&dir);
    d.wait("solved", 200);
    let startup = t0.elapsed().as_secs_f64();
    let edited = dir.join("assets/m117/g.uvpin.ron");
    let latency = timed_save(
        &edited,
        &format!("(asset: \"g.glb\", constraints: [(vertex: {centre}, uv: (0.52, 0.49))])\n"),
        &dir.join("out/m117/g.glb"),
    );
    std::thread::sleep(Duration::from_secs(1));
    (startup, d.count("solving") - 200, latency)
}

fn main() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (sample, idle_cpu) = sample_case(repo);
    let rows = [sample, big_case()];
    let (startup, solves_after_edit, latency) = many_case();
    let mut body = format!(
        "`uvpin watch` (the release binary, a real file watcher): time from a constraint file's rename to the \
         output's rename, median of {EDITS} edits, debounce {DEBOUNCE_MS} ms.\n\n\
         | asset | vertices | latency (median) | latency - debounce | solve (median) | reached |\n|---|---|---|---|---|---|\n"
    );
    for r in &rows {
        body += &format!(
            "| {} | {} | {:.0} ms | {:.0} ms | {:.1} ms | {}/{} |\n",
            r.name,
            r.vertices,
            r.latency,
            r.latency - DEBOUNCE_MS as f64,
            r.solve,
            r.reached,
            EDITS
        );
    }
    body += &format!(
        "\nIdle CPU over 10 s: {idle_cpu:.2} % of one core. 200 watched assets: all solved {startup:.1} s after start; \
         one edited gives {solves_after_edit} re-solve, latency {latency:.0} ms."
    );
    common::publish("watch", "Hot reload", &body);
}
