//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty temporary folder for one test (removed when dropped).
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("uvpin-test-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        TempDir(dir)
    }
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `../shared/meshes/<name>`, or `None` (with a message) when `../shared` is absent.
pub fn shared_mesh(name: &str) -> Option<PathBuf> {
    let p = repo().join("../shared/meshes").join(name);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!(
            "SKIP: {} not found (../shared/meshes is beside the repository in CI)",
            p.display()
        );
        None
    }
}

/// Runs the uvpin binary.
pub fn uvpin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_uvpin"))
        .args(args)
        .output()
        .expect("run uvpin")
}

/// Runs `uvpin solve RON -o OUT --report - --quiet`: the process output and
/// the JSON report it printed (`Null` when it printed none, as on errors).
pub fn solve_json(ron: &Path, out: &Path) -> (Output, serde_json::Value) {
    let o = uvpin(&[
        "solve",
        ron.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--report",
        "-",
        "--quiet",
    ]);
    let report = serde_json::from_slice(&o.stdout).unwrap_or(serde_json::Value::Null);
    (o, report)
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Writes a constraint file; `asset` is absolute or relative to it.
pub fn write_constraints(path: &Path, asset: &Path, constraints: &[(u32, f64, f64)], extra: &str) {
    let mut text = format!("(\n    asset: {:?},\n    constraints: [\n", asset.display().to_string());
    for (v, u, w) in constraints {
        text += &format!("        (vertex: {v}, uv: ({u}, {w})),\n");
    }
    text += &format!("    ],\n{extra})\n");
    std::fs::write(path, text).expect("write constraints");
}

/// Writes a mesh as a fresh .glb (positions and indices only).
pub fn write_mesh_glb(path: &Path, mesh: &uvpin::mesh::TriMesh) {
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "test");
    uvpin::io::gltf_file::write_new_document(&json, &blob, path).expect("write glb");
}

/// Runs the independent Python reader (tests/helpers/read_gltf.py, standard
/// library only) on `path` with `args`; its JSON, or `None` (with a message)
/// without python3.
fn python_reader(path: &Path, args: &[&str]) -> Option<serde_json::Value> {
    let script = repo().join("tests/helpers/read_gltf.py");
    match Command::new("python3").arg(script).arg(path).args(args).output() {
        Ok(o) if o.status.success() => Some(serde_json::from_slice(&o.stdout).expect("reader JSON")),
        Ok(o) => panic!(
            "independent reader failed on {}: {}",
            path.display(),
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => {
            eprintln!("SKIP independent reader: python3 not available ({e})");
            None
        }
    }
}

/// Reads a glTF file back with the independent Python reader: per primitive
/// of mesh 0, its vertex count, triangle count and how many triangles of each
/// orientation TEXCOORD_<set> gives. `None` (with a message) without python3.
pub fn python_uv_orientation(path: &Path, uv_set: u32) -> Option<serde_json::Value> {
    python_reader(path, &[&uv_set.to_string()])
}

/// The texture coordinates (TEXCOORD_<set>) of primitive 0 of mesh 0, read
/// back with the independent Python reader, and its flipped + zero-area
/// triangle count. `None` (with a message) without python3.
pub fn python_uvs(path: &Path, uv_set: u32) -> Option<(Vec<[f64; 2]>, u64)> {
    let v = python_reader(path, &[&uv_set.to_string(), "uvs"])?;
    let p = &v[0];
    let uvs = p["uv"]
        .as_array()
        .expect("uv list")
        .iter()
        .map(|c| [c[0].as_f64().unwrap(), c[1].as_f64().unwrap()])
        .collect();
    let bad = p["positive"].as_u64().unwrap() + p["zero"].as_u64().unwrap();
    Some((uvs, bad))
}
