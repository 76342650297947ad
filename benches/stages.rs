//! Per-stage timings: `cargo bench --bench stages [-- FILTER]`.
//!
//! Prints a table of medians (ms) over repeated runs for the sample asset, the
//! paper's case size (1.7k vertices, 50 constraints), the shared third-party
//! meshes (end to end through glTF files, if `../shared/meshes` exists), and
//! generated grids of 10k, 100k and 1M vertices. Constrained cases use
//! targets pushed through a smooth bijective warp of the step-1 layout, so
//! they are reachable. Not a test: no thresholds, just figures.

use glam::DVec2;
use std::path::{Path, PathBuf};
use uvpin::mesh::TriMesh;
use uvpin::options::SolverOptions;
use uvpin::param::{uv_to_xy, xy_to_uv};
use uvpin::report::{Report, StageTimes};
use uvpin::testing::{Rng, grid_mesh, smooth_warp, swirl};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

struct Row {
    name: String,
    vertices: usize,
    constraints: usize,
    status: String,
    runs: usize,
    times: Vec<StageTimes>,
    /// The last run's report (quality figures are the same every run).
    report: Option<Report>,
}

/// Step-1-only layout against uvpin's result: stretch, residual, time.
fn print_comparison(rows: &[Row]) {
    println!("\n| case | step 1: L2 | L∞ | max residual | ms | uvpin: L2 | L∞ | max residual | ms |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let Some(rep) = &r.report else { continue };
        let step1_residual = rep
            .constraints
            .iter()
            .map(|c| c.step1.distance(c.target))
            .fold(0.0, f64::max);
        let step1_ms = median(
            r.times
                .iter()
                .map(|t| t.load_ms + t.topology_ms + t.boundary_ms + t.factor_ms + t.solve_ms)
                .collect(),
        );
        let total_ms = median(r.times.iter().map(|t| t.total_ms()).collect());
        println!(
            "| {} | {:.3} | {:.3} | {:.3e} | {:.1} | {:.3} | {:.3} | {:.1e} | {:.1} |",
            r.name,
            rep.stretch_step1.l2,
            rep.stretch_step1.linf,
            step1_residual,
            step1_ms,
            rep.stretch_final.l2,
            rep.stretch_final.linf,
            rep.max_residual,
            total_ms
        );
    }
}

fn print_header() {
    println!(
        "| case | vertices | constraints | status | runs | load | topology | boundary | factor | solve | spline | guard | completion | polish | export | step 1 | total |"
    );
    println!("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
}

fn print_row(r: &Row) {
    let m = |f: fn(&StageTimes) -> f64| median(r.times.iter().map(f).collect());
    let fmt = |x: f64| {
        if x >= 100.0 {
            format!("{x:.0}")
        } else if x >= 1.0 {
            format!("{x:.2}")
        } else {
            format!("{x:.3}")
        }
    };
    println!(
        "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
        r.name,
        r.vertices,
        r.constraints,
        r.status,
        r.runs,
        fmt(m(|t| t.load_ms)),
        fmt(m(|t| t.topology_ms)),
        fmt(m(|t| t.boundary_ms)),
        fmt(m(|t| t.factor_ms)),
        fmt(m(|t| t.solve_ms)),
        fmt(m(|t| t.stepping_ms)),
        fmt(m(|t| t.guard_ms)),
        fmt(m(|t| t.complete_ms)),
        fmt(m(|t| t.polish_ms)),
        fmt(m(|t| t.export_ms)),
        fmt(m(|t| t.topology_ms + t.boundary_ms + t.factor_ms + t.solve_ms)),
        fmt(m(|t| t.total_ms())),
    );
}

/// uvpin's layout of `mesh` without constraints, as stored: the step-1
/// layout, polished if `options` polish (the defaults do, up to 20k vertices).
fn unconstrained_uvs(mesh: &TriMesh, options: SolverOptions) -> Vec<[f32; 2]> {
    uvpin::solve_mesh(mesh, &uvpin::Pins::new(&[]), &options.into())
        .expect("step 1")
        .uvs
}

/// The smooth bijective warp of the warped cases.
fn warp(xy: DVec2) -> DVec2 {
    smooth_warp(xy, 0.12)
}

/// `k` interior vertices with targets = uvpin's unconstrained layout
/// (defaults) through the smooth warp.
fn warp_constraints(mesh: &TriMesh, k: usize, seed: u64) -> Vec<(u32, DVec2)> {
    mapped_constraints(&unconstrained_uvs(mesh, SolverOptions::DEFAULT), k, seed, warp)
}

/// `k` interior vertices of the fold-free layout `uvs` with targets = their
/// positions through `map` (a bijection of the square in its centred
/// coordinates).
fn mapped_constraints(uvs: &[[f32; 2]], k: usize, seed: u64, map: impl Fn(DVec2) -> DVec2) -> Vec<(u32, DVec2)> {
    let mut rng = Rng::new(seed);
    let mut out: Vec<(u32, DVec2)> = Vec::new();
    let mut tries = 0;
    while out.len() < k && tries < 100 * k {
        tries += 1;
        let v = rng.below(uvs.len()) as u32;
        let uv = DVec2::new(uvs[v as usize][0] as f64, uvs[v as usize][1] as f64);
        let inside = uv.cmpgt(DVec2::splat(1e-6)).all() && uv.cmplt(DVec2::splat(1.0 - 1e-6)).all();
        if inside && out.iter().all(|(w, _)| *w != v) {
            out.push((v, xy_to_uv(map(uv_to_xy(uv)))));
        }
    }
    out
}

fn bench_mesh(name: &str, mesh: &TriMesh, constraints: &[(u32, DVec2)], runs: usize) -> Row {
    let mut times = Vec::new();
    let mut status = String::new();
    let mut last = None;
    for _ in 0..runs {
        let uvpin::MeshSolution { report, .. } =
            uvpin::solve_mesh(mesh, &uvpin::Pins::new(constraints), &SolverOptions::DEFAULT.into()).expect("solve");
        status = format!("{:?}", report.status).to_lowercase();
        times.push(report.times);
        last = Some(report);
    }
    Row {
        name: name.into(),
        vertices: mesh.n_vertices(),
        constraints: constraints.len(),
        status,
        runs,
        times,
        report: last,
    }
}

/// One case of an interleaved set: name, mesh, constraints, options.
type Case<'a> = (&'a str, &'a TriMesh, Vec<(u32, DVec2)>, SolverOptions);

/// Runs `cases` round-robin, one solve of each per round, `runs` rounds.
/// This machine switches between fast and slow spells lasting about a
/// second (up to 2× apart); run back to back, a case's runs would all land
/// in one spell, so rows could not be compared with each other.
fn bench_interleaved(cases: &[Case], runs: usize) -> Vec<Row> {
    let mut rows: Vec<Row> = cases
        .iter()
        .map(|(name, mesh, constraints, _)| Row {
            name: (*name).into(),
            vertices: mesh.n_vertices(),
            constraints: constraints.len(),
            status: String::new(),
            runs,
            times: Vec::new(),
            report: None,
        })
        .collect();
    for _ in 0..runs {
        for ((_, mesh, constraints, options), row) in cases.iter().zip(&mut rows) {
            let uvpin::MeshSolution { report, .. } =
                uvpin::solve_mesh(mesh, &uvpin::Pins::new(constraints), &(*options).into()).expect("solve");
            row.status = format!("{:?}", report.status).to_lowercase();
            row.times.push(report.times);
            row.report = Some(report);
        }
    }
    rows
}

fn bench_file(name: &str, constraints: &Path, out: &Path, runs: usize) -> Option<Row> {
    let mut times = Vec::new();
    let mut last: Option<Report> = None;
    let options = uvpin::Options {
        output: Some(out.to_path_buf()),
        ..Default::default()
    };
    for _ in 0..runs {
        let report = uvpin::solve_file(constraints, &options)
            .map_err(|e| eprintln!("{name}: {e}"))
            .ok()?;
        times.push(report.times);
        last = Some(report);
    }
    let r = last?;
    Some(Row {
        name: name.into(),
        vertices: r.counts.vertices,
        constraints: r.constraints.len(),
        status: format!("{:?}", r.status).to_lowercase(),
        runs,
        times,
        report: Some(r),
    })
}

/// The text of a constraint file for `asset` with `constraints`, without
/// its closing parenthesis (options may follow).
fn constraint_text(asset: &Path, constraints: &[(u32, DVec2)]) -> String {
    let mut text = format!("(asset: {:?}, constraints: [\n", asset.display().to_string());
    for (v, uv) in constraints {
        text += &format!("  (vertex: {v}, uv: ({}, {})),\n", uv.x, uv.y);
    }
    text + "]"
}

/// A curved, jittered grid patch like a scanned surface.
fn curved_grid(n: usize, seed: u64) -> TriMesh {
    let mut rng = Rng::new(seed);
    uvpin::testing::random_disk(&mut rng, n, 0)
}

fn main() {
    let filter: Option<String> = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let wanted = |name: &str| filter.as_ref().is_none_or(|f| name.contains(f.as_str()));
    let tmp = std::env::temp_dir().join(format!("uvpin-bench-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    println!("uvpin per-stage medians, milliseconds (release build, Par::Seq)\n");
    print_header();
    let mut rows: Vec<Row> = Vec::new();
    let show = |row: Row, rows: &mut Vec<Row>| {
        print_row(&row);
        rows.push(row);
    };

    if wanted("sample") {
        let sample = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/face.uvpin.ron");
        if let Some(r) = bench_file("sample face (assets/)", &sample, &tmp.join("face.glb"), 21) {
            show(r, &mut rows);
        }
    }
    if wanted("paper") {
        let mesh = curved_grid(41, 1);
        let c = warp_constraints(&mesh, 50, 2);
        let mut no_polish = SolverOptions::DEFAULT;
        no_polish.polish = false;
        // The paper's Fig. 8 crossing at the same size: the spline path stalls.
        let (a, b) = (15 + 41 * 20, 25 + 41 * 20);
        let uvs = unconstrained_uvs(&mesh, no_polish);
        let at = |v: u32| DVec2::new(uvs[v as usize][0] as f64, uvs[v as usize][1] as f64);
        let crossing = vec![(a, at(b)), (b, at(a))];
        // 50 constraints turned by a strong swirl: the spline path stalls and
        // the completion reaches them (its result is the witness).
        let swirled = mapped_constraints(&uvs, 50, 2, |xy| swirl(xy, 4.0));
        let d = SolverOptions::DEFAULT;
        let cases: Vec<Case> = vec![
            ("paper size: 41² curved grid", &mesh, c.clone(), d),
            ("paper size, polish off", &mesh, c, no_polish),
            ("paper size, crossing pair", &mesh, crossing, d),
            ("paper size, swirl (stalls)", &mesh, swirled.clone(), d),
            ("paper size, swirl, polish off", &mesh, swirled, no_polish),
        ];
        for row in bench_interleaved(&cases, 21) {
            show(row, &mut rows);
        }
    }
    let shared = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes");
    if shared.is_dir() {
        for (file, runs) in [
            ("woody.glb", 11),
            ("halftunnel.glb", 11),
            ("alligator.glb", 11),
            ("lion.glb", 7),
            ("camelhead.glb", 7),
            ("face.glb", 5),
        ] {
            let name = format!("{file} (40 constraints)");
            if !wanted(&name) {
                continue;
            }
            let asset = uvpin::io::load_asset(&shared.join(file), None, 0).expect("shared mesh");
            let mesh = uvpin::mesh::weld::weld(&asset.primitives).mesh;
            let uvs = unconstrained_uvs(&mesh, SolverOptions::DEFAULT);
            let c = mapped_constraints(&uvs, 40, 3, warp);
            let ron = tmp.join(format!("{file}.uvpin.ron"));
            let text = constraint_text(&shared.join(file), &c);
            std::fs::write(&ron, format!("{text})\n")).expect("write");
            if let Some(r) = bench_file(&name, &ron, &tmp.join(file), runs) {
                show(r, &mut rows);
            }
            // The 26k-vertex patch once more with the completion doing all
            // the work (the goal's worst case: 0.5 s with it taking over).
            if file == "face.glb" {
                let forced = tmp.join("face.always.uvpin.ron");
                std::fs::write(&forced, format!("{text}, solver: (completion: Always))\n")).expect("write");
                let name = format!("{file} (40 constraints, completion: Always)");
                if let Some(r) = bench_file(&name, &forced, &tmp.join("face.always.glb"), runs) {
                    show(r, &mut rows);
                }
                // A real stall at 26k vertices: the same 40 vertices turned
                // by a 4 rad swirl (the whole swirled step-1 layout is
                // fold-free, so it is reachable); the spline path stalls at
                // once and the completion does all the work.
                let turn = |xy: DVec2| swirl(xy, 4.0);
                let swirled = mapped_constraints(&uvs, 40, 3, turn);
                let ron = tmp.join("face.swirl.uvpin.ron");
                let text = constraint_text(&shared.join(file), &swirled);
                std::fs::write(&ron, format!("{text})\n")).expect("write");
                let witness: Vec<[f32; 2]> = uvs
                    .iter()
                    .map(|p| {
                        let q = xy_to_uv(turn(uv_to_xy(DVec2::new(p[0] as f64, p[1] as f64))));
                        [q.x as f32, q.y as f32]
                    })
                    .collect();
                let folds = uvpin::guard::count_uv_orientations(&witness, &mesh.triangles);
                let name = if folds.is_clean() {
                    format!("{file} (40 constraints swirled 4 rad, stalls)")
                } else {
                    format!("{file} (40 constraints swirled 4 rad, stalls; its witness folds: {folds:?})")
                };
                if let Some(r) = bench_file(&name, &ron, &tmp.join("face.swirl.glb"), 3) {
                    show(r, &mut rows);
                }
            }
        }
    } else {
        eprintln!("(../shared/meshes not found: shared meshes skipped)");
    }
    for (n, runs, k) in [(100usize, 11usize, 40usize), (317, 5, 40), (1000, 3, 0)] {
        let name = format!("grid {n}² ({} constraints)", k);
        if !wanted(&name) {
            continue;
        }
        let mesh = grid_mesh(n, n);
        let c = if k > 0 {
            warp_constraints(&mesh, k, 4)
        } else {
            Vec::new()
        };
        show(bench_mesh(&name, &mesh, &c, runs), &mut rows);
    }
    print_comparison(&rows);
    let _ = std::fs::remove_dir_all(&tmp);
}
