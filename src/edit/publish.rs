//! The daemon's side of the editor: [`EditorAttachment`] serves it beside
//! the daemon; after a tick that changed a file's status,
//! [`publish_to_editor`] hands each watched file's state, the inputs of its
//! last loaded content and its last written solve to the [`Hub`] the
//! server reads.

use super::hub::{EditInputs, FileUpdate, Hub, SolvedView};
use super::text::ExistingItem;
use crate::chart::PrimitiveUvs;
use crate::constraints::ConstraintSource;
use crate::daemon::charts::{DaemonLog, DaemonState, Settings, WatchedFile, report_results, write_status_file};
use crate::daemon::log::Logger;
use crate::daemon::paths::display;
use crate::ecs::{Exported, Finished, Session, SolveJob};
use crate::report::Status;
use bevy_ecs::prelude::*;
use serde_json::json;
use std::sync::Arc;

/// The hub the daemon publishes to (present only when serving the editor).
#[derive(Resource, Debug, Clone)]
pub struct EditorFeed(pub Arc<Hub>);

/// The edit inputs of a file's loaded content.
fn inputs(job: &SolveJob, session: &Session, text_hash: Option<u64>) -> Option<Arc<EditInputs>> {
    let ConstraintSource::File(loaded) = &job.source else {
        return None;
    };
    let existing = session
        .0
        .prepared()
        .constraints
        .iter()
        .map(|c| ExistingItem {
            index: c.index,
            primitive: c.primitive,
            vertex: c.vertex,
        })
        .collect();
    Some(Arc::new(EditInputs {
        loaded: loaded.clone(),
        asset: job.asset.clone(),
        existing,
        text_hash: text_hash?,
    }))
}

/// The written solve of a file: its report, UVs, and the session the
/// editor's drag previews start from.
fn solved(job: &SolveJob, session: &Session, finished: &Finished, exported: &Exported) -> Arc<SolvedView> {
    let uvs = session.0.uvs(finished.0.solver.layout());
    let written: PrimitiveUvs = exported.0.corners.iter().flatten().map(|u| u.corners.clone()).collect();
    Arc::new(SolvedView {
        report: exported.0.report.clone(),
        in_chart: drawn_from_vertices(&job.asset, session.0.prepared(), &uvs, &written),
        uvs,
        written,
        session: Arc::new(session.0.clone()),
        asset: job.asset.clone(),
    })
}

/// Per primitive and triangle: 1 where the page draws the triangle from its
/// vertices' UVs (a triangle of the solved chart, which moves while a
/// target is dragged), 0 where from the written corners (another chart, a
/// packed piece, a triangle beside a seam whose corners differ from its
/// vertices' UVs).
fn drawn_from_vertices(
    asset: &crate::io::SourceAsset,
    prepared: &crate::chart::PreparedChart,
    uvs: &PrimitiveUvs,
    written: &PrimitiveUvs,
) -> Vec<Vec<u8>> {
    let mut in_chart = vec![false; prepared.welded.mesh.n_triangles()];
    prepared
        .chart
        .triangle_ids
        .iter()
        .for_each(|&t| in_chart[t as usize] = true);
    let mut welded_triangle = 0;
    asset
        .primitives
        .iter()
        .enumerate()
        .map(|(p, prim)| {
            prim.indices
                .chunks_exact(3)
                .enumerate()
                .map(|(t, corners)| {
                    let chart = in_chart.get(welded_triangle).copied().unwrap_or(false);
                    welded_triangle += 1;
                    let same = written.get(p).is_none_or(|w| {
                        corners
                            .iter()
                            .enumerate()
                            .all(|(i, &v)| w.get(3 * t + i) == uvs[p].get(v as usize))
                    });
                    u8::from(chart && same)
                })
                .collect()
        })
        .collect()
}

type FileParts<'a> = (
    &'a WatchedFile,
    Option<Ref<'a, SolveJob>>,
    Option<&'a Session>,
    Option<&'a Finished>,
    Option<Ref<'a, Exported>>,
);

/// Publishes every watched file when the status board changed this tick.
pub fn publish_to_editor(
    feed: Res<EditorFeed>,
    settings: Res<Settings>,
    log: Res<DaemonLog>,
    state: Res<DaemonState>,
    files: Query<FileParts>,
) {
    if !log.status.dirty {
        return;
    }
    let updates = files
        .iter()
        .filter_map(|(watched, job, session, finished, exported)| {
            let name = display(&watched.path, &settings.0.cwd);
            let status = log.status.files.get(&name)?;
            let text_hash = state.registry.files.get(&watched.path).and_then(|r| r.hash);
            let new_inputs = match (&job, session) {
                (Some(job), Some(session)) if job.is_changed() => inputs(job, session, text_hash),
                _ => None,
            };
            let new_solve = match (&job, session, finished, &exported) {
                (Some(job), Some(session), Some(finished), Some(e))
                    if e.is_changed() && e.0.report.status != Status::Error =>
                {
                    Some(solved(job, session, finished, e))
                }
                _ => None,
            };
            Some(FileUpdate {
                path: watched.path.clone(),
                name,
                state: status.state,
                error: status.last_error.clone(),
                text_hash,
                inputs: new_inputs,
                solved: new_solve,
            })
        })
        .collect();
    feed.0.publish(updates);
}

/// The editor served beside the daemon (`uvpin edit`, `uvpin watch --serve`).
pub struct EditorAttachment {
    /// Where to serve it (`HOST:PORT`).
    pub addr: String,
    /// Open its page in a browser once it is served.
    pub open: bool,
    /// Drag previews of charts above this many vertices are solved on their
    /// coarse level.
    pub coarse_above: usize,
    server: Option<super::server::EditorServer>,
}

impl EditorAttachment {
    pub fn new(addr: String, open: bool) -> Self {
        EditorAttachment {
            addr,
            open,
            coarse_above: super::preview::COARSE_ABOVE,
            server: None,
        }
    }
}

impl crate::daemon::run::Attachment for EditorAttachment {
    /// Starts the editor's server on the address, fed by the daemon's
    /// schedule; logs its address (and opens it in a browser if asked).
    fn attach(&mut self, world: &mut World, schedule: &mut Schedule, logger: &Logger) -> anyhow::Result<()> {
        let hub = Arc::new(Hub::default());
        let input = world.resource::<Settings>().0.input.clone();
        let server = super::server::EditorServer::start(&self.addr, hub.clone(), input, self.coarse_above)?;
        world.insert_resource(EditorFeed(hub));
        schedule.add_systems(publish_to_editor.after(report_results).before(write_status_file));
        let message = format!("editor at {} (open it in a browser)", server.url);
        logger.info("serve", None, &message, json!({ "url": server.url }));
        if !server.loopback {
            let warning =
                "the editor is served beyond this machine: anyone who can reach it can change the constraint files";
            logger.warn("serve", None, warning, json!({}));
        }
        if self.open && !open_in_browser(&server.url) {
            let message = "could not open a browser: open the address above";
            logger.warn("serve", None, message, json!({}));
        }
        self.server = Some(server);
        Ok(())
    }

    fn stop(&mut self) {
        if let Some(server) = self.server.take() {
            server.stop();
        }
    }
}

/// Opens `url` with the desktop's opener; whether one started.
fn open_in_browser(url: &str) -> bool {
    ["xdg-open", "open"].iter().any(|opener| {
        std::process::Command::new(opener)
            .arg(url)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .is_ok()
    })
}
