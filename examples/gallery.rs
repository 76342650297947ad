//! The README gallery: the sample's layout before (step 1) and after, the
//! render through both (over the file's guide image), and the contact sheet
//! of the sample sweep.
//!
//! `cargo run --release --example gallery` writes `docs/gallery/*.png`
//! (run from the repository root; the sweep's results go to `out/sweep/`).

use std::path::Path;
use std::sync::Arc;
use uvpin::constraints::ConstraintSource;
use uvpin::options::SolverOptions;

/// Large enough for the landmarks' labels (768 px and up).
const SIZE: u32 = 800;

fn main() {
    let docs = Path::new("docs/gallery");
    std::fs::create_dir_all(docs).expect("docs/gallery");
    let (loaded, asset) = uvpin::load(
        Path::new("assets/face.uvpin.ron"),
        &SolverOptions::DEFAULT,
        &Default::default(),
    )
    .expect("load the sample");
    let options = loaded.solver;
    let source = ConstraintSource::File(Arc::new(loaded));
    // The pictures show the layout over the file's guide image.
    let background = source.image_path();
    let asset = Arc::new(asset);
    let mut session = uvpin::session::ChartSession::open(source, asset.clone(), 0.0).expect("open");
    let solved = uvpin::assembly::solve(&mut session, &options).expect("solve");
    let report = &solved.report;
    let data = session.prepared();
    let step1 = session.step_one_layout().expect("step 1");
    let layout = solved.solver.layout();
    let boundary = &session.boundary().expect("step 1").loop_vertices;
    // Before: the constraints where step 1 put them, none on target yet.
    let mut before = report.clone();
    for c in &mut before.constraints {
        c.result = c.step1;
        c.reached = c.step1.distance(c.target) <= 1e-9;
    }
    let draw = |layout: &[glam::DVec2], report: &uvpin::report::Report, name: &str| {
        let pictures = uvpin::preview::Pictures {
            layout: Some(docs.join(format!("{name}-layout.png"))),
            render: Some(docs.join(format!("{name}-render.png"))),
            size: SIZE,
            background: background.clone(),
        };
        let writing = uvpin::io::atomic::Writing::default();
        uvpin::preview::draw_chart(&asset, data, boundary, layout, report, &pictures, &writing).expect("pictures");
    };
    draw(step1, &before, "before");
    draw(layout, report, "after");
    let outcome = uvpin::sweep::run_sweep(
        Path::new("assets/face.sweep.ron"),
        &uvpin::sweep::SweepOptions {
            force: false,
            jobs: None,
            progress: uvpin::sweep::Progress::Auto,
            shard: None,
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
