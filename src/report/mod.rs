//! The solve report: status, per-constraint results, fold counts, stretch,
//! iterations, time per stage, sizes. Written as JSON; summarised on stderr.

#![warn(missing_docs)]

mod build;
mod explain;
mod summary;

pub(crate) use build::vertex_namer;
pub use build::{build, seam_of};
pub use summary::SolveSummary;

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
    /// The command line's exit code for this status.
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
    /// Its label in the file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// The glTF primitive holding the vertex.
    pub primitive: usize,
    /// The vertex (glTF index in `primitive`).
    pub vertex: u32,
    /// Its welded vertex (internal): every copy of it is checked as written.
    #[serde(skip)]
    pub welded: u32,
    /// Target, glTF texture coordinates.
    pub target: DVec2,
    /// Where the vertex ended, glTF texture coordinates.
    pub result: DVec2,
    /// Where step 1 (the bar-net) put it.
    pub step1: DVec2,
    /// Distance from result to target, texture units.
    pub residual: f64,
    /// Within the solver's tolerance of the target.
    pub reached: bool,
    /// On the outer boundary (placed by the boundary map, not moved).
    pub on_boundary: bool,
    /// For a `near` constraint: how far the chosen vertex is from the point.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snapped_distance: Option<f64>,
}

impl ConstraintReport {
    /// `c`'s outcome: it ended at `result` (glTF texture coordinates),
    /// `residual` from its target; step 1 put it at `step1`.
    pub fn of(c: &crate::pins::ResolvedConstraint, result: DVec2, step1: DVec2, residual: f64, reached: bool) -> Self {
        ConstraintReport {
            index: c.index,
            label: c.label.clone(),
            primitive: c.primitive,
            vertex: c.vertex,
            welded: c.welded,
            target: c.target_uv,
            result,
            step1,
            residual,
            reached,
            on_boundary: false,
            snapped_distance: c.snapped_distance,
        }
    }
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
    /// A solve set aside for a better one (a disk cut open, then solved as
    /// it is): all its stages.
    pub detour_ms: f64,
}

impl StageTimes {
    /// These times with the solver's stages (spline path, guard,
    /// completion, polish) taken from `solver`.
    #[must_use]
    pub fn with_solver(mut self, solver: crate::solver::SolverTimes) -> Self {
        self.stepping_ms = solver.stepping_ms;
        self.guard_ms = solver.guard_ms;
        self.complete_ms = solver.complete_ms;
        self.polish_ms = solver.polish_ms;
        self
    }

    /// Every stage's time together.
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
            + self.detour_ms
    }
}

/// Sizes of what was solved.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Counts {
    /// Charts in the mesh (after welding).
    pub charts: usize,
    /// The solved chart's id.
    pub chart: u32,
    /// The chart's vertices.
    pub vertices: usize,
    /// The chart's triangles.
    pub triangles: usize,
    /// Its holes (inner boundary loops).
    pub holes: usize,
    /// Vertices on its outer loop.
    pub boundary_vertices: usize,
}

/// How the outer boundary was placed.
#[derive(Debug, Clone, Serialize)]
pub struct BoundaryReport {
    /// The shape the outer loop was mapped onto.
    pub shape: BoundaryShape,
    /// Whether the corners were given or chosen.
    pub corner_source: CornerSource,
    /// glTF vertex ids (in the first primitive that has them) of the corners,
    /// top_left, bottom_left, bottom_right, top_right.
    pub corners: [Option<u32>; 4],
}

/// What the completion and polish did (the report's `completion` section).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CompletionStats {
    /// The soft-to-hard phase ran.
    pub soft: bool,
    /// Soft-to-hard rounds run.
    pub rounds: u32,
    /// Newton steps over all rounds.
    pub newton_steps: u32,
    /// Constrained vertices were put exactly on their targets.
    pub snapped: bool,
    /// The round after which they were snapped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snapped_at_round: Option<u32>,
    /// The distortion polish ran.
    pub polish: bool,
    /// A layout too squeezed to store as f32 was spread first (before the
    /// soft rounds, or by the polish).
    pub repair: bool,
    /// Newton steps of the polish.
    pub polish_steps: u32,
    /// Steps spent spreading a start too squeezed for f32, before the soft rounds.
    pub repair_steps: u32,
    /// Polish steps spent on the same repair (not counted against `polish_iterations`).
    pub polish_repair_steps: u32,
    /// Symmetric Dirichlet energy (area-weighted, 4 per unit area = isometry) at the start and end.
    pub energy_start: f64,
    /// The energy at the end.
    pub energy_end: f64,
    /// The same energy right after the snap onto the targets (before any polish).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub energy_snapped: Option<f64>,
    /// The largest energy of one real triangle (ψ, 4 = isometry) at the
    /// start of the soft rounds, and right after the snap.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_start: Option<f64>,
    /// The largest energy of one real triangle right after the snap.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_snapped: Option<f64>,
    /// The most triangles any soft step measured against a progressive
    /// reference shape instead of their rest shape.
    pub capped_triangles: usize,
    /// The time budget cut the phase short.
    pub out_of_time: bool,
    /// The targets were reached moving along arcs.
    pub arc_retry: bool,
    /// Some constraints' straight paths cross, so arcs were tried first.
    pub paths_cross: bool,
    /// The targets are provably unreachable: one straight attempt for the
    /// closest layout, no retries along arcs.
    pub proven_unreachable: bool,
}

impl CompletionStats {
    /// The section for a solve's record.
    pub fn from_record(r: &crate::solver::SolveRecord) -> Self {
        use crate::complete::attempts::TargetPath;
        use crate::complete::polish::PolishGoal;
        let mut c = CompletionStats {
            energy_end: r.energy_end,
            out_of_time: r.out_of_time,
            ..Default::default()
        };
        if let Some(p) = &r.polish {
            c.polish = p.goal == PolishGoal::Distortion;
            c.repair = p.started_unstorable;
            c.polish_steps = p.steps;
            c.polish_repair_steps = p.repair_steps;
            c.energy_start = p.energy_start;
        }
        if let Some(s) = &r.soft {
            c.soft = true;
            c.rounds = s.rounds;
            c.newton_steps = s.newton_steps;
            c.snapped = s.snapped_at_round.is_some();
            c.snapped_at_round = s.snapped_at_round;
            c.repair |= s.started_unstorable;
            c.repair_steps = s.repair_steps;
            c.energy_start = s.energy_start;
            c.energy_snapped = s.energy_snapped;
            c.worst_start = Some(s.worst_start);
            c.worst_snapped = s.worst_snapped;
            c.capped_triangles = s.capped_triangles;
            c.arc_retry = matches!(s.snapped_path, Some(TargetPath::Arc { .. }));
            c.paths_cross = s.paths_cross;
            c.proven_unreachable = s.obstruction.is_some();
        }
        c
    }
}

/// A large chart's coarse level ([`crate::solver::multilevel`]).
#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CoarseLevel {
    /// Solved and prolonged: the chart started from it.
    Used(crate::solver::multilevel::MultilevelStats),
}

/// What the planner tried for a chart ([`crate::plan`]), and which it kept.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PlanReport {
    /// Every candidate tried, in order.
    pub tried: Vec<TrialReport>,
    /// The one kept (an index into `tried`).
    pub chosen: Option<usize>,
    /// Why it was kept.
    pub why: String,
}

/// A tried candidate and what it gave.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrialReport {
    /// How it is named: its form, boundary and start.
    pub candidate: String,
    /// What it gave.
    #[serde(flatten)]
    pub outcome: TrialOutcome,
    /// Milliseconds it took.
    pub ms: f64,
}

/// What a tried candidate gave.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "outcome")]
pub enum TrialOutcome {
    /// It could not be made or started: why.
    Dropped {
        /// Why.
        why: String,
    },
    /// Solved at a level of `vertices` vertices.
    Solved {
        /// Every landmark on its target.
        reached: bool,
        /// The largest distance of a landmark from its target.
        residual: f64,
        /// Sander stretch at that level.
        stretch: Stretch,
        /// The same chart's own free layout, where it was measured.
        own: Option<Stretch>,
        /// Vertices of the level solved.
        vertices: usize,
    },
}

impl PlanReport {
    /// The explain's lines: each candidate and what it gave, then the one kept.
    pub fn lines(&self) -> Vec<String> {
        let mut lines: Vec<String> = self
            .tried
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let what = match &t.outcome {
                    TrialOutcome::Dropped { why } => format!("not solved: {why}"),
                    TrialOutcome::Solved {
                        reached,
                        residual,
                        stretch,
                        own,
                        vertices,
                    } => format!(
                        "{} on {vertices} vertices, stretch L2 {:.3}{}",
                        if *reached {
                            "reached".to_string()
                        } else {
                            format!("{residual:.1e} short")
                        },
                        stretch.l2,
                        own.map_or(String::new(), |o| format!(
                            " ({:.2}× its own {:.3})",
                            stretch.l2 / o.l2,
                            o.l2
                        )),
                    ),
                };
                format!("candidate {}, {}: {what}; {:.1} ms", i + 1, t.candidate, t.ms)
            })
            .collect();
        if let Some(i) = self.chosen {
            lines.push(format!(
                "kept candidate {} ({}): {}",
                i + 1,
                self.tried[i].candidate,
                self.why
            ));
        }
        lines
    }
}

/// The full report of one solve.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Reached, partial or error.
    pub status: Status,
    /// Why stepping stopped short, or the error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
    /// The constraint file (or `<memory>`).
    pub constraint_file: String,
    /// The asset solved.
    pub asset: String,
    /// The file written (`None`: nothing written).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    /// The UV set written (`TEXCOORD_n`).
    pub uv_set: u32,
    /// Every constraint's outcome, in the file's order.
    pub constraints: Vec<ConstraintReport>,
    /// The largest distance of a constraint from its target (texture units).
    pub max_residual: f64,
    /// The mean distance of the constraints from their targets.
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
    /// For a partial result: the stretch of the chart's own shape (its free
    /// layout without landmarks, cut the same way; step 1's on the square).
    /// A partial layout is never more than 3 times as stretched.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stretch_own: Option<Stretch>,
    /// What the completion phase and polish did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub completion: Option<CompletionStats>,
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
    /// Spline-path iterations (Eq. 6 steps accepted or halved).
    pub iterations: u32,
    /// Step halvings by the foldover guard.
    pub halvings: u32,
    /// Milliseconds per stage.
    pub times: StageTimes,
    /// Milliseconds in all.
    pub total_ms: f64,
    /// Sizes of what was solved.
    pub counts: Counts,
    /// How the outer loop was placed on the square (`None`: free).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub boundary: Option<BoundaryReport>,
    /// `square` (the outer loop on the square) or `free`.
    pub boundary_mode: BoundaryMode,
    /// A free boundary's region, start and global injectivity.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub free: Option<FreeReport>,
    /// A large chart's coarse level: what it did, or why it was not used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coarse_level: Option<CoarseLevel>,
    /// Where the chart was cut open to a disk (`None`: it was one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seam: Option<SeamReport>,
    /// The candidates tried for the chart, and which was kept.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plan: Option<PlanReport>,
    /// The other charts given UVs beside the solved one (`None`: none needed them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rest: Option<RestReport>,
    /// The other charts holding constraints, each solved after this one in
    /// its own island: one report each (`status`, `max_residual` above
    /// cover them all).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub charts: Vec<Report>,
    /// What the user should know that did not stop the solve.
    pub warnings: Vec<String>,
}

/// The charts laid out without landmarks and packed around the solved one
/// (the report's `rest` section).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RestReport {
    /// How many charts.
    pub charts: usize,
    /// Their triangles.
    pub triangles: usize,
    /// Triangles of charts that could not be made disks, laid out one by one.
    pub triangle_by_triangle: usize,
    /// Their common scale: texture units per mesh unit.
    pub scale: f64,
}

/// Where a chart was cut open (the report's `seam` section).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeamReport {
    /// `auto` or `given` (the constraint file's `seams: Edges`).
    pub source: &'static str,
    /// Number of edges cut.
    pub n_edges: usize,
    /// 3D length of the seam.
    pub length: f64,
    /// The length relative to the square root of the chart's 3D area.
    pub relative_length: f64,
    /// Vertices split along it (the files hold one more copy each).
    pub vertices_split: usize,
    /// Cone points the seam tree reaches.
    pub cones: usize,
    /// Edges that open handles.
    pub handle_edges: usize,
    /// Edges where the landmarks' chart was cut from the rest of a chart
    /// too large for its targets (the rest is laid out apart).
    pub separation_edges: usize,
    /// The edges, as glTF vertex ids (in the first primitive that has them).
    pub edges: Vec<[Option<u32>; 2]>,
}

/// The `boundary_mode` of a report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundaryMode {
    /// The outer loop on the unit square.
    Square,
    /// The outer loop free inside a region.
    Free,
}

/// What a free boundary's solve did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FreeReport {
    /// The rectangle the chart stays inside (texture coordinates).
    pub region: crate::param::region::Region,
    /// Where the region came from.
    pub region_source: crate::free::RegionSource,
    /// The layout the solve started from.
    pub start: crate::domain::start::StartKind,
    /// How much the start was shrunk to fit its room (1: not at all).
    pub start_shrink: f64,
    /// Newton steps that relaxed the start before the spline path.
    pub relax_steps: u32,
    /// The spline path stalled holding a sample of the outer loop and ran
    /// again with the loop free: `kept`, or `discarded` when that run ended
    /// further from the targets (`null`: not run again).
    pub spline_loop_freed: Option<crate::solver::LoopFreed>,
    /// Pairs of boundary edges of the written layout that cross (always 0).
    pub crossings: usize,
    /// Other islands' triangles near the region, kept clear of.
    pub island_triangles: usize,
    /// Scaffold triangles around the final layout.
    pub scaffold_triangles: usize,
    /// Milliseconds spent on the start (conformal solve, fit, relaxing)
    /// and on triangulating scaffolds.
    pub start_ms: f64,
    /// Milliseconds spent triangulating scaffolds.
    pub scaffold_ms: f64,
}

impl Report {
    /// Adds the reports of the other charts solved with this one (and why
    /// any could not be): the status is the worst of all, the residuals
    /// the largest and mean over every constraint.
    pub fn add_charts(&mut self, charts: Vec<Report>) {
        let rank = |s: Status| match s {
            Status::Reached => 0,
            Status::Partial => 1,
            Status::Error => 2,
        };
        let mut n = self.constraints.len() as f64;
        let mut sum = self.mean_residual * n;
        for c in &charts {
            if rank(c.status) > rank(self.status) {
                self.status = c.status;
                self.message = c.message.as_ref().map(|m| format!("chart {}: {m}", c.counts.chart));
            }
            self.max_residual = self.max_residual.max(c.max_residual);
            sum += c.mean_residual * c.constraints.len() as f64;
            n += c.constraints.len() as f64;
        }
        self.mean_residual = if n > 0.0 { sum / n } else { 0.0 };
        self.charts = charts;
    }

    /// Every chart's constraints: the solved chart's, then the others'.
    pub fn every_constraint(&self) -> impl Iterator<Item = &ConstraintReport> {
        self.constraints
            .iter()
            .chain(self.charts.iter().flat_map(|c| &c.constraints))
    }

    /// A short human summary (a few lines).
    pub fn summary(&self) -> String {
        // Every chart's constraints count, the first's and the others'.
        let counts = format!(
            "{} of {} constraints reached (max residual {:.3e}), {} flipped / {} zero-area triangles",
            self.every_constraint().filter(|c| c.reached).count(),
            self.every_constraint().count(),
            self.max_residual,
            self.orientation.flipped,
            self.orientation.zero_area,
        );
        let target = self.output.as_deref().unwrap_or(&self.asset);
        // An error's first line says why; the counts follow.
        let mut s = match (self.status, &self.message) {
            (Status::Error, Some(m)) => format!("error: {target} — {m}\n  {counts}\n"),
            (status, _) => format!(
                "{}: {target} — {counts}\n",
                match status {
                    Status::Reached => "reached",
                    Status::Partial => "partial",
                    Status::Error => "error",
                }
            ),
        };
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
        for c in &self.charts {
            s += &format!(
                "  and chart {}: {} of {} constraints reached (max residual {:.3e}); stretch L2 {:.4}, L∞ {:.4}\n",
                c.counts.chart,
                c.constraints.iter().filter(|k| k.reached).count(),
                c.constraints.len(),
                c.max_residual,
                c.stretch_final.l2,
                c.stretch_final.linf
            );
        }
        if let Some(seam) = &self.seam {
            s += &format!(
                "  cut open ({} seam): {} edges, length {:.4} ({:.2} × √area), {} vertices split, {} cones, {} edges through handles\n",
                seam.source,
                seam.n_edges,
                seam.length,
                seam.relative_length,
                seam.vertices_split,
                seam.cones,
                seam.handle_edges
            );
        }
        s += &format!(
            "  {} iterations, {} halvings, {:.1} ms\n",
            self.iterations, self.halvings, self.total_ms
        );
        // The first line already says a reached result is on target.
        if let Some(m) = self.message.as_ref().filter(|_| self.status == Status::Partial) {
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
