//! One run of a sweep: its targets (a blend between step 1 and the file's
//! targets, plus seeded jitter) solved through the library's path. The
//! inputs and step-1 probes are loaded once per sweep, on first use, so
//! threads, shards and Ray workers share one way to a row.

use super::file::{CornerChoice, Setting, SweepFile};
use super::plan::SweepPlan;
use super::{Row, Run};
use crate::constraints::{ConstraintSource, LoadedConstraints};
use crate::io::SourceAsset;
use crate::options::SolverOptions;
use crate::report::{Report, Status};
use glam::DVec2;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, OnceLock};

/// A sweep's plan with its inputs and probes, each loaded once when a run
/// first needs it.
pub struct SweepRunner {
    pub plan: SweepPlan,
    inputs: Vec<OnceLock<Input>>,
    probes: HashMap<(usize, CornerChoice), OnceLock<Probe>>,
}

impl SweepRunner {
    /// A runner of `plan`'s grid; loads nothing yet.
    pub fn new(plan: SweepPlan) -> Self {
        let inputs = plan.files.iter().map(|_| OnceLock::new()).collect();
        let probes = plan
            .runs
            .iter()
            .map(|r| ((r.file_index, r.setting.corners), OnceLock::new()))
            .collect();
        SweepRunner { plan, inputs, probes }
    }

    /// Loads the inputs, then the step-1 probes, that `runs` need, in
    /// parallel: each key by one task, so no task waits on another's.
    pub fn preload(&self, runs: &[&Run]) {
        let mut files: Vec<usize> = runs.iter().map(|r| r.file_index).collect();
        files.sort_unstable();
        files.dedup();
        files.par_iter().for_each(|&i| {
            self.input(i);
        });
        let mut keys: Vec<(usize, CornerChoice)> = runs.iter().map(|r| (r.file_index, r.setting.corners)).collect();
        keys.sort_by_key(|(i, c)| (*i, *c == CornerChoice::Auto));
        keys.dedup();
        keys.par_iter().for_each(|&(i, corners)| {
            self.probe(i, corners);
        });
    }

    fn input(&self, file_index: usize) -> &Input {
        self.inputs[file_index].get_or_init(|| {
            let loaded = crate::api::load(
                &self.plan.files[file_index],
                &SolverOptions::DEFAULT,
                &crate::io::InputRules::default(),
            )
            .map(|(l, a)| (l, Arc::new(a)))
            .map_err(Arc::new);
            Input {
                name: self.plan.names[file_index].clone(),
                loaded,
            }
        })
    }

    fn probe(&self, file_index: usize, corners: CornerChoice) -> &Probe {
        self.probes[&(file_index, corners)].get_or_init(|| match &self.input(file_index).loaded {
            Ok((l, a)) => probe_step1(l, a, corners),
            Err(e) => Err(e.clone()),
        })
    }

    /// Solves `run` (one of this plan's); its thumbnail, when the sweep draws
    /// them, is written into `thumbs`.
    pub fn solve(&self, run: &Run, thumbs: Option<&Path>) -> Row {
        let input = self.input(run.file_index);
        let probe = self.probe(run.file_index, run.setting.corners);
        solve_run(run, input, probe, &self.plan.sweep, thumbs)
    }
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// A deterministic generator (SplitMix64) for the jitter.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A stable 64-bit hash of `s` (FNV-1a), for seeding per run.
fn stable_hash(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A constraint file and its asset, loaded once per sweep.
struct Input {
    name: String,
    /// Loaded once and read by every run: the error shared, not rebuilt.
    loaded: Result<(LoadedConstraints, Arc<SourceAsset>), Arc<crate::Error>>,
}

/// Step-1 position and whether on the outer boundary, per constraint (file order).
type Probe = Result<Vec<(DVec2, bool)>, Arc<crate::Error>>;

fn options_for(loaded: &LoadedConstraints, setting: &Setting) -> SolverOptions {
    setting.solver.unwrap_or(loaded.solver)
}

fn with_setting(loaded: &LoadedConstraints, setting: &Setting) -> LoadedConstraints {
    let mut l = loaded.clone();
    l.solver = options_for(loaded, setting);
    if setting.corners == CornerChoice::Auto {
        l.file.corners = None;
    }
    l
}

/// Step 1 only (the probe): where the bar-net puts each constraint, and
/// whether it is on the outer boundary.
fn probe_step1(loaded: &LoadedConstraints, asset: &Arc<SourceAsset>, corners: CornerChoice) -> Probe {
    let setting = Setting {
        name: String::new(),
        solver: None,
        corners,
    };
    let source = ConstraintSource::File(Arc::new(with_setting(loaded, &setting)));
    let mut session = crate::session::ChartSession::open(source, asset.clone(), 0.0).map_err(Arc::new)?;
    session.run_step_one().map_err(Arc::new)?;
    let (Some(boundary), Some(layout)) = (session.boundary(), session.step_one_layout()) else {
        return Err(Arc::new(crate::Error::Internal("step 1 was not solved".into())));
    };
    let prepared = session.prepared();
    let on_outer = boundary.on_loop(prepared.filled.mesh.n_vertices());
    let mut out = vec![(DVec2::ZERO, false); loaded.file.constraints.len()];
    for (c, &v) in prepared.constraints.iter().zip(&prepared.constraint_vertices) {
        out[c.index] = (crate::param::xy_to_uv(layout[v as usize]), on_outer[v as usize]);
    }
    Ok(out)
}

/// The file name of `run`'s thumbnail (its grid index and a safe form of its id).
pub fn thumbnail_name(run: &Run) -> String {
    let safe: String = run
        .id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("{:04}-{}.png", run.index, safe.chars().take(80).collect::<String>())
}

fn solve_run(run: &Run, input: &Input, step1: &Probe, sweep: &SweepFile, thumbs: Option<&Path>) -> Row {
    let started = std::time::Instant::now();
    let mut row = Row {
        run: run.index,
        id: run.id.clone(),
        constraint_file: input.name.clone(),
        setting: run.setting.name.clone(),
        blend: run.blend,
        jitter_sample: run.sample,
        guard: String::new(),
        completion: String::new(),
        max_halvings: 0,
        corners: format!("{:?}", run.setting.corners),
        status: "error".into(),
        reached: 0,
        constraints: 0,
        max_residual: None,
        mean_residual: None,
        flipped: 0,
        zero_area: 0,
        stretch_l2_step1: None,
        stretch_l2: None,
        stretch_linf: None,
        iterations: 0,
        halvings: 0,
        completion_ran: false,
        newton_steps: 0,
        time_ms: 0.0,
        thumbnail: None,
        message: String::new(),
    };
    let (loaded, asset) = match &input.loaded {
        Ok(x) => x,
        Err(e) => {
            row.message = e.to_string();
            return row;
        }
    };
    let options = options_for(loaded, &run.setting);
    row.guard = format!("{:?}", options.guard);
    row.completion = format!("{:?}", options.completion);
    row.max_halvings = options.max_halvings;
    let step1 = match step1 {
        Ok(s) => s,
        Err(e) => {
            row.message = e.to_string();
            return row;
        }
    };
    let mut l = with_setting(loaded, &run.setting);
    let mut rng = run.sample.map(|s| {
        let seed = sweep.jitter.map_or(0, |j| j.seed);
        SplitMix(seed ^ stable_hash(&format!("{}|{s}|{}", input.name, run.blend_index)))
    });
    let amplitude = sweep.jitter.map_or(0.0, |j| j.amplitude);
    for (i, spec) in l.file.constraints.iter_mut().enumerate() {
        let (start, on_boundary) = step1[i];
        let Some(requested) = spec.uv.or_else(|| {
            let (w, h) = l.file.image_size?;
            spec.px.map(|p| DVec2::new(p.x / w as f64, p.y / h as f64))
        }) else {
            continue;
        };
        let mut target = (start + (requested - start) * run.blend).clamp(DVec2::ZERO, DVec2::ONE);
        if let Some(rng) = rng.as_mut()
            && !on_boundary
        {
            let d = DVec2::new(rng.next() * 2.0 - 1.0, rng.next() * 2.0 - 1.0) * amplitude;
            target = (target + d).clamp(DVec2::ZERO, DVec2::ONE);
        }
        spec.uv = Some(target);
        spec.px = None;
    }
    let thumbnail = thumbs.map(|dir| dir.join(thumbnail_name(run)));
    let options = crate::api::Options {
        pictures: crate::preview::Pictures {
            layout: thumbnail.clone(),
            render: None,
            size: sweep.thumbnail_size,
            background: None,
        },
        // A thumbnail shows a refused run too (the paper guard's folds).
        on_error: crate::api::OnError::DrawPictures,
        ..Default::default()
    };
    match crate::api::solve_loaded(l, asset, &options) {
        Ok(report) => fill_row(&mut row, &report),
        Err(e) => row.message = e.to_string(),
    }
    if row.status != "error" {
        row.thumbnail = thumbnail.map(|t| t.file_name().unwrap_or_default().to_string_lossy().into_owned());
    }
    row.time_ms = started.elapsed().as_secs_f64() * 1e3;
    row
}

fn fill_row(row: &mut Row, report: &Report) {
    let folded = report.orientation.flipped + report.orientation.zero_area > 0;
    row.status = match (report.status, folded) {
        (_, true) => "folded",
        (Status::Reached, false) => "reached",
        (Status::Partial, false) => "partial",
        (Status::Error, false) => "error",
    }
    .into();
    row.reached = report.constraints.iter().filter(|c| c.reached).count();
    row.constraints = report.constraints.len();
    row.max_residual = finite(report.max_residual);
    row.mean_residual = finite(report.mean_residual);
    row.flipped = report.orientation.flipped;
    row.zero_area = report.orientation.zero_area;
    row.stretch_l2_step1 = finite(report.stretch_step1.l2);
    row.stretch_l2 = finite(report.stretch_final.l2);
    row.stretch_linf = finite(report.stretch_final.linf);
    row.iterations = report.iterations;
    row.halvings = report.halvings;
    if let Some(c) = &report.completion {
        row.completion_ran = c.soft;
        row.newton_steps = c.newton_steps + c.polish_steps;
    }
    // A row's message says what went short; a reached run's needs no words.
    if report.status != Status::Reached {
        row.message = report.message.clone().unwrap_or_default();
    }
}
