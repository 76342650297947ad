//! # uvpin — constrained, fold-free texture mapping
//!
//! Gives a 3D mesh texture coordinates so that chosen vertices land exactly on
//! chosen texture positions, and no triangle ever flips. It starts from the
//! paper *Constrained Texture Mapping and Foldover-free Condition*
//! (`../shared/paper/`); `../shared/design/algorithm.md` has the measured
//! facts behind each departure from it.
//!
//! | paper | what | where |
//! |---|---|---|
//! | §III.B | outer boundary loop → unit square, corners, arc length | [`param::boundary::map_outer_boundary`] |
//! | Eq. 2 | force densities `q = 1 − len/max_len + ε` | [`param::bar_net::force_densities`] |
//! | Eq. 1 | bar-net equilibrium `D x = −D_f x_f` (holes fan-filled) | [`param::bar_net::BarNet`] |
//! | Eq. 3 | foldover-free condition `det ∇U > 0`, checked exactly per triangle | [`guard`] |
//! | Eq. 5/7 | the paper's pointwise guard `det(I + t ∇ΔX) > 0` at constraint points (comparison only) | [`rbf::stepping::FullStep::paper_guard_accepts`] |
//! | Eq. 6 | thin-plate-spline displacement | [`rbf::tps::ThinPlateSpline`] |
//! | §IV.B loop | interpolated stepping with step halving | [`rbf::stepping`] |
//! | §V.B | Sander L2 / L∞ stretch | [`metrics::sander_stretch`] |
//!
//! The core modules are plain functions over plain data. The ECS layer
//! ([`ecs`]) holds charts as `bevy_ecs` entities and runs one core function per
//! system; [`solve::solve_file`] runs that schedule to convergence, the
//! daemon ([`watch`]) runs it forever, and [`sweep`] runs many solves in
//! parallel. [`preview`] draws the layout and a checker render.

pub mod chart;
pub mod cli;
pub mod complete;
pub mod config;
pub mod constraints;
pub mod ecs;
pub mod error;
pub mod guard;
pub mod io;
pub mod mesh;
pub mod metrics;
pub mod options;
pub mod param;
pub mod preview;
pub mod rbf;
pub mod report;
pub mod ron_file;
pub mod solve;
pub mod sparse;
pub mod sweep;
#[doc(hidden)]
pub mod testing;
pub mod watch;

pub use error::{Error, Result};
pub use report::{Report, Status};
pub use solve::{solve_file, solve_mesh, unreachable_proof};
