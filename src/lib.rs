//! # uvpin — constrained, fold-free texture mapping
//!
//! Gives a 3D mesh texture coordinates so that chosen vertices land exactly on
//! chosen texture positions, and no triangle ever flips. It starts from the
//! paper *Constrained Texture Mapping and Foldover-free Condition*;
//! `docs/algorithm.md` in the repository has the facts the code relies on,
//! and where and why it departs from the paper.
//!
//! | paper | what | where |
//! |---|---|---|
//! | §III.B | outer boundary loop → unit square, corners, arc length | [`param::boundary::map_outer_boundary`] |
//! | Eq. 2 | force densities `q = 1 − len/max_len + ε` | [`param::bar_net::force_densities`] |
//! | Eq. 1 | bar-net equilibrium `D x = −D_f x_f` (holes fan-filled) | [`param::bar_net::BarNet`], [`solver::step_one`] |
//! | Eq. 3 | foldover-free condition `det ∇U > 0`, checked exactly per triangle | [`guard`] |
//! | Eq. 5/7 | the paper's pointwise guard `det(I + t ∇ΔX) > 0` at constraint points (comparison only) | [`rbf::stepping::FullStep::paper_guard_accepts`] |
//! | Eq. 6 | thin-plate-spline displacement | [`rbf::tps::ThinPlateSpline`] |
//! | §IV.B loop | interpolated stepping with step halving | [`rbf::stepping`], [`solver::ChartSolver`] |
//! | §V.B | Sander L2 / L∞ stretch | [`metrics::sander_stretch`] |
//!
//! The core modules are plain functions over plain data; the chart solver
//! ([`solver::ChartSolver`]) sequences step 1, the spline path, the
//! completion ([`complete`]) and the polish, each rule once
//! ([`solver::policy`]). The library API ([`solve_file`], [`solve_mesh`],
//! [`step_one`], [`unreachable_proof`]) runs it directly. The ECS layer
//! ([`ecs`]) holds charts as `bevy_ecs` entities and runs one core function
//! per system, tick by tick, for the daemon.
//!
//! `missing_docs` holds for the library's facade (`api`, `session`, `pins`,
//! `report`, `error`, `options`, `export`); the internal layers are public
//! for the tests and benches and documented per module.
//!
//! Cargo features: `cli` (default) gives the command line, the daemon
//! (`daemon`), the landmark editor's server (`editor`), sweeps and the
//! pictures (`pictures`); without default features the crate is the
//! library and its ECS pipeline (with [`inspect`] and the constraint-file
//! edits of [`edit::text`]).

pub mod api;
pub mod assembly;
pub mod atlas;
pub mod chart;
pub mod check;
#[cfg(feature = "cli")]
pub mod cli;
pub mod complete;
pub mod config;
pub mod constraints;
pub mod cut;
#[cfg(feature = "daemon")]
pub mod daemon;
pub mod domain;
pub mod ecs;
pub mod edit;
pub mod error;
pub mod export;
pub mod free;
pub mod guard;
pub mod injective;
pub mod inspect;
pub mod io;
pub mod mesh;
pub mod metrics;
pub mod multilevel;
pub mod options;
pub mod pack;
pub mod param;
pub mod pins;
pub mod plan;
#[cfg(feature = "pictures")]
pub mod preview;
pub mod rbf;
pub mod report;
pub mod ron_file;
pub mod session;
mod simd;
pub mod solver;
pub mod sparse;
#[cfg(feature = "sweep")]
pub mod sweep;
#[doc(hidden)]
pub mod testing;

/// The README's Rust example, compiled and run as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeExample;

pub use api::{
    MeshSolution, MeshStepOne, Options, ProgressSink, load, solve_file, solve_loaded, solve_mesh, step_one,
    unreachable_proof,
};
pub use error::{Error, Result};
pub use pins::Pins;
pub use report::{Report, Status};
pub use solver::{Progress, Stage};
