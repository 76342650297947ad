//! How the solve scales: the shared face (26k vertices) midpoint-subdivided
//! to 103k, 413k and 1.65M vertices, the same landmarks at every size (a
//! flat subdivision keeps the surface, so a witness of the 26k face is a
//! witness of each), square and free, polished by default. Time per phase,
//! peak memory, stretch. `cargo bench --bench scale [FILTER]`.

mod common;
use glam::DVec2;
use std::path::Path;
use std::time::Instant;
use uvpin::mesh::TriMesh;
use uvpin::options::SolverOptions;
use uvpin::pins::BoundaryChoice;

/// Solves per case, by size.
fn runs(n_vertices: usize) -> usize {
    match n_vertices {
        0..=150_000 => 3,
        _ => 1,
    }
}

/// One solve's figures.
#[derive(Debug, Default, Clone)]
struct Figures {
    ms: Vec<f64>,
    peak_mb: f64,
    status: String,
    l2: f64,
    linf: f64,
    residual: f64,
    phases: String,
}

fn solve(mesh: &TriMesh, constraints: &[(u32, DVec2)], boundary: BoundaryChoice, runs: usize) -> Figures {
    let pins = uvpin::Pins::new(constraints).with_boundary(boundary);
    let mut f = Figures::default();
    for _ in 0..runs {
        common::reset_peak();
        let t0 = Instant::now();
        let s = uvpin::solve_mesh(mesh, &pins, &SolverOptions::DEFAULT.into()).expect("solve");
        f.ms.push(t0.elapsed().as_secs_f64() * 1e3);
        f.peak_mb = f.peak_mb.max(common::peak_mb());
        let r = &s.report;
        let t = &r.times;
        assert_eq!(r.orientation.flipped + r.orientation.zero_area, 0, "a fold");
        f.status = format!("{:?}", r.status).to_lowercase();
        (f.l2, f.linf, f.residual) = (r.stretch_final.l2, r.stretch_final.linf, r.max_residual);
        let coarse = match &r.coarse_level {
            Some(uvpin::report::CoarseLevel::Used(m)) => m.coarsen_ms + m.coarse_solve_ms + m.prolong_ms,
            _ => 0.0,
        };
        let listed = t.topology_ms + t.boundary_ms + t.factor_ms + t.solve_ms + coarse;
        let listed = listed + t.guard_ms + t.complete_ms + t.polish_ms + t.export_ms;
        f.phases = format!(
            "{:.0} / {:.0} / {:.0} / {:.0} / {:.0} / {:.0} / {:.0} / {:.0}",
            t.topology_ms + t.boundary_ms,
            t.factor_ms + t.solve_ms,
            coarse,
            f.ms.last().unwrap() - listed,
            t.guard_ms,
            t.complete_ms,
            t.polish_ms,
            t.export_ms
        );
        eprintln!(
            "  {:?} {:.0} ms, phases {}, peak {:.0} MB",
            boundary,
            f.ms.last().unwrap(),
            f.phases,
            f.peak_mb
        );
        for line in &r.explain {
            eprintln!("    {line}");
        }
    }
    f
}

fn main() {
    let filter = common::filter();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/face.glb");
    if !path.is_file() {
        eprintln!("(../shared/meshes/face.glb not found: nothing to measure)");
        return;
    }
    let asset = uvpin::io::load_asset(&path, None, 0, &Default::default()).expect("face.glb");
    let base = uvpin::mesh::weld::weld(&asset.primitives).mesh;
    let cases: Vec<(usize, Vec<(u32, DVec2)>)> = [24, 40]
        .into_iter()
        .filter_map(|k| Some((k, uvpin::testing::witnessed_free_case(&base, k, 7)?.0)))
        .collect();
    let mut mesh = base;
    let mut rows = String::new();
    for level in 0..4 {
        if level > 0 {
            mesh = uvpin::testing::subdivide_midpoint(&mesh);
        }
        for (k, constraints) in &cases {
            for boundary in [BoundaryChoice::Square, BoundaryChoice::Free] {
                let name = format!("{} vertices, {k} landmarks, {boundary:?}", mesh.n_vertices());
                if filter.as_ref().is_some_and(|f| !name.contains(f.as_str())) {
                    continue;
                }
                eprintln!("{name}");
                let f = solve(&mesh, constraints, boundary, runs(mesh.n_vertices()));
                rows += &format!(
                    "| {} | {k} | {boundary:?} | {} | {:.0} | {} | {:.0} | {:.3} | {:.2} | {:.1e} |\n",
                    mesh.n_vertices(),
                    f.status,
                    common::median(f.ms.clone()),
                    f.phases,
                    f.peak_mb,
                    f.l2,
                    f.linf,
                    f.residual
                );
            }
        }
    }
    let body = format!(
        "The shared face.glb midpoint-subdivided (the surface unchanged), the same witnessed landmarks at every \
         size, uvpin's defaults (polished). Median milliseconds of 3 runs (1 from 413k); phases of the last run: \
         topology and boundary / step 1 (factor and solve) / coarse level (coarsened, solved, prolonged with its \
         sweeps: above 40k vertices) / the rest (the planner's choice, the start, the spline path) / guard / completion / polish / export; peak resident \
         memory of the solve.\n\n\
         | vertices | landmarks | boundary | status | ms | phases ms | peak MB | L2 | L∞ | residual |\n\
         |---:|---:|---|---|---:|---|---:|---:|---:|---:|\n{rows}"
    );
    common::publish("scale", "Scale: the face subdivided to 1.65M vertices", &body);
}
