//! The editor's web server (threads over [`super::http`]; no async runtime:
//! the daemon is threads and channels too). It serves the page, the served
//! constraint files' meshes, textures and solves, drag previews, saves, and
//! a stream of changes (server-sent events).
//!
//! Safe by default: it binds 127.0.0.1 unless told otherwise; a request
//! whose `Host` is not the served address is refused (DNS rebinding); a
//! write must come from the page's own origin as JSON; files are named by
//! their number among the served constraint files, so no path from a
//! request ever reaches the file system, and the only file written is the
//! served constraint file itself.

use super::http::{BodyError, Limits, Method, Request, Server};
use super::hub::{FileView, Hub};
use super::preview::{PreviewReply, Previewer};
use super::text::{EditError, rewrite_constraints};
use super::{page, payload};
use crate::io::InputRules;
use crate::io::content_hash;
use std::io::Write;
use std::net::{IpAddr, SocketAddr};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The editor's default address (`uvpin edit`, `uvpin watch --serve`).
pub const DEFAULT_ADDR: &str = "127.0.0.1:7878";

/// Request bodies larger than this are refused.
const MAX_BODY: usize = 4 << 20;

/// Request-handling threads (event streams get their own).
const WORKERS: usize = 4;

/// How often an idle event stream sends a comment (to notice closed pages).
const KEEPALIVE: Duration = Duration::from_secs(10);

/// Event streams open at once at most (each holds a thread).
const MAX_STREAMS: usize = 32;

/// A reply: status, content type, body.
struct Reply {
    status: u16,
    content_type: &'static str,
    body: Vec<u8>,
}

impl Reply {
    fn json(status: u16, value: &serde_json::Value) -> Reply {
        Reply {
            status,
            content_type: "application/json",
            body: value.to_string().into_bytes(),
        }
    }

    fn error(status: u16, message: impl std::fmt::Display) -> Reply {
        Reply::json(status, &serde_json::json!({ "error": message.to_string() }))
    }
}

/// What the request threads share.
struct Context {
    hub: Arc<Hub>,
    previewer: Previewer,
    /// `Host` values this server answers to.
    hosts: Vec<String>,
    /// The port, for hosts allowed by rule (an unspecified bind address).
    port: u16,
    any_ip: bool,
    input: InputRules,
    textures: Mutex<Vec<EncodedTexture>>,
    /// Held across a save's read, check and write: two saves of one base
    /// never both pass the check.
    saving: Mutex<()>,
    /// Event streams open now.
    streams: std::sync::atomic::AtomicUsize,
}

/// A texture encoded as PNG for one file, and what it was made from.
struct EncodedTexture {
    file: usize,
    source: String,
    png: Arc<Vec<u8>>,
}

/// The running server.
pub struct EditorServer {
    server: Arc<Mutex<Server>>,
    context: Arc<Context>,
    threads: Vec<std::thread::JoinHandle<()>>,
    pub url: String,
    /// Bound to a loopback address only.
    pub loopback: bool,
}

/// The `Host` values a server bound to `addr` answers to.
fn allowed_hosts(addr: SocketAddr) -> Vec<String> {
    let port = addr.port();
    let mut hosts = vec![match addr.ip() {
        IpAddr::V4(ip) => format!("{ip}:{port}"),
        IpAddr::V6(ip) => format!("[{ip}]:{port}"),
    }];
    if addr.ip().is_loopback() || addr.ip().is_unspecified() {
        hosts.extend([
            format!("localhost:{port}"),
            format!("127.0.0.1:{port}"),
            format!("[::1]:{port}"),
        ]);
    }
    hosts
}

impl EditorServer {
    /// Binds `addr` and starts serving `hub`; reads textures within `input`;
    /// previews charts above `coarse_above` vertices on their coarse level.
    ///
    /// # Errors
    /// The address cannot be parsed or bound (in use, not permitted).
    pub fn start(addr: &str, hub: Arc<Hub>, input: InputRules, coarse_above: usize) -> anyhow::Result<EditorServer> {
        let wanted: SocketAddr = addr.parse().map_err(|_| {
            anyhow::anyhow!("--addr {addr}: expected HOST:PORT with an IP address, such as {DEFAULT_ADDR}")
        })?;
        let limits = Limits {
            body: MAX_BODY,
            ..Limits::DEFAULT
        };
        let server = Server::bind(wanted, limits).map_err(|e| {
            anyhow::anyhow!("cannot serve the editor on {addr}: {e} (another program may use the port: try --addr 127.0.0.1:0 for any free one)")
        })?;
        let bound = server.addr();
        let context = Arc::new(Context {
            hub,
            previewer: Previewer::start(coarse_above),
            hosts: allowed_hosts(bound),
            port: bound.port(),
            any_ip: bound.ip().is_unspecified(),
            input,
            textures: Mutex::new(Vec::new()),
            saving: Mutex::new(()),
            streams: std::sync::atomic::AtomicUsize::new(0),
        });
        let requests = server.requests();
        let server = Arc::new(Mutex::new(server));
        let threads = (0..WORKERS)
            .map(|k| {
                let (requests, context) = (requests.clone(), context.clone());
                std::thread::Builder::new()
                    .name(format!("uvpin-http-{k}"))
                    .spawn(move || serve(&requests, &context))
                    .expect("a thread")
            })
            .collect();
        let host = if bound.ip().is_unspecified() {
            format!("127.0.0.1:{}", bound.port())
        } else {
            context.hosts[0].clone()
        };
        Ok(EditorServer {
            server,
            context,
            threads,
            url: format!("http://{host}/"),
            loopback: bound.ip().is_loopback(),
        })
    }

    /// Stops serving: event streams end, the threads are joined.
    pub fn stop(self) {
        self.context.hub.close();
        self.server
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .close();
        for t in self.threads {
            let _ = t.join();
        }
    }
}

fn serve(requests: &super::http::Requests, context: &Arc<Context>) {
    while let Some(mut request) = requests.recv() {
        if context.hub.is_closed() {
            request.respond(503, &[], b"");
            break;
        }
        if let Err(reply) = check_request(context, &request) {
            respond(request, reply);
            continue;
        }
        if request.method == Method::Get && request.url == "/api/events" {
            open_stream(request, context);
            continue;
        }
        // A bug in one request must not take a thread of the server down.
        let reply = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| route(context, &mut request)))
            .unwrap_or_else(|_| Reply::error(500, "internal error"));
        respond(request, reply);
    }
}

/// Streams events to `request` on a thread of its own, or answers 503 when
/// too many streams are open.
fn open_stream(request: Request, context: &Arc<Context>) {
    use std::sync::atomic::Ordering;
    if context.streams.fetch_add(1, Ordering::SeqCst) >= MAX_STREAMS {
        context.streams.fetch_sub(1, Ordering::SeqCst);
        return respond(request, Reply::error(503, "too many open editor pages"));
    }
    let (mine, slot) = (context.clone(), context.clone());
    let spawned = std::thread::Builder::new().name("uvpin-events".into()).spawn(move || {
        stream_events(request, &mine);
        mine.streams.fetch_sub(1, Ordering::SeqCst);
    });
    if spawned.is_err() {
        slot.streams.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Whether `host` names this server.
fn host_allowed(context: &Context, host: &str) -> bool {
    if context.hosts.iter().any(|h| h.eq_ignore_ascii_case(host)) {
        return true;
    }
    // Bound to every address: any IP literal with the port (never a name).
    context.any_ip && host.parse::<SocketAddr>().is_ok_and(|a| a.port() == context.port)
}

/// The `Host` must name this server; a write must come from the page (its
/// origin, as JSON).
fn check_request(context: &Context, request: &Request) -> Result<(), Reply> {
    let host = request.header("Host").unwrap_or("");
    if !host_allowed(context, host) {
        return Err(Reply::error(403, "this server answers only to its own address"));
    }
    if request.method == Method::Get || request.method == Method::Head {
        return Ok(());
    }
    if request.method != Method::Post {
        return Err(Reply::error(405, "only GET and POST"));
    }
    let origin_ok = request
        .header("Origin")
        .is_none_or(|o| o.eq_ignore_ascii_case(&format!("http://{host}")));
    let site_ok = request
        .header("Sec-Fetch-Site")
        .is_none_or(|s| s == "same-origin" || s == "none");
    let json = request
        .header("Content-Type")
        .is_some_and(|t| t.starts_with("application/json"));
    if !(origin_ok && site_ok && json) {
        return Err(Reply::error(
            403,
            "writes are accepted only from the editor's own page, as JSON",
        ));
    }
    Ok(())
}

fn respond(request: Request, reply: Reply) {
    let headers = [
        ("Content-Type", reply.content_type),
        ("Cache-Control", "no-store"),
        ("X-Content-Type-Options", "nosniff"),
        ("X-Frame-Options", "DENY"),
        ("Referrer-Policy", "no-referrer"),
        (
            "Content-Security-Policy",
            "default-src 'self'; img-src 'self' blob: data:; script-src 'self'; style-src 'self'; connect-src 'self'; frame-ancestors 'none'",
        ),
    ];
    let body = if request.method == Method::Head {
        &[][..]
    } else {
        &reply.body[..]
    };
    let status = reply.status;
    request.respond(status, &headers, body);
}

/// The file id in `/api/file/{id}/…` and the rest of the path.
fn file_route(url: &str) -> Option<(usize, &str)> {
    let rest = url.strip_prefix("/api/file/")?;
    let (id, tail) = rest.split_once('/').unwrap_or((rest, ""));
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) || id.len() > 9 {
        return None;
    }
    Some((id.parse().ok()?, tail))
}

fn route(context: &Context, request: &mut Request) -> Reply {
    // The query only defeats caches (`?asset=…`); it selects nothing.
    let url = request.url.split('?').next().unwrap_or("").to_string();
    let method = request.method.clone();
    if let Some(asset) = page::asset(&url).filter(|_| method == Method::Get) {
        return Reply {
            status: 200,
            content_type: asset.content_type,
            body: asset.body.as_bytes().to_vec(),
        };
    }
    if url == "/api/files" && method == Method::Get {
        let (version, files) = context.hub.summary();
        return Reply::json(200, &serde_json::json!({ "version": version, "files": files }));
    }
    let Some((id, tail)) = file_route(&url) else {
        return Reply::error(404, "not found");
    };
    let Some(view) = context.hub.file(id) else {
        return Reply::error(404, "no such constraint file");
    };
    match (method, tail) {
        (Method::Get, "") => Reply::json(200, &payload::state(&view, texture_key(context, &view))),
        (Method::Get, "mesh") => match &view.inputs {
            Some(i) => Reply::json(200, &payload::mesh(&i.asset)),
            None => Reply::error(409, "the file has not loaded yet"),
        },
        (Method::Get, "texture") => texture(context, &view),
        (Method::Post, "preview") => match read_json(request) {
            Ok(body) => preview(context, &view, &body),
            Err(e) => e,
        },
        (Method::Post, "save") => match read_json(request) {
            Ok(body) => save(context, &view, &body),
            Err(e) => e,
        },
        _ => Reply::error(404, "not found"),
    }
}

fn read_json(request: &mut Request) -> Result<serde_json::Value, Reply> {
    let body = request.read_body(MAX_BODY).map_err(|e| match e {
        BodyError::TooLarge => Reply::error(413, "request too large"),
        BodyError::Unreadable => Reply::error(400, "the body must come with its Content-Length, whole"),
    })?;
    serde_json::from_slice(&body).map_err(|e| Reply::error(400, format!("not JSON: {e}")))
}

/// The file's `image:` path, if it names one.
fn image_path(inputs: &super::hub::EditInputs) -> Option<std::path::PathBuf> {
    let image = inputs.loaded.file.image.as_ref()?;
    Some(
        inputs
            .loaded
            .path
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join(image),
    )
}

/// The key of the file's texture when it has one: the image it names (if
/// it may read it) with its size and modification time, so a repainted or
/// renamed image gets a new key; else its asset's base-colour texture
/// (decoded once per asset and kept).
fn texture_key(context: &Context, view: &FileView) -> Option<String> {
    let inputs = view.inputs.as_ref()?;
    match image_path(inputs) {
        Some(path) => (path.is_file() && context.input.scope.allows(&path)).then(|| image_key(inputs, &path)),
        None => crate::preview::texture::base_colour_texture(&inputs.asset)
            .map(|_| format!("asset {:p}", Arc::as_ptr(&inputs.asset))),
    }
}

/// An `image:` file's key: its name, size and modification time.
fn image_key(inputs: &super::hub::EditInputs, path: &std::path::Path) -> String {
    let image = inputs.loaded.file.image.as_deref().unwrap_or_default();
    let stamp = std::fs::metadata(path).map(|m| (m.len(), m.modified().ok())).ok();
    format!("image {image} {stamp:?}")
}

fn texture(context: &Context, view: &FileView) -> Reply {
    let Some(inputs) = &view.inputs else {
        return Reply::error(409, "the file has not loaded yet");
    };
    // An image is known by its size and modification time too, so a
    // repainted image is served anew.
    let source = match image_path(inputs) {
        Some(path) => image_key(inputs, &path),
        None => format!("asset {:p}", Arc::as_ptr(&inputs.asset)),
    };
    let mut cache = context
        .textures
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(t) = cache.iter().find(|t| t.file == view.id && t.source == source) {
        return png_reply(&t.png);
    }
    let image = match image_path(inputs) {
        Some(path) => crate::preview::texture::load_image(&path, &context.input)
            .map(Arc::new)
            .map_err(|e| e.to_string()),
        None => crate::preview::texture::base_colour_texture(&inputs.asset)
            .ok_or_else(|| "the asset's material has no base-colour texture".to_string()),
    };
    match image {
        Ok(image) => {
            let png = Arc::new(crate::preview::texture::png_bytes(&image));
            cache.retain(|t| t.file != view.id);
            cache.push(EncodedTexture {
                file: view.id,
                source,
                png: png.clone(),
            });
            png_reply(&png)
        }
        Err(e) => Reply::error(404, e),
    }
}

fn png_reply(png: &Arc<Vec<u8>>) -> Reply {
    Reply {
        status: 200,
        content_type: "image/png",
        body: png.to_vec(),
    }
}

fn preview(context: &Context, view: &FileView, body: &serde_json::Value) -> Reply {
    let Some(inputs) = view.inputs.clone() else {
        return Reply::error(409, "the file has not loaded yet");
    };
    let wanted = match payload::wanted(body, inputs.loaded.file.primitive) {
        Ok(w) => w,
        Err(e) => return Reply::error(400, e),
    };
    let seq = body.get("seq").cloned().unwrap_or(serde_json::Value::Null);
    // The daemon's solve is a start only if it solved this very asset.
    let seed = view
        .solved
        .as_ref()
        .filter(|s| Arc::ptr_eq(&s.asset, &inputs.asset))
        .map(|s| s.session.clone());
    match context.previewer.solve(inputs, seed, wanted) {
        PreviewReply::Solved(p) => {
            let held = body.get("coarse_key").and_then(serde_json::Value::as_str);
            Reply::json(200, &payload::preview(&p, seq, held))
        }
        PreviewReply::Superseded => Reply::json(200, &serde_json::json!({ "seq": seq, "superseded": true })),
        PreviewReply::Invalid(message) => Reply::json(200, &serde_json::json!({ "seq": seq, "invalid": message })),
    }
}

/// Rewrites the served constraint file with the page's list, if the file is
/// still the content the page edited.
fn save(context: &Context, view: &FileView, body: &serde_json::Value) -> Reply {
    let Some(inputs) = &view.inputs else {
        return Reply::error(409, "the file has not loaded yet");
    };
    let wanted = match payload::wanted(body, inputs.loaded.file.primitive) {
        Ok(w) => w,
        Err(e) => return Reply::error(400, e),
    };
    let base = body.get("base").and_then(serde_json::Value::as_str);
    let _one_at_a_time = context.saving.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let limit = context.input.limits.max_text_bytes;
    let bytes = match crate::io::read::read_regular(&view.path, limit, &crate::io::ReadScope::Anywhere) {
        Ok(b) => b,
        Err(e) => return Reply::error(409, format!("cannot read {}: {e}", view.name)),
    };
    let hash = content_hash(&bytes);
    if base != Some(payload::hash_text(hash).as_str()) || hash != inputs.text_hash {
        return Reply::error(
            409,
            "the file changed on disk since the page loaded it; its new content is shown",
        );
    }
    let Ok(text) = String::from_utf8(bytes) else {
        return Reply::error(409, "the file is not UTF-8 text");
    };
    let new_text = match rewrite_constraints(&text, &inputs.loaded, &inputs.existing, &wanted) {
        Ok(t) => t,
        Err(e @ EditError::Mismatch(_)) => return Reply::error(500, e),
        Err(e) => return Reply::error(400, e),
    };
    if new_text == text {
        // Nothing to write (a label trimmed back, a target rounded to where
        // it was): the daemon has this content already.
        return Reply::json(
            200,
            &serde_json::json!({ "hash": payload::hash_text(hash), "unchanged": true }),
        );
    }
    if let Err(e) = check_against_asset(&new_text, inputs) {
        return Reply::error(400, e.to_string());
    }
    if let Err(e) = crate::io::atomic::write_atomically(&view.path, new_text.as_bytes()) {
        return Reply::error(500, format!("cannot write {}: {}", view.name, e.message));
    }
    Reply::json(
        200,
        &serde_json::json!({ "hash": payload::hash_text(content_hash(new_text.as_bytes())) }),
    )
}

/// The new text must give constraints the asset can take (vertices that
/// exist, in one chart, targets apart), or nothing is written.
fn check_against_asset(text: &str, inputs: &super::hub::EditInputs) -> Result<(), crate::Error> {
    let defaults = inputs.loaded.solver;
    let loaded = crate::constraints::LoadedConstraints::parse_with_defaults(&inputs.loaded.path, text, &defaults)?;
    let source = crate::constraints::ConstraintSource::File(Arc::new(loaded));
    crate::chart::prepare(&source, &inputs.asset).map(|_| ())
}

/// A server-sent event stream: the file list whenever the hub's version moves.
fn stream_events(request: Request, context: &Context) {
    let mut out = request.into_stream();
    let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
                X-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n";
    if out.write_all(head.as_bytes()).and_then(|()| out.flush()).is_err() {
        return;
    }
    let mut seen = 0;
    loop {
        let (version, files) = context.hub.summary();
        let message = if version != seen {
            seen = version;
            let data = serde_json::json!({ "version": version, "files": files });
            format!("event: files\ndata: {data}\n\n")
        } else {
            ": idle\n\n".to_string()
        };
        if out.write_all(message.as_bytes()).and_then(|()| out.flush()).is_err() {
            return;
        }
        if context.hub.wait(seen, KEEPALIVE).is_none() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_routes_take_only_numbers() {
        assert_eq!(file_route("/api/file/3/mesh"), Some((3, "mesh")));
        assert_eq!(file_route("/api/file/12"), Some((12, "")));
        for bad in [
            "/api/file/../x",
            "/api/file/-1",
            "/api/file/",
            "/api/file/1e3/mesh",
            "/api/file/99999999999",
        ] {
            assert_eq!(file_route(bad), None, "{bad}");
        }
    }

    #[test]
    fn hosts_are_the_bound_address_and_loopback_names() {
        let h = allowed_hosts("127.0.0.1:7878".parse().unwrap());
        assert!(h.contains(&"localhost:7878".to_string()) && h.contains(&"127.0.0.1:7878".to_string()));
        let h = allowed_hosts("192.168.1.5:80".parse().unwrap());
        assert_eq!(h, vec!["192.168.1.5:80".to_string()]);
    }
}
