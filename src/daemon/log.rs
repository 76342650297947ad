//! The daemon's log: one line per event on standard error, readable or JSON.

use crate::config::LogFormat;
use serde_json::{Map, Value, json};
use std::io::Write;
use std::time::{SystemTime, UNIX_EPOCH};

/// Severity of a log line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    Info,
    Warn,
    Error,
}

impl Level {
    fn as_str(self) -> &'static str {
        match self {
            Level::Info => "info",
            Level::Warn => "warn",
            Level::Error => "error",
        }
    }
}

/// Writes log lines to standard error in the configured format.
#[derive(Debug, Clone)]
pub struct Logger {
    pub format: LogFormat,
}

/// `text` with its control characters escaped (`\n`, `\u{1b}`, …).
fn escape_controls(text: &str) -> String {
    if text.chars().any(char::is_control) {
        text.chars()
            .flat_map(|c| {
                if c.is_control() {
                    c.escape_debug().collect::<Vec<_>>()
                } else {
                    vec![c]
                }
            })
            .collect()
    } else {
        text.to_string()
    }
}

/// Milliseconds since the Unix epoch.
pub fn unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

/// `HH:MM:SS.mmm` (UTC) of a Unix time in milliseconds.
fn clock(ms: u64) -> String {
    let day_ms = ms % 86_400_000;
    format!(
        "{:02}:{:02}:{:02}.{:03}",
        day_ms / 3_600_000,
        day_ms / 60_000 % 60,
        day_ms / 1000 % 60,
        day_ms % 1000
    )
}

impl Logger {
    /// Logs `event` about `file` with a human `message` and machine `fields`
    /// (a JSON object; added to the JSON line, ignored in human lines).
    pub fn log(&self, level: Level, event: &str, file: Option<&str>, message: &str, fields: Value) {
        let ts = unix_ms();
        // One event, one line: control characters (a newline in a file
        // name quoted by an error) are escaped.
        let message = &escape_controls(message);
        let line = match self.format {
            LogFormat::Human => {
                let tag = match level {
                    Level::Info => "",
                    Level::Warn => "warning: ",
                    Level::Error => "error: ",
                };
                match file {
                    Some(f) => format!("[{}] {f}: {tag}{message}", clock(ts)),
                    None => format!("[{}] {tag}{message}", clock(ts)),
                }
            }
            LogFormat::Json => {
                let mut object = Map::new();
                object.insert("ts".into(), json!(ts));
                object.insert("level".into(), json!(level.as_str()));
                object.insert("event".into(), json!(event));
                if let Some(f) = file {
                    object.insert("file".into(), json!(f));
                }
                object.insert("message".into(), json!(message));
                if let Value::Object(extra) = fields {
                    object.extend(extra);
                }
                Value::Object(object).to_string()
            }
        };
        let mut err = std::io::stderr().lock();
        let _ = writeln!(err, "{line}");
    }

    pub fn info(&self, event: &str, file: Option<&str>, message: &str, fields: Value) {
        self.log(Level::Info, event, file, message, fields);
    }

    pub fn warn(&self, event: &str, file: Option<&str>, message: &str, fields: Value) {
        self.log(Level::Warn, event, file, message, fields);
    }

    pub fn error(&self, event: &str, file: Option<&str>, message: &str, fields: Value) {
        self.log(Level::Error, event, file, message, fields);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn clock_formats_utc_time_of_day() {
        assert_eq!(super::clock(86_400_000 + 3_723_045), "01:02:03.045");
    }
}
