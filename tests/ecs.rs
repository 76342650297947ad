//! The ECS schedule on a bare World: stage order, and the rules the daemon
//! relies on (re-solving a changed boundary reuses the factorisation).

use bevy_ecs::prelude::*;
use std::path::Path;
use std::sync::Arc;
use uvpin::constraints::LoadedConstraints;
use uvpin::ecs::*;
use uvpin::io::SourceAsset;
use uvpin::testing::grid_mesh;

fn spawn(world: &mut World, ron: &str) -> Entity {
    spawn_mesh(world, ron, true)
}

fn spawn_mesh(world: &mut World, ron: &str, curved: bool) -> Entity {
    let mut mesh = grid_mesh(12, 12);
    if curved {
        for p in &mut mesh.positions {
            p.z = 0.2 * (p.x * 4.0).cos();
        }
    }
    let loaded = LoadedConstraints::parse(Path::new("mem.uvpin.ron"), ron).unwrap();
    let job = SolveJob::from_file(loaded, Arc::new(SourceAsset::from_mesh(&mesh)), None);
    spawn_job(world, job, 0.0).unwrap()
}

#[test]
fn a_tick_advances_each_stage_in_order() {
    let mut world = World::new();
    let e = spawn(
        &mut world,
        "(asset: \"m\", constraints: [(vertex: 40, uv: (0.35, 0.62))])",
    );
    let mut schedule = solve_schedule();
    let session = |world: &World| world.get::<Session>(e).unwrap().0.clone();
    assert!(session(&world).boundary().is_none());
    schedule.run(&mut world);
    // One tick: boundary → factor → step 1 → the plan started → its first step.
    assert!(session(&world).boundary().is_some());
    assert!(session(&world).bar_net().is_some());
    assert!(session(&world).step_one_layout().is_some());
    assert!(world.get::<Planning>(e).is_some());
    let ticks = run_to_convergence(&mut world, &mut schedule, 1000);
    assert!(ticks < 1000);
    let report = &world.get::<Exported>(e).expect("exported").0.report;
    assert_eq!(report.status, uvpin::Status::Reached);
    assert!(world.get::<Planning>(e).is_none(), "the plan is over");
    assert!(uvpin::guard::all_positive(
        world.get::<Finished>(e).unwrap().0.solver.layout(),
        &world.get::<Session>(e).unwrap().0.prepared().filled.mesh.triangles
    ));
}

#[test]
fn a_new_boundary_re_solves_without_refactoring() {
    let mut world = World::new();
    // Flat: the arc-length corners are the grid's corners, so turning the
    // boundary by a quarter keeps every corner on a grid corner (no zero-area trap).
    let e = spawn_mesh(&mut world, "(asset: \"m\", constraints: [])", false);
    let mut schedule = solve_schedule();
    run_to_convergence(&mut world, &mut schedule, 100);
    let session = |world: &World| world.get::<Session>(e).unwrap().0.clone();
    let factor = Arc::clone(session(&world).bar_net().unwrap());
    let first = session(&world).step_one_layout().unwrap().to_vec();
    // Rotate the corners one step along the loop: same fixed set, new positions.
    let mut boundary = session(&world).boundary().unwrap().clone();
    let n = boundary.loop_vertices.len();
    boundary.positions.rotate_right(n / 4);
    world.get_mut::<Session>(e).unwrap().0.replace_boundary(boundary);
    run_to_convergence(&mut world, &mut schedule, 100);
    assert!(
        Arc::ptr_eq(&factor, session(&world).bar_net().unwrap()),
        "the factorisation must be reused"
    );
    let after = session(&world);
    let second = after.step_one_layout().unwrap();
    assert!(
        first.iter().zip(second).any(|(a, b)| a.distance(*b) > 1e-3),
        "the layout must change"
    );
    assert!(world.get::<Exported>(e).is_some(), "the re-solve is exported again");
}

#[test]
fn input_errors_become_a_failed_component() {
    let mut world = World::new();
    // Vertex 1 is on the outer boundary, which the file puts on the square;
    // its target contradicts the boundary map (the file's word is law: no
    // free layout is tried instead).
    let e = spawn(
        &mut world,
        "(asset: \"m\", constraints: [(vertex: 1, uv: (0.5, 0.5))], boundary: Square)",
    );
    let mut schedule = solve_schedule();
    run_to_convergence(&mut world, &mut schedule, 100);
    let failed = world.get::<Failed>(e).expect("failed");
    assert!(failed.0.to_string().contains("outer boundary"), "{}", failed.0);
    assert!(world.get::<Exported>(e).is_none());
}
