//! The daemon's side of the editor: after a tick that changed a file's
//! status, [`publish_to_editor`] hands each watched file's state, the
//! inputs of its last loaded content and its last written solve to the
//! [`Hub`] the server reads.

use super::hub::{EditInputs, FileUpdate, Hub, SolvedView};
use super::text::ExistingItem;
use crate::constraints::ConstraintSource;
use crate::ecs::watch::{DaemonLog, WatchSettings, WatchedFile};
use crate::ecs::{Exported, Session, SolveJob, Solver};
use crate::report::Status;
use crate::watch::registry::display;
use bevy_ecs::prelude::*;
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
fn solved(job: &SolveJob, session: &Session, solver: &Solver, report: &crate::Report) -> Arc<SolvedView> {
    let prepared = session.0.prepared();
    let in_chart = prepared
        .welded
        .vertex_of
        .iter()
        .map(|map| {
            map.iter()
                .map(|&w| u8::from(prepared.chart.local_of(w).is_some()))
                .collect()
        })
        .collect();
    Arc::new(SolvedView {
        report: report.clone(),
        uvs: session.0.uvs(solver.0.layout()),
        in_chart,
        session: Arc::new(session.0.clone()),
        asset: job.asset.clone(),
    })
}

type FileParts<'a> = (
    &'a WatchedFile,
    Option<Ref<'a, SolveJob>>,
    Option<&'a Session>,
    Option<&'a Solver>,
    Option<Ref<'a, Exported>>,
);

/// Publishes every watched file when the status board changed this tick.
pub fn publish_to_editor(
    feed: Res<EditorFeed>,
    settings: Res<WatchSettings>,
    log: Res<DaemonLog>,
    files: Query<FileParts>,
) {
    if !log.status.dirty {
        return;
    }
    let updates = files
        .iter()
        .filter_map(|(watched, job, session, solver, exported)| {
            let name = display(&watched.path, &settings.cwd);
            let status = log.status.files.get(&name)?;
            let new_inputs = match (&job, session) {
                (Some(job), Some(session)) if job.is_changed() => inputs(job, session, watched.hash),
                _ => None,
            };
            let new_solve = match (&job, session, solver, &exported) {
                (Some(job), Some(session), Some(solver), Some(e)) if e.is_changed() && e.0.status != Status::Error => {
                    Some(solved(job, session, solver, &e.0))
                }
                _ => None,
            };
            Some(FileUpdate {
                path: watched.path.clone(),
                name,
                state: status.state,
                error: status.last_error.clone(),
                text_hash: watched.hash,
                inputs: new_inputs,
                solved: new_solve,
            })
        })
        .collect();
    feed.0.publish(updates);
}
