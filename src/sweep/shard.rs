//! Sweeps across machines on a job array (Slurm, Kubernetes Indexed Jobs,
//! AWS Batch): `--shard I/N` runs a deterministic part of the grid into its
//! own folder, and [`merge`] joins the parts into the rows, summary and
//! contact sheet one machine writes.

use super::plan::SweepPlan;
use super::{Row, SweepError, SweepOutcome, rows_done, write_outputs};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Part `index` of `count` of a grid; numbered from 0 as job arrays number
/// their tasks (`SLURM_ARRAY_TASK_ID` of `--array=0-3`,
/// `JOB_COMPLETION_INDEX`, `AWS_BATCH_JOB_ARRAY_INDEX`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// Shards of one grid at most (a grid has at most this many runs).
    pub const MAX_COUNT: usize = super::file::MAX_RUNS;

    /// Whether grid run `run` is this shard's. Runs are dealt in turn, so
    /// every shard gets a share of each file, setting and blend.
    pub fn holds(&self, run: usize) -> bool {
        run % self.count == self.index
    }

    /// The folder of this shard's rows inside the sweep's output folder.
    pub fn folder(&self, output: &Path) -> PathBuf {
        output.join("shards").join(format!("{}-of-{}", self.index, self.count))
    }

    /// The shard a folder name (`I-of-N`) stands for.
    fn from_folder_name(name: &str) -> Option<Shard> {
        let (i, n) = name.split_once("-of-")?;
        Shard::new(i.parse().ok()?, n.parse().ok()?).ok()
    }

    fn new(index: usize, count: usize) -> Result<Shard, ShardError> {
        if !(1..=Self::MAX_COUNT).contains(&count) {
            return Err(ShardError::Count { max: Self::MAX_COUNT });
        }
        if index >= count {
            return Err(ShardError::Index { last: count - 1 });
        }
        Ok(Shard { index, count })
    }
}

/// What is wrong with a `--shard I/N`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    #[error("expected I/N, e.g. 0/4")]
    Form,
    #[error("{0:?} is not a whole number")]
    NotANumber(String),
    #[error("the count must be between 1 and {max}")]
    Count { max: usize },
    #[error("shards are numbered 0 to {last} (as job arrays number their tasks)")]
    Index { last: usize },
}

/// Why the shards' folders cannot be merged.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MergeError {
    #[error("{message}: run `uvpin sweep FILE --shard I/N` for every I first")]
    NoFolder { message: String },
    #[error("cannot copy the thumbnail: {message}")]
    Thumbnail { message: String },
    #[error("no shard folders (I-of-N) in it")]
    NoShards,
    #[error("shards of different counts ({counts:?}): remove the folders of the old split")]
    MixedCounts { counts: Vec<usize> },
    #[error("{}; run those shards again (`uvpin sweep {sweep} --shard I/{count}` resumes)", short.join("; "))]
    Short {
        short: Vec<String>,
        sweep: String,
        count: usize,
    },
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl std::str::FromStr for Shard {
    type Err = SweepError;

    /// `I/N`, e.g. `0/4`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let error = |error: ShardError| SweepError::Shard {
            given: s.to_string(),
            error,
        };
        let (i, n) = s.split_once('/').ok_or_else(|| error(ShardError::Form))?;
        let number = |t: &str| {
            t.trim()
                .parse::<usize>()
                .map_err(|_| error(ShardError::NotANumber(t.to_string())))
        };
        Shard::new(number(i)?, number(n)?).map_err(error)
    }
}

/// Joins the shards' rows of the sweep in `sweep_path` into its output
/// folder: `runs.jsonl`, `runs.csv`, `summary.md`, the thumbnails and the
/// contact sheet, the same (but `time_ms`) as one machine writes.
///
/// # Errors
/// The sweep file; no shards, shards of different counts, a shard missing or
/// short of rows (named, with the command that completes it); the output.
pub fn merge(sweep_path: &Path) -> Result<SweepOutcome, SweepError> {
    let plan = SweepPlan::open(sweep_path)?;
    let shards_dir = plan.output.join("shards");
    let error = |error: MergeError| SweepError::Merge {
        path: shards_dir.clone(),
        error,
    };
    let count = shard_count(&shards_dir).map_err(error)?;
    let mut rows: HashMap<String, Row> = HashMap::new();
    let mut short: Vec<String> = Vec::new();
    for index in 0..count {
        let shard = Shard { index, count };
        let mut found = rows_done(&shard.folder(&plan.output).join("runs.jsonl"));
        let mine = plan.runs.iter().filter(|r| shard.holds(r.index));
        let missing: Vec<&str> = mine
            .filter_map(|r| match found.remove(&r.id) {
                Some(row) => {
                    rows.insert(r.id.clone(), row);
                    None
                }
                None => Some(r.id.as_str()),
            })
            .collect();
        if let Some(first) = missing.first() {
            short.push(format!(
                "shard {shard} has no row for {} run(s) (first: {first})",
                missing.len()
            ));
        }
    }
    if !short.is_empty() {
        return Err(error(MergeError::Short {
            short,
            sweep: sweep_path.display().to_string(),
            count,
        }));
    }
    let rows: Vec<Row> = plan.runs.iter().filter_map(|r| rows.remove(&r.id)).collect();
    let thumbs = plan.thumbs_in(&plan.output);
    if let Some(dir) = &thumbs {
        gather_thumbnails(&plan, &rows, count, dir)?;
    }
    let summary = write_outputs(
        &plan.output,
        &rows,
        &plan.runs,
        thumbs.as_deref(),
        plan.sweep.thumbnail_size,
    )?;
    Ok(SweepOutcome {
        rows,
        ran: 0,
        output: plan.output,
        summary,
    })
}

/// The one shard count of the folders in `shards_dir`.
fn shard_count(shards_dir: &Path) -> Result<usize, MergeError> {
    let entries = std::fs::read_dir(shards_dir).map_err(|e| MergeError::NoFolder { message: e.to_string() })?;
    let mut counts: Vec<usize> = entries
        .filter_map(Result::ok)
        .filter(|e| e.path().is_dir())
        .filter_map(|e| Shard::from_folder_name(&e.file_name().to_string_lossy()))
        .map(|s| s.count)
        .collect();
    counts.sort_unstable();
    counts.dedup();
    match counts[..] {
        [] => Err(MergeError::NoShards),
        [n] => Ok(n),
        _ => Err(MergeError::MixedCounts { counts }),
    }
}

/// Copies each row's thumbnail from its shard's folder into `dir`.
fn gather_thumbnails(plan: &SweepPlan, rows: &[Row], count: usize, dir: &Path) -> Result<(), SweepError> {
    std::fs::create_dir_all(dir).map_err(|e| SweepError::Write {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    for row in rows {
        let Some(name) = &row.thumbnail else { continue };
        let shard = Shard {
            index: row.run % count,
            count,
        };
        let from = shard.folder(&plan.output).join("thumbs").join(name);
        std::fs::copy(&from, dir.join(name)).map_err(|e| SweepError::Merge {
            path: from.clone(),
            error: MergeError::Thumbnail { message: e.to_string() },
        })?;
    }
    Ok(())
}
