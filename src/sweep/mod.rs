//! `uvpin sweep`: a grid of solves over constraint files × solver settings ×
//! target blends × seeded jitter, run in parallel, one row per run (CSV and
//! JSON Lines), a summary per setting, layout thumbnails and a contact sheet.
//! Deterministic for a given sweep file (every column but `time_ms`);
//! re-running skips the runs already in `runs.jsonl`.

pub mod file;
pub mod plan;
pub mod run;
pub mod shard;
pub mod sheet;

use file::{Setting, SweepFile};
pub use plan::SweepPlan;
use rayon::prelude::*;
pub use run::SweepRunner;
use serde::{Deserialize, Serialize};
pub use shard::{Shard, merge};
use std::collections::HashMap;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum SweepError {
    #[error("{path}: cannot read the sweep file: {source}")]
    Read {
        path: PathBuf,
        source: crate::io::ReadError,
    },
    #[error("{path}: the sweep is too large: {size}")]
    TooLarge { path: PathBuf, size: file::SizeError },
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
    #[error("--shard {given:?}: {error}")]
    Shard { given: String, error: shard::ShardError },
    #[error("{path}: cannot merge the shards: {error}")]
    Merge { path: PathBuf, error: shard::MergeError },
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
    /// Run only this part of the grid, into its own folder (a job array's task).
    pub shard: Option<Shard>,
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

/// Runs the sweep in `sweep_path`, or the part of it `options.shard` names
/// (into its own folder, for [`merge`]).
///
/// # Errors
/// The sweep file (unreadable, RON errors, a pattern matching nothing),
/// the output folder. Failures of single runs are rows with status `error`.
pub fn run_sweep(sweep_path: &Path, options: &SweepOptions) -> Result<SweepOutcome, SweepError> {
    let runner = SweepRunner::new(SweepPlan::open(sweep_path)?);
    let plan = &runner.plan;
    let (folder, runs): (PathBuf, Vec<&Run>) = match options.shard {
        None => (plan.output.clone(), plan.runs.iter().collect()),
        Some(shard) => (
            shard.folder(&plan.output),
            plan.runs.iter().filter(|r| shard.holds(r.index)).collect(),
        ),
    };
    let jsonl_path = folder.join("runs.jsonl");
    let mut done = if options.force {
        HashMap::new()
    } else {
        rows_done(&jsonl_path)
    };
    let pending: Vec<&Run> = runs.iter().filter(|r| !done.contains_key(&r.id)).copied().collect();
    let thumbs = plan.thumbs_in(&folder);
    std::fs::create_dir_all(thumbs.as_deref().unwrap_or(&folder)).map_err(|e| SweepError::Write {
        path: folder.clone(),
        message: e.to_string(),
    })?;
    let pool = thread_pool(options.jobs)?;
    pool.install(|| runner.preload(&pending));
    let new_rows = pool.install(|| run_pending(&runner, &pending, &jsonl_path, thumbs.as_deref(), options))?;
    let ran = new_rows.len();
    for row in new_rows {
        done.insert(row.id.clone(), row);
    }
    // Rows in grid order; rows of runs no longer in the grid are dropped.
    let rows: Vec<Row> = runs.iter().filter_map(|r| done.remove(&r.id)).collect();
    // A shard's rows are one part of the grid: the merge draws the sheet.
    let sheet = thumbs.as_deref().filter(|_| options.shard.is_none());
    let summary = write_outputs(&folder, &rows, &plan.runs, sheet, plan.sweep.thumbnail_size)?;
    Ok(SweepOutcome {
        rows,
        ran,
        output: folder,
        summary,
    })
}

/// A pool of `jobs` worker threads (default: one per core).
fn thread_pool(jobs: Option<usize>) -> Result<rayon::ThreadPool, SweepError> {
    let jobs = jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if !(1..=MAX_JOBS).contains(&jobs) {
        return Err(SweepError::Threads {
            jobs,
            message: format!("--jobs must be between 1 and {MAX_JOBS}"),
        });
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| SweepError::Threads {
            jobs,
            message: e.to_string(),
        })
}

/// The rows already in `runs.jsonl`, by run id.
pub fn rows_done(jsonl_path: &Path) -> HashMap<String, Row> {
    let Ok(text) = std::fs::read_to_string(jsonl_path) else {
        return HashMap::new();
    };
    text.lines()
        .filter_map(|line| serde_json::from_str::<Row>(line).ok())
        .map(|row| (row.id.clone(), row))
        .collect()
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
    runner: &SweepRunner,
    pending: &[&Run],
    jsonl_path: &Path,
    thumbs: Option<&Path>,
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
            let row = runner.solve(run, thumbs);
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
pub fn write_outputs(
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
        let sheet = sheet::contact_sheet(runs, rows, dir, thumbnail_size);
        let png = crate::preview::render::encode_png(&sheet).map_err(|e| SweepError::Write {
            path: output.join("contact_sheet.png"),
            message: e.to_string(),
        })?;
        write(&output.join("contact_sheet.png"), &png)?;
    }
    Ok(summary)
}
