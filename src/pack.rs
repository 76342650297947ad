//! Packing charts into the free space of a texture: every chart at one
//! common scale (the same texel density), each turned to its smallest
//! bounding box, placed where its box meets no occupied cell of a raster of
//! the texture. Occupied cells are marked conservatively (every cell a
//! triangle's bounding box touches) and grown by the padding, so charts in
//! disjoint cells cannot overlap, whatever the rounding to f32. The scale is
//! the largest that fits all (bisection).

use crate::injective::bounds;
use glam::DVec2;
use thiserror::Error;

/// A chart's layout at its own 3D scale (one layout unit is one mesh unit).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Shape {
    pub points: Vec<DVec2>,
    pub triangles: Vec<[u32; 3]>,
}

/// Where a packed chart goes: `p ↦ offset + scale · rotate(p)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// `(cos θ, sin θ)`.
    pub rotation: DVec2,
    pub scale: f64,
    pub offset: DVec2,
}

impl Placement {
    /// `p` placed.
    pub fn apply(&self, p: DVec2) -> DVec2 {
        self.offset + self.scale * self.rotation.rotate(p)
    }
}

/// How finely the texture is rastered, and the gap between charts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackRules {
    /// Cells across the region (default 256).
    pub cells: u32,
    /// Empty cells kept around every chart, at least 1 (default 2).
    pub padding_cells: u32,
}

impl PackRules {
    pub const DEFAULT: PackRules = PackRules {
        cells: 256,
        padding_cells: 2,
    };
}

#[derive(Debug, Error, Clone, PartialEq)]
pub enum PackError {
    #[error("no room left in the texture for {n_charts} more charts (the landmarked charts fill it)")]
    NoRoom { n_charts: usize },
}

/// A raster of the region's cells, `true` where occupied.
#[derive(Debug, Clone)]
struct Grid {
    n: usize,
    lo: DVec2,
    cell: DVec2,
    occupied: Vec<bool>,
}

impl Grid {
    fn new(lo: DVec2, hi: DVec2, n: usize) -> Self {
        Grid {
            n,
            lo,
            cell: (hi - lo) / n as f64,
            occupied: vec![false; n * n],
        }
    }

    /// The cells a box touches, clamped: `(x0, y0, x1, y1)` inclusive.
    fn cells_of(&self, lo: DVec2, hi: DVec2) -> (usize, usize, usize, usize) {
        let max = (self.n - 1) as f64;
        let a = ((lo - self.lo) / self.cell)
            .floor()
            .clamp(DVec2::ZERO, DVec2::splat(max));
        let b = ((hi - self.lo) / self.cell)
            .floor()
            .clamp(DVec2::ZERO, DVec2::splat(max));
        (a.x as usize, a.y as usize, b.x as usize, b.y as usize)
    }

    /// Marks every cell within `grow` cells of a triangle's bounding box;
    /// the cells marked, `(x0, y0, x1, y1)` inclusive.
    fn mark(&mut self, triangle: [DVec2; 3], grow: usize) -> Option<(usize, usize, usize, usize)> {
        let lo = triangle[0].min(triangle[1]).min(triangle[2]);
        let hi = triangle[0].max(triangle[1]).max(triangle[2]);
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let (x0, y0, x1, y1) = self.cells_of(lo, hi);
        let n = self.n;
        let (x0, y0, x1, y1) = (
            x0.saturating_sub(grow),
            y0.saturating_sub(grow),
            (x1 + grow).min(n - 1),
            (y1 + grow).min(n - 1),
        );
        for y in y0..=y1 {
            self.occupied[y * n + x0..=y * n + x1].fill(true);
        }
        Some((x0, y0, x1, y1))
    }

    /// Summed-area table of the occupied cells, `(n + 1)²`.
    fn summed(&self) -> Vec<u32> {
        let n = self.n;
        let mut s = vec![0u32; (n + 1) * (n + 1)];
        for y in 0..n {
            for x in 0..n {
                s[(y + 1) * (n + 1) + x + 1] =
                    u32::from(self.occupied[y * n + x]) + s[y * (n + 1) + x + 1] + s[(y + 1) * (n + 1) + x]
                        - s[y * (n + 1) + x];
            }
        }
        s
    }
}

/// Placements between rebuilds of [`Occupancy`]'s summed-area table at
/// least.
const REBUILD_EVERY: usize = 8;

/// What a placement asks of the grid: whether a box is free. A summed-area
/// table answers for the cells as they were at its last rebuild; the boxes
/// marked since are looked at one by one. Rebuilding the table after every
/// chart cost a full pass over the grid per chart (a rest of 1,400 pieces
/// took a minute to pack); it is rebuilt once looking at the boxes marked
/// since has cost as much as a rebuild (a soup of ten thousand pieces,
/// each found in a few looks, rebuilt it every eight placements for most
/// of its solve).
struct Occupancy {
    summed: Vec<u32>,
    recent: Vec<(usize, usize, usize, usize)>,
    /// Boxes looked at since the last rebuild.
    looked: std::cell::Cell<usize>,
}

impl Occupancy {
    fn new(grid: &Grid) -> Self {
        Occupancy {
            summed: grid.summed(),
            recent: Vec::new(),
            looked: std::cell::Cell::new(0),
        }
    }

    /// Whether no cell of the `w × h` box at `(x, y)` is occupied.
    fn is_free(&self, grid: &Grid, (x, y): (usize, usize), (w, h): (usize, usize)) -> bool {
        let n = grid.n;
        self.looked.set(self.looked.get() + self.recent.len());
        occupied_in(&self.summed, n, (x, y), (w, h)) == 0
            && self.recent.iter().all(|&(x0, y0, x1, y1)| {
                let (ax, bx) = (x.max(x0), (x + w).min(x1 + 1));
                let (ay, by) = (y.max(y0), (y + h).min(y1 + 1));
                ax >= bx || ay >= by || (ay..by).all(|r| !grid.occupied[r * n + ax..r * n + bx].contains(&true))
            })
    }

    /// `cells` were marked in `grid`.
    fn marked(&mut self, grid: &Grid, cells: (usize, usize, usize, usize)) {
        self.recent.push(cells);
        let rebuild = grid.n * grid.n;
        if self.recent.len() >= REBUILD_EVERY && (self.looked.get() >= rebuild || self.recent.len() >= grid.n) {
            self.summed = grid.summed();
            self.recent.clear();
            self.looked.set(0);
        }
    }
}

/// Occupied cells in the `w × h` box at `(x, y)`.
fn occupied_in(s: &[u32], n: usize, (x, y): (usize, usize), (w, h): (usize, usize)) -> u32 {
    let at = |x: usize, y: usize| s[y * (n + 1) + x];
    at(x + w, y + h) + at(x, y) - at(x + w, y) - at(x, y + h)
}

/// A shape turned to its smallest bounding box (of 32 turns over a half
/// turn), moved so the box starts at the origin; the turn and the box size.
fn turned(shape: &Shape) -> (DVec2, DVec2, DVec2) {
    let best = (0..32)
        .map(|k| DVec2::from_angle(std::f64::consts::PI * k as f64 / 32.0))
        .map(|r| {
            let (lo, hi) = bounds(shape.points.iter().map(|&p| r.rotate(p)));
            let size = hi - lo;
            (r, lo, size)
        })
        .min_by(|a, b| (a.2.x * a.2.y).total_cmp(&(b.2.x * b.2.y)))
        .expect("turns");
    (best.0, best.1, best.2)
}

/// Packs `shapes` into the box `lo..hi` (layout coordinates) around the
/// `occupied` triangles; one placement per shape, all at one scale.
///
/// # Errors
/// The charts do not fit at any scale worth having (the occupied triangles
/// leave no room).
pub fn pack(
    occupied: &[[DVec2; 3]],
    (lo, hi): (DVec2, DVec2),
    shapes: &[Shape],
    rules: &PackRules,
) -> Result<Vec<Placement>, PackError> {
    if shapes.is_empty() {
        return Ok(Vec::new());
    }
    // A full texture leaves room in slivers a coarse raster cannot see:
    // finer rasters with the least padding before giving up.
    let n = rules.cells.max(8) as usize;
    let finer = [(n, rules.padding_cells.max(1) as usize), (2 * n, 1), (4 * n, 1)];
    finer
        .into_iter()
        .find_map(|(n, pad)| pack_on(occupied, (lo, hi), shapes, n, pad))
        .ok_or(PackError::NoRoom { n_charts: shapes.len() })
}

/// The scale, relative to the largest the free area allows, at which a
/// raster is first asked whether the charts fit at all: the search's own
/// floor (24 halvings).
const SMALLEST: f64 = 1.0 / (1u32 << 23) as f64;

/// The search for the largest scale stops within this share of it.
const PRECISION: f64 = 0.03;

/// [`pack`] on an `n × n` raster with `pad` cells around every chart.
fn pack_on(
    occupied: &[[DVec2; 3]],
    (lo, hi): (DVec2, DVec2),
    shapes: &[Shape],
    n: usize,
    pad: usize,
) -> Option<Vec<Placement>> {
    let mut base = Grid::new(lo, hi, n);
    for t in occupied {
        base.mark(*t, pad);
    }
    let turns: Vec<(DVec2, DVec2, DVec2)> = shapes.iter().map(turned).collect();
    let mut order: Vec<usize> = (0..shapes.len()).collect();
    order.sort_by(|&a, &b| {
        (turns[b].2.x * turns[b].2.y)
            .total_cmp(&(turns[a].2.x * turns[a].2.y))
            .then(a.cmp(&b))
    });
    let free = base.occupied.iter().filter(|&&o| !o).count() as f64 * base.cell.x * base.cell.y;
    let total: f64 = turns.iter().map(|t| t.2.x * t.2.y).sum::<f64>().max(1e-300);
    let (mut low, mut high) = (0.0, (free / total).sqrt());
    let mut best: Option<Vec<Placement>> = None;
    for k in 0..24 {
        let scale = if k == 0 { high } else { 0.5 * (low + high) };
        match try_pack(&base, shapes, &turns, &order, scale, pad) {
            Some(placed) => {
                best = Some(placed);
                low = scale;
            }
            // Charts too many for this raster's cells fit at no scale: a
            // finer raster is tried at once, not after a search down to
            // nothing.
            None if k == 0 => {
                best = Some(try_pack(&base, shapes, &turns, &order, SMALLEST * high, pad)?);
                (low, high) = (SMALLEST * high, scale);
            }
            None => high = scale,
        }
        if best.is_some() && high - low < PRECISION * high {
            break;
        }
    }
    best
}

/// The cells a shape covers once placed with its box's corner at the
/// origin: per row of its box, the first and last cell covered (`None`
/// for an empty row), conservative like [`Grid::mark`].
fn row_spans(
    shape: &Shape,
    rotation: DVec2,
    box_lo: DVec2,
    scale: f64,
    cell: DVec2,
    (w, h): (usize, usize),
) -> Vec<Option<(usize, usize)>> {
    let mut spans: Vec<Option<(usize, usize)>> = vec![None; h];
    let at = |p: DVec2| (scale * (rotation.rotate(p) - box_lo)) / cell + DVec2::ONE;
    for t in &shape.triangles {
        let [a, b, c] = t.map(|v| at(shape.points[v as usize]));
        let (lo, hi) = (a.min(b).min(c).floor(), a.max(b).max(c).floor());
        let (x0, x1) = (lo.x.max(0.0) as usize, (hi.x as usize).min(w - 1));
        for row in spans
            .iter_mut()
            .take((hi.y as usize).min(h - 1) + 1)
            .skip(lo.y.max(0.0) as usize)
        {
            *row = Some(row.map_or((x0, x1), |(p, q)| (p.min(x0), q.max(x1))));
        }
    }
    spans
}

/// A shape's cells at one scale: its box and the cells of each row.
type Cells = (usize, usize, Vec<Option<(usize, usize)>>);

/// Every shape placed at `scale`, or `None` if one does not fit.
fn try_pack(
    base: &Grid,
    shapes: &[Shape],
    turns: &[(DVec2, DVec2, DVec2)],
    order: &[usize],
    scale: f64,
    pad: usize,
) -> Option<Vec<Placement>> {
    let mut grid = base.clone();
    let mut occupancy = Occupancy::new(&grid);
    let mut first_row = 0;
    let mut placed = vec![None; shapes.len()];
    // Where the last shape with the same cells was placed: every spot
    // before it was refused to that shape, and the grid only fills, so an
    // identical shape (a soup's repeated parts) is looked for from there.
    let mut resume: std::collections::HashMap<Cells, (usize, usize)> = std::collections::HashMap::new();
    for &i in order {
        let (rotation, box_lo, size) = turns[i];
        // The box in cells, one more each way for rounding.
        let w = ((size.x * scale) / grid.cell.x).ceil() as usize + 2;
        let h = ((size.y * scale) / grid.cell.y).ceil() as usize + 2;
        if w > grid.n || h > grid.n {
            return None;
        }
        let spans = row_spans(&shapes[i], rotation, box_lo, scale, grid.cell, (w, h));
        let n = grid.n;
        // Where the whole box is free, or else where every row of the
        // shape's own cells (grown a cell each way) is.
        let fits = |(x, y): (usize, usize)| {
            occupancy.is_free(&grid, (x, y), (w, h))
                || spans.iter().enumerate().all(|(r, span)| {
                    span.is_none_or(|(a, b)| {
                        let (a, b) = (a.saturating_sub(1), (b + 1).min(w - 1));
                        let (r0, r1) = (r.saturating_sub(1), (r + 1).min(h - 1));
                        occupancy.is_free(&grid, (x + a, y + r0), (b - a + 1, r1 - r0 + 1))
                    })
                })
        };
        // Rows filled from end to end hold no box: the search starts below them.
        while first_row < n && !grid.occupied[first_row * n..(first_row + 1) * n].contains(&false) {
            first_row += 1;
        }
        let key = (w, h, spans.clone());
        let from = resume.get(&key).copied().unwrap_or((0, 0));
        let spot = (first_row.max(from.1)..=n.checked_sub(h)?)
            .flat_map(|y| (if y == from.1 { from.0 } else { 0 }..=n - w).map(move |x| (x, y)))
            .find(|&at| fits(at))?;
        resume.insert(key, spot);
        let corner = grid.lo + DVec2::new((spot.0 + 1) as f64 * grid.cell.x, (spot.1 + 1) as f64 * grid.cell.y);
        let placement = Placement {
            rotation,
            scale,
            offset: corner - scale * box_lo,
        };
        let mut cells: Option<(usize, usize, usize, usize)> = None;
        for t in &shapes[i].triangles {
            let marked = grid.mark(t.map(|v| placement.apply(shapes[i].points[v as usize])), pad);
            cells = match (cells, marked) {
                (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.min(b.1), a.2.max(b.2), a.3.max(b.3))),
                (a, b) => a.or(b),
            };
        }
        if let Some(cells) = cells {
            occupancy.marked(&grid, cells);
        }
        placed[i] = Some(placement);
    }
    placed.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(side: f64) -> Shape {
        Shape {
            points: vec![
                DVec2::ZERO,
                DVec2::new(side, 0.0),
                DVec2::new(side, side),
                DVec2::new(0.0, side),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    fn placed_triangles(shapes: &[Shape], placements: &[Placement]) -> Vec<[DVec2; 3]> {
        shapes
            .iter()
            .zip(placements)
            .flat_map(|(s, p)| {
                s.triangles
                    .iter()
                    .map(move |t| t.map(|v| p.apply(s.points[v as usize])))
            })
            .collect()
    }

    #[test]
    fn charts_go_around_what_is_there_apart_and_inside() {
        // The left half of the texture is taken.
        let taken = [
            [DVec2::ZERO, DVec2::new(0.5, 0.0), DVec2::new(0.5, 1.0)],
            [DVec2::ZERO, DVec2::new(0.5, 1.0), DVec2::new(0.0, 1.0)],
        ];
        let shapes = vec![square(2.0), square(1.0), square(1.0)];
        let placements = pack(&taken, (DVec2::ZERO, DVec2::ONE), &shapes, &PackRules::DEFAULT).unwrap();
        let scale = placements[0].scale;
        assert!(placements.iter().all(|p| p.scale == scale), "one texel density");
        let tris = placed_triangles(&shapes, &placements);
        for t in &tris {
            for p in t {
                assert!(p.x > 0.5 && p.x < 1.0 && p.y > 0.0 && p.y < 1.0, "{p}");
            }
        }
        // Boxes of different charts do not meet.
        let boxes: Vec<(DVec2, DVec2)> = shapes
            .iter()
            .zip(&placements)
            .map(|(s, p)| bounds(s.points.iter().map(|&q| p.apply(q))))
            .collect();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (boxes[i], boxes[j]);
                let apart = a.1.x < b.0.x || b.1.x < a.0.x || a.1.y < b.0.y || b.1.y < a.0.y;
                assert!(apart, "{a:?} {b:?}");
            }
        }
        // Most of the free half is used.
        let used: f64 = shapes.iter().map(|s| 0.0 + s.points[2].x * s.points[2].y).sum::<f64>() * scale * scale;
        assert!(used > 0.2, "{used}");
    }

    #[test]
    fn many_equal_charts_fill_the_texture_apart() {
        // A soup's repeated parts: each looked for from where the last
        // equal one went, each between two rebuilds of the table.
        let shapes: Vec<Shape> = (0..600).map(|k| square(if k % 3 == 0 { 1.0 } else { 0.5 })).collect();
        let placements = pack(&[], (DVec2::ZERO, DVec2::ONE), &shapes, &PackRules::DEFAULT).unwrap();
        let boxes: Vec<(DVec2, DVec2)> = shapes
            .iter()
            .zip(&placements)
            .map(|(s, p)| bounds(s.points.iter().map(|&q| p.apply(q))))
            .collect();
        let mut by_x: Vec<usize> = (0..boxes.len()).collect();
        by_x.sort_by(|&i, &j| boxes[i].0.x.total_cmp(&boxes[j].0.x));
        for (k, &i) in by_x.iter().enumerate() {
            for &j in by_x[k + 1..].iter().take_while(|&&j| boxes[j].0.x <= boxes[i].1.x) {
                let (a, b) = (boxes[i], boxes[j]);
                let apart = a.1.x < b.0.x || a.1.y < b.0.y || b.1.y < a.0.y;
                assert!(apart, "charts {i} and {j}: {a:?} {b:?}");
            }
        }
        let used: f64 = shapes.iter().map(|s| s.points[2].x * s.points[2].y).sum::<f64>();
        let scale = placements[0].scale;
        assert!(used * scale * scale > 0.4, "{}", used * scale * scale);
    }

    #[test]
    fn a_full_texture_leaves_no_room() {
        let full = [
            [DVec2::ZERO, DVec2::new(2.0, 0.0), DVec2::new(0.0, 2.0)],
            [DVec2::new(1.0, -1.0), DVec2::new(1.0, 2.0), DVec2::new(-1.0, 2.0)],
        ];
        assert!(pack(&full, (DVec2::ZERO, DVec2::ONE), &[square(1.0)], &PackRules::DEFAULT).is_err());
    }

    #[test]
    fn a_long_chart_is_turned_to_its_smallest_box() {
        let long = Shape {
            points: vec![DVec2::ZERO, DVec2::new(1.0, 1.0), DVec2::new(0.9, 1.1)],
            triangles: vec![[0, 1, 2]],
        };
        let (_, _, size) = turned(&long);
        assert!(size.x * size.y < 0.21, "turned from a 1 × 1.1 box: {size}");
    }
}
