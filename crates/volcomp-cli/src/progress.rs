//! Progress bars on standard error, for the library's
//! [`volcomp_core::progress::Progress`]: drawn only when standard error is
//! a terminal (never into a pipe or a file), for work large enough to
//! wait for, silenced by `--quiet`; one summary line when the work ends.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

static QUIET: AtomicBool = AtomicBool::new(false);

/// `--quiet`: no progress bar, no summary line, no report of what was
/// written ([`note!`](crate::note)); warnings and errors still show.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// Whether `--quiet` was given.
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// `eprintln!` of a report line (what a command wrote, and its size),
/// unless `--quiet`.
#[macro_export]
macro_rules! note {
    ($($arg:tt)*) => {
        if !$crate::progress::quiet() {
            eprintln!("{}", $crate::output::clean(&format!($($arg)*)));
        }
    };
}

/// Smallest input (bytes) whose reading gets a bar from the start: 1 MiB,
/// about 40 000 lines of G-code, a second or more of work.
pub const MIN_BYTES: u64 = 1 << 20;

/// Seconds of work after which a bar is drawn for any input.
const LATE_S: f64 = 1.0;

/// A bar, or nothing when it must not be drawn. Clones share the bar.
#[derive(Clone)]
pub struct Bar {
    bar: Option<ProgressBar>,
    task: String,
    started: Instant,
    bytes: bool,
}

impl Bar {
    fn new(task: &str, total: u64, large: bool, bytes: bool) -> Self {
        // Work too small for a bar at the start gets one once it has
        // taken longer than `LATE_S` (a slow model or fine sampling).
        let shown = !QUIET.load(Ordering::Relaxed) && std::io::stderr().is_terminal();
        let bar = shown.then(|| {
            let template = if bytes {
                "{msg} [{bar:30}] {bytes}/{total_bytes} ({eta} left)"
            } else {
                "{msg} [{bar:30}] {pos}/{len} ({eta} left)"
            };
            let target = match large {
                true => ProgressDrawTarget::stderr(),
                false => ProgressDrawTarget::hidden(),
            };
            let b = ProgressBar::with_draw_target(Some(total), target);
            b.set_style(
                ProgressStyle::with_template(template)
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.set_message(task.to_string());
            b.tick();
            b
        });
        Self {
            bar,
            task: task.to_string(),
            started: Instant::now(),
            bytes,
        }
    }

    /// A bar over the bytes of the file `path` ("-": standard input, of
    /// unknown length, gets none).
    pub fn reading(task: &str, path: &std::path::Path) -> Self {
        let total = if path.as_os_str() == "-" {
            None
        } else {
            std::fs::metadata(path).ok().map(|m| m.len())
        };
        let total = total.unwrap_or(0);
        Self::new(task, total, total >= MIN_BYTES, true)
    }

    /// A bar over `total` units of work; drawn when `large`.
    pub fn items(task: &str, total: u64, large: bool) -> Self {
        Self::new(task, total, large, false)
    }

    /// Clears the bar and, when one was drawn, prints one summary line.
    pub fn finish(&self) {
        if let Some(b) = self.bar.as_ref().filter(|b| !b.is_hidden()) {
            let done = b.position();
            b.finish_and_clear();
            let what = if self.bytes {
                indicatif::HumanBytes(done).to_string()
            } else {
                format!("{done} of {}", b.length().unwrap_or(done))
            };
            eprintln!(
                "volcomp: {}: {what} in {:.1} s",
                self.task,
                self.started.elapsed().as_secs_f64()
            );
        }
    }
}

impl volcomp_core::progress::Progress for Bar {
    fn start(&mut self, _task: &str, total: Option<u64>) {
        if let (Some(b), Some(t)) = (&self.bar, total) {
            b.set_length(t);
        }
    }
    fn advance_to(&mut self, done: u64) {
        if let Some(b) = &self.bar {
            if b.is_hidden() && self.started.elapsed().as_secs_f64() > LATE_S {
                b.set_draw_target(ProgressDrawTarget::stderr());
            }
            b.set_position(done);
        }
    }
}
