//! A welded chart made solvable: triangles given twice dropped (their
//! copy takes their UVs), pinches, edges of more than two triangles and
//! disagreeing windings repaired by splitting vertices ([`split_wedges`]),
//! and the result opened to a disk along seams ([`super::open`]).

use super::separate::{Budget, separate};
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
    /// The other pieces the chart fell into when repaired (it touched them
    /// only at a fin, a pinch or an edge wound both ways), repaired but
    /// neither cut nor solved: they need layouts of their own. And the
    /// rest of a chart too large for its targets ([`super::separate`]).
    pub rest: Vec<Chart>,
    /// Where the landmarks' chart was cut from the rest, welded pairs
    /// (empty when it fitted).
    pub separation: Vec<[u32; 2]>,
    /// Whether the targets' scale was weighed (the chart had to be cut
    /// open): then a new scale may split it differently.
    pub scale_weighed: bool,
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
        "the chart falls into {n_pieces} pieces once split where it is not a surface ({where_}), and the landmarks are on more \
         than one of them (welded vertices {a} and {b}): put them on one piece, or mend the mesh there"
    )]
    Pieces {
        n_pieces: usize,
        where_: String,
        a: u32,
        b: u32,
    },
}

/// `chart` repaired and opened along the seams `spec` asks for, keeping
/// them off `landmarks` and off the `unseamable` edges (polygon diagonals);
/// seams, landmarks and edges as welded ids. When the repair splits the chart into pieces, the
/// one holding the landmarks (or the largest) is solved; the others are
/// handed back in [`Solvable::rest`].
///
/// # Errors
/// A double-sided face, landmarks on several pieces, bad given seams, or a
/// chart still not a disk.
pub fn make_solvable(
    chart: &Chart,
    spec: &SeamSpec,
    landmarks: &[u32],
    unseamable: &[[u32; 2]],
    budget: Option<Budget>,
    rules: &SeamRules,
) -> Result<Solvable, SolvableError> {
    let (single, duplicates) = without_duplicates(chart)?;
    let repaired = split_wedges(&single.mesh, &|_| false);
    let whole = single.opened(&repaired);
    let (mut main, mut rest) = main_piece(&whole, landmarks, &repaired.repairs)?;
    let mut separation = Vec::new();
    // Only a chart that must be cut open can be too large for its targets:
    // a disk lies flat at any scale.
    let topology = Topology::build(&main.mesh);
    let must_open = topology.as_ref().map_or(true, |t| super::nearly_closed(&main.mesh, t));
    let scale_weighed = must_open && budget.is_some() && matches!(spec, SeamSpec::Auto);
    if let (SeamSpec::Auto, Some(budget), true) = (spec, budget, must_open) {
        let local_landmarks: Vec<u32> = landmarks.iter().filter_map(|w| main.local_of(*w)).collect();
        let local_barred = local_pairs(&main, unseamable);
        if let Some(split) = separate(&main, &local_landmarks, budget, &local_barred) {
            separation = split
                .edges
                .iter()
                .map(|e| e.map(|v| main.welded_ids[v as usize]))
                .collect();
            main = split.main;
            rest.extend(split.rest);
        }
    }
    let local = |w: &u32| main.local_of(*w);
    let landmark_ids: Vec<u32> = landmarks.iter().filter_map(local).collect();
    let barred = local_pairs(&main, unseamable);
    let spec = match spec {
        SeamSpec::Auto => SeamSpec::Auto,
        SeamSpec::Edges(paths) => SeamSpec::Edges(
            paths
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    p.iter()
                        .map(local)
                        .collect::<Option<Vec<u32>>>()
                        .ok_or(CutError::OffPiece { path: k })
                })
                .collect::<Result<_, _>>()?,
        ),
    };
    let (repairs, duplicates) = (repaired.repairs, duplicates);
    // A disk with boundary enough, its seams left to us, is solvable as it
    // is (what `open` would find, without building its topology again).
    let (opened, topology) = match topology {
        Ok(t) if matches!(spec, SeamSpec::Auto) && !must_open && !rules.spread_disks => (None, Some(t)),
        _ => (super::open(&main.mesh, &spec, &landmark_ids, &barred, rules)?, None),
    };
    match opened {
        None => Ok(Solvable {
            topology: topology.map_or_else(|| Topology::build(&main.mesh), Ok)?,
            chart: main,
            seam: None,
            seam_copies: 0,
            repairs,
            duplicates,
            rest,
            separation,
            scale_weighed,
        }),
        Some(opened) => Ok(Solvable {
            chart: main.opened(&opened.wedges),
            topology: opened.topology,
            seam: Some(opened.seam),
            seam_copies: opened.wedges.n_added(),
            repairs,
            duplicates,
            rest,
            separation,
            scale_weighed,
        }),
    }
}

/// Welded vertex pairs as `chart`'s local `(min, max)` pairs, sorted (pairs
/// not in the chart left out).
fn local_pairs(chart: &Chart, pairs: &[[u32; 2]]) -> Vec<[u32; 2]> {
    let mut out: Vec<[u32; 2]> = pairs
        .iter()
        .filter_map(|[a, b]| Some((chart.local_of(*a)?, chart.local_of(*b)?)))
        .map(|(a, b)| [a.min(b), a.max(b)])
        .collect();
    out.sort_unstable();
    out
}

/// The piece of `whole` that holds every landmark (welded ids), or the one
/// with the most triangles, and the other pieces.
///
/// # Errors
/// Landmarks on two pieces.
fn main_piece(whole: &Chart, landmarks: &[u32], repairs: &Repairs) -> Result<(Chart, Vec<Chart>), SolvableError> {
    let (n_pieces, piece_of) = triangle_components(&whole.mesh);
    if n_pieces == 1 {
        return Ok((whole.clone(), Vec::new()));
    }
    let mut piece_of_vertex = vec![u32::MAX; whole.mesh.n_vertices()];
    let mut size = vec![0usize; n_pieces];
    for (t, tri) in whole.mesh.triangles.iter().enumerate() {
        size[piece_of[t] as usize] += 1;
        tri.iter().for_each(|&v| piece_of_vertex[v as usize] = piece_of[t]);
    }
    let holding: Vec<(u32, u32)> = landmarks
        .iter()
        .filter_map(|&w| whole.local_of(w).map(|l| (w, piece_of_vertex[l as usize])))
        .collect();
    if let Some(&(b, _)) = holding.iter().find(|(_, p)| *p != holding[0].1) {
        return Err(SolvableError::Pieces {
            n_pieces,
            where_: describe_repairs(repairs),
            a: holding[0].0,
            b,
        });
    }
    let main = holding.first().map_or_else(
        || {
            (0..n_pieces)
                .max_by_key(|&p| (size[p], std::cmp::Reverse(p)))
                .expect("pieces") as u32
        },
        |h| h.1,
    );
    let charts = (0..n_pieces as u32)
        .map(|p| whole.piece(&piece_of.iter().map(|&q| q == p).collect::<Vec<bool>>()))
        .collect::<Vec<Chart>>();
    let mut rest = charts;
    let main_chart = rest.remove(main as usize);
    Ok((main_chart, rest))
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
