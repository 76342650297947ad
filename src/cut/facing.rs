//! A landmarked chart seen as a photograph sees it: when the targets are
//! (nearly) where an affine camera would put the landmarks — the landmarks
//! of a face photo on a head — the part of the surface that camera sees
//! facing it, clear of anything in front of it, is a chart whose
//! projection is already one-to-one and puts every landmark near its
//! target. That part is split from the rest (packed apart) and its
//! projection is the free solve's start; the spline path (Eq. 6) then
//! closes the last distance, and the polish relaxes the foreshortening.
//!
//! A triangle `t` projects with orientation `(a₁ × a₂) · n_t` (the camera's
//! two rows `a₁`, `a₂`), so the fitted camera itself says which side is
//! seen: a mirrored fit faces away from the landmarks and gives no chart.

use super::graph::{EdgeGraph, NONE};
use crate::mesh::TriMesh;
use crate::mesh::topology::UnionFind;
use glam::{DMat3, DVec2, DVec3};

/// An affine camera: a point `p` is seen at `rows · p + offset` (layout
/// coordinates, the targets' frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub rows: [DVec3; 2],
    pub offset: DVec2,
}

/// A triangle counts as facing the camera when its normal is within this
/// cosine of the view: nearer the silhouette, the projection crushes it.
const MIN_FACING: f64 = 0.2;

/// A facing triangle is hidden when something lies more than this many
/// mean edge lengths in front of it.
const HIDDEN_DEPTH: f64 = 3.0;

/// The depth buffer has at most this many cells a side.
const MAX_CELLS: usize = 2048;

/// The chart keeps this share of the room's size clear of its border.
const ROOM_MARGIN: f64 = 0.004;

impl Camera {
    /// The camera that best maps `points` onto `targets` (least squares);
    /// `None` with fewer than three landmarks, or when they fix no view
    /// (all on one line, or targets on one line).
    pub fn fit(points: &[DVec3], targets: &[DVec2]) -> Option<Camera> {
        let k = points.len();
        if k < 3 || targets.len() != k {
            return None;
        }
        let pc = points.iter().sum::<DVec3>() / k as f64;
        let tc = targets.iter().sum::<DVec2>() / k as f64;
        let mut m = DMat3::ZERO;
        let mut r = [DVec3::ZERO; 2];
        for (p, t) in points.iter().zip(targets) {
            let (q, s) = (*p - pc, *t - tc);
            m += DMat3::from_cols(q * q.x, q * q.y, q * q.z);
            r[0] += q * s.x;
            r[1] += q * s.y;
        }
        // A light ridge: landmarks on one plane leave the view along its
        // normal, the least-norm camera.
        let trace = m.x_axis.x + m.y_axis.y + m.z_axis.z;
        if !(trace.is_finite() && trace > 0.0) {
            return None;
        }
        m += DMat3::from_diagonal(DVec3::splat(1e-9 * trace));
        let det = m.determinant();
        if !(det.is_finite() && det > 0.0) {
            return None;
        }
        let inv = m.inverse();
        let rows = [inv * r[0], inv * r[1]];
        let view = rows[0].cross(rows[1]);
        if view.length().partial_cmp(&(1e-9 * rows[0].length() * rows[1].length())) != Some(std::cmp::Ordering::Greater)
        {
            return None;
        }
        let offset = tc - DVec2::new(rows[0].dot(pc), rows[1].dot(pc));
        Some(Camera { rows, offset })
    }

    /// Where the camera sees `p`.
    pub fn project(&self, p: DVec3) -> DVec2 {
        DVec2::new(self.rows[0].dot(p), self.rows[1].dot(p)) + self.offset
    }

    /// The unit direction towards the camera: a triangle whose normal
    /// points along it projects positively.
    pub fn towards(&self) -> DVec3 {
        self.rows[0].cross(self.rows[1]).normalize()
    }

    /// The largest distance of a projected landmark from its target.
    pub fn residual(&self, points: &[DVec3], targets: &[DVec2]) -> f64 {
        points
            .iter()
            .zip(targets)
            .map(|(p, t)| self.project(*p).distance(*t))
            .fold(0.0, f64::max)
    }
}

/// Which triangles count as what the camera sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sight {
    /// Facing it by their corners' normals and nearest within a few edge
    /// lengths of depth, with the dimples they enclose: a scan's noisy
    /// surface, seen as a photograph shows it.
    Near,
    /// Seen whole ([`super::occlusion::seen_whole`]): turned towards it by
    /// their own normal and overlapped by nothing nearer, so that the view
    /// of them is one-to-one exactly — a CAD part's facets, walls and
    /// bores, where a depth tolerance takes in what lies behind an edge.
    Whole,
    /// Grown from the landmarks as one disk over what projects without
    /// overlapping itself ([`super::grown`]): where the whole view folds
    /// over itself, the part of it that is one-to-one.
    Grown,
}

/// The triangles of `mesh` (manifold) the camera sees (as `sight` says;
/// [`Sight::Near`] those projected inside `room`, a layout box), in the
/// parts joined by edges that hold landmarks; never across an `unseamable` edge (sorted pairs: a
/// polygon of the file stays whole, on the side away from the chart).
/// `None` when a landmark is on no such part.
pub fn facing_region(
    mesh: &TriMesh,
    (camera, sight): (&Camera, Sight),
    (landmarks, copies): (&[u32], &[u32]),
    room: (DVec2, DVec2),
    unseamable: &[[u32; 2]],
) -> Option<Vec<bool>> {
    if landmarks.is_empty() {
        return None;
    }
    let towards = camera.towards();
    let projected: Vec<DVec2> = mesh.positions.iter().map(|&p| camera.project(p)).collect();
    let depth: Vec<f64> = mesh.positions.iter().map(|p| p.dot(towards)).collect();
    let graph = EdgeGraph::new(mesh);
    let mut seen = match sight {
        Sight::Near => {
            let within = within_room(mesh, &projected, room);
            let (mut seen, at_centre) = seen_near(mesh, (&projected, &depth), towards, landmarks, &within);
            fill_pockets(&graph, &mut seen, &at_centre);
            seen
        }
        Sight::Whole => {
            // All of it, past the room too: the start draws in what
            // reaches out ([`crate::domain::start`]); a landmark on a long
            // facet that leaves the room is on no triangle within it.
            super::occlusion::seen_whole(mesh, &projected, &depth)
        }
        Sight::Grown => {
            let within = within_room(mesh, &projected, room);
            let view = super::grown::View {
                mesh,
                graph: &graph,
                projected: &projected,
                towards,
                within: &within,
                gap: ROOM_MARGIN * (room.1 - room.0).max_element(),
            };
            return super::grown::grown_region(&view, (landmarks, copies), unseamable);
        }
    };
    keep_polygons_out(&graph, unseamable, &mut seen);
    landmarks_part(&graph, mesh, &seen, landmarks)
}

/// Whether each triangle of `mesh` is `projected` inside `room`, kept
/// [`ROOM_MARGIN`] off its border.
fn within_room(mesh: &TriMesh, projected: &[DVec2], room: (DVec2, DVec2)) -> Vec<bool> {
    let margin = (room.1 - room.0) * ROOM_MARGIN;
    let (lo, hi) = (room.0 + margin, room.1 - margin);
    mesh.triangles
        .iter()
        .map(|tri| {
            tri.iter().all(|&v| {
                let p = projected[v as usize];
                p.cmpge(lo).all() && p.cmple(hi).all()
            })
        })
        .collect()
}

/// The triangles [`Sight::Near`] sees, before the dimples they enclose,
/// and those seen at their centre (the dimples it may take in).
fn seen_near(
    mesh: &TriMesh,
    (projected, depth): (&[DVec2], &[f64]),
    towards: DVec3,
    landmarks: &[u32],
    within: &[bool],
) -> (Vec<bool>, Vec<bool>) {
    let (visible, strict) = visible(mesh, projected, depth);
    let facing = facing_triangles(mesh, towards);
    let mut seen: Vec<bool> = (0..strict.len()).map(|t| strict[t] && facing[t] && within[t]).collect();
    // A landmark the photo shows is seen: where every triangle around it
    // passes behind another part at a corner, leans past the room (a CAD
    // part's long facet) or faces the camera only by its own normal, those
    // seen at their centre and turned towards the camera take it in.
    let is_landmark = crate::mesh::marked(mesh.n_vertices(), landmarks);
    let mut held = vec![false; mesh.n_vertices()];
    for (tri, _) in mesh.triangles.iter().zip(&seen).filter(|(_, s)| **s) {
        tri.iter().for_each(|&v| held[v as usize] = true);
    }
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let lone = tri.iter().any(|&v| is_landmark[v as usize] && !held[v as usize]);
        let [a, b, c] = tri.map(|v| projected[v as usize]);
        let turned = facing[t] || crate::guard::orientation(a, b, c) > 0.0;
        seen[t] |= lone && visible[t] && turned;
    }
    let at_centre = (0..seen.len()).map(|t| visible[t] && within[t]).collect();
    (seen, at_centre)
}

/// Whether each triangle faces the camera (`towards` it): the mean of its
/// corners' normals within [`MIN_FACING`] of the view. Corner normals
/// (area-weighted) smooth a scan's noise and a CAD part's slivers, whose
/// own normals say little; the few triangles they leave turned over in the
/// projection are untangled at the start ([`crate::domain::start::projection_start`]).
fn facing_triangles(mesh: &TriMesh, towards: DVec3) -> Vec<bool> {
    let normals = super::cost::vertex_normals(mesh);
    mesh.triangles
        .iter()
        .map(|t| {
            let n = t.iter().map(|&v| normals[v as usize]).sum::<DVec3>();
            n.dot(towards) > MIN_FACING * n.length()
        })
        .collect()
}

/// Adds to the `chosen` triangles every part of the others that they
/// enclose (all but the largest), where it is seen (`seen`): a dimple of a
/// scan, a sliver between two faces, a shallow fold. Deep pockets, hidden
/// by their rims, stay out (holes of the chart).
fn fill_pockets(graph: &EdgeGraph, chosen: &mut [bool], seen: &[bool]) {
    let n_t = chosen.len();
    let mut rest = UnionFind::new(n_t);
    for f in &graph.faces {
        if f[1] != NONE && !chosen[f[0] as usize] && !chosen[f[1] as usize] {
            rest.union(f[0] as usize, f[1] as usize);
        }
    }
    let mut size = vec![0usize; n_t];
    let mut hidden = vec![false; n_t];
    for t in (0..n_t).filter(|&t| !chosen[t]) {
        let r = rest.find(t);
        size[r] += 1;
        hidden[r] |= !seen[t];
    }
    let Some(largest) = (0..n_t)
        .filter(|&t| !chosen[t])
        .max_by_key(|&t| (size[rest.find(t)], std::cmp::Reverse(t)))
    else {
        return;
    };
    let outside = rest.find(largest);
    for (t, c) in chosen.iter_mut().enumerate().filter(|(_, c)| !**c) {
        let r = rest.find(t);
        *c = r != outside && !hidden[r];
    }
}

/// Whether each triangle is the nearest surface where it is seen: a depth
/// buffer over the projection, a cell about a triangle's size, holding the
/// nearest depth of every triangle covering it. Seen at its centre, and
/// seen at its centre and corners (strictly).
fn visible(mesh: &TriMesh, projected: &[DVec2], depth: &[f64]) -> (Vec<bool>, Vec<bool>) {
    let n_t = mesh.triangles.len();
    if n_t == 0 {
        return (Vec::new(), Vec::new());
    }
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    let (mut area, mut edge) = (0.0, 0.0);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| projected[v as usize]);
        lo = lo.min(a).min(b).min(c);
        hi = hi.max(a).max(b).max(c);
        area += 0.5 * (b - a).perp_dot(c - a).abs();
        let [p, q, r] = t.map(|v| mesh.positions[v as usize]);
        edge += (p.distance(q) + q.distance(r) + r.distance(p)) / 3.0;
    }
    let span = (hi - lo).max(DVec2::splat(1e-300));
    let cell = (area / n_t as f64)
        .sqrt()
        .max(span.max_element() / MAX_CELLS as f64)
        .max(1e-300);
    let nx = ((span.x / cell).ceil() as usize).clamp(1, MAX_CELLS);
    let ny = ((span.y / cell).ceil() as usize).clamp(1, MAX_CELLS);
    let cell_of = |p: DVec2| {
        let q = (p - lo) / cell;
        ((q.x as usize).min(nx - 1), (q.y as usize).min(ny - 1))
    };
    let mut nearest = vec![f64::NEG_INFINITY; nx * ny];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| projected[v as usize]);
        let [da, db, dc] = t.map(|v| depth[v as usize]);
        let (x0, y0) = cell_of(a.min(b).min(c));
        let (x1, y1) = cell_of(a.max(b).max(c));
        let twice = (b - a).perp_dot(c - a);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let p = lo + DVec2::new(x as f64 + 0.5, y as f64 + 0.5) * cell;
                let d = if twice.abs() > 0.0 {
                    let wa = (b - p).perp_dot(c - p) / twice;
                    let wb = (c - p).perp_dot(a - p) / twice;
                    let wc = 1.0 - wa - wb;
                    if wa < -1e-9 || wb < -1e-9 || wc < -1e-9 {
                        continue;
                    }
                    wa * da + wb * db + wc * dc
                } else {
                    da.max(db).max(dc)
                };
                let k = y * nx + x;
                nearest[k] = nearest[k].max(d);
            }
        }
        // A triangle smaller than a cell marks the cell of its centre.
        let (cx, cy) = cell_of((a + b + c) / 3.0);
        let k = cy * nx + cx;
        nearest[k] = nearest[k].max((da + db + dc) / 3.0);
    }
    let tolerance = HIDDEN_DEPTH * edge / n_t as f64;
    let seen_at = |p: DVec2, d: f64| {
        let (x, y) = cell_of(p);
        d >= nearest[y * nx + x] - tolerance
    };
    // Strictly, its corners too: a triangle half behind another part
    // (where a far part comes out from behind a near one) is hidden, so
    // the parts seen do not overlap where the camera shows them.
    mesh.triangles
        .iter()
        .map(|t| {
            let centre = t.iter().map(|&v| projected[v as usize]).sum::<DVec2>() / 3.0;
            let d = t.iter().map(|&v| depth[v as usize]).sum::<f64>() / 3.0;
            let at_centre = seen_at(centre, d);
            let strictly = at_centre && t.iter().all(|&v| seen_at(projected[v as usize], depth[v as usize]));
            (at_centre, strictly)
        })
        .unzip()
}

/// Leaves out every chosen triangle across an unseamable edge from one
/// that is not chosen, until none is: a polygon is never split.
fn keep_polygons_out(graph: &EdgeGraph, unseamable: &[[u32; 2]], chosen: &mut [bool]) {
    if unseamable.is_empty() {
        return;
    }
    loop {
        let mut moved = false;
        for (e, edge) in graph.edges.iter().enumerate() {
            let [t0, t1] = graph.faces[e];
            if t1 != NONE && chosen[t0 as usize] != chosen[t1 as usize] && unseamable.binary_search(edge).is_ok() {
                chosen[t0 as usize] = false;
                chosen[t1 as usize] = false;
                moved = true;
            }
        }
        if !moved {
            return;
        }
    }
}

/// The edge-connected parts of the `chosen` triangles that touch a
/// landmark (a landmark touches a part through any of its triangles), or
/// `None` when a landmark touches none.
fn landmarks_part(graph: &EdgeGraph, mesh: &TriMesh, chosen: &[bool], landmarks: &[u32]) -> Option<Vec<bool>> {
    let n_t = chosen.len();
    let mut parts = UnionFind::new(n_t);
    for f in &graph.faces {
        if f[1] != NONE && chosen[f[0] as usize] && chosen[f[1] as usize] {
            parts.union(f[0] as usize, f[1] as usize);
        }
    }
    let is_landmark = crate::mesh::marked(mesh.n_vertices(), landmarks);
    let (mut touched, mut holding) = (vec![false; mesh.n_vertices()], vec![false; n_t]);
    for (t, tri) in mesh.triangles.iter().enumerate().filter(|(t, _)| chosen[*t]) {
        for &v in tri.iter().filter(|&&v| is_landmark[v as usize]) {
            touched[v as usize] = true;
            holding[parts.find(t)] = true;
        }
    }
    if !landmarks.iter().all(|&l| touched[l as usize]) {
        return None;
    }
    let mut part: Vec<bool> = (0..n_t).map(|t| chosen[t] && holding[parts.find(t)]).collect();
    // Every triangle around a landmark with it: a landmark is never on the
    // border between its chart and what is laid out apart.
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if tri.iter().any(|&v| is_landmark[v as usize]) {
            part[t] = true;
        }
    }
    Some(part)
}

/// The camera's view of `positions` (a chart's vertices), in layout coordinates.
pub fn projection(camera: &Camera, positions: &[DVec3]) -> Vec<DVec2> {
    positions.iter().map(|&p| camera.project(p)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::uv_sphere;

    #[test]
    fn a_camera_is_recovered_from_its_own_projection() {
        let rows = [DVec3::new(0.3, 0.1, -0.2), DVec3::new(-0.05, 0.25, 0.15)];
        let offset = DVec2::new(0.4, 0.6);
        let truth = Camera { rows, offset };
        let points: Vec<DVec3> = (0..9)
            .map(|i| DVec3::new((i as f64).sin(), (i as f64 * 1.7).cos(), (i as f64 * 0.3).sin()))
            .collect();
        let targets: Vec<DVec2> = points.iter().map(|&p| truth.project(p)).collect();
        let fit = Camera::fit(&points, &targets).expect("a view");
        assert!(fit.residual(&points, &targets) < 1e-6);
        assert!((fit.towards() - rows[0].cross(rows[1]).normalize()).length() < 1e-6);
        let line: Vec<DVec3> = (0..5).map(|i| DVec3::X * i as f64).collect();
        assert_eq!(
            Camera::fit(&line, &targets[..5]),
            None,
            "collinear landmarks fix no view"
        );
    }

    #[test]
    fn a_view_seen_whole_keeps_what_reaches_past_the_room() {
        let sphere = uv_sphere(24, 36);
        // The view spans 0.2..0.8; the room only 0.35..0.65.
        let camera = Camera {
            rows: [DVec3::new(0.3, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.3)],
            offset: DVec2::splat(0.5),
        };
        let room = (DVec2::splat(0.35), DVec2::splat(0.65));
        let projected = projection(&camera, &sphere.positions);
        let outside = |v: u32| {
            let p = projected[v as usize];
            !(p.cmpge(room.0).all() && p.cmple(room.1).all())
        };
        // Landmarks in the room on triangles that reach out of it.
        let landmarks: Vec<u32> = (0..sphere.n_vertices() as u32)
            .filter(|&v| sphere.positions[v as usize].y < -0.3 && !outside(v))
            .filter(|&v| {
                sphere
                    .triangles
                    .iter()
                    .any(|t| t.contains(&v) && t.iter().any(|&w| outside(w)))
            })
            .collect();
        assert!(!landmarks.is_empty());
        let region = facing_region(&sphere, (&camera, Sight::Whole), (&landmarks, &[]), room, &[]).expect("a part");
        let past = sphere
            .triangles
            .iter()
            .zip(&region)
            .filter(|(t, kept)| **kept && t.iter().any(|&v| outside(v)))
            .count();
        assert!(past > sphere.n_triangles() / 8, "{past} triangles past the room");
        let near = facing_region(&sphere, (&camera, Sight::Near), (&landmarks, &[]), room, &[]).expect("a part");
        let near_past = sphere
            .triangles
            .iter()
            .zip(&near)
            .filter(|(t, kept)| **kept && t.iter().any(|&v| outside(v)))
            .count();
        assert!(near_past < past, "the scan's view keeps to the room: {near_past}");
    }

    #[test]
    fn a_sphere_seen_from_the_front_gives_its_front_cap_unfolded() {
        let sphere = uv_sphere(24, 36);
        // Looking along −y: the camera sees (x, z) scaled into the texture.
        let camera = Camera {
            rows: [DVec3::new(0.3, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.3)],
            offset: DVec2::splat(0.5),
        };
        assert!(camera.towards().dot(-DVec3::Y) > 0.99);
        let front: Vec<u32> = (0..sphere.n_vertices() as u32)
            .filter(|&v| sphere.positions[v as usize].y < -0.9)
            .collect();
        let region = facing_region(
            &sphere,
            (&camera, Sight::Near),
            (&front, &[]),
            (DVec2::ZERO, DVec2::ONE),
            &[],
        )
        .expect("a part");
        let kept = region.iter().filter(|&&k| k).count();
        assert!(kept > 0 && kept < sphere.n_triangles() / 2 + 40, "{kept} triangles");
        for (t, tri) in sphere.triangles.iter().enumerate().filter(|(t, _)| region[*t]) {
            let [a, b, c] = tri.map(|v| camera.project(sphere.positions[v as usize]));
            assert!((b - a).perp_dot(c - a) > 0.0, "triangle {t} projects positively");
        }
        let mirrored = Camera {
            rows: [camera.rows[1], camera.rows[0]],
            ..camera
        };
        assert_eq!(
            facing_region(
                &sphere,
                (&mirrored, Sight::Near),
                (&front, &[]),
                (DVec2::ZERO, DVec2::ONE),
                &[]
            ),
            None,
            "a mirrored view sees the back, away from the landmarks"
        );
    }
}
