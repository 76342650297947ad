//! Multilevel solves of large charts: a coarse mesh made by collapsing
//! edges ([`coarsen`]) is solved in full, then the collapses are undone
//! ([`prolong`]) with every triangle kept positive, and local sweeps of the
//! symmetric Dirichlet energy ([`smooth`]) settle the fine vertices. The
//! landmarks are coarse vertices, so they stay exactly on their targets.

pub mod coarsen;
pub mod outline;
pub mod prolong;
pub mod smooth;
