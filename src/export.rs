//! The last check before anything is written, and the write: the solved
//! chart's layout is checked exactly as the output stores it (f32 texture
//! coordinates), then the asset is written atomically with the new UV set.

use crate::chart::{self, PreparedChart};
use crate::io::SourceAsset;
use crate::options::Guard;
use crate::report::{Report, Status};
use glam::DVec2;
use std::path::Path;

/// Checks `layout` (the solved chart's, filled) as it will be stored and, if
/// it keeps every triangle positive, writes `asset` with it to `output` (if
/// given). Returns `report` with the output named, or with status `Error`
/// and the reason when nothing was written. `guard` names the guard that
/// accepted the layout, for the message about a folded one (only the
/// paper's pointwise guard lets folds through).
pub fn export_chart(
    asset: &SourceAsset,
    prepared: &PreparedChart,
    layout: &[DVec2],
    mut report: Report,
    output: Option<&Path>,
    guard: Guard,
) -> Report {
    let triangles = &prepared.filled.mesh.triangles;
    let written = report.orientation;
    if !crate::guard::all_positive(layout, triangles) {
        report.status = Status::Error;
        report.message = Some(format!(
            "folded: the {guard:?} guard let {} triangles flip and {} collapse; a folded layout is never written",
            written.flipped, written.zero_area
        ));
    } else if !written.is_clean() {
        report.status = Status::Error;
        report.message = Some(format!(
            "the layout is fold-free in double precision, but {} triangles would be flipped and {} zero-area once stored \
             as f32 texture coordinates (thin parts of the chart are squeezed against the square's sides; smallest triangle \
             area {:.1e} of the texture); nothing written",
            written.flipped,
            written.zero_area,
            crate::guard::smallest_area(layout, triangles)
        ));
    } else if let Some(out) = output {
        let uvs = chart::assemble_uvs(asset, prepared, layout);
        match crate::io::gltf_file::write_asset(asset, &uvs, out) {
            Ok(()) => report.output = Some(out.display().to_string()),
            Err(e) => {
                report.status = Status::Error;
                report.message = Some(e.to_string());
            }
        }
    }
    report
}
