//! The solved chart: chosen from the constraints, checked, hole-filled, with
//! constraints and corners in chart-local ids; and the final per-primitive UVs.

use crate::constraints::ConstraintSource;
use crate::cut::prepare::{Form, make_solvable};
use crate::cut::separate::Budget;
use crate::cut::{SeamRules, SeamSpec};
use crate::domain::Domain;
pub use crate::domain::setup::Pick;
use crate::error::Error;
use crate::guard::{self, OrientationCounts};
use crate::io::SourceAsset;
use crate::io::corners::CornerUvs;
use crate::mesh::topology::Topology;
use crate::mesh::weld::{Chart, WeldedMesh, weld};
use crate::param::bar_net::{FilledChart, fill_holes};
use crate::param::boundary::{BoundaryMap, TrapCandidates};
use crate::param::region::Region;
use crate::param::{uv_to_xy, xy_to_uv};
use crate::pins::ResolvedConstraint;
use crate::rbf::stepping::{StepProblem, pick_anchors};
use glam::DVec2;
use std::sync::Arc;

/// Everything about the chart being solved that does not depend on the layout.
#[derive(Debug, Clone)]
///
/// The geometry (weld, chart, topology, trap candidates, hole fill) is shared
/// behind `Arc`s, so a constraint edit on the same asset reuses it
/// ([`PreparedChart::retargeted`]).
pub struct PreparedChart {
    pub welded: Arc<WeldedMesh>,
    pub chart: Arc<Chart>,
    pub topology: Arc<Topology>,
    pub traps: Arc<TrapCandidates>,
    pub filled: Arc<FilledChart>,
    pub constraints: Vec<ResolvedConstraint>,
    /// Chart-local vertex of each constraint (same order as `constraints`).
    pub constraint_vertices: Vec<u32>,
    /// Given corners, chart-local.
    pub corners: Option<[u32; 4]>,
    /// Where it is laid out: the outer boundary on the square, or free inside a region.
    pub domain: Domain,
    pub warnings: Vec<String>,
    /// How the chart was made solvable: seams, repairs, repeated triangles.
    pub opening: Arc<Opening>,
    /// The other charts holding constraints, in the order they are solved
    /// after this one (each in its own island, clear of the others).
    pub secondary: Vec<u32>,
    /// The share of the surface that other charts needing UVs take
    /// (they are packed around this one): depends on the geometry only.
    pub rest_share: f64,
    /// Where every UV this solve writes stays: the given region, or the
    /// texture (the charts packed beside this one too).
    pub whole: Region,
}

/// What was done to a chart so it could be solved: where it was cut open
/// and what was repaired (chart-local ids of `PreparedChart::chart`).
#[derive(Debug, Clone, Default)]
pub struct Opening {
    /// The seams it was cut along (`None`: it was a disk).
    pub seam: Option<crate::cut::Seam>,
    /// Whether the seams were given in the constraint file (else automatic).
    pub seam_given: bool,
    /// How many vertices the seam split off.
    pub seam_copies: usize,
    /// What was split apart to repair it.
    pub repairs: crate::mesh::wedges::Repairs,
    /// Triangles given twice: (welded triangle left out, chart triangle
    /// whose UVs it takes).
    pub duplicates: Vec<(u32, u32)>,
    /// The other pieces the chart fell into when repaired, or was split
    /// into around its landmarks: laid out apart, without landmarks.
    pub rest: Vec<Arc<Chart>>,
    /// The other pieces holding landmarks: each solved as a chart of its
    /// own after this one ([`Pick::piece`]).
    pub pieces: Vec<Arc<Chart>>,
    /// Where the landmarks' chart was cut from the rest of a chart too
    /// large for its targets (welded pairs).
    pub separation: Vec<[u32; 2]>,
    /// What the geometry was made for: the seams asked for and, for a
    /// chart that was cut automatically, its landmarks (welded ids, sorted).
    key: GeometryKey,
}

impl Opening {
    /// How a chart laid out without landmarks was made solvable.
    pub fn without_landmarks(solvable: &crate::cut::prepare::Solvable) -> Opening {
        Opening {
            seam: solvable.seam.clone(),
            seam_given: false,
            seam_copies: solvable.seam_copies,
            repairs: solvable.repairs.clone(),
            duplicates: solvable.duplicates.clone(),
            rest: Vec::new(),
            pieces: Vec::new(),
            separation: Vec::new(),
            key: GeometryKey::default(),
        }
    }
}

/// What a chart's geometry depends on beyond the chart itself.
#[derive(Debug, Clone, Default, PartialEq)]
struct GeometryKey {
    seams: crate::pins::SeamsChoice,
    landmarks: Option<Vec<u32>>,
    /// The form asked for (`None`: as given, or cut when it is no disk).
    form: Option<Form>,
    /// No form was asked for and the chart, no disk, was cut: the same
    /// geometry as [`Form::Cut`] asked for.
    cut_by_default: bool,
}

/// Welds the asset's mesh, resolves the constraints, picks the chart that
/// holds them (the largest chart when there are none), and checks its topology.
///
/// # Errors
/// Constraint errors against the asset (with line:column for a file),
/// constraints in several charts, corners outside the chart, topology
/// errors of the chart (closed, non-manifold, not a disk).
pub fn prepare(source: &ConstraintSource, asset: &SourceAsset) -> Result<PreparedChart, Error> {
    prepare_on(source, asset, Arc::new(weld(&asset.primitives)), None, &Pick::default())
}

/// Chart `pick.chart` of the same weld, prepared with its own constraints
/// and `pick`'s obstacles (a secondary chart of a solve, [`PreparedChart::secondary`]).
///
/// # Errors
/// As [`prepare`].
pub fn prepare_pick(
    source: &ConstraintSource,
    asset: &SourceAsset,
    welded: Arc<WeldedMesh>,
    pick: &Pick,
) -> Result<PreparedChart, Error> {
    prepare_on(source, asset, welded, None, pick)
}

impl PreparedChart {
    /// The same asset's chart for new constraints `source`: this weld, and
    /// this chart's topology, trap candidates and hole fill when the
    /// constraints fall in the same chart (shared, see
    /// [`Self::same_geometry`]); only the constraints and corners are
    /// resolved again.
    ///
    /// # Errors
    /// As [`prepare`].
    pub fn retargeted(&self, source: &ConstraintSource, asset: &SourceAsset) -> Result<PreparedChart, Error> {
        prepare_on(source, asset, self.welded.clone(), Some(self), &Pick::default())
    }

    /// The same chart and constraints as `pick` makes them (another form
    /// or boundary), sharing this chart's geometry where `pick`'s form
    /// makes the same (a cut asked for where the default cut already).
    /// For a whole chart, not a piece: a `pick` of a piece is made anew.
    ///
    /// # Errors
    /// As [`prepare`].
    pub fn repicked(
        &self,
        source: &ConstraintSource,
        asset: &SourceAsset,
        pick: &Pick,
    ) -> Result<PreparedChart, Error> {
        let previous = Some(self).filter(|_| pick.piece.is_none());
        prepare_on(source, asset, self.welded.clone(), previous, pick)
    }
}

fn prepare_on(
    source: &ConstraintSource,
    asset: &SourceAsset,
    welded: Arc<WeldedMesh>,
    previous: Option<&PreparedChart>,
    pick: &Pick,
) -> Result<PreparedChart, Error> {
    let (all_constraints, welded_corners) = source.resolve(&asset.primitives, &welded)?;
    let (chart_id, secondary) = choose_chart(&all_constraints, &welded, asset, pick)?;
    let constraints: Vec<ResolvedConstraint> = (all_constraints.iter())
        .filter(|c| match &pick.piece {
            Some(piece) => piece.local_of(c.welded).is_some(),
            None => welded.chart_of_vertex[c.welded as usize] == Some(chart_id),
        })
        .cloned()
        .collect();
    let seams = source.seams(&asset.primitives, &welded)?;
    let landmarks: Vec<u32> = constraints.iter().map(|c| c.welded).collect();
    // A piece is solved as it is; its start is its form's (the camera's view).
    let form = if pick.piece.is_some() { None } else { pick.form.as_ref() };
    let reusable = previous.filter(|p| p.chart.id == chart_id && p.opening.key.fits(&seams, &landmarks, form));
    // An area sum over every triangle: kept with the geometry it depends on.
    let kept_share = reusable.map(|p| p.rest_share);
    let geometry = match reusable {
        Some(p) => (
            p.chart.clone(),
            p.topology.clone(),
            p.traps.clone(),
            p.filled.clone(),
            p.opening.clone(),
        ),
        None => {
            let base = pick.piece.as_deref().cloned().unwrap_or_else(|| welded.chart(chart_id));
            chart_geometry(base, &welded, asset, source, (&seams, &landmarks, form))?
        }
    };
    let (chart, topology, traps, filled, opening) = geometry;
    // Landmarks on the other pieces are solved with those.
    let constraints: Vec<ResolvedConstraint> = constraints
        .into_iter()
        .filter(|c| chart.local_of(c.welded).is_some())
        .collect();
    let constraint_vertices: Vec<u32> = constraints
        .iter()
        .map(|c| chart.local_of(c.welded).expect("constraint in the chart"))
        .collect();
    let corners = welded_corners.map(|w| local_corners(w, &chart, source)).transpose()?;
    let mut warnings: Vec<String> = Vec::new();
    warnings.extend(repair_warnings(&opening));
    // A chart cut open, or with an outer loop of 3 (no 4 corners), has no
    // shape the square would suit.
    let cut = opening.seam.is_some() || !opening.separation.is_empty() || topology.outer_loop().len() < 4;
    let rest_share = kept_share.unwrap_or_else(|| rest_share(asset, &welded, &chart, &opening));
    // What the camera sees of the other pieces is theirs: the chart keeps
    // off it (each piece keeps off the ones after it, [`PreparedChart::reserved_after`]).
    let seen = seen_pieces(pick.form.as_ref(), &opening.pieces);
    let reserved = (pick.piece.is_none() && !seen.is_empty()).then(|| {
        let mut placed = (*pick.placed).clone();
        placed.extend(seen);
        Pick {
            placed: Arc::new(placed),
            ..pick.clone()
        }
    });
    let decided_by = reserved.as_ref().unwrap_or(pick);
    let photo_scale = (constraints.len() < 2)
        .then(|| crate::domain::setup::photo_scale(&all_constraints, &welded))
        .flatten();
    let mut domain = crate::domain::setup::decide(
        source,
        asset,
        &welded,
        &chart,
        &constraints,
        (cut, rest_share, photo_scale),
        decided_by,
    )?;
    if let Domain::Free(setup) = &domain
        && let Some(layout) = camera_start(
            pick,
            setup,
            &filled,
            (&all_constraints, &welded),
            (&constraints, &constraint_vertices),
        )
    {
        domain = Domain::Free(Arc::new(
            setup.starting_from(layout, crate::domain::start::StartKind::Projection),
        ));
    }
    if corners.is_some() && matches!(domain, Domain::Free(_)) {
        warnings.push("corners are ignored: the boundary is free".into());
    }
    Ok(PreparedChart {
        welded,
        chart,
        topology,
        traps,
        filled,
        constraints,
        constraint_vertices,
        corners,
        domain,
        warnings,
        opening,
        secondary,
        rest_share,
        whole: source.boundary().1.unwrap_or(Region::TEXTURE),
    })
}

/// The start of a free chart (`setup`) as a camera sees it: the view of
/// the camera `pick` makes it as; else, for a chart with one landmark
/// (`constraints` at the chart's `vertices`) not kept in its island, the
/// photo's ([`photo_start`], from `all` of the file's constraints).
fn camera_start(
    pick: &Pick,
    setup: &crate::free::FreeSetup,
    filled: &FilledChart,
    (all, welded): (&[ResolvedConstraint], &WeldedMesh),
    (constraints, vertices): (&[ResolvedConstraint], &[u32]),
) -> Option<Vec<DVec2>> {
    match (&pick.form, vertices) {
        (Some(Form::Facing { camera, sight, .. }), _) => {
            crate::domain::start::projection_start((camera, *sight), filled, vertices)
        }
        (None, [landmark]) if setup.island.is_none() => {
            photo_start(all, welded, filled, (*landmark, constraints[0].target_uv))
        }
        _ => None,
    }
}

/// A chart with one landmark as the camera that `all` the file's
/// landmarks fit sees it (a photo's of the whole mesh), moved so that its
/// landmark is on its target (`landmark`, `target` in texture
/// coordinates): its size and turn as the photo shows it, where one target
/// gives neither. `None` without three landmarks that fix a view, or when
/// the view folds.
fn photo_start(
    all: &[ResolvedConstraint],
    welded: &WeldedMesh,
    filled: &FilledChart,
    (landmark, target): (u32, DVec2),
) -> Option<Vec<DVec2>> {
    let points: Vec<glam::DVec3> = all.iter().map(|c| welded.mesh.positions[c.welded as usize]).collect();
    let targets: Vec<DVec2> = all.iter().map(|c| uv_to_xy(c.target_uv)).collect();
    let camera = crate::cut::facing::Camera::fit(&points, &targets)?;
    let sight = (&camera, crate::cut::facing::Sight::Near);
    let mut layout = crate::domain::start::projection_start(sight, filled, &[landmark])?;
    let shift = uv_to_xy(target) - layout[landmark as usize];
    layout.iter_mut().for_each(|p| *p += shift);
    Some(layout)
}

/// The triangles of `pieces` where the camera of a chart made as it sees
/// them (`form`) shows them; empty for any other form.
fn seen_pieces(form: Option<&Form>, pieces: &[Arc<Chart>]) -> Vec<[DVec2; 3]> {
    let Some(Form::Facing { camera, .. }) = form else {
        return Vec::new();
    };
    pieces
        .iter()
        .flat_map(|piece| {
            let seen = crate::cut::facing::projection(camera, &piece.mesh.positions);
            piece.mesh.triangles.iter().map(move |t| t.map(|v| seen[v as usize]))
        })
        .collect()
}

impl GeometryKey {
    /// Whether geometry made for this key serves `seams`, `landmarks`
    /// (welded ids) and `form`: the same seams and form asked for and, if
    /// the chart was cut or split around them, the same landmark vertices
    /// (a split at a scale within a quarter octave of this one's).
    fn fits(&self, seams: &crate::pins::SeamsChoice, landmarks: &[u32], form: Option<&Form>) -> bool {
        let same_form = match (&self.form, form) {
            (Some(Form::Around(a)), Some(Form::Around(b))) => scale_step(*a) == scale_step(*b),
            (None, Some(Form::Cut)) => self.cut_by_default,
            (a, b) => a.as_ref() == b,
        };
        self.seams == *seams && same_form && self.landmarks.as_ref().is_none_or(|l| *l == sorted(landmarks))
    }
}

fn scale_step(budget: Budget) -> i32 {
    (budget.scale.log2() * 4.0).round() as i32
}

/// The scale the targets ask for and the room they leave, when the chart
/// is laid out anew (it has no UVs) and freely: the budget of a chart cut
/// down to the landmarks' surroundings ([`crate::cut::separate`]).
pub fn separation_budget(
    source: &ConstraintSource,
    asset: &SourceAsset,
    welded: &WeldedMesh,
    chart_id: u32,
    constraints: &[ResolvedConstraint],
) -> Option<Budget> {
    let (choice, region) = source.boundary();
    let has_uvs = asset.primitives.iter().zip(&welded.vertex_of).any(|(p, map)| {
        p.uvs.is_some()
            && map
                .iter()
                .any(|&w| welded.chart_of_vertex[w as usize] == Some(chart_id))
    });
    if choice == Some(crate::pins::BoundaryChoice::Square) || has_uvs || constraints.len() < 2 {
        return None;
    }
    let (mut uv, mut xyz) = (0.0, 0.0);
    for (i, a) in constraints.iter().enumerate() {
        for b in &constraints[i + 1..] {
            uv += a.target_uv.distance(b.target_uv);
            xyz += welded.mesh.positions[a.welded as usize].distance(welded.mesh.positions[b.welded as usize]);
        }
    }
    let scale = uv / xyz;
    let r = region.unwrap_or(Region::TEXTURE);
    let room = (r.max.x - r.min.x) * (r.max.y - r.min.y);
    (scale.is_finite() && scale > 0.0).then_some(Budget { scale, room })
}

fn sorted(ids: &[u32]) -> Vec<u32> {
    let mut v = ids.to_vec();
    v.sort_unstable();
    v.dedup();
    v
}

/// The share of the surface laid out beside the solved chart: the pieces
/// its repair or split handed back, and every other chart without UVs.
fn rest_share(asset: &SourceAsset, welded: &WeldedMesh, chart: &Chart, opening: &Opening) -> f64 {
    let mut has_uv = vec![false; welded.mesh.n_vertices()];
    for (prim, map) in asset.primitives.iter().zip(&welded.vertex_of) {
        if prim.uvs.is_some() {
            map.iter().for_each(|&w| has_uv[w as usize] = true);
        }
    }
    let others: f64 = welded
        .mesh
        .triangles
        .iter()
        .filter(|t| {
            let c = welded.chart_of_vertex[t[0] as usize];
            c != Some(chart.id) && t.iter().any(|&v| !has_uv[v as usize])
        })
        .map(|t| crate::mesh::triangle_area_3d(&welded.mesh, *t))
        .sum();
    // Pieces holding landmarks need room beside it too.
    let rest = others
        + opening
            .rest
            .iter()
            .chain(&opening.pieces)
            .map(|c| c.mesh.area())
            .sum::<f64>();
    let total = rest + chart.mesh.area();
    if total > 0.0 { rest / total } else { 0.0 }
}

/// What the report says about repairs.
fn repair_warnings(opening: &Opening) -> Vec<String> {
    let r = &opening.repairs;
    let mut out = Vec::new();
    if !r.pinches.is_empty() {
        out.push(format!(
            "{} pinched vertices (where separate fans meet, e.g. chart vertex {}) were split for the solve",
            r.pinches.len(),
            r.pinches[0]
        ));
    }
    if let Some((edge, triangles)) = r.non_manifold_edges.first() {
        out.push(format!(
            "{} edges shared by more than two triangles (e.g. edge ({}, {}) of triangles {triangles:?}) were split for the solve",
            r.non_manifold_edges.len(),
            edge[0],
            edge[1]
        ));
    }
    if let Some(t) = r.back_faces.first() {
        out.push(format!(
            "{} double-sided faces (e.g. welded triangle {t} is another wound the other way): the back triangle of each \
             is laid out apart with the other charts (one layout cannot keep both windings)",
            r.back_faces.len()
        ));
    }
    if let Some((edge, t)) = r.inconsistent_edges.first() {
        out.push(format!(
            "{} edges whose two triangles are wound opposite ways (e.g. edge ({}, {}) of triangles {} and {}) were split for the solve",
            r.inconsistent_edges.len(),
            edge[0],
            edge[1],
            t[0],
            t[1]
        ));
    }
    if !opening.duplicates.is_empty() {
        out.push(format!(
            "{} triangles repeat another's vertices and take its UVs (e.g. welded triangle {})",
            opening.duplicates.len(),
            opening.duplicates[0].0
        ));
    }
    out
}

/// The chart `pick` names, or the one holding the most constraints (the
/// first met on a tie), or the largest without any; and the other charts
/// holding constraints, in the order their first constraint comes.
fn choose_chart(
    constraints: &[ResolvedConstraint],
    welded: &WeldedMesh,
    asset: &SourceAsset,
    pick: &Pick,
) -> Result<(u32, Vec<u32>), Error> {
    let chart_of =
        |c: &ResolvedConstraint| welded.chart_of_vertex[c.welded as usize].expect("resolved vertices are used");
    let mut holding: Vec<(u32, usize)> = Vec::new();
    for c in constraints {
        match holding.iter_mut().find(|(id, _)| *id == chart_of(c)) {
            Some(entry) => entry.1 += 1,
            None => holding.push((chart_of(c), 1)),
        }
    }
    let main = match (pick.chart, holding.iter().max_by_key(|(_, n)| *n)) {
        (Some(id), _) => id,
        (None, Some(&(id, n))) => holding.iter().find(|(_, m)| *m == n).map_or(id, |h| h.0),
        (None, None) => {
            let sizes = welded.chart_sizes();
            let largest = (0..sizes.len()).max_by_key(|&c| (sizes[c].1, std::cmp::Reverse(c)));
            return largest.map(|c| (c as u32, Vec::new())).ok_or_else(|| {
                Error::Asset(crate::io::AssetError::MeshSelection {
                    path: asset.path.clone(),
                    message: "the mesh has no triangles".into(),
                })
            });
        }
    };
    let secondary = if pick.chart.is_some() {
        Vec::new()
    } else {
        holding.iter().map(|h| h.0).filter(|&id| id != main).collect()
    };
    Ok((main, secondary))
}

/// Chart `chart_id` of `welded` made solvable (repaired, cut open where it
/// must be), its topology, trap candidates, hole fill and how it was opened.
type ChartGeometry = (
    Arc<Chart>,
    Arc<Topology>,
    Arc<TrapCandidates>,
    Arc<FilledChart>,
    Arc<Opening>,
);

fn chart_geometry(
    chart: Chart,
    welded: &WeldedMesh,
    asset: &SourceAsset,
    source: &ConstraintSource,
    (seams, landmarks, form): (&crate::pins::SeamsChoice, &[u32], Option<&Form>),
) -> Result<ChartGeometry, Error> {
    let chart_id = chart.id;
    let spec = match seams {
        crate::pins::SeamsChoice::Auto => SeamSpec::Auto,
        crate::pins::SeamsChoice::Edges(paths) => {
            if let Some(k) = paths
                .iter()
                .position(|p| p.iter().any(|&w| chart.local_of(w).is_none()))
            {
                return Err(source
                    .seams_error(format!("seams[{k}] leaves the solved chart {chart_id}"))
                    .into());
            }
            SeamSpec::Edges(paths.clone())
        }
    };
    let diagonals = polygon_diagonals(asset, welded);
    // No form asked for: as given, cut where it is no disk.
    let solvable =
        make_solvable(&chart, form, &spec, landmarks, &diagonals, &SeamRules::DEFAULT).map_err(|source| {
            Error::Topology {
                path: asset.path.clone(),
                mesh: asset.mesh_index,
                chart: chart_id,
                n_vertices: chart.mesh.n_vertices(),
                n_triangles: chart.mesh.n_triangles(),
                source,
            }
        })?;
    let auto_cut = (solvable.seam.is_some() || !solvable.separation.is_empty()) && matches!(spec, SeamSpec::Auto);
    // Nothing asked and seams automatic: a seam means it was no disk.
    let cut_by_default = form.is_none() && solvable.seam.is_some() && matches!(spec, SeamSpec::Auto);
    let opening = Opening {
        rest: solvable.rest.into_iter().map(Arc::new).collect(),
        pieces: solvable.pieces.into_iter().map(Arc::new).collect(),
        separation: solvable.separation,
        seam: solvable.seam,
        seam_given: matches!(spec, SeamSpec::Edges(_)),
        seam_copies: solvable.seam_copies,
        repairs: solvable.repairs,
        duplicates: solvable.duplicates,
        key: GeometryKey {
            seams: seams.clone(),
            landmarks: auto_cut.then(|| sorted(landmarks)),
            form: form.cloned(),
            cut_by_default,
        },
    };
    let (chart, topology) = (solvable.chart, solvable.topology);
    let traps = TrapCandidates::find(&chart.mesh, &topology);
    let filled = fill_holes(&chart.mesh, &topology);
    Ok((
        Arc::new(chart),
        Arc::new(topology),
        Arc::new(traps),
        Arc::new(filled),
        Arc::new(opening),
    ))
}

/// The edges an OBJ's triangulation added inside its polygons, as welded
/// pairs: a seam along one would split a polygon's corner.
pub fn polygon_diagonals(asset: &SourceAsset, welded: &WeldedMesh) -> Vec<[u32; 2]> {
    let crate::io::Container::Obj { faces, .. } = &asset.container else {
        return Vec::new();
    };
    let map = &welded.vertex_of[0];
    faces
        .diagonals
        .iter()
        .map(|d| [map[d[0] as usize], map[d[1] as usize]])
        .collect()
}

/// The corners (welded ids) as chart-local ids.
fn local_corners(welded: [u32; 4], chart: &Chart, source: &ConstraintSource) -> Result<[u32; 4], Error> {
    let mut local = [0u32; 4];
    for k in 0..4 {
        local[k] = chart.local_of(welded[k]).ok_or_else(|| {
            source.corners_error(format!(
                "{} is not in the solved chart {}",
                crate::param::boundary::CORNER_NAMES[k],
                chart.id
            ))
        })?;
    }
    Ok(local)
}

impl PreparedChart {
    /// Whether `other` shares this chart's geometry (so its boundary map,
    /// bar-net factor and step-1 layout apply here too).
    pub fn same_geometry(&self, other: &PreparedChart) -> bool {
        Arc::ptr_eq(&self.filled, &other.filled)
    }

    /// The constraints (their indices) whose targets lie strictly inside
    /// a triangle of another chart's island kept in the set written: no
    /// one-to-one layout of this chart beside that island reaches them.
    pub fn targets_on_kept_islands(&self) -> Vec<usize> {
        let Some(free) = self.domain.free().filter(|f| f.island.is_some()) else {
            return Vec::new();
        };
        let o = &free.obstacles;
        self.constraints
            .iter()
            .filter(|c| {
                let t = uv_to_xy(c.target_uv);
                o.triangles
                    .iter()
                    .any(|tri| crate::injective::strictly_inside(t, tri.map(|v| o.layout[v as usize])))
            })
            .map(|c| c.index)
            .collect()
    }
}

/// The constraints (their indices) whose targets lie strictly inside a
/// triangle, as stored in the set, of a chart that holds no constraint:
/// its island is kept when the atlas is, so no one-to-one layout beside it
/// reaches them. `None` when the asset has no UVs in the set.
pub fn on_kept_islands(
    asset: &SourceAsset,
    welded: &WeldedMesh,
    constraints: &[ResolvedConstraint],
) -> Option<Vec<usize>> {
    if !asset.has_uvs() {
        return None;
    }
    let uvs = crate::domain::setup::welded_uvs(asset, welded);
    let mut landmarked = vec![false; welded.n_charts];
    for c in constraints {
        if let Some(k) = welded.chart_of_vertex[c.welded as usize] {
            landmarked[k as usize] = true;
        }
    }
    let kept: Vec<[DVec2; 3]> = welded
        .mesh
        .triangles
        .iter()
        .filter(|t| welded.chart_of_vertex[t[0] as usize].is_some_and(|k| !landmarked[k as usize]))
        .filter_map(|t| {
            let [a, b, c] = t.map(|v| uvs[v as usize]);
            Some([a?, b?, c?].map(|uv| DVec2::new(uv[0] as f64, uv[1] as f64)))
        })
        .collect();
    // The targets by u: each triangle tests those within its u span only.
    let mut by_u: Vec<&ResolvedConstraint> = constraints.iter().collect();
    by_u.sort_by(|a, b| a.target_uv.x.total_cmp(&b.target_uv.x));
    let mut on = vec![false; by_u.len()];
    for t in &kept {
        let (lo, hi) = t
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.x), h.max(p.x)));
        let first = by_u.partition_point(|c| c.target_uv.x <= lo);
        for (k, c) in by_u
            .iter()
            .enumerate()
            .skip(first)
            .take_while(|(_, c)| c.target_uv.x < hi)
        {
            on[k] |= crate::injective::strictly_inside(c.target_uv, *t);
        }
    }
    let mut indices: Vec<usize> = by_u
        .iter()
        .zip(&on)
        .filter(|(_, on)| **on)
        .map(|(c, _)| c.index)
        .collect();
    indices.sort_unstable();
    Some(indices)
}

/// Tolerance for a constraint on the outer boundary to agree with the boundary map.
pub const BOUNDARY_TOLERANCE: f64 = 1e-6;

/// Splits the constraints into those the spline moves and those on the outer
/// boundary, which must already sit on their targets.
///
/// # Errors
/// A constraint on the outer boundary whose target differs from where the
/// boundary map puts it.
pub fn step_problem(
    prepared: &PreparedChart,
    source: &ConstraintSource,
    boundary: &BoundaryMap,
    max_boundary_centres: usize,
) -> Result<StepProblem, Error> {
    let n = prepared.filled.mesh.n_vertices();
    let mut on_outer = vec![None; n];
    for (i, &v) in boundary.loop_vertices.iter().enumerate() {
        on_outer[v as usize] = Some(i);
    }
    let mut problem = StepProblem::default();
    if prepared.domain.free().is_some() {
        // A free boundary moves: every constraint is the spline's and every
        // vertex movable (hole centres too); the spline path first holds a
        // sample of the outer loop (as the square does), so its field stays
        // tame there, and lets it go if it stalls so (`ChartSolver`).
        for (c, &v) in prepared.constraints.iter().zip(&prepared.constraint_vertices) {
            problem.constraint_vertices.push(v);
            problem.targets.push(uv_to_xy(c.target_uv));
        }
        let anchors = pick_anchors(prepared.topology.outer_loop(), max_boundary_centres, &[]);
        problem.anchors = anchors
            .into_iter()
            .filter(|v| !problem.constraint_vertices.contains(v))
            .collect();
        problem.movable = (0..n as u32).collect();
        return Ok(problem);
    }
    for (c, &v) in prepared.constraints.iter().zip(&prepared.constraint_vertices) {
        let target = uv_to_xy(c.target_uv);
        match on_outer[v as usize] {
            Some(i) => {
                let at = boundary.positions[i];
                if at.distance(target) > BOUNDARY_TOLERANCE {
                    let uv = xy_to_uv(at);
                    return Err(source.error_at(
                        c.index,
                        source.target_field(c.index),
                        format!(
                            "vertex {} is on the outer boundary, which the boundary mapping places at ({:.6}, {:.6}); \
                             the target ({}, {}) contradicts it. Constrain an interior vertex, or make this vertex a corner",
                            c.vertex, uv.x, uv.y, c.target_uv.x, c.target_uv.y
                        ),
                    )
                    .into());
                }
            }
            None => {
                problem.constraint_vertices.push(v);
                problem.targets.push(target);
            }
        }
    }
    problem.anchors = pick_anchors(
        &boundary.loop_vertices,
        max_boundary_centres,
        &boundary.corner_vertices(),
    );
    problem.movable = (0..n as u32).filter(|&v| on_outer[v as usize].is_none()).collect();
    Ok(problem)
}

/// Texture coordinates per primitive of an asset (glTF's `TEXCOORD_0`, one per vertex).
pub type PrimitiveUvs = Vec<Vec<[f32; 2]>>;

/// How one layout point is stored, and what a vertex outside the chart keeps.
#[derive(Debug, Clone, Copy)]
struct Storage {
    /// A layout point as stored.
    store: fn(DVec2) -> [f32; 2],
    /// A vertex's old UV (glTF convention) as stored.
    keep: fn([f32; 2]) -> [f32; 2],
    /// A vertex outside the chart without UVs.
    missing: [f32; 2],
    /// OBJ's `vt` (an OBJ atlas's own values are kept as read).
    vt: bool,
}

const GLTF: Storage = Storage {
    store: guard::stored_uv,
    keep: |uv| uv,
    missing: [0.0, 0.0],
    vt: false,
};

const OBJ: Storage = Storage {
    store: guard::stored_vt,
    keep: |uv| [uv[0], 1.0 - uv[1]],
    missing: [0.0, 1.0],
    vt: true,
};

/// A laid-out chart: its triangles' corners take their UVs from `layout`.
#[derive(Debug, Clone, Copy)]
pub struct Part<'a> {
    pub chart: &'a Chart,
    /// Layout coordinates of the chart's vertices (at least its real ones).
    pub layout: &'a [DVec2],
    /// Triangles given twice: (welded triangle, chart triangle it copies).
    pub duplicates: &'a [(u32, u32)],
}

/// How laid-out parts fail to be one-to-one together ([`overlap_of`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartsOverlap {
    /// Part `k` crosses itself.
    Crosses(usize),
    /// Parts `a < b` overlap each other.
    Overlap(usize, usize),
}

impl std::fmt::Display for PartsOverlap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PartsOverlap::Crosses(k) => write!(f, "part {k} crosses itself"),
            PartsOverlap::Overlap(a, b) => write!(f, "parts {a} and {b} overlap"),
        }
    }
}

/// Where `parts` laid out together stop being one-to-one as stored (f32
/// texture coordinates): a part crossing itself or two parts overlapping
/// ([`crate::injective::atlas_overlaps`]); `None` when they are one-to-one.
pub fn overlap_of(parts: &[Part]) -> Option<PartsOverlap> {
    let (mut points, mut triangles, mut chart_of) = (Vec::new(), Vec::new(), Vec::new());
    for (k, part) in parts.iter().enumerate() {
        let base = points.len() as u32;
        let n = part.chart.mesh.n_vertices();
        points.extend(part.layout[..n].iter().map(|&p| {
            let uv = xy_to_uv(p);
            uv_to_xy(DVec2::new(f64::from(uv.x as f32), f64::from(uv.y as f32)))
        }));
        triangles.extend(part.chart.mesh.triangles.iter().map(|t| t.map(|v| v + base)));
        chart_of.extend(std::iter::repeat_n(k as u32, part.chart.mesh.n_triangles()));
    }
    let found = crate::injective::atlas_overlaps(&points, &triangles, &chart_of, parts.len(), 1);
    if let Some(k) = found.self_crossings.iter().position(|&n| n > 0) {
        return Some(PartsOverlap::Crosses(k));
    }
    found
        .overlapping
        .first()
        .map(|&(a, b)| PartsOverlap::Overlap(a as usize, b as usize))
}

impl PreparedChart {
    /// The solved chart with `layout` as a [`Part`].
    pub fn part<'a>(&'a self, layout: &'a [DVec2]) -> Part<'a> {
        Part {
            chart: &self.chart,
            layout,
            duplicates: &self.opening.duplicates,
        }
    }

    /// The chart's own triangles (not its hole fill) where `layout` puts
    /// them: obstacles of the charts laid out beside it.
    pub fn placed(&self, layout: &[DVec2]) -> Vec<[DVec2; 3]> {
        let f = &self.filled;
        f.mesh.triangles[..f.n_real_triangles]
            .iter()
            .map(|t| t.map(|v| layout[v as usize]))
            .collect()
    }

    /// How far a landmark's copy ends from its target when a seam or a
    /// separation runs through the landmark (its copies cannot all sit on
    /// the target): `None` when none does; infinite when a copy lies in a
    /// part laid out apart (the rest, packed elsewhere) or is not in
    /// `layout` (a coarse level that dropped it: `fine` holds the copies).
    pub fn landmark_copies_off(&self, layout: &[DVec2], fine: &PreparedChart) -> Option<f64> {
        let targets: std::collections::HashMap<u32, (u32, DVec2)> = self
            .constraints
            .iter()
            .zip(&self.constraint_vertices)
            .map(|(c, &v)| (self.chart.welded_ids[v as usize], (v, uv_to_xy(c.target_uv))))
            .collect();
        let mut off: Option<f64> = None;
        let mut worse = |d: f64| off = Some(off.map_or(d, |o| o.max(d)));
        for (u, w) in self.chart.welded_ids.iter().enumerate() {
            if let Some(&(v, target)) = targets.get(w)
                && v != u as u32
            {
                worse(layout.get(u).map_or(f64::INFINITY, |p| p.distance(target)));
            }
        }
        let copies = |chart: &Chart, w: u32| chart.welded_ids.iter().filter(|&&x| x == w).count();
        for &w in targets.keys() {
            let apart = fine.opening.rest.iter().any(|r| r.local_of(w).is_some());
            if apart || (copies(&fine.chart, w) > 1 && copies(&self.chart, w) == 1) {
                worse(f64::INFINITY);
            }
        }
        off
    }

    /// Texture length per mesh length of the chart laid out as `layout`
    /// (its texel density).
    pub fn density(&self, layout: &[DVec2]) -> f64 {
        let mesh = &self.chart.mesh;
        crate::metrics::texture_per_mesh_length(&mesh.positions, &layout[..mesh.n_vertices()], &mesh.triangles)
    }

    /// Where a camera's view puts the pieces after the `k`-th when the
    /// chart is made as the camera sees it (`form`): the room they are
    /// kept, so that no chart or piece laid out before them spreads over
    /// it. Empty for any other form.
    pub fn reserved_after(&self, form: Option<&Form>, k: usize) -> Vec<[DVec2; 3]> {
        let later = (k + 1).min(self.opening.pieces.len());
        seen_pieces(form, &self.opening.pieces[later..])
    }

    /// How another chart or piece holding landmarks is picked to be solved
    /// beside this one (`piece` of chart `id`, or chart `id` itself), free,
    /// clear of the `placed` triangles, at most at `density` without two
    /// targets; a piece is made as `form` says.
    pub fn pick_beside(
        &self,
        (id, piece): (u32, Option<Arc<Chart>>),
        form: Option<&Form>,
        placed: Vec<[DVec2; 3]>,
        density: Option<f64>,
    ) -> Pick {
        let mut replaced = vec![self.chart.id];
        replaced.extend(&self.secondary);
        Pick {
            chart: Some(id),
            placed: Arc::new(placed),
            replaced,
            form: piece.as_ref().and(form.cloned()),
            boundary: piece.as_ref().map(|_| crate::pins::BoundaryChoice::Free),
            piece,
            order: crate::domain::setup::Order::Beside(density),
        }
    }
}

/// Final UVs per face corner of every primitive (glTF texture coordinates,
/// f32): the laid-out `parts`' from their layouts (a vertex on a seam has
/// one per side), every other corner's as it was (or (0, 0) without UVs).
pub fn assemble_corner_uvs(asset: &SourceAsset, welded: &WeldedMesh, parts: &[Part]) -> Vec<CornerUvs> {
    assemble(asset, welded, parts, GLTF)
}

/// As [`assemble_corner_uvs`] in OBJ's `vt` convention (f32, v up) for
/// the single OBJ primitive; corners outside the parts get (0, 1), glTF's
/// (0, 0).
pub fn assemble_obj_corners(asset: &SourceAsset, welded: &WeldedMesh, parts: &[Part]) -> CornerUvs {
    assemble(asset, welded, parts, OBJ).swap_remove(0)
}

/// Final UVs per vertex of every primitive with `layout` on the solved
/// chart: as [`assemble_corner_uvs`], a vertex on a seam with its first
/// corner's UV (the library's and the editor's per-vertex view; files get
/// every side).
pub fn assemble_uvs(asset: &SourceAsset, prepared: &PreparedChart, layout: &[DVec2]) -> PrimitiveUvs {
    assemble_corner_uvs(asset, &prepared.welded, &[prepared.part(layout)])
        .iter()
        .zip(&asset.primitives)
        .map(|(c, prim)| {
            let mut uvs = c.split(&prim.indices).uvs;
            uvs.truncate(prim.positions.len());
            uvs
        })
        .collect()
}

/// The welded vertices of triangle `k` of `part`, sorted.
fn welded_corners(part: &Part, k: usize) -> [u32; 3] {
    let mut c = part.chart.mesh.triangles[k].map(|v| part.chart.welded_ids[v as usize]);
    c.sort_unstable();
    c
}

/// Every part's triangles by their welded corners (sorted).
fn by_corners(parts: &[Part]) -> std::collections::HashMap<[u32; 3], (u32, u32)> {
    let mut out = std::collections::HashMap::new();
    for (p, part) in parts.iter().enumerate() {
        for k in 0..part.chart.mesh.n_triangles() {
            out.entry(welded_corners(part, k)).or_insert((p as u32, k as u32));
        }
    }
    out
}

/// A triangle given twice takes its twin's corners in `from` (welded
/// triangle → part and triangle): a duplicate whose recorded triangle is
/// not over its corners (the part is a piece of the chart it was found in,
/// numbered anew), or one no part names. The parts' own triangles are over
/// their corners by construction and are not looked at.
fn give_twins(welded: &WeldedMesh, parts: &[Part], from: &mut [(u32, u32)]) {
    let corners = |w: usize| {
        let mut c = welded.mesh.triangles[w];
        c.sort_unstable();
        c
    };
    let over = |w: usize, (p, k): (u32, u32)| {
        let part = parts.get(p as usize);
        part.is_some_and(|part| {
            (k as usize) < part.chart.mesh.n_triangles() && welded_corners(part, k as usize) == corners(w)
        })
    };
    let duplicates = parts
        .iter()
        .flat_map(|part| part.duplicates.iter().map(|&(w, _)| w as usize));
    let unnamed = (0..from.len()).filter(|&w| from[w].0 == u32::MAX);
    let recheck: Vec<usize> = duplicates.chain(unnamed).filter(|&w| !over(w, from[w])).collect();
    if recheck.is_empty() {
        return;
    }
    let twins = by_corners(parts);
    for w in recheck {
        from[w] = twins.get(&corners(w)).copied().unwrap_or((u32::MAX, u32::MAX));
    }
}

fn assemble(asset: &SourceAsset, welded: &WeldedMesh, parts: &[Part], how: Storage) -> Vec<CornerUvs> {
    // An OBJ atlas's corners outside the parts keep their `vt` bits as read.
    let raw_vt = match &asset.container {
        crate::io::Container::Obj { faces, .. } if how.vt => faces.vt.as_deref(),
        _ => None,
    };
    // Welded triangle → (part, the part's triangle that gives its corners).
    let mut from = vec![(u32::MAX, u32::MAX); welded.mesh.n_triangles()];
    for (p, part) in parts.iter().enumerate() {
        for (k, &w) in part.chart.triangle_ids.iter().enumerate() {
            from[w as usize] = (p as u32, k as u32);
        }
        for &(w, k) in part.duplicates {
            from[w as usize] = (p as u32, k);
        }
    }
    give_twins(welded, parts, &mut from);
    // Welded vertex → the first part holding it and its first copy there
    // (one pass: a soup's thousands of pieces, each asked of every vertex,
    // took most of a solve).
    let mut holder: Vec<Option<(u32, u32)>> = vec![None; welded.mesh.n_vertices()];
    for (p, part) in parts.iter().enumerate() {
        for (l, &w) in part.chart.welded_ids.iter().enumerate() {
            holder[w as usize].get_or_insert((p as u32, l as u32));
        }
    }
    let mut first_triangle = 0usize;
    asset
        .primitives
        .iter()
        .zip(&welded.vertex_of)
        .map(|(prim, map)| {
            let old = |v: u32| match (raw_vt, &prim.uvs) {
                (Some(vt), _) => vt[v as usize],
                (None, Some(u)) => (how.keep)(u[v as usize]),
                (None, None) => how.missing,
            };
            let mut corners = Vec::with_capacity(prim.indices.len());
            for (j, t) in prim.indices.chunks_exact(3).enumerate() {
                let (p, k) = from[first_triangle + j];
                for &v in t {
                    corners.push(if p == u32::MAX {
                        old(v)
                    } else {
                        let part = &parts[p as usize];
                        let tri = part.chart.mesh.triangles[k as usize];
                        let w = map[v as usize];
                        let c = tri
                            .iter()
                            .find(|&&c| part.chart.welded_ids[c as usize] == w)
                            .expect("corner of its triangle");
                        (how.store)(part.layout[*c as usize])
                    });
                }
            }
            first_triangle += prim.indices.len() / 3;
            let unused = (0..prim.positions.len() as u32)
                .map(|v| {
                    holder[map[v as usize] as usize]
                        .map(|(p, l)| (how.store)(parts[p as usize].layout[l as usize]))
                        .unwrap_or_else(|| old(v))
                })
                .collect();
            CornerUvs { corners, unused }
        })
        .collect()
}

/// Orientation of the solved chart exactly as it will be stored, real and
/// virtual hole triangles: the worse of glTF's f32 texture coordinates and
/// OBJ's f32 `vt` (every accepted layout is clean in both).
pub fn written_orientation(prepared: &PreparedChart, layout: &[DVec2]) -> OrientationCounts {
    let triangles = &prepared.filled.mesh.triangles;
    let gltf: Vec<[f32; 2]> = layout.iter().map(|p| guard::stored_uv(*p)).collect();
    let obj: Vec<[f32; 2]> = layout.iter().map(|p| guard::stored_vt(*p)).collect();
    let a = guard::count_stored_orientations(&gltf, triangles, guard::VAxis::Down);
    let b = guard::count_stored_orientations(&obj, triangles, guard::VAxis::Up);
    if a.flipped + a.zero_area >= b.flipped + b.zero_area {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_landmark_a_seam_runs_through_has_a_copy_off_its_target() {
        let asset = SourceAsset::from_mesh(&crate::testing::uv_sphere(12, 18));
        let pins = crate::pins::Pins::new(&[(40, DVec2::new(0.5, 0.5))]);
        let mut prepared = prepare(&ConstraintSource::Memory(Arc::new(pins)), &asset).expect("the sphere, cut open");
        let ids = prepared.chart.welded_ids.clone();
        let split = (0..ids.len())
            .find(|&u| ids[u + 1..].contains(&ids[u]))
            .expect("a vertex the seam split");
        let copy = ids.iter().rposition(|&w| w == ids[split]).expect("its copy");
        let mut layout: Vec<DVec2> = (0..prepared.filled.mesh.n_vertices())
            .map(|k| DVec2::new(k as f64, (k * k) as f64) * 1e-3)
            .collect();
        assert_eq!(
            prepared.landmark_copies_off(&layout, &prepared),
            None,
            "the seam keeps clear of the landmark"
        );
        prepared.constraint_vertices[0] = split as u32;
        prepared.constraints[0].target_uv = xy_to_uv(layout[split]);
        let off = prepared.landmark_copies_off(&layout, &prepared).expect("a copy");
        assert!((off - layout[split].distance(layout[copy])).abs() < 1e-12, "{off}");
        layout[copy] = layout[split];
        let off = prepared.landmark_copies_off(&layout, &prepared).expect("a copy");
        assert!(off < 1e-12, "copies on the target: {off}");
    }

    #[test]
    fn a_cut_asked_of_a_chart_the_default_cut_shares_its_geometry() {
        let asset = SourceAsset::from_mesh(&crate::testing::uv_sphere(12, 18));
        let pins = crate::pins::Pins::new(&[(40, DVec2::new(0.5, 0.5))]);
        let source = ConstraintSource::Memory(Arc::new(pins));
        let base = prepare(&source, &asset).expect("the sphere, cut open");
        assert!(base.opening.seam.is_some(), "no disk: cut by default");
        let pick = |form| Pick {
            form: Some(form),
            ..Pick::default()
        };
        let cut = base.repicked(&source, &asset, &pick(Form::Cut)).expect("cut");
        assert!(
            Arc::ptr_eq(&base.filled, &cut.filled),
            "the default's cut, not made again"
        );
        assert!(Arc::ptr_eq(&base.opening, &cut.opening));
        // Taken as given, the sphere is no disk: nothing shared, an error.
        assert!(base.repicked(&source, &asset, &pick(Form::AsGiven)).is_err());
    }
}
