//! `uvpin watch`: the file watcher, the daemon loop, the log and the status
//! file. The ECS side (ingesting events, reporting results) is in
//! [`crate::ecs::watch`].

pub mod daemon;
pub mod events;
pub mod log;
pub mod registry;
pub mod status;
