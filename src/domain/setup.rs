//! How a chart's boundary is laid out, decided from the constraint file's
//! `boundary` and `region` and from the UVs the asset already has: a chart
//! that has UVs stays free inside its own island unless told otherwise.

use super::Domain;
use crate::constraints::ConstraintSource;
use crate::cut::prepare::Form;
use crate::error::Error;
use crate::free::{FreeSetup, Obstacles, RegionSource};
use crate::io::SourceAsset;
use crate::mesh::weld::{Chart, WeldedMesh};
use crate::param::region::{MIN_REGION_SIDE, Region};
use crate::pins::{BoundaryChoice, ResolvedConstraint};
use glam::DVec2;
use std::sync::Arc;

/// Which chart to prepare, and what this solve has laid out around it.
#[derive(Debug, Clone, Default)]
pub struct Pick {
    /// The chart (default: the one holding the most constraints, or the
    /// largest without any); only its constraints are solved with it.
    pub chart: Option<u32>,
    /// Triangles this solve has laid out already (layout coordinates):
    /// obstacles of a free chart.
    pub placed: Arc<Vec<[DVec2; 3]>>,
    /// Charts whose stored UVs this solve replaces: not obstacles.
    pub replaced: Vec<u32>,
    /// How the chart is made a disk (`None`: as given when it is one,
    /// else cut open).
    pub form: Option<Form>,
    /// The boundary when the constraint file names none and gives no
    /// region (`None`: the default, [`decide`]).
    pub boundary: Option<BoundaryChoice>,
    /// A piece of chart `chart` holding landmarks, split off another
    /// solve's chart ([`crate::chart::Opening::pieces`]): solved with its own landmarks
    /// instead of the whole chart.
    pub piece: Option<Arc<Chart>>,
    /// The solve's first chart, or one solved beside it.
    pub order: Order,
}

/// Whether a chart is the solve's first or one solved beside it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Order {
    /// The first chart: it leaves a strip for the rest.
    #[default]
    First,
    /// A piece or chart solved beside the first: it leaves no strip for
    /// the rest, and one with fewer than two targets is laid out at most
    /// at the first chart's texel density (texture length per mesh
    /// length; `None` when that has no finite value).
    Beside(Option<f64>),
}

impl Order {
    /// The texel density a chart beside the first is held to.
    pub fn density(self) -> Option<f64> {
        match self {
            Order::First => None,
            Order::Beside(density) => density,
        }
    }
}

/// At most this many constraints are paired for [`photo_scale`].
const SCALE_SAMPLE: usize = 64;

/// Texture length per mesh length that the file's targets give the mesh:
/// the median over pairs of constraints (`all` of them, the first
/// `SCALE_SAMPLE`) of their targets' distance over their vertices'.
/// `None` with fewer than two constraints apart.
pub fn photo_scale(all: &[ResolvedConstraint], welded: &WeldedMesh) -> Option<f64> {
    let all = &all[..all.len().min(SCALE_SAMPLE)];
    let at = |c: &ResolvedConstraint| welded.mesh.positions[c.welded as usize];
    let mut ratios: Vec<f64> = (0..all.len())
        .flat_map(|i| (i + 1..all.len()).map(move |j| (i, j)))
        .filter_map(|(i, j)| {
            let d = at(&all[i]).distance(at(&all[j]));
            let r = all[i].target_uv.distance(all[j].target_uv) / d;
            (r.is_finite() && r > 0.0).then_some(r)
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    ratios.get(ratios.len() / 2).copied()
}

/// How far an island's region is grown past a target outside it, relative
/// to the region's size: a target on the border could not be reached (the
/// region is open).
const GROWTH_MARGIN: f64 = 0.01;

/// The boundary setup of `chart`: `Square` when asked for (or when the
/// chart has no UVs and no region is given), else free inside the given
/// region, the texture, or the chart's island, with every other chart that
/// has UVs as an obstacle. A free chart with fewer than two targets is
/// held to `photo_scale` ([`photo_scale`]), else to the pick's density.
///
/// # Errors
/// A region that is not a rectangle, or a target outside it (located at
/// the `region` field or the constraint).
pub fn decide(
    source: &ConstraintSource,
    asset: &SourceAsset,
    welded: &WeldedMesh,
    chart: &Chart,
    constraints: &[ResolvedConstraint],
    (cut, rest_share, photo_scale): (bool, f64, Option<f64>),
    pick: &Pick,
) -> Result<Domain, Error> {
    let (choice, given) = source.boundary();
    // The solve's own choice stands where the file makes none.
    let choice = choice.or(pick.boundary.filter(|_| given.is_none()));
    let facing = matches!(pick.form, Some(Form::Facing { .. }));
    // A chart solved beside a first one leaves no strip for the rest: the
    // rest is packed around them all, and the strip would cut its room
    // short of the size the targets give it.
    let strip = if pick.order == Order::First { rest_share } else { 0.0 };
    let uvs = welded_uvs(asset, welded);
    let island: Option<Vec<DVec2>> = chart
        .welded_ids
        .iter()
        .map(|&w| uvs[w as usize].map(|[u, v]| DVec2::new(u as f64, 1.0 - v as f64)))
        .collect();
    let on_square = || {
        for c in constraints {
            let t = c.target_uv;
            if !(t.x >= 0.0 && t.x <= 1.0 && t.y >= 0.0 && t.y <= 1.0) {
                return Err(source.error_at(
                    c.index,
                    source.target_field(c.index),
                    format!(
                        "target ({}, {}) in texture coordinates is outside the unit square [0, 1] × [0, 1], where the \
                         square boundary lays the chart out",
                        t.x, t.y
                    ),
                ));
            }
        }
        Ok(Domain::Square)
    };
    let (region, source_kind) = match (choice, given) {
        (Some(BoundaryChoice::Square), _) => return Ok(on_square()?),
        (_, Some(region)) => (leave_room(region, constraints, strip), RegionSource::Given),
        // A chart as the camera sees it keeps the place the targets give it.
        (_, None) if facing => (Region::TEXTURE, RegionSource::Texture),
        (Some(BoundaryChoice::Free), None) => (leave_room(Region::TEXTURE, constraints, strip), RegionSource::Texture),
        (None, None) => match &island {
            Some(layout) if !cut => (island_region(layout, constraints), RegionSource::Island),
            // A chart cut open has no shape a square would suit, and one
            // that shares the texture with charts laid out beside it
            // cannot fill it: free in the texture.
            _ if cut || rest_share > 0.0 => (leave_room(Region::TEXTURE, constraints, strip), RegionSource::Texture),
            _ => return Ok(on_square()?),
        },
    };
    if let Some(problem) = region.problem() {
        return Err(source.region_error(problem).into());
    }
    for c in constraints {
        let t = c.target_uv;
        let inside = t.cmpgt(region.min).all() && t.cmplt(region.max).all();
        if !inside {
            return Err(source.error_at(
                c.index,
                source.target_field(c.index),
                format!(
                    "target ({}, {}) is not inside the region u {}..{}, v {}..{} (a free chart stays strictly inside it)",
                    t.x, t.y, region.min.x, region.max.x, region.min.y, region.max.y
                ),
            )
            .into());
        }
    }
    let obstacles = other_islands(welded, chart.id, &uvs, region, pick);
    // Without two targets of its own, the scale the file's targets give
    // all the mesh (a photo's), else the first chart's.
    let density = (constraints.len() < 2)
        .then_some(photo_scale)
        .flatten()
        .or(pick.order.density());
    Ok(Domain::Free(Arc::new(FreeSetup {
        region,
        source: source_kind,
        obstacles: Arc::new(obstacles),
        island,
        given: None,
        density,
    })))
}

/// `whole` (the texture, or the given region) less a strip along one side
/// for the charts packed beside this one, as wide as their share of the
/// surface (at most half), on the side the targets leave most room on;
/// all of it without them.
fn leave_room(whole: Region, constraints: &[ResolvedConstraint], share: f64) -> Region {
    if share <= 0.0 {
        return whole;
    }
    let size = whole.max - whole.min;
    let margin = 0.02;
    let (lo, hi) = constraints
        .iter()
        .fold((DVec2::splat(1.0), DVec2::splat(0.0)), |(lo, hi), c| {
            let t = (c.target_uv - whole.min) / size;
            (lo.min(t), hi.max(t))
        });
    // Room past the targets on each side: left, top, right, bottom (shares of `whole`).
    let gaps = [lo.x, lo.y, 1.0 - hi.x, 1.0 - hi.y].map(|g| (g - margin).max(0.0));
    let (side, gap) = gaps
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(k, &g)| (k, g))
        .expect("four sides");
    let width = share.clamp(0.05, 0.5).min(gap);
    if width < 0.03 {
        return whole;
    }
    let mut r = whole;
    match side {
        0 => r.min.x += width * size.x,
        1 => r.min.y += width * size.y,
        2 => r.max.x -= width * size.x,
        _ => r.max.y -= width * size.y,
    }
    r
}

/// Each welded vertex's stored UV (glTF convention), if its primitive has them.
pub fn welded_uvs(asset: &SourceAsset, welded: &WeldedMesh) -> Vec<Option<[f32; 2]>> {
    let mut out = vec![None; welded.mesh.n_vertices()];
    for (prim, map) in asset.primitives.iter().zip(&welded.vertex_of) {
        if let Some(uvs) = &prim.uvs {
            for (i, &w) in map.iter().enumerate() {
                out[w as usize] = Some(uvs[i]);
            }
        }
    }
    out
}

/// The island's bounding rectangle (texture coordinates), grown past any
/// target outside it by [`GROWTH_MARGIN`] of its size.
fn island_region(layout: &[DVec2], constraints: &[ResolvedConstraint]) -> Region {
    let uv = |p: &DVec2| DVec2::new(p.x, 1.0 - p.y);
    let bounds = Region::bounding(layout.iter().map(uv)).unwrap_or(Region::TEXTURE);
    let grown = bounds.grown_to(constraints.iter().map(|c| c.target_uv));
    let pad = GROWTH_MARGIN * (grown.max - grown.min).max(DVec2::splat(MIN_REGION_SIDE));
    let mut region = grown;
    // Pad only the sides a target pushed out (or sits on).
    for k in 0..2 {
        if grown.min[k] < bounds.min[k] || constraints.iter().any(|c| c.target_uv[k] <= bounds.min[k]) {
            region.min[k] = grown.min[k] - pad[k];
        }
        if grown.max[k] > bounds.max[k] || constraints.iter().any(|c| c.target_uv[k] >= bounds.max[k]) {
            region.max[k] = grown.max[k] + pad[k];
        }
    }
    region
}

/// Every other chart's triangles that have UVs (but those `pick` says this
/// solve replaces), and the triangles it has laid out already, near
/// `region`.
fn other_islands(welded: &WeldedMesh, chart: u32, uvs: &[Option<[f32; 2]>], region: Region, pick: &Pick) -> Obstacles {
    let mut stored: Vec<[f32; 2]> = uvs.iter().map(|u| u.unwrap_or([0.0, 0.0])).collect();
    let mut triangles: Vec<[u32; 3]> = welded
        .mesh
        .triangles
        .iter()
        .filter(|t| {
            let c = welded.chart_of_vertex[t[0] as usize];
            c != Some(chart)
                && !c.is_some_and(|c| pick.replaced.contains(&c))
                && t.iter().all(|&v| uvs[v as usize].is_some())
        })
        .copied()
        .collect();
    for t in pick.placed.iter() {
        let first = stored.len() as u32;
        stored.extend(t.iter().map(|&p| crate::guard::stored_uv(p)));
        triangles.push([first, first + 1, first + 2]);
    }
    Obstacles::new(&stored, &triangles, region)
}
