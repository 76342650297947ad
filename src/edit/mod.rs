//! The landmark editor (`uvpin edit`, `uvpin watch --serve`): pick vertices
//! on the mesh, place their targets on the texture, and watch the fold-free
//! map follow.
//!
//! - [`text`]: rewriting a constraint file's list as the editor asks,
//!   keeping everything else the user wrote (pure, always built).
//! - With the `editor` feature: [`hub`] (what the daemon shows the page),
//!   [`publish`] (the ECS system that fills it), [`preview`] (solves for
//!   dragged targets, newest first), [`server`] over [`http`] (a bounded
//!   HTTP/1.1 server) and the [`page`] itself.
pub mod text;

#[cfg(feature = "editor")]
pub mod http;
#[cfg(feature = "editor")]
pub mod hub;
#[cfg(feature = "editor")]
pub mod page;
#[cfg(feature = "editor")]
pub mod payload;
#[cfg(feature = "editor")]
pub mod preview;
#[cfg(feature = "editor")]
pub mod publish;
#[cfg(feature = "editor")]
pub mod server;
