//! Draws a solve as SVG: the step-1 (bar-net) layout with arrows from each
//! constrained vertex to its target, beside the final layout with the
//! constrained vertices on their targets. Holes are shaded, the outer
//! boundary drawn, unreached constraints red.
//!
//! `cargo run --release --example draw_layout -- assets/face.uvpin.ron docs/face-layout.svg`
//!
//! With a third argument `free`, the two panels are the final layouts with
//! the square boundary and with a free one (the other charts' islands, if
//! any, in grey):
//! `cargo run --release --example draw_layout -- assets/face.uvpin.ron docs/free-layout.svg free`

use glam::DVec2;
use std::fmt::Write;
use std::path::Path;
use std::sync::Arc;
use uvpin::assembly::Solution;
use uvpin::constraints::ConstraintSource;
use uvpin::options::SolverOptions;
use uvpin::pins::BoundaryChoice;
use uvpin::session::ChartSession;

const SIZE: f64 = 460.0;
const MARGIN: f64 = 30.0;

fn panel(
    svg: &mut String,
    x0: f64,
    title: &str,
    layout: &[DVec2],
    data: &uvpin::chart::PreparedChart,
    boundary: &[u32],
    marks: &[(DVec2, DVec2, bool)],
) {
    // Layout (x, y up) → picture: u right, v down, like the texture.
    let at = |p: DVec2| (x0 + MARGIN + p.x * SIZE, MARGIN + 24.0 + (1.0 - p.y) * SIZE);
    let (ox, oy) = at(DVec2::new(0.0, 1.0));
    writeln!(
        svg,
        r##"<text x="{}" y="20" font-family="sans-serif" font-size="15" fill="#222">{title}</text>"##,
        ox
    )
    .unwrap();
    writeln!(
        svg,
        r##"<rect x="{ox}" y="{oy}" width="{SIZE}" height="{SIZE}" fill="#fbfaf6" stroke="#bbb"/>"##
    )
    .unwrap();
    let filled = &data.filled;
    let mut path = String::new();
    for (i, t) in filled.mesh.triangles.iter().enumerate() {
        let pts: Vec<(f64, f64)> = t.iter().map(|&v| at(layout[v as usize])).collect();
        if i >= filled.n_real_triangles {
            writeln!(
                svg,
                r##"<polygon points="{:.2},{:.2} {:.2},{:.2} {:.2},{:.2}" fill="#d9d4c7" stroke="none"/>"##,
                pts[0].0, pts[0].1, pts[1].0, pts[1].1, pts[2].0, pts[2].1
            )
            .unwrap();
        } else {
            write!(
                path,
                "M{:.2},{:.2}L{:.2},{:.2}L{:.2},{:.2}Z",
                pts[0].0, pts[0].1, pts[1].0, pts[1].1, pts[2].0, pts[2].1
            )
            .unwrap();
        }
    }
    writeln!(
        svg,
        r##"<path d="{path}" fill="none" stroke="#5b7fa6" stroke-width="0.35"/>"##
    )
    .unwrap();
    let outline: Vec<String> = boundary
        .iter()
        .map(|&v| {
            let (x, y) = at(layout[v as usize]);
            format!("{x:.2},{y:.2}")
        })
        .collect();
    writeln!(
        svg,
        r##"<polygon points="{}" fill="none" stroke="#222" stroke-width="1.4"/>"##,
        outline.join(" ")
    )
    .unwrap();
    for &(from, to, reached) in marks {
        let (a, b) = (at(from), at(to));
        let colour = if reached { "#1a9850" } else { "#d73027" };
        if from.distance(to) > 1e-6 {
            writeln!(svg, r##"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="{colour}" stroke-width="1.6" marker-end="url(#arrow)"/>"##, a.0, a.1, b.0, b.1).unwrap();
            writeln!(
                svg,
                r##"<circle cx="{:.2}" cy="{:.2}" r="3.2" fill="{colour}"/>"##,
                a.0, a.1
            )
            .unwrap();
        } else {
            writeln!(
                svg,
                r##"<circle cx="{:.2}" cy="{:.2}" r="4" fill="{colour}" stroke="white" stroke-width="1"/>"##,
                b.0, b.1
            )
            .unwrap();
        }
    }
}

/// Solves `ron` with its boundary setting replaced by `boundary` (if given).
fn solve(ron: &Path, boundary: Option<BoundaryChoice>) -> (ChartSession, Solution) {
    let (mut loaded, asset) = uvpin::load(ron, &SolverOptions::DEFAULT, &Default::default()).expect("load");
    if boundary.is_some() {
        loaded.file.boundary = boundary;
    }
    let options = loaded.solver;
    let source = ConstraintSource::File(Arc::new(loaded));
    let mut session = ChartSession::open(source, Arc::new(asset), 0.0).expect("open");
    let solved = uvpin::assembly::solve(&mut session, &options).expect("solve");
    (session, solved)
}

/// The final layout's panel title.
fn final_title(what: &str, report: &uvpin::Report) -> String {
    format!(
        "{what}: {} of {} on target, {} flipped, L2 {:.2}",
        report.constraints.iter().filter(|c| c.reached).count(),
        report.constraints.len(),
        report.orientation.flipped,
        report.stretch_final.l2
    )
}

/// Square against free: the two final layouts side by side.
fn compare(ron: &Path) -> String {
    let mut svg = String::new();
    for (k, (boundary, what)) in [(BoundaryChoice::Square, "square"), (BoundaryChoice::Free, "free")]
        .into_iter()
        .enumerate()
    {
        let (session, solved) = solve(ron, Some(boundary));
        let layout = solved.solver.layout();
        let data = session.prepared();
        let outer = data.topology.outer_loop().to_vec();
        let marks: Vec<(DVec2, DVec2, bool)> = solved
            .report
            .constraints
            .iter()
            .zip(&data.constraint_vertices)
            .map(|(c, &v)| (layout[v as usize], uvpin::param::uv_to_xy(c.target), c.reached))
            .collect();
        let title = final_title(what, &solved.report);
        panel(
            &mut svg,
            k as f64 * (SIZE + 2.0 * MARGIN),
            &title,
            layout,
            data,
            &outer,
            &marks,
        );
    }
    svg
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (ron, out) = (Path::new(&args[1]), Path::new(&args[2]));
    let width = 2.0 * (SIZE + 2.0 * MARGIN);
    let height = SIZE + 2.0 * MARGIN + 24.0;
    let header = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}">
<defs><marker id="arrow" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="6" markerHeight="6" orient="auto-start-reverse"><path d="M0,0L10,5L0,10z" fill="#1a9850"/></marker></defs>
<rect width="100%" height="100%" fill="white"/>
"##
    );
    if args.get(3).map(String::as_str) == Some("free") {
        let svg = header + &compare(ron) + "</svg>\n";
        std::fs::write(out, svg).expect("write svg");
        println!("wrote {}", out.display());
        return;
    }
    let (session, solved) = solve(ron, None);
    let report = &solved.report;
    let data = session.prepared();
    let step1 = session.step_one_layout().expect("step 1");
    let layout = solved.solver.layout();
    let boundary = &session.boundary().expect("step 1").loop_vertices;
    let targets: Vec<(DVec2, DVec2, bool)> = report
        .constraints
        .iter()
        .zip(&data.constraint_vertices)
        .map(|(c, &v)| (step1[v as usize], uvpin::param::uv_to_xy(c.target), c.reached))
        .collect();
    let finals: Vec<(DVec2, DVec2, bool)> = report
        .constraints
        .iter()
        .zip(&data.constraint_vertices)
        .map(|(c, &v)| (layout[v as usize], uvpin::param::uv_to_xy(c.target), c.reached))
        .collect();
    let mut svg = header;
    panel(
        &mut svg,
        0.0,
        "step 1: bar-net (Eq. 1-2), arrows to the targets",
        step1,
        data,
        boundary,
        &targets,
    );
    let title = format!(
        "final: {:?}, {} of {} on target, {} flipped",
        report.status,
        report.constraints.iter().filter(|c| c.reached).count(),
        report.constraints.len(),
        report.orientation.flipped
    );
    panel(&mut svg, SIZE + 2.0 * MARGIN, &title, layout, data, boundary, &finals);
    svg += "</svg>\n";
    std::fs::write(out, svg).expect("write svg");
    println!("wrote {}", out.display());
}
