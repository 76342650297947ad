//! A welded chart made solvable: triangles given twice dropped (their
//! copy takes their UVs), pinches, edges of more than two triangles and
//! disagreeing windings repaired by splitting vertices ([`split_wedges`]),
//! and the result opened to a disk along seams ([`super::open`]).

use super::{CutError, Seam, SeamRules, SeamSpec};
use crate::mesh::topology::{Topology, TopologyError, triangle_components};
use crate::mesh::wedges::{Repairs, split_wedges};
use crate::mesh::weld::Chart;
use thiserror::Error;

/// A chart ready for the solve.
#[derive(Debug, Clone)]
pub struct Solvable {
    /// The chart as solved: a disk (holes allowed), vertices split where
    /// repaired or cut (`welded_ids` maps each copy to its welded vertex).
    pub chart: Chart,
    pub topology: Topology,
    /// Where it was cut open (`None`: it was a disk already).
    pub seam: Option<Seam>,
    /// How many vertices the seam split off (one per extra side).
    pub seam_copies: usize,
    /// What was repaired.
    pub repairs: Repairs,
    /// Triangles given twice: (welded triangle left out, chart triangle
    /// whose UVs it takes).
    pub duplicates: Vec<(u32, u32)>,
}

/// Why a chart cannot be made solvable.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SolvableError {
    #[error("{0}")]
    Topology(#[from] TopologyError),
    #[error("{0}")]
    Cut(#[from] CutError),
    #[error(
        "triangles {t0} and {t1} are the same triangle wound both ways (a double-sided face): one UV layout cannot keep both \
         orientations; remove one of them"
    )]
    DoubleSided { t0: u32, t1: u32 },
    #[error(
        "the chart falls into {n_pieces} pieces once split where it is not a surface ({where_}); lay out each piece as its own \
         chart, or mend the mesh there"
    )]
    Pieces { n_pieces: usize, where_: String },
}

/// `chart` repaired and opened along the seams `spec` asks for, keeping
/// them off `landmarks` (chart-local vertices) and off the `unseamable`
/// edges (chart-local pairs `(min, max)`, sorted: polygon diagonals).
///
/// # Errors
/// A double-sided face, a chart that falls apart when repaired, bad given
/// seams, or a chart still not a disk.
pub fn make_solvable(
    chart: &Chart,
    spec: &SeamSpec,
    landmarks: &[u32],
    unseamable: &[[u32; 2]],
    rules: &SeamRules,
) -> Result<Solvable, SolvableError> {
    let (single, duplicates) = without_duplicates(chart)?;
    let repaired = split_wedges(&single.mesh, &|_| false);
    let (n_pieces, _) = triangle_components(&repaired.mesh);
    if n_pieces > 1 {
        return Err(SolvableError::Pieces {
            n_pieces,
            where_: describe_repairs(&repaired.repairs),
        });
    }
    let chart_repaired = single.opened(&repaired);
    // A vertex keeps its chart-local id through the repair: landmarks and
    // unseamable edges still name the same vertices.
    match super::open(&chart_repaired.mesh, spec, landmarks, unseamable, rules)? {
        None => Ok(Solvable {
            topology: Topology::build(&chart_repaired.mesh)?,
            chart: chart_repaired,
            seam: None,
            seam_copies: 0,
            repairs: repaired.repairs,
            duplicates,
        }),
        Some(opened) => Ok(Solvable {
            chart: chart_repaired.opened(&opened.wedges),
            topology: opened.topology,
            seam: Some(opened.seam),
            seam_copies: opened.wedges.n_added(),
            repairs: repaired.repairs,
            duplicates,
        }),
    }
}

/// The first repair of each kind, for a message.
fn describe_repairs(r: &Repairs) -> String {
    let mut parts = Vec::new();
    if let Some((e, t)) = r.non_manifold_edges.first() {
        parts.push(format!(
            "non-manifold edge ({}, {}) of {} triangles {t:?}",
            e[0],
            e[1],
            t.len()
        ));
    }
    if let Some((e, t)) = r.inconsistent_edges.first() {
        parts.push(format!(
            "edge ({}, {}) whose triangles {} and {} are wound opposite ways",
            e[0], e[1], t[0], t[1]
        ));
    }
    if let Some(v) = r.pinches.first() {
        parts.push(format!("pinched vertex {v}"));
    }
    parts.join("; ")
}

/// The chart without triangles that repeat an earlier one's vertices in
/// the same winding, and which triangle each dropped one copies.
///
/// # Errors
/// A triangle that repeats another's vertices in the other winding.
fn without_duplicates(chart: &Chart) -> Result<(Chart, Vec<(u32, u32)>), SolvableError> {
    let tris = &chart.mesh.triangles;
    let mut keyed: Vec<([u32; 3], u32)> = tris
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let mut key = *t;
            key.sort_unstable();
            (key, k as u32)
        })
        .collect();
    keyed.sort_unstable();
    let mut keep = vec![true; tris.len()];
    let mut copies: Vec<(u32, u32)> = Vec::new();
    for pair in keyed.windows(2) {
        let ((ka, a), (kb, b)) = (pair[0], pair[1]);
        if ka != kb {
            continue;
        }
        // `a` is the first of its kind (or a copy of it): `b` repeats it.
        let first = copies.iter().find(|(c, _)| *c == a).map_or(a, |(_, f)| *f);
        if rotation_of(tris[first as usize], tris[b as usize]) {
            keep[b as usize] = false;
            copies.push((b, first));
        } else {
            return Err(SolvableError::DoubleSided {
                t0: chart.triangle_ids[first as usize],
                t1: chart.triangle_ids[b as usize],
            });
        }
    }
    if copies.is_empty() {
        return Ok((chart.clone(), Vec::new()));
    }
    let single = chart.with_triangles(&keep);
    // Kept triangles are renumbered in order: where each one went.
    let mut new_index = vec![u32::MAX; tris.len()];
    let mut n = 0;
    for (k, &kept) in keep.iter().enumerate() {
        if kept {
            new_index[k] = n;
            n += 1;
        }
    }
    let duplicates = copies
        .into_iter()
        .map(|(dup, first)| (chart.triangle_ids[dup as usize], new_index[first as usize]))
        .collect();
    Ok((single, duplicates))
}

/// Whether `b` lists `a`'s vertices in the same cyclic order.
fn rotation_of(a: [u32; 3], b: [u32; 3]) -> bool {
    (0..3).any(|r| [b[r], b[(r + 1) % 3], b[(r + 2) % 3]] == a)
}
