//! Generates the sample asset: `assets/face.glb`, a face-like curved patch
//! with two eye holes and a mouth hole, and `assets/face.uvpin.ron`, landmark
//! constraints (eye corners, nose, mouth corners, chin, brows) with targets on
//! a typical front-facing photo layout.
//!
//! It also draws `assets/face-guide.png`, a stylised front-facing face whose
//! features sit where the landmarks' targets are: the image the editor
//! places the targets on (the constraint file's `image:`).
//!
//! `cargo run --release --example make_sample` (deterministic output).

use glam::{DVec2, DVec3};
use uvpin::mesh::TriMesh;
use uvpin::mesh::topology::{Topology, TopologyError};

/// Outer outline: an ellipse; holes: eyes and mouth (centre, radii).
const OUTER: (DVec2, DVec2) = (DVec2::new(0.0, 0.0), DVec2::new(0.78, 1.0));
const HOLES: [(DVec2, DVec2); 3] = [
    (DVec2::new(-0.30, 0.22), DVec2::new(0.15, 0.07)),
    (DVec2::new(0.30, 0.22), DVec2::new(0.15, 0.07)),
    (DVec2::new(0.0, -0.45), DVec2::new(0.22, 0.06)),
];

fn inside(p: DVec2, (c, r): (DVec2, DVec2)) -> f64 {
    let q = (p - c) / r;
    q.length_squared()
}

fn in_domain(p: DVec2) -> bool {
    inside(p, OUTER) < 1.0 && HOLES.iter().all(|&h| inside(p, h) > 1.0)
}

/// Height field: an ellipsoid front with a nose, brow ridge and cheeks.
fn height(p: DVec2) -> f64 {
    let q = p / OUTER.1;
    let base = 0.55 * (1.0 - 0.85 * q.length_squared()).max(0.0).sqrt();
    let g = |c: DVec2, s: DVec2, a: f64| a * (-((p - c) / s).length_squared()).exp();
    base + g(DVec2::new(0.0, -0.05), DVec2::new(0.07, 0.22), 0.16)
        + g(DVec2::new(-0.3, 0.36), DVec2::new(0.2, 0.05), 0.03)
        + g(DVec2::new(0.3, 0.36), DVec2::new(0.2, 0.05), 0.03)
        + g(DVec2::new(-0.38, -0.2), DVec2::new(0.15, 0.15), 0.03)
        + g(DVec2::new(0.38, -0.2), DVec2::new(0.15, 0.15), 0.03)
}

/// Points of a staggered grid (near-equilateral triangles) over the face's
/// bounding box, and the triangles whose corners are all inside the outline.
fn staggered_grid() -> (Vec<DVec2>, Vec<[u32; 3]>) {
    let (nx, ny) = (47, 60);
    let mut pts = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let x = -0.8 + 1.6 * (i as f64 + if j % 2 == 1 { 0.5 } else { 0.0 }) / (nx - 1) as f64;
            let y = -1.02 + 2.04 * j as f64 / (ny - 1) as f64;
            pts.push(DVec2::new(x, y));
        }
    }
    let id = |i: usize, j: usize| (i + j * nx) as u32;
    let mut tris = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
            if j % 2 == 0 {
                tris.push([a, b, c]);
                tris.push([b, d, c]);
            } else {
                tris.push([a, d, c]);
                tris.push([a, b, d]);
            }
        }
    }
    tris.retain(|t| t.iter().all(|&v| in_domain(pts[v as usize])));
    (pts, tris)
}

/// Removes bow-ties and dangling pieces until the patch is a clean manifold,
/// then keeps its largest connected piece (removals can split off slivers).
fn clean_patch(pts: &[DVec2], mut tris: Vec<[u32; 3]>) -> TriMesh {
    let mesh = loop {
        let m = uvpin::testing::compact(TriMesh {
            positions: pts.iter().map(|p| DVec3::new(p.x, p.y, 0.0)).collect(),
            triangles: tris.clone(),
        });
        match Topology::build(&m) {
            Err(TopologyError::NonManifoldVertex { vertex, .. }) => {
                let p = m.positions[vertex as usize].truncate();
                let orig = pts.iter().position(|q| *q == p).expect("vertex") as u32;
                let first = tris.iter().position(|t| t.contains(&orig)).expect("triangle");
                tris.remove(first);
            }
            Err(e) => panic!("sample mesh: {e}"),
            Ok(_) => break m,
        }
    };
    let prim = uvpin::mesh::weld::PrimitiveGeometry {
        index: 0,
        positions: mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect(),
        indices: mesh.triangles.iter().flatten().copied().collect(),
        uvs: None,
    };
    let welded = uvpin::mesh::weld::weld(std::slice::from_ref(&prim));
    let sizes = welded.chart_sizes();
    let biggest = (0..sizes.len()).max_by_key(|&c| sizes[c].1).expect("a chart") as u32;
    welded.chart(biggest).mesh
}

/// Snaps boundary vertices onto their own outline (the outer loop onto the
/// face's, each hole's loop onto the hole nearest its centroid) where the
/// move is short (under a grid step) and keeps every triangle positive.
fn snap_to_outline(mesh: &mut TriMesh) {
    const STEP: f64 = 0.06;
    let topo = Topology::build(mesh).expect("clean patch");
    let outer = topo.outer_loop().to_vec();
    for lp in &topo.loops {
        let centroid = lp.iter().map(|&v| mesh.positions[v as usize].truncate()).sum::<DVec2>() / lp.len() as f64;
        let shape = if *lp == outer {
            OUTER
        } else {
            *HOLES
                .iter()
                .min_by(|a, b| a.0.distance(centroid).total_cmp(&b.0.distance(centroid)))
                .expect("holes")
        };
        for &v in lp {
            let p = mesh.positions[v as usize].truncate();
            let q = (p - shape.0) / shape.1;
            let snapped = shape.0 + q.normalize() * shape.1;
            if snapped.distance(p) > STEP {
                continue;
            }
            let old = mesh.positions[v as usize];
            mesh.positions[v as usize] = snapped.extend(0.0);
            let layout: Vec<DVec2> = mesh.positions.iter().map(|p| p.truncate()).collect();
            if !uvpin::guard::all_positive(&layout, &mesh.triangles) {
                mesh.positions[v as usize] = old;
            }
        }
    }
}

/// (label, point on the face): each landmark is the vertex nearest it.
const LANDMARKS: [(&str, [f64; 2]); 12] = [
    ("right eye, outer corner", [-0.45, 0.22]),
    ("right eye, inner corner", [-0.15, 0.22]),
    ("left eye, inner corner", [0.15, 0.22]),
    ("left eye, outer corner", [0.45, 0.22]),
    ("nose tip", [0.0, -0.12]),
    ("right mouth corner", [-0.22, -0.45]),
    ("left mouth corner", [0.22, -0.45]),
    ("upper lip", [0.0, -0.39]),
    ("chin", [0.0, -0.78]),
    ("right brow", [-0.3, 0.4]),
    ("left brow", [0.3, 0.4]),
    ("forehead", [0.0, 0.7]),
];

/// Where a front photo shows a point of the face (x right, y up): an
/// orthographic view from the front, the face's outline filling the
/// picture's width and height (u right, v down). Targets are the photo
/// positions of the landmark vertices themselves, so they agree with the
/// mesh around them (a mouth corner and the upper lip keep the mouth's
/// shape), and the guide draws every feature where the photo shows it.
pub fn photo(p: DVec2) -> DVec2 {
    DVec2::new(0.5 + 0.638 * p.x, 0.5 - 0.5 * p.y)
}

/// The constraint file: each landmark's nearest vertex, and corners so the face is upright.
fn constraint_text(mesh: &TriMesh, outer: &[u32]) -> String {
    let nearest_of = |candidates: &mut dyn Iterator<Item = u32>, p: DVec2| -> u32 {
        candidates
            .min_by(|&a, &b| {
                mesh.positions[a as usize]
                    .truncate()
                    .distance(p)
                    .total_cmp(&mesh.positions[b as usize].truncate().distance(p))
            })
            .expect("vertices")
    };
    let mut ron = String::from(
        "// Sample constraint file: landmarks of assets/face.glb onto a front-facing photo layout.\n\
         // Generated by `cargo run --release --example make_sample`; edit freely.\n(\n    asset: \"face.glb\",\n    // The picture the editor shows the targets on.\n    image: \"face-guide.png\",\n    constraints: [\n",
    );
    for (label, at) in LANDMARKS {
        let v = nearest_of(&mut (0..mesh.n_vertices() as u32), DVec2::from(at));
        let uv = photo(mesh.positions[v as usize].truncate());
        ron += &format!(
            "        (vertex: {v}, uv: ({:.3}, {:.3}), label: \"{label}\"),\n",
            uv[0], uv[1]
        );
    }
    // The outer-loop vertices nearest the outline's diagonals.
    let corner = |dir: DVec2| nearest_of(&mut outer.iter().copied(), OUTER.0 + dir.normalize() * OUTER.1);
    ron += &format!(
        "    ],\n    // Texture corners (outer-boundary vertices): keeps the face upright in the image.\n    \
         corners: (top_left: {}, bottom_left: {}, bottom_right: {}, top_right: {}),\n)\n",
        corner(DVec2::new(-1.0, 1.0)),
        corner(DVec2::new(-1.0, -1.0)),
        corner(DVec2::new(1.0, -1.0)),
        corner(DVec2::new(1.0, 1.0))
    );
    ron
}

fn main() {
    let (pts, tris) = staggered_grid();
    let mut mesh = clean_patch(&pts, tris);
    snap_to_outline(&mut mesh);
    for p in &mut mesh.positions {
        p.z = height(p.truncate());
    }
    let topo = Topology::build(&mesh).expect("clean patch");
    println!(
        "face patch: {} vertices, {} triangles, {} boundary loops",
        mesh.n_vertices(),
        mesh.n_triangles(),
        topo.loops.len()
    );
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "face");
    uvpin::io::gltf_file::write_new_document(&json, &blob, std::path::Path::new("assets/face.glb")).expect("write");
    std::fs::write("assets/face.uvpin.ron", constraint_text(&mesh, topo.outer_loop())).expect("write constraints");
    guide::draw(1024)
        .save_png("assets/face-guide.png")
        .expect("write the guide");
    println!("wrote assets/face.glb, assets/face.uvpin.ron and assets/face-guide.png");
}

/// The guide picture: a stylised face on the landmarks' targets (texture
/// coordinates, v down).
mod guide {
    use tiny_skia::{Color, FillRule, LineCap, Paint, Path, PathBuilder, Pixmap, Stroke, Transform};

    fn paint(r: u8, g: u8, b: u8) -> Paint<'static> {
        let mut p = Paint::default();
        p.set_color(Color::from_rgba8(r, g, b, 255));
        p.anti_alias = true;
        p
    }

    fn ellipse(cx: f32, cy: f32, rx: f32, ry: f32) -> Path {
        PathBuilder::from_oval(tiny_skia::Rect::from_xywh(cx - rx, cy - ry, 2.0 * rx, 2.0 * ry).expect("rect"))
            .expect("oval")
    }

    /// An almond between two corners, `open` high at its middle.
    fn almond(a: (f32, f32), b: (f32, f32), open: f32) -> Path {
        let mut pb = PathBuilder::new();
        let mid = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
        pb.move_to(a.0, a.1);
        pb.quad_to(mid.0, mid.1 - 2.0 * open, b.0, b.1);
        pb.quad_to(mid.0, mid.1 + 1.6 * open, a.0, a.1);
        pb.close();
        pb.finish().expect("almond")
    }

    fn curve(points: &[(f32, f32)]) -> Path {
        let mut pb = PathBuilder::new();
        pb.move_to(points[0].0, points[0].1);
        for w in points[1..].chunks(2) {
            pb.quad_to(w[0].0, w[0].1, w[1].0, w[1].1);
        }
        pb.finish().expect("curve")
    }

    pub fn draw(size: u32) -> Pixmap {
        let mut pm = Pixmap::new(size, size).expect("pixmap");
        pm.fill(Color::from_rgba8(58, 64, 74, 255));
        let t = Transform::from_scale(size as f32, size as f32);
        let line = |w: f32| Stroke {
            width: w / size as f32,
            line_cap: LineCap::Round,
            ..Stroke::default()
        };
        let fill = |pm: &mut Pixmap, path: &Path, p: &Paint| pm.fill_path(path, p, FillRule::Winding, t, None);
        // Hair, face, neck shadow.
        fill(&mut pm, &ellipse(0.5, 0.36, 0.44, 0.36), &paint(74, 50, 38));
        fill(&mut pm, &ellipse(0.5, 0.5, 0.4, 0.46), &paint(232, 194, 166));
        fill(&mut pm, &ellipse(0.5, 0.17, 0.3, 0.09), &paint(235, 199, 171));
        for (cx, cy) in [(0.27, 0.6), (0.73, 0.6)] {
            fill(&mut pm, &ellipse(cx, cy, 0.07, 0.05), &paint(234, 186, 160));
        }
        // Eyes between their corners, with irises; brows above.
        for (a, b) in [((0.215, 0.385), (0.405, 0.395)), ((0.595, 0.395), (0.785, 0.385))] {
            fill(&mut pm, &almond(a, b, 0.022), &paint(250, 248, 244));
            let c = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0 - 0.004);
            fill(&mut pm, &ellipse(c.0, c.1, 0.026, 0.026), &paint(92, 120, 70));
            fill(&mut pm, &ellipse(c.0, c.1, 0.011, 0.011), &paint(20, 20, 20));
            pm.stroke_path(&almond(a, b, 0.022), &paint(110, 70, 55), &line(3.0), t, None);
        }
        for (x0, x1) in [(0.2, 0.4), (0.6, 0.8)] {
            let brow = curve(&[(x0, 0.3), ((x0 + x1) / 2.0, 0.27), (x1, 0.3)]);
            pm.stroke_path(&brow, &paint(80, 55, 40), &line(12.0), t, None);
        }
        // Nose: the bridge, the tip, the nostrils.
        let nose = paint(176, 128, 104);
        pm.stroke_path(
            &curve(&[(0.47, 0.42), (0.455, 0.5), (0.46, 0.56)]),
            &nose,
            &line(4.0),
            t,
            None,
        );
        pm.stroke_path(
            &curve(&[(0.44, 0.59), (0.5, 0.615), (0.56, 0.59)]),
            &nose,
            &line(4.0),
            t,
            None,
        );
        fill(&mut pm, &ellipse(0.5, 0.58, 0.018, 0.014), &paint(222, 170, 146));
        // Lips around the mouth hole (an ellipse centred at (0, -0.45) of
        // radii (0.22, 0.06) on the face, at (0.5, 0.725) by (0.140, 0.030)
        // in the photo): the upper lip above its top edge, the lower lip
        // below its bottom edge, the opening dark (it is the hole).
        let (l, r) = (0.355, 0.645);
        let mut lips = PathBuilder::new();
        lips.move_to(l, 0.726);
        lips.quad_to(0.41, 0.67, 0.47, 0.668);
        lips.quad_to(0.5, 0.676, 0.53, 0.668);
        lips.quad_to(0.59, 0.67, r, 0.726);
        lips.quad_to(0.5, 0.83, l, 0.726);
        lips.close();
        fill(&mut pm, &lips.finish().expect("lips"), &paint(196, 104, 104));
        fill(&mut pm, &ellipse(0.5, 0.725, 0.142, 0.031), &paint(90, 40, 40));
        let upper = curve(&[(l, 0.726), (0.43, 0.675), (0.5, 0.676), (0.57, 0.675), (r, 0.726)]);
        pm.stroke_path(&upper, &paint(150, 72, 72), &line(2.0), t, None);
        // Chin.
        pm.stroke_path(
            &curve(&[(0.43, 0.88), (0.5, 0.9), (0.57, 0.88)]),
            &paint(200, 150, 126),
            &line(4.0),
            t,
            None,
        );
        pm
    }
}
