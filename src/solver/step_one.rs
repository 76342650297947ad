//! Step 1 of the paper (§III): the outer boundary onto the unit square,
//! then the force-density ("bar-net") solve for everything else (Eq. 1–2).
//! Three functions, one per stage, which the chart session runs (and keeps
//! the results of: the factor survives new corners).

use crate::chart::PreparedChart;
use crate::constraints::ConstraintSource;
use crate::error::Error;
use crate::param::bar_net::BarNet;
use crate::param::boundary::{BoundaryError, BoundaryMap, BoundaryShape, map_outer_boundary};
use glam::DVec2;
use std::path::Path;
use std::sync::Arc;

/// Step 1's results for one chart: the outer loop on the square, the
/// factored bar-net matrix `D` of Eq. 1 (kept for re-solves), and the
/// layout of the filled chart (layout coordinates, y up).
#[derive(Debug, Clone)]
pub struct StepOne {
    pub boundary: BoundaryMap,
    pub bar_net: Arc<BarNet>,
    pub layout: Vec<DVec2>,
    pub times: StepOneTimes,
}

/// Milliseconds per stage of step 1.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepOneTimes {
    pub boundary_ms: f64,
    pub factor_ms: f64,
    pub solve_ms: f64,
}

/// The outer loop onto the unit square (§III.B).
///
/// # Errors
/// Corners that are not on the outer loop, are mirrored, or trap a triangle
/// with no way out (located at the `corners` field); a chart on the square
/// whose outer loop has only 3 vertices.
pub fn map_boundary(prepared: &PreparedChart, source: &ConstraintSource) -> Result<BoundaryMap, Error> {
    let c = prepared;
    let on_square = c.domain.free().is_none();
    let boundary = map_outer_boundary(&c.chart.mesh, &c.topology, &c.traps, c.corners)
        .map_err(|e| source.corners_error(e.to_string()))?;
    match boundary.shape {
        BoundaryShape::Triangle if on_square => Err(source
            .boundary_error(BoundaryError::ThreeCorneredLoop.to_string())
            .into()),
        _ => Ok(boundary),
    }
}

/// `D = Cᵀ Q C` of Eq. 1 (force densities of Eq. 2) over the nodes off the
/// outer loop, factored once.
///
/// # Errors
/// No free vertex, or `D` singular (named with `asset` and the chart).
pub fn factor_bar_net(prepared: &PreparedChart, boundary: &BoundaryMap, asset: &Path) -> Result<BarNet, Error> {
    let filled = &prepared.filled;
    let mut fixed = vec![false; filled.mesh.n_vertices()];
    for &v in &boundary.loop_vertices {
        fixed[v as usize] = true;
    }
    BarNet::factor(filled, &fixed).map_err(|source| Error::BarNet {
        path: asset.to_path_buf(),
        chart: prepared.chart.id,
        source,
    })
}

/// Step 1 of `prepared` in a row: [`map_boundary`], [`factor_bar_net`]
/// and [`solve_force_density`].
///
/// # Errors
/// As those functions.
pub fn run(
    prepared: &PreparedChart,
    source: &ConstraintSource,
    asset: &Path,
) -> Result<(BoundaryMap, BarNet, Vec<DVec2>), Error> {
    let boundary = map_boundary(prepared, source)?;
    let net = factor_bar_net(prepared, &boundary, asset)?;
    let layout = solve_force_density(prepared, &boundary, &net);
    Ok((boundary, net, layout))
}

/// Eq. 1 solved for the free nodes with the outer loop where `boundary`
/// puts it: the step-1 layout of the filled chart.
pub fn solve_force_density(prepared: &PreparedChart, boundary: &BoundaryMap, net: &BarNet) -> Vec<DVec2> {
    let mut layout = vec![DVec2::ZERO; prepared.filled.mesh.n_vertices()];
    for (&v, &p) in boundary.loop_vertices.iter().zip(&boundary.positions) {
        layout[v as usize] = p;
    }
    net.solve(&mut layout);
    layout
}
