//! What a camera sees one-to-one: a disk grown from the landmarks over the
//! triangles whose projection keeps the view an embedding. Where the whole
//! view of a part folds over itself (a CAD part's slivers and bores, a
//! wall seen behind a rim, holes that are not star-shaped in projection),
//! the part of it that a disk reaches without overlapping itself is still a
//! chart whose projection is a fold-free layout with every landmark where
//! the camera puts it, near its target: the free solve's start
//! ([`super::facing`], Eq. 6 closes the rest).
//!
//! The disk grows nearest surface first, one polygon of the file at a
//! time (never split), taking a polygon only when its projection is turned
//! towards the camera, inside the room and overlaps nothing taken or
//! held for a landmark, and only when it meets the disk along one path of
//! edges (so the disk stays a disk: no hole is closed, no pinch made). The
//! triangles around every landmark are one unit, taken whatever their
//! projection (a landmark is never on a seam). A landmark the first disk
//! does not reach starts a disk of its own, kept a gap from the others:
//! each is a piece of its own, solved beside the first.

use super::graph::{EdgeGraph, NONE};
use crate::mesh::TriMesh;
use crate::mesh::topology::UnionFind;
use glam::{DVec2, DVec3};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// A triangle is taken only when its projection keeps this share of its
/// area (the cosine of its turn from the camera): a wall seen edge-on is
/// left out, its projection crushed.
const MIN_TURN: f64 = 0.1;

/// The grid cells hold about this many triangles each.
const PER_CELL: f64 = 2.0;

/// The grid has at most this many cells a side.
const MAX_CELLS: usize = 1024;

/// What the grown disk needs to know of the mesh and the view.
pub struct View<'a> {
    pub mesh: &'a TriMesh,
    pub graph: &'a EdgeGraph,
    /// Each vertex where the camera sees it.
    pub projected: &'a [DVec2],
    /// The unit direction towards the camera.
    pub towards: DVec3,
    /// Whether each triangle is projected inside the room.
    pub within: &'a [bool],
    /// The least distance kept between two disks' projections.
    pub gap: f64,
}

/// The disks of triangles grown from the landmarks (see the module doc),
/// never across an `unseamable` edge (sorted pairs) from one side to the
/// other: one from the first landmark, then one from each landmark the
/// disks before did not reach, none touching another. The triangles
/// around the landmarks' other `copies` (where the file's sheets meet) are
/// taken first where they fit. `None` when a landmark's triangles are left out.
pub fn grown_region(view: &View, (landmarks, copies): (&[u32], &[u32]), unseamable: &[[u32; 2]]) -> Option<Vec<bool>> {
    let (units, forced) = landmark_units(view, unseamable, landmarks);
    if forced.contains(&NONE) {
        return None;
    }
    let mut growth = Growth::new(view, &units, &forced, landmarks);
    for u in units.around(view.mesh, copies).into_iter().filter(|&u| u != NONE) {
        growth.wanted[u as usize] = true;
    }
    while let Some(&seed) = forced.iter().find(|&&u| !growth.disks.taken[u as usize]) {
        if !growth.disks.apart(seed) {
            return None;
        }
        growth.grow(seed);
    }
    let mut region = vec![false; view.mesh.triangles.len()];
    for (members, _) in units.members.iter().zip(&growth.disks.taken).filter(|(_, t)| **t) {
        members.iter().for_each(|&t| region[t as usize] = true);
    }
    Some(region)
}

/// What becomes of a unit offered to the disk being grown.
enum Verdict {
    Take,
    /// Not now: it may meet the disk as it must once more is taken.
    Later,
    /// Never for this disk: it overlaps what is taken, or faces away.
    Never,
}

/// The disks being grown and what bars them.
struct Growth<'a> {
    view: &'a View<'a>,
    units: &'a Units,
    disks: Disks<'a>,
    grid: Grid,
    forced: Vec<bool>,
    /// Units around a landmark's other copies: offered first.
    wanted: Vec<bool>,
    /// The corners of a landmark's triangle turned over in the view: the
    /// start moves them to turn it over ([`crate::domain::start`]), so
    /// nothing else is taken at them.
    loose: Vec<bool>,
    /// The forced units at each vertex.
    forced_at: Vec<Vec<u32>>,
}

impl<'a> Growth<'a> {
    fn new(view: &'a View<'a>, units: &'a Units, forced: &[u32], landmarks: &[u32]) -> Self {
        let mut growth = Growth {
            view,
            units,
            disks: Disks::new(view, units),
            grid: Grid::new(view),
            forced: vec![false; units.members.len()],
            wanted: vec![false; units.members.len()],
            loose: vec![false; view.mesh.n_vertices()],
            forced_at: vec![Vec::new(); view.mesh.n_vertices()],
        };
        let is_landmark = crate::mesh::marked(view.mesh.n_vertices(), landmarks);
        for &u in forced {
            growth.forced[u as usize] = true;
            for &t in &units.members[u as usize] {
                let tri = view.mesh.triangles[t as usize];
                for &v in &tri {
                    if !growth.forced_at[v as usize].contains(&u) {
                        growth.forced_at[v as usize].push(u);
                    }
                }
                let [a, b, c] = tri.map(|v| view.projected[v as usize]);
                if crate::guard::orientation(a, b, c) > 0.0 {
                    growth.grid.insert(view, t);
                } else {
                    for &v in tri.iter().filter(|&&v| !is_landmark[v as usize]) {
                        growth.loose[v as usize] = true;
                    }
                }
            }
        }
        growth
    }

    /// Grows a disk from unit `seed`, nearest the camera first (the
    /// landmarks' units and copies' before anything).
    fn grow(&mut self, seed: u32) {
        let disk = self.disks.start(seed);
        let mut never = vec![false; self.units.members.len()];
        let mut heap: BinaryHeap<Queued> = self.disks.neighbours(seed).map(|n| Queued(f64::INFINITY, n)).collect();
        while let Some(Queued(_, u)) = heap.pop() {
            if self.disks.taken[u as usize] || never[u as usize] {
                continue;
            }
            match self.verdict(u, disk) {
                Verdict::Take => {}
                Verdict::Later => continue,
                Verdict::Never => {
                    never[u as usize] = true;
                    continue;
                }
            }
            self.disks.take(u, disk);
            if !self.forced[u as usize] {
                self.units.members[u as usize]
                    .iter()
                    .for_each(|&t| self.grid.insert(self.view, t));
            }
            let next: Vec<Queued> = self
                .disks
                .neighbours(u)
                .map(|n| {
                    let first = self.forced[n as usize] || self.wanted[n as usize];
                    Queued(
                        if first {
                            f64::INFINITY
                        } else {
                            self.units.depth[n as usize]
                        },
                        n,
                    )
                })
                .collect();
            heap.extend(next);
        }
    }

    /// Whether unit `u` is taken into `disk` now. A unit that is not a
    /// landmark's never takes a loose corner, nor a corner of a landmark's
    /// unit not taken yet without an edge of it too (that unit could then
    /// join only at a lone corner); it must fit the view, kept the gap from
    /// everything but its own disk and the landmarks' units beside it.
    fn verdict(&self, u: u32, disk: u32) -> Verdict {
        if !self.forced[u as usize] {
            let corners = self.disks.corner_vertices(u);
            let beside: Vec<u32> = self.disks.neighbours(u).collect();
            let barred = corners.iter().any(|&v| {
                self.loose[v as usize]
                    || self.forced_at[v as usize]
                        .iter()
                        .any(|&f| !self.disks.taken[f as usize] && !beside.contains(&f))
            });
            if barred {
                return Verdict::Later;
            }
            let touches = |s: u32| {
                let us = self.units.of[s as usize];
                self.disks.unit_disk[us as usize] == disk
                    || (self.forced[us as usize]
                        && !self.disks.taken[us as usize]
                        && self.view.mesh.triangles[s as usize]
                            .iter()
                            .any(|v| corners.binary_search(v).is_ok()))
            };
            if !fits(self.view, &self.grid, &self.units.members[u as usize], &touches) {
                return Verdict::Never;
            }
        }
        if self.disks.meets_along_one_path(u, disk) {
            Verdict::Take
        } else {
            Verdict::Later
        }
    }
}

/// Rounds of [`landmark_units`] at most.
const HUB_ROUNDS: usize = 4;

/// The units (polygons, and the triangles around each hub as one) and
/// the forced ones (around a hub). The hubs are the landmarks, and every
/// vertex where two forced units meet at a corner only (two landmarks two
/// edges apart), whose triangles join them. Forced units then meet along
/// edges, never at a lone corner (which no disk can take).
fn landmark_units(view: &View, unseamable: &[[u32; 2]], landmarks: &[u32]) -> (Units, Vec<u32>) {
    let mut hubs = landmarks.to_vec();
    let mut round = 0;
    loop {
        let units = Units::new(view, unseamable, &hubs);
        let forced = units.around(view.mesh, &hubs);
        round += 1;
        if round >= HUB_ROUNDS || forced.contains(&NONE) {
            return (units, forced);
        }
        let mut first = vec![NONE; view.mesh.n_vertices()];
        let mut meets = vec![false; view.mesh.n_vertices()];
        for &u in &forced {
            for &t in &units.members[u as usize] {
                for &v in &view.mesh.triangles[t as usize] {
                    match first[v as usize] {
                        NONE => first[v as usize] = u,
                        f if f != u => meets[v as usize] = true,
                        _ => {}
                    }
                }
            }
        }
        let before = hubs.len();
        hubs.extend((0..view.mesh.n_vertices() as u32).filter(|&v| meets[v as usize]));
        if hubs.len() == before {
            return (units, forced);
        }
    }
}

/// A unit in the queue, nearest the camera first.
struct Queued(f64, u32);

impl PartialEq for Queued {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Queued {}
impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Queued {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0).then(other.1.cmp(&self.1))
    }
}

/// The polygons of the file: triangles joined across unseamable edges,
/// taken or left together.
struct Units {
    /// The unit of each triangle.
    of: Vec<u32>,
    /// The triangles of each unit.
    members: Vec<Vec<u32>>,
    /// Each unit's mean depth towards the camera (nearest largest).
    depth: Vec<f64>,
}

impl Units {
    /// The polygons, and the triangles around each of the `hubs` as one
    /// unit: taken whole, so that no landmark is left on the border.
    fn new(view: &View, unseamable: &[[u32; 2]], landmarks: &[u32]) -> Self {
        let n_t = view.mesh.triangles.len();
        let mut joined = UnionFind::new(n_t);
        let mut first_around = vec![NONE; view.mesh.n_vertices()];
        let is_landmark = crate::mesh::marked(view.mesh.n_vertices(), landmarks);
        for (t, tri) in view.mesh.triangles.iter().enumerate() {
            for &v in tri.iter().filter(|&&v| is_landmark[v as usize]) {
                match first_around[v as usize] {
                    NONE => first_around[v as usize] = t as u32,
                    f => joined.union(f as usize, t),
                }
            }
        }
        for (e, edge) in view.graph.edges.iter().enumerate() {
            let [t0, t1] = view.graph.faces[e];
            if t1 != NONE && unseamable.binary_search(edge).is_ok() {
                joined.union(t0 as usize, t1 as usize);
            }
        }
        let mut id = vec![NONE; n_t];
        let mut members = Vec::<Vec<u32>>::new();
        let of: Vec<u32> = (0..n_t)
            .map(|t| {
                let root = joined.find(t);
                if id[root] == NONE {
                    id[root] = members.len() as u32;
                    members.push(Vec::new());
                }
                members[id[root] as usize].push(t as u32);
                id[root]
            })
            .collect();
        let depth = members
            .iter()
            .map(|m| {
                let sum: f64 = m
                    .iter()
                    .flat_map(|&t| view.mesh.triangles[t as usize])
                    .map(|v| view.mesh.positions[v as usize].dot(view.towards))
                    .sum();
                sum / (3 * m.len()) as f64
            })
            .collect();
        Units { of, members, depth }
    }

    /// The units around the landmarks, sorted; `NONE` among them when a
    /// landmark is on no triangle.
    fn around(&self, mesh: &TriMesh, landmarks: &[u32]) -> Vec<u32> {
        let is_landmark = crate::mesh::marked(mesh.n_vertices(), landmarks);
        let mut on_one = vec![false; mesh.n_vertices()];
        let mut out: Vec<u32> = Vec::new();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            if tri.iter().any(|&v| is_landmark[v as usize]) {
                tri.iter().for_each(|&v| on_one[v as usize] = true);
                out.push(self.of[t]);
            }
        }
        if landmarks.iter().any(|&l| !on_one[l as usize]) {
            out.push(NONE);
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// Whether every triangle of a unit is turned towards the camera, inside
/// the room, and overlaps nothing in the `grid`, kept the view's gap from
/// those it may not `touch`.
fn fits(view: &View, grid: &Grid, members: &[u32], touch: &dyn Fn(u32) -> bool) -> bool {
    members.iter().all(|&t| {
        let tri = view.mesh.triangles[t as usize];
        let [a, b, c] = tri.map(|v| view.projected[v as usize]);
        let [p, q, r] = tri.map(|v| view.mesh.positions[v as usize]);
        let normal = (q - p).cross(r - p);
        view.within[t as usize]
            && crate::guard::orientation(a, b, c) > 0.0
            && normal.dot(view.towards) > MIN_TURN * normal.length()
            && grid.clear_of(view, t, touch)
    })
}

/// The disks grown so far, each vertex held by at most one.
struct Disks<'a> {
    view: &'a View<'a>,
    units: &'a Units,
    taken: Vec<bool>,
    /// The disk of each unit (`NONE`: not taken).
    unit_disk: Vec<u32>,
    /// The disk holding each vertex (`NONE`: none).
    held: Vec<u32>,
    n_disks: u32,
}

impl<'a> Disks<'a> {
    fn new(view: &'a View<'a>, units: &'a Units) -> Self {
        Disks {
            view,
            units,
            taken: vec![false; units.members.len()],
            unit_disk: vec![NONE; units.members.len()],
            held: vec![NONE; view.mesh.n_vertices()],
            n_disks: 0,
        }
    }

    /// The unit's outline: its edges not shared inside it.
    fn outline(&self, u: u32) -> impl Iterator<Item = u32> + '_ {
        let g = self.view.graph;
        self.units.members[u as usize]
            .iter()
            .flat_map(|&t| g.triangle_edges[t as usize])
            .filter(move |&e| {
                let [t0, t1] = g.faces[e as usize];
                t1 == NONE || self.units.of[t0 as usize] != self.units.of[t1 as usize]
            })
    }

    /// The unit across edge `e` from unit `u`, if any.
    fn across(&self, u: u32, e: u32) -> Option<u32> {
        let [t0, t1] = self.view.graph.faces[e as usize];
        let other = if self.units.of[t0 as usize] == u { t1 } else { t0 };
        (other != NONE).then(|| self.units.of[other as usize])
    }

    /// The corners of unit `u`, sorted.
    fn corner_vertices(&self, u: u32) -> Vec<u32> {
        let mut corners: Vec<u32> = self.units.members[u as usize]
            .iter()
            .flat_map(|&t| self.view.mesh.triangles[t as usize])
            .collect();
        corners.sort_unstable();
        corners.dedup();
        corners
    }

    /// The disks holding each corner of unit `u` (`NONE`: none).
    fn corners(&self, u: u32) -> Vec<u32> {
        self.corner_vertices(u)
            .into_iter()
            .map(|v| self.held[v as usize])
            .collect()
    }

    /// Whether unit `u` touches no disk.
    fn apart(&self, u: u32) -> bool {
        self.corners(u).iter().all(|&d| d == NONE)
    }

    /// Whether unit `u` meets `disk` along one path of edges, short of its
    /// whole outline, and nothing else: taking it keeps the disk a disk
    /// (no pinch, no hole closed) and apart from the others.
    fn meets_along_one_path(&self, u: u32, disk: u32) -> bool {
        let (mut shared, mut outline) = (0usize, 0usize);
        for e in self.outline(u) {
            outline += 1;
            shared += usize::from(self.across(u, e).is_some_and(|n| self.taken[n as usize]));
        }
        let corners = self.corners(u);
        let met = corners.iter().filter(|&&d| d == disk).count();
        let elsewhere = corners.iter().any(|&d| d != disk && d != NONE);
        !elsewhere && shared >= 1 && shared < outline && met == shared + 1
    }

    /// Starts a new disk with unit `u`; its number.
    fn start(&mut self, u: u32) -> u32 {
        self.n_disks += 1;
        self.take(u, self.n_disks - 1);
        self.n_disks - 1
    }

    fn take(&mut self, u: u32, disk: u32) {
        self.taken[u as usize] = true;
        self.unit_disk[u as usize] = disk;
        for &t in &self.units.members[u as usize] {
            self.view.mesh.triangles[t as usize]
                .iter()
                .for_each(|&v| self.held[v as usize] = disk);
        }
    }

    /// The units across the outline of `u`, not taken.
    fn neighbours(&self, u: u32) -> impl Iterator<Item = u32> + '_ {
        self.outline(u)
            .filter_map(move |e| self.across(u, e))
            .filter(|&n| !self.taken[n as usize])
    }
}

/// The projected triangles taken or held, bucketed on a grid.
struct Grid {
    lo: DVec2,
    cell: f64,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<u32>>,
}

impl Grid {
    fn new(view: &View) -> Self {
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in view.projected.iter().filter(|p| p.is_finite()) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if !(lo.is_finite() && hi.is_finite()) {
            (lo, hi) = (DVec2::ZERO, DVec2::ONE);
        }
        let span = (hi - lo).max(DVec2::splat(1e-300));
        let n_t = view.mesh.triangles.len().max(1) as f64;
        let cell = (span.x * span.y * PER_CELL / n_t)
            .sqrt()
            .max(span.max_element() / MAX_CELLS as f64)
            .max(1e-300);
        let nx = ((span.x / cell).ceil() as usize).clamp(1, MAX_CELLS);
        let ny = ((span.y / cell).ceil() as usize).clamp(1, MAX_CELLS);
        Grid {
            lo,
            cell,
            nx,
            ny,
            cells: vec![Vec::new(); nx * ny],
        }
    }

    /// The cells a box (`lo`, `hi`) covers.
    fn cells_of(&self, (lo, hi): (DVec2, DVec2)) -> impl Iterator<Item = usize> + '_ {
        let at = |p: DVec2| {
            let q = ((p - self.lo) / self.cell).max(DVec2::ZERO);
            ((q.x as usize).min(self.nx - 1), (q.y as usize).min(self.ny - 1))
        };
        let ((x0, y0), (x1, y1)) = (at(lo), at(hi));
        (y0..=y1).flat_map(move |y| (x0..=x1).map(move |x| y * self.nx + x))
    }

    fn insert(&mut self, view: &View, t: u32) {
        let tri = view.mesh.triangles[t as usize].map(|v| view.projected[v as usize]);
        let cells: Vec<usize> = self.cells_of(box_of(tri, 0.0)).collect();
        cells.into_iter().for_each(|k| self.cells[k].push(t));
    }

    /// Whether triangle `t`'s projection overlaps none in the grid: those
    /// it may `touch` share corners and edges at most, the others are kept
    /// the view's gap away.
    fn clear_of(&self, view: &View, t: u32, touch: &dyn Fn(u32) -> bool) -> bool {
        let project = |s: u32| view.mesh.triangles[s as usize].map(|v| view.projected[v as usize]);
        let tri = project(t);
        let mut near: Vec<u32> = self
            .cells_of(box_of(tri, view.gap))
            .flat_map(|k| self.cells[k].iter().copied())
            .collect();
        near.sort_unstable();
        near.dedup();
        near.into_iter()
            .all(|s| s == t || apart(tri, project(s), if touch(s) { 0.0 } else { view.gap }))
    }
}

/// The box of a projected triangle, widened by `gap` on every side.
fn box_of(tri: [DVec2; 3], gap: f64) -> (DVec2, DVec2) {
    let (lo, hi) = (tri[0].min(tri[1]).min(tri[2]), tri[0].max(tri[1]).max(tri[2]));
    (lo - DVec2::splat(gap), hi + DVec2::splat(gap))
}

/// Whether two projected triangles are `gap` apart (for no gap, their
/// insides apart, touching allowed): an edge of one has the other wholly
/// that far on its outer side.
fn apart(a: [DVec2; 3], b: [DVec2; 3], gap: f64) -> bool {
    let ccw = |t: [DVec2; 3]| {
        if crate::guard::orientation(t[0], t[1], t[2]) < 0.0 {
            [t[0], t[2], t[1]]
        } else {
            t
        }
    };
    let (a, b) = (ccw(a), ccw(b));
    let splits = |s: [DVec2; 3], o: [DVec2; 3]| {
        (0..3).any(|k| {
            let (p, q) = (s[k], s[(k + 1) % 3]);
            let least = gap * p.distance(q);
            o.iter().all(|&x| crate::guard::orientation(p, q, x) <= -least)
        })
    };
    splits(a, b) || splits(b, a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::uv_sphere;

    fn view_of<'a>(mesh: &'a TriMesh, graph: &'a EdgeGraph, projected: &'a [DVec2], within: &'a [bool]) -> View<'a> {
        View {
            mesh,
            graph,
            projected,
            towards: DVec3::Z,
            within,
            gap: 0.0,
        }
    }

    /// A mesh seen from above (+z), all of it within the room: its edge
    /// graph, its projection and the room test.
    fn from_above(mesh: &TriMesh) -> (EdgeGraph, Vec<DVec2>, Vec<bool>) {
        let projected = mesh.positions.iter().map(|p| p.truncate()).collect();
        (EdgeGraph::new(mesh), projected, vec![true; mesh.triangles.len()])
    }

    #[test]
    fn apart_allows_touching_and_refuses_overlap() {
        let a = [DVec2::ZERO, DVec2::X, DVec2::Y];
        assert!(
            apart(a, [DVec2::X, DVec2::new(1.0, 1.0), DVec2::Y], 0.0),
            "sharing an edge"
        );
        assert!(
            apart(a, [DVec2::X, DVec2::new(2.0, 0.0), DVec2::new(2.0, 1.0)], 0.0),
            "sharing a corner"
        );
        assert!(!apart(
            a,
            [DVec2::splat(0.2), DVec2::new(2.0, 0.2), DVec2::new(0.2, 2.0)],
            0.0
        ));
        assert!(
            !apart(a, [DVec2::splat(0.1), DVec2::splat(0.2), DVec2::new(0.1, 0.3)], 0.0),
            "inside"
        );
    }

    #[test]
    fn a_sphere_seen_from_above_grows_a_disk_that_projects_one_to_one() {
        let sphere = uv_sphere(24, 36);
        let (graph, projected, within) = from_above(&sphere);
        let view = view_of(&sphere, &graph, &projected, &within);
        let top = (0..sphere.n_vertices() as u32)
            .filter(|&v| sphere.positions[v as usize].z > 0.5)
            .step_by(7)
            .take(6)
            .collect::<Vec<_>>();
        let region = grown_region(&view, (&top, &[]), &[]).expect("a disk");
        let chosen: Vec<[u32; 3]> = (0..region.len())
            .filter(|&t| region[t])
            .map(|t| sphere.triangles[t])
            .collect();
        // Every triangle seen from above, and none from below.
        for t in &chosen {
            let [a, b, c] = t.map(|v| projected[v as usize]);
            assert!(crate::guard::orientation(a, b, c) > 0.0);
        }
        assert!(chosen.len() * 3 > sphere.triangles.len(), "most of the upper half");
        // A disk: V - E + F = 1, and one-to-one: no two overlap.
        let part = crate::testing::compact(TriMesh {
            positions: sphere.positions.clone(),
            triangles: chosen.clone(),
        });
        let topo = crate::mesh::topology::Topology::build(&part).expect("a disk");
        assert_eq!(topo.holes().count(), 0);
        for (i, s) in chosen.iter().enumerate() {
            for t in &chosen[i + 1..] {
                assert!(apart(
                    s.map(|v| projected[v as usize]),
                    t.map(|v| projected[v as usize]),
                    0.0
                ));
            }
        }
    }

    #[test]
    fn a_landmark_on_the_far_side_is_a_disk_of_its_own_triangles() {
        let sphere = uv_sphere(12, 18);
        let (graph, projected, within) = from_above(&sphere);
        let view = view_of(&sphere, &graph, &projected, &within);
        let find =
            |f: &dyn Fn(f64) -> bool| (0..sphere.n_vertices() as u32).find(|&v| f(sphere.positions[v as usize].z));
        let top = find(&|z| z > 0.7).expect("a top vertex");
        let bottom = find(&|z| z < -0.7).expect("a bottom vertex");
        let region = grown_region(&view, (&[top, bottom], &[]), &[]).expect("two disks");
        for (t, tri) in sphere.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|v| projected[v as usize]);
            let facing = crate::guard::orientation(a, b, c) > 0.0;
            // Facing away, only the landmark's own triangles are taken.
            if !facing {
                assert_eq!(region[t], tri.contains(&bottom), "triangle {t}");
            }
        }
        // A landmark on no triangle is on no disk.
        let mut lone = sphere.clone();
        lone.positions.push(DVec3::ZERO);
        let (graph, projected, within) = from_above(&lone);
        let view = view_of(&lone, &graph, &projected, &within);
        let unused = lone.n_vertices() as u32 - 1;
        assert_eq!(grown_region(&view, (&[top, unused], &[]), &[]), None);
    }
}
