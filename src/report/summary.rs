//! What a report is built from.

use super::StageTimes;
use crate::chart::PreparedChart;
use crate::param::boundary::BoundaryMap;
use crate::solver::ChartSolver;
use glam::DVec2;

/// Everything [`super::build`] needs about a finished solve.
pub struct SolveSummary<'a> {
    /// How the report names the constraints' source (a path or `<memory>`).
    pub constraint_file: String,
    /// The asset solved.
    pub asset: &'a crate::io::SourceAsset,
    /// The chart solved.
    pub prepared: &'a PreparedChart,
    /// The outer loop on the square (§III.B).
    pub boundary: &'a BoundaryMap,
    /// The step-1 layout of the filled chart.
    pub step1: &'a [DVec2],
    /// The finished solver: its final layout and record.
    pub solver: &'a ChartSolver,
    /// Every stage's time so far (the solver's own included).
    pub times: StageTimes,
}
