//! Procedural meshes for tests and benchmarks (no third-party data).

use crate::mesh::TriMesh;
use glam::DVec3;

/// A `nx × ny` vertex grid over the unit square in the z = 0 plane, each quad
/// split into two triangles, counter-clockwise seen from +z. Vertex `i + j·nx`
/// sits at `(i/(nx-1), j/(ny-1), 0)`.
pub fn grid_mesh(nx: usize, ny: usize) -> TriMesh {
    assert!(nx >= 2 && ny >= 2);
    let mut positions = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            positions.push(DVec3::new(i as f64 / (nx - 1) as f64, j as f64 / (ny - 1) as f64, 0.0));
        }
    }
    let mut triangles = Vec::with_capacity(2 * (nx - 1) * (ny - 1));
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let v = (i + j * nx) as u32;
            let (r, u, ur) = (v + 1, v + nx as u32, v + nx as u32 + 1);
            // Alternate the diagonal so the grid has no preferred direction.
            if (i + j) % 2 == 0 {
                triangles.push([v, r, ur]);
                triangles.push([v, ur, u]);
            } else {
                triangles.push([v, r, u]);
                triangles.push([r, ur, u]);
            }
        }
    }
    TriMesh { positions, triangles }
}

/// Deterministic xorshift64* generator for property tests.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }
    /// Uniform integer in [0, n).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// A random, curved disk-like patch: a jittered `n × n` grid lifted onto a
/// bumpy height field, with up to `n_holes` holes punched around random
/// interior vertices (each hole removes the triangles of one vertex's fan, so
/// the result stays manifold). Unused vertices are dropped.
pub fn random_disk(rng: &mut Rng, n: usize, n_holes: usize) -> TriMesh {
    let mut mesh = grid_mesh(n, n);
    let h = 1.0 / (n - 1) as f64;
    let (a, b, c) = (rng.range(-0.4, 0.4), rng.range(-0.4, 0.4), rng.range(1.0, 4.0));
    for (i, p) in mesh.positions.iter_mut().enumerate() {
        let (ix, iy) = (i % n, i / n);
        if ix > 0 && iy > 0 && ix < n - 1 && iy < n - 1 {
            p.x += rng.range(-0.3, 0.3) * h;
            p.y += rng.range(-0.3, 0.3) * h;
        }
        p.z = a * (c * p.x).sin() + b * (c * p.y).cos() * p.x;
    }
    // Punch holes at interior vertices at least 3 rings from the border and each other.
    let mut centres: Vec<(usize, usize)> = Vec::new();
    for _ in 0..n_holes * 4 {
        if centres.len() == n_holes || n < 8 {
            break;
        }
        let (ix, iy) = (3 + rng.below(n - 6), 3 + rng.below(n - 6));
        if centres.iter().all(|&(x, y)| x.abs_diff(ix) > 3 || y.abs_diff(iy) > 3) {
            centres.push((ix, iy));
        }
    }
    let removed: Vec<u32> = centres.iter().map(|&(x, y)| (x + y * n) as u32).collect();
    mesh.triangles.retain(|t| !t.iter().any(|v| removed.contains(v)));
    compact(mesh)
}

/// Drops vertices that no triangle uses, renumbering the rest in order.
pub fn compact(mesh: TriMesh) -> TriMesh {
    let mut new_id = vec![u32::MAX; mesh.positions.len()];
    let mut positions = Vec::new();
    for t in &mesh.triangles {
        for &v in t {
            if new_id[v as usize] == u32::MAX {
                new_id[v as usize] = 0;
            }
        }
    }
    for (v, id) in new_id.iter_mut().enumerate() {
        if *id == 0 {
            *id = positions.len() as u32;
            positions.push(mesh.positions[v]);
        }
    }
    let triangles = mesh.triangles.iter().map(|t| t.map(|v| new_id[v as usize])).collect();
    TriMesh { positions, triangles }
}

/// A smooth bijective warp of the unit square that fixes its boundary:
/// `p + amp · sin(πx) sin(πy) · (1, 0.6)`. For `amp < 1 / (1.6 π)` its
/// Jacobian determinant is positive everywhere, so a fold-free layout pushed
/// through it stays fold-free: the warped layout witnesses that targets taken
/// from it are reachable.
pub fn smooth_warp(p: glam::DVec2, amp: f64) -> glam::DVec2 {
    use std::f64::consts::PI;
    let s = (PI * p.x).sin() * (PI * p.y).sin();
    p + glam::DVec2::new(1.0, 0.6) * (amp * s)
}

/// A swirl of the unit square: points within 0.45 of the centre turn about
/// it by `angle · (1 − r/0.45)²`, the rest stay. It is a bijection (each
/// circle turns rigidly) fixing the boundary; whether a given layout stays
/// fold-free through it depends on the mesh resolving the twist, so a test
/// using it as a witness must check the warped layout. Strong swirls stall
/// the spline path: the constraints' displacements turn around the centre.
pub fn swirl(p: glam::DVec2, angle: f64) -> glam::DVec2 {
    let centre = glam::DVec2::splat(0.5);
    let d = p - centre;
    let t = (1.0 - d.length() / 0.45).max(0.0);
    centre + glam::DVec2::from_angle(angle * t * t).rotate(d)
}

/// uvpin's layout of `mesh` with `boundary`, no landmarks and no seams, if
/// fold-free: a witness is a layout of the mesh as it is (one UV per
/// vertex), even where uvpin would cut it open by default (a boundary
/// short for its area).
fn uncut_layout(mesh: &TriMesh, boundary: crate::pins::BoundaryChoice) -> Option<crate::MeshSolution> {
    let pins = crate::pins::Pins::new(&[])
        .with_boundary(boundary)
        .with_seams(crate::pins::SeamsChoice::Edges(Vec::new()));
    // Solved on the chart itself, so that a witness does not move with the
    // size above which charts start from a coarse level.
    let options = crate::options::SolverOptions {
        multilevel_above: usize::MAX,
        ..crate::options::SolverOptions::DEFAULT
    };
    let solved = crate::solve_mesh(mesh, &pins, &options.into()).ok()?;
    let split = solved.report.seam.as_ref().is_some_and(|s| s.vertices_split > 0);
    (solved.report.orientation.is_clean() && !split).then_some(solved)
}

/// Landmarks (vertex, target in texture coordinates) and the witness layout.
pub type WitnessedCase = (Vec<(u32, glam::DVec2)>, Vec<glam::DVec2>);

/// A witnessed free-boundary case on `mesh`: uvpin's own free layout of it
/// without landmarks (globally injective), shrunk to leave the region's
/// border alone and pushed through [`smooth_warp`]; `k` random interior
/// vertices get their warped positions as targets (texture coordinates), so
/// a fold-free, one-to-one layout meeting them exists. Also the warped
/// layout (layout coordinates). `None` when the witness does not hold up
/// (the free layout failed, or the warp folds it or turns a loop inside out).
pub fn witnessed_free_case(mesh: &TriMesh, k: usize, seed: u64) -> Option<WitnessedCase> {
    use crate::param::uv_to_xy;
    use glam::DVec2;
    let free = uncut_layout(mesh, crate::pins::BoundaryChoice::Free)?;
    if free.report.free.as_ref().is_none_or(|f| f.crossings > 0) {
        return None;
    }
    let warped: Vec<DVec2> = free
        .uvs
        .iter()
        .map(|uv| {
            let p = uv_to_xy(DVec2::new(uv[0] as f64, uv[1] as f64));
            smooth_warp(DVec2::splat(0.5) + (p - 0.5) * 0.8, 0.12)
        })
        .collect();
    if !crate::guard::all_positive(&warped, &mesh.triangles) || inside_out_loops(mesh, &warped) > 0 {
        return None;
    }
    let landmarks = pick_interior(mesh, &warped, k, seed)?;
    Some((landmarks, warped))
}

/// A witnessed case on the square: uvpin's own square layout of `mesh`
/// without landmarks, pushed through [`smooth_warp`] (which keeps the square's
/// border where it is); `k` random interior vertices get their warped
/// positions as targets. The targets fill the texture as the square fills
/// it: a free layout must reach them too (a square layout inside the region
/// is a free layout). `None` when the square layout or the warp folds.
pub fn witnessed_square_case(mesh: &TriMesh, k: usize, seed: u64) -> Option<WitnessedCase> {
    use crate::param::uv_to_xy;
    use glam::DVec2;
    let square = uncut_layout(mesh, crate::pins::BoundaryChoice::Square)?;
    let warped: Vec<DVec2> = square
        .uvs
        .iter()
        .map(|uv| smooth_warp(uv_to_xy(DVec2::new(uv[0] as f64, uv[1] as f64)), 0.12))
        .collect();
    if !crate::guard::all_positive(&warped, &mesh.triangles) {
        return None;
    }
    let landmarks = pick_interior(mesh, &warped, k, seed)?;
    Some((landmarks, warped))
}

/// `k` distinct random vertices of `mesh` off its boundary, each with its
/// position in `layout` as its target (texture coordinates).
fn pick_interior(mesh: &TriMesh, layout: &[glam::DVec2], k: usize, seed: u64) -> Option<Vec<(u32, glam::DVec2)>> {
    let topology = crate::mesh::topology::Topology::build(mesh).ok()?;
    let mut on_boundary = vec![false; mesh.positions.len()];
    topology
        .loops
        .iter()
        .flatten()
        .for_each(|&v| on_boundary[v as usize] = true);
    if on_boundary.iter().filter(|b| !**b).count() < k {
        return None;
    }
    let mut rng = Rng::new(seed);
    let mut out: Vec<(u32, glam::DVec2)> = Vec::new();
    while out.len() < k {
        let v = rng.below(mesh.positions.len()) as u32;
        if !on_boundary[v as usize] && out.iter().all(|(w, _)| *w != v) {
            out.push((v, crate::param::xy_to_uv(layout[v as usize])));
        }
    }
    Some(out)
}

/// Boundary loops of `layout` whose signed area has the wrong sign for a
/// one-to-one layout (in the faces' winding the outer loop turns
/// counter-clockwise, every hole clockwise): a hole turned inside out covers
/// its surroundings twice without any edge crossing.
pub fn inside_out_loops(mesh: &TriMesh, layout: &[glam::DVec2]) -> usize {
    let Ok(topology) = crate::mesh::topology::Topology::build(mesh) else {
        return 0;
    };
    let area = |lp: &[u32]| -> f64 {
        (0..lp.len())
            .map(|k| layout[lp[k] as usize].perp_dot(layout[lp[(k + 1) % lp.len()] as usize]))
            .sum::<f64>()
    };
    topology
        .loops
        .iter()
        .enumerate()
        .filter(|(k, lp)| (area(lp) > 0.0) != (*k == topology.outer))
        .count()
}

/// A fresh, empty folder for one unit test, `uvpin-NAME-PID` under the
/// system's temporary folder (an earlier run's is removed first).
pub fn fresh_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("uvpin-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    dir
}

/// A closed UV sphere of radius 1: `n_lat` bands from pole to pole, `n_lon`
/// around, the poles single vertices; outward-facing.
pub fn uv_sphere(n_lat: usize, n_lon: usize) -> TriMesh {
    use std::f64::consts::PI;
    assert!(n_lat >= 2 && n_lon >= 3);
    let mut positions = vec![DVec3::Z];
    for i in 1..n_lat {
        let theta = PI * i as f64 / n_lat as f64;
        for j in 0..n_lon {
            let phi = 2.0 * PI * j as f64 / n_lon as f64;
            positions.push(DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ));
        }
    }
    positions.push(-DVec3::Z);
    let south = (positions.len() - 1) as u32;
    let ring = |i: usize, j: usize| (1 + (i - 1) * n_lon + j % n_lon) as u32;
    let mut triangles = Vec::new();
    for j in 0..n_lon {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        triangles.push([ring(n_lat - 1, j), south, ring(n_lat - 1, j + 1)]);
    }
    for i in 1..n_lat - 1 {
        for j in 0..n_lon {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j));
            triangles.push([a, d, c]);
            triangles.push([a, c, b]);
        }
    }
    TriMesh { positions, triangles }
}

/// A closed torus around the z axis: tube radius `r` around a circle of
/// radius `big_r`, `n_major × n_minor` quads split in two; outward-facing.
pub fn torus(n_major: usize, n_minor: usize, big_r: f64, r: f64) -> TriMesh {
    use std::f64::consts::TAU;
    let mut positions = Vec::with_capacity(n_major * n_minor);
    for i in 0..n_major {
        let a = TAU * i as f64 / n_major as f64;
        for j in 0..n_minor {
            let b = TAU * j as f64 / n_minor as f64;
            let rho = big_r + r * b.cos();
            positions.push(DVec3::new(rho * a.cos(), rho * a.sin(), r * b.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % n_major) * n_minor + j % n_minor) as u32;
    let mut triangles = Vec::new();
    for i in 0..n_major {
        for j in 0..n_minor {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    TriMesh { positions, triangles }
}

/// A closed surface of genus `holes`: an `n × n` plate (over [0, 2] × [0, 1]
/// when `holes` is 2, else the unit square) with `holes` square holes,
/// thickened into a top and a bottom sheet stitched along every boundary,
/// its edges rounded. Outward-facing.
pub fn holed_plate(n: usize, holes: usize) -> TriMesh {
    let width = if holes >= 2 { 2.0 } else { 1.0 };
    let (nx, ny) = (if holes >= 2 { 2 * n - 1 } else { n }, n);
    let mut top = grid_mesh(nx, ny);
    for p in &mut top.positions {
        p.x *= width;
    }
    let centres: Vec<f64> = (0..holes)
        .map(|h| width * (h as f64 + 0.5) / holes.max(1) as f64)
        .collect();
    top.triangles.retain(|t| {
        let c = t.iter().map(|&v| top.positions[v as usize]).sum::<DVec3>() / 3.0;
        !centres
            .iter()
            .any(|&x| (c.x - x).abs() < 0.2 && (c.y - 0.5).abs() < 0.2)
    });
    let top = compact(top);
    let topology = crate::mesh::topology::Topology::build(&top).expect("a plate with holes");
    let n_top = top.positions.len() as u32;
    // Thicker towards the middle of the sheet, thin at every rim.
    let rim = |p: DVec3| {
        let mut d = p.x.min(width - p.x).min(p.y).min(1.0 - p.y);
        for &x in &centres {
            d = d.min(((p.x - x).abs() - 0.2).max((p.y - 0.5).abs() - 0.2).abs());
        }
        0.02 + 0.15 * (d * 6.0).min(1.0).sqrt()
    };
    let mut positions: Vec<DVec3> = top.positions.iter().map(|&p| p + DVec3::Z * rim(p)).collect();
    positions.extend(top.positions.iter().map(|&p| p - DVec3::Z * rim(p)));
    let mut triangles = top.triangles.clone();
    triangles.extend(top.triangles.iter().map(|t| [t[0] + n_top, t[2] + n_top, t[1] + n_top]));
    for lp in &topology.loops {
        for k in 0..lp.len() {
            let (a, b) = (lp[k], lp[(k + 1) % lp.len()]);
            triangles.push([b, a, a + n_top]);
            triangles.push([b, a + n_top, b + n_top]);
        }
    }
    TriMesh { positions, triangles }
}

/// A closed head-like blob facing −y: a sphere stretched taller, two eye
/// sockets, a nose and two ears. Returns it with the vertices nearest its
/// eye corners, nose tip, mouth corners and chin (in that order).
pub fn blob_head(n_lat: usize, n_lon: usize) -> (TriMesh, Vec<u32>) {
    let mut mesh = uv_sphere(n_lat, n_lon);
    let bump = |p: DVec3, at: DVec3, width: f64, height: f64| {
        let d2 = (p.normalize() - at.normalize()).length_squared();
        height * (-d2 / (width * width)).exp()
    };
    for p in &mut mesh.positions {
        let q = *p;
        let mut r = 1.0;
        r -= bump(q, DVec3::new(-0.35, -0.8, 0.25), 0.22, 0.12);
        r -= bump(q, DVec3::new(0.35, -0.8, 0.25), 0.22, 0.12);
        r += bump(q, DVec3::new(0.0, -1.0, 0.0), 0.18, 0.18);
        r += bump(q, DVec3::new(-1.0, 0.0, 0.05), 0.15, 0.15);
        r += bump(q, DVec3::new(1.0, 0.0, 0.05), 0.15, 0.15);
        *p = DVec3::new(q.x * r * 0.85, q.y * r, q.z * r * 1.15);
    }
    let nearest = |target: DVec3| {
        (0..mesh.positions.len())
            .min_by(|&a, &b| {
                (mesh.positions[a] - target)
                    .length_squared()
                    .total_cmp(&(mesh.positions[b] - target).length_squared())
            })
            .expect("vertices") as u32
    };
    let features = [
        DVec3::new(-0.45, -0.75, 0.3),
        DVec3::new(-0.18, -0.85, 0.3),
        DVec3::new(0.18, -0.85, 0.3),
        DVec3::new(0.45, -0.75, 0.3),
        DVec3::new(0.0, -1.2, 0.0),
        DVec3::new(-0.3, -0.85, -0.45),
        DVec3::new(0.3, -0.85, -0.45),
        DVec3::new(0.0, -0.7, -0.85),
    ];
    let landmarks = features.iter().map(|&f| nearest(f)).collect();
    (mesh, landmarks)
}

/// Landmarks as a photograph places them: `k` vertices of `mesh` among
/// those `allowed` marks that face the camera (looking along `view`, `up`
/// up), on the near half of the mesh and not hidden behind another part of
/// it, spread out (farthest first); their targets are the orthographic
/// projection scaled to span `span` of the texture, centred. `(vertex, u,
/// v)`, glTF texture coordinates.
///
/// # Panics
/// Fewer than `k` such vertices.
pub fn photo_landmarks_on(
    mesh: &TriMesh,
    allowed: &[bool],
    view: DVec3,
    up: DVec3,
    k: usize,
    span: f64,
) -> Vec<(u32, f64, f64)> {
    photo_landmarks_where(mesh, allowed, (view, up), (k, span), (Seen::NearHalf, Hiding::Vertices))
}

/// As [`photo_landmarks`], but among the vertices the photograph truly
/// shows ([`Hiding::Surfaces`]): on a triangle turned towards the camera
/// and behind no triangle nearer it.
///
/// # Panics
/// Fewer than `k` such vertices.
pub fn photo_landmarks_unhidden(mesh: &TriMesh, view: DVec3, up: DVec3, k: usize, span: f64) -> Vec<(u32, f64, f64)> {
    photo_landmarks_where(
        mesh,
        &vec![true; mesh.n_vertices()],
        (view, up),
        (k, span),
        (Seen::NearHalf, Hiding::Surfaces),
    )
}

/// What hides a vertex from the photograph.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hiding {
    /// Another vertex near its view ray and nearer the camera: a dense
    /// mesh's surface, read at its vertices (a CAD part's long facets hide
    /// vertices that no vertex of theirs is near).
    Vertices,
    /// That, or a triangle covering it nearer the camera; and a vertex
    /// only on triangles turned away is not shown.
    Surfaces,
}

/// Which of the vertices a photograph shows may be landmarks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Seen {
    /// Those on the near half of the mesh.
    NearHalf,
    /// Any: the far side too, where it shows (through a ring's hole).
    Anywhere,
}

/// As [`photo_landmarks_on`] among all vertices, the far side too where
/// the photograph shows it ([`Seen::Anywhere`]).
///
/// # Panics
/// Fewer than `k` such vertices.
pub fn photo_landmarks_anywhere(mesh: &TriMesh, view: DVec3, up: DVec3, k: usize, span: f64) -> Vec<(u32, f64, f64)> {
    photo_landmarks_where(
        mesh,
        &vec![true; mesh.n_vertices()],
        (view, up),
        (k, span),
        (Seen::Anywhere, Hiding::Vertices),
    )
}

fn photo_landmarks_where(
    mesh: &TriMesh,
    allowed: &[bool],
    (view, up): (DVec3, DVec3),
    (k, span): (usize, f64),
    (seen, hiding): (Seen, Hiding),
) -> Vec<(u32, f64, f64)> {
    let normals = crate::cut::cost::vertex_normals(mesh);
    let right = view.cross(up).normalize();
    let up = right.cross(view).normalize();
    let (lo, hi) = mesh
        .positions
        .iter()
        .fold((DVec3::MAX, DVec3::MIN), |(a, b), &p| (a.min(p), b.max(p)));
    let scale = (hi - lo).max_element() / 2.0;
    // The near half only: what a photo shows of a figure's other side
    // (between a cow's legs) is mirrored in any one-piece layout.
    let middle = 0.5 * (lo + hi).dot(view);
    let radius = 0.03 * scale;
    let mut hidden = occluded(mesh, (right, up, view), radius, 0.05 * scale);
    let mut on_front = vec![hiding == Hiding::Vertices; mesh.n_vertices()];
    if hiding == Hiding::Surfaces {
        let covered = covered(mesh, (right, up, view), 0.01 * scale);
        hidden.iter_mut().zip(&covered).for_each(|(h, c)| *h |= c);
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            if (b - a).cross(c - a).dot(-view) > 0.0 {
                t.iter().for_each(|&v| on_front[v as usize] = true);
            }
        }
    }
    let visible: Vec<usize> = (0..mesh.n_vertices())
        .filter(|&v| {
            let near = seen == Seen::Anywhere || mesh.positions[v].dot(view) < middle;
            allowed[v] && normals[v].dot(-view) > 0.55 && on_front[v] && near && !hidden[v]
        })
        .collect();
    assert!(visible.len() >= k, "only {} visible vertices", visible.len());
    let mut chosen = vec![visible[visible.len() / 2]];
    let mut nearest = vec![f64::MAX; visible.len()];
    while chosen.len() < k {
        let last = mesh.positions[*chosen.last().expect("one") as usize];
        for (d, &v) in nearest.iter_mut().zip(&visible) {
            *d = d.min(mesh.positions[v].distance(last));
        }
        let far = (0..visible.len())
            .max_by(|&a, &b| nearest[a].total_cmp(&nearest[b]))
            .expect("visible");
        chosen.push(visible[far]);
    }
    let flat: Vec<(f64, f64)> = chosen
        .iter()
        .map(|&v| (mesh.positions[v].dot(right), mesh.positions[v].dot(up)))
        .collect();
    let (mut lo, mut hi) = ((f64::MAX, f64::MAX), (f64::MIN, f64::MIN));
    for &(x, y) in &flat {
        lo = (lo.0.min(x), lo.1.min(y));
        hi = (hi.0.max(x), hi.1.max(y));
    }
    let s = span / (hi.0 - lo.0).max(hi.1 - lo.1);
    let centre = ((lo.0 + hi.0) / 2.0, (lo.1 + hi.1) / 2.0);
    chosen
        .iter()
        .zip(&flat)
        .map(|(&v, &(x, y))| (v as u32, 0.5 + s * (x - centre.0), 0.5 - s * (y - centre.1)))
        .collect()
}

/// As [`photo_landmarks_on`], among all vertices.
pub fn photo_landmarks(mesh: &TriMesh, view: DVec3, up: DVec3, k: usize, span: f64) -> Vec<(u32, f64, f64)> {
    photo_landmarks_on(mesh, &vec![true; mesh.n_vertices()], view, up, k, span)
}

/// Whether each vertex has another within `radius` of its view ray and
/// more than `depth` nearer the camera (a grid of the projected vertices).
fn occluded(mesh: &TriMesh, (right, up, view): (DVec3, DVec3, DVec3), radius: f64, depth: f64) -> Vec<bool> {
    let cell = |p: DVec3| {
        (
            (p.dot(right) / radius).floor() as i64,
            (p.dot(up) / radius).floor() as i64,
        )
    };
    let mut grid: std::collections::HashMap<(i64, i64), Vec<u32>> = std::collections::HashMap::new();
    for (v, &p) in mesh.positions.iter().enumerate() {
        grid.entry(cell(p)).or_default().push(v as u32);
    }
    mesh.positions
        .iter()
        .map(|&p| {
            let (cx, cy) = cell(p);
            let (x, y, d) = (p.dot(right), p.dot(up), p.dot(view));
            (cx - 1..=cx + 1)
                .flat_map(|i| (cy - 1..=cy + 1).map(move |j| (i, j)))
                .any(|key| {
                    grid.get(&key).is_some_and(|vs| {
                        vs.iter().any(|&w| {
                            let q = mesh.positions[w as usize];
                            let (qx, qy) = (q.dot(right) - x, q.dot(up) - y);
                            qx * qx + qy * qy < radius * radius && q.dot(view) < d - depth
                        })
                    })
                })
        })
        .collect()
}

/// Whether each vertex lies behind a triangle (not one of its own) that
/// covers it in the view and is more than `depth` nearer the camera: a
/// CAD part's long facets hide vertices that no vertex of theirs is near.
fn covered(mesh: &TriMesh, (right, up, view): (DVec3, DVec3, DVec3), depth: f64) -> Vec<bool> {
    let flat: Vec<(f64, f64, f64)> = mesh
        .positions
        .iter()
        .map(|p| (p.dot(right), p.dot(up), p.dot(view)))
        .collect();
    let (mut lo, mut hi) = ((f64::MAX, f64::MAX), (f64::MIN, f64::MIN));
    for &(x, y, _) in &flat {
        lo = (lo.0.min(x), lo.1.min(y));
        hi = (hi.0.max(x), hi.1.max(y));
    }
    const CELLS: usize = 128;
    let cell = ((hi.0 - lo.0).max(hi.1 - lo.1) / CELLS as f64).max(1e-300);
    let at = |x: f64, y: f64| {
        (
            (((x - lo.0) / cell) as usize).min(CELLS),
            (((y - lo.1) / cell) as usize).min(CELLS),
        )
    };
    let mut grid = vec![Vec::<u32>::new(); (CELLS + 1) * (CELLS + 1)];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|v| flat[v as usize]);
        let (x0, y0) = at(a.0.min(b.0).min(c.0), a.1.min(b.1).min(c.1));
        let (x1, y1) = at(a.0.max(b.0).max(c.0), a.1.max(b.1).max(c.1));
        for j in y0..=y1 {
            for i in x0..=x1 {
                grid[j * (CELLS + 1) + i].push(t as u32);
            }
        }
    }
    (0..mesh.n_vertices())
        .map(|v| {
            let (x, y, d) = flat[v];
            let (i, j) = at(x, y);
            grid[j * (CELLS + 1) + i].iter().any(|&t| {
                let tri = mesh.triangles[t as usize];
                if tri.contains(&(v as u32)) {
                    return false;
                }
                let [a, b, c] = tri.map(|w| flat[w as usize]);
                let twice = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
                if twice.abs() < 1e-300 {
                    return false;
                }
                let wa = ((b.0 - x) * (c.1 - y) - (b.1 - y) * (c.0 - x)) / twice;
                let wb = ((c.0 - x) * (a.1 - y) - (c.1 - y) * (a.0 - x)) / twice;
                let wc = 1.0 - wa - wb;
                wa >= 0.0 && wb >= 0.0 && wc >= 0.0 && wa * a.2 + wb * b.2 + wc * c.2 < d - depth
            })
        })
        .collect()
}

/// A regular octahedron (6 vertices, 8 triangles, closed), outward and
/// counter-clockwise: a closed mesh of few vertices.
pub fn octahedron() -> TriMesh {
    TriMesh {
        positions: vec![DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z],
        triangles: vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ],
    }
}

/// A square frame as a CAD tool exports it (genus 1): a 3 × 3 square
/// with a 1 × 1 square hole through it, `height` thick, every face flat
/// and split into long facets; each facet then split `levels` times at
/// its edges' midpoints (the surface unchanged). Outward, counter-clockwise.
pub fn square_frame(height: f64, levels: usize) -> TriMesh {
    let ring = |r: f64, z: f64| -> Vec<DVec3> {
        [(-r, -r), (r, -r), (r, r), (-r, r)]
            .iter()
            .map(|&(x, y)| DVec3::new(x, y, z))
            .collect()
    };
    // Outer top 0..4, inner top 4..8, outer bottom 8..12, inner bottom 12..16.
    let positions = [ring(1.5, height), ring(0.5, height), ring(1.5, 0.0), ring(0.5, 0.0)].concat();
    let mut triangles = Vec::new();
    for k in 0..4u32 {
        let j = (k + 1) % 4;
        let (o, i, ob, ib) = ((k, j), (4 + k, 4 + j), (8 + k, 8 + j), (12 + k, 12 + j));
        triangles.extend([[o.0, o.1, i.1], [o.0, i.1, i.0]]);
        triangles.extend([[ob.0, ib.1, ob.1], [ob.0, ib.0, ib.1]]);
        triangles.extend([[ob.0, ob.1, o.1], [ob.0, o.1, o.0]]);
        triangles.extend([[ib.1, ib.0, i.0], [ib.1, i.0, i.1]]);
    }
    let mut mesh = TriMesh { positions, triangles };
    for _ in 0..levels {
        mesh = subdivide_midpoint(&mesh);
    }
    mesh
}

/// `mesh` with every triangle split into four at its edges' midpoints (a
/// flat subdivision: the surface is unchanged). The original vertices keep
/// their ids; each edge's midpoint is numbered after them. A layout of
/// `mesh` interpolated at the midpoints is a layout of the result with the
/// same orientation per triangle.
pub fn subdivide_midpoint(mesh: &TriMesh) -> TriMesh {
    let mut positions = mesh.positions.clone();
    let mut midpoint = std::collections::HashMap::<(u32, u32), u32>::with_capacity(mesh.triangles.len() * 3 / 2);
    let mut mid = |a: u32, b: u32, positions: &mut Vec<DVec3>| {
        *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
            positions.push(0.5 * (positions[a as usize] + positions[b as usize]));
            (positions.len() - 1) as u32
        })
    };
    let mut triangles = Vec::with_capacity(mesh.triangles.len() * 4);
    for &[a, b, c] in &mesh.triangles {
        let (ab, bc, ca) = (
            mid(a, b, &mut positions),
            mid(b, c, &mut positions),
            mid(c, a, &mut positions),
        );
        triangles.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    TriMesh { positions, triangles }
}
