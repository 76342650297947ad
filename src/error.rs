//! The crate's top-level error: a caller mistake in an input file, named with
//! the file and the place; or an internal failure, kept apart.

use crate::constraints::ConstraintFileError;
use crate::io::AssetError;
use crate::mesh::topology::TopologyError;
use crate::param::bar_net::BarNetError;
use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum Error {
    #[error(transparent)]
    Constraints(#[from] ConstraintFileError),
    #[error(transparent)]
    Pins(#[from] crate::pins::PinError),
    #[error(transparent)]
    Asset(#[from] AssetError),
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    #[error("{path}: mesh {mesh}, chart {chart} ({n_vertices} vertices, {n_triangles} triangles): {source}")]
    Topology {
        path: PathBuf,
        mesh: usize,
        chart: u32,
        n_vertices: usize,
        n_triangles: usize,
        source: TopologyError,
    },
    #[error("{path}: force-density solve of chart {chart}: {source}")]
    BarNet {
        path: PathBuf,
        chart: u32,
        source: BarNetError,
    },
    #[error(
        "chart {chart} does not fit in its region (u {:.4}..{:.4}, v {:.4}..{:.4}) across a tenth of it or more: the targets ask for a chart far larger than it, or other islands fill it; give a larger `region`, or `boundary: Square`",
        region.min.x, region.max.x, region.min.y, region.max.y
    )]
    NoRoom {
        chart: u32,
        region: crate::param::region::Region,
    },
    /// A bug: a layout that would have been written failed the final check.
    #[error("internal error, nothing written: {0}")]
    Internal(String),
}

impl From<crate::constraints::ConstraintError> for Error {
    fn from(e: crate::constraints::ConstraintError) -> Self {
        match e {
            crate::constraints::ConstraintError::File(e) => Error::Constraints(e),
            crate::constraints::ConstraintError::Pins(e) => Error::Pins(e),
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
