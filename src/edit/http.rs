//! A small HTTP/1.1 server for the editor, bounded everywhere: the request
//! line, each header line, the number and total size of the headers and the
//! body have limits (answered 414, 431 and 413), every connection has read
//! and write timeouts, and connections being read at once are capped. One
//! request per connection (`Connection: close`), which is all the editor's
//! page needs. A request whose head is complete goes to the worker threads
//! over a channel; a bad one is answered by the thread that read it.

use crossbeam_channel::{Receiver, Sender};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

/// How much a request may be: every field's default is the editor's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// The request line (method, path, version), bytes (default 8 KiB).
    pub request_line: usize,
    /// One header line, bytes (default 8 KiB).
    pub header_line: usize,
    /// Header lines at most (default 64).
    pub headers: usize,
    /// All header lines together, bytes (default 32 KiB).
    pub header_bytes: usize,
    /// The body, bytes (default 4 MiB).
    pub body: usize,
    /// Reading the head or the body, and writing, may stall this long (default 10 s).
    pub timeout: Duration,
    /// Connections whose head is being read at once (default 64).
    pub connections: usize,
}

impl Limits {
    pub const DEFAULT: Limits = Limits {
        request_line: 8 << 10,
        header_line: 8 << 10,
        headers: 64,
        header_bytes: 32 << 10,
        body: 4 << 20,
        timeout: Duration::from_secs(10),
        connections: 64,
    };
}

/// A request's method.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Method {
    Get,
    Head,
    Post,
    Other(String),
}

/// A request whose head has been read; its body is read on demand.
pub struct Request {
    pub method: Method,
    /// The request target as sent (path and query).
    pub url: String,
    headers: Vec<(String, String)>,
    reader: BufReader<TcpStream>,
    limits: Limits,
}

/// Why a body could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyError {
    /// Larger than the limit (413).
    TooLarge,
    /// Not sent with a length, or cut short (400).
    Unreadable,
}

impl Request {
    /// The first header named `name` (any case).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    /// The body, at most `max` bytes (and the server's limit).
    ///
    /// # Errors
    /// Larger than either limit; no `Content-Length`; cut short.
    pub fn read_body(&mut self, max: usize) -> Result<Vec<u8>, BodyError> {
        let max = max.min(self.limits.body);
        if self.header("Transfer-Encoding").is_some() {
            return Err(BodyError::Unreadable);
        }
        let length = match self.header("Content-Length") {
            None => 0,
            Some(v) => v.trim().parse::<u64>().map_err(|_| BodyError::Unreadable)?,
        };
        if length > max as u64 {
            return Err(BodyError::TooLarge);
        }
        let mut body = Vec::with_capacity(length as usize);
        (&mut self.reader)
            .take(length)
            .read_to_end(&mut body)
            .map_err(|_| BodyError::Unreadable)?;
        if body.len() as u64 != length {
            return Err(BodyError::Unreadable);
        }
        Ok(body)
    }

    /// Answers with `status`, `headers` and `body`, then closes.
    pub fn respond(self, status: u16, headers: &[(&str, &str)], body: &[u8]) {
        let mut out = self.into_stream();
        let _ = write_response(&mut out, status, headers, body);
        close_gently(out);
    }

    /// The connection, to write a response of one's own (an event stream).
    pub fn into_stream(self) -> TcpStream {
        self.reader.into_inner()
    }
}

/// Ends the connection after a response: what the client sent on (a body
/// not read, the rest of a refused head) is read a little, briefly, and
/// dropped, so closing does not reset the connection before the client has
/// read the answer.
fn close_gently(out: TcpStream) {
    let _ = out.shutdown(std::net::Shutdown::Write);
    let _ = out.set_read_timeout(Some(Duration::from_millis(200)));
    let _ = std::io::copy(&mut (&out).take(1 << 20), &mut std::io::sink());
}

/// Writes a complete response with `Content-Length` and `Connection: close`.
pub fn write_response(out: &mut impl Write, status: u16, headers: &[(&str, &str)], body: &[u8]) -> std::io::Result<()> {
    let mut head = format!("HTTP/1.1 {status} {}\r\n", reason(status));
    for (k, v) in headers {
        head += &format!("{k}: {v}\r\n");
    }
    head += &format!("Content-Length: {}\r\nConnection: close\r\n\r\n", body.len());
    // One write: a head sent apart from its body waits for the client's
    // delayed acknowledgement (Nagle), 40 ms on every answer.
    let mut response = head.into_bytes();
    response.extend_from_slice(body);
    out.write_all(&response)?;
    out.flush()
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        409 => "Conflict",
        413 => "Content Too Large",
        414 => "URI Too Long",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        503 => "Service Unavailable",
        _ => "",
    }
}

/// Where workers take requests from (cloned for each worker).
#[derive(Clone)]
pub struct Requests {
    requests: Receiver<Request>,
    closed: Arc<AtomicBool>,
}

impl Requests {
    /// The next request, or `None` once the server is closed.
    pub fn recv(&self) -> Option<Request> {
        loop {
            if self.closed.load(Ordering::SeqCst) {
                return None;
            }
            match self.requests.recv_timeout(Duration::from_millis(200)) {
                Ok(r) => return Some(r),
                Err(crossbeam_channel::RecvTimeoutError::Timeout) => {}
                Err(crossbeam_channel::RecvTimeoutError::Disconnected) => return None,
            }
        }
    }
}

/// The running server: requests whose head is complete, for the workers.
pub struct Server {
    addr: SocketAddr,
    requests: Receiver<Request>,
    closed: Arc<AtomicBool>,
    acceptor: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// Binds `addr` and starts accepting.
    ///
    /// # Errors
    /// The address cannot be bound.
    pub fn bind(addr: SocketAddr, limits: Limits) -> std::io::Result<Server> {
        let listener = TcpListener::bind(addr)?;
        let addr = listener.local_addr()?;
        let (send, requests) = crossbeam_channel::bounded(limits.connections);
        let closed = Arc::new(AtomicBool::new(false));
        let flag = closed.clone();
        let acceptor = std::thread::Builder::new()
            .name("uvpin-http-accept".into())
            .spawn(move || accept(&listener, &send, limits, &flag))?;
        Ok(Server {
            addr,
            requests,
            closed,
            acceptor: Some(acceptor),
        })
    }

    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The queue the workers take requests from.
    pub fn requests(&self) -> Requests {
        Requests {
            requests: self.requests.clone(),
            closed: self.closed.clone(),
        }
    }

    /// Stops accepting; `recv` returns `None` from now on.
    pub fn close(&mut self) {
        self.closed.store(true, Ordering::SeqCst);
        // Wake the acceptor, blocked in `accept`.
        let _ = TcpStream::connect_timeout(&self.addr, Duration::from_secs(1));
        if let Some(t) = self.acceptor.take() {
            let _ = t.join();
        }
    }
}

/// Accepts connections until closed; each one's head is read on a thread
/// of its own, at most `limits.connections` at once (others are closed).
fn accept(listener: &TcpListener, send: &Sender<Request>, limits: Limits, closed: &AtomicBool) {
    let reading = Arc::new(AtomicUsize::new(0));
    for stream in listener.incoming() {
        if closed.load(Ordering::SeqCst) {
            return;
        }
        let Ok(stream) = stream else { continue };
        // Answers and events go out as written, not held for an acknowledgement.
        let _ = stream.set_nodelay(true);
        if reading.fetch_add(1, Ordering::SeqCst) >= limits.connections {
            reading.fetch_sub(1, Ordering::SeqCst);
            let mut stream = stream;
            let _ = write_response(&mut stream, 503, &[], b"busy");
            continue;
        }
        let (send, count) = (send.clone(), reading.clone());
        let spawned = std::thread::Builder::new()
            .name("uvpin-http-read".into())
            .spawn(move || {
                if let Some(request) = read_head(stream, limits) {
                    let _ = send.send(request);
                }
                count.fetch_sub(1, Ordering::SeqCst);
            });
        if spawned.is_err() {
            reading.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// Reads a request's head within `limits`; a head that breaks them is
/// answered here (414, 431, 400) and the connection closed.
fn read_head(stream: TcpStream, limits: Limits) -> Option<Request> {
    stream.set_read_timeout(Some(limits.timeout)).ok()?;
    stream.set_write_timeout(Some(limits.timeout)).ok()?;
    let mut reader = BufReader::new(stream);
    let refuse = |reader: BufReader<TcpStream>, status: u16, why: &str| {
        let mut out = reader.into_inner();
        let _ = write_response(&mut out, status, &[("Content-Type", "text/plain")], why.as_bytes());
        close_gently(out);
        None
    };
    let line = match read_line(&mut reader, limits.request_line) {
        Line::Text(l) => l,
        Line::TooLong => return refuse(reader, 414, "request line too long"),
        Line::Broken => return None,
    };
    let mut parts = line.split(' ');
    let (Some(method), Some(url), Some(_version)) = (parts.next(), parts.next(), parts.next()) else {
        return refuse(reader, 400, "bad request line");
    };
    let method = match method {
        "GET" => Method::Get,
        "HEAD" => Method::Head,
        "POST" => Method::Post,
        other => Method::Other(other.to_string()),
    };
    let url = url.to_string();
    let mut headers = Vec::new();
    let mut total = 0;
    loop {
        let line = match read_line(&mut reader, limits.header_line) {
            Line::Text(l) => l,
            Line::TooLong => return refuse(reader, 431, "header line too long"),
            Line::Broken => return None,
        };
        if line.is_empty() {
            break;
        }
        total += line.len();
        if headers.len() >= limits.headers || total > limits.header_bytes {
            return refuse(reader, 431, "too many or too large headers");
        }
        let Some((k, v)) = line.split_once(':') else {
            return refuse(reader, 400, "bad header line");
        };
        headers.push((k.trim().to_string(), v.trim().to_string()));
    }
    Some(Request {
        method,
        url,
        headers,
        reader,
        limits,
    })
}

enum Line {
    Text(String),
    TooLong,
    /// Cut short, timed out, or not text.
    Broken,
}

/// One line ending in CRLF (or LF), at most `max` bytes before it.
fn read_line(reader: &mut BufReader<TcpStream>, max: usize) -> Line {
    let mut buf = Vec::new();
    // Reading one byte past the limit tells a line that is too long.
    match reader.by_ref().take(max as u64 + 2).read_until(b'\n', &mut buf) {
        Ok(0) | Err(_) => return Line::Broken,
        Ok(_) => {}
    }
    if buf.last() != Some(&b'\n') {
        return if buf.len() > max { Line::TooLong } else { Line::Broken };
    }
    buf.pop();
    if buf.last() == Some(&b'\r') {
        buf.pop();
    }
    if buf.len() > max {
        return Line::TooLong;
    }
    String::from_utf8(buf).map_or(Line::Broken, Line::Text)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sends `head` (and `body`) to a server with `limits`; the status answered
    /// or the request as the worker sees it.
    /// What a worker saw of a request: its method, target and `X-A` header.
    type Seen = (Method, String, Option<String>);

    /// `reaches`: whether the head should reach the workers (a refused one
    /// never does: a short wait shows it).
    fn exchange(limits: Limits, head: &[u8], reaches: bool) -> (Option<u16>, Option<Seen>) {
        let wait = if reaches { 10_000 } else { 300 };
        let mut server = Server::bind("127.0.0.1:0".parse().unwrap(), limits).unwrap();
        let mut client = TcpStream::connect(server.addr()).unwrap();
        client.write_all(head).unwrap();
        let _ = client.shutdown(std::net::Shutdown::Write);
        let seen = std::thread::scope(|s| {
            let worker = s.spawn(|| {
                let r = server.requests.recv_timeout(Duration::from_millis(wait)).ok()?;
                let seen = (r.method.clone(), r.url.clone(), r.header("x-a").map(str::to_string));
                r.respond(200, &[], b"ok");
                Some(seen)
            });
            worker.join().unwrap()
        });
        let mut answer = String::new();
        let _ = client.read_to_string(&mut answer);
        let status = answer.split(' ').nth(1).and_then(|s| s.parse().ok());
        server.close();
        (status, seen)
    }

    #[test]
    fn heads_within_the_limits_reach_the_workers() {
        let head = b"GET /api/files?x=1 HTTP/1.1\r\nHost: a\r\nX-A: b\r\n\r\n";
        let (status, seen) = exchange(Limits::DEFAULT, head, true);
        assert_eq!(status, Some(200));
        assert_eq!(seen, Some((Method::Get, "/api/files?x=1".into(), Some("b".into()))));
    }

    #[test]
    fn oversized_heads_are_answered_and_never_reach_the_workers() {
        let small = Limits {
            request_line: 64,
            header_line: 64,
            headers: 3,
            header_bytes: 100,
            ..Limits::DEFAULT
        };
        let long_path = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(100));
        assert_eq!(exchange(small, long_path.as_bytes(), false), (Some(414), None));
        let long_header = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "b".repeat(100));
        assert_eq!(exchange(small, long_header.as_bytes(), false), (Some(431), None));
        let many = "GET / HTTP/1.1\r\nA: 1\r\nB: 2\r\nC: 3\r\nD: 4\r\n\r\n";
        assert_eq!(exchange(small, many.as_bytes(), false), (Some(431), None));
        assert_eq!(exchange(small, b"NONSENSE\r\n\r\n", false), (Some(400), None));
    }
}
