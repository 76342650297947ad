//! Meshes as they come: every mesh file in a folder (OBJ, glTF, PLY, STL,
//! OFF, searched recursively) given two photo-style landmark sets, solved
//! by the `uvpin` binary with the default boundary and with `boundary:
//! Free`; counts by format and by genus, the commonest refusals, crashes
//! and false exits (exit 0 with a landmark off target or a fold, as
//! `uvpin check` reads the written file); of the partial runs, those whose
//! report proves the targets unreachable.
//!
//! `cargo bench --bench corpus -- DIR [FILTER]` (or `UVPIN_CORPUS=DIR`);
//! `UVPIN_CORPUS_KEEP=1` keeps the cases' files (constraints and outputs);
//! the folder is not in the repository (public test-model collections, such
//! as the ones geometry libraries keep for their tests, serve).
//!
//! A landmark set: the mesh seen orthographically from a direction drawn
//! from its name, the side its faces turn to; 12 visible vertices spread
//! over the view (farthest points on screen); their targets where the view
//! shows them, fitted into 15–85 % of the texture. Two sets per mesh, by
//! what hides a vertex ([`uvpin::testing::Hiding`]): a nearer vertex (the
//! first set the bench kept, rows named by the mesh alone), or a nearer
//! vertex or surface (rows named `mesh (unhidden)`), which is what a
//! photograph shows of a CAD part's long facets.

mod common;
use glam::{DVec2, DVec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const LANDMARKS: usize = 12;
const TIMEOUT: Duration = Duration::from_secs(120);
const FORMATS: [&str; 6] = ["obj", "glb", "gltf", "ply", "stl", "off"];

/// One mesh of the folder, as read.
struct Mesh {
    path: PathBuf,
    name: String,
    format: String,
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    genus: String,
}

/// How a run ended.
#[derive(Debug, Clone, PartialEq)]
enum Outcome {
    Reached,
    /// Exit 2; `true` when the report proves the targets unreachable (no
    /// fold-free layout without splitting a landmark holds them).
    Partial(bool),
    Refused(String),
    Crashed(String),
    /// Exit 0 with a landmark off target or a fold in the written file.
    FalseExit(String),
}

fn corpus_dir() -> Option<PathBuf> {
    let arg = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    std::env::var_os("UVPIN_CORPUS")
        .map(PathBuf::from)
        .or_else(|| arg.map(PathBuf::from))
}

/// A case-name filter: the second free argument.
fn name_filter() -> Option<String> {
    std::env::args().skip(1).filter(|a| !a.starts_with('-')).nth(1)
}

fn mesh_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            mesh_files(&p, out);
        } else if extension(&p).is_some_and(|e| FORMATS.contains(&e.as_str())) {
            out.push(p);
        }
    }
}

fn extension(p: &Path) -> Option<String> {
    p.extension().map(|e| e.to_string_lossy().to_lowercase())
}

/// The genus of a closed mesh (from Euler's formula per connected piece),
/// or "open" / "pieces" where the question has no single answer.
fn genus(positions: usize, triangles: &[[u32; 3]]) -> String {
    let mut edges: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    if edges.values().any(|&n| n != 2) {
        return "open or non-manifold".into();
    }
    let mut parent: Vec<u32> = (0..positions as u32).collect();
    fn root(p: &mut [u32], mut v: u32) -> u32 {
        while p[v as usize] != v {
            p[v as usize] = p[p[v as usize] as usize];
            v = p[v as usize];
        }
        v
    }
    for &(a, b) in edges.keys() {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        parent[ra as usize] = rb;
    }
    let used: std::collections::BTreeSet<u32> = triangles.iter().flatten().copied().collect();
    let pieces: std::collections::BTreeSet<u32> = used.iter().map(|&v| root(&mut parent, v)).collect();
    let chi = used.len() as i64 - edges.len() as i64 + triangles.len() as i64;
    let g = (2 * pieces.len() as i64 - chi) / 2;
    match pieces.len() {
        1 => format!("closed, genus {g}"),
        n => format!("closed, {n} pieces, genus {g} in all"),
    }
}

fn read(path: &Path) -> Result<Mesh, String> {
    let asset = uvpin::io::load_asset(path, None, 0, &Default::default()).map_err(|e| e.to_string())?;
    let welded = uvpin::mesh::weld::weld(&asset.primitives).mesh;
    let name = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    Ok(Mesh {
        genus: genus(welded.positions.len(), &welded.triangles),
        path: path.to_path_buf(),
        format: extension(path).unwrap_or_default(),
        name,
        positions: welded.positions,
        triangles: welded.triangles,
    })
}

/// A direction drawn from the mesh's name, and the up it is seen with.
fn view_of(mesh: &Mesh) -> (DVec3, DVec3) {
    let seed = mesh
        .name
        .bytes()
        .fold(17u64, |h, b| h.wrapping_mul(31).wrapping_add(b as u64));
    let mut rng = uvpin::testing::Rng::new(seed);
    let d = DVec3::new(rng.f64() - 0.5, 0.6 * (rng.f64() - 0.5), rng.f64() - 0.5).normalize_or(DVec3::Z);
    let up = if d.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    (d, up)
}

/// The two landmark sets of a mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Set {
    /// Hidden by nearer vertices only ([`uvpin::testing::photo_landmarks`]).
    Vertices,
    /// Hidden by nearer surfaces too ([`uvpin::testing::photo_landmarks_unhidden`]).
    Unhidden,
}

impl Set {
    /// The row's name for `mesh`.
    fn name(self, mesh: &str) -> String {
        match self {
            Set::Vertices => mesh.to_string(),
            Set::Unhidden => format!("{mesh} (unhidden)"),
        }
    }
}

/// Photo-style landmarks ([`uvpin::testing::photo_landmarks`]) from the
/// mesh's view or, when too few vertices face it (a mesh wound inward),
/// the opposite one: each landmark's position and target.
fn landmarks(mesh: &Mesh, set: Set) -> Option<Vec<(DVec3, DVec2)>> {
    let tri = uvpin::mesh::TriMesh {
        positions: mesh.positions.clone(),
        triangles: mesh.triangles.clone(),
    };
    let (view, up) = view_of(mesh);
    let quiet = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let found = [view, -view].into_iter().find_map(|v| {
        std::panic::catch_unwind(|| match set {
            Set::Vertices => uvpin::testing::photo_landmarks(&tri, v, up, LANDMARKS, 0.7),
            Set::Unhidden => uvpin::testing::photo_landmarks_unhidden(&tri, v, up, LANDMARKS, 0.7),
        })
        .ok()
    });
    std::panic::set_hook(quiet);
    let marks = found?;
    Some(
        marks
            .iter()
            .map(|&(v, u, w)| (mesh.positions[v as usize], DVec2::new(u, w)))
            .collect(),
    )
}

fn constraint_file(mesh: &Mesh, marks: &[(DVec3, DVec2)], free: bool) -> String {
    let mut text = format!(
        "(\n    asset: {:?},\n    constraints: [\n",
        mesh.path.display().to_string()
    );
    for (p, t) in marks {
        text += &format!(
            "        (near: ({:?}, {:?}, {:?}), uv: ({:.6}, {:.6})),\n",
            p.x, p.y, p.z, t.x, t.y
        );
    }
    text += "    ],\n";
    if free {
        text += "    boundary: Free,\n";
    }
    text + ")\n"
}

/// The `uvpin` binary to run: this build's, or `UVPIN_BIN` (another build,
/// for a side-by-side run; its table is then not written into the docs).
fn binary() -> PathBuf {
    std::env::var_os("UVPIN_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_uvpin")))
}

/// Runs `uvpin` with `args`, killed after [`TIMEOUT`]: exit code (None:
/// killed or signalled) and standard error.
fn run(args: &[&str]) -> (Option<i32>, String) {
    let mut child = Command::new(binary())
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("uvpin");
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break Some(s);
        }
        if t0.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        use std::io::Read;
        let _ = e.read_to_string(&mut err);
    }
    (status.and_then(|s| s.code()), err)
}

/// A refusal's first line with its numbers and paths made general.
fn reason(stderr: &str) -> String {
    let first = stderr.lines().find(|l| !l.trim().is_empty());
    let line = stderr
        .lines()
        .find(|l| l.starts_with("error"))
        .or(first)
        .unwrap_or("(no message)");
    let words: Vec<String> = line
        .split_whitespace()
        .map(|w| {
            if w.contains('/') {
                "PATH".to_string()
            } else if w.chars().any(|c| c.is_ascii_digit()) {
                "N".to_string()
            } else {
                w.to_string()
            }
        })
        .collect();
    // Backticks would break the table's code span.
    words.join(" ").replace('`', "'").chars().take(150).collect()
}

/// Exit 0 checked against the written file: every landmark on target and
/// the UVs clean.
fn confirmed(out: &Path, ron: &Path) -> Result<(), String> {
    let (code, err) = run(&["check", &out.to_string_lossy(), "--constraints", &ron.to_string_lossy()]);
    match code {
        Some(0) => Ok(()),
        _ => Err(err
            .lines()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("check failed")
            .to_string()),
    }
}

fn solve_case(mesh: &Mesh, (marks, set): (&[(DVec3, DVec2)], Set), free: bool, dir: &Path) -> (Outcome, f64) {
    let tag = if set == Set::Unhidden { "-unhidden" } else { "" };
    let ron = dir.join(format!(
        "{}{tag}-{}.uvpin.ron",
        mesh.name,
        if free { "free" } else { "default" }
    ));
    std::fs::write(&ron, constraint_file(mesh, marks, free)).expect("write case");
    let out = ron.with_extension("glb");
    let t0 = Instant::now();
    let report = ron.with_extension("json");
    let (code, err) = run(&[
        "solve",
        &ron.to_string_lossy(),
        "-o",
        &out.to_string_lossy(),
        "--report",
        &report.to_string_lossy(),
        "-q",
    ]);
    let seconds = t0.elapsed().as_secs_f64();
    let outcome = match code {
        Some(0) => confirmed(&out, &ron).map_or_else(Outcome::FalseExit, |()| Outcome::Reached),
        Some(2) => Outcome::Partial(proven(&report)),
        Some(1) => Outcome::Refused(reason(&err)),
        Some(c) => Outcome::Crashed(format!("exit {c}: {}", reason(&err))),
        None => Outcome::Crashed(format!("no end within {} s (or a signal)", TIMEOUT.as_secs())),
    };
    (outcome, seconds)
}

/// Whether the written report proves the targets unreachable.
fn proven(report: &Path) -> bool {
    std::fs::read(report)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .is_some_and(|r| !r["unreachable_proof"].is_null())
}

/// Counts of one group of cases.
#[derive(Default)]
struct Tally {
    n: usize,
    reached: usize,
    partial: usize,
    proven: usize,
    refused: usize,
    crashed: usize,
    false_exits: usize,
    seconds: Vec<f64>,
}

impl Tally {
    fn add(&mut self, o: &Outcome, seconds: f64) {
        self.n += 1;
        self.seconds.push(seconds);
        match o {
            Outcome::Reached => self.reached += 1,
            Outcome::Partial(proven) => {
                self.partial += 1;
                self.proven += usize::from(*proven);
            }
            Outcome::Refused(_) => self.refused += 1,
            Outcome::Crashed(_) => self.crashed += 1,
            Outcome::FalseExit(_) => self.false_exits += 1,
        }
    }

    fn row(&self, name: &str) -> String {
        format!(
            "| {name} | {} | {} ({:.0} %) | {} ({} proven) | {} | {} | {} | {:.2} s |\n",
            self.n,
            self.reached,
            100.0 * self.reached as f64 / self.n.max(1) as f64,
            self.partial,
            self.proven,
            self.refused,
            self.crashed,
            self.false_exits,
            common::median(self.seconds.clone()),
        )
    }
}

const HEADER: &str = "| cases | n | reached | partial (proven unreachable) | refused | crashed | false exit 0 | median time |\n|---|---:|---:|---:|---:|---:|---:|---:|\n";

/// Every table of the run: counts by group, refusals, crashes and false exits.
#[derive(Default)]
struct Tables {
    all: Tally,
    by_mode: BTreeMap<&'static str, Tally>,
    by_set: BTreeMap<&'static str, Tally>,
    by_format: BTreeMap<String, Tally>,
    by_genus: BTreeMap<String, Tally>,
    reasons: BTreeMap<String, usize>,
    notable: String,
    meshes: usize,
}

impl Tables {
    fn add(&mut self, mesh: &Mesh, (row, set, mode): (&str, Set, &'static str), outcome: &Outcome, seconds: f64) {
        let hidden_by = match set {
            Set::Vertices => "landmarks hidden by vertices",
            Set::Unhidden => "landmarks hidden by surfaces too",
        };
        for tally in [
            self.by_format.entry(mesh.format.clone()).or_default(),
            self.by_genus.entry(mesh.genus.clone()).or_default(),
            self.by_mode.entry(mode).or_default(),
            self.by_set.entry(hidden_by).or_default(),
            &mut self.all,
        ] {
            tally.add(outcome, seconds);
        }
        match outcome {
            Outcome::Refused(r) => *self.reasons.entry(r.clone()).or_default() += 1,
            Outcome::Crashed(r) | Outcome::FalseExit(r) => {
                self.notable += &format!("- {row} ({mode}): {outcome:?}: {r}\n");
            }
            _ => {}
        }
    }

    fn body(&self) -> String {
        let mut body = format!(
            "{} mesh files, each with two landmark sets of {LANDMARKS} photo-style landmarks (a vertex hidden \
             by nearer vertices, or by nearer surfaces too), each solved with the default boundary and free: {} cases.\n\n",
            self.meshes, self.all.n
        );
        body += HEADER;
        body += &self.all.row("all");
        for (name, t) in self.by_mode.iter().chain(&self.by_set) {
            body += &t.row(name);
        }
        for (name, t) in &self.by_format {
            body += &t.row(&format!("`.{name}`"));
        }
        body += "\nBy shape:\n\n";
        body += HEADER;
        for (name, t) in &self.by_genus {
            body += &t.row(name);
        }
        let mut common_reasons: Vec<(&String, &usize)> = self.reasons.iter().collect();
        common_reasons.sort_by(|a, b| b.1.cmp(a.1));
        if common_reasons.is_empty() {
            body += "\nNo case was refused.\n";
        } else {
            body += "\nThe commonest refusals:\n\n";
            for (r, n) in common_reasons.iter().take(5) {
                body += &format!("- {n} × `{r}`\n");
            }
        }
        if !self.notable.is_empty() {
            body += &format!("\nCrashes and false exits:\n\n{}", self.notable);
        }
        body
    }
}

fn main() {
    let Some(dir) = corpus_dir() else {
        eprintln!("give the corpus folder: cargo bench --bench corpus -- DIR (or UVPIN_CORPUS=DIR)");
        std::process::exit(1);
    };
    let mut files = Vec::new();
    mesh_files(&dir, &mut files);
    let filter = name_filter();
    let work = std::env::temp_dir().join(format!("uvpin-bench-corpus-{}", std::process::id()));
    std::fs::create_dir_all(&work).unwrap();
    let mut tables = Tables::default();
    let mut ever = common::Reached::open("corpus");
    for path in files
        .iter()
        .filter(|p| filter.as_ref().is_none_or(|f| p.to_string_lossy().contains(f.as_str())))
    {
        let mesh = match read(path) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("{}: not read: {e}", path.display());
                continue;
            }
        };
        let sets: Vec<(Set, Vec<(DVec3, DVec2)>)> = [Set::Vertices, Set::Unhidden]
            .into_iter()
            .filter_map(|set| {
                let marks = landmarks(&mesh, set);
                if marks.is_none() {
                    eprintln!(
                        "{}: fewer than {LANDMARKS} vertices face the camera either way: skipped",
                        set.name(&mesh.name)
                    );
                }
                marks.map(|m| (set, m))
            })
            .collect();
        tables.meshes += usize::from(!sets.is_empty());
        for (set, marks) in &sets {
            for free in [false, true] {
                let (outcome, seconds) = solve_case(&mesh, (marks, *set), free, &work);
                let mode = if free { "boundary: Free" } else { "default boundary" };
                let row = set.name(&mesh.name);
                eprintln!("{row} ({mode}): {outcome:?} in {seconds:.2} s");
                ever.record(&format!("{row} | {mode}"), outcome == Outcome::Reached);
                tables.add(&mesh, (&row, *set, mode), &outcome, seconds);
            }
        }
    }
    let body = tables.body();
    if tables.notable.is_empty() && std::env::var_os("UVPIN_CORPUS_KEEP").is_none() {
        let _ = std::fs::remove_dir_all(&work);
    } else {
        eprintln!("the cases' files are kept in {}", work.display());
    }
    println!("\n{body}");
    if filter.is_none() && std::env::var_os("UVPIN_BIN").is_none() {
        common::write_section("corpus", "Meshes as they come (`--bench corpus`)", &body);
    }
    ever.finish();
}
