//! Solves for dragged targets, in memory, newest first: while a marker is
//! dragged the page sends every new position; a newer request drops the
//! one waiting and stops the one running (between ticks of the chart
//! solver), so the layout follows the pointer instead of queueing behind
//! it. Solves retarget the previous one's chart session (its chart, step 1
//! and Newton pattern), start from its layout (the targets moved a little),
//! and skip the distortion polish (the daemon's solve on release polishes).

use super::hub::EditInputs;
use super::text::WantedConstraint;
use crate::chart::{self, PrimitiveUvs};
use crate::constraints::{ConstraintSource, ConstraintSpec, LoadedConstraints};
use crate::options::SolverOptions;
use crate::report::Report;
use crate::session::{ChartSession, Solution, StartFrom};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

/// The answer to one preview request.
#[derive(Debug, Clone)]
pub enum PreviewReply {
    Solved(Box<Preview>),
    /// A newer request took its place.
    Superseded,
    /// The targets cannot be solved (an error in words: two targets on one
    /// point, a target outside the region, …).
    Invalid(String),
}

/// A solved preview: never folded (the solver's guarantee, checked again).
#[derive(Debug, Clone)]
pub struct Preview {
    pub report: Report,
    pub uvs: PrimitiveUvs,
    /// Milliseconds from the request to the answer.
    pub ms: f64,
}

struct Job {
    ticket: u64,
    inputs: Arc<EditInputs>,
    seed: Option<Arc<ChartSession>>,
    wanted: Vec<WantedConstraint>,
    reply: crossbeam_channel::Sender<PreviewReply>,
    at: Instant,
}

#[derive(Default)]
struct Shared {
    waiting: Mutex<Option<Job>>,
    ready: Condvar,
    /// The newest ticket handed out.
    newest: AtomicU64,
    closed: std::sync::atomic::AtomicBool,
}

/// The preview solver: one worker thread.
pub struct Previewer {
    shared: Arc<Shared>,
    worker: Option<std::thread::JoinHandle<()>>,
}

impl Previewer {
    pub fn start() -> Previewer {
        let shared = Arc::new(Shared::default());
        let worker = {
            let shared = shared.clone();
            std::thread::Builder::new()
                .name("uvpin-preview".into())
                .spawn(move || work(&shared))
                .expect("a thread")
        };
        Previewer {
            shared,
            worker: Some(worker),
        }
    }

    /// Solves `wanted` against `inputs`, starting from `seed` (the daemon's
    /// solve of the file) unless a preview of the same asset came since;
    /// blocks until solved or superseded.
    pub fn solve(
        &self,
        inputs: Arc<EditInputs>,
        seed: Option<Arc<ChartSession>>,
        wanted: Vec<WantedConstraint>,
    ) -> PreviewReply {
        let (reply, answer) = crossbeam_channel::bounded(1);
        let ticket = self.shared.newest.fetch_add(1, Ordering::SeqCst) + 1;
        let job = Job {
            ticket,
            inputs,
            seed,
            wanted,
            reply,
            at: Instant::now(),
        };
        let dropped = self
            .shared
            .waiting
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .replace(job);
        if let Some(old) = dropped {
            let _ = old.reply.send(PreviewReply::Superseded);
        }
        self.shared.ready.notify_one();
        answer.recv().unwrap_or(PreviewReply::Superseded)
    }
}

impl Drop for Previewer {
    fn drop(&mut self) {
        self.shared.closed.store(true, Ordering::SeqCst);
        self.shared.newest.fetch_add(1, Ordering::SeqCst);
        self.shared.ready.notify_all();
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
    }
}

fn work(shared: &Shared) {
    // The session of the last preview, with the inputs it was opened for.
    let mut last: Option<(Arc<EditInputs>, ChartSession)> = None;
    loop {
        let job = {
            let mut waiting = shared.waiting.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            loop {
                if shared.closed.load(Ordering::SeqCst) {
                    return;
                }
                if let Some(job) = waiting.take() {
                    break job;
                }
                waiting = shared
                    .ready
                    .wait(waiting)
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
            }
        };
        let kept = last
            .take()
            .filter(|(inputs, _)| Arc::ptr_eq(&inputs.asset, &job.inputs.asset));
        let session = kept.map(|(_, s)| s).or_else(|| job.seed.as_deref().cloned());
        let stop = || shared.newest.load(Ordering::SeqCst) != job.ticket;
        // A bug in one solve must not stop the worker (every later preview
        // would wait for it forever).
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut session = session;
            let solved = solve(&job.inputs, &job.wanted, &mut session, &stop);
            (session, solved)
        }))
        .unwrap_or_else(|_| (None, Err("internal error while solving the preview".into())));
        let (session, solved) = outcome;
        let reply = match (&session, solved) {
            (Some(session), Ok(Some(solved))) => answer(&job, session, &solved),
            (_, Ok(_)) => PreviewReply::Superseded,
            (_, Err(message)) => PreviewReply::Invalid(message),
        };
        last = session.map(|s| (job.inputs.clone(), s));
        let _ = job.reply.send(reply);
    }
}

/// The constraint file with its constraints replaced by `wanted`.
fn with_targets(loaded: &LoadedConstraints, wanted: &[WantedConstraint]) -> LoadedConstraints {
    let mut out = loaded.clone();
    out.file.constraints = wanted
        .iter()
        .map(|w| ConstraintSpec {
            vertex: Some(w.vertex),
            uv: Some(w.uv),
            label: w.label.clone(),
            primitive: w.primitive,
            ..ConstraintSpec::default()
        })
        .collect();
    out.file.image_size = None;
    out.item_positions = vec![(1, 1); wanted.len()];
    out
}

/// Solves `wanted` in `session` (retargeted; opened when `None`), from
/// its last layout; `None` when stopped.
fn solve(
    inputs: &EditInputs,
    wanted: &[WantedConstraint],
    session: &mut Option<ChartSession>,
    stop: &dyn Fn() -> bool,
) -> Result<Option<Solution>, String> {
    super::text::check_wanted(wanted).map_err(|e| e.to_string())?;
    let loaded = with_targets(&inputs.loaded, wanted);
    // While a target is dragged the layout is shown without the distortion
    // polish (a Newton solve per step, most of a small chart's time); the
    // daemon's solve after the release polishes it.
    let options = SolverOptions {
        polish: false,
        ..loaded.solver
    };
    let source = ConstraintSource::File(Arc::new(loaded));
    let session = match session {
        Some(s) => {
            s.retarget(source, 0.0).map_err(|e| e.to_string())?;
            s
        }
        None => session.insert(ChartSession::open(source, inputs.asset.clone(), 0.0).map_err(|e| e.to_string())?),
    };
    session
        .solve_until(&options, StartFrom::LastLayout, stop)
        .map_err(|e| e.to_string())
}

fn answer(job: &Job, session: &ChartSession, solved: &Solution) -> PreviewReply {
    let layout = solved.solver.layout();
    let stored_clean = chart::written_orientation(session.prepared(), layout).is_clean();
    if !stored_clean {
        // The solver never ends folded; if it ever did, nothing is shown.
        return PreviewReply::Invalid("the solve ended with a folded layout; nothing is shown".into());
    }
    PreviewReply::Solved(Box::new(Preview {
        report: solved.report.clone(),
        uvs: session.uvs(layout),
        ms: job.at.elapsed().as_secs_f64() * 1e3,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::text::ExistingItem;
    use glam::DVec2;

    fn sample() -> Arc<EditInputs> {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
        let (loaded, asset) = crate::load(
            &dir.join("face.uvpin.ron"),
            &SolverOptions::DEFAULT,
            &Default::default(),
        )
        .unwrap();
        Arc::new(EditInputs {
            existing: Vec::<ExistingItem>::new(),
            loaded: Arc::new(loaded),
            asset: Arc::new(asset),
            text_hash: 0,
        })
    }

    fn targets(inputs: &EditInputs, shift: f64) -> Vec<WantedConstraint> {
        inputs
            .loaded
            .file
            .constraints
            .iter()
            .map(|c| WantedConstraint {
                primitive: None,
                vertex: c.vertex.unwrap(),
                uv: c.uv.unwrap() + DVec2::new(shift, 0.0),
                label: c.label.clone(),
            })
            .collect()
    }

    #[test]
    fn the_newest_request_wins_and_answers_are_fold_free() {
        let inputs = sample();
        let previewer = Arc::new(Previewer::start());
        let threads: Vec<_> = (0..6)
            .map(|k| {
                let (p, i) = (previewer.clone(), inputs.clone());
                let wanted = targets(&inputs, 0.002 * k as f64);
                std::thread::spawn(move || p.solve(i, None, wanted))
            })
            .collect();
        let replies: Vec<PreviewReply> = threads.into_iter().map(|t| t.join().unwrap()).collect();
        let solved: Vec<&Preview> = replies
            .iter()
            .filter_map(|r| match r {
                PreviewReply::Solved(p) => Some(&**p),
                _ => None,
            })
            .collect();
        assert!(!solved.is_empty(), "{replies:?}");
        for p in solved {
            assert!(p.report.orientation.is_clean());
            assert_eq!(p.report.status, crate::Status::Reached);
        }
        // Alone, a request is solved (reusing the last chart and step 1).
        let again = previewer.solve(inputs.clone(), None, targets(&inputs, 0.01));
        let PreviewReply::Solved(p) = again else {
            panic!("{again:?}")
        };
        assert!(p.report.constraints.iter().all(|c| c.reached));
        let bad = previewer.solve(inputs.clone(), None, targets(&inputs, 2.0));
        assert!(matches!(bad, PreviewReply::Invalid(m) if m.contains("outside")));
    }
}
