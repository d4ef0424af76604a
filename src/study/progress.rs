//! Progress on stderr: the bars of long runs and the notes a run leaves on the way. On a
//! terminal a bar redraws in place; where stderr is not one (a batch job's log, a pipe) it
//! becomes a plain line every [`PROGRESS_VARIABLE`] seconds (10 by default), written whether
//! the run moved or not, so that the log of a long run says where it is and that it is alive.
//! The analyses below the study layer never print; their observers here do.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle, TermLike};

/// The environment variable with the seconds between two lines of a bar where stderr is not a
/// terminal: a number from 0 (a line at every update) to [`MAX_INTERVAL_SECONDS`]; unset or
/// empty means [`DEFAULT_INTERVAL`].
pub const PROGRESS_VARIABLE: &str = "HELIXBIF_PROGRESS_SECONDS";

/// The seconds between two lines of a bar where stderr is not a terminal, by default: a run
/// shorter than that leaves no line.
pub const DEFAULT_INTERVAL: Duration = Duration::from_secs(10);

/// The largest interval [`PROGRESS_VARIABLE`] may ask for (a day).
pub const MAX_INTERVAL_SECONDS: f64 = 86_400.0;

/// The interval in use, in milliseconds, process-wide.
static INTERVAL_MS: AtomicU64 = AtomicU64::new(DEFAULT_INTERVAL.as_millis() as u64);

/// The interval [`PROGRESS_VARIABLE`] names, applied where it is set (and not empty); an input
/// error naming the variable where it holds no number of seconds in range. A front end (the
/// command line, the Python module) calls it at its start.
pub fn interval_from_environment() -> crate::Result<()> {
    let allowed = format!("must be a number of seconds from 0 to {MAX_INTERVAL_SECONDS}");
    match std::env::var(PROGRESS_VARIABLE) {
        Ok(text) if !text.trim().is_empty() => {
            let seconds = seconds(&text).ok_or_else(|| {
                crate::Error::input(PROGRESS_VARIABLE, format!("{allowed}, not `{text}`"))
            })?;
            INTERVAL_MS.store((seconds * 1000.0).round() as u64, Ordering::Relaxed);
            Ok(())
        }
        Ok(_) | Err(std::env::VarError::NotPresent) => Ok(()),
        Err(std::env::VarError::NotUnicode(_)) => Err(crate::Error::input(
            PROGRESS_VARIABLE,
            format!("is not valid Unicode ({allowed})"),
        )),
    }
}

/// The seconds `text` names, where they lie from 0 to [`MAX_INTERVAL_SECONDS`].
fn seconds(text: &str) -> Option<f64> {
    (text.trim().parse::<f64>().ok()).filter(|s| (0.0..=MAX_INTERVAL_SECONDS).contains(s))
}

/// The interval between two lines of a bar where stderr is not a terminal; `None` on a
/// terminal.
fn log_interval() -> Option<Duration> {
    (!std::io::stderr().is_terminal())
        .then(|| Duration::from_millis(INTERVAL_MS.load(Ordering::Relaxed)))
}

/// How often indicatif may draw into a log (as into a terminal): the frames in between are
/// not formatted at all.
const LOG_DRAWS_PER_SECOND: u8 = 20;

/// Where a bar draws: stderr where it is a terminal, else [`LogLines`] on stderr.
fn target() -> ProgressDrawTarget {
    match log_interval() {
        None => ProgressDrawTarget::stderr(),
        Some(interval) => ProgressDrawTarget::term_like_with_hz(
            Box::new(LogLines::new(Box::new(std::io::stderr()), interval)),
            LOG_DRAWS_PER_SECOND,
        ),
    }
}

/// `bar` on the [`target`]; in a log it also ticks every interval (where that is not zero), so
/// that a line comes while the run does not move (a point of a sweep, a long corrector).
fn drawn(bar: ProgressBar) -> ProgressBar {
    bar.set_draw_target(target());
    if let Some(interval) = log_interval().filter(|i| !i.is_zero()) {
        bar.enable_steady_tick(interval);
    }
    bar
}

/// A [`TermLike`] for a log: each frame indicatif draws (one line per bar) is written as plain
/// lines, the first frame once `interval` has passed since the bars were made and then at most
/// once per `interval` (to a tenth of it); the cursor moves and clears of a terminal are dropped. (A line printed
/// above the bars, [`ProgressBar::println`], would be part of a frame and share its fate; the
/// study layer prints its notes with [`note`] instead.)
pub(crate) struct LogLines {
    interval: Duration,
    state: Mutex<LogState>,
}

struct LogState {
    out: Box<dyn Write + Send>,
    /// The bars' lines of the frame being drawn.
    frame: Vec<String>,
    /// When the last frame was written (at first, when the bars were made).
    written: Instant,
}

impl LogLines {
    pub(crate) fn new(out: Box<dyn Write + Send>, interval: Duration) -> Self {
        LogLines {
            interval,
            state: Mutex::new(LogState {
                out,
                frame: Vec::new(),
                written: Instant::now(),
            }),
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, LogState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }
}

impl std::fmt::Debug for LogLines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogLines")
            .field("interval", &self.interval)
            .finish()
    }
}

impl TermLike for LogLines {
    /// Wide enough for a bar's line (indicatif pads each to the width; a longer line is
    /// written whole).
    fn width(&self) -> u16 {
        250
    }
    /// Tall enough for every bar of a run.
    fn height(&self) -> u16 {
        u16::MAX
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        self.write_str(s)
    }
    /// A bar's line, or the padding after it or a carriage return (blank), which are dropped.
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        let line = s.trim();
        if !line.is_empty() {
            self.state().frame.push(line.to_string());
        }
        Ok(())
    }
    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }
    /// The end of a frame: written if `interval` has passed since the last one, less a tenth
    /// of it (a tick `interval` after the last line, late by the scheduler's delay, may find
    /// a little less passed since that line was written; without the tenth it would be skipped
    /// and the log go twice the interval without a line).
    fn flush(&self) -> std::io::Result<()> {
        let mut state = self.state();
        let frame = std::mem::take(&mut state.frame);
        if frame.is_empty() || state.written.elapsed() < self.interval - self.interval / 10 {
            return Ok(());
        }
        state.written = Instant::now();
        for line in &frame {
            writeln!(state.out, "{line}")?;
        }
        state.out.flush()
    }
}

/// Bars drawn together (one line each), on the [`target`] of every bar.
pub(crate) fn multi() -> MultiProgress {
    MultiProgress::with_draw_target(target())
}

/// The style of every bar: what runs, the time since it started, the bar, and a message.
fn style() -> ProgressStyle {
    ProgressStyle::with_template("{prefix} [{elapsed_precise}] {bar:30} {msg}")
        .expect("a valid template")
}

/// A bar of 1000 steps for a run over a range (a rate, a parameter, a time) named `what`.
pub fn bar(what: &str) -> ProgressBar {
    drawn(
        ProgressBar::new(1000)
            .with_style(style())
            .with_prefix(what.to_string()),
    )
}

/// A bar over `[0, omegabar_max]` for a continuation in the rate.
pub(crate) fn progress(omegabar_max: f64, what: &str) -> ProgressBar {
    let bar = bar(what);
    bar.set_message(format!("up to omegabar = {omegabar_max:.4e}"));
    bar
}

/// A bar over `count` points of a sweep, with the estimated time left.
pub fn points(count: usize) -> ProgressBar {
    drawn(ProgressBar::new(count as u64)).with_style(
        ProgressStyle::with_template(
            "sweep [{elapsed_precise}] {bar:30} {pos}/{len} points, eta {eta}",
        )
        .expect("a valid template"),
    )
}

/// A spinner for a run of unknown length named `what`.
pub(crate) fn spinner(what: &str) -> ProgressBar {
    let bar = drawn(ProgressBar::new_spinner());
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// A writer into a buffer the test keeps.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl Write for Shared {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(bytes);
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Shared {
        fn lines(&self) -> Vec<String> {
            let bytes = self.0.lock().unwrap().clone();
            String::from_utf8(bytes)
                .unwrap()
                .lines()
                .map(String::from)
                .collect()
        }
    }

    fn logged(interval: Duration) -> (LogLines, Shared) {
        let out = Shared::default();
        (LogLines::new(Box::new(out.clone()), interval), out)
    }

    fn counted(what: &str) -> ProgressStyle {
        ProgressStyle::with_template(&format!("{what} {{pos}}/{{len}} {{msg}}")).unwrap()
    }

    /// A bar of 8 steps named `what` drawing into [`logged`] at `interval`.
    fn logged_bar(what: &str, interval: Duration) -> (ProgressBar, Shared) {
        let (log, out) = logged(interval);
        let target = ProgressDrawTarget::term_like(Box::new(log));
        let bar = ProgressBar::with_draw_target(Some(8), target).with_style(counted(what));
        (bar, out)
    }

    /// At a zero interval every update of a bar is one plain line, in order, without the
    /// terminal's carriage returns or padding.
    #[test]
    fn a_bar_in_a_log_writes_a_plain_line_per_update() {
        let (bar, out) = logged_bar("sweep", Duration::ZERO);
        for done in 1..=3 {
            bar.set_message(format!("point {done}"));
            bar.set_position(done);
        }
        let lines = out.lines();
        assert_eq!(lines.last().unwrap(), "sweep 3/8 point 3");
        assert!(
            lines.contains(&"sweep 2/8 point 2".to_string()),
            "{lines:?}"
        );
        assert!(lines.iter().all(|l| l.starts_with("sweep ")), "{lines:?}");
    }

    /// A bar that does not move still writes a line each interval where it ticks at the interval
    /// (as [`drawn`] makes it tick in a log): each tick, late by less than a tenth of the
    /// interval against the one before, finds the interval passed.
    #[test]
    fn a_bar_that_does_not_move_still_writes_a_line_each_interval() {
        let interval = Duration::from_secs(1);
        let (bar, out) = logged_bar("simulate", interval);
        bar.set_position(1);
        bar.enable_steady_tick(interval);
        std::thread::sleep(2 * interval + interval / 2);
        bar.disable_steady_tick();
        assert_eq!(out.lines(), ["simulate 1/8", "simulate 1/8"]);
    }

    /// A run shorter than the interval leaves no line; one longer writes a line once the
    /// interval has passed, and not again before it passes once more.
    #[test]
    fn a_bar_in_a_log_writes_at_most_once_per_interval() {
        let interval = Duration::from_millis(500);
        let (bar, out) = logged_bar("boundary", interval);
        bar.set_position(1);
        bar.set_position(2);
        assert!(out.lines().is_empty(), "{:?}", out.lines());
        std::thread::sleep(interval + Duration::from_millis(50));
        bar.set_position(3);
        bar.set_position(4);
        assert_eq!(out.lines(), ["boundary 3/8"]);
    }

    /// Bars drawn together write one line each per frame.
    #[test]
    fn bars_drawn_together_write_a_line_each() {
        let (log, out) = logged(Duration::ZERO);
        let bars = MultiProgress::with_draw_target(ProgressDrawTarget::term_like(Box::new(log)));
        let a = bars.add(ProgressBar::new(4).with_style(counted("omega = 1")));
        let b = bars.add(ProgressBar::new(4).with_style(counted("omega = 2")));
        a.set_position(1);
        b.set_position(2);
        let lines = out.lines();
        let n = lines.len();
        assert!(n >= 2, "{lines:?}");
        assert_eq!(lines[n - 2..], ["omega = 1 1/4", "omega = 2 2/4"]);
    }

    /// The interval is a number of seconds in range; anything else is refused.
    #[test]
    fn the_interval_is_a_number_of_seconds_in_range() {
        assert_eq!(seconds(" 2.5 "), Some(2.5));
        assert_eq!(seconds("0"), Some(0.0));
        for bad in ["-1", "1e6", "ten", "NaN", "inf"] {
            assert_eq!(seconds(bad), None, "{bad}");
        }
    }
}
