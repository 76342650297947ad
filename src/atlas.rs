//! Every triangle gets UVs: in a new UV set, the charts a solve does not
//! lay out with landmarks (the asset's other pieces, and pieces the solved
//! chart fell into when repaired) are unwrapped on their own, free and cut
//! as needed, and packed around the landmarked chart into the texture's
//! free space at one texel density, apart by the padding ([`crate::pack`]).
//! A piece that cannot be made a disk is laid out triangle by triangle,
//! each flat at its own 3D shape.

use crate::chart::{Opening, PreparedChart};
use crate::cut::prepare::make_solvable;
use crate::cut::{SeamRules, SeamSpec};
use crate::domain::Domain;
use crate::free::FreeSetup;
use crate::io::SourceAsset;
use crate::mesh::weld::Chart;
use crate::options::SolverOptions;
use crate::pack::{PackError, PackRules, Placement, Shape};
use crate::param::region::Region;
use glam::DVec2;
use std::sync::Arc;

/// A chart laid out on its own: its layout at its 3D scale.
#[derive(Debug, Clone)]
pub struct Unwrapped {
    /// The chart as laid out (vertices split where it was cut or repaired).
    pub chart: Arc<Chart>,
    /// Triangles given twice: (welded triangle left out, chart triangle).
    pub duplicates: Vec<(u32, u32)>,
    /// Its layout (layout coordinates), one mesh unit one layout unit.
    pub shape: Shape,
    /// Whether it was laid out triangle by triangle.
    pub soup: bool,
    /// The layout of the chart with its holes filled (virtual vertices
    /// after the real ones), at the scale of `shape`; empty for a soup.
    pub filled: Vec<DVec2>,
}

/// The charts of a solve beside the landmarked one, unwrapped.
#[derive(Debug, Clone, Default)]
pub struct Rest {
    pub charts: Vec<Unwrapped>,
}

/// A chart placed: the chart, its repeated triangles (welded triangle,
/// chart triangle) and its final layout (layout coordinates).
pub type PlacedChart = (Arc<Chart>, Vec<(u32, u32)>, Vec<DVec2>);

/// The rest placed: each chart's final layout.
#[derive(Debug, Clone, Default)]
pub struct PlacedRest {
    pub charts: Vec<PlacedChart>,
    /// The one scale of every packed chart (layout units per mesh unit).
    pub scale: f64,
}

impl PlacedRest {
    /// The solved chart with `layout` and these charts, as parts to assemble.
    pub fn parts<'a>(&'a self, prepared: &'a PreparedChart, layout: &'a [DVec2]) -> Vec<crate::chart::Part<'a>> {
        let mut parts = vec![prepared.part(layout)];
        parts.extend(
            self.charts
                .iter()
                .map(|(chart, duplicates, layout)| crate::chart::Part {
                    chart,
                    layout,
                    duplicates,
                }),
        );
        parts
    }
}

/// Whether each welded vertex has a stored UV in the asset's set.
fn has_uv(asset: &SourceAsset, prepared: &PreparedChart) -> Vec<bool> {
    let mut out = vec![false; prepared.welded.mesh.n_vertices()];
    for (prim, map) in asset.primitives.iter().zip(&prepared.welded.vertex_of) {
        if prim.uvs.is_some() {
            map.iter().for_each(|&w| out[w as usize] = true);
        }
    }
    out
}

/// The charts that need a layout beside `prepared`'s: its repair's other
/// pieces, and every other welded chart with a vertex that has no UV.
pub fn rest_charts(asset: &SourceAsset, prepared: &PreparedChart) -> Vec<Arc<Chart>> {
    let welded = &prepared.welded;
    let uv = has_uv(asset, prepared);
    let mut missing = vec![false; welded.n_charts];
    for (v, c) in welded.chart_of_vertex.iter().enumerate() {
        if let Some(c) = c
            && !uv[v]
        {
            missing[*c as usize] = true;
        }
    }
    let mut out = prepared.opening.rest.clone();
    let others: Vec<u32> = (0..welded.n_charts as u32)
        .filter(|&c| c != prepared.chart.id && missing[c as usize])
        .collect();
    out.extend(welded.charts(&others).into_iter().map(Arc::new));
    out
}

/// Unwraps every chart of `charts` (and the pieces their repairs split off).
pub fn unwrap_all(
    asset: &Arc<SourceAsset>,
    prepared: &PreparedChart,
    charts: Vec<Arc<Chart>>,
    options: &SolverOptions,
) -> Rest {
    let diagonals = crate::chart::polygon_diagonals(asset, &prepared.welded);
    let mut queue = charts;
    let mut out = Vec::new();
    while let Some(chart) = queue.pop() {
        let rules = SeamRules {
            spread_disks: true,
            ..SeamRules::DEFAULT
        };
        match make_solvable(
            &chart,
            Some(&crate::cut::prepare::Form::Cut),
            &SeamSpec::Auto,
            &[],
            &diagonals,
            &rules,
        ) {
            Ok(solvable) => {
                queue.extend(solvable.rest.iter().cloned().map(Arc::new));
                let opening = Opening::without_landmarks(&solvable);
                let unwrapped = free_layout(prepared, solvable.chart, solvable.topology, opening, options);
                out.push(unwrapped.unwrap_or_else(|chart| soup(&chart, SoupShape::Own)));
            }
            Err(_) => out.push(soup(&chart, SoupShape::Own)),
        }
    }
    Rest { charts: out }
}

/// The free, unconstrained layout of a solvable chart, at its 3D scale;
/// the chart back when it cannot be laid out one-to-one.
fn free_layout(
    prepared: &PreparedChart,
    chart: Chart,
    topology: crate::mesh::topology::Topology,
    opening: Opening,
    options: &SolverOptions,
) -> Result<Unwrapped, Box<Chart>> {
    let traps = crate::param::boundary::TrapCandidates::find(&chart.mesh, &topology);
    let filled = crate::param::bar_net::fill_holes(&chart.mesh, &topology);
    let duplicates = opening.duplicates.clone();
    let setup = FreeSetup::open_texture();
    let chart = Arc::new(chart);
    let piece = PreparedChart {
        welded: prepared.welded.clone(),
        chart: chart.clone(),
        topology: Arc::new(topology),
        traps: Arc::new(traps),
        filled: Arc::new(filled),
        constraints: Vec::new(),
        constraint_vertices: Vec::new(),
        corners: None,
        domain: Domain::Free(Arc::new(setup)),
        warnings: Vec::new(),
        opening: Arc::new(opening),
        secondary: Vec::new(),
        // Its domain is given: the share only decides a chart's region.
        rest_share: 0.0,
        whole: Region::TEXTURE,
    };
    let solver = crate::solver::own::solve(&piece, options).ok_or_else(|| Box::new((*chart).clone()))?;
    let clean = crate::guard::all_positive_as_stored(solver.layout(), &piece.filled.mesh.triangles)
        && solver
            .free()
            .is_some_and(|f| f.domain.room.admits(solver.layout()).is_ok());
    if !clean {
        return Err(Box::new((*chart).clone()));
    }
    let n = chart.mesh.n_vertices();
    let full = solver.layout();
    let k = mesh_scale(&chart, &full[..n]);
    Ok(Unwrapped {
        filled: full.iter().map(|&p| p * k).collect(),
        shape: Shape {
            points: full[..n].iter().map(|&p| p * k).collect(),
            triangles: chart.mesh.triangles.clone(),
        },
        chart,
        duplicates,
        soup: false,
    })
}

/// The free layout of `prepared`'s chart, cut as it is, without its
/// landmarks (the yardstick of the constrained layout's stretch); `None`
/// when it cannot be laid out one-to-one.
pub fn unconstrained(prepared: &PreparedChart, options: &SolverOptions) -> Option<Unwrapped> {
    let opening = Opening::clone(&prepared.opening);
    let topology = (*prepared.topology).clone();
    free_layout(prepared, (*prepared.chart).clone(), topology, opening, options).ok()
}

/// The factor that scales `layout` of `chart` to the chart's 3D area.
fn mesh_scale(chart: &Chart, layout: &[DVec2]) -> f64 {
    let area_2d: f64 = chart
        .mesh
        .triangles
        .iter()
        .map(|t| 0.5 * crate::guard::orientation(layout[t[0] as usize], layout[t[1] as usize], layout[t[2] as usize]))
        .sum();
    (chart.mesh.area() / area_2d.max(1e-300)).sqrt()
}

/// How a chart laid out triangle by triangle shapes each triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SoupShape {
    /// Flat at its 3D shape (texel density kept).
    Own,
    /// Equilateral, of its 3D area, its side at least the one given (mesh
    /// units, [`least_fat_side`]: a sliver, or a triangle whose corners
    /// meet): for triangles too thin to keep an area once packed and
    /// stored as f32. The texel density stays near the 3D one.
    Fat(f64),
}

/// `chart` laid out triangle by triangle: every corner its own vertex,
/// each triangle flat (see [`SoupShape`]), side by side on shelves about
/// as wide as the whole is tall (one long row would pack at a tiny scale).
pub fn soup(chart: &Chart, shape: SoupShape) -> Unwrapped {
    let wedges = crate::mesh::wedges::split_wedges(&chart.mesh, &|_| true);
    let opened = chart.opened(&wedges);
    let flat: Vec<[DVec2; 3]> = opened
        .mesh
        .triangles
        .iter()
        .map(|t| flat_triangle(t.map(|v| opened.mesh.positions[v as usize]), shape))
        .collect();
    let extent = |f: &[DVec2; 3]| f[1].max(f[2]) - f[0].min(f[2]);
    let area: f64 = flat.iter().map(|f| extent(f).x * extent(f).y).sum();
    let row_width = (1.3 * area).sqrt();
    let (mut x, mut y, mut row_height) = (0.0, 0.0, 0.0f64);
    let mut points = vec![DVec2::ZERO; opened.mesh.n_vertices()];
    for (t, f) in opened.mesh.triangles.iter().zip(&flat) {
        let (lo, size) = (f[0].min(f[2]), extent(f));
        if x > 0.0 && x + size.x > row_width {
            (x, y, row_height) = (0.0, y + row_height, 0.0);
        }
        for (k, &v) in t.iter().enumerate() {
            points[v as usize] = f[k] - lo + DVec2::new(x, y);
        }
        let gap = 0.1 * size.x.max(size.y);
        (x, row_height) = (x + size.x + gap, row_height.max(size.y + gap));
    }
    Unwrapped {
        shape: Shape {
            points,
            triangles: opened.mesh.triangles.clone(),
        },
        chart: Arc::new(opened),
        duplicates: Vec::new(),
        soup: true,
        filled: Vec::new(),
    }
}

/// The side of the equilateral triangle of the same area as `[a, b, c]`.
fn equal_area_side([a, b, c]: [glam::DVec3; 3]) -> f64 {
    let area = 0.5 * (b - a).cross(c - a).length();
    (area * 4.0 / 3.0f64.sqrt()).sqrt()
}

/// The side a fat triangle of `rest` has at least ([`SoupShape::Fat`]): a
/// quarter of the median longest side of its triangles (a CAD part's
/// slivers have little area but long sides), positive ones only (1 when
/// none is: every corner meets).
pub fn least_fat_side(rest: &Rest) -> f64 {
    let sides = rest.charts.iter().flat_map(|u| {
        let m = &u.chart.mesh;
        m.triangles.iter().map(|t| {
            let [a, b, c] = t.map(|v| m.positions[v as usize]);
            a.distance(b).max(b.distance(c)).max(c.distance(a))
        })
    });
    let mut positive: Vec<f64> = sides.filter(|s| *s > 0.0 && s.is_finite()).collect();
    if positive.is_empty() {
        return 1.0;
    }
    let middle = positive.len() / 2;
    0.25 * *positive.select_nth_unstable_by(middle, f64::total_cmp).1
}

/// A triangle of 3D corners `[a, b, c]` laid flat: `a` at the origin, `b`
/// along x, `c` above (counter-clockwise), at its own shape or fat.
fn flat_triangle([a, b, c]: [glam::DVec3; 3], shape: SoupShape) -> [DVec2; 3] {
    let (ab, ac) = (b - a, c - a);
    let len = ab.length().max(1e-12);
    match shape {
        SoupShape::Own => {
            let along = ac.dot(ab) / len;
            let up = (ac - ab * (along / len)).length().max(1e-9 * len);
            [DVec2::ZERO, DVec2::new(len, 0.0), DVec2::new(along, up)]
        }
        SoupShape::Fat(least) => {
            let side = equal_area_side([a, b, c]).max(least);
            [
                DVec2::ZERO,
                DVec2::new(side, 0.0),
                DVec2::new(0.5 * side, 0.75f64.sqrt() * side),
            ]
        }
    }
}

/// Packs `rest` around the `occupied` triangles (layout coordinates) into
/// `whole` (the texture, or the given region).
///
/// # Errors
/// No room left.
pub fn place(rest: &Rest, occupied: &[[DVec2; 3]], whole: Region, rules: &PackRules) -> Result<PlacedRest, PackError> {
    let shapes: Vec<Shape> = rest.charts.iter().map(|u| u.shape.clone()).collect();
    let placements: Vec<Placement> = crate::pack::pack(occupied, whole.layout_box(), &shapes, rules)?;
    let scale = placements.first().map_or(0.0, |p| p.scale);
    let charts = rest
        .charts
        .iter()
        .zip(&placements)
        .map(|(u, p)| {
            (
                u.chart.clone(),
                u.duplicates.clone(),
                u.shape.points.iter().map(|&q| p.apply(q)).collect(),
            )
        })
        .collect();
    Ok(PlacedRest { charts, scale })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Rng;

    /// A soup of random triangles: obtuse ones leaning back past their first
    /// corner, slivers, tiny and large ones.
    fn random_soup(rng: &mut Rng, n: usize) -> Chart {
        let mut positions = Vec::new();
        for _ in 0..n {
            let size = 10f64.powf(rng.range(-3.0, 1.0));
            let a = glam::DVec3::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0), rng.range(-5.0, 5.0));
            let b = a + glam::DVec3::X * size;
            let lean = rng.range(-3.0, 3.0) * size;
            let height = if rng.below(3) == 0 {
                1e-8 * size
            } else {
                rng.range(0.01, 2.0) * size
            };
            positions.extend([a, b, a + glam::DVec3::new(lean, height, 0.0)]);
        }
        let welded = crate::mesh::weld::weld(&[crate::mesh::weld::PrimitiveGeometry {
            index: 0,
            positions: positions.iter().map(|p| p.as_vec3().to_array()).collect(),
            indices: (0..positions.len() as u32).collect(),
            uvs: None,
        }]);
        let mut chart = welded.chart(0);
        for c in 1..welded.n_charts as u32 {
            let more = welded.chart(c);
            let base = chart.mesh.positions.len() as u32;
            chart.mesh.positions.extend(&more.mesh.positions);
            chart
                .mesh
                .triangles
                .extend(more.mesh.triangles.iter().map(|t| t.map(|v| v + base)));
            chart.welded_ids.extend(&more.welded_ids);
            chart.triangle_ids.extend(&more.triangle_ids);
        }
        chart
    }

    #[test]
    fn a_soup_lays_every_triangle_apart_and_the_right_way_round() {
        let mut rng = Rng::new(7);
        for n in [1, 2, 7, 60, 400] {
            let chart = random_soup(&mut rng, n);
            for shape in [SoupShape::Own, SoupShape::Fat(0.01)] {
                let u = soup(&chart, shape);
                let (points, triangles) = (&u.shape.points, &u.shape.triangles);
                assert!(crate::guard::all_positive(points, triangles), "{n} {shape:?}");
                let one_chart = vec![0u32; triangles.len()];
                let found = crate::injective::atlas_overlaps(points, triangles, &one_chart, 1, 10);
                assert_eq!(found.self_crossings, vec![0], "{n} {shape:?}");
                // Shelves: about as tall as wide, never one long row.
                let (lo, hi) = crate::injective::bounds(points);
                let size = hi - lo;
                assert!(n < 60 || size.x < 4.0 * size.y, "{n} {shape:?}: {size}");
                if shape != SoupShape::Own {
                    let thinnest = triangles
                        .iter()
                        .map(|t| {
                            let [a, b, c] = t.map(|v| points[v as usize]);
                            crate::guard::orientation(a, b, c) / (b - a).length_squared()
                        })
                        .fold(f64::INFINITY, f64::min);
                    assert!(thinnest > 0.8, "fat triangles: {thinnest}");
                }
            }
        }
    }
}
