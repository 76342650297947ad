//! A mesh hierarchy by half-edge collapses (Hoppe's progressive meshes):
//! the filled chart is coarsened by removing one vertex at a time into a
//! neighbour, shortest 3D edges first, in rounds that touch each region
//! once, keeping it a manifold disk with the
//! same holes, its loops walked only along themselves, its landmarks and
//! hole centres in place, and no triangle turned over on the surface. Every
//! coarse vertex is a fine one, so a coarse layout meeting the targets meets
//! them on the fine mesh too; the collapses, undone in reverse, are the
//! prolongation ([`super::prolong`]).

use crate::mesh::TriMesh;
use glam::DVec3;

/// What a vertex is to the coarsening.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Off every loop: may go into any neighbour.
    Inner,
    /// On boundary loop `k` of the real mesh (the outer loop or a hole's):
    /// may go only into a neighbour along that loop.
    Loop(u32),
    /// Never removed: a landmark or a hole's virtual centre.
    Kept,
}

/// One collapse: `u` went into `v`. [`Hierarchy::star`] from `star` up to
/// the next collapse's (the stars are stacked in order) holds `u`'s
/// triangles then, each as `id · 4 + slot`, the slot of `u` in a triangle
/// that took `v` for it, or 3 for one that had both and went.
#[derive(Debug, Clone, Copy)]
pub struct Collapse {
    pub u: u32,
    pub v: u32,
    pub star: u32,
}

/// The fine mesh's triangles as the coarse level has them, and the
/// collapses that led there.
#[derive(Debug, Clone)]
pub struct Hierarchy {
    /// Every triangle of the fine mesh, as it stands at the coarse level
    /// (a removed one keeps its fine corners).
    pub triangles: Vec<[u32; 3]>,
    pub alive: Vec<bool>,
    /// Whether each fine vertex is still there.
    pub present: Vec<bool>,
    pub collapses: Vec<Collapse>,
    pub star: Vec<u32>,
}

/// A triangle whose corners' quality (`4√3 A / Σ ℓ²`, 1 for equilateral)
/// falls below this is not made by a collapse, unless the triangle it
/// replaces was as poor.
const MIN_QUALITY: f64 = 0.05;

/// A collapse may not turn a triangle's normal by more than this much
/// (cosine), nor make one whose normal is further than this from the fine
/// surface's normal at any of its corners: the coarse surface stays close
/// to the fine one.
const MIN_NORMAL_COSINE: f64 = 0.5;

/// Loops keep at least this many vertices (the outer one more).
const MIN_HOLE: u32 = 3;
const MIN_OUTER: u32 = 12;

struct Coarsening<'a> {
    positions: &'a [DVec3],
    /// The fine surface's area-weighted vertex normals (unit).
    normals: Vec<DVec3>,
    role: &'a [Role],
    /// Whether a vertex is on the outer loop (kept ones too: a corner, a
    /// landmark): the filled chart's only border.
    on_outer: Vec<bool>,
    triangles: Vec<[u32; 3]>,
    alive: Vec<bool>,
    incident: Vec<Vec<u32>>,
    present: Vec<bool>,
    /// The round in which a vertex last took in a neighbour.
    touched: Vec<u32>,
    loop_size: Vec<u32>,
    outer: u32,
    square: bool,
    /// Whether a triangle is real (all corners real vertices).
    real: Vec<bool>,
    collapses: Vec<Collapse>,
    star: Vec<u32>,
    /// Scratch lists of neighbours.
    around: [Vec<u32>; 2],
}

/// How to coarsen a filled chart.
#[derive(Debug, Clone, Copy)]
pub struct Plan<'a> {
    /// What each vertex may do.
    pub role: &'a [Role],
    /// The outer loop's index among the loops of [`Role::Loop`].
    pub outer: u32,
    /// The first virtual vertex: triangles touching one are not checked
    /// against the surface.
    pub virtual_from: usize,
    /// Vertices to leave, about.
    pub target: usize,
    /// The outer loop lies on the square: no collapse joins two of its
    /// vertices by a new edge (a chord or a triangle along one side of the
    /// square has no area).
    pub square: bool,
}

/// Coarsens `mesh` (a filled chart: a disk, holes closed by fans) as
/// `plan` says.
pub fn coarsen(mesh: &TriMesh, plan: Plan) -> Hierarchy {
    let Plan {
        role,
        outer,
        virtual_from,
        target,
        square,
    } = plan;
    let n = mesh.n_vertices();
    let mut incident = vec![Vec::with_capacity(6); n];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for &v in tri {
            incident[v as usize].push(t as u32);
        }
    }
    let mut loop_size = Vec::new();
    for r in role {
        if let Role::Loop(k) = *r {
            if loop_size.len() <= k as usize {
                loop_size.resize(k as usize + 1, 0);
            }
            loop_size[k as usize] += 1;
        }
    }
    let real: Vec<bool> = mesh
        .triangles
        .iter()
        .map(|t| t.iter().all(|&v| (v as usize) < virtual_from))
        .collect();
    let mut normals = vec![DVec3::ZERO; n];
    for (t, _) in mesh.triangles.iter().zip(&real).filter(|(_, r)| **r) {
        let nt = normal(t.map(|v| mesh.positions[v as usize]));
        t.iter().for_each(|&v| normals[v as usize] += nt);
    }
    normals.iter_mut().for_each(|n| *n = n.normalize_or_zero());
    let mut c = Coarsening {
        positions: &mesh.positions,
        normals,
        on_outer: border_vertices(mesh),
        role,
        triangles: mesh.triangles.clone(),
        alive: vec![true; mesh.n_triangles()],
        incident,
        present: vec![true; n],
        touched: vec![0; n],
        loop_size,
        outer,
        square,
        real,
        collapses: Vec::new(),
        star: Vec::new(),
        around: [Vec::new(), Vec::new()],
    };
    c.run(target);
    Hierarchy {
        triangles: c.triangles,
        alive: c.alive,
        present: c.present,
        collapses: c.collapses,
        star: c.star,
    }
}

/// Whether each vertex of `mesh` is on an edge of one triangle only (the
/// filled chart is wound one way, so its boundary edges are exactly those).
fn border_vertices(mesh: &TriMesh) -> Vec<bool> {
    let mut out = vec![false; mesh.n_vertices()];
    for [a, b] in crate::injective::boundary_edges(&mesh.triangles) {
        out[a as usize] = true;
        out[b as usize] = true;
    }
    out
}

impl Coarsening<'_> {
    /// Rounds of collapses, shortest edges first: each round sorts the
    /// living edges once and collapses along them, each survivor taking in
    /// one neighbour at most, so the mesh coarsens evenly; until `target`
    /// vertices are left or a round removes none.
    fn run(&mut self, target: usize) {
        let mut remaining = self.present.len();
        let mut round = 0u32;
        let mut edges: Vec<(u64, u32)> = Vec::new();
        while remaining > target {
            round += 1;
            self.living_edges(&mut edges);
            let before = remaining;
            for &(key, b) in &edges {
                let a = key as u32;
                if remaining <= target {
                    break;
                }
                if self.touched[a as usize] == round || self.touched[b as usize] == round {
                    continue;
                }
                if self.try_collapse(a, b) || self.try_collapse(b, a) {
                    remaining -= 1;
                    let v = self.survivor(a, b);
                    self.touched[v as usize] = round;
                }
            }
            if remaining == before {
                break;
            }
        }
    }

    /// Every living edge once, shortest first: its squared length's bits
    /// above its first end, and its second end.
    fn living_edges(&self, edges: &mut Vec<(u64, u32)>) {
        use rayon::slice::ParallelSliceMut;
        edges.clear();
        for (t, _) in self.triangles.iter().zip(&self.alive).filter(|(_, a)| **a) {
            let [a, b, c] = *t;
            for (p, q) in [(a, b), (b, c), (c, a)] {
                let (p, q) = (p.min(q), p.max(q));
                let d = self.positions[p as usize].distance_squared(self.positions[q as usize]) as f32;
                edges.push(((u64::from(d.to_bits()) << 32) | u64::from(p), q));
            }
        }
        edges.par_sort_unstable();
        edges.dedup();
    }

    /// Which of `a` and `b` is left after one went into the other.
    fn survivor(&self, a: u32, b: u32) -> u32 {
        if self.present[a as usize] { a } else { b }
    }

    /// The living triangles around `v`.
    fn star_of(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.incident[v as usize]
            .iter()
            .copied()
            .filter(move |&t| self.alive[t as usize] && self.triangles[t as usize].contains(&v))
    }

    /// `v`'s neighbours into `out`, sorted.
    fn neighbours(&self, v: u32, out: &mut Vec<u32>) {
        out.clear();
        out.extend(
            self.star_of(v)
                .flat_map(|t| self.triangles[t as usize])
                .filter(|&w| w != v),
        );
        out.sort_unstable();
        out.dedup();
    }

    /// Removes `u` into `v` if every rule allows it.
    fn try_collapse(&mut self, u: u32, v: u32) -> bool {
        if !self.allowed(u, v) {
            return false;
        }
        let start = self.star.len() as u32;
        let star: Vec<u32> = self.star_of(u).collect();
        for &t in &star {
            let tri = &mut self.triangles[t as usize];
            if tri.contains(&v) {
                self.alive[t as usize] = false;
                self.star.push(t * 4 + 3);
            } else {
                let slot = tri.iter().position(|&w| w == u).expect("in u's star");
                tri[slot] = v;
                self.star.push(t * 4 + slot as u32);
                self.incident[v as usize].push(t);
            }
        }
        self.incident[u as usize] = Vec::new();
        self.incident[v as usize].retain(|&t| self.alive[t as usize]);
        self.present[u as usize] = false;
        if let Role::Loop(k) = self.role[u as usize] {
            self.loop_size[k as usize] -= 1;
        }
        self.collapses.push(Collapse { u, v, star: start });
        true
    }

    /// The rules: `u` may go; along its loop if on one; the link
    /// condition (the mesh stays a manifold disk); no triangle made poor or
    /// turned over on the surface.
    fn allowed(&mut self, u: u32, v: u32) -> bool {
        let k = match self.role[u as usize] {
            Role::Kept => return false,
            Role::Inner => None,
            Role::Loop(k) => Some(k),
        };
        let (mut shared, mut shared_real) = (0, 0);
        for t in self.star_of(u).filter(|&t| self.triangles[t as usize].contains(&v)) {
            shared += 1;
            shared_real += usize::from(self.real[t as usize]);
        }
        if let Some(k) = k {
            let on_loop_edge = self.role[v as usize] == Role::Loop(k) && shared_real == 1;
            let least = if k == self.outer { MIN_OUTER } else { MIN_HOLE };
            if !on_loop_edge || self.loop_size[k as usize] <= least {
                return false;
            }
        }
        self.link_condition(u, v, shared)
            && self.shapes_kept(u, v)
            && !(self.square && (self.makes_chord(u, v) || self.in_loop_triangle(u)))
    }

    /// Whether outer-loop vertex `u` is a corner of a triangle with all
    /// three corners on the outer loop: put back on a side of the square
    /// between its loop neighbours, it would lay that triangle flat (an
    /// ear along one side), which no place on the side avoids.
    fn in_loop_triangle(&self, u: u32) -> bool {
        let on_outer = |w: u32| self.on_outer[w as usize];
        on_outer(u)
            && self
                .star_of(u)
                .any(|t| self.real[t as usize] && self.triangles[t as usize].iter().all(|&w| on_outer(w)))
    }

    /// Whether `u` going into outer-loop vertex `v` would join `v` to
    /// another outer-loop vertex it is not joined to yet.
    fn makes_chord(&mut self, u: u32, v: u32) -> bool {
        let on_outer = |w: u32| self.on_outer[w as usize];
        if !on_outer(v) {
            return false;
        }
        let [mut nu, mut nv] = std::mem::take(&mut self.around);
        self.neighbours(u, &mut nu);
        self.neighbours(v, &mut nv);
        let chord = nu
            .iter()
            .any(|&w| w != v && on_outer(w) && nv.binary_search(&w).is_err());
        self.around = [nu, nv];
        chord
    }

    /// The vertices next to both `u` and `v` are exactly the far corners
    /// of the `n_shared` triangles on edge (u, v).
    fn link_condition(&mut self, u: u32, v: u32, n_shared: usize) -> bool {
        if !(1..=2).contains(&n_shared) {
            return false;
        }
        let [mut nu, mut nv] = std::mem::take(&mut self.around);
        self.neighbours(u, &mut nu);
        self.neighbours(v, &mut nv);
        let common = nu.iter().filter(|w| nv.binary_search(w).is_ok()).count();
        self.around = [nu, nv];
        common == n_shared
    }

    /// Every triangle of `u`'s that takes `v` for `u` keeps its side of the
    /// surface and a fair shape.
    fn shapes_kept(&self, u: u32, v: u32) -> bool {
        let p = |w: u32| self.positions[w as usize];
        self.star_of(u).all(|t| {
            let tri = self.triangles[t as usize];
            if tri.contains(&v) || !self.real[t as usize] {
                return true;
            }
            let moved = tri.map(|w| if w == u { v } else { w });
            let (n0, n1) = (normal(tri.map(p)), normal(moved.map(p)));
            let off_surface = moved
                .iter()
                .any(|&w| self.normals[w as usize].dot(n1) <= MIN_NORMAL_COSINE * n1.length());
            let turned = off_surface || n0.dot(n1) <= MIN_NORMAL_COSINE * n0.length() * n1.length();
            let poorer = quality(moved.map(p)) < MIN_QUALITY.min(quality(tri.map(p)));
            !turned && !poorer
        })
    }
}

fn normal([a, b, c]: [DVec3; 3]) -> DVec3 {
    (b - a).cross(c - a)
}

/// `4√3 A / Σ ℓ²`: 1 for an equilateral triangle, 0 for a flat one.
fn quality(t: [DVec3; 3]) -> f64 {
    let l2 = t[0].distance_squared(t[1]) + t[1].distance_squared(t[2]) + t[2].distance_squared(t[0]);
    if l2 > 0.0 {
        2.0 * 3f64.sqrt() * normal(t).length() / l2
    } else {
        0.0
    }
}

impl Hierarchy {
    /// The coarse mesh: the vertices still present, renumbered in order,
    /// and the living triangles; `fine_of[k]` is coarse vertex `k`'s fine id.
    pub fn coarse_mesh(&self, positions: &[DVec3]) -> (TriMesh, Vec<u32>) {
        let mut coarse_of = vec![u32::MAX; self.present.len()];
        let mut fine_of = Vec::new();
        for (v, _) in self.present.iter().enumerate().filter(|(_, p)| **p) {
            coarse_of[v] = fine_of.len() as u32;
            fine_of.push(v as u32);
        }
        let triangles = self
            .triangles
            .iter()
            .zip(&self.alive)
            .filter(|(_, a)| **a)
            .map(|(t, _)| t.map(|v| coarse_of[v as usize]))
            .collect();
        let positions = fine_of.iter().map(|&v| positions[v as usize]).collect();
        (TriMesh { positions, triangles }, fine_of)
    }

    /// The number of vertices left.
    pub fn n_coarse(&self) -> usize {
        self.present.len() - self.collapses.len()
    }

    /// Undoes the last collapse: its vertex back, its star's triangles
    /// given it again and the ones it removed alive. The collapse and its
    /// star, or `None` at the fine level.
    pub fn split_last(&mut self) -> Option<(Collapse, Vec<u32>)> {
        let c = self.collapses.pop()?;
        let star = self.star.split_off(c.star as usize);
        self.set_star(&star, c.u, true);
        self.present[c.u as usize] = true;
        Some((c, star))
    }

    /// Makes collapse `c` (its star `star`) again: [`Self::split_last`]
    /// undone.
    pub fn collapse_again(&mut self, c: Collapse, star: Vec<u32>) {
        self.set_star(&star, c.v, false);
        self.present[c.u as usize] = false;
        self.star.extend(star);
        self.collapses.push(c);
    }

    /// Each star entry (triangle × 4 + corner slot, slot 3 for the triangle
    /// itself) set: a corner to `vertex`, a triangle to `alive`.
    fn set_star(&mut self, star: &[u32], vertex: u32, alive: bool) {
        for &s in star {
            let (t, slot) = ((s / 4) as usize, (s % 4) as usize);
            if slot == 3 {
                self.alive[t] = alive;
            } else {
                self.triangles[t][slot] = vertex;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::Topology;
    use crate::testing::grid_mesh;

    fn roles(mesh: &TriMesh, kept: &[u32]) -> (Vec<Role>, u32) {
        let topology = Topology::build(mesh).unwrap();
        let mut role = vec![Role::Inner; mesh.n_vertices()];
        for (k, l) in topology.loops.iter().enumerate() {
            for &v in l {
                role[v as usize] = Role::Loop(k as u32);
            }
        }
        for &v in kept {
            role[v as usize] = Role::Kept;
        }
        (role, topology.outer as u32)
    }

    fn plan(role: &[Role], outer: u32, target: usize) -> Plan<'_> {
        Plan {
            role,
            outer,
            virtual_from: role.len(),
            target,
            square: false,
        }
    }

    #[test]
    fn a_grid_coarsens_to_a_disk_with_its_landmarks() {
        let mut mesh = grid_mesh(60, 60);
        for p in &mut mesh.positions {
            p.z = 0.1 * (3.0 * p.x).sin() * (2.0 * p.y).cos();
        }
        let kept = [61 + 60 * 10, 1000, 2500];
        let (role, outer) = roles(&mesh, &kept);
        let h = coarsen(&mesh, plan(&role, outer, 400));
        assert!(h.n_coarse() <= 450, "{} left", h.n_coarse());
        let (coarse, fine_of) = h.coarse_mesh(&mesh.positions);
        for k in kept {
            assert!(fine_of.contains(&k), "landmark {k} kept");
        }
        let topology = Topology::build(&coarse).expect("a manifold");
        assert_eq!(topology.loops.len(), 1, "a disk");
        let euler = coarse.n_vertices() as i64 - topology.edges.len() as i64 + coarse.n_triangles() as i64;
        assert_eq!(euler, 1);
        // Every coarse triangle faces up, as the bumps' normals do.
        for t in &coarse.triangles {
            assert!(normal(t.map(|v| coarse.positions[v as usize])).z > 0.0);
        }
    }

    #[test]
    fn undoing_every_collapse_gives_the_fine_triangles_back() {
        let mesh = grid_mesh(20, 20);
        let (role, outer) = roles(&mesh, &[]);
        let mut h = coarsen(&mesh, plan(&role, outer, 30));
        while h.split_last().is_some() {}
        assert_eq!(h.triangles, mesh.triangles);
        assert!(h.alive.iter().all(|&a| a));
    }

    #[test]
    fn on_the_square_a_triangle_with_every_corner_on_the_border_keeps_them() {
        // A grid with two corner cells cut diagonally: the triangle left in
        // each has all three corners on the border, one of them a corner of
        // the square. Put back on a side, a collapsed corner of such a
        // triangle would lay it flat.
        let n = 40u32;
        let mut mesh = grid_mesh(n as usize, n as usize);
        let v = (n - 2) + (n - 2) * n;
        mesh.triangles
            .retain(|t| *t != [0, n + 1, n] && *t != [v, v + 1, v + n + 1]);
        let border = border_vertices(&mesh);
        let along: Vec<u32> = mesh
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&w| border[w as usize]))
            .flatten()
            .copied()
            .collect();
        assert!(along.len() >= 6, "triangles along the border");
        let (mut role, outer) = roles(&mesh, &[]);
        let kept_after = |role: &[Role]| {
            let h = coarsen(
                &mesh,
                Plan {
                    square: true,
                    ..plan(role, outer, 200)
                },
            );
            assert!(h.n_coarse() < 400, "{} left", h.n_coarse());
            let (_, fine_of) = h.coarse_mesh(&mesh.positions);
            along.iter().all(|w| fine_of.contains(w))
        };
        assert!(kept_after(&role), "each corner of a triangle along the border stays");
        // The square's corners kept, as the solve keeps them: still so.
        role[0] = Role::Kept;
        role[(n * n - 1) as usize] = Role::Kept;
        assert!(kept_after(&role), "with the square's corners kept");
    }
}
