//! A running daemon (`uvpin watch`, `uvpin edit`) for the integration tests.

use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How long a test waits for the daemon.
pub const WAIT: Duration = Duration::from_secs(60);

/// A running `uvpin watch` or `uvpin edit` (`--log json`) and the log
/// lines it printed.
pub struct Daemon {
    pub child: Child,
    lines: Arc<Mutex<Vec<Value>>>,
}

impl Daemon {
    /// `uvpin watch ARGS --log json --debounce-ms 100` in `cwd`.
    pub fn watch(cwd: &Path, args: &[&str]) -> Daemon {
        Self::start(cwd, "watch", args, &["--debounce-ms", "100"])
    }

    /// As [`Daemon::watch`], with `env` set in the daemon's environment.
    pub fn watch_with_env(cwd: &Path, args: &[&str], env: &[(&str, &str)]) -> Daemon {
        Self::spawn(cwd, "watch", args, &["--debounce-ms", "100"], env)
    }

    /// `uvpin edit ARGS --log json --addr 127.0.0.1:0` in `cwd`.
    pub fn edit(cwd: &Path, args: &[&str]) -> Daemon {
        Self::start(cwd, "edit", args, &["--addr", "127.0.0.1:0"])
    }

    fn start(cwd: &Path, command: &str, args: &[&str], extra: &[&str]) -> Daemon {
        Self::spawn(cwd, command, args, extra, &[])
    }

    /// `uvpin watch ARGS --log json` started by `program` (a wrapper such
    /// as `setpriv … uvpin`, its last argument the binary) in `cwd`.
    pub fn watch_via(mut program: Command, cwd: &Path, args: &[&str]) -> Daemon {
        Self::spawn_from(&mut program, cwd, "watch", args, &[], &[])
    }

    fn spawn(cwd: &Path, command: &str, args: &[&str], extra: &[&str], env: &[(&str, &str)]) -> Daemon {
        Self::spawn_from(
            &mut Command::new(env!("CARGO_BIN_EXE_uvpin")),
            cwd,
            command,
            args,
            extra,
            env,
        )
    }

    fn spawn_from(
        program: &mut Command,
        cwd: &Path,
        command: &str,
        args: &[&str],
        extra: &[&str],
        env: &[(&str, &str)],
    ) -> Daemon {
        let mut child = program
            .envs(env.iter().copied())
            .arg(command)
            .args(args)
            .args(["--log", "json"])
            .args(extra)
            .current_dir(cwd)
            .stderr(Stdio::piped())
            .stdout(Stdio::null())
            .spawn()
            .expect("spawn uvpin watch");
        let lines = Arc::new(Mutex::new(Vec::new()));
        let sink = lines.clone();
        let stderr = child.stderr.take().expect("stderr");
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let v = serde_json::from_str(&line).unwrap_or_else(|_| serde_json::json!({ "raw": line }));
                sink.lock().unwrap().push(v);
            }
        });
        Daemon { child, lines }
    }

    pub fn log(&self) -> Vec<Value> {
        self.lines.lock().unwrap().clone()
    }

    /// The message of the last `event` line.
    pub fn last_message(&self, event: &str) -> String {
        let log = self.log();
        let last = log.iter().rev().find(|l| l["event"] == event);
        last.and_then(|l| l["message"].as_str()).unwrap_or("").to_string()
    }

    /// Whether it is still running.
    pub fn alive(&mut self) -> bool {
        self.child.try_wait().expect("wait").is_none()
    }

    /// Number of `event` lines about a file whose name ends with `file`.
    pub fn count(&self, event: &str, file: &str) -> usize {
        self.log()
            .iter()
            .filter(|l| l["event"] == event && l["file"].as_str().is_some_and(|f| f.ends_with(file)))
            .count()
    }

    /// Waits until there are `n` `event` lines about `file`; panics with the log after [`WAIT`].
    pub fn wait_count(&self, event: &str, file: &str, n: usize) {
        let t0 = Instant::now();
        while self.count(event, file) < n {
            assert!(
                t0.elapsed() < WAIT,
                "timed out waiting for {n} `{event}` lines about {file}; log:\n{}",
                self.dump()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub fn dump(&self) -> String {
        self.log().iter().map(|l| l.to_string()).collect::<Vec<_>>().join("\n")
    }

    /// Sends SIGTERM and waits for the exit.
    pub fn terminate(&mut self) -> ExitStatus {
        let pid = self.child.id().to_string();
        Command::new("kill").args(["-TERM", &pid]).status().expect("kill");
        let t0 = Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().expect("wait") {
                return status;
            }
            assert!(t0.elapsed() < WAIT, "no exit after SIGTERM; log:\n{}", self.dump());
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
