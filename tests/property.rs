//! Property tests: random curved disks with holes × random constraint sets.
//! Whatever the constraints ask, no layout uvpin returns may contain a
//! triangle with zero or positive signed area in glTF (u, v) numbers.

mod common;
use glam::DVec2;
use uvpin::options::SolverOptions;
use uvpin::param::{uv_to_xy, xy_to_uv};
use uvpin::report::Status;
use uvpin::testing::{Rng, random_disk, smooth_warp};

/// Pins on the square.
fn square(constraints: &[(u32, DVec2)]) -> uvpin::Pins {
    uvpin::Pins::new(constraints).with_boundary(uvpin::pins::BoundaryChoice::Square)
}

/// Vertices not on the outer boundary (the longest loop).
fn interior_vertices(mesh: &uvpin::mesh::TriMesh) -> Vec<u32> {
    let topo = uvpin::mesh::topology::Topology::build(mesh).expect("disk");
    let outer = topo.outer_loop();
    (0..mesh.n_vertices() as u32).filter(|v| !outer.contains(v)).collect()
}

#[test]
fn random_disks_and_random_constraints_never_fold() {
    let mut reached = 0;
    let mut partial = 0;
    let mut proven = 0;
    let mut bulged = 0;
    // UVPIN_PROPERTY_CASES=3000 for a longer stress run.
    let cases: u64 = std::env::var("UVPIN_PROPERTY_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(240);
    for case in 0..cases {
        let mut rng = Rng::new(1000 + case);
        let n = 8 + rng.below(14);
        let holes = rng.below(4);
        let mesh = random_disk(&mut rng, n, holes);
        let uvpin::MeshSolution { report: step1, uvs, .. } =
            uvpin::solve_mesh(&mesh, &square(&[]), &SolverOptions::DEFAULT.into()).expect("step 1");
        assert_eq!(step1.status, Status::Reached);
        assert!(step1.orientation.is_clean(), "case {case}: step 1 folds");
        if step1.boundary.as_ref().unwrap().shape != uvpin::param::boundary::BoundaryShape::Square {
            bulged += 1;
        }
        let interior = interior_vertices(&mesh);
        let k = 1 + rng.below(12.min(interior.len()));
        let mut constraints: Vec<(u32, DVec2)> = Vec::new();
        let warp = case % 2 == 0;
        let amp = rng.range(0.02, 0.14);
        while constraints.len() < k {
            let v = interior[rng.below(interior.len())];
            if constraints.iter().any(|c| c.0 == v) {
                continue;
            }
            let at = DVec2::new(uvs[v as usize][0] as f64, uvs[v as usize][1] as f64);
            let target = if warp {
                xy_to_uv(smooth_warp(uv_to_xy(at), amp))
            } else {
                DVec2::new(rng.range(0.02, 0.98), rng.range(0.02, 0.98))
            };
            constraints.push((v, target));
        }
        let uvpin::MeshSolution {
            report,
            uvs,
            corner_uvs,
        } = uvpin::solve_mesh(&mesh, &uvpin::Pins::new(&constraints), &SolverOptions::DEFAULT.into())
            .unwrap_or_else(|e| panic!("case {case}: {e}"));
        // The report counts virtual hole triangles too; check the real ones
        // independently, per corner (a chart cut open has two sides on a seam).
        assert!(report.orientation.is_clean(), "case {case}: {:?}", report.orientation);
        let corners: Vec<[u32; 3]> = (0..mesh.n_triangles() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        let counts = uvpin::guard::count_uv_orientations(&corner_uvs, &corners);
        assert!(counts.is_clean(), "case {case}: {counts:?}");
        // Soundness of the certificates: never for targets that were
        // reached; the report carries the same one when they were not.
        let proof = uvpin::unreachable_proof(&mesh, &uvpin::Pins::new(&constraints)).unwrap();
        // The proof holds on the square (its boundary pinned); a free
        // boundary moves, and may reach what the square cannot.
        let on_square = report.boundary_mode == uvpin::report::BoundaryMode::Square;
        match report.status {
            Status::Reached if on_square => {
                assert_eq!(proof, None, "case {case}: reached, yet 'proven' unreachable")
            }
            Status::Reached => {}
            _ if on_square => assert_eq!(report.unreachable_proof, proof, "case {case}"),
            _ => {}
        }
        proven += usize::from(proof.is_some());
        match report.status {
            Status::Reached => {
                reached += 1;
                assert!(report.max_residual <= 1e-9, "case {case}");
                for (v, t) in &constraints {
                    let got = DVec2::new(uvs[*v as usize][0] as f64, uvs[*v as usize][1] as f64);
                    assert!(got.distance(*t) < 1e-6, "case {case}: vertex {v}");
                }
            }
            Status::Partial => {
                partial += 1;
                assert!(report.message.is_some());
                assert!(
                    report.every_constraint().any(|c| !c.reached),
                    "case {case}: partial with every constraint reached: {:?}",
                    report.message
                );
            }
            Status::Error => panic!("case {case}: {:?}", report.message),
        }
    }
    eprintln!(
        "{cases} cases: {reached} reached, {partial} partial ({proven} of them proven unreachable), 0 folded; \
         {bulged} needed the bulged boundary"
    );
    assert!(
        bulged * 20 <= cases as usize,
        "the square should be kept in nearly every case ({bulged} bulged)"
    );
    assert_eq!(reached + partial, cases as usize);
    assert!(reached > 0 && partial > 0, "the corpus should exercise both outcomes");
}

#[test]
fn fewer_than_three_constraints_are_handled() {
    // One or two constraints alone make the spline system singular; the
    // boundary anchors make it well posed.
    let mut rng = Rng::new(9);
    let mesh = random_disk(&mut rng, 15, 1);
    let uvpin::MeshSolution { uvs, .. } =
        uvpin::solve_mesh(&mesh, &uvpin::Pins::new(&[]), &SolverOptions::DEFAULT.into()).unwrap();
    let interior = interior_vertices(&mesh);
    for k in 1..=2 {
        let constraints: Vec<(u32, DVec2)> = interior
            .iter()
            .take(k)
            .map(|&v| {
                (
                    v,
                    xy_to_uv(smooth_warp(
                        uv_to_xy(DVec2::new(uvs[v as usize][0] as f64, uvs[v as usize][1] as f64)),
                        0.05,
                    )),
                )
            })
            .collect();
        let uvpin::MeshSolution { report, .. } =
            uvpin::solve_mesh(&mesh, &uvpin::Pins::new(&constraints), &SolverOptions::DEFAULT.into()).unwrap();
        assert_eq!(report.status, Status::Reached, "{k} constraints: {:?}", report.message);
    }
}

/// A random closed surface: a bumpy sphere, a bumpy torus or a holed
/// plate of genus 1 or 2, at a random resolution.
fn random_closed(rng: &mut Rng) -> uvpin::mesh::TriMesh {
    let mut mesh = match rng.below(4) {
        0 | 1 => uvpin::testing::uv_sphere(6 + rng.below(10), 8 + rng.below(14)),
        2 => uvpin::testing::torus(12 + rng.below(16), 6 + rng.below(8), 1.0, rng.range(0.2, 0.5)),
        _ => uvpin::testing::holed_plate(6 + rng.below(6), 1 + rng.below(2)),
    };
    let (a, b, c) = (rng.range(-0.3, 0.3), rng.range(-0.3, 0.3), rng.range(1.0, 4.0));
    for p in &mut mesh.positions {
        let bump = 1.0 + a * (c * p.x).sin() + b * (c * p.y).cos() * p.z;
        *p *= bump.max(0.3);
    }
    mesh
}

/// Every triangle of `corner_uvs` (per triangle corner, glTF (u, v))
/// keeps its orientation, and the layout is one-to-one: uvpin's check of
/// the triangles exploded into corners (each its own vertex).
fn assert_fold_free_and_one_to_one(name: &str, mesh: &uvpin::mesh::TriMesh, corner_uvs: &[[f32; 2]]) {
    let exploded = uvpin::mesh::TriMesh {
        positions: mesh
            .triangles
            .iter()
            .flatten()
            .map(|&v| mesh.positions[v as usize])
            .collect(),
        triangles: (0..mesh.n_triangles() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect(),
    };
    let counts = uvpin::guard::count_uv_orientations(corner_uvs, &exploded.triangles);
    assert!(counts.is_clean(), "{name}: {counts:?}");
    let checked = uvpin::check::check_mesh(&exploded, corner_uvs);
    assert!(checked.atlas.injective, "{name}: {:?}", checked.atlas);
}

#[test]
fn random_closed_meshes_and_random_landmarks_never_write_a_fold_or_an_overlap() {
    let cases: u64 = std::env::var("UVPIN_PROPERTY_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(40);
    let (mut reached, mut partial, mut refused) = (0, 0, 0);
    let mut worst: f64 = 0.0;
    for case in 0..cases {
        let mut rng = Rng::new(9_000 + case);
        let mesh = random_closed(&mut rng);
        let k = 1 + rng.below(8);
        let mut pins = Vec::new();
        while pins.len() < k {
            let v = rng.below(mesh.n_vertices()) as u32;
            if pins.iter().all(|(w, _)| *w != v) {
                pins.push((v, DVec2::new(rng.range(0.1, 0.9), rng.range(0.1, 0.9))));
            }
        }
        let name = format!("case {case} ({} vertices, {k} pins)", mesh.n_vertices());
        let solved = match uvpin::solve_mesh(&mesh, &uvpin::Pins::new(&pins), &SolverOptions::DEFAULT.into()) {
            Ok(s) => s,
            // Bad input is refused by name; nothing to check.
            Err(_) => {
                refused += 1;
                continue;
            }
        };
        match solved.report.status {
            Status::Reached => reached += 1,
            Status::Partial => partial += 1,
            Status::Error => {
                refused += 1;
                continue;
            }
        }
        assert_eq!(
            solved.corner_uvs.len(),
            3 * mesh.n_triangles(),
            "{name}: every triangle has UVs"
        );
        assert_fold_free_and_one_to_one(&name, &mesh, &solved.corner_uvs);
        if solved.report.status == Status::Partial {
            // A partial layout stays usable: at most 3 times as stretched as
            // the chart's own shape (its free layout without landmarks).
            let yardstick = solved
                .report
                .stretch_own
                .unwrap_or_else(|| {
                    panic!(
                        "{name}: a partial result names its yardstick\n{}",
                        solved.report.explain.join("\n")
                    )
                })
                .l2;
            let ratio = solved.report.stretch_final.l2 / yardstick;
            worst = worst.max(ratio);
            assert!(
                ratio <= 3.0 + 1e-9,
                "{name}: partial L2 {} against its own shape's {yardstick}",
                solved.report.stretch_final.l2
            );
        }
    }
    eprintln!(
        "{cases} closed cases: {reached} reached, {partial} partial, {refused} refused; worst partial stretch ratio {worst:.2}"
    );
    assert!(
        reached + partial >= cases as usize * 3 / 4,
        "most random cases give a layout"
    );
}

/// Photo-style landmark sets: an orthographic view of the visible vertices
/// from a random direction, 8 to 24 landmarks, targets spanning 30 to 90 %
/// of the texture.
fn photo_set(mesh: &uvpin::mesh::TriMesh, rng: &mut Rng) -> Option<Vec<(u32, DVec2)>> {
    let view = glam::DVec3::new(rng.f64() - 0.5, rng.f64() - 0.5, rng.f64() - 0.5).normalize();
    let up = if view.z.abs() > 0.9 {
        glam::DVec3::X
    } else {
        glam::DVec3::Z
    };
    let (k, span) = (8 + rng.below(17), rng.range(0.3, 0.9));
    let quiet = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let found = std::panic::catch_unwind(|| uvpin::testing::photo_landmarks(mesh, view, up, k, span));
    std::panic::set_hook(quiet);
    Some(found.ok()?.into_iter().map(|(v, u, w)| (v, DVec2::new(u, w))).collect())
}

/// Reached, or proven unreachable (the completion found an obstruction):
/// never short for want of trying the right candidate.
fn reached_or_proven(report: &uvpin::Report) -> bool {
    report.status == Status::Reached || report.completion.as_ref().is_some_and(|c| c.proven_unreachable)
}

/// Every candidate the planner weighs (as given, cut, as the camera sees
/// it, the landmarks' surroundings; free or on the square) on closed,
/// holed and handled meshes with photo-style landmarks: each set reached or
/// proven unreachable, in both modes, and free never loses a set the
/// square (the default) reaches.
#[test]
fn photo_sets_on_closed_and_handled_meshes_are_reached_and_free_never_loses_one() {
    use uvpin::testing::{blob_head, holed_plate, torus, uv_sphere};
    let meshes = [
        ("sphere", uv_sphere(24, 48)),
        ("torus", torus(48, 24, 1.0, 0.35)),
        ("two-hole plate", holed_plate(16, 2)),
        ("three-hole plate", holed_plate(16, 3)),
        ("head", blob_head(40, 60).0),
    ];
    let cases: usize = std::env::var("UVPIN_PLAN_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4);
    let mut rng = Rng::new(11);
    let (mut n, mut reached) = (0, 0);
    for (name, mesh) in &meshes {
        for case in 0..cases {
            let Some(targets) = photo_set(mesh, &mut rng) else {
                continue;
            };
            let solve = |boundary| {
                let mut pins = uvpin::Pins::new(&targets);
                pins.boundary = boundary;
                uvpin::solve_mesh(mesh, &pins, &uvpin::Options::default()).expect("solved")
            };
            let default = solve(None);
            let free = solve(Some(uvpin::pins::BoundaryChoice::Free));
            for (mode, s) in [("default", &default), ("free", &free)] {
                assert!(
                    reached_or_proven(&s.report),
                    "{name} case {case} ({mode}, {} landmarks): {:?}\n{}",
                    targets.len(),
                    s.report.status,
                    s.report.explain.join("\n")
                );
                n += 1;
                reached += usize::from(s.report.status == Status::Reached);
            }
            assert!(
                default.report.status != Status::Reached || free.report.status == Status::Reached,
                "{name} case {case}: the square reached, free did not\n{}",
                free.report.explain.join("\n")
            );
        }
    }
    eprintln!("photo sets: {reached} of {n} reached");
    assert!(n >= 10 * cases, "too few photo sets could be made: {n}");
}

/// Square-witness sets (targets from a fold-free square layout pushed
/// through a warp that keeps the square's border): reached on the square,
/// and free reaches them too without the square's hint; the last two on
/// charts large enough to be tried on their coarse level first.
#[test]
fn free_reaches_every_square_witnessed_set() {
    let mut rng = Rng::new(23);
    let mut n = 0;
    for seed in 0..8u64 {
        let size = if seed < 6 {
            12 + rng.below(20)
        } else {
            80 + rng.below(10)
        };
        let holes = rng.below(3);
        let mesh = random_disk(&mut rng, size, holes);
        let Some((targets, _)) = uvpin::testing::witnessed_square_case(&mesh, 4 + rng.below(12), seed) else {
            continue;
        };
        let solve = |boundary| {
            let pins = uvpin::Pins::new(&targets).with_boundary(boundary);
            uvpin::solve_mesh(&mesh, &pins, &uvpin::Options::default()).expect("solved")
        };
        let square = solve(uvpin::pins::BoundaryChoice::Square);
        let free = solve(uvpin::pins::BoundaryChoice::Free);
        assert_eq!(
            square.report.status,
            Status::Reached,
            "seed {seed}: {}",
            square.report.explain.join("\n")
        );
        assert_eq!(
            free.report.status,
            Status::Reached,
            "seed {seed}: {}",
            free.report.explain.join("\n")
        );
        eprintln!(
            "witnessed seed {seed}: {} vertices, {} landmarks",
            mesh.n_vertices(),
            targets.len()
        );
        n += 1;
    }
    assert!(n >= 4, "too few witnessed sets: {n}");
}
