//! The report of a finished chart solve.

use super::explain::explain_lines;
use super::summary::SolveSummary;
use super::{BoundaryMode, BoundaryReport, CompletionStats, ConstraintReport, Counts, FreeReport, Report, Status};
use crate::chart::PreparedChart;
use crate::complete::obstruction::Obstruction;
use crate::metrics::{Stretch, sander_stretch};
use crate::param::boundary::BoundaryShape;
use crate::param::xy_to_uv;
use crate::rbf::stepping::SteppingPhase;
use glam::DVec2;

/// A chart vertex's id in the asset (the first primitive that has it).
fn gltf_id(p: &PreparedChart, local: u32) -> Option<u32> {
    let w = *p.chart.welded_ids.get(local as usize)?;
    p.welded
        .vertex_of
        .iter()
        .find_map(|map| map.iter().position(|&x| x == w).map(|i| i as u32))
}

/// Which constraint (its index in the file) pins a chart vertex, if any.
fn constraint_of(p: &PreparedChart) -> impl Fn(u32) -> Option<usize> + '_ {
    |v| {
        p.constraints
            .iter()
            .zip(&p.constraint_vertices)
            .find_map(|(c, &w)| (w == v).then_some(c.index))
    }
}

/// How a message names a chart vertex: `constraints[i]`, `boundary vertex N`
/// or `vertex N` (N its id in the asset).
pub(crate) fn vertex_namer<'a>(p: &'a PreparedChart, on_outer: &'a [bool]) -> impl Fn(u32) -> String + 'a {
    move |v| match (constraint_of(p)(v), gltf_id(p, v)) {
        (Some(i), _) => format!("constraints[{i}]"),
        (None, Some(id)) if on_outer[v as usize] => format!("boundary vertex {id}"),
        (None, Some(id)) => format!("vertex {id}"),
        (None, None) => "a hole's centre".into(),
    }
}

/// Each constraint's target, result, step-1 position and residual.
fn constraint_reports(s: &SolveSummary, on_outer: &[bool]) -> Vec<ConstraintReport> {
    let tolerance = s.solver.options().tolerance;
    let layout = s.solver.layout();
    s.prepared
        .constraints
        .iter()
        .zip(&s.prepared.constraint_vertices)
        .map(|(c, &v)| {
            let result = xy_to_uv(layout[v as usize]);
            let residual = result.distance(c.target_uv);
            ConstraintReport {
                on_boundary: on_outer[v as usize],
                ..ConstraintReport::of(
                    c,
                    result,
                    xy_to_uv(s.step1[v as usize]),
                    residual,
                    residual <= tolerance,
                )
            }
        })
        .collect()
}

/// The status and its message: that every constraint is on target, or why
/// stepping stopped short.
fn status_and_message(s: &SolveSummary, all_reached: bool) -> (Status, Option<String>) {
    let record = s.solver.record();
    if all_reached {
        let message = "every constraint is on its target and no triangle is flipped or degenerate";
        return (Status::Reached, Some(message.into()));
    }
    let message = if record.soft.is_some() {
        if record.out_of_time {
            "the time budget ran out before every constraint was placed; the layout is the best fold-free one so far"
                .into()
        } else {
            "no fold-free layout with every constraint on its target was found; the layout is the best fold-free one"
                .into()
        }
    } else if let SteppingPhase::Stalled(reason) = &s.solver.spline().phase {
        format!("the spline path stalled ({reason}); the layout is the last fold-free step (completion: Never)")
    } else {
        "some constraints are outside tolerance".into()
    };
    (Status::Partial, Some(message))
}

/// For unreached constraints: a proof that no fold-free layout reaches
/// them, if there is one (the soft rounds looked for it when they started;
/// it depends only on the targets and, on the square, the boundary), else none.
fn certificate(s: &SolveSummary, any_unreached: bool) -> Option<Obstruction> {
    if !any_unreached {
        return None;
    }
    // A free chart's completion looks for none (see `complete::soft`).
    let free = s.solver.free().is_some();
    match &s.solver.record().soft {
        Some(soft) if !free => soft.obstruction.clone(),
        _ => crate::complete::find_obstruction(
            &s.prepared.filled,
            (s.solver.layout(), crate::complete::Pinned::for_boundary(free)),
            s.solver.problem(),
        ),
    }
}

/// The hint for unreached constraints and the proof, if any.
fn hint_and_proof(
    s: &SolveSummary,
    constraints: &[ConstraintReport],
    on_outer: &[bool],
) -> (Option<String>, Option<String>) {
    let p = s.prepared;
    let unreached: Vec<(usize, u32)> = constraints
        .iter()
        .zip(&p.constraint_vertices)
        .filter(|(c, _)| !c.reached)
        .map(|(c, &v)| (c.index, v))
        .collect();
    let certificate = certificate(s, !unreached.is_empty());
    let name = vertex_namer(p, on_outer);
    let hint = (!unreached.is_empty()).then(|| {
        on_other_islands(p, &unreached).unwrap_or_else(|| match &certificate {
            Some(c) => crate::complete::obstruction_hint(c, constraint_of(p), &name),
            None => crate::complete::partial_hint(&p.filled, s.solver.layout(), s.solver.problem(), &unreached),
        })
    });
    (hint, certificate.as_ref().map(|c| c.describe(&name)))
}

/// The hint when a chart laid out again in its own island falls short of
/// targets that lie on other charts' islands: those keep their UVs in the
/// set written, so the chart cannot reach them however it is laid out.
fn on_other_islands(p: &PreparedChart, unreached: &[(usize, u32)]) -> Option<String> {
    let covered: Vec<String> = p
        .targets_on_kept_islands()
        .into_iter()
        .filter(|index| unreached.iter().any(|(i, _)| i == index))
        .map(|index| format!("constraints[{index}]"))
        .collect();
    (!covered.is_empty()).then(|| {
        format!(
            "{} have targets on other charts' islands, which keep their UVs in this set: write the layout as a new UV \
             set (`uv_set: 1` beside an atlas in set 0; with `uv_set` left out, the whole mesh is laid out afresh in \
             this set when a target lies on the island of a chart without landmarks, or when that reaches more), or \
             keep the targets inside this chart's island",
            covered.join(", ")
        )
    })
}

fn coarse_level(s: &SolveSummary) -> Option<crate::report::CoarseLevel> {
    let r = s.solver.record();
    r.multilevel.clone().map(crate::report::CoarseLevel::Used)
}

/// The chart's warnings, and one for a bulged boundary.
fn warnings(s: &SolveSummary) -> Vec<String> {
    let mut warnings = s.prepared.warnings.clone();
    if let Some(from) = s.solver.record().settled_from {
        warnings.push(format!(
            "the fold-free layout that came closest to the targets was stretched to L2 {:.2} (L∞ {:.1}), more than {}× the \
             chart's own shape: that shape, fitted to the targets, is written instead (the residuals above are its)",
            from.l2,
            from.linf,
            crate::solver::SETTLE_FACTOR
        ));
    }
    if s.boundary.shape == BoundaryShape::BulgedSquare {
        warnings.push(format!(
            "{} triangles or interior edges would lie flat on one side of the square with these corners; \
             the sides were bowed outward (strictly convex) instead, so the corners sit slightly inside the texture's corners",
            s.boundary.trapped_on_square
        ));
    }
    warnings
}

fn counts(s: &SolveSummary) -> Counts {
    let p = s.prepared;
    Counts {
        charts: p.welded.n_charts,
        chart: p.chart.id,
        vertices: p.chart.mesh.n_vertices(),
        triangles: p.chart.mesh.n_triangles(),
        holes: p.filled.n_holes(),
        boundary_vertices: s.boundary.loop_vertices.len(),
    }
}

/// Sander stretch of `layout` over the real triangles.
fn stretch_of(p: &PreparedChart, layout: &[DVec2]) -> Stretch {
    let real = &p.chart.mesh;
    sander_stretch(&real.positions, &layout[..p.filled.n_real_vertices], &real.triangles)
}

/// The report of a finished solve (before the file is written).
pub fn build(s: &SolveSummary) -> Report {
    let p = s.prepared;
    let on_outer = s.boundary.on_loop(p.filled.mesh.n_vertices());
    let constraints = constraint_reports(s, &on_outer);
    let max_residual = constraints.iter().map(|c| c.residual).fold(0.0, f64::max);
    let mean_residual = if constraints.is_empty() {
        0.0
    } else {
        constraints.iter().map(|c| c.residual).sum::<f64>() / constraints.len() as f64
    };
    let (status, message) = status_and_message(s, constraints.iter().all(|c| c.reached));
    let (hint, unreachable_proof) = hint_and_proof(s, &constraints, &on_outer);
    let stretch_step1 = stretch_of(p, s.step1);
    let stretch_final = stretch_of(p, s.solver.layout());
    let completion = CompletionStats::from_record(s.solver.record());
    let explain = explain_lines(s, &completion, status, (&stretch_step1, &stretch_final), max_residual);
    let spline = s.solver.spline();
    Report {
        status,
        message,
        constraint_file: s.constraint_file.clone(),
        asset: s.asset.path.display().to_string(),
        output: None,
        uv_set: s.asset.uv_set,
        constraints,
        max_residual,
        mean_residual,
        orientation: crate::chart::written_orientation(p, s.solver.layout()),
        stretch_step1,
        stretch_before_polish: s.solver.record().stretch_before_polish,
        stretch_final,
        stretch_own: s.solver.record().own_stretch,
        completion: Some(completion),
        hint,
        unreachable_proof,
        explain,
        iterations: spline.iterations,
        halvings: spline.total_halvings,
        times: s.times,
        total_ms: s.times.total_ms(),
        counts: counts(s),
        boundary: Some(BoundaryReport {
            shape: s.boundary.shape,
            corner_source: s.boundary.corner_source,
            corners: s.boundary.corner_vertices().map(|v| gltf_id(p, v)),
        }),
        boundary_mode: if s.solver.free().is_some() {
            BoundaryMode::Free
        } else {
            BoundaryMode::Square
        },
        free: free_report(s),
        coarse_level: coarse_level(s),
        seam: seam_of(p),
        plan: None,
        rest: None,
        charts: Vec::new(),
        warnings: warnings(s),
    }
}

/// Where the chart was cut, in the asset's vertex ids.
pub fn seam_of(p: &PreparedChart) -> Option<crate::report::SeamReport> {
    let none = crate::cut::Seam::default();
    let seam = match (&p.opening.seam, p.opening.separation.is_empty()) {
        (Some(seam), _) => seam,
        (None, false) => &none,
        (None, true) => return None,
    };
    let mut first_id: Vec<Option<u32>> = vec![None; p.welded.mesh.n_vertices()];
    for map in p.welded.vertex_of.iter().rev() {
        for (i, &w) in map.iter().enumerate().rev() {
            first_id[w as usize] = Some(i as u32);
        }
    }
    let id = |local: u32| first_id[p.chart.welded_ids[local as usize] as usize];
    let area = p.chart.mesh.area();
    Some(crate::report::SeamReport {
        source: if p.opening.seam_given { "given" } else { "auto" },
        n_edges: seam.edges.len(),
        length: seam.length,
        relative_length: if area > 0.0 { seam.length / area.sqrt() } else { 0.0 },
        vertices_split: p.opening.seam_copies,
        cones: seam.cones.len(),
        handle_edges: seam.n_handle_edges,
        separation_edges: p.opening.separation.len(),
        edges: seam.edges.iter().map(|e| [id(e[0]), id(e[1])]).collect(),
    })
}

/// A free chart's region, start and global injectivity as written.
fn free_report(s: &SolveSummary) -> Option<FreeReport> {
    let free = s.solver.free()?;
    let room = &free.domain.room;
    let setup = room.setup();
    let layout = s.solver.full_layout();
    let boundary = room.boundary_vertices();
    let scaffold = free
        .domain
        .scaffold
        .triangulate(layout, boundary, &free.domain.edges, free.domain.offset);
    Some(FreeReport {
        region: setup.region,
        region_source: setup.source,
        start: free.start,
        start_shrink: free.shrink,
        relax_steps: free.relax_steps,
        spline_loop_freed: s.solver.record().spline_loop_freed,
        crossings: room.crossings(layout, usize::MAX),
        island_triangles: setup.obstacles.triangles.len(),
        scaffold_triangles: scaffold.map_or(0, |t| t.len()),
        start_ms: free.start_ms,
        scaffold_ms: s.solver.record().scaffold_ms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pins::Pins;

    #[test]
    fn targets_on_another_island_get_a_hint_that_says_so() {
        // Two grids apart in space; set 0 holds one in the left half of the
        // texture and the other in the right half.
        let grid = crate::testing::grid_mesh(6, 6);
        let n = grid.n_vertices();
        let mut mesh = grid.clone();
        mesh.positions
            .extend(grid.positions.iter().map(|p| *p + glam::DVec3::X * 2.0));
        mesh.triangles
            .extend(grid.triangles.iter().map(|t| t.map(|v| v + n as u32)));
        let uvs: Vec<[f32; 2]> = (0..2 * n)
            .map(|k| {
                let p = grid.positions[k % n];
                let u0 = if k < n { 0.05 } else { 0.55 };
                [(u0 + 0.4 * p.x) as f32, (0.9 - 0.8 * p.y) as f32]
            })
            .collect();
        // The first grid's corners pinned where they are, a middle vertex
        // into the other grid's island.
        let at = |v: usize| DVec2::new(f64::from(uvs[v][0]), f64::from(uvs[v][1]));
        let pins = Pins::new(&[(0, at(0)), (5, at(5)), (30, at(30)), (14, DVec2::new(0.75, 0.5))]);
        let solved = crate::api::solve_atlas(&mesh, &uvs, &pins, &Default::default()).expect("a solve");
        assert_eq!(solved.report.status, Status::Partial);
        let hint = solved.report.hint.expect("a hint");
        assert!(
            hint.starts_with("constraints[3] have targets on other charts' islands") && hint.contains("uv_set: 1"),
            "{hint}"
        );
    }
}
