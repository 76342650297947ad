//! The last check before anything is written, and the files to write: the
//! solved chart's layout is checked exactly as the outputs store it (f32
//! texture coordinates), then the asset's files with the new UV set are
//! staged, to be replaced atomically together with the report and pictures.

use crate::chart::{self, PreparedChart};
use crate::io::SourceAsset;
use crate::io::atomic::Staged;
use crate::io::gltf_file::StoredUvs;
use crate::options::Guard;
use crate::report::{Report, Status};
use glam::DVec2;
use std::path::Path;

/// Marks `report` as an error: nothing is written.
pub fn refuse(report: &mut Report, message: String) {
    report.status = Status::Error;
    report.message = Some(message);
    report.output = None;
}

/// Checks `layout` (the solved chart's, filled) as it will be stored and, if
/// it keeps every triangle positive, stages `asset` with it as `output` (if
/// given), naming the output in `report`. Otherwise `report` gets status
/// `Error` and the reason, and nothing is staged. `guard` names the guard
/// that accepted the layout, for the message about a folded one (only the
/// paper's pointwise guard lets folds through).
pub fn stage_chart(
    asset: &SourceAsset,
    prepared: &PreparedChart,
    layout: &[DVec2],
    report: &mut Report,
    output: Option<&Path>,
    guard: Guard,
) -> Staged {
    let triangles = &prepared.filled.mesh.triangles;
    let written = report.orientation;
    if !crate::guard::all_positive(layout, triangles) {
        refuse(
            report,
            format!(
                "folded: the {guard:?} guard let {} triangles flip and {} collapse; a folded layout is never written",
                written.flipped, written.zero_area
            ),
        );
        return Staged::new();
    }
    if !written.is_clean() {
        refuse(
            report,
            format!(
                "the layout is fold-free in double precision, but {} triangles would be flipped and {} zero-area once stored \
                 as f32 texture coordinates (thin parts of the chart are squeezed against the square's sides; smallest triangle \
                 area {:.1e} of the texture); nothing written",
                written.flipped,
                written.zero_area,
                crate::guard::smallest_area(layout, triangles)
            ),
        );
        return Staged::new();
    }
    if let Some(violation) = overlap(prepared, layout) {
        refuse(
            report,
            format!("the free layout is not one-to-one inside its region as stored ({violation}); nothing written"),
        );
        return Staged::new();
    }
    let Some(out) = output else {
        return Staged::new();
    };
    let uvs = StoredUvs {
        gltf: chart::assemble_uvs(asset, prepared, layout),
        obj_vt: (asset.format == crate::io::AssetFormat::Obj).then(|| chart::assemble_obj_vt(asset, prepared, layout)),
    };
    match crate::io::gltf_file::stage_asset(asset, &uvs, out) {
        Ok(staged) => {
            report.output = Some(out.display().to_string());
            staged
        }
        Err(e) => {
            refuse(report, e.to_string());
            Staged::new()
        }
    }
}

/// For a free chart: why its layout, as glTF and OBJ store it, is not
/// globally injective inside its region and clear of the other islands.
fn overlap(prepared: &PreparedChart, layout: &[DVec2]) -> Option<crate::free::room::Violation> {
    let crate::free::BoundarySetup::Free(setup) = &prepared.boundary else {
        return None;
    };
    let f = &prepared.filled;
    let room = crate::free::room::Room::new(
        setup.clone(),
        &prepared.topology,
        &f.mesh.triangles[..f.n_real_triangles],
    );
    room.admits(layout).err()
}

/// Writes `staged`; on failure `report` becomes an error (nothing replaced).
pub fn commit(staged: Staged, report: &mut Report) {
    if let Err(e) = staged.commit() {
        refuse(report, format!("cannot write: {e}; nothing was replaced"));
    }
}
