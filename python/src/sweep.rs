//! `uvpin._native.Sweep`: a sweep's grid, one run at a time, for engines
//! that spread runs over machines (Ray): every run goes through the same
//! `SweepRunner` as `uvpin sweep`, so the rows are the same.

use super::input_error;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use std::path::PathBuf;
use uvpin::sweep::{Row, SweepPlan, SweepRunner, rows_done, write_outputs};

/// A sweep file's grid; its inputs load once per process, on first use.
#[pyclass(frozen, module = "uvpin._native")]
pub struct Sweep {
    runner: SweepRunner,
}

fn row_json(row: &Row) -> PyResult<String> {
    serde_json::to_string(row).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

#[pymethods]
impl Sweep {
    /// Reads the sweep file and lays out its grid; solves nothing.
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        let plan = SweepPlan::open(&path).map_err(|e| input_error(e.to_string()))?;
        Ok(Sweep {
            runner: SweepRunner::new(plan),
        })
    }

    /// The output folder.
    #[getter]
    fn output(&self) -> PathBuf {
        self.runner.plan.output.clone()
    }

    /// Whether the sweep draws thumbnails.
    #[getter]
    fn thumbnails(&self) -> bool {
        self.runner.plan.sweep.thumbnails
    }

    /// Every run of the grid: (index, id), in row order.
    fn runs(&self) -> Vec<(usize, String)> {
        self.runner.plan.runs.iter().map(|r| (r.index, r.id.clone())).collect()
    }

    /// Solves run `index`; its thumbnail (if the sweep draws them) goes into
    /// `thumbs`. Returns the row as JSON.
    #[pyo3(signature = (index, thumbs=None))]
    fn run(&self, py: Python<'_>, index: usize, thumbs: Option<PathBuf>) -> PyResult<String> {
        let run = self.runner.plan.runs.get(index).ok_or_else(|| {
            input_error(format!(
                "run {index} is out of range: the grid has runs 0..{}",
                self.runner.plan.runs.len()
            ))
        })?;
        let row = py.detach(|| self.runner.solve(run, thumbs.as_deref()));
        row_json(&row)
    }

    /// The rows already in the output's `runs.jsonl` (JSON, one per run).
    fn done(&self) -> PyResult<Vec<String>> {
        let found = rows_done(&self.runner.plan.output.join("runs.jsonl"));
        self.runner
            .plan
            .runs
            .iter()
            .filter_map(|r| found.get(&r.id))
            .map(row_json)
            .collect()
    }

    /// Writes `rows` (JSON) in grid order as `runs.jsonl`, `runs.csv`,
    /// `summary.md` and the contact sheet (from the thumbnails in the
    /// output's `thumbs`); returns the summary. Rows of runs not in the
    /// grid are dropped.
    fn write(&self, py: Python<'_>, rows: Vec<String>) -> PyResult<String> {
        let plan = &self.runner.plan;
        let mut by_id = std::collections::HashMap::new();
        for (i, text) in rows.iter().enumerate() {
            let row: Row = serde_json::from_str(text).map_err(|e| input_error(format!("rows[{i}]: {e}")))?;
            by_id.insert(row.id.clone(), row);
        }
        let rows: Vec<Row> = plan.runs.iter().filter_map(|r| by_id.remove(&r.id)).collect();
        let thumbs = plan.thumbs_in(&plan.output);
        py.detach(|| {
            write_outputs(
                &plan.output,
                &rows,
                &plan.runs,
                thumbs.as_deref(),
                plan.sweep.thumbnail_size,
            )
        })
        .map_err(|e| input_error(e.to_string()))
    }
}
