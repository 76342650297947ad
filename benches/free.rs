//! The free boundary against the square one and step 1 on the shared
//! meshes, with SLIM (libigl's, from PyPI) run in the same session on the
//! same cases: stretch, how far the landmarks land from their targets, and
//! time. `cargo bench --bench free [FILTER]`.
//!
//! Each case is witnessed: uvpin's own free layout of the mesh without
//! landmarks (globally injective), pushed through a smooth bijective warp of
//! the texture; 24 or 40 interior vertices get their warped positions as
//! targets, so a fold-free, one-to-one layout meeting them exists. SLIM
//! (symmetric Dirichlet, free boundary, landmarks as soft constraints with
//! libigl's default penalty) starts from Tutte's embedding on a circle
//! (its holes fan-filled for the embedding).

mod common;
use glam::DVec2;
use std::path::{Path, PathBuf};
use std::process::Command;
use uvpin::mesh::TriMesh;
use uvpin::metrics::sander_stretch;
use uvpin::options::SolverOptions;
use uvpin::param::{uv_to_xy, xy_to_uv};
use uvpin::pins::BoundaryChoice;
use uvpin::testing::Rng;

/// SLIM iterations per solve.
const SLIM_ITERATIONS: usize = 100;

/// One method's result on one case.
#[derive(Debug, Clone, Default)]
struct Outcome {
    l2: Vec<f64>,
    linf: Vec<f64>,
    residual: Vec<f64>,
    ms: Vec<f64>,
    /// Flipped triangles, pairs of boundary edges that cross, and boundary
    /// loops turned inside out (a hole covering its surroundings twice
    /// without any edge crossing), in the last run.
    flips: usize,
    crossings: usize,
    inside_out: usize,
    reached: bool,
}

impl Outcome {
    fn cells(&self) -> String {
        if self.ms.is_empty() {
            return "– | – | – | –".into();
        }
        let m = |v: &[f64]| common::median(v.to_vec());
        let broken = match (self.flips, self.crossings, self.inside_out) {
            (0, 0, 0) => String::new(),
            (f, c, h) => format!(" ({f} flipped, {c} crossings, {h} loops inside out)"),
        };
        format!(
            "{:.3} | {:.2} | {:.1e}{broken} | {:.0}",
            m(&self.l2),
            m(&self.linf),
            m(&self.residual),
            m(&self.ms)
        )
    }
}

/// A witnessed case: targets, and the factor that scales the mesh to their
/// layout's area (for SLIM, whose isometry is at the mesh's own scale).
struct Case {
    constraints: Vec<(u32, DVec2)>,
    scale: f64,
}

/// Which layout witnesses a case's targets.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Witness {
    /// uvpin's free layout, shrunk and warped
    /// ([`uvpin::testing::witnessed_free_case`]).
    Free,
    /// uvpin's square layout, warped: targets fill the texture
    /// ([`uvpin::testing::witnessed_square_case`]).
    Square,
}

/// Witnessed targets for `k` interior vertices of `mesh` and the scale that
/// takes the mesh to their layout's area.
fn witnessed_case(mesh: &TriMesh, k: usize, seed: u64, witness: Witness) -> Option<Case> {
    let (constraints, warped) = match witness {
        Witness::Free => uvpin::testing::witnessed_free_case(mesh, k, seed)?,
        Witness::Square => uvpin::testing::witnessed_square_case(mesh, k, seed)?,
    };
    let area = |l: &[DVec2]| uvpin::domain::start::layout_area(l, &mesh.triangles);
    let area_3d: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    Some(Case {
        constraints,
        scale: (area(&warped) / area_3d).sqrt(),
    })
}

/// uvpin with `boundary`, one run: stretch, residual, time.
fn run_uvpin(mesh: &TriMesh, constraints: &[(u32, DVec2)], boundary: BoundaryChoice, out: &mut Outcome) {
    let pins = uvpin::Pins::new(constraints).with_boundary(boundary);
    let t0 = std::time::Instant::now();
    let s = uvpin::solve_mesh(mesh, &pins, &SolverOptions::DEFAULT.into()).expect("solve");
    out.ms.push(t0.elapsed().as_secs_f64() * 1e3);
    out.l2.push(s.report.stretch_final.l2);
    out.linf.push(s.report.stretch_final.linf);
    out.residual.push(s.report.max_residual);
    out.flips = s.report.orientation.flipped + s.report.orientation.zero_area;
    out.crossings = s.report.free.as_ref().map_or(0, |f| f.crossings);
    out.reached = s.report.status == uvpin::Status::Reached;
}

/// Step 1 alone: its stretch, how far the landmarks are from their targets.
fn run_step1(mesh: &TriMesh, constraints: &[(u32, DVec2)], out: &mut Outcome) {
    let t0 = std::time::Instant::now();
    let s = uvpin::step_one(mesh, None).expect("step 1");
    out.ms.push(t0.elapsed().as_secs_f64() * 1e3);
    let layout: Vec<DVec2> = s
        .vertex_layout()
        .into_iter()
        .map(|p| p.unwrap_or(DVec2::ZERO))
        .collect();
    record_layout(mesh, &layout, constraints, out);
}

/// The stretch of `layout` and how far its landmarks are from their targets.
fn record_layout(mesh: &TriMesh, layout: &[DVec2], constraints: &[(u32, DVec2)], out: &mut Outcome) {
    let stretch = sander_stretch(&mesh.positions, layout, &mesh.triangles);
    out.l2.push(stretch.l2);
    out.linf.push(stretch.linf);
    let residual = constraints
        .iter()
        .map(|(v, t)| xy_to_uv(layout[*v as usize]).distance(*t))
        .fold(0.0, f64::max);
    out.residual.push(residual);
}

/// A Python with libigl: `target/bench-venv`, made (and libigl installed
/// from PyPI) on first use. `None` (with why) when it cannot be had.
fn slim_python() -> Result<PathBuf, String> {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench-venv");
    let python = venv.join("bin/python");
    let has_igl = |p: &Path| {
        Command::new(p)
            .args(["-c", "import igl"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if has_igl(&python) {
        return Ok(python);
    }
    let made = Command::new("python3").args(["-m", "venv"]).arg(&venv).status();
    if !made.is_ok_and(|s| s.success()) {
        return Err("python3 -m venv failed".into());
    }
    let pip = Command::new(&python)
        .args(["-m", "pip", "install", "--quiet", "libigl", "numpy"])
        .status();
    if !pip.is_ok_and(|s| s.success()) || !has_igl(&python) {
        return Err("pip install libigl failed".into());
    }
    Ok(python)
}

/// SLIM on the case, one run; `scale` takes the mesh to the targets' scale.
fn run_slim(python: &Path, mesh: &TriMesh, case: &Case, tmp: &Path, out: &mut Outcome) {
    let (constraints, scale) = (&case.constraints, case.scale);
    let case = serde_json::json!({
        "v": mesh.positions.iter().map(|p| [p.x * scale, p.y * scale, p.z * scale]).collect::<Vec<_>>(),
        "f": mesh.triangles,
        "b": constraints.iter().map(|(v, _)| v).collect::<Vec<_>>(),
        "bc": constraints.iter().map(|(_, t)| { let p = uv_to_xy(*t); [p.x, p.y] }).collect::<Vec<_>>(),
    });
    let file = tmp.join("slim-case.json");
    std::fs::write(&file, case.to_string()).expect("write case");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/helpers/slim.py");
    let o = Command::new(python)
        .arg(script)
        .arg(&file)
        .arg(SLIM_ITERATIONS.to_string())
        .output()
        .expect("run SLIM");
    assert!(o.status.success(), "SLIM: {}", String::from_utf8_lossy(&o.stderr));
    let result: serde_json::Value = serde_json::from_slice(&o.stdout).expect("SLIM JSON");
    let layout: Vec<DVec2> = result["uv"]
        .as_array()
        .expect("uv")
        .iter()
        .map(|p| DVec2::new(p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect();
    out.ms.push(result["ms"].as_f64().unwrap());
    record_layout(mesh, &layout, constraints, out);
    let orientation = uvpin::guard::count_orientations(&layout, &mesh.triangles);
    out.flips = orientation.flipped + orientation.zero_area;
    let edges = uvpin::injective::boundary_edges(&mesh.triangles);
    out.crossings =
        uvpin::injective::meeting_pairs(&layout, &edges, uvpin::injective::Contact::Proper, 10_000, edges.len()).len();
    out.inside_out = uvpin::testing::inside_out_loops(mesh, &layout);
}

/// A mesh to measure: its name, the mesh, rounds, landmark counts.
type Subject = (String, TriMesh, usize, &'static [usize]);

/// The paper's case size (a 41² curved grid, 50 landmarks), then the shared
/// meshes with 24 and 40 (when `../shared/meshes` is there).
fn subjects() -> Vec<Subject> {
    let mut rng = Rng::new(1);
    let grid = uvpin::testing::random_disk(&mut rng, 41, 0);
    let mut out: Vec<Subject> = vec![("paper size: 41² curved grid".into(), grid, 11, &[50])];
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes");
    if !shared.is_dir() {
        eprintln!("(../shared/meshes not found: shared meshes skipped)");
        return out;
    }
    for (file, runs) in [
        ("woody.glb", 5),
        ("halftunnel.glb", 5),
        ("alligator.glb", 5),
        ("lion.glb", 3),
        ("camelhead.glb", 3),
        ("face.glb", 5),
    ] {
        let asset = uvpin::io::load_asset(&shared.join(file), None, 0, &Default::default()).expect("mesh");
        out.push((
            file.into(),
            uvpin::mesh::weld::weld(&asset.primitives).mesh,
            runs,
            &[24, 40],
        ));
    }
    for (file, charts) in [("Duck.glb", 1), ("DamagedHelmet.glb", 2)] {
        out.extend(atlas_charts(&shared.join(file), charts));
    }
    out
}

/// The `n` largest charts of an atlas (welded by position and UV) that are
/// disks, each as a mesh of its own.
fn atlas_charts(path: &Path, n: usize) -> Vec<Subject> {
    let asset = uvpin::io::load_asset(path, None, 0, &Default::default()).expect("atlas");
    let welded = uvpin::mesh::weld::weld(&asset.primitives);
    let sizes = welded.chart_sizes();
    let mut ids: Vec<u32> = (0..sizes.len() as u32).collect();
    ids.sort_by_key(|&c| std::cmp::Reverse(sizes[c as usize].1));
    let file = path.file_name().unwrap_or_default().to_string_lossy().into_owned();
    ids.into_iter()
        .map(|c| (c, welded.chart(c).mesh))
        .filter(|(_, mesh)| is_disk(mesh))
        .take(n)
        .map(|(c, mesh)| (format!("{file} chart {c}"), mesh, 5, &[24, 40][..]))
        .collect()
}

/// One boundary loop and Euler characteristic 1.
fn is_disk(mesh: &TriMesh) -> bool {
    uvpin::mesh::topology::Topology::build(mesh).is_ok_and(|t| {
        let edges: std::collections::HashSet<(u32, u32)> = mesh
            .triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        let euler = mesh.n_vertices() as i64 - edges.len() as i64 + mesh.n_triangles() as i64;
        t.loops.len() == 1 && euler == 1
    })
}

/// One row: step 1, square, free and SLIM side by side, one run of each per round.
fn measure(mesh: &TriMesh, case: &Case, runs: usize, python: Option<&Path>, tmp: &Path) -> [Outcome; 4] {
    let (mut step1, mut square, mut free, mut slim) = Default::default();
    let constraints = &case.constraints;
    for round in 0..runs {
        run_step1(mesh, constraints, &mut step1);
        run_uvpin(mesh, constraints, BoundaryChoice::Square, &mut square);
        run_uvpin(mesh, constraints, BoundaryChoice::Free, &mut free);
        if let Some(python) = python
            && (round < 2 || mesh.positions.len() < 10_000)
        {
            run_slim(python, mesh, case, tmp, &mut slim);
        }
    }
    [step1, square, free, slim]
}

fn main() {
    let filter = common::filter();
    let python = slim_python();
    if let Err(why) = &python {
        eprintln!("(SLIM skipped: {why})");
    }
    let tmp = std::env::temp_dir().join(format!("uvpin-bench-free-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("tmp");
    let mut rows = Vec::new();
    let mut ever = common::Reached::open("free");
    for (label, mesh, runs, ks) in subjects() {
        for (&k, witness) in ks.iter().flat_map(|k| [(k, Witness::Free), (k, Witness::Square)]) {
            let name = match witness {
                Witness::Free => format!("{label}, {k} landmarks"),
                Witness::Square => format!("{label}, {k} landmarks, square witness"),
            };
            if filter.as_ref().is_some_and(|f| !name.contains(f.as_str())) {
                continue;
            }
            let Some(case) = witnessed_case(&mesh, k, 7, witness) else {
                eprintln!("{name}: no witness");
                continue;
            };
            let [step1, square, free, slim] = measure(&mesh, &case, runs, python.as_deref().ok(), &tmp);
            eprintln!("{name}: free {}", free.cells());
            ever.record(&format!("{name} | Square"), square.reached);
            ever.record(&format!("{name} | Free"), free.reached);
            rows.push((name, mesh.positions.len(), step1, square, free, slim));
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    let mut body = format!(
        "Sander L2 and L∞ stretch (1 = isometry), largest distance of a landmark from its target (texture units), \
         median milliseconds (`cargo bench --bench free`). Targets witnessed by a one-to-one free layout through a \
         smooth warp, or (square witness) by uvpin's square layout through a warp that keeps the square's border: \
         targets that fill the texture; uvpin runs with its defaults (polish included). SLIM: libigl {} iterations from Tutte's \
         embedding on a circle (holes fan-filled for it) fitted to the landmarks, landmarks as soft constraints; it keeps triangles from \
         flipping, not the boundary from crossing itself or a hole from turning inside out (counted in brackets).\n\n\
         | case | vertices | step 1: L2 | L∞ | residual | ms | square: L2 | L∞ | residual | ms | free: L2 | L∞ | residual | ms | SLIM: L2 | L∞ | residual | ms |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        SLIM_ITERATIONS
    );
    for (name, n, step1, square, free, slim) in &rows {
        let mark = |o: &Outcome| if o.reached { "" } else { " (partial)" };
        body += &format!(
            "| {name} | {n} | {} | {}{} | {}{} | {} |\n",
            step1.cells(),
            square.cells(),
            mark(square),
            free.cells(),
            mark(free),
            slim.cells()
        );
    }
    if python.is_err() {
        body += "\nSLIM was not run (no Python with libigl).\n";
    }
    common::publish("free", "Free boundary", &body);
    ever.finish();
}
