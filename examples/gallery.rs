//! The README gallery: the sample's layout before (step 1) and after, the
//! checker render through both, and the contact sheet of the sample sweep.
//!
//! `cargo run --release --example gallery` writes `docs/gallery/*.png`
//! (run from the repository root; the sweep's results go to `out/sweep/`).

use bevy_ecs::prelude::*;
use std::path::Path;
use uvpin::ecs::{BoundaryLayout, ChartData, Exported, Layout, Step1Layout};

const SIZE: u32 = 512;

fn main() {
    let docs = Path::new("docs/gallery");
    std::fs::create_dir_all(docs).expect("docs/gallery");
    let (loaded, asset) = uvpin::solve::load(Path::new("assets/face.uvpin.ron")).expect("load the sample");
    let mut world = World::new();
    let e = uvpin::solve::spawn_job(&mut world, loaded, asset, None, 0.0).expect("prepare");
    let mut schedule = uvpin::ecs::solve_schedule();
    uvpin::ecs::run_to_convergence(&mut world, &mut schedule, uvpin::solve::MAX_TICKS);
    let job = world.get::<uvpin::ecs::SolveJob>(e).unwrap();
    let report = &world.get::<Exported>(e).expect("solved").0;
    let data = &world.get::<ChartData>(e).unwrap().0;
    let step1 = &world.get::<Step1Layout>(e).unwrap().0;
    let layout = &world.get::<Layout>(e).unwrap().0;
    let boundary = &world.get::<BoundaryLayout>(e).unwrap().0.loop_vertices;
    // Before: the constraints where step 1 put them, none on target yet.
    let mut before = report.clone();
    for c in &mut before.constraints {
        c.result = c.step1;
        c.reached = c.step1.distance(c.target) <= 1e-9;
    }
    let draw = |layout: &[glam::DVec2], report: &uvpin::report::Report, name: &str| {
        uvpin::preview::draw_chart(
            &job.asset,
            data,
            boundary,
            layout,
            report,
            Some(&docs.join(format!("{name}-layout.png"))),
            Some(&docs.join(format!("{name}-render.png"))),
            SIZE,
        )
        .expect("pictures");
    };
    draw(step1, &before, "before");
    draw(layout, report, "after");
    let outcome = uvpin::sweep::run_sweep(
        Path::new("assets/face.sweep.ron"),
        &uvpin::sweep::SweepOptions {
            force: false,
            jobs: None,
            progress: uvpin::sweep::Progress::Auto,
        },
    )
    .expect("sample sweep");
    std::fs::copy(
        outcome.output.join("contact_sheet.png"),
        docs.join("sweep-contact-sheet.png"),
    )
    .expect("copy");
    println!("{}", outcome.summary);
    println!("wrote docs/gallery/{{before,after}}-{{layout,render}}.png and sweep-contact-sheet.png");
}
