//! The landmark editor end to end: `uvpin edit` and `uvpin watch --serve`
//! on copies of the sample, spoken to over HTTP as the page does (and as a
//! hostile page would), and driven in real headless Chromium.

mod common;

use common::daemon::{Daemon, WAIT};
use common::*;
use serde_json::{Value, json};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A copy of the sample in `dir/assets`; the constraint file's path.
fn sample(dir: &Path) -> PathBuf {
    let assets = dir.join("assets");
    std::fs::create_dir_all(&assets).unwrap();
    for f in ["face.glb", "face.uvpin.ron", "face-guide.png"] {
        std::fs::copy(repo().join("assets").join(f), assets.join(f)).unwrap();
    }
    assets.join("face.uvpin.ron")
}

/// The editor's `host:port`, from its log.
fn address(d: &Daemon) -> String {
    let t0 = Instant::now();
    loop {
        if let Some(url) = d.log().iter().find_map(|l| l["url"].as_str().map(str::to_string)) {
            return url.trim_start_matches("http://").trim_end_matches('/').to_string();
        }
        assert!(t0.elapsed() < WAIT, "no editor address; log:\n{}", d.dump());
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// One HTTP request (`Connection: close`); the status and the body.
fn http(addr: &str, method: &str, path: &str, headers: &[(&str, &str)], body: &str) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(WAIT)).unwrap();
    let mut request = format!("{method} {path} HTTP/1.1\r\nConnection: close\r\n");
    if !headers.iter().any(|(k, _)| *k == "Content-Length") {
        request += &format!("Content-Length: {}\r\n", body.len());
    }
    if !headers.iter().any(|(k, _)| *k == "Host") {
        request += &format!("Host: {addr}\r\n");
    }
    for (k, v) in headers {
        request += &format!("{k}: {v}\r\n");
    }
    request += "\r\n";
    request += body;
    s.write_all(request.as_bytes()).unwrap();
    let mut response = Vec::new();
    s.read_to_end(&mut response).unwrap();
    let split = response
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a response head");
    let head = String::from_utf8_lossy(&response[..split]).to_string();
    let status = head.split(' ').nth(1).and_then(|c| c.parse().ok()).expect("a status");
    let body = response[split + 4..].to_vec();
    let chunked = head.to_ascii_lowercase().contains("transfer-encoding: chunked");
    (status, if chunked { unchunk(&body) } else { body })
}

/// A chunked body's bytes.
fn unchunk(mut body: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let line_end = body.windows(2).position(|w| w == b"\r\n").expect("a chunk size");
        let size = usize::from_str_radix(String::from_utf8_lossy(&body[..line_end]).trim(), 16).expect("hex size");
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&body[line_end + 2..line_end + 2 + size]);
        body = &body[line_end + 4 + size..];
    }
}

fn get_json(addr: &str, path: &str) -> Value {
    let (status, body) = http(addr, "GET", path, &[], "");
    assert_eq!(status, 200, "{path}: {}", String::from_utf8_lossy(&body));
    serde_json::from_slice(&body).unwrap()
}

/// A write as the page makes it (its own origin, JSON).
fn post(addr: &str, path: &str, value: &Value) -> (u16, Value) {
    let origin = format!("http://{addr}");
    let headers = [("Content-Type", "application/json"), ("Origin", origin.as_str())];
    let (status, body) = http(addr, "POST", path, &headers, &value.to_string());
    (status, serde_json::from_slice(&body).unwrap_or(Value::Null))
}

/// Waits until file 0's state satisfies `done`; returns it.
fn wait_state(addr: &str, d: &Daemon, done: impl Fn(&Value) -> bool) -> Value {
    let t0 = Instant::now();
    loop {
        // 404 until the daemon has found the file.
        let (status, body) = http(addr, "GET", "/api/file/0", &[], "");
        let s: Value = serde_json::from_slice(&body).unwrap_or(Value::Null);
        if status == 200 && done(&s) {
            return s;
        }
        assert!(t0.elapsed() < WAIT, "state never came: {s}\nlog:\n{}", d.dump());
        std::thread::sleep(Duration::from_millis(30));
    }
}

/// The page's list from a state, as it sends it back.
fn page_list(state: &Value) -> Vec<Value> {
    state["constraints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| json!({ "primitive": c["primitive"], "vertex": c["vertex"], "uv": c["target"], "label": c["label"] }))
        .collect()
}

fn serves_its_page_and_refuses_foreign_hosts_paths_and_origins() {
    let dir = TempDir::new("editor-safe");
    sample(&dir.0);
    let mut d = Daemon::edit(&dir.0, &["assets/face.uvpin.ron"]);
    let addr = address(&d);
    assert!(addr.starts_with("127.0.0.1:"), "{addr}");
    let (status, page) = http(&addr, "GET", "/", &[], "");
    let page = String::from_utf8(page).unwrap();
    assert_eq!(status, 200);
    for id in ["mesh-view", "texture-view", "constraint-list", "status"] {
        assert!(page.contains(&format!("data-testid=\"{id}\"")), "{id} missing");
    }
    assert!(
        !page.contains("http://") && !page.contains("https://"),
        "the page loads nothing from elsewhere"
    );
    let state = wait_state(&addr, &d, |s| s["state"] == "reached");
    let (_, mesh) = http(&addr, "GET", "/api/file/0/mesh", &[], "");
    let mesh: Value = serde_json::from_slice(&mesh).unwrap();
    assert_eq!(mesh["primitives"][0]["positions"].as_array().unwrap().len(), 1943 * 3);
    // DNS rebinding: another name for this address is refused.
    for host in ["evil.example:80", "evil.example", "", "127.0.0.2:1"] {
        let (status, _) = http(&addr, "GET", "/api/files", &[("Host", host)], "");
        assert_eq!(status, 403, "Host {host:?}");
    }
    // No path reaches the file system.
    for path in [
        "/../Cargo.toml",
        "/..%2f..%2fetc/passwd",
        "/api/file/../../assets/face.glb",
        "/assets/face.glb",
        "/api/file/7",
    ] {
        assert_eq!(http(&addr, "GET", path, &[], "").0, 404, "{path}");
    }
    // Writes only from the page's own origin, as JSON.
    let body = json!({ "base": state["hash"], "constraints": page_list(&state) }).to_string();
    let cross = [("Content-Type", "application/json"), ("Origin", "http://evil.example")];
    assert_eq!(http(&addr, "POST", "/api/file/0/save", &cross, &body).0, 403);
    let form = [("Content-Type", "text/plain")];
    assert_eq!(http(&addr, "POST", "/api/file/0/save", &form, &body).0, 403);
    let site = [("Content-Type", "application/json"), ("Sec-Fetch-Site", "cross-site")];
    assert_eq!(http(&addr, "POST", "/api/file/0/save", &site, &body).0, 403);
    assert_eq!(http(&addr, "DELETE", "/api/file/0", &[], "").0, 405);
    // Malformed writes from the page's own origin: refused, nothing written.
    let origin = format!("http://{addr}");
    let own = [("Content-Type", "application/json"), ("Origin", origin.as_str())];
    assert_eq!(http(&addr, "POST", "/api/file/0/save", &own, "{not json").0, 400);
    let claims_huge = [own[0], own[1], ("Content-Length", "100000000")];
    assert_eq!(http(&addr, "POST", "/api/file/0/save", &claims_huge, "{}").0, 413);
    let mut list = page_list(&state);
    list[0]["vertex"] = json!(999_999);
    let (status, e) = post(
        &addr,
        "/api/file/0/save",
        &json!({ "base": state["hash"], "constraints": list }),
    );
    assert_eq!(status, 400);
    assert!(e["error"].as_str().unwrap().contains("out of range"), "{e}");
    let mut list = page_list(&state);
    list[1]["uv"] = list[0]["uv"].clone();
    let (_, p) = post(&addr, "/api/file/0/preview", &json!({ "seq": 1, "constraints": list }));
    assert!(p["invalid"].as_str().is_some_and(|m| m.contains("same")), "{p}");
    let before = std::fs::read(dir.path("assets/face.uvpin.ron")).unwrap();
    assert_eq!(before, std::fs::read(repo().join("assets/face.uvpin.ron")).unwrap());
    assert!(d.terminate().success(), "SIGTERM ends it cleanly; log:\n{}", d.dump());
}

fn a_save_is_solved_written_and_a_broken_file_shows_its_error_until_fixed() {
    let dir = TempDir::new("editor-save");
    let ron = sample(&dir.0);
    let mut d = Daemon::edit(&dir.0, &["assets/face.uvpin.ron", "--out", "out"]);
    let addr = address(&d);
    let state = wait_state(&addr, &d, |s| s["state"] == "reached");
    let out = dir.path("out/face.glb");
    // The file's image, served anew (under a new key) once it is repainted.
    let texture = || http(&addr, "GET", "/api/file/0/texture", &[], "");
    let (status, guide) = texture();
    assert_eq!((status, &guide[1..4]), (200, &b"PNG"[..]));
    assert_eq!(texture().1, guide);
    let key = state["texture"].clone();
    assert!(key.as_str().is_some_and(|k| k.contains("face-guide.png")), "{state}");
    std::thread::sleep(Duration::from_millis(20));
    std::fs::copy(repo().join("docs/editor-error.png"), dir.path("assets/face-guide.png")).unwrap();
    let (status, repainted) = texture();
    assert_eq!(status, 200);
    assert_ne!(repainted, guide, "the repainted image");
    assert_ne!(get_json(&addr, "/api/file/0")["texture"], key);
    // A drag preview: solved in memory, nothing written.
    let mut list = page_list(&state);
    list[4]["uv"] = json!([0.52, 0.6]);
    list.push(json!({ "primitive": 0, "vertex": 100, "uv": [0.3, 0.8], "label": "new" }));
    let (status, preview) = post(&addr, "/api/file/0/preview", &json!({ "seq": 1, "constraints": list }));
    assert_eq!(status, 200);
    assert_eq!(preview["report"]["status"], "reached", "{preview}");
    assert_eq!(preview["report"]["flipped"], 0);
    let written = std::fs::read(&out).unwrap();
    // The save: only what changed is rewritten, comments and corners kept.
    let (status, saved) = post(
        &addr,
        "/api/file/0/save",
        &json!({ "base": state["hash"], "constraints": list }),
    );
    assert_eq!(status, 200, "{saved}");
    let text = std::fs::read_to_string(&ron).unwrap();
    let original = std::fs::read_to_string(repo().join("assets/face.uvpin.ron")).unwrap();
    let expected = original
        .replace("(vertex: 820, uv: (0.500, 0.561)", "(vertex: 820, uv: (0.52, 0.6)")
        .replace(
            "label: \"forehead\"),\n",
            "label: \"forehead\"),\n        (vertex: 100, uv: (0.3, 0.8), label: \"new\"),\n",
        );
    assert_eq!(text, expected);
    // A second save on the old base is refused: the file changed since.
    assert_eq!(
        post(
            &addr,
            "/api/file/0/save",
            &json!({ "base": state["hash"], "constraints": list })
        )
        .0,
        409
    );
    let solved = wait_state(&addr, &d, |s| s["hash"] == saved["hash"] && s["state"] == "reached");
    assert_eq!(solved["constraints"].as_array().unwrap().len(), 13);
    let (uvs, bad) = python_uvs(&out, 0);
    assert_eq!(bad, 0);
    let [u, v] = uvs[100];
    assert!(
        (u - 0.3).abs() < 1e-6 && (v - 0.8).abs() < 1e-6,
        "vertex 100 at ({u}, {v})"
    );
    assert_ne!(std::fs::read(&out).unwrap(), written);
    // Broken outside the page: the error with line:column, the output kept.
    let good = std::fs::read(&out).unwrap();
    std::fs::write(
        &ron,
        text.replace("(vertex: 100, uv: (0.3, 0.8)", "(vertex: 100 uv: (0.3, 0.8)"),
    )
    .unwrap();
    let broken = wait_state(&addr, &d, |s| s["state"] == "error");
    let error = broken["error"].as_str().unwrap();
    let line = 1 + text.lines().position(|l| l.contains("(vertex: 100,")).unwrap();
    assert!(error.contains(&format!("face.uvpin.ron:{line}:")), "{error}");
    assert_eq!(broken["editable"], false);
    assert_eq!(
        post(
            &addr,
            "/api/file/0/save",
            &json!({ "base": broken["hash"], "constraints": list })
        )
        .0,
        409
    );
    assert_eq!(std::fs::read(&out).unwrap(), good);
    std::fs::write(&ron, &text).unwrap();
    let fixed = wait_state(&addr, &d, |s| s["state"] == "reached" && s["editable"] == true);
    // Saving what the file already says writes nothing.
    let same = json!({ "base": fixed["hash"], "constraints": page_list(&fixed) });
    let (status, reply) = post(&addr, "/api/file/0/save", &same);
    assert_eq!((status, &reply["unchanged"]), (200, &json!(true)), "{reply}");
    assert_eq!(std::fs::read_to_string(&ron).unwrap(), text);
    assert!(d.terminate().success());
}

fn a_new_constraint_file_is_made_for_an_asset_and_watch_serves_every_file() {
    let dir = TempDir::new("editor-new");
    sample(&dir.0);
    std::fs::create_dir_all(dir.path("work")).unwrap();
    let mut d = Daemon::edit(&dir.0, &["work/new.uvpin.ron", "--asset", "assets/face.glb"]);
    let addr = address(&d);
    let state = wait_state(&addr, &d, |s| s["state"] == "reached");
    assert_eq!(state["constraints"], json!([]));
    let text = std::fs::read_to_string(dir.path("work/new.uvpin.ron")).unwrap();
    assert!(text.contains("asset: \"../assets/face.glb\""), "{text}");
    assert!(d.terminate().success());
    let missing = uvpin(&["edit", dir.path("nothing.uvpin.ron").to_str().unwrap()]);
    assert_eq!(missing.status.code(), Some(1));
    assert!(stderr(&missing).contains("give --asset MESH"), "{}", stderr(&missing));
    let wrong = uvpin(&["edit", dir.path("x.ron").to_str().unwrap()]);
    assert!(
        stderr(&wrong).contains("must end with .uvpin.ron"),
        "{}",
        stderr(&wrong)
    );
    // `uvpin watch --serve`: the same page, every watched file.
    let mut w = Daemon::watch(&dir.0, &["assets", "work", "--serve", "127.0.0.1:0"]);
    let addr = address(&w);
    let t0 = Instant::now();
    while get_json(&addr, "/api/files")["files"].as_array().unwrap().len() < 2 {
        assert!(t0.elapsed() < WAIT, "{}", w.dump());
        std::thread::sleep(Duration::from_millis(30));
    }
    assert!(w.terminate().success());
}

/// The largest resident size the process has had, from /proc (kB).
fn peak_kb(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).expect("VmHWM");
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// Sends `head` to `addr`, then up to 1 GiB more of its last line (until
/// the server stops reading); the status it answered, if any.
fn flood(addr: &str, head: &str) -> Option<u16> {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(WAIT)).unwrap();
    s.write_all(head.as_bytes()).unwrap();
    let chunk = vec![b'a'; 1 << 20];
    for _ in 0..1024 {
        if s.write_all(&chunk).is_err() {
            break;
        }
    }
    let mut answer = Vec::new();
    let _ = s.read_to_end(&mut answer);
    String::from_utf8_lossy(&answer)
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
}

/// Request heads past the server's limits are answered 414, 431 or 413 and
/// cost no memory: two 1 GiB header lines leave the editor alive and small.
fn oversized_requests_are_refused_and_the_editor_stays_small() {
    let dir = TempDir::new("editor-huge");
    sample(&dir.0);
    let mut d = Daemon::edit(&dir.0, &["assets/face.uvpin.ron"]);
    let addr = address(&d);
    wait_state(&addr, &d, |s| s["state"] == "reached");
    let before = peak_kb(d.child.id());
    let floods: Vec<_> = (0..2)
        .map(|_| {
            let (addr, head) = (addr.clone(), format!("GET / HTTP/1.1\r\nHost: {addr}\r\nX-Big: "));
            std::thread::spawn(move || flood(&addr, &head))
        })
        .collect();
    for f in floods {
        // The answer may be lost to a reset once the server stops reading.
        let status = f.join().unwrap();
        assert!(matches!(status, Some(431) | None), "{status:?}");
    }
    // A request line past its limit, answered before the flood fills it.
    let long_path = format!("GET /{} HTTP/1.1\r\nHost: {addr}\r\n\r\n", "a".repeat(10_000));
    let mut s = TcpStream::connect(&addr).unwrap();
    s.set_read_timeout(Some(WAIT)).unwrap();
    s.write_all(long_path.as_bytes()).unwrap();
    let mut answer = String::new();
    let _ = s.read_to_string(&mut answer);
    assert!(answer.starts_with("HTTP/1.1 414"), "{answer}");
    let origin = format!("http://{addr}");
    let big_body = [
        ("Content-Type", "application/json"),
        ("Origin", origin.as_str()),
        ("Content-Length", "100000000"),
    ];
    assert_eq!(http(&addr, "POST", "/api/file/0/save", &big_body, "{}").0, 413);
    // Alive, answering, and still small.
    assert_eq!(http(&addr, "GET", "/api/files", &[], "").0, 200);
    let after = peak_kb(d.child.id());
    assert!(
        after < 100 * 1024,
        "peak resident {after} kB (was {before} kB before the flood)"
    );
    assert!(d.terminate().success(), "{}", d.dump());
}

/// Runs `script` (in tests/browser) in Node against `uvpin edit` on a copy
/// of the sample started with `flags`, with `args` after the URL and the folder.
fn browser_script(script: &str, flags: &[&str], args: &[String]) {
    let dir = TempDir::new(&format!("editor-browser-{script}"));
    sample(&dir.0);
    let mut edit = vec!["assets/face.uvpin.ron", "--out", "out"];
    edit.extend(flags);
    let mut d = Daemon::edit(&dir.0, &edit);
    let addr = address(&d);
    let o = std::process::Command::new("node")
        .arg(repo().join("tests/browser").join(script))
        .arg(format!("http://{addr}/"))
        .arg(&dir.0)
        .args(args)
        .env("NODE_PATH", repo().join(".tools/node_modules"))
        .output()
        .expect("run node");
    let log = d.dump();
    assert!(
        o.status.success(),
        "browser test failed:\n{}\n{}\ndaemon log:\n{log}",
        stdout(&o),
        stderr(&o)
    );
    assert!(d.terminate().success());
}

fn in_chromium() {
    browser_script("editor.mjs", &[], &[]);
}

/// A drag on a chart previewed on its coarse level (`--coarse-above 0`
/// makes the sample's chart one): the landmark exact on it, the mesh
/// drawn, the release solved in full.
fn a_drag_is_previewed_on_the_coarse_level_in_chromium() {
    let asset = uvpin::io::load_asset(&repo().join("assets/face.glb"), None, 0, &Default::default()).unwrap();
    let vertices: usize = asset.primitives.iter().map(|p| p.positions.len()).sum();
    browser_script("coarse.mjs", &["--coarse-above", "0"], &[vertices.to_string()]);
}

/// A constraint file whose image lives in another folder (as `uvpin photo`
/// writes one: the photo where it was, the file beside the output): the
/// editor serves the image it names, labels and all.
fn the_image_a_file_names_elsewhere_is_served() {
    let dir = TempDir::new("editor-image-elsewhere");
    let ron = sample(&dir.0);
    std::fs::create_dir_all(dir.path("photos")).unwrap();
    std::fs::rename(dir.path("assets/face-guide.png"), dir.path("photos/face.png")).unwrap();
    std::fs::create_dir_all(dir.path("work")).unwrap();
    let text = std::fs::read_to_string(&ron)
        .unwrap()
        .replace("\"face.glb\"", "\"../assets/face.glb\"")
        .replace("\"face-guide.png\"", "\"../photos/face.png\"");
    assert!(
        text.contains("../photos/face.png"),
        "the sample names its image: {text}"
    );
    std::fs::write(dir.path("work/face.uvpin.ron"), text).unwrap();
    let d = Daemon::edit(&dir.0, &["work/face.uvpin.ron", "--out", "out"]);
    let addr = address(&d);
    let state = wait_state(&addr, &d, |s| s["state"] == "reached");
    assert!(
        state["texture"].as_str().is_some_and(|k| k.contains("photos/face.png")),
        "{state}"
    );
    let (status, png) = http(&addr, "GET", "/api/file/0/texture", &[], "");
    assert_eq!((status, &png[1..4]), (200, &b"PNG"[..]));
}

/// A closed egg standing on Z (as scanners and CAD tools export), its
/// landmarks on the +X side with targets where a camera there sees them:
/// cut open by the solve. The mesh payload names Z as up; every triangle
/// is given to the texture view either from the chart's vertex UVs (equal
/// to what the file holds) or from the written corners, never from a
/// vertex's UV that a seam splits; in Chromium the 3D view stands on Z and
/// opens facing the landmarks.
fn a_z_up_closed_mesh_opens_facing_its_landmarks_and_draws_every_triangle_where_written() {
    let dir = TempDir::new("editor-z-up");
    let mut egg = uvpin::testing::uv_sphere(20, 32);
    egg.positions.iter_mut().for_each(|p| p.z *= 2.5);
    write_mesh_glb(&dir.path("egg.glb"), &egg);
    let side: Vec<u32> = (0..egg.positions.len() as u32)
        .filter(|&v| egg.positions[v as usize].x > 0.75)
        .step_by(7)
        .take(8)
        .collect();
    let marks: Vec<(u32, f64, f64)> = side
        .iter()
        .map(|&v| {
            let p = egg.positions[v as usize];
            (v, 0.5 + 0.3 * p.y, 0.5 - 0.12 * p.z)
        })
        .collect();
    write_constraints(&dir.path("egg.uvpin.ron"), Path::new("egg.glb"), &marks, "");
    let mean = side
        .iter()
        .fold(glam::DVec3::ZERO, |s, &v| s + egg.positions[v as usize])
        / side.len() as f64;
    let mut d = Daemon::edit(&dir.0, &["egg.uvpin.ron", "--out", "out"]);
    let addr = address(&d);
    let state = wait_state(&addr, &d, |s| s["solved"].is_object());
    let mesh = get_json(&addr, "/api/file/0/mesh");
    assert_eq!(mesh["up"], json!([0.0, 0.0, 1.0]), "tallest along Z");
    let solved = &state["solved"];
    let (uvs, in_chart, written) = (&solved["uvs"][0], &solved["in_chart"][0], &solved["written"][0]);
    let n = egg.triangles.len();
    assert_eq!(
        (in_chart.as_array().unwrap().len(), written.as_array().unwrap().len()),
        (n, 6 * n)
    );
    let at = |a: &Value, k: usize| [a[2 * k].as_f64().unwrap(), a[2 * k + 1].as_f64().unwrap()];
    let mut from_corners = 0;
    for (t, tri) in egg.triangles.iter().enumerate() {
        let corners: Vec<[f64; 2]> = (0..3).map(|i| at(written, 3 * t + i)).collect();
        if in_chart[t] == 1 {
            for (i, &v) in tri.iter().enumerate() {
                assert_eq!(at(uvs, v as usize), corners[i], "triangle {t} drawn where written");
            }
        } else {
            from_corners += 1;
        }
        let [a, b, c] = [corners[0], corners[1], corners[2]];
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        assert!(area.abs() > 0.0, "triangle {t} has its place in the written set");
    }
    assert!(
        from_corners > 0,
        "the seam's triangles are drawn from the written corners"
    );
    let o = std::process::Command::new("node")
        .arg(repo().join("tests/browser/zup.mjs"))
        .arg(format!("http://{addr}/"))
        .args([mean.x, mean.y, mean.z].map(|x| x.to_string()))
        .env("NODE_PATH", repo().join(".tools/node_modules"))
        .output()
        .expect("run node");
    assert!(
        o.status.success(),
        "browser test failed:\n{}\n{}\n{}",
        stdout(&o),
        stderr(&o),
        d.dump()
    );
    assert!(d.terminate().success());
}

fn main() -> std::process::ExitCode {
    run_cases(&[
        (
            "serves_its_page_and_refuses_foreign_hosts_paths_and_origins",
            &[],
            serves_its_page_and_refuses_foreign_hosts_paths_and_origins,
        ),
        (
            "a_save_is_solved_written_and_a_broken_file_shows_its_error_until_fixed",
            &[],
            a_save_is_solved_written_and_a_broken_file_shows_its_error_until_fixed,
        ),
        (
            "a_new_constraint_file_is_made_for_an_asset_and_watch_serves_every_file",
            &[],
            a_new_constraint_file_is_made_for_an_asset_and_watch_serves_every_file,
        ),
        (
            "oversized_requests_are_refused_and_the_editor_stays_small",
            &[],
            oversized_requests_are_refused_and_the_editor_stays_small,
        ),
        (
            "the_image_a_file_names_elsewhere_is_served",
            &[],
            the_image_a_file_names_elsewhere_is_served,
        ),
        ("in_chromium", &[Needs::Browser], in_chromium),
        (
            "a_z_up_closed_mesh_opens_facing_its_landmarks_and_draws_every_triangle_where_written",
            &[Needs::Browser],
            a_z_up_closed_mesh_opens_facing_its_landmarks_and_draws_every_triangle_where_written,
        ),
        (
            "a_drag_is_previewed_on_the_coarse_level_in_chromium",
            &[Needs::Browser],
            a_drag_is_previewed_on_the_coarse_level_in_chromium,
        ),
    ])
}
