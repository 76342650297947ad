//! The crate's top-level error: a caller mistake in an input file, named with
//! the file and the place; or an internal failure, kept apart.

#![warn(missing_docs)]

use crate::constraints::ConstraintFileError;
use crate::cut::prepare::SolvableError;
use crate::io::AssetError;
use crate::param::bar_net::BarNetError;
use std::path::PathBuf;
use thiserror::Error;

/// Why a solve could not start or finish: every caller mistake names its
/// file and place; [`Error::Internal`] is a bug.
#[derive(Debug, Error)]
pub enum Error {
    /// A constraint file's mistake, with its line and column.
    #[error(transparent)]
    Constraints(#[from] ConstraintFileError),
    /// In-memory pins' mistake, with the constraint's index.
    #[error(transparent)]
    Pins(#[from] crate::pins::PinError),
    /// An asset that cannot be read, selected or written.
    #[error(transparent)]
    Asset(#[from] AssetError),
    /// A configuration file's mistake.
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    /// The solved chart cannot be made a disk (given seams that do not open
    /// it, a form that leaves no part holding every landmark).
    #[error("{path}: mesh {mesh}, chart {chart} ({n_vertices} vertices, {n_triangles} triangles): {source}")]
    Topology {
        /// The asset.
        path: PathBuf,
        /// The mesh's index in the asset.
        mesh: usize,
        /// The chart's id (connected piece after welding).
        chart: u32,
        /// The chart's vertex count.
        n_vertices: usize,
        /// The chart's triangle count.
        n_triangles: usize,
        /// What is wrong, with the offending edge, vertex or triangles.
        source: SolvableError,
    },
    /// The force-density system of Eq. 1 cannot be factored.
    #[error("{path}: force-density solve of chart {chart}: {source}")]
    BarNet {
        /// The asset.
        path: PathBuf,
        /// The chart's id.
        chart: u32,
        /// Why it failed.
        source: BarNetError,
    },
    /// A free chart fits nowhere in its region.
    #[error(
        "chart {chart} does not fit in its region (u {:.4}..{:.4}, v {:.4}..{:.4}) across a tenth of it or more: the targets ask for a chart far larger than it, or other islands fill it; give a larger `region`, or `boundary: Square`",
        region.min.x, region.max.x, region.min.y, region.max.y
    )]
    NoRoom {
        /// The chart's id.
        chart: u32,
        /// Its region of the texture.
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

/// A result with uvpin's [`enum@Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
