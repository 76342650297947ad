//! The solve report: status, per-constraint results, fold counts, stretch,
//! iterations, time per stage, sizes. Written as JSON; summarised on stderr.

use crate::guard::OrientationCounts;
use crate::metrics::Stretch;
use crate::param::boundary::{BoundaryShape, CornerSource};
use glam::DVec2;
use serde::Serialize;

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Every constraint on its target, no fold. Exit code 0.
    Reached,
    /// Written, fold-free, but some constraints are short of their targets. Exit code 2.
    Partial,
    /// Nothing written. Exit code 1.
    Error,
}

impl Status {
    pub fn exit_code(self) -> i32 {
        match self {
            Status::Reached => 0,
            Status::Partial => 2,
            Status::Error => 1,
        }
    }
}

/// One constraint's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct ConstraintReport {
    /// Index in the constraint file's list.
    pub index: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    pub primitive: usize,
    pub vertex: u32,
    /// Target, glTF texture coordinates.
    pub target: DVec2,
    /// Where the vertex ended, glTF texture coordinates.
    pub result: DVec2,
    /// Where step 1 (the bar-net) put it.
    pub step1: DVec2,
    /// Distance from result to target, texture units.
    pub residual: f64,
    pub reached: bool,
    /// On the outer boundary (placed by the boundary map, not moved).
    pub on_boundary: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snapped_distance: Option<f64>,
}

/// Wall-clock milliseconds per stage.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct StageTimes {
    /// Reading the constraint file and the asset.
    pub load_ms: f64,
    /// Welding, chart choice, topology checks, hole filling.
    pub topology_ms: f64,
    /// Outer boundary onto the square (§III.B).
    pub boundary_ms: f64,
    /// Building and factoring D (Eq. 1–2).
    pub factor_ms: f64,
    /// Solving for the free nodes (Eq. 1).
    pub solve_ms: f64,
    /// Spline fits and evaluations (Eq. 6).
    pub stepping_ms: f64,
    /// Completion phase (soft-to-hard Newton steps).
    pub complete_ms: f64,
    /// Distortion polish.
    pub polish_ms: f64,
    /// Orientation checks of candidate layouts.
    pub guard_ms: f64,
    /// Metrics, final checks, writing the file.
    pub export_ms: f64,
}

impl StageTimes {
    pub fn total_ms(&self) -> f64 {
        self.load_ms
            + self.topology_ms
            + self.boundary_ms
            + self.factor_ms
            + self.solve_ms
            + self.stepping_ms
            + self.complete_ms
            + self.polish_ms
            + self.guard_ms
            + self.export_ms
    }
}

/// Sizes of what was solved.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Counts {
    /// Charts in the mesh (after welding).
    pub charts: usize,
    /// The solved chart's id.
    pub chart: u32,
    pub vertices: usize,
    pub triangles: usize,
    pub holes: usize,
    pub boundary_vertices: usize,
}

/// How the outer boundary was placed.
#[derive(Debug, Clone, Serialize)]
pub struct BoundaryReport {
    pub shape: BoundaryShape,
    pub corner_source: CornerSource,
    /// glTF vertex ids (in the first primitive that has them) of the corners,
    /// top_left, bottom_left, bottom_right, top_right.
    pub corners: [Option<u32>; 4],
}

/// The full report of one solve.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub status: Status,
    /// Why stepping stopped short, or the error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
    pub constraint_file: String,
    pub asset: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    pub uv_set: u32,
    pub constraints: Vec<ConstraintReport>,
    pub max_residual: f64,
    pub mean_residual: f64,
    /// Orientation of the solved chart as written (f32), virtual hole triangles included.
    pub orientation: OrientationCounts,
    /// Stretch of the step-1 (bar-net) layout.
    pub stretch_step1: Stretch,
    /// Stretch once the targets were reached, before the polish.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stretch_before_polish: Option<Stretch>,
    /// Stretch of the final layout.
    pub stretch_final: Stretch,
    /// What the completion phase and polish did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub completion: Option<crate::complete::CompletionStats>,
    /// For a partial result: which constraints conflict and where the mesh is squeezed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hint: Option<String>,
    /// For a partial result that no fold-free layout of this mesh could
    /// improve on: what would have to happen for every target to be reached
    /// (a crossing, a flipped or overlapped piece pinned in place).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unreachable_proof: Option<String>,
    /// What each phase did, one line each (`uvpin solve --explain`).
    pub explain: Vec<String>,
    pub iterations: u32,
    pub halvings: u32,
    pub times: StageTimes,
    pub total_ms: f64,
    pub counts: Counts,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub boundary: Option<BoundaryReport>,
    pub warnings: Vec<String>,
}

impl Report {
    /// A short human summary (a few lines).
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{}: {} — {} of {} constraints reached (max residual {:.3e}), {} flipped / {} zero-area triangles\n",
            match self.status {
                Status::Reached => "reached",
                Status::Partial => "partial",
                Status::Error => "error",
            },
            self.output.as_deref().unwrap_or(&self.asset),
            self.constraints.iter().filter(|c| c.reached).count(),
            self.constraints.len(),
            self.max_residual,
            self.orientation.flipped,
            self.orientation.zero_area,
        );
        s += &format!(
            "  chart {} of {}: {} vertices, {} triangles, {} holes; stretch L2 {:.4} → {:.4}, L∞ {:.4} → {:.4}\n",
            self.counts.chart,
            self.counts.charts,
            self.counts.vertices,
            self.counts.triangles,
            self.counts.holes,
            self.stretch_step1.l2,
            self.stretch_final.l2,
            self.stretch_step1.linf,
            self.stretch_final.linf
        );
        s += &format!(
            "  {} iterations, {} halvings, {:.1} ms\n",
            self.iterations, self.halvings, self.total_ms
        );
        if let Some(m) = &self.message {
            s += &format!("  {m}\n");
        }
        if let Some(h) = &self.hint {
            s += &format!("  hint: {h}\n");
        }
        for c in self.constraints.iter().filter(|c| !c.reached) {
            s += &format!(
                "  unreached: constraints[{}]{} vertex {}: target ({:.4}, {:.4}), at ({:.4}, {:.4}), residual {:.4}\n",
                c.index,
                c.label.as_ref().map(|l| format!(" \"{l}\"")).unwrap_or_default(),
                c.vertex,
                c.target.x,
                c.target.y,
                c.result.x,
                c.result.y,
                c.residual
            );
        }
        for w in &self.warnings {
            s += &format!("  warning: {w}\n");
        }
        s
    }
}

/// Everything [`build`] needs about a finished solve.
pub struct SolveSummary<'a> {
    pub constraints: &'a crate::constraints::LoadedConstraints,
    pub asset: &'a crate::io::SourceAsset,
    pub prepared: &'a crate::chart::PreparedChart,
    pub boundary: &'a crate::param::boundary::BoundaryMap,
    pub step1: &'a [DVec2],
    pub layout: &'a [DVec2],
    pub state: &'a crate::rbf::stepping::SteppingState,
    pub completion: Option<&'a crate::complete::CompletionStats>,
    pub stretch_before_polish: Option<Stretch>,
    pub problem: &'a crate::rbf::stepping::StepProblem,
    pub times: StageTimes,
}

/// A chart vertex's id in the asset (the first primitive that has it).
fn gltf_id(p: &crate::chart::PreparedChart, local: u32) -> Option<u32> {
    let w = *p.chart.welded_ids.get(local as usize)?;
    p.welded
        .vertex_of
        .iter()
        .find_map(|map| map.iter().position(|&x| x == w).map(|i| i as u32))
}

/// Which constraint (its index in the file) pins a chart vertex, if any.
pub(crate) fn constraint_of(p: &crate::chart::PreparedChart) -> impl Fn(u32) -> Option<usize> + '_ {
    |v| {
        p.constraints
            .iter()
            .zip(&p.constraint_vertices)
            .find_map(|(c, &w)| (w == v).then_some(c.index))
    }
}

/// How a message names a chart vertex: `constraints[i]`, `boundary vertex N`
/// or `vertex N` (N its id in the asset).
pub(crate) fn vertex_namer<'a>(
    p: &'a crate::chart::PreparedChart,
    on_outer: &'a [bool],
) -> impl Fn(u32) -> String + 'a {
    move |v| match (constraint_of(p)(v), gltf_id(p, v)) {
        (Some(i), _) => format!("constraints[{i}]"),
        (None, Some(id)) if on_outer[v as usize] => format!("boundary vertex {id}"),
        (None, Some(id)) => format!("vertex {id}"),
        (None, None) => "a hole's centre".into(),
    }
}

/// The report of a finished solve (before the file is written).
pub fn build(s: &SolveSummary) -> Report {
    use crate::param::xy_to_uv;
    use crate::rbf::stepping::SteppingPhase;
    let p = s.prepared;
    let tolerance = s.constraints.solver.tolerance;
    let mut on_outer = vec![false; p.filled.mesh.n_vertices()];
    for &v in &s.boundary.loop_vertices {
        on_outer[v as usize] = true;
    }
    let constraints: Vec<ConstraintReport> = p
        .constraints
        .iter()
        .zip(&p.constraint_vertices)
        .map(|(c, &v)| {
            let result = xy_to_uv(s.layout[v as usize]);
            let residual = result.distance(c.target_uv);
            ConstraintReport {
                index: c.index,
                label: c.label.clone(),
                primitive: c.primitive,
                vertex: c.vertex,
                target: c.target_uv,
                result,
                step1: xy_to_uv(s.step1[v as usize]),
                residual,
                reached: residual <= tolerance,
                on_boundary: on_outer[v as usize],
                snapped_distance: c.snapped_distance,
            }
        })
        .collect();
    let max_residual = constraints.iter().map(|c| c.residual).fold(0.0, f64::max);
    let mean_residual = if constraints.is_empty() {
        0.0
    } else {
        constraints.iter().map(|c| c.residual).sum::<f64>() / constraints.len() as f64
    };
    let all_reached = constraints.iter().all(|c| c.reached);
    let completion_ran = s.completion.is_some_and(|c| c.soft);
    let (status, message) = match (&s.state.phase, all_reached) {
        (_, true) => (Status::Reached, None),
        (_, false) if completion_ran => (
            Status::Partial,
            Some(if s.completion.is_some_and(|c| c.out_of_time) {
                "the time budget ran out before every constraint was placed; the layout is the best fold-free one so far".into()
            } else {
                "no fold-free layout with every constraint on its target was found; the layout is the best fold-free one".into()
            }),
        ),
        (SteppingPhase::Stalled(reason), false) => (
            Status::Partial,
            Some(format!(
                "the spline path stalled ({reason}); the layout is the last fold-free step (completion: Never)"
            )),
        ),
        (_, false) => (Status::Partial, Some("some constraints are outside tolerance".into())),
    };
    let unreached: Vec<(usize, u32)> = constraints
        .iter()
        .zip(&p.constraint_vertices)
        .filter(|(c, _)| !c.reached)
        .map(|(c, &v)| (c.index, v))
        .collect();
    let n_real = p.filled.n_real_vertices;
    let real = &p.chart.mesh;
    let stretch_step1 = crate::metrics::sander_stretch(&real.positions, &s.step1[..n_real], &real.triangles);
    let stretch_final = crate::metrics::sander_stretch(&real.positions, &s.layout[..n_real], &real.triangles);
    let gltf_id = |local: u32| gltf_id(p, local);
    // Unreached: a proof that no fold-free layout reaches them, if there is
    // one, else where the mesh is squeezed. The soft rounds looked for one
    // when they started (it depends only on the boundary and the targets).
    let certificate = if unreached.is_empty() {
        None
    } else if let Some(c) = s.completion.filter(|c| c.soft) {
        c.obstruction.clone()
    } else {
        crate::complete::find_obstruction(&p.filled, s.layout, s.problem)
    };
    let (constraint_of, vertex_name) = (constraint_of(p), vertex_namer(p, &on_outer));
    let hint = (!unreached.is_empty()).then(|| match &certificate {
        Some(c) => crate::complete::obstruction_hint(c, &constraint_of, &vertex_name),
        None => crate::complete::partial_hint(&p.filled, s.layout, s.problem, &unreached),
    });
    let unreachable_proof = certificate.as_ref().map(|c| c.describe(&vertex_name));
    let mut warnings = p.warnings.clone();
    if s.boundary.shape == crate::param::boundary::BoundaryShape::BulgedSquare {
        warnings.push(format!(
            "{} triangles or interior edges would lie flat on one side of the square with these corners; \
             the sides were bowed outward (strictly convex) instead, so the corners sit slightly inside the texture's corners",
            s.boundary.trapped_on_square
        ));
    }
    let explain = explain_lines(s, status, &stretch_step1, &stretch_final, max_residual);
    Report {
        status,
        message,
        constraint_file: s.constraints.path.display().to_string(),
        asset: s.asset.path.display().to_string(),
        output: None,
        uv_set: s.asset.uv_set,
        constraints,
        max_residual,
        mean_residual,
        orientation: crate::chart::written_orientation(p, s.layout),
        stretch_step1,
        stretch_before_polish: s.stretch_before_polish,
        stretch_final,
        completion: s.completion.cloned(),
        hint,
        unreachable_proof,
        explain,
        iterations: s.state.iterations,
        halvings: s.state.total_halvings,
        times: s.times,
        total_ms: s.times.total_ms(),
        counts: Counts {
            charts: p.welded.n_charts,
            chart: p.chart.id,
            vertices: real.n_vertices(),
            triangles: real.n_triangles(),
            holes: p.filled.n_holes(),
            boundary_vertices: s.boundary.loop_vertices.len(),
        },
        boundary: Some(BoundaryReport {
            shape: s.boundary.shape,
            corner_source: s.boundary.corner_source,
            corners: s.boundary.corner_vertices().map(gltf_id),
        }),
        warnings,
    }
}

/// One line per phase, for `--explain`.
fn explain_lines(s: &SolveSummary, status: Status, step1: &Stretch, last: &Stretch, max_residual: f64) -> Vec<String> {
    use crate::param::boundary::{BoundaryShape, CornerSource};
    use crate::rbf::stepping::SteppingPhase;
    let p = s.prepared;
    let t = &s.times;
    let mut out = vec![format!(
        "step 1 (bar-net, Eq. 1-2): outer loop of {} vertices on the {} (corners {}); {} holes fan-filled; \
         {} free vertices solved; stretch L2 {:.4}, L∞ {:.4}; {:.2} ms",
        s.boundary.loop_vertices.len(),
        if s.boundary.shape == BoundaryShape::Square {
            "square"
        } else {
            "bulged square (zero-area trap)"
        },
        match s.boundary.corner_source {
            CornerSource::Given => "given".to_string(),
            CornerSource::Automatic { shift } => format!("automatic, {shift} shifts"),
        },
        p.filled.n_holes(),
        s.problem.movable.len(),
        step1.l2,
        step1.linf,
        t.boundary_ms + t.factor_ms + t.solve_ms
    )];
    let st = s.state;
    out.push(match &st.phase {
        SteppingPhase::Skipped => "spline path (Eq. 6): skipped (completion: Always)".into(),
        SteppingPhase::Reached if st.iterations == 0 => "spline path (Eq. 6): nothing to move".into(),
        SteppingPhase::Reached => format!(
            "spline path (Eq. 6): reached in {} steps, {} halvings; {:.2} ms",
            st.iterations,
            st.total_halvings,
            t.stepping_ms + t.guard_ms
        ),
        SteppingPhase::Stalled(reason) => format!(
            "spline path (Eq. 6): stalled after {} steps, {} halvings ({reason}); {:.2} ms",
            st.iterations,
            st.total_halvings,
            t.stepping_ms + t.guard_ms
        ),
        SteppingPhase::Stepping => "spline path (Eq. 6): unfinished".into(),
    });
    match s.completion {
        Some(c) if c.soft => out.push(format!(
            "completion (soft-to-hard symmetric Dirichlet): {}{} rounds, {} Newton steps, {}; energy {:.4} → {:.4}{}{}; {:.2} ms",
            if c.repair_steps > 0 {
                format!("{} steps spreading triangles too small for f32, then ", c.repair_steps)
            } else {
                String::new()
            },
            c.rounds,
            c.newton_steps,
            match (c.snapped_at_round, c.arc_retry) {
                (Some(r), false) => format!("snapped onto the targets in round {}", r + 1),
                (Some(r), true) => format!(
                    "snapped onto the targets in round {} moving along arc paths{}",
                    r + 1,
                    if c.paths_cross {
                        " (tried first: two constraints' straight paths meet head-on)"
                    } else {
                        ""
                    }
                ),
                (None, _) if c.proven_unreachable => {
                    "could not snap onto the targets (proven unreachable, see the hint: one straight attempt, no arc retries)".into()
                }
                (None, _) => "could not snap onto the targets (straight and arc paths tried)".into(),
            },
            c.energy_start,
            c.energy_snapped.unwrap_or(c.energy_end),
            if c.capped_triangles > 0 {
                format!(
                    "; up to {} triangles measured against progressive reference shapes",
                    c.capped_triangles
                )
            } else {
                String::new()
            },
            if c.out_of_time { " (time budget)" } else { "" },
            t.complete_ms
        )),
        _ => out.push("completion: not needed".into()),
    }
    match (s.completion, s.stretch_before_polish) {
        (Some(c), Some(before)) if c.polish || c.polish_repair_steps > 0 => out.push(format!(
            "polish (constraints and boundary held): {} Newton steps{}; stretch L2 {:.4} → {:.4}, L∞ {:.4} → {:.4}; {:.2} ms",
            c.polish_steps,
            if c.polish_repair_steps > 0 {
                format!(" ({} of them spreading triangles too small for f32)", c.polish_repair_steps)
            } else {
                String::new()
            },
            before.l2,
            last.l2,
            before.linf,
            last.linf,
            t.polish_ms
        )),
        _ => {
            let o = &s.constraints.solver;
            let n = s.prepared.filled.n_real_vertices;
            out.push(if !o.polish {
                "polish: off".into()
            } else if o.guard == crate::options::Guard::Paper {
                "polish: not run (the paper's guard: its spline path alone)".into()
            } else if s.completion.is_some_and(|c| c.soft && !c.snapped) {
                "polish: not run (the targets were not reached)".into()
            } else if n > o.polish_max_vertices {
                let after = match s.completion {
                    Some(c) if c.soft => "the completion left the layout no more distorted than step 1, in all and in its worst triangle",
                    _ => "the spline path reached the targets",
                };
                format!(
                    "polish: not run ({after}, on {n} vertices: above polish_max_vertices {})",
                    o.polish_max_vertices
                )
            } else {
                "polish: not run".into()
            });
        }
    }
    out.push(format!(
        "result: {}, max residual {:.3e}, {:.2} ms in all",
        match status {
            Status::Reached => "reached",
            Status::Partial => "partial",
            Status::Error => "error",
        },
        max_residual,
        t.total_ms()
    ));
    out
}
