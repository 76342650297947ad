//! Step 2 of the paper (§IV.B): thin-plate-spline displacements (Eq. 6) moved
//! in interpolated steps toward the targets, each step guarded.

pub mod stepping;
pub mod tps;
