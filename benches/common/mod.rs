//! What the benches share: medians, the machine line, and writing their
//! tables into `docs/benchmarks.md` (each bench owns one section between
//! markers, replaced whole on a full run).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The peak resident memory of this process since the last
/// [`reset_peak`], in MB.
pub fn peak_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// Starts [`peak_mb`] afresh.
pub fn reset_peak() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The first command-line argument that is not a flag (cargo passes
/// `--bench`): a filter on case names.
pub fn filter() -> Option<String> {
    std::env::args().skip(1).find(|a| !a.starts_with('-'))
}

/// The machine the figures were measured on: CPU model, cores, date.
pub fn machine_line() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let date = std::process::Command::new("date")
        .arg("+%Y-%m-%d")
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    format!("Measured {date} on {cpu}, {cores} cores (release build).")
}

fn benchmarks_md() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/benchmarks.md")
}

/// Replaces section `name` of `docs/benchmarks.md` with `body` (markdown),
/// under the heading `title` and the machine line. Other sections stay.
pub fn write_section(name: &str, title: &str, body: &str) {
    let path = benchmarks_md();
    let text = std::fs::read_to_string(&path).unwrap_or_else(|_| {
        "# Benchmarks\n\nWritten by the bench commands (`cargo bench --bench NAME`); each run of a bench \
         replaces its own section. Medians over repeated runs; timings are never asserted in tests.\n"
            .to_string()
    });
    let (start, end) = (
        format!("<!-- bench:{name}:start -->"),
        format!("<!-- bench:{name}:end -->"),
    );
    let section = format!("{start}\n## {title}\n\n{}\n\n{body}\n{end}", machine_line());
    let new = match (text.find(&start), text.find(&end)) {
        (Some(a), Some(b)) if b > a => format!("{}{section}{}", &text[..a], &text[b + end.len()..]),
        _ => format!("{}\n{section}\n", text.trim_end()),
    };
    std::fs::write(&path, new).expect("write docs/benchmarks.md");
    eprintln!("wrote section `{name}` of {}", path.display());
}

/// Prints `body` and, on a full run (no filter), writes it to `docs/benchmarks.md`.
pub fn publish(name: &str, title: &str, body: &str) {
    println!("\n## {title}\n\n{body}");
    if filter().is_none() {
        write_section(name, title, body);
    } else {
        eprintln!("(filtered run: docs/benchmarks.md not updated)");
    }
}

/// The rows a bench has ever reached, kept in `benches/reached/NAME.txt`
/// (one row key per line): the table only grows. A row reached before and
/// run again without being reached is lost, and a lost row fails the bench.
pub struct Reached {
    path: PathBuf,
    ever: std::collections::BTreeSet<String>,
    lost: Vec<String>,
    new: Vec<String>,
}

impl Reached {
    pub fn open(bench: &str) -> Reached {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("benches/reached/{bench}.txt"));
        let ever = std::fs::read_to_string(&path)
            .unwrap_or_default()
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .map(String::from)
            .collect();
        Reached {
            path,
            ever,
            lost: Vec::new(),
            new: Vec::new(),
        }
    }

    /// Row `key` was run now: reached or not.
    pub fn record(&mut self, key: &str, reached: bool) {
        match (self.ever.contains(key), reached) {
            (true, false) => self.lost.push(key.to_string()),
            (false, true) => self.new.push(key.to_string()),
            _ => {}
        }
    }

    /// Adds the rows reached for the first time to the file, prints them and
    /// the lost ones, and ends the bench with exit 1 when a row was lost
    /// (call it after the tables are written).
    pub fn finish(mut self) {
        if !self.new.is_empty() {
            eprintln!("{} rows reached for the first time: {:?}", self.new.len(), self.new);
            self.ever.extend(self.new.drain(..));
            let mut text = String::from(
                "# Every row this bench has ever reached; a row run again and not reached fails the bench.\n",
            );
            for key in &self.ever {
                text += key;
                text.push('\n');
            }
            let _ = std::fs::create_dir_all(self.path.parent().expect("benches/reached"));
            std::fs::write(&self.path, text).expect("write the reached rows");
        }
        if !self.lost.is_empty() {
            eprintln!("error: {} rows reached before are lost:", self.lost.len());
            for key in &self.lost {
                eprintln!("  lost: {key}");
            }
            std::process::exit(1);
        }
    }
}
