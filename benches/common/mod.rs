//! What the benches share: medians, the machine line, and writing their
//! tables into `docs/benchmarks.md` (each bench owns one section between
//! markers, replaced whole on a full run).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

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
