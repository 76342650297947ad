//! Per-stage timings: `cargo bench --bench stages [-- FILTER]`.
//!
//! Medians (ms) over repeated runs for the sample asset, the paper's case
//! size (1.7k vertices, 50 constraints), the shared third-party meshes (end
//! to end through glTF files, if `../shared/meshes` exists), and generated
//! grids of 10k, 100k and 1M vertices; then step 1 alone against uvpin's
//! result. Constrained cases use targets pushed through a smooth bijective
//! warp (or a swirl) of the unconstrained layout, so they are reachable. A
//! full run (no filter) writes the tables into `docs/benchmarks.md`. Not a
//! test: no thresholds, just figures.

mod common;

use glam::DVec2;
use std::path::{Path, PathBuf};
use uvpin::mesh::TriMesh;
use uvpin::options::SolverOptions;
use uvpin::param::{uv_to_xy, xy_to_uv};
use uvpin::pins::BoundaryChoice;
use uvpin::report::{Report, StageTimes};
use uvpin::testing::{Rng, grid_mesh, smooth_warp, swirl};

use common::median;

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
fn comparison_table(rows: &[Row]) -> String {
    let mut out = String::from("| case | step 1: L2 | L∞ | max residual | ms | uvpin: L2 | L∞ | max residual | ms |\n");
    out += "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for r in rows {
        let Some(rep) = &r.report else { continue };
        let total_ms = median(r.times.iter().map(|t| t.total_ms()).collect());
        if rep.coarse_level.is_some() {
            // Started from its coarse level: no step 1 of its own.
            out += &format!(
                "| {} | – | – | – | – | {:.3} | {:.3} | {:.1e} | {:.1} |\n",
                r.name, rep.stretch_final.l2, rep.stretch_final.linf, rep.max_residual, total_ms
            );
            continue;
        }
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
        out += &format!(
            "| {} | {:.3} | {:.3} | {:.3e} | {:.1} | {:.3} | {:.3} | {:.1e} | {:.1} |\n",
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
    out
}

const HEADER: &str = "| case | vertices | constraints | status | runs | load | topology | boundary | factor | solve | spline | guard | completion | polish | export | step 1 | total |\n\
|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|";

fn stage_row(r: &Row) -> String {
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
    format!(
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
    )
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

/// One case of an interleaved set: name, mesh, constraints, options, boundary.
type Case<'a> = (&'a str, &'a TriMesh, Vec<(u32, DVec2)>, SolverOptions, BoundaryChoice);

/// Runs `cases` round-robin, one solve of each per round, `runs` rounds, so
/// that the rows are measured side by side (a shared machine's speed drifts;
/// run back to back, each row would see a different part of the drift).
fn bench_interleaved(cases: &[Case], runs: usize) -> Vec<Row> {
    let mut rows: Vec<Row> = cases
        .iter()
        .map(|(name, mesh, constraints, _, _)| Row {
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
        for ((_, mesh, constraints, options, boundary), row) in cases.iter().zip(&mut rows) {
            let pins = uvpin::Pins::new(constraints).with_boundary(*boundary);
            let uvpin::MeshSolution { report, .. } = uvpin::solve_mesh(mesh, &pins, &(*options).into()).expect("solve");
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

/// The sample asset, end to end through its files.
fn sample_rows(tmp: &Path) -> Vec<Row> {
    let sample = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/face.uvpin.ron");
    bench_file("sample face (assets/)", &sample, &tmp.join("face.glb"), 21)
        .into_iter()
        .collect()
}

/// The paper's case size, with the polish on and off, the Fig. 8 crossing
/// and a strong swirl that stalls the spline path.
fn paper_rows() -> Vec<Row> {
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
    let (square, free) = (BoundaryChoice::Square, BoundaryChoice::Free);
    let cases: Vec<Case> = vec![
        ("paper size: 41² curved grid", &mesh, c.clone(), d, square),
        ("paper size, polish off", &mesh, c.clone(), no_polish, square),
        ("paper size, free boundary", &mesh, c, d, free),
        ("paper size, crossing pair", &mesh, crossing.clone(), d, square),
        ("paper size, crossing pair, free boundary", &mesh, crossing, d, free),
        ("paper size, swirl (stalls)", &mesh, swirled.clone(), d, square),
        ("paper size, swirl, polish off", &mesh, swirled, no_polish, square),
    ];
    bench_interleaved(&cases, 21)
}

/// A 26k-vertex real stall: the face's 40 vertices turned by a 4 rad swirl
/// (the whole swirled layout is checked to be fold-free, so it is reachable).
fn face_swirl_row(tmp: &Path, asset: &Path, mesh: &TriMesh, uvs: &[[f32; 2]]) -> Option<Row> {
    let turn = |xy: DVec2| swirl(xy, 4.0);
    let swirled = mapped_constraints(uvs, 40, 3, turn);
    let ron = tmp.join("face.swirl.uvpin.ron");
    std::fs::write(&ron, format!("{})\n", constraint_text(asset, &swirled))).expect("write");
    let witness: Vec<[f32; 2]> = uvs
        .iter()
        .map(|p| {
            let q = xy_to_uv(turn(uv_to_xy(DVec2::new(p[0] as f64, p[1] as f64))));
            [q.x as f32, q.y as f32]
        })
        .collect();
    let folds = uvpin::guard::count_uv_orientations(&witness, &mesh.triangles);
    let name = if folds.is_clean() {
        "face.glb (40 constraints swirled 4 rad, stalls)".to_string()
    } else {
        format!("face.glb (40 constraints swirled 4 rad, stalls; its witness folds: {folds:?})")
    };
    bench_file(&name, &ron, &tmp.join("face.swirl.glb"), 3)
}

/// The shared third-party meshes with 40 warped constraints each (and the
/// face twice more: the completion doing all the work, and a swirl).
fn shared_rows(tmp: &Path, wanted: &dyn Fn(&str) -> bool) -> Vec<Row> {
    let shared = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes");
    if !shared.is_dir() {
        eprintln!("(../shared/meshes not found: shared meshes skipped)");
        return Vec::new();
    }
    let mut rows = Vec::new();
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
        let asset = uvpin::io::load_asset(&shared.join(file), None, 0, &Default::default()).expect("shared mesh");
        let mesh = uvpin::mesh::weld::weld(&asset.primitives).mesh;
        let uvs = unconstrained_uvs(&mesh, SolverOptions::DEFAULT);
        let c = mapped_constraints(&uvs, 40, 3, warp);
        let ron = tmp.join(format!("{file}.uvpin.ron"));
        let text = constraint_text(&shared.join(file), &c);
        std::fs::write(&ron, format!("{text})\n")).expect("write");
        rows.extend(bench_file(&name, &ron, &tmp.join(file), runs));
        if file == "face.glb" {
            let forced = tmp.join("face.always.uvpin.ron");
            std::fs::write(&forced, format!("{text}, solver: (completion: Always))\n")).expect("write");
            let name = format!("{file} (40 constraints, completion: Always)");
            rows.extend(bench_file(&name, &forced, &tmp.join("face.always.glb"), runs));
            rows.extend(face_swirl_row(tmp, &shared.join(file), &mesh, &uvs));
        }
    }
    rows
}

/// Generated grids of 10k, 100k and 1M vertices.
fn grid_rows(wanted: &dyn Fn(&str) -> bool) -> Vec<Row> {
    let mut rows = Vec::new();
    for (n, runs, k) in [(100usize, 11usize, 40usize), (317, 5, 40), (1000, 3, 0)] {
        let name = format!("grid {n}² ({k} constraints)");
        if !wanted(&name) {
            continue;
        }
        let mesh = grid_mesh(n, n);
        let c = if k > 0 {
            warp_constraints(&mesh, k, 4)
        } else {
            Vec::new()
        };
        rows.push(bench_mesh(&name, &mesh, &c, runs));
    }
    rows
}

fn main() {
    let filter = common::filter();
    let wanted = |name: &str| filter.as_ref().is_none_or(|f| name.contains(f.as_str()));
    let tmp = std::env::temp_dir().join(format!("uvpin-bench-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    println!("{HEADER}");
    let mut rows: Vec<Row> = Vec::new();
    let mut show = |new: Vec<Row>| {
        for r in new {
            println!("{}", stage_row(&r));
            rows.push(r);
        }
    };
    if wanted("sample") {
        show(sample_rows(&tmp));
    }
    if wanted("paper") {
        show(paper_rows());
    }
    show(shared_rows(&tmp, &wanted));
    show(grid_rows(&wanted));
    let stages: Vec<String> = rows.iter().map(stage_row).collect();
    let body = format!(
        "Per-stage medians in milliseconds (`cargo bench --bench stages`); the paper-size rows are \
         measured side by side, interleaved.\n\n{HEADER}\n{}\n\nStep 1 alone against uvpin's result \
         (Sander L2 and L∞ stretch, 1 = isometry; largest distance of a constraint from its target; – where a chart \
         starts from its coarse level, without a step 1 of its own):\n\n{}",
        stages.join("\n"),
        comparison_table(&rows)
    );
    common::publish("stages", "Stages", &body);
    let _ = std::fs::remove_dir_all(&tmp);
}
