//! A structure-aware mutation fuzzer on stable Rust: GLB, glTF (+ .bin),
//! RON constraint files and OBJ, mutated from valid seeds by a seeded
//! generator and run through the library in this process (load, solve,
//! write, read back). It fails on a panic, a hang, an allocation past the
//! address-space limit, or an output that folds when read back.
//!
//! `cargo test --release --test fuzz` runs a fixed list of seeds, the same in
//! every run: `UVPIN_FUZZ_CASES` inputs (default 300) from seed
//! `UVPIN_FUZZ_SEED` (default 1), stopping early (and saying so) after
//! `UVPIN_FUZZ_SECONDS` seconds (default 60). `UVPIN_FUZZ_SEED=random`
//! starts from the clock (printed) for exploring. A failing input is saved under `target/fuzz-failures/`
//! with the seed that made it; each one found becomes a named test in
//! `tests/hostile.rs` or a unit test beside the fix.

mod common;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use uvpin::testing::Rng;

/// Address space of this fuzzing process at most: a mutation that makes the
/// library ask for more aborts the run (a failure).
const MEMORY_LIMIT: u64 = 3 << 30;
/// One input may take this long at most.
const INPUT_TIME: Duration = Duration::from_secs(10);

/// The kinds of input mutated.
#[derive(Debug, Clone, Copy)]
enum Kind {
    Glb,
    Gltf,
    Constraints,
    Obj,
}

/// One generated case: files to write into the case folder, and the
/// constraint file to solve.
struct Case {
    kind: Kind,
    files: Vec<(String, Vec<u8>)>,
}

fn grid_document() -> (Value, Vec<u8>) {
    let mut mesh = uvpin::testing::grid_mesh(7, 7);
    for p in &mut mesh.positions {
        p.z = 0.1 * (p.x * 3.0).sin();
    }
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    uvpin::io::gltf_file::new_document(&positions, &indices, None, "grid")
}

fn grid_obj() -> String {
    let mesh = uvpin::testing::grid_mesh(7, 7);
    let mut text = String::new();
    for p in &mesh.positions {
        text += &format!("v {} {} {}\n", p.x, p.y, 0.1 * p.x * p.y);
    }
    for t in &mesh.triangles {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    text
}

fn constraints_text(asset: &str) -> String {
    format!(
        "(\n    asset: \"{asset}\",\n    constraints: [\n        (vertex: 16, uv: (0.3, 0.4), label: \"a\"),\n        \
         (vertex: 24, uv: (0.6, 0.5)),\n        (near: (0.5, 0.8, 0.0), uv: (0.5, 0.7)),\n    ],\n)\n"
    )
}

const INTERESTING_NUMBERS: [f64; 16] = [
    0.0,
    1.0,
    -1.0,
    2.0,
    3.0,
    4.0,
    255.0,
    256.0,
    65535.0,
    2147483647.0,
    2147483648.0,
    4294967295.0,
    4294967296.0,
    1e20,
    0.5,
    5126.0,
];

fn interesting_value(rng: &mut Rng) -> Value {
    match rng.below(8) {
        0..=4 => json!(INTERESTING_NUMBERS[rng.below(INTERESTING_NUMBERS.len())]),
        5 => json!(
            [
                "x",
                "../../etc/passwd",
                "/dev/zero",
                "file:///etc/hosts",
                "data:,",
                "VEC2",
                "MAT4"
            ][rng.below(7)]
        ),
        6 => [Value::Null, json!(true), json!([]), json!({})][rng.below(4)].clone(),
        _ => json!(rng.below(20)),
    }
}

/// Every path into `v` (object keys and array indices).
fn paths(v: &Value, prefix: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    out.push(prefix.clone());
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                prefix.push(json!(k));
                paths(c, prefix, out);
                prefix.pop();
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                prefix.push(json!(i));
                paths(c, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

fn at<'a>(v: &'a mut Value, path: &[Value]) -> Option<&'a mut Value> {
    path.iter().try_fold(v, |v, seg| match seg {
        Value::String(k) => v.get_mut(k.as_str()),
        Value::Number(i) => v.get_mut(i.as_u64()? as usize),
        _ => None,
    })
}

/// One structure-aware edit of a glTF JSON document.
fn mutate_json(doc: &mut Value, rng: &mut Rng) {
    let mut all = Vec::new();
    paths(doc, &mut Vec::new(), &mut all);
    let path = all[rng.below(all.len())].clone();
    let Some((last, parent)) = path.split_last() else {
        return;
    };
    let op = rng.below(4);
    if let Some(p) = at(doc, parent) {
        match (op, p, last) {
            (0, Value::Object(m), Value::String(k)) => {
                m.remove(k);
            }
            (1, Value::Array(a), Value::Number(i)) => {
                let i = i.as_u64().unwrap_or(0) as usize;
                let copy = a[i.min(a.len() - 1)].clone();
                a.push(copy);
            }
            _ => {
                if let Some(target) = at(doc, &path) {
                    *target = interesting_value(rng);
                }
            }
        }
    }
}

/// One edit of binary data: flipped bytes, a cut, or a tail.
fn mutate_bytes(bytes: &mut Vec<u8>, rng: &mut Rng) {
    match rng.below(3) {
        0 if !bytes.is_empty() => {
            for _ in 0..1 + rng.below(8) {
                let i = rng.below(bytes.len());
                bytes[i] ^= 1 << rng.below(8);
            }
        }
        1 => bytes.truncate(rng.below(bytes.len() + 1)),
        _ => bytes.extend((0..rng.below(64)).map(|_| rng.below(256) as u8)),
    }
}

/// One edit of text: a character deleted or inserted, a number made
/// extreme, a line doubled or cut.
fn mutate_text(text: &mut String, rng: &mut Rng) {
    let chars: Vec<char> = text.chars().collect();
    if chars.is_empty() {
        text.push('(');
        return;
    }
    let i = rng.below(chars.len());
    let pieces = [
        "(",
        ")",
        ",",
        ":",
        "[",
        "]",
        "\"",
        "-",
        "1e999",
        "nan",
        "18446744073709551616",
        "\u{feff}",
        "//",
        "\n",
        "f 0 0 0\n",
        "v 1e39 0 0\n",
        "f 1 2 3 4\n",
        "vt 0.5\n",
    ];
    let mut out: Vec<char> = chars.clone();
    match rng.below(5) {
        0 => {
            out.remove(i);
        }
        1 => {
            let piece = pieces[rng.below(pieces.len())];
            out.splice(i..i, piece.chars());
        }
        2 => out.truncate(i),
        3 => {
            let lines: Vec<&str> = text.lines().collect();
            let l = lines[rng.below(lines.len())];
            out.extend(format!("\n{l}\n").chars());
        }
        _ => {
            let start = chars[i..].iter().position(|c| c.is_ascii_digit()).map(|k| i + k);
            if let Some(s) = start {
                let end = chars[s..]
                    .iter()
                    .position(|c| !c.is_ascii_digit() && *c != '.')
                    .map_or(chars.len(), |k| s + k);
                let n = INTERESTING_NUMBERS[rng.below(INTERESTING_NUMBERS.len())];
                out.splice(s..end, format!("{n}").chars());
            }
        }
    }
    *text = out.into_iter().collect();
}

fn generate(rng: &mut Rng) -> Case {
    let kind = [Kind::Glb, Kind::Gltf, Kind::Constraints, Kind::Obj][rng.below(4)];
    let edits = 1 + rng.below(4);
    match kind {
        Kind::Glb => {
            let (mut doc, mut bin) = grid_document();
            for _ in 0..edits {
                if rng.below(4) == 0 {
                    mutate_bytes(&mut bin, rng);
                } else {
                    mutate_json(&mut doc, rng);
                }
            }
            let mut file = uvpin::io::glb::build(&serde_json::to_vec(&doc).unwrap(), Some(&bin));
            if rng.below(10) == 0 {
                mutate_bytes(&mut file, rng);
            }
            Case {
                kind,
                files: vec![
                    ("m.glb".into(), file),
                    ("c.uvpin.ron".into(), constraints_text("m.glb").into_bytes()),
                ],
            }
        }
        Kind::Gltf => {
            let (mut doc, mut bin) = grid_document();
            doc["buffers"][0]["uri"] = json!("m.bin");
            for _ in 0..edits {
                if rng.below(4) == 0 {
                    mutate_bytes(&mut bin, rng);
                } else {
                    mutate_json(&mut doc, rng);
                }
            }
            Case {
                kind,
                files: vec![
                    ("m.gltf".into(), serde_json::to_vec_pretty(&doc).unwrap()),
                    ("m.bin".into(), bin),
                    ("c.uvpin.ron".into(), constraints_text("m.gltf").into_bytes()),
                ],
            }
        }
        Kind::Constraints => {
            let (doc, bin) = grid_document();
            let mut text = constraints_text("m.glb");
            for _ in 0..edits {
                mutate_text(&mut text, rng);
            }
            let glb = uvpin::io::glb::build(&serde_json::to_vec(&doc).unwrap(), Some(&bin));
            Case {
                kind,
                files: vec![("m.glb".into(), glb), ("c.uvpin.ron".into(), text.into_bytes())],
            }
        }
        Kind::Obj => {
            let mut text = grid_obj();
            for _ in 0..edits {
                mutate_text(&mut text, rng);
            }
            Case {
                kind,
                files: vec![
                    ("m.obj".into(), text.into_bytes()),
                    ("c.uvpin.ron".into(), constraints_text("m.obj").into_bytes()),
                ],
            }
        }
    }
}

/// Loads, solves and writes the case in `dir`; checks what it wrote.
fn run_case(dir: &Path, case: &Case) {
    for (name, bytes) in &case.files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let rules = uvpin::io::InputRules {
        limits: uvpin::io::InputLimits {
            max_vertices: 200_000,
            max_triangles: 400_000,
            ..uvpin::io::InputLimits::DEFAULT
        },
        scope: uvpin::io::ReadScope::within([dir.to_path_buf()]),
    };
    let Ok((loaded, asset)) = uvpin::load(&dir.join("c.uvpin.ron"), &Default::default(), &rules) else {
        return;
    };
    let options = loaded.solver;
    let source = uvpin::constraints::ConstraintSource::File(Arc::new(loaded));
    let asset = Arc::new(asset);
    let Ok(mut session) = uvpin::session::ChartSession::open(source, asset.clone(), 0.0) else {
        return;
    };
    let Ok(solved) = uvpin::assembly::solve(&mut session, &options) else {
        return;
    };
    let ext = match case.kind {
        Kind::Obj => "obj",
        Kind::Gltf => "gltf",
        _ => "glb",
    };
    let out = dir.join(format!("out.{ext}"));
    let in_chart = chart_membership(session.prepared(), &asset);
    let outputs = uvpin::Options::from(options).with_output(&out).outputs();
    let report = uvpin::assembly::export(&session, &solved, &outputs).report;
    if report.status != uvpin::Status::Error {
        assert_written_fold_free(&out, &asset, &in_chart);
    }
}

/// Per primitive and vertex, whether it is in the solved chart.
fn chart_membership(p: &uvpin::chart::PreparedChart, asset: &uvpin::io::SourceAsset) -> Vec<Vec<bool>> {
    asset
        .primitives
        .iter()
        .zip(&p.welded.vertex_of)
        .map(|(_, map)| map.iter().map(|&w| p.chart.local_of(w).is_some()).collect())
        .collect()
}

/// Reads `out` back and checks every triangle of the solved chart keeps its
/// orientation as stored.
fn assert_written_fold_free(out: &Path, asset: &uvpin::io::SourceAsset, in_chart: &[Vec<bool>]) {
    use uvpin::guard::VAxis;
    let rules = uvpin::io::InputRules::default();
    if out.extension().is_some_and(|e| e == "obj") {
        // Read as any OBJ reader does: each face corner names its own `vt`.
        let text = std::fs::read_to_string(out).expect("our OBJ output reads back");
        let (n_v, mut vt, mut flipped) = (std::cell::Cell::new(0usize), Vec::<[f32; 2]>::new(), 0);
        let number = |x: &str| x.parse::<f32>().expect("a number");
        for line in text.lines() {
            let mut parts = line.split_whitespace();
            match parts.next() {
                Some("v") => n_v.set(n_v.get() + 1),
                Some("vt") => vt.push([number(parts.next().unwrap()), number(parts.next().unwrap())]),
                Some("f") => {
                    let index = |s: &str, n: usize| {
                        let i: i64 = s.parse().expect("an index");
                        if i > 0 { i as usize - 1 } else { (n as i64 + i) as usize }
                    };
                    let corners: Vec<(usize, [f32; 2])> = parts
                        .map(|c| {
                            let mut f = c.split('/');
                            let v = index(f.next().unwrap(), n_v.get());
                            let t = f.next().filter(|t| !t.is_empty()).expect("every corner has a vt");
                            (v, vt[index(t, vt.len())])
                        })
                        .collect();
                    if corners.iter().all(|(v, _)| in_chart[0][*v]) {
                        let uvs: Vec<[f32; 2]> = corners.iter().map(|c| c.1).collect();
                        let fan: Vec<[u32; 3]> = (1..uvs.len() as u32 - 1).map(|k| [0, k, k + 1]).collect();
                        let counts = uvpin::guard::count_stored_orientations(&uvs, &fan, VAxis::Up);
                        flipped += counts.flipped + counts.zero_area;
                    }
                }
                _ => {}
            }
        }
        assert_eq!(
            flipped,
            0,
            "{}: flipped or flat faces of the solved chart as written",
            out.display()
        );
        return;
    }
    let back = uvpin::io::load_asset(out, None, asset.uv_set, &rules).expect("our output reads back");
    let uvs: Vec<Vec<[f32; 2]>> = back
        .primitives
        .iter()
        .map(|p| p.uvs.clone().expect("the written UV set"))
        .collect();
    for ((prim, uvs), inside) in back.primitives.iter().zip(&uvs).zip(in_chart) {
        let _ = asset;
        let triangles: Vec<[u32; 3]> = prim
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .filter(|t| t.iter().all(|&v| inside.get(v as usize).copied().unwrap_or(true)))
            .collect();
        let counts = uvpin::guard::count_stored_orientations(uvs, &triangles, VAxis::Down);
        assert!(
            counts.is_clean(),
            "{}: {counts:?} in the solved chart as written",
            out.display()
        );
    }
}

fn limit_memory() {
    let limit = libc::rlimit {
        rlim_cur: MEMORY_LIMIT,
        rlim_max: MEMORY_LIMIT,
    };
    // SAFETY: a plain system call on this process.
    assert_eq!(unsafe { libc::setrlimit(libc::RLIMIT_AS, &limit) }, 0);
}

fn main() {
    limit_memory();
    let number = |name: &str, default: u64| {
        std::env::var(name).map_or(default, |s| {
            s.parse()
                .unwrap_or_else(|_| panic!("{name}={s:?} is not a whole number"))
        })
    };
    let seconds = number("UVPIN_FUZZ_SECONDS", 60);
    let cases = number("UVPIN_FUZZ_CASES", 300);
    let base_seed: u64 = match std::env::var("UVPIN_FUZZ_SEED").as_deref() {
        Err(_) => 1,
        Ok("random") => std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(1, |d| d.as_secs()),
        Ok(s) => s
            .parse()
            .unwrap_or_else(|_| panic!("UVPIN_FUZZ_SEED={s:?}: a number or `random`")),
    };
    let failures = common::repo().join("target/fuzz-failures");
    let dir = std::env::temp_dir().join(format!("uvpin-fuzz-{}", std::process::id()));
    eprintln!(
        "fuzzing {cases} inputs from seed {base_seed} within {seconds} s (UVPIN_FUZZ_SEED={base_seed} repeats this run)"
    );
    // The watchdog: the input running too long is saved and the run aborted.
    let current: Arc<Mutex<Option<(u64, Instant)>>> = Arc::new(Mutex::new(None));
    let watched = current.clone();
    let saved = failures.clone();
    std::thread::spawn(move || {
        loop {
            std::thread::sleep(Duration::from_millis(200));
            if let Some((seed, t0)) = *watched.lock().unwrap()
                && t0.elapsed() > INPUT_TIME
            {
                eprintln!(
                    "HANG: the input of seed {seed} ran over {INPUT_TIME:?}; saved under {}",
                    saved.display()
                );
                save(&saved, seed);
                std::process::abort();
            }
        }
    });
    let count = AtomicU64::new(0);
    let start = Instant::now();
    let mut seed = base_seed;
    while count.load(Ordering::Relaxed) < cases {
        if start.elapsed() >= Duration::from_secs(seconds) {
            eprintln!("the time box of {seconds} s ran out before seed {seed}: the seeds after it were not run");
            break;
        }
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let case = generate(&mut Rng::new(seed));
        *current.lock().unwrap() = Some((seed, Instant::now()));
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_case(&dir, &case)));
        *current.lock().unwrap() = None;
        if result.is_err() {
            save(&failures, seed);
            panic!(
                "seed {seed} ({:?}) failed; its input is saved under {}",
                case.kind,
                failures.display()
            );
        }
        count.fetch_add(1, Ordering::Relaxed);
        seed = seed.wrapping_add(1);
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("{} inputs, no failure", count.load(Ordering::Relaxed));
}

/// Writes the case of `seed` under `folder/seed-N/`.
fn save(folder: &Path, seed: u64) {
    let case = generate(&mut Rng::new(seed));
    let dir: PathBuf = folder.join(format!("seed-{seed}"));
    let _ = std::fs::create_dir_all(&dir);
    for (name, bytes) in &case.files {
        let _ = std::fs::write(dir.join(name), bytes);
    }
}
