//! A welded chart made solvable: triangles given twice dropped (their
//! copy takes their UVs), pinches, edges of more than two triangles and
//! disagreeing windings repaired by splitting vertices ([`split_wedges`]),
//! and the result opened to a disk along seams ([`super::open`]).

use super::facing::{Camera, Sight};
use super::separate::{Budget, separate};
use super::{CutError, Seam, SeamRules, SeamSpec};
use crate::mesh::topology::{Topology, TopologyError, triangle_components};
use crate::mesh::wedges::{Repairs, split_wedges};
use crate::mesh::weld::Chart;
use glam::DVec2;
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
    /// rest of a chart split around its landmarks.
    pub rest: Vec<Chart>,
    /// The other pieces holding landmarks (split apart where the chart is
    /// not a surface, or seen apart by the camera): each is solved as a
    /// chart of its own, after this one.
    pub pieces: Vec<Chart>,
    /// Where the landmarks' chart was cut from the rest, welded pairs
    /// (empty when it fitted).
    pub separation: Vec<[u32; 2]>,
}

/// Why a chart cannot be made solvable.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SolvableError {
    #[error("{0}")]
    Topology(#[from] TopologyError),
    #[error("{0}")]
    Cut(#[from] CutError),
    #[error("{0}")]
    NotADisk(TopologyError),
    #[error("no part {form} holds every landmark")]
    NoPart { form: &'static str },
}

/// How a landmarked chart is made a disk: the candidates a solve weighs
/// on its coarse level before it picks one.
#[derive(Debug, Clone, PartialEq)]
pub enum Form {
    /// As it comes, repaired (a disk, holes allowed), cut only along the
    /// seams given.
    AsGiven,
    /// Cut open along automatic seams: handles, then out to cone points
    /// (a disk too, from its boundary).
    Cut,
    /// The landmarks' geodesic surroundings, as large as the targets'
    /// scale leaves room for ([`super::separate`]); the rest apart.
    Around(Budget),
    /// What a camera fitted to the targets sees (as `sight` says),
    /// projected inside `room` (a layout box) ([`super::facing`]); the rest apart.
    Facing {
        camera: Camera,
        room: (DVec2, DVec2),
        sight: Sight,
    },
}

impl Form {
    /// A short name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            Form::AsGiven => "as given",
            Form::Cut => "cut",
            Form::Around(_) => "landmarks' surroundings",
            Form::Facing { sight: Sight::Near, .. } => "as the camera sees it",
            Form::Facing {
                sight: Sight::Whole, ..
            } => "what the camera sees whole",
            Form::Facing {
                sight: Sight::Grown, ..
            } => "what the camera sees one-to-one",
        }
    }
}

/// The vertices of `chart` that copy one of the `landmarks` (welded ids)
/// besides its `primary` local vertex: where the repair split a vertex at
/// which the file's sheets meet.
fn other_copies(chart: &Chart, landmarks: &[u32], primary: &[u32]) -> Vec<u32> {
    let mut welded = landmarks.to_vec();
    welded.sort_unstable();
    let is_primary = crate::mesh::marked(chart.welded_ids.len(), primary);
    (0..chart.welded_ids.len() as u32)
        .filter(|&v| !is_primary[v as usize] && welded.binary_search(&chart.welded_ids[v as usize]).is_ok())
        .collect()
}

/// `chart` repaired and made a disk as `form` says, seams kept off
/// `landmarks` and off the `unseamable` edges (polygon diagonals); seams,
/// landmarks and edges as welded ids. When the repair splits the chart
/// into pieces, the one holding the landmarks (or the largest) is solved;
/// the others are handed back in [`Solvable::rest`], with what a
/// separating form split off.
///
/// # Errors
/// Bad given seams, a form that leaves the chart no disk, or one that
/// finds no part holding every landmark.
pub fn make_solvable(
    chart: &Chart,
    asked: Option<&Form>,
    spec: &SeamSpec,
    landmarks: &[u32],
    unseamable: &[[u32; 2]],
    rules: &SeamRules,
) -> Result<Solvable, SolvableError> {
    let (single, repeated) = without_duplicates(chart);
    let mut repaired = split_wedges(&single.mesh, &|_| false);
    let whole = single.opened(&repaired);
    let (mut main, mut pieces, mut rest) = main_piece(&whole, landmarks);
    let duplicates = repeated.duplicates;
    if let Some((back, ids)) = repeated.back {
        rest.push(back);
        repaired.repairs.back_faces = ids;
    }
    let mut separation = Vec::new();
    let local_landmarks = |c: &Chart| -> Vec<u32> { landmarks.iter().filter_map(|w| c.local_of(*w)).collect() };
    let form = asked.unwrap_or(&Form::AsGiven);
    let split = match form {
        Form::AsGiven | Form::Cut => None,
        Form::Around(budget) => {
            let barred = local_pairs(&main, unseamable);
            let split = separate(&main, &local_landmarks(&main), *budget, &barred);
            Some(split.ok_or(SolvableError::NoPart { form: form.name() })?)
        }
        Form::Facing { camera, room, sight } => {
            let barred = local_pairs(&main, unseamable);
            let primary = local_landmarks(&main);
            let copies = other_copies(&main, landmarks, &primary);
            let marks = (primary.as_slice(), copies.as_slice());
            let region = super::facing::facing_region(&main.mesh, (camera, *sight), marks, *room, &barred)
                .ok_or(SolvableError::NoPart { form: form.name() })?;
            Some(
                super::separate::split_off(&main, &region, &primary)
                    .ok_or(SolvableError::NoPart { form: form.name() })?,
            )
        }
    };
    if let Some(split) = split {
        // Other parts holding landmarks (what a camera sees of a ring, on
        // both sides of its hole) are pieces of their own, solved beside
        // the main one; the planner judges a form with them all.
        separation = split
            .edges
            .iter()
            .map(|e| e.map(|v| main.welded_ids[v as usize]))
            .collect();
        main = split.main;
        pieces.extend(split.others);
        rest.extend(split.rest);
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
    let repairs = repaired.repairs;
    let topology = Topology::build(&main.mesh).map(|t| match form {
        // The camera's view is the layout: its outline is the outer loop.
        Form::Facing { camera, .. } => t.outermost_in(&super::facing::projection(camera, &main.mesh.positions)),
        _ => t,
    });
    let cut = match (asked, &spec, &topology) {
        (Some(Form::AsGiven), SeamSpec::Auto, Err(e)) => return Err(SolvableError::NotADisk(e.clone())),
        // As given, or split apart around the landmarks: a disk is solved as
        // it is; what is not a disk yet (a handle inside the part) is cut.
        (None | Some(Form::AsGiven | Form::Around(_) | Form::Facing { .. }), SeamSpec::Auto, Ok(_)) => None,
        // Cut where asked, or where nothing was asked and it is no disk.
        (Some(Form::Cut), SeamSpec::Auto, _) | (None, SeamSpec::Auto, Err(_)) => {
            let spread = SeamRules {
                spread_disks: true,
                ..*rules
            };
            super::open(&main.mesh, &spec, &landmark_ids, &barred, &spread)?
        }
        _ => super::open(&main.mesh, &spec, &landmark_ids, &barred, rules)?,
    };
    let (chart, topology, seam, seam_copies) = match cut {
        None => (main, topology?, None, 0),
        Some(opened) => (
            main.opened(&opened.wedges),
            opened.topology,
            Some(opened.seam),
            opened.wedges.n_added(),
        ),
    };
    Ok(Solvable {
        chart,
        topology,
        seam,
        seam_copies,
        repairs,
        duplicates,
        rest,
        pieces,
        separation,
    })
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

/// The piece of `whole` that holds most landmarks (welded ids; without
/// any, the one with the most triangles), the other pieces holding
/// landmarks, and the pieces without.
fn main_piece(whole: &Chart, landmarks: &[u32]) -> (Chart, Vec<Chart>, Vec<Chart>) {
    let (n_pieces, piece_of) = triangle_components(&whole.mesh);
    if n_pieces == 1 {
        return (whole.clone(), Vec::new(), Vec::new());
    }
    let mut piece_of_vertex = vec![u32::MAX; whole.mesh.n_vertices()];
    let mut size = vec![0usize; n_pieces];
    for (t, tri) in whole.mesh.triangles.iter().enumerate() {
        size[piece_of[t] as usize] += 1;
        tri.iter().for_each(|&v| piece_of_vertex[v as usize] = piece_of[t]);
    }
    // Every copy of a landmark counts: a piece with one holds it too.
    let mut held = vec![0usize; n_pieces];
    for (v, w) in whole.welded_ids.iter().enumerate() {
        if landmarks.contains(w) && piece_of_vertex[v] != u32::MAX {
            held[piece_of_vertex[v] as usize] += 1;
        }
    }
    let main = (0..n_pieces)
        .max_by_key(|&p| (held[p], size[p], std::cmp::Reverse(p)))
        .expect("pieces");
    super::sorted_pieces(whole, &piece_of, &held, main)
}

/// What [`without_duplicates`] leaves out of a chart.
struct Repeated {
    /// Triangles repeating an earlier one in the same winding: (welded
    /// triangle left out, chart triangle whose UVs it takes).
    duplicates: Vec<(u32, u32)>,
    /// Back faces: triangles repeating an earlier one in the other
    /// winding (one layout cannot keep both windings), as a chart of their
    /// own to lay out apart; with their welded triangle ids.
    back: Option<(Chart, Vec<u32>)>,
}

/// The chart without triangles that repeat an earlier one's vertices:
/// those in the same winding copy it, those in the other (the back of a
/// double-sided face) are laid out apart.
fn without_duplicates(chart: &Chart) -> (Chart, Repeated) {
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
    let mut back = vec![false; tris.len()];
    let mut copies: Vec<(u32, u32)> = Vec::new();
    for pair in keyed.windows(2) {
        let ((ka, a), (kb, b)) = (pair[0], pair[1]);
        if ka != kb {
            continue;
        }
        // `a` is the first of its kind (or a copy of it): `b` repeats it.
        let first = copies.iter().find(|(c, _)| *c == a).map_or(a, |(_, f)| *f);
        keep[b as usize] = false;
        if rotation_of(tris[first as usize], tris[b as usize]) {
            copies.push((b, first));
        } else {
            back[b as usize] = true;
        }
    }
    let back = back.iter().any(|&b| b).then(|| {
        let ids = (0..tris.len())
            .filter(|&k| back[k])
            .map(|k| chart.triangle_ids[k])
            .collect();
        (chart.piece(&back), ids)
    });
    if copies.is_empty() && back.is_none() {
        return (
            chart.clone(),
            Repeated {
                duplicates: Vec::new(),
                back: None,
            },
        );
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
    (single, Repeated { duplicates, back })
}

/// Whether `b` lists `a`'s vertices in the same cyclic order.
fn rotation_of(a: [u32; 3], b: [u32; 3]) -> bool {
    (0..3).any(|r| [b[r], b[(r + 1) % 3], b[(r + 2) % 3]] == a)
}
