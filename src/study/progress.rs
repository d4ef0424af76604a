//! Progress on stderr: the bars of long runs (indicatif hides them when stderr is not a
//! terminal) and the notes a run leaves on the way. The analyses below the study layer never
//! print; their observers here do.

use indicatif::{ProgressBar, ProgressStyle};

/// The style of every bar: what runs, the time since it started, the bar, and a message.
fn style() -> ProgressStyle {
    ProgressStyle::with_template("{prefix} [{elapsed_precise}] {bar:30} {msg}")
        .expect("a valid template")
}

/// A bar of 1000 steps for a run over a range (a rate, a parameter, a time) named `what`.
pub fn bar(what: &str) -> ProgressBar {
    ProgressBar::new(1000)
        .with_style(style())
        .with_prefix(what.to_string())
}

/// A bar over `[0, omegabar_max]` for a continuation in the rate.
pub(crate) fn progress(omegabar_max: f64, what: &str) -> ProgressBar {
    let bar = bar(what);
    bar.set_message(format!("up to omegabar = {omegabar_max:.4e}"));
    bar
}

/// A bar over `count` points of a sweep, with the estimated time left.
pub fn points(count: usize) -> ProgressBar {
    ProgressBar::new(count as u64).with_style(
        ProgressStyle::with_template(
            "sweep [{elapsed_precise}] {bar:30} {pos}/{len} points, eta {eta}",
        )
        .expect("a valid template"),
    )
}

/// A spinner for a run of unknown length named `what`.
pub(crate) fn spinner(what: &str) -> ProgressBar {
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template(&format!("{what} [{{elapsed_precise}}] {{spinner}} {{msg}}"))
            .expect("a valid template"),
    );
    bar
}

/// Sets `bar` to the fraction `(x - a)/(b - a)` of a range, clipped to it.
pub(crate) fn set_fraction(bar: &ProgressBar, x: f64, (a, b): (f64, f64)) {
    let fraction = ((x - a) / (b - a)).clamp(0.0, 1.0);
    bar.set_position((fraction * 1000.0) as u64);
}

/// A line on stderr about a run in progress (a rung of a refinement, rows a fit left out).
pub(crate) fn note(text: &str) {
    eprintln!("{text}");
}
