//! `uvpin watch`: the daemon. OS file events become a small event enum
//! ([`events`]); a registry state machine holds every rule and turns events
//! into actions ([`registry`]); the ECS adapters apply them to chart
//! entities and report each result ([`charts`]); the loop ties the watcher,
//! the registry and the schedule together ([`run`]), with the log
//! ([`log`]) and the status file ([`status`]).

pub mod assets;
pub mod charts;
pub mod events;
pub mod log;
pub mod paths;
pub mod registry;
pub mod run;
pub mod status;
