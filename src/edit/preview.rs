//! Solves for dragged targets, in memory, newest first: while a marker is
//! dragged the page sends every new position; a newer request drops the
//! one waiting and stops the one running (between ticks of the chart
//! solver), so the layout follows the pointer instead of queueing behind
//! it. Solves retarget the previous one's chart session (its chart, step 1
//! and Newton pattern), start from its layout (the targets moved a little),
//! and skip the distortion polish (the daemon's solve on release polishes).
//!
//! A chart larger than `coarse_above` vertices is previewed on its coarse
//! level ([`CoarseView`]): about a thousand vertices with the landmarks among
//! them, made once per landmark set, so a move costs milliseconds whatever
//! the chart's size; the page draws that level's triangles until the
//! release is solved in full. The level is exact on the landmarks and
//! fold-free as stored, like every answer; one that fails is answered on
//! the chart itself.

use super::hub::EditInputs;
use super::text::WantedConstraint;
use crate::chart::{self, PrimitiveUvs};
use crate::constraints::{ConstraintSource, ConstraintSpec, LoadedConstraints};
use crate::options::SolverOptions;
use crate::report::Report;
use crate::session::{ChartSession, CoarseMesh, CoarseView, StartFrom};
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
    pub shown: Shown,
    /// Milliseconds from the request to the answer.
    pub ms: f64,
}

/// What a preview shows.
#[derive(Debug, Clone)]
pub enum Shown {
    /// The chart itself: its asset's UVs per primitive.
    Chart(PrimitiveUvs),
    /// The chart's coarse level: its mesh (`key` names it; the same key,
    /// the same mesh) and glTF UVs per coarse vertex.
    Coarse {
        key: u64,
        mesh: Arc<CoarseMesh>,
        uvs: Vec<[f32; 2]>,
    },
}

/// Drag previews of a chart with more vertices than this are solved on its
/// coarse level (`uvpin edit --coarse-above`).
pub const COARSE_ABOVE: usize = 6000;

/// Milliseconds a move's solve on the coarse level may take.
const LEVEL_BUDGET_MS: f64 = 50.0;

/// A coarse level has at most this many vertices (and half the chart's):
/// a move solves it in milliseconds.
const LEVEL_VERTICES: usize = 1000;

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
    /// A previewer solving charts above `coarse_above` vertices on their
    /// coarse level.
    pub fn start(coarse_above: usize) -> Previewer {
        let shared = Arc::new(Shared::default());
        let worker = {
            let shared = shared.clone();
            std::thread::Builder::new()
                .name("uvpin-preview".into())
                .spawn(move || work(&shared, coarse_above))
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

/// What the worker keeps between previews: the session of the last one,
/// with the inputs it was opened for, and the coarse level it used.
struct Held {
    inputs: Arc<EditInputs>,
    session: ChartSession,
    level: Option<Level>,
}

/// A coarse level and its mesh as the page draws it.
struct Level {
    view: CoarseView,
    mesh: Arc<CoarseMesh>,
}

fn work(shared: &Shared, coarse_above: usize) {
    let mut last: Option<Held> = None;
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
            .filter(|held| Arc::ptr_eq(&held.inputs.asset, &job.inputs.asset));
        let (session, level) = match kept {
            Some(held) => (Some(held.session), held.level),
            None => (job.seed.as_deref().cloned(), None),
        };
        let stop = || shared.newest.load(Ordering::SeqCst) != job.ticket;
        // A bug in one solve must not stop the worker (every later preview
        // would wait for it forever).
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let (mut session, mut level) = (session, level);
            let solved = solve(
                &job.inputs,
                &job.wanted,
                (&mut session, &mut level),
                coarse_above,
                &stop,
            );
            (session, level, solved)
        }))
        .unwrap_or_else(|_| (None, None, Err(PreviewError::Panicked)));
        let (session, level, solved) = outcome;
        let reply = match solved {
            Ok(Some((report, shown))) => PreviewReply::Solved(Box::new(Preview {
                report,
                shown,
                ms: job.at.elapsed().as_secs_f64() * 1e3,
            })),
            Ok(None) => PreviewReply::Superseded,
            Err(e) => PreviewReply::Invalid(e.to_string()),
        };
        last = session.map(|session| Held {
            inputs: job.inputs.clone(),
            session,
            level,
        });
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

/// Why a preview is not shown: the page's list or the solve refused, or
/// (a bug) the solve folded or panicked.
#[derive(Debug, thiserror::Error)]
enum PreviewError {
    #[error(transparent)]
    Wanted(#[from] super::text::EditError),
    #[error(transparent)]
    Solve(#[from] crate::Error),
    #[error("the solve ended with a folded layout; nothing is shown")]
    Folded,
    #[error("internal error while solving the preview")]
    Panicked,
}

/// Solves `wanted` in `session` (retargeted; opened when `None`), on its
/// coarse `level` (made anew when it no longer fits) when the chart has
/// more than `coarse_above` vertices, else from its last layout; `None`
/// when stopped.
fn solve(
    inputs: &EditInputs,
    wanted: &[WantedConstraint],
    (session, level): (&mut Option<ChartSession>, &mut Option<Level>),
    coarse_above: usize,
    stop: &dyn Fn() -> bool,
) -> Result<Option<(Report, Shown)>, PreviewError> {
    super::text::check_wanted(wanted)?;
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
            s.retarget(source, 0.0)?;
            s
        }
        None => session.insert(ChartSession::open(source, inputs.asset.clone(), 0.0)?),
    };
    let n = session.prepared().filled.mesh.n_vertices();
    if n > coarse_above
        && let Some(answer) = on_coarse_level(session, level, &options, stop)
    {
        return Ok(answer);
    }
    let Some(solved) = crate::assembly::solve_until(session, &options, StartFrom::LastLayout, stop)? else {
        return Ok(None);
    };
    let layout = solved.solver.layout();
    if !chart::written_orientation(session.prepared(), layout).is_clean() {
        // The solver never ends folded; if it ever did, nothing is shown.
        return Err(PreviewError::Folded);
    }
    Ok(Some((solved.report, Shown::Chart(session.uvs(layout)))))
}

/// The preview on `session`'s coarse level (made first if `level` does not
/// fit the chart's landmarks); `None` when there is no level or its solve
/// fails or folds as stored (the chart is then solved itself), `Some(None)`
/// when stopped.
fn on_coarse_level(
    session: &mut ChartSession,
    level: &mut Option<Level>,
    options: &SolverOptions,
    stop: &dyn Fn() -> bool,
) -> Option<Option<(Report, Shown)>> {
    if !level.as_ref().is_some_and(|l| l.view.fits(session)) {
        let vertices = (session.prepared().filled.mesh.n_vertices() / 2).min(LEVEL_VERTICES);
        *level = session.coarse_view(vertices).ok().flatten().map(|view| Level {
            mesh: Arc::new(view.mesh()),
            view,
        });
    }
    let level = level.as_mut()?;
    // A move the level cannot follow at once is shown as far as it got (the
    // next move goes on from there; the release is solved in full).
    let options = SolverOptions {
        time_budget_ms: Some(options.time_budget_ms.unwrap_or(f64::INFINITY).min(LEVEL_BUDGET_MS)),
        ..*options
    };
    let solved = match level.view.solve_until(session, &options, stop) {
        Ok(Some(solved)) => solved,
        Ok(None) => return Some(None),
        Err(_) => return None,
    };
    if !level.view.stored_clean(&solved.layout) {
        return None;
    }
    let uvs = solved.layout[..level.mesh.vertices.len()]
        .iter()
        .map(|&p| crate::guard::stored_uv(p))
        .collect();
    let shown = Shown::Coarse {
        key: level.view.key(),
        mesh: level.mesh.clone(),
        uvs,
    };
    Some(Some((solved.report, shown)))
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
        let previewer = Arc::new(Previewer::start(COARSE_ABOVE));
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

    #[test]
    fn a_chart_above_the_threshold_is_previewed_on_its_coarse_level() {
        let inputs = sample();
        let previewer = Previewer::start(0);
        let mut keys = Vec::new();
        for k in 0..3 {
            let reply = previewer.solve(inputs.clone(), None, targets(&inputs, 0.003 * k as f64));
            let PreviewReply::Solved(p) = reply else {
                panic!("{reply:?}")
            };
            let Shown::Coarse { key, mesh, uvs } = &p.shown else {
                panic!("the chart itself was shown")
            };
            assert_eq!(uvs.len(), mesh.vertices.len());
            assert!(mesh.vertices.len() < inputs.asset.primitives[0].positions.len());
            assert!(p.report.constraints.iter().all(|c| c.reached));
            for c in &p.report.constraints {
                let at = mesh
                    .vertices
                    .iter()
                    .position(|&(_, v)| v == c.vertex)
                    .expect("a coarse vertex");
                let uv = DVec2::new(uvs[at][0] as f64, uvs[at][1] as f64);
                assert!(uv.distance(c.target) < 1e-6, "{uv} {}", c.target);
            }
            keys.push(*key);
        }
        assert!(
            keys.windows(2).all(|w| w[0] == w[1]),
            "one level while only targets move"
        );
    }
}
