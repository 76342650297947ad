//! The progress bar of a long `uvpin solve`: the stage, how far through it,
//! and the time so far, on standard error when it is a terminal.

use crate::api::ProgressSink;
use crate::solver::{Progress, Stage};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::Arc;
use std::time::Duration;

/// A bar for one solve and the sink that moves it; `None` when standard
/// error is not a terminal (nothing would be drawn) or output is quiet.
pub fn solve_bar(quiet: bool) -> Option<(ProgressBar, ProgressSink)> {
    let target = ProgressDrawTarget::stderr_with_hz(10);
    if quiet || target.is_hidden() {
        return None;
    }
    let bar = ProgressBar::with_draw_target(Some(100), target);
    let style = ProgressStyle::with_template("{spinner} {elapsed:>4} [{bar:30}] {msg}").ok()?;
    bar.set_style(style.progress_chars("=> "));
    bar.enable_steady_tick(Duration::from_millis(250));
    let shown = bar.clone();
    let sink = ProgressSink(Arc::new(move |p: Progress| show(&shown, p)));
    Some((bar, sink))
}

/// Moves the bar: each stage fills it from the left as far as it is through.
fn show(bar: &ProgressBar, p: Progress) {
    match p.fraction {
        Some(f) => {
            bar.set_position((f * 100.0).round() as u64);
            bar.set_message(format!("{} {:.0} %", p.stage.label(), f * 100.0));
        }
        None => {
            bar.set_position(if p.stage == Stage::Writing { 100 } else { 0 });
            bar.set_message(p.stage.label());
        }
    }
}
