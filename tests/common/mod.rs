//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod daemon;

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

/// `../shared/meshes/<name>`. Tests that use it are trials that need
/// [`Needs::SharedMeshes`]: ignored when the folder is absent, outside CI.
///
/// # Panics
/// When the file is missing.
pub fn shared_mesh(name: &str) -> PathBuf {
    let p = repo().join("../shared/meshes").join(name);
    assert!(p.is_file(), "{} not found", p.display());
    p
}

/// What a test needs beyond the repository, and may be absent on a
/// developer's machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Needs {
    /// Third-party meshes in `../shared/meshes` (beside the repository in CI).
    SharedMeshes,
    /// Node and the Khronos glTF validator in `.tools/` (the README's test command installs it).
    Validator,
    /// Chromium (`/usr/bin/chromium`, or `$CHROMIUM`) and playwright-core in `.tools/`.
    Browser,
}

impl Needs {
    /// Why the need is not met, if it is not.
    fn missing(self) -> Option<&'static str> {
        match self {
            Needs::SharedMeshes => (!repo().join("../shared/meshes").is_dir()).then_some("../shared/meshes not found"),
            Needs::Validator => validator_module()
                .is_none()
                .then_some("gltf-validator not installed (npm install --prefix .tools gltf-validator)"),
            Needs::Browser => {
                if !chromium().is_file() {
                    Some("Chromium not installed (apt install chromium, or set CHROMIUM)")
                } else if !repo()
                    .join(".tools/node_modules/playwright-core/package.json")
                    .is_file()
                {
                    Some("playwright-core not installed (npm install --prefix .tools playwright-core)")
                } else {
                    None
                }
            }
        }
    }
}

/// The Chromium binary the browser tests drive.
pub fn chromium() -> PathBuf {
    std::env::var_os("CHROMIUM").map_or_else(|| PathBuf::from("/usr/bin/chromium"), PathBuf::from)
}

/// The Khronos validator's npm module, if installed.
pub fn validator_module() -> Option<PathBuf> {
    [
        std::env::var_os("GLTF_VALIDATOR_MODULE").map(PathBuf::from),
        Some(repo().join(".tools/node_modules/gltf-validator")),
    ]
    .into_iter()
    .flatten()
    .find(|p| p.join("package.json").is_file())
}

/// A test of a `harness = false` file: its name, what it needs, its body.
pub type Case = (&'static str, &'static [Needs], fn());

/// Runs `cases` with libtest's output and arguments. A case whose needs
/// are not met is reported as *ignored* (in the summary's count, with the
/// reason on its line), except in CI (where `CI` is set): there it runs,
/// and fails on what is missing.
pub fn run_cases(cases: &[Case]) -> std::process::ExitCode {
    let args = libtest_mimic::Arguments::from_args();
    let in_ci = std::env::var_os("CI").is_some();
    let trials = cases
        .iter()
        .map(|&(name, needs, body)| {
            let missing = needs.iter().find_map(|n| n.missing()).filter(|_| !in_ci);
            let trial = libtest_mimic::Trial::test(name, move || {
                body();
                Ok(())
            });
            match missing {
                Some(reason) => trial.with_kind(format!("needs: {reason}")).with_ignored_flag(true),
                None => trial,
            }
        })
        .collect();
    libtest_mimic::run(&args, trials).exit_code()
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
    solve_json_with(ron, out, &[])
}

/// [`solve_json`] with more arguments (`--explain`, ...).
pub fn solve_json_with(ron: &Path, out: &Path, more: &[&str]) -> (Output, serde_json::Value) {
    let mut args = vec![
        "solve",
        ron.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--report",
        "-",
        "--quiet",
    ];
    args.extend_from_slice(more);
    let o = uvpin(&args);
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
/// `mesh` as OBJ text (`v` and `f` lines).
pub fn obj_text(mesh: &uvpin::mesh::TriMesh) -> String {
    let mut text = String::new();
    for p in &mesh.positions {
        text += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in &mesh.triangles {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    text
}

pub fn write_mesh_glb(path: &Path, mesh: &uvpin::mesh::TriMesh) {
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (json, blob) = uvpin::io::gltf_file::new_document(&positions, &indices, None, "test");
    uvpin::io::gltf_file::write_new_document(&json, &blob, path).expect("write glb");
}

/// Runs the independent Python reader (tests/helpers/read_gltf.py, standard
/// library only) on `path` with `args`; its JSON.
///
/// # Panics
/// Without python3 (a prerequisite of the tests), or when the reader fails.
fn python_reader(path: &Path, args: &[&str]) -> serde_json::Value {
    let script = repo().join("tests/helpers/read_gltf.py");
    match Command::new("python3").arg(script).arg(path).args(args).output() {
        Ok(o) if o.status.success() => serde_json::from_slice(&o.stdout).expect("reader JSON"),
        Ok(o) => panic!(
            "independent reader failed on {}: {}",
            path.display(),
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => panic!("python3 runs the tests' independent glTF reader: {e}"),
    }
}

/// Reads a glTF file back with the independent Python reader: per primitive
/// of mesh 0, its vertex count, triangle count and how many triangles of each
/// orientation TEXCOORD_<set> gives.
pub fn python_uv_orientation(path: &Path, uv_set: u32) -> serde_json::Value {
    python_reader(path, &[&uv_set.to_string()])
}

/// The texture coordinates (TEXCOORD_<set>) of primitive 0 of mesh 0, read
/// back with the independent Python reader, and its flipped + zero-area
/// triangle count.
pub fn python_uvs(path: &Path, uv_set: u32) -> (Vec<[f64; 2]>, u64) {
    let v = python_reader(path, &[&uv_set.to_string(), "uvs"]);
    let p = &v[0];
    let uvs = p["uv"]
        .as_array()
        .expect("uv list")
        .iter()
        .map(|c| [c[0].as_f64().unwrap(), c[1].as_f64().unwrap()])
        .collect();
    let bad = p["positive"].as_u64().unwrap() + p["zero"].as_u64().unwrap();
    (uvs, bad)
}

/// Global injectivity of mesh 0's TEXCOORD_<set>, decided by the
/// independent Python reader with exact arithmetic: `islands`,
/// `crossings` (boundary edges of one island crossing), `overlapping_pairs`
/// (islands overlapping each other), `min` and `max` of the UVs.
pub fn python_injectivity(path: &Path, uv_set: u32) -> serde_json::Value {
    python_reader(path, &[&uv_set.to_string(), "injectivity"])
}

/// UV set `uv_set` of `path`, read back by the independent reader: no
/// triangle flipped or flat, no island crossing itself or another; `what`
/// names the case in a failure.
pub fn assert_read_back_one_to_one(path: &Path, uv_set: u32, what: &str) {
    for prim in python_uv_orientation(path, uv_set).as_array().unwrap() {
        assert_eq!(
            (prim["positive"].as_u64(), prim["zero"].as_u64()),
            (Some(0), Some(0)),
            "{what}: {prim}"
        );
    }
    let inj = python_injectivity(path, uv_set);
    assert_eq!(
        (inj["crossings"].as_u64(), inj["overlapping_pairs"].as_u64()),
        (Some(0), Some(0)),
        "{what}: {inj}"
    );
}

/// Every vertex attribute (and morph target attribute, `target<t>:<name>`)
/// of every primitive, per triangle corner, read back by the independent
/// Python reader: what a renderer sees at each corner.
pub fn python_corner_values(path: &Path) -> serde_json::Value {
    python_reader(path, &["0", "corners"])
}

/// The Khronos validator's report on each of `files` (one JSON each).
pub fn khronos_validate(files: &[&Path]) -> Vec<serde_json::Value> {
    let module = validator_module().expect("the validator (a need of this test)");
    let o = Command::new("node")
        .arg(repo().join("tests/helpers/validate.mjs"))
        .args(files)
        .env("GLTF_VALIDATOR_MODULE", &module)
        .output()
        .expect("node");
    assert!(o.status.success(), "validator: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("validator JSON"))
        .collect()
}

/// Address space a hostile-input run of the binary may use (bytes).
pub const MEMORY_LIMIT: u64 = 1 << 30;
/// Wall time a hostile-input run may take.
pub const TIME_LIMIT: std::time::Duration = std::time::Duration::from_secs(5);

/// Runs the uvpin binary with `args` in `cwd` under an address-space limit of
/// [`MEMORY_LIMIT`], killing it after twice [`TIME_LIMIT`]; asserts it
/// finished within [`TIME_LIMIT`] and did not panic or abort.
pub fn uvpin_limited(args: &[&str], cwd: &Path) -> Output {
    match run_limited(args, cwd, 2 * TIME_LIMIT) {
        Ok((o, elapsed)) => {
            assert!(elapsed < TIME_LIMIT, "uvpin {args:?} took {elapsed:?}");
            o
        }
        Err(why) => panic!("{why}"),
    }
}

/// Runs the uvpin binary with `args` in `cwd` under an address-space limit of
/// [`MEMORY_LIMIT`], killed after `kill_after`: its output and how long it
/// took, or why it failed (hung, panicked, aborted).
pub fn run_limited(
    args: &[&str],
    cwd: &Path,
    kill_after: std::time::Duration,
) -> Result<(Output, std::time::Duration), String> {
    use std::os::unix::process::CommandExt;
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_uvpin"));
    cmd.args(args)
        .current_dir(cwd)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    // SAFETY: setrlimit is async-signal-safe; nothing else runs in the child.
    unsafe {
        cmd.pre_exec(|| {
            let limit = libc::rlimit {
                rlim_cur: MEMORY_LIMIT,
                rlim_max: MEMORY_LIMIT,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let t0 = std::time::Instant::now();
    let mut child = cmd.spawn().expect("spawn uvpin");
    // Both pipes are drained while it runs: a long report must not fill a
    // pipe and stall the child (which would pass for a hang).
    let drain = |pipe: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut bytes);
            }
            bytes
        })
    };
    let out = drain(
        child
            .stdout
            .take()
            .map(|p| Box::new(p) as Box<dyn std::io::Read + Send>),
    );
    let err = drain(
        child
            .stderr
            .take()
            .map(|p| Box::new(p) as Box<dyn std::io::Read + Send>),
    );
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if t0.elapsed() > kill_after {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("uvpin {args:?} hung (killed after {kill_after:?})"));
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    let o = Output {
        status,
        stdout: out.join().expect("stdout"),
        stderr: err.join().expect("stderr"),
    };
    let elapsed = t0.elapsed();
    let err = stderr(&o);
    if o.status.code().is_none() || o.status.code() == Some(101) || err.contains("panicked") {
        return Err(format!("uvpin {args:?} panicked or was killed ({:?}): {err}", o.status));
    }
    Ok((o, elapsed))
}

/// Every file below `dir` with its bytes (to tell that nothing was written).
pub fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for e in entries.flatten() {
            let Ok(t) = e.file_type() else { continue };
            if t.is_dir() {
                stack.push(e.path());
            } else if t.is_file() {
                out.push((e.path(), std::fs::read(e.path()).unwrap_or_default()));
            }
        }
    }
    out.sort();
    out
}
