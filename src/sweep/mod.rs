//! `uvpin sweep`: a grid of solves over constraint files × solver settings ×
//! target blends × seeded jitter, run in parallel, one row per run (CSV and
//! JSON Lines), a summary per setting, layout thumbnails and a contact sheet.
//! Deterministic for a given sweep file (every column but `time_ms`);
//! re-running skips the runs already in `runs.jsonl`.

pub mod file;

use crate::constraints::{ConstraintSource, LoadedConstraints};
use crate::io::SourceAsset;
use crate::options::SolverOptions;
use crate::report::{Report, Status};
use file::{CornerChoice, Setting, SweepFile};
use glam::DVec2;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use thiserror::Error;

#[derive(Debug, Error)]
pub enum SweepError {
    #[error("{path}: cannot read the sweep file: {source}")]
    Read {
        path: PathBuf,
        source: crate::io::ReadError,
    },
    #[error("{path}: the sweep is too large: {message}")]
    TooLarge { path: PathBuf, message: String },
    #[error("{path}: setting {setting:?}: {source}")]
    Option {
        path: PathBuf,
        setting: String,
        source: crate::options::OptionError,
    },
    #[error(transparent)]
    Syntax(#[from] crate::ron_file::RonSyntaxError),
    #[error("{sweep}: constraints pattern {pattern:?} matches no file")]
    NoFiles { sweep: PathBuf, pattern: String },
    #[error("{path}: cannot write: {message}")]
    Write { path: PathBuf, message: String },
    #[error("cannot start {jobs} worker threads: {message}")]
    Threads { jobs: usize, message: String },
}

/// How a sweep shows progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// A progress bar on a terminal, plain lines otherwise.
    Auto,
    /// Nothing.
    Quiet,
}

/// Options of one `uvpin sweep` invocation.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Re-run every run, even those already in `runs.jsonl`.
    pub force: bool,
    /// Worker threads (default: one per core).
    pub jobs: Option<usize>,
    pub progress: Progress,
}

/// One cell of the grid.
#[derive(Debug, Clone)]
pub struct Run {
    /// Position in the grid (row order of the outputs).
    pub index: usize,
    /// Stable identity: file, setting, blend, jitter sample.
    pub id: String,
    pub file_index: usize,
    pub setting: Setting,
    pub blend: f64,
    pub blend_index: usize,
    pub sample: Option<u32>,
}

/// One result row (CSV and JSON Lines). Non-finite figures are empty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub run: usize,
    pub id: String,
    pub constraint_file: String,
    pub setting: String,
    pub blend: f64,
    pub jitter_sample: Option<u32>,
    pub guard: String,
    pub completion: String,
    pub max_halvings: u32,
    pub corners: String,
    /// `reached`, `partial`, `folded` (paper guard only; never exported) or `error`.
    pub status: String,
    pub reached: usize,
    pub constraints: usize,
    pub max_residual: Option<f64>,
    pub mean_residual: Option<f64>,
    pub flipped: usize,
    pub zero_area: usize,
    pub stretch_l2_step1: Option<f64>,
    pub stretch_l2: Option<f64>,
    pub stretch_linf: Option<f64>,
    pub iterations: u32,
    pub halvings: u32,
    pub completion_ran: bool,
    pub newton_steps: u32,
    pub time_ms: f64,
    pub thumbnail: Option<String>,
    pub message: String,
}

/// CSV columns, in order (the fields of [`Row`]).
pub const COLUMNS: [&str; 27] = [
    "run",
    "id",
    "constraint_file",
    "setting",
    "blend",
    "jitter_sample",
    "guard",
    "completion",
    "max_halvings",
    "corners",
    "status",
    "reached",
    "constraints",
    "max_residual",
    "mean_residual",
    "flipped",
    "zero_area",
    "stretch_l2_step1",
    "stretch_l2",
    "stretch_linf",
    "iterations",
    "halvings",
    "completion_ran",
    "newton_steps",
    "time_ms",
    "thumbnail",
    "message",
];

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// What a finished sweep did.
#[derive(Debug, Clone)]
pub struct SweepOutcome {
    pub rows: Vec<Row>,
    /// Runs solved now (the others were already in runs.jsonl).
    pub ran: usize,
    pub output: PathBuf,
    /// The summary table (Markdown).
    pub summary: String,
}

/// The grid of runs of `sweep` over `files`.
pub fn grid(sweep: &SweepFile, files: &[String]) -> Vec<Run> {
    let mut runs = Vec::new();
    let blends = sweep.blend_values();
    let samples: Vec<Option<u32>> = match sweep.jitter {
        Some(j) if j.samples > 0 => (0..j.samples).map(Some).collect(),
        _ => vec![None],
    };
    for (file_index, file) in files.iter().enumerate() {
        for setting in sweep.settings() {
            for &sample in &samples {
                for (blend_index, &blend) in blends.iter().enumerate() {
                    let id = format!(
                        "{file}|{}|b={blend:.4}|j={}",
                        setting.name,
                        sample.map_or("-".into(), |s| s.to_string())
                    );
                    runs.push(Run {
                        index: runs.len(),
                        id,
                        file_index,
                        setting: setting.clone(),
                        blend,
                        blend_index,
                        sample,
                    });
                }
            }
        }
    }
    runs
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
    loaded: Result<(LoadedConstraints, Arc<SourceAsset>), String>,
}

/// Step-1 position and whether on the outer boundary, per constraint (file order).
type Probe = Result<Vec<(DVec2, bool)>, String>;

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
    let mut session = crate::session::ChartSession::open(source, asset.clone(), 0.0).map_err(|e| e.to_string())?;
    session.run_step_one().map_err(|e| e.to_string())?;
    let (Some(boundary), Some(layout)) = (session.boundary(), session.step_one_layout()) else {
        return Err("step 1 was not solved".into());
    };
    let prepared = session.prepared();
    let on_outer = boundary.on_loop(prepared.filled.mesh.n_vertices());
    let mut out = vec![(DVec2::ZERO, false); loaded.file.constraints.len()];
    for (c, &v) in prepared.constraints.iter().zip(&prepared.constraint_vertices) {
        out[c.index] = (crate::param::xy_to_uv(layout[v as usize]), on_outer[v as usize]);
    }
    Ok(out)
}

fn thumbnail_name(run: &Run) -> String {
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
            row.message = e.clone();
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
            row.message = e.clone();
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

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The rows as CSV (header first).
pub fn to_csv(rows: &[Row]) -> String {
    let mut out = COLUMNS.join(",") + "\n";
    for r in rows {
        let v = serde_json::to_value(r).expect("row serialises");
        let fields: Vec<String> = COLUMNS
            .iter()
            .map(|c| match &v[*c] {
                serde_json::Value::Null => String::new(),
                serde_json::Value::String(s) => csv_field(s),
                other => other.to_string(),
            })
            .collect();
        out += &fields.join(",");
        out.push('\n');
    }
    out
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Per setting: runs, reached / partial / folded / error counts, median
/// stretch (fold-free results) and median time (Markdown table).
pub fn summary(rows: &[Row]) -> String {
    let mut order: Vec<String> = Vec::new();
    for r in rows {
        if !order.contains(&r.setting) {
            order.push(r.setting.clone());
        }
    }
    let mut out = String::from(
        "| setting | runs | reached | partial | folded | error | stretch L2 (median) | time ms (median) |\n|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for name in order {
        let rs: Vec<&Row> = rows.iter().filter(|r| r.setting == name).collect();
        let count = |s: &str| rs.iter().filter(|r| r.status == s).count();
        let stretch = median(
            rs.iter()
                .filter(|r| r.status == "reached" || r.status == "partial")
                .filter_map(|r| r.stretch_l2)
                .collect(),
        );
        let time = median(rs.iter().map(|r| r.time_ms).collect());
        out += &format!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} |\n",
            rs.len(),
            count("reached"),
            count("partial"),
            count("folded"),
            count("error"),
            stretch.map_or("–".into(), |s| format!("{s:.3}")),
            time.map_or("–".into(), |t| format!("{t:.1}")),
        );
    }
    out
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), SweepError> {
    crate::io::atomic::write_atomically(path, bytes).map_err(|e| SweepError::Write {
        path: path.to_path_buf(),
        message: e.message,
    })
}

/// Worker threads of one sweep at most.
pub const MAX_JOBS: usize = 256;

/// Runs the sweep in `sweep_path`.
///
/// # Errors
/// The sweep file (unreadable, RON errors, a pattern matching nothing),
/// the output folder. Failures of single runs are rows with status `error`.
pub fn run_sweep(sweep_path: &Path, options: &SweepOptions) -> Result<SweepOutcome, SweepError> {
    let sweep = SweepFile::load(sweep_path)?;
    // A bare file name's folder is the current one.
    let base = sweep_path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let files = expand_files(&sweep, sweep_path, base)?;
    let names: Vec<String> = files
        .iter()
        .map(|f| f.strip_prefix(base).unwrap_or(f).display().to_string())
        .collect();
    let output = output_folder(base, &sweep.output);
    let jsonl_path = output.join("runs.jsonl");
    let runs = grid(&sweep, &names);
    check_grid(&runs, &sweep, sweep_path)?;
    let mut done = if options.force {
        HashMap::new()
    } else {
        rows_done(&jsonl_path)
    };
    let pending: Vec<&Run> = runs.iter().filter(|r| !done.contains_key(&r.id)).collect();
    let thumbs = sweep.thumbnails.then(|| output.join("thumbs"));
    std::fs::create_dir_all(thumbs.as_deref().unwrap_or(&output)).map_err(|e| SweepError::Write {
        path: output.clone(),
        message: e.to_string(),
    })?;
    let jobs = options
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if !(1..=MAX_JOBS).contains(&jobs) {
        return Err(SweepError::Threads {
            jobs,
            message: format!("--jobs must be between 1 and {MAX_JOBS}"),
        });
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.max(1))
        .build()
        .map_err(|e| SweepError::Threads {
            jobs,
            message: e.to_string(),
        })?;
    let inputs = pool.install(|| load_inputs(&files, &names, &pending));
    let probes = pool.install(|| probe_all(&inputs, &pending));
    let ctx = RunContext {
        inputs: &inputs,
        probes: &probes,
        sweep: &sweep,
        thumbs: thumbs.as_deref(),
    };
    let new_rows = pool.install(|| run_pending(&ctx, &pending, &jsonl_path, options))?;
    let ran = new_rows.len();
    for row in new_rows {
        done.insert(row.id.clone(), row);
    }
    // Rows in grid order; rows of runs no longer in the grid are dropped.
    let rows: Vec<Row> = runs.iter().filter_map(|r| done.remove(&r.id)).collect();
    let summary = write_outputs(&output, &rows, &runs, thumbs.as_deref(), sweep.thumbnail_size)?;
    Ok(SweepOutcome {
        rows,
        ran,
        output,
        summary,
    })
}

/// The grid and its contact sheet stay within [`file::MAX_RUNS`] and
/// [`file::MAX_SHEET_PIXELS`].
fn check_grid(runs: &[Run], sweep: &SweepFile, sweep_path: &Path) -> Result<(), SweepError> {
    let too_large = |message: String| SweepError::TooLarge {
        path: sweep_path.to_path_buf(),
        message,
    };
    if runs.len() > file::MAX_RUNS {
        return Err(too_large(format!("{} runs, more than {}", runs.len(), file::MAX_RUNS)));
    }
    let pixels = runs.len() as u64 * u64::from(sweep.thumbnail_size).pow(2);
    if sweep.thumbnails && pixels > file::MAX_SHEET_PIXELS {
        return Err(too_large(format!(
            "{} thumbnails of {} px make a contact sheet of {pixels} pixels, more than {}",
            runs.len(),
            sweep.thumbnail_size,
            file::MAX_SHEET_PIXELS
        )));
    }
    Ok(())
}

/// The constraint files the sweep's patterns name, each once.
fn expand_files(sweep: &SweepFile, sweep_path: &Path, base: &Path) -> Result<Vec<PathBuf>, SweepError> {
    let mut files: Vec<PathBuf> = Vec::new();
    for pattern in &sweep.constraints {
        let found = file::expand(pattern, base);
        if found.is_empty() {
            return Err(SweepError::NoFiles {
                sweep: sweep_path.to_path_buf(),
                pattern: pattern.clone(),
            });
        }
        for f in found {
            if !files.contains(&f) {
                files.push(f);
            }
        }
    }
    Ok(files)
}

/// The output folder, relative to the working folder where it is inside it.
fn output_folder(base: &Path, output: &Path) -> PathBuf {
    let cwd = std::env::current_dir().unwrap_or_default();
    let output = crate::io::paths::normalize(&base.join(output), &cwd);
    output.strip_prefix(&cwd).map(Path::to_path_buf).unwrap_or(output)
}

/// The rows already in `runs.jsonl`, by run id.
fn rows_done(jsonl_path: &Path) -> HashMap<String, Row> {
    let Ok(text) = std::fs::read_to_string(jsonl_path) else {
        return HashMap::new();
    };
    text.lines()
        .filter_map(|line| serde_json::from_str::<Row>(line).ok())
        .map(|row| (row.id.clone(), row))
        .collect()
}

/// The constraint files with pending runs and their assets, loaded once each.
fn load_inputs(files: &[PathBuf], names: &[String], pending: &[&Run]) -> HashMap<usize, Input> {
    let needed: Vec<usize> = (0..files.len())
        .filter(|&i| pending.iter().any(|r| r.file_index == i))
        .collect();
    needed
        .par_iter()
        .map(|&i| {
            let loaded = crate::api::load(&files[i], &SolverOptions::DEFAULT, &crate::io::InputRules::default())
                .map(|(l, a)| (l, Arc::new(a)))
                .map_err(|e| e.to_string());
            let input = Input {
                name: names[i].clone(),
                loaded,
            };
            (i, input)
        })
        .collect()
}

/// Step 1 of every (file, corner choice) the pending runs need.
fn probe_all(inputs: &HashMap<usize, Input>, pending: &[&Run]) -> HashMap<(usize, CornerChoice), Probe> {
    let mut keys: Vec<(usize, CornerChoice)> = pending.iter().map(|r| (r.file_index, r.setting.corners)).collect();
    keys.sort_by_key(|(i, c)| (*i, *c == CornerChoice::Auto));
    keys.dedup();
    keys.par_iter()
        .map(|&(i, corners)| {
            let step1 = match &inputs[&i].loaded {
                Ok((l, a)) => probe_step1(l, a, corners),
                Err(e) => Err(e.clone()),
            };
            ((i, corners), step1)
        })
        .collect()
}

/// What every run of one sweep shares.
struct RunContext<'a> {
    inputs: &'a HashMap<usize, Input>,
    probes: &'a HashMap<(usize, CornerChoice), Probe>,
    sweep: &'a SweepFile,
    thumbs: Option<&'a Path>,
}

/// A progress bar on a terminal, plain lines otherwise (or nothing).
enum Reporter {
    Bar(indicatif::ProgressBar),
    Lines,
    Quiet,
}

impl Reporter {
    fn new(progress: Progress, total: usize) -> Self {
        match progress {
            Progress::Quiet => Reporter::Quiet,
            Progress::Auto if std::io::stderr().is_terminal() => {
                let bar = indicatif::ProgressBar::new(total as u64);
                if let Ok(style) = indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} {msg}")
                {
                    bar.set_style(style);
                }
                Reporter::Bar(bar)
            }
            Progress::Auto => Reporter::Lines,
        }
    }

    fn done(&self, row: &Row, k: usize, total: usize) {
        match self {
            Reporter::Bar(bar) => {
                bar.inc(1);
                bar.set_message(format!("{}: {}", row.id, row.status));
            }
            Reporter::Lines => eprintln!("[{k}/{total}] {}: {} ({:.1} ms)", row.id, row.status, row.time_ms),
            Reporter::Quiet => {}
        }
    }

    fn finish(self) {
        if let Reporter::Bar(bar) = self {
            bar.finish_and_clear();
        }
    }
}

/// Solves the pending runs in parallel, each row appended to the journal
/// (`runs.jsonl`) as it finishes, so an interrupted sweep resumes.
fn run_pending(
    ctx: &RunContext,
    pending: &[&Run],
    jsonl_path: &Path,
    options: &SweepOptions,
) -> Result<Vec<Row>, SweepError> {
    let journal = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(jsonl_path)
        .map_err(|e| SweepError::Write {
            path: jsonl_path.to_path_buf(),
            message: e.to_string(),
        })?;
    if options.force {
        journal.set_len(0).ok();
    }
    let journal = Mutex::new(journal);
    let reporter = Reporter::new(options.progress, pending.len());
    let counter = std::sync::atomic::AtomicUsize::new(0);
    let rows = pending
        .par_iter()
        .map(|run| {
            let input = &ctx.inputs[&run.file_index];
            let probe = &ctx.probes[&(run.file_index, run.setting.corners)];
            let row = solve_run(run, input, probe, ctx.sweep, ctx.thumbs);
            if let Ok(line) = serde_json::to_string(&row)
                && let Ok(mut f) = journal.lock()
            {
                let _ = writeln!(f, "{line}");
            }
            let k = counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            reporter.done(&row, k, pending.len());
            row
        })
        .collect();
    reporter.finish();
    Ok(rows)
}

/// Writes `runs.jsonl` (in grid order), `runs.csv`, `summary.md` and the
/// contact sheet; returns the summary.
fn write_outputs(
    output: &Path,
    rows: &[Row],
    runs: &[Run],
    thumbs: Option<&Path>,
    thumbnail_size: u32,
) -> Result<String, SweepError> {
    let mut jsonl = String::new();
    for r in rows {
        jsonl += &serde_json::to_string(r).expect("row serialises");
        jsonl.push('\n');
    }
    write(&output.join("runs.jsonl"), jsonl.as_bytes())?;
    write(&output.join("runs.csv"), to_csv(rows).as_bytes())?;
    let summary = summary(rows);
    write(&output.join("summary.md"), summary.as_bytes())?;
    if let Some(dir) = thumbs {
        let sheet = contact_sheet(runs, rows, dir, thumbnail_size);
        let png = crate::preview::render::encode_png(&sheet).map_err(|e| SweepError::Write {
            path: output.join("contact_sheet.png"),
            message: e.to_string(),
        })?;
        write(&output.join("contact_sheet.png"), &png)?;
    }
    Ok(summary)
}

/// Status colour under each thumbnail of the contact sheet.
pub fn status_colour(status: &str) -> [u8; 3] {
    match status {
        "reached" => [40, 170, 70],
        "partial" => [240, 160, 30],
        "folded" => [200, 0, 200],
        _ => [200, 30, 30],
    }
}

/// One thumbnail per run: a row per (file, setting, jitter sample), a
/// column per blend value, each with a status bar (green reached, orange
/// partial, magenta folded, red error). Rows are labelled with their
/// setting (and file and sample when there are several), columns with
/// their blend, and a key below names the bar colours.
fn contact_sheet(runs: &[Run], rows: &[Row], thumbs: &Path, size: u32) -> image::RgbaImage {
    use crate::preview::text::{self, Ink};
    use image::{Rgba, RgbaImage};
    let columns = runs.iter().map(|r| r.blend_index).max().map_or(1, |m| m + 1) as u32;
    let n_rows = (runs.len() as u32).div_ceil(columns.max(1));
    let (gap, bar) = (4u32, 6u32);
    let line = text::line_height(1);
    let row_names: Vec<String> = runs
        .iter()
        .step_by(columns as usize)
        .map(|r| row_name(r, runs))
        .collect();
    let label_w = row_names.iter().map(|n| text::width(n, 1)).max().unwrap_or(0) + 2 * gap;
    let key = "bar: reached  partial  folded  error";
    let (cell_w, cell_h) = (size + gap, size + bar + gap);
    let width = (label_w + columns * cell_w + gap).max(text::width(key, 1) + 10 * text::GLYPH);
    let mut sheet = RgbaImage::from_pixel(
        width,
        line + n_rows * cell_h + gap + line + gap,
        Rgba([255, 255, 255, 255]),
    );
    let ink = Ink::dark(1);
    let by_id: HashMap<&str, &Row> = rows.iter().map(|r| (r.id.as_str(), r)).collect();
    for (k, run) in runs.iter().enumerate() {
        let (col, row_k) = (k as u32 % columns, k as u32 / columns);
        let (cx, cy) = (label_w + col * cell_w + gap, line + row_k * cell_h + gap);
        if row_k == 0 {
            text::draw(&mut sheet, i64::from(cx), 2, &format!("blend {}", run.blend), ink);
        }
        if col == 0 {
            let y = i64::from(cy + size / 2) - i64::from(text::GLYPH / 2);
            text::draw(&mut sheet, i64::from(gap), y, &row_names[row_k as usize], ink);
        }
        let row = by_id.get(run.id.as_str());
        let thumb = row
            .and_then(|r| r.thumbnail.as_ref())
            .and_then(|t| image::open(thumbs.join(t)).ok())
            .map(|i| i.to_rgba8());
        for y in 0..size {
            for x in 0..size {
                let p = thumb
                    .as_ref()
                    .and_then(|t| t.get_pixel_checked(x, y).copied())
                    .unwrap_or(Rgba([225, 225, 225, 255]));
                sheet.put_pixel(cx + x, cy + y, p);
            }
        }
        let colour = status_colour(row.map_or("error", |r| r.status.as_str()));
        text::fill_rect(&mut sheet, i64::from(cx), i64::from(cy + size), size, bar, colour, 255);
    }
    let key_y = i64::from(sheet.height() - line);
    draw_bar_key(&mut sheet, i64::from(gap), key_y);
    sheet
}

/// How a contact-sheet row is named: its setting, with the file and the
/// jitter sample when the sweep has several of them.
fn row_name(run: &Run, runs: &[Run]) -> String {
    let mut name = run.setting.name.clone();
    if runs.iter().any(|r| r.file_index != run.file_index) {
        name = format!("file {} {name}", run.file_index + 1);
    }
    if let Some(sample) = run.sample {
        name += &format!(" #{sample}");
    }
    // A long name is cut: the sheet's size stays bounded by its thumbnails.
    if name.chars().count() > 40 {
        name = name.chars().take(37).collect::<String>() + "...";
    }
    name
}

/// The key of the status bars: a swatch and a word for each status.
fn draw_bar_key(sheet: &mut image::RgbaImage, mut x: i64, y: i64) {
    use crate::preview::text::{self, Ink};
    x += i64::from(text::draw(sheet, x, y, "bar: ", Ink::dark(1)));
    for status in ["reached", "partial", "folded", "error"] {
        text::fill_rect(sheet, x, y, text::GLYPH * 2, text::GLYPH, status_colour(status), 255);
        x += i64::from(text::GLYPH * 2 + 4);
        x += i64::from(text::draw(sheet, x, y, &format!("{status}   "), Ink::dark(1)));
    }
}
