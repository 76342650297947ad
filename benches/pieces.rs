//! Meshes in many pieces, as vegetation, kit-bashed scenes and unwelded
//! exports come: a field of separate tiles of five sizes, the landmarks on
//! the first, every other tile unwrapped and packed around it, written as a
//! new UV set. Median of 3 solves, peak resident memory.
//! `cargo bench --bench pieces [FILTER]`.

mod common;
use glam::{DVec2, DVec3};
use uvpin::mesh::TriMesh;
use uvpin::options::SolverOptions;

/// `n` tiles (rounded to a square field), each a quad of its own four vertices.
fn tiles(n: usize) -> TriMesh {
    let side = (n as f64).sqrt().ceil() as usize;
    let mut mesh = TriMesh {
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    for k in 0..side * side {
        let (i, j) = ((k % side) as f64, (k / side) as f64);
        let s = 0.5 + 0.1 * (k % 5) as f64;
        let base = mesh.positions.len() as u32;
        for (a, b) in [(0.0, 0.0), (s, 0.0), (s, 0.7 * s), (0.0, s)] {
            mesh.positions.push(DVec3::new(i + a, j + b, 0.01 * (k % 7) as f64));
        }
        mesh.triangles.push([base, base + 1, base + 2]);
        mesh.triangles.push([base, base + 2, base + 3]);
    }
    mesh
}

fn main() {
    let filter = common::filter();
    let mut rows = String::new();
    for n in [1_000, 10_000, 40_000] {
        let mesh = tiles(n);
        let name = format!("{} pieces", mesh.n_triangles() / 2);
        if filter.as_ref().is_some_and(|f| !name.contains(f.as_str())) {
            continue;
        }
        eprintln!("{name}");
        // The first tile's corners, kept turning the same way (v down).
        let pins = uvpin::Pins::new(&[
            (0, DVec2::new(0.1, 0.2)),
            (1, DVec2::new(0.2, 0.2)),
            (2, DVec2::new(0.2, 0.13)),
        ]);
        let mut ms = Vec::new();
        let mut status = String::new();
        common::reset_peak();
        for _ in 0..3 {
            let t0 = std::time::Instant::now();
            let solved = uvpin::solve_mesh(&mesh, &pins, &SolverOptions::DEFAULT.into()).expect("solve");
            ms.push(t0.elapsed().as_secs_f64() * 1e3);
            let r = &solved.report;
            assert_eq!(r.orientation.flipped + r.orientation.zero_area, 0, "a fold");
            status = format!("{:?}", r.status).to_lowercase();
            eprintln!("  {status} in {:.0} ms", ms.last().expect("a run"));
        }
        rows += &format!(
            "| {} | {} | {} | {:.0} | {:.0} |\n",
            mesh.n_triangles() / 2,
            mesh.n_vertices(),
            status,
            common::median(ms),
            common::peak_mb()
        );
    }
    let body = format!(
        "A field of separate tiles (five sizes), three landmarks on the first, every other tile unwrapped and \
         packed around it; `solve_mesh`, uvpin's defaults. Median milliseconds of 3 solves, peak resident memory \
         of the process.\n\n\
         | pieces | vertices | status | ms | peak MB |\n|---:|---:|---|---:|---:|\n{rows}"
    );
    common::publish("pieces", "Many pieces: a soup of separate tiles", &body);
}
