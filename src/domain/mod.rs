//! The boundary as a domain: where a chart's layout lives. On the square
//! (§III.B) its outer loop is fixed by step 1; free, the outer loop and
//! holes move inside a region of the texture (its `region`), clear of every
//! other island, so the layout is one-to-one as a whole. The domain says
//! how a solve starts ([`start`]), what it admits and how it ends.

pub mod setup;
pub mod solve;
pub mod start;
pub mod unfold;

use crate::free::FreeSetup;
use std::sync::Arc;

/// Where a chart is laid out: its outer loop on the square, or free
/// inside a region of the texture, clear of the other islands.
#[derive(Debug, Clone)]
pub enum Domain {
    /// The outer loop on the unit square (§III.B).
    Square,
    /// Free inside a region, clear of other islands.
    Free(Arc<FreeSetup>),
}

impl Domain {
    pub fn free(&self) -> Option<&FreeSetup> {
        match self {
            Domain::Square => None,
            Domain::Free(f) => Some(f),
        }
    }
}
