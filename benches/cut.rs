//! Closed and atlas meshes as they come, given a photo's landmarks: how long
//! the cut and the solve take, how long the seam is, and the stretch of the
//! constrained result against the same cut's unconstrained free layout and
//! against xatlas (PyPI `xatlas`, its own seams and packing, no landmarks),
//! run in the same session. `cargo bench --bench cut [FILTER]` prints a
//! table and writes it into `docs/benchmarks.md`; timings are never
//! asserted.

mod common;
use glam::{DVec2, DVec3, Vec3};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::Instant;
use uvpin::constraints::ConstraintSource;
use uvpin::io::SourceAsset;
use uvpin::mesh::TriMesh;
use uvpin::options::SolverOptions;
use uvpin::pins::Pins;
use uvpin::session::ChartSession;

/// One case: a mesh (as an asset), its landmarks and what to call it.
struct Case {
    name: String,
    asset: Arc<SourceAsset>,
    landmarks: Vec<(u32, f64, f64)>,
}

/// Medians of one case's runs, and what its last run gave.
#[derive(Debug, Default)]
struct Figures {
    vertices: usize,
    landmarks: usize,
    status: String,
    cut_ms: f64,
    solve_ms: f64,
    pack_ms: f64,
    seam: String,
    l2: f64,
    free_l2: f64,
    xatlas_l2: Option<f64>,
    xatlas_ms: Option<f64>,
    xatlas_bad: (usize, usize),
}

fn mesh_of(asset: &SourceAsset) -> TriMesh {
    let prim = &asset.primitives[0];
    TriMesh {
        positions: prim.positions.iter().map(|p| Vec3::from(*p).as_dvec3()).collect(),
        triangles: prim.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    }
}

fn procedural(name: &str, mesh: &TriMesh, view: DVec3, up: DVec3, k: usize, span: f64) -> Case {
    let landmarks = uvpin::testing::photo_landmarks(mesh, view, up, k, span);
    Case {
        name: name.into(),
        asset: Arc::new(SourceAsset::from_mesh(mesh)),
        landmarks,
    }
}

/// A shared mesh (UV set `uv_set`) with a photo's landmarks on its largest
/// welded piece, above `above` along `up`.
fn shared(file: &str, uv_set: u32, (view, up): (DVec3, DVec3), above: f64, k: usize, span: f64) -> Option<Case> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/meshes")
        .join(file);
    let asset = uvpin::io::load_asset(&path, None, uv_set, &Default::default()).ok()?;
    let mesh = mesh_of(&asset);
    let welded = uvpin::mesh::weld::weld(&asset.primitives);
    let sizes = welded.chart_sizes();
    let big = (0..sizes.len()).max_by_key(|&c| sizes[c].1)? as u32;
    let allowed: Vec<bool> = (0..mesh.n_vertices())
        .map(|v| {
            welded.chart_of_vertex[welded.vertex_of[0][v] as usize] == Some(big) && mesh.positions[v].dot(up) > above
        })
        .collect();
    let landmarks = uvpin::testing::photo_landmarks_on(&mesh, &allowed, view, up, k, span);
    Some(Case {
        name: format!("{file}{}", if uv_set > 0 { " (new UV set)" } else { "" }),
        asset: Arc::new(asset),
        landmarks,
    })
}

/// The cut, the solve and the packing `runs` times; medians.
fn run(case: &Case, runs: usize) -> Figures {
    let pins: Vec<(u32, DVec2)> = case.landmarks.iter().map(|&(v, u, w)| (v, DVec2::new(u, w))).collect();
    let source = ConstraintSource::Memory(Arc::new(Pins::new(&pins)));
    let options = SolverOptions::DEFAULT;
    let (mut cut, mut solve, mut pack) = (Vec::new(), Vec::new(), Vec::new());
    let mut last = None;
    for _ in 0..runs {
        let t0 = Instant::now();
        let mut session = ChartSession::open(source.clone(), case.asset.clone(), 0.0).expect("prepared");
        cut.push(t0.elapsed().as_secs_f64() * 1e3);
        let t1 = Instant::now();
        let solved = uvpin::assembly::solve(&mut session, &options).expect("solved");
        solve.push(t1.elapsed().as_secs_f64() * 1e3);
        let t2 = Instant::now();
        let (report, uvs) = uvpin::assembly::final_uvs(&session, &solved);
        pack.push(t2.elapsed().as_secs_f64() * 1e3);
        assert!(uvs.is_some(), "{}: {:?}", case.name, report.message);
        last = Some((session, report));
    }
    let (session, report) = last.expect("a run");
    for line in &report.explain {
        eprintln!("  {line}");
    }
    let free_l2 = uvpin::atlas::unconstrained(session.prepared(), &options).map_or(f64::NAN, |u| {
        let c = &u.chart.mesh;
        uvpin::metrics::sander_stretch(&c.positions, &u.shape.points, &c.triangles).l2
    });
    let seam = report.seam.as_ref().map_or("none".into(), |s| {
        format!(
            "{} edges, {:.2} √A{}",
            s.n_edges + s.separation_edges,
            s.relative_length,
            if s.separation_edges > 0 { ", split" } else { "" }
        )
    });
    Figures {
        vertices: case.asset.primitives[0].positions.len(),
        landmarks: case.landmarks.len(),
        status: format!("{:?}", report.status).to_lowercase(),
        cut_ms: common::median(cut),
        solve_ms: common::median(solve),
        pack_ms: common::median(pack),
        seam,
        l2: report.stretch_final.l2,
        free_l2,
        ..Figures::default()
    }
}

/// A Python with xatlas: `target/bench-venv` (shared with the free bench's
/// SLIM), else `.tools/venv`; installed there if missing.
fn xatlas_python() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let has = |p: &Path| {
        Command::new(p)
            .args(["-c", "import xatlas"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    for venv in ["target/bench-venv", ".tools/venv"] {
        let python = root.join(venv).join("bin/python");
        if python.is_file()
            && (has(&python)
                || Command::new(&python)
                    .args(["-m", "pip", "install", "-q", "xatlas", "numpy"])
                    .status()
                    .is_ok_and(|s| s.success())
                    && has(&python))
        {
            return Some(python);
        }
    }
    None
}

/// xatlas on the whole mesh welded by position: its Sander L2 (turned-over
/// charts measured the right way round), time, and how many triangles it
/// turns over and flattens.
fn xatlas(python: &Path, case: &Case) -> Option<(f64, f64, (usize, usize))> {
    let welded = uvpin::mesh::weld::weld(&[uvpin::mesh::weld::PrimitiveGeometry {
        uvs: None,
        ..case.asset.primitives[0].clone()
    }]);
    let mesh = &welded.mesh;
    let dir = std::env::temp_dir().join(format!("uvpin-bench-cut-{}", std::process::id()));
    std::fs::create_dir_all(&dir).ok()?;
    let file = dir.join("case.json");
    let v: Vec<[f64; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    std::fs::write(&file, serde_json::json!({ "v": v, "f": mesh.triangles }).to_string()).ok()?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/helpers/xatlas_run.py");
    let out = Command::new(python).arg(script).arg(&file).output().ok()?;
    let _ = std::fs::remove_dir_all(&dir);
    if !out.status.success() {
        eprintln!("xatlas: {}", String::from_utf8_lossy(&out.stderr));
        return None;
    }
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).ok()?;
    let vmapping: Vec<usize> = serde_json::from_value(r["vmapping"].clone()).ok()?;
    let triangles: Vec<[u32; 3]> = serde_json::from_value(r["f"].clone()).ok()?;
    let uv: Vec<[f64; 2]> = serde_json::from_value(r["uv"].clone()).ok()?;
    let positions: Vec<DVec3> = vmapping.iter().map(|&o| mesh.positions[o]).collect();
    let layout: Vec<DVec2> = uv.iter().map(|p| DVec2::from_array(*p)).collect();
    // xatlas turns some charts over (their texture mirrored on the
    // surface): each such triangle is measured the right way round, and
    // counted; one with no area in the texture is counted apart.
    let area =
        |t: &[u32; 3]| uvpin::guard::orientation(layout[t[0] as usize], layout[t[1] as usize], layout[t[2] as usize]);
    let mirrored = triangles.iter().filter(|t| area(t) < 0.0).count();
    let kept: Vec<[u32; 3]> = triangles
        .iter()
        .filter(|t| area(t).abs() > 1e-14)
        .map(|t| if area(t) < 0.0 { [t[0], t[2], t[1]] } else { *t })
        .collect();
    let flat = triangles.len() - kept.len();
    let l2 = uvpin::metrics::sander_stretch(&positions, &layout, &kept).l2;
    Some((l2, r["ms"].as_f64()?, (mirrored, flat)))
}

fn cases() -> Vec<Case> {
    let (head, _) = uvpin::testing::blob_head(160, 320);
    let mut out = vec![
        procedural(
            "closed head (blob, eye sockets, ears)",
            &head,
            DVec3::Y,
            DVec3::Z,
            48,
            0.7,
        ),
        procedural(
            "closed sphere, photo spanning 40 %",
            &uvpin::testing::uv_sphere(60, 120),
            DVec3::Y,
            DVec3::Z,
            24,
            0.4,
        ),
        procedural(
            "torus",
            &uvpin::testing::torus(120, 48, 1.0, 0.4),
            DVec3::Y,
            DVec3::Z,
            24,
            0.4,
        ),
    ];
    let view = |v: DVec3, u: DVec3| (v, u);
    out.extend(shared("cow.obj", 0, view(DVec3::NEG_Y, DVec3::X), f64::MIN, 24, 0.6));
    out.extend(shared("ogre.obj", 0, view(DVec3::NEG_Z, DVec3::Y), 25.0, 24, 0.6));
    out.extend(shared("Duck.glb", 1, view(DVec3::NEG_Z, DVec3::Y), f64::MIN, 16, 0.6));
    out
}

fn main() {
    let filter = common::filter();
    let python = xatlas_python();
    let mut rows = String::from(
        "| case | vertices | landmarks | status | cut ms | solve ms | pack ms | seam | L2 | L2 free, same cut | ratio | xatlas L2 | xatlas mirrored / flat triangles | xatlas ms |\n\
         |---|---:|---:|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|\n",
    );
    let mut ever = common::Reached::open("cut");
    for case in cases() {
        if filter.as_ref().is_some_and(|f| !case.name.contains(f.as_str())) {
            continue;
        }
        let runs = if case.asset.primitives[0].positions.len() > 20_000 {
            3
        } else {
            5
        };
        let mut f = run(&case, runs);
        if let Some((l2, ms, bad)) = python.as_deref().and_then(|p| xatlas(p, &case)) {
            (f.xatlas_l2, f.xatlas_ms, f.xatlas_bad) = (Some(l2), Some(ms), bad);
        }
        let opt = |x: Option<f64>, digits: usize| x.map_or("–".into(), |x| format!("{x:.digits$}"));
        rows += &format!(
            "| {} | {} | {} | {} | {:.0} | {:.0} | {:.0} | {} | {:.3} | {:.3} | {:.2} | {} | {} / {} | {} |\n",
            case.name,
            f.vertices,
            f.landmarks,
            f.status,
            f.cut_ms,
            f.solve_ms,
            f.pack_ms,
            f.seam,
            f.l2,
            f.free_l2,
            f.l2 / f.free_l2,
            opt(f.xatlas_l2, 3),
            f.xatlas_bad.0,
            f.xatlas_bad.1,
            opt(f.xatlas_ms, 0),
        );
        eprintln!("{}: {f:?}", case.name);
        ever.record(&case.name, f.status == "reached");
    }
    let body = format!(
        "Each mesh given a photo's landmarks (an orthographic view of visible vertices on its near side, spread \
         farthest first, targets spanning 40–70 % of the texture). Cut: weld, repairs and opening to a disk; solve: \
         step 1 to polish; pack: the other pieces unwrapped and packed. Medians of 3–5 runs. L2: Sander stretch of \
         the landmarked chart; L2 free: the same cut laid out free without landmarks; xatlas: the whole mesh welded \
         by position, its own seams, no landmarks (its charts turned over, the texture mirrored on them, are \
         measured the right way round and counted, as are triangles it leaves without area: uvpin writes neither). {}\n\n{rows}",
        if python.is_none() {
            "xatlas not measured: no Python with it."
        } else {
            ""
        }
    );
    common::publish("cut", "Closed meshes and atlases: cut, solve, stretch", &body);
    ever.finish();
}
