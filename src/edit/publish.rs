//! The daemon's side of the editor: after a tick that changed a file's
//! status, [`publish_to_editor`] hands each watched file's state, the
//! inputs of its last loaded content and its last written solve to the
//! [`Hub`] the server reads.

use super::hub::{EditInputs, FileUpdate, Hub, SolvedView};
use super::text::ExistingItem;
use crate::api::SolvedChart;
use crate::constraints::ConstraintSource;
use crate::ecs::watch::{DaemonLog, WatchSettings, WatchedFile};
use crate::ecs::{BarNetFactor, BoundaryLayout, ChartData, Exported, SolveJob, Solver, Step1Layout};
use crate::report::Status;
use crate::solver::step1::{Step1, Step1Times};
use crate::watch::registry::display;
use bevy_ecs::prelude::*;
use std::sync::Arc;

/// The hub the daemon publishes to (present only when serving the editor).
#[derive(Resource, Debug, Clone)]
pub struct EditorFeed(pub Arc<Hub>);

/// The edit inputs of a file's loaded content.
fn inputs(job: &SolveJob, data: &ChartData, text_hash: Option<u64>) -> Option<Arc<EditInputs>> {
    let ConstraintSource::File(loaded) = &job.source else {
        return None;
    };
    let existing = data
        .0
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

/// The written solve of a file.
fn solved(job: &SolveJob, data: &ChartData, solver: &Solver, step1: Step1, report: &crate::Report) -> Arc<SolvedView> {
    let prepared = &data.0;
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
        uvs: crate::chart::assemble_uvs(&job.asset, prepared, solver.0.layout()),
        in_chart,
        chart: Arc::new(SolvedChart {
            prepared: (**prepared).clone(),
            step1,
            solver: solver.0.clone(),
            report: report.clone(),
        }),
        asset: job.asset.clone(),
    })
}

type FileParts<'a> = (
    &'a WatchedFile,
    Option<Ref<'a, SolveJob>>,
    Option<&'a ChartData>,
    Option<&'a Solver>,
    Option<Ref<'a, Exported>>,
    Option<Step1Parts<'a>>,
);

/// Step 1's components (the boundary on the square, the factor, the layout).
type Step1Parts<'a> = (&'a BoundaryLayout, &'a BarNetFactor, &'a Step1Layout);

fn step1_of((boundary, bar_net, layout): Step1Parts) -> Step1 {
    Step1 {
        boundary: boundary.0.clone(),
        bar_net: bar_net.0.clone(),
        layout: layout.0.clone(),
        times: Step1Times::default(),
    }
}

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
        .filter_map(|(watched, job, data, solver, exported, step1)| {
            let name = display(&watched.path, &settings.cwd);
            let status = log.status.files.get(&name)?;
            let new_inputs = match (&job, data) {
                (Some(job), Some(data)) if job.is_changed() => inputs(job, data, watched.hash),
                _ => None,
            };
            let new_solve = match (&job, data, solver, &exported, step1) {
                (Some(job), Some(data), Some(solver), Some(e), Some(step1))
                    if e.is_changed() && e.0.status != Status::Error =>
                {
                    Some(solved(job, data, solver, step1_of(step1), &e.0))
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
