//! The last check before anything is written, and the files to write: the
//! solved chart's layout is checked exactly as the outputs store it (f32
//! texture coordinates), then the asset's files with the new UV set are
//! staged, to be replaced atomically together with the report and pictures.

#![warn(missing_docs)]

use crate::chart::{self, PreparedChart};
use crate::io::SourceAsset;
use crate::io::atomic::{Staged, Writing};
use crate::io::gltf_file::StoredUvs;
use crate::options::Guard;
use crate::report::{Report, Status};
use glam::DVec2;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a finished solve writes, all in one commit: the asset with its new
/// UV set, the JSON report and the pictures, each only when named.
#[derive(Debug, Clone, Default)]
pub struct Outputs {
    /// The asset with the new UVs (`None`: not written).
    pub model: Option<PathBuf>,
    /// The JSON report (`None`: not written).
    pub report: Option<PathBuf>,
    /// The pictures to draw (none by default); without a `background`
    /// they are drawn over the constraint file's `image:`.
    #[cfg(feature = "pictures")]
    pub pictures: crate::preview::Pictures,
    /// Where the files may be written, and whether folders may be made.
    pub writing: Writing,
    /// What is written when the layout is refused.
    pub on_error: OnError,
}

/// What [`export`] writes when the layout is refused or the model cannot
/// be written.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum OnError {
    /// Nothing: every named output (report, pictures) stays as it was, as the
    /// command line promises for exit code 1.
    #[default]
    WriteNothing,
    /// The pictures, which show what failed (a sweep's thumbnails of the
    /// paper guard's folds, the daemon's pictures of a refused layout).
    DrawPictures,
}

/// The finished layout of a chart, and what to say about it.
#[derive(Debug, Clone, Copy)]
pub struct Finished<'a> {
    /// The asset the chart is from.
    pub asset: &'a SourceAsset,
    /// The chart.
    pub prepared: &'a PreparedChart,
    /// The outer loop (chart-local ids), drawn on the layout picture.
    pub outer_loop: &'a [u32],
    /// The final layout of the filled chart (layout coordinates).
    pub layout: &'a [DVec2],
    /// The guard that accepted it (named when a folded layout is refused).
    pub guard: Guard,
    /// The other charts that need UVs, laid out on their own, to be packed
    /// around this one (none in an atlas that keeps its other charts).
    pub rest: Option<&'a crate::atlas::Rest>,
    /// The other charts holding constraints, solved after this one, each
    /// clear of those before it.
    pub secondary: &'a [Secondary],
}

/// A chart with constraints of its own, solved after the main one.
#[derive(Debug, Clone)]
pub struct Secondary {
    /// The chart.
    pub prepared: PreparedChart,
    /// Its final layout (filled chart).
    pub layout: Vec<DVec2>,
}

/// What [`export`] gives: the final report, and the UVs per face corner of
/// every primitive as written (`None` when the layout was refused).
#[derive(Debug, Clone)]
pub struct Written {
    /// The final report (status `Error` when refused or not written).
    pub report: Report,
    /// The UVs as a file stores them (glTF convention).
    pub corners: Option<Vec<crate::io::corners::CornerUvs>>,
}

/// Checks the layout as stored, then writes every output `outputs` names
/// in one commit (all or none): the final report and the UVs as written. A
/// refused layout writes nothing (or only the pictures, as
/// `outputs.on_error` says).
pub fn export(finished: &Finished, report: &Report, outputs: &Outputs) -> Written {
    let t0 = Instant::now();
    let mut report = report.clone();
    let stored = stored(finished, &mut report);
    let mut staged = stage_chart(finished, stored.as_ref(), &mut report, outputs.model.as_deref());
    staged = staged.writing(outputs.writing.clone());
    report.times.export_ms += t0.elapsed().as_secs_f64() * 1e3;
    report.total_ms = report.times.total_ms();
    let corners = stored.map(|s| s.gltf);
    let refused = report.status == Status::Error;
    if refused && outputs.on_error == OnError::WriteNothing {
        return Written { report, corners };
    }
    #[cfg(feature = "pictures")]
    {
        let pictures = &outputs.pictures;
        let (asset, prepared, layout) = (finished.asset, finished.prepared, finished.layout);
        let written = corners.as_deref().map_or_else(Vec::new, triangles_of);
        match crate::preview::render_chart(
            asset,
            prepared,
            finished.outer_loop,
            layout,
            &report,
            pictures,
            &written,
        ) {
            Ok(pictures) => pictures.into_iter().for_each(|(path, png)| staged.add(path, png)),
            Err(e) => report.warnings.push(format!("preview: {e}")),
        }
    }
    if let Some(path) = outputs.report.as_ref().filter(|_| !refused) {
        let json = serde_json::to_string_pretty(&report).expect("the report serialises");
        staged.add(path.clone(), format!("{json}\n").into_bytes());
    }
    commit(staged, &mut report);
    Written { report, corners }
}

/// Marks `report` as an error: nothing is written.
pub fn refuse(report: &mut Report, message: String) {
    report.status = Status::Error;
    report.message = Some(message);
    report.output = None;
}

/// The UVs as the outputs store them: the finished layout (the solved
/// chart's, filled) checked as stored and, if it keeps every triangle
/// positive, the other charts that need UVs packed around it. Otherwise
/// `None`, and `report` gets status `Error` and the reason. The guard that
/// accepted the layout is named in the message about a folded one (only the
/// paper's pointwise guard lets folds through).
fn stored(finished: &Finished, report: &mut Report) -> Option<StoredUvs> {
    let placed = checked(finished, report)?;
    let (asset, prepared) = (finished.asset, finished.prepared);
    let parts = every_part(finished, &placed);
    // The last word before anything is written: every part of the new UV
    // set (the landmarks' chart, the others holding landmarks, the packed
    // rest) one-to-one with every other, as stored.
    if let Some(overlap) = chart::overlap_of(&parts) {
        refuse(
            report,
            format!("internal error: the new UV set is not one-to-one ({overlap}); nothing written"),
        );
        return None;
    }
    let uvs = StoredUvs {
        gltf: chart::assemble_corner_uvs(asset, &prepared.welded, &parts),
        obj_vt: (asset.format == crate::io::AssetFormat::Obj)
            .then(|| chart::assemble_obj_corners(asset, &prepared.welded, &parts)),
    };
    every_copy_on_target(asset, &prepared.welded, &uvs.gltf, report);
    Some(uvs)
}

/// The asset with `uvs` staged as `output` (if both are given), naming the
/// output in `report`; nothing staged when the layout was refused or the
/// asset cannot be written (then `report` says why).
fn stage_chart(finished: &Finished, uvs: Option<&StoredUvs>, report: &mut Report, output: Option<&Path>) -> Staged {
    let (Some(uvs), Some(out)) = (uvs, output) else {
        return Staged::new();
    };
    match crate::io::gltf_file::stage_asset(finished.asset, uvs, out) {
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

/// The final texture coordinates per face corner of every primitive, as a
/// file stores them (glTF convention), after the checks of [`export`];
/// `None` (and `report` an error) when they refuse the layout.
pub fn final_uvs(finished: &Finished, report: &mut Report) -> Option<Vec<crate::io::corners::CornerUvs>> {
    stored(finished, report).map(|s| s.gltf)
}

/// Every triangle of the UV set as it is written (texture coordinates),
/// for the layout picture.
#[cfg(feature = "pictures")]
fn triangles_of(corners: &[crate::io::corners::CornerUvs]) -> Vec<[DVec2; 3]> {
    let uv = |c: [f32; 2]| DVec2::new(f64::from(c[0]), f64::from(c[1]));
    corners
        .iter()
        .flat_map(|u| u.corners.chunks_exact(3).map(move |t| [uv(t[0]), uv(t[1]), uv(t[2])]))
        .collect()
}

/// Every laid-out part: the solved chart, the rest placed around it, and
/// the other charts and pieces holding landmarks.
fn every_part<'a>(finished: &Finished<'a>, placed: &'a crate::atlas::PlacedRest) -> Vec<chart::Part<'a>> {
    let mut parts = placed.parts(finished.prepared, finished.layout);
    parts.extend(finished.secondary.iter().map(|s| s.prepared.part(&s.layout)));
    parts
}

/// How far (texture units) a stored copy of a reached landmark may lie
/// from its target: f32 storage, never a seam's other side.
const COPY_TOLERANCE: f64 = 1e-5;

/// Checks every face corner that names a constrained vertex (every copy
/// of it, on every side of a seam and in every chart) as written: a
/// constraint counts as reached only if all of them are on its target.
/// One that is not is marked unreached, with the farthest copy, and a
/// reached report becomes partial.
fn every_copy_on_target(
    asset: &SourceAsset,
    welded: &crate::mesh::weld::WeldedMesh,
    uvs: &[crate::io::corners::CornerUvs],
    report: &mut Report,
) {
    // Reached ones, and set-aside ones whose place is not known yet.
    let measured = |c: &&crate::report::ConstraintReport| c.reached || !c.residual.is_finite();
    // Per constrained vertex: its farthest copy's distance and place.
    let mut farthest: std::collections::HashMap<u32, (f64, DVec2, DVec2)> = report
        .every_constraint()
        .filter(measured)
        .map(|c| (c.welded, (0.0, c.target, DVec2::NAN)))
        .collect();
    for (p, (prim, corners)) in asset.primitives.iter().zip(uvs).enumerate() {
        for (&v, uv) in prim.indices.iter().zip(&corners.corners) {
            if let Some((far, target, place)) = farthest.get_mut(&welded.vertex_of[p][v as usize]) {
                let at = DVec2::new(f64::from(uv[0]), f64::from(uv[1]));
                let d = if at.is_finite() {
                    at.distance(*target)
                } else {
                    f64::INFINITY
                };
                if d > *far || place.is_nan() {
                    (*far, *place) = (d, at);
                }
            }
        }
    }
    let mut missed = Vec::new();
    let mut set_aside = false;
    let lists = std::iter::once(&mut report.constraints).chain(report.charts.iter_mut().map(|r| &mut r.constraints));
    for list in lists {
        // A set-aside constraint is where its farthest copy was written.
        for c in list.iter_mut().filter(|c| !c.reached && !c.residual.is_finite()) {
            (c.residual, _, c.result) = farthest[&c.welded];
            set_aside = true;
        }
        for c in list.iter_mut().filter(|c| c.reached) {
            let (far, _, _) = farthest[&c.welded];
            if far > COPY_TOLERANCE {
                (c.reached, c.residual) = (false, far);
                missed.push((c.index, far));
            }
        }
    }
    if set_aside && report.max_residual.is_infinite() {
        report.max_residual = report.every_constraint().map(|c| c.residual).fold(0.0, f64::max);
    }
    if let Some(&(index, far)) = missed.first() {
        report.max_residual = report.max_residual.max(far);
        if report.status == Status::Reached {
            report.status = Status::Partial;
            report.message = Some(format!(
                "{} constraint(s) have a copy off their target as written (constraints[{index}]: {far:.3e} away): a seam or a separation runs through the vertex",
                missed.len()
            ));
        }
    }
}

/// The layout checked as stored, and the other charts packed around it;
/// `None` (the report refused) when a check fails.
fn checked(finished: &Finished, report: &mut Report) -> Option<crate::atlas::PlacedRest> {
    let (prepared, layout, guard) = (finished.prepared, finished.layout, finished.guard);
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
        return None;
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
        return None;
    }
    if let Some(violation) = overlap(prepared, layout) {
        refuse(
            report,
            format!("the free layout is not one-to-one inside its region as stored ({violation}); nothing written"),
        );
        return None;
    }
    place_rest(finished, report)
        .map_err(|e| refuse(report, e.to_string()))
        .ok()
}

/// Why the charts without landmarks could not be packed around the solved
/// ones.
#[derive(Debug, thiserror::Error)]
pub enum RestError {
    /// No room left for them.
    #[error("{0}; nothing written")]
    NoRoom(#[from] crate::pack::PackError),
    /// Charts still losing a triangle's area once stored as f32, laid out
    /// triangle by triangle, fat.
    #[error(
        "{thin} of {total} charts without landmarks do not fit the texture at a size that keeps their triangles once \
         stored as f32, even laid out triangle by triangle; nothing written"
    )]
    Thin {
        /// The charts still thin.
        thin: usize,
        /// The charts without landmarks.
        total: usize,
    },
}

/// The other charts packed around the solved one (layout coordinates),
/// each checked as stored; what the report says of them.
///
/// # Errors
/// No room for them, or a chart too small to keep its triangles once
/// stored as f32.
fn place_rest(finished: &Finished, report: &mut Report) -> Result<crate::atlas::PlacedRest, RestError> {
    let Some(rest) = finished.rest.filter(|r| !r.charts.is_empty()) else {
        return Ok(crate::atlas::PlacedRest::default());
    };
    let prepared = finished.prepared;
    let f = &prepared.filled;
    let mut occupied: Vec<[DVec2; 3]> = f.mesh.triangles[..f.n_real_triangles]
        .iter()
        .map(|t| t.map(|v| finished.layout[v as usize]))
        .collect();
    for s in finished.secondary {
        let g = &s.prepared.filled;
        occupied.extend(
            g.mesh.triangles[..g.n_real_triangles]
                .iter()
                .map(|t| t.map(|v| s.layout[v as usize])),
        );
    }
    if let Some(setup) = prepared.domain.free() {
        let o = &setup.obstacles;
        occupied.extend(o.triangles.iter().map(|t| t.map(|v| o.layout[v as usize])));
    }
    let mut rest = rest.clone();
    let placed = pack_fattening_thin(&mut rest, &occupied, prepared.whole)?;
    report.rest = Some(crate::report::RestReport {
        charts: rest.charts.len(),
        triangles: rest.charts.iter().map(|u| u.chart.mesh.n_triangles()).sum(),
        triangle_by_triangle: rest
            .charts
            .iter()
            .filter(|u| u.soup)
            .map(|u| u.chart.mesh.n_triangles())
            .sum(),
        scale: placed.scale,
    });
    Ok(placed)
}

/// Rounds of [`pack_fattening_thin`] at most: each packs again at a smaller
/// scale, which can make other charts thin.
const FATTEN_ROUNDS: usize = 4;

/// The rest packed around `occupied` in `whole`. A chart whose triangles
/// lose their area once packed and stored as f32 (slivers, a soup packed
/// small) is laid out again triangle by triangle, each triangle fat
/// ([`crate::atlas::SoupShape::Fat`]), and the rest packed again, until
/// none is thin: a chart without landmarks never makes the solve fail.
///
/// # Errors
/// No room, or a chart still thin once every thin one is fat.
fn pack_fattening_thin(
    rest: &mut crate::atlas::Rest,
    occupied: &[[DVec2; 3]],
    whole: crate::param::region::Region,
) -> Result<crate::atlas::PlacedRest, RestError> {
    let least = crate::atlas::least_fat_side(rest);
    let mut fat = vec![false; rest.charts.len()];
    let mut placed = pack_rest(rest, occupied, whole)?;
    for _ in 0..FATTEN_ROUNDS {
        let thin: Vec<usize> = thin_charts(&placed).into_iter().filter(|&k| !fat[k]).collect();
        if thin.is_empty() {
            break;
        }
        for k in thin {
            let duplicates = rest.charts[k].duplicates.clone();
            rest.charts[k] = crate::atlas::soup(&rest.charts[k].chart, crate::atlas::SoupShape::Fat(least));
            rest.charts[k].duplicates = duplicates;
            fat[k] = true;
        }
        placed = pack_rest(rest, occupied, whole)?;
    }
    let still = thin_charts(&placed);
    if !still.is_empty() {
        return Err(RestError::Thin {
            thin: still.len(),
            total: rest.charts.len(),
        });
    }
    Ok(placed)
}

/// The rest packed around `occupied` in `whole`.
fn pack_rest(
    rest: &crate::atlas::Rest,
    occupied: &[[DVec2; 3]],
    whole: crate::param::region::Region,
) -> Result<crate::atlas::PlacedRest, RestError> {
    Ok(crate::atlas::place(
        rest,
        occupied,
        whole,
        &crate::pack::PackRules::DEFAULT,
    )?)
}

/// The placed charts that lose a triangle's area or cross themselves once
/// stored as f32 (a chart packed small: its close boundary edges meet).
fn thin_charts(placed: &crate::atlas::PlacedRest) -> Vec<usize> {
    let thin = |(chart, _, layout): &crate::atlas::PlacedChart| {
        let stored: Vec<[f32; 2]> = layout.iter().map(|&p| crate::guard::stored_uv(p)).collect();
        let part = chart::Part {
            chart,
            layout,
            duplicates: &[],
        };
        !crate::guard::count_stored_orientations(&stored, &chart.mesh.triangles, crate::guard::VAxis::Down).is_clean()
            || chart::overlap_of(&[part]).is_some()
    };
    placed
        .charts
        .iter()
        .enumerate()
        .filter(|(_, c)| thin(c))
        .map(|(k, _)| k)
        .collect()
}

/// For a free chart: why its layout, as glTF and OBJ store it, is not
/// globally injective inside its region and clear of the other islands.
fn overlap(prepared: &PreparedChart, layout: &[DVec2]) -> Option<crate::free::room::Violation> {
    let crate::domain::Domain::Free(setup) = &prepared.domain else {
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
