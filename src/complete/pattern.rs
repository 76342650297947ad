//! A chart's Newton pattern, built once and shared: in the background while
//! the spline path runs when the polish will need it anyway, else on first
//! use. It depends only on the mesh and the free set, so the daemon keeps it
//! across constraint edits of the same geometry.

use super::newton::NewtonPattern;
use super::newton_pattern;
use crate::param::bar_net::FilledChart;
use crate::sparse::SparseError;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

type PatternResult = Result<Arc<NewtonPattern>, SparseError>;

/// A [`NewtonPattern`] being built in the background, built, or not built yet.
#[derive(Debug)]
pub struct PendingNewtonPattern {
    filled: Arc<FilledChart>,
    movable: Vec<u32>,
    /// The movable vertices in step 1's elimination order, if known.
    order: Option<Arc<Vec<u32>>>,
    state: Mutex<PatternState>,
}

#[derive(Debug)]
enum PatternState {
    NotStarted,
    Building(JoinHandle<PatternResult>),
    Built(PatternResult),
}

/// When to build a pattern.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Build {
    /// On its own thread, now (it will surely be needed).
    InBackground,
    /// On first use.
    Lazily,
}

impl PendingNewtonPattern {
    /// The pattern over `movable` (in elimination order `order` if given,
    /// see [`newton_pattern`]), built as `build` says (lazily if no thread
    /// can be started).
    pub fn new(filled: Arc<FilledChart>, movable: Vec<u32>, order: Option<Arc<Vec<u32>>>, build: Build) -> Self {
        let pending = PendingNewtonPattern {
            filled: filled.clone(),
            movable: movable.clone(),
            order: order.clone(),
            state: Mutex::new(PatternState::NotStarted),
        };
        if build == Build::InBackground && !movable.is_empty() {
            let work = move || newton_pattern(&filled, &movable, order.as_deref().map(Vec::as_slice)).map(Arc::new);
            if let Ok(handle) = std::thread::Builder::new()
                .name("uvpin-newton-pattern".into())
                .spawn(work)
            {
                *pending.state.lock().unwrap_or_else(|p| p.into_inner()) = PatternState::Building(handle);
            }
        }
        pending
    }

    /// Whether this is the pattern over exactly `movable`.
    pub fn serves(&self, movable: &[u32]) -> bool {
        self.movable == movable
    }

    /// The pattern: waits for the background build, or builds it now.
    ///
    /// # Errors
    /// The pattern faer rejected (never for a valid mesh), or the build
    /// thread panicked.
    pub fn get(&self) -> PatternResult {
        let mut state = self.state.lock().unwrap_or_else(|p| p.into_inner());
        let result = match std::mem::replace(&mut *state, PatternState::NotStarted) {
            PatternState::Built(result) => result,
            PatternState::Building(handle) => handle
                .join()
                .unwrap_or_else(|_| Err(SparseError::Pattern("the Newton pattern thread panicked".into()))),
            PatternState::NotStarted => {
                newton_pattern(&self.filled, &self.movable, self.order.as_deref().map(Vec::as_slice)).map(Arc::new)
            }
        };
        *state = PatternState::Built(result.clone());
        result
    }
}
