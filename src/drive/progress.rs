//! A render's progress: a bar on a terminal, else a line every so often
//! (for logs), counted in samples.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// Samples taken of the total, shown as the render goes.
pub struct Progress {
    bar: ProgressBar,
    counts: Arc<ProgressCounts>,
    logger: Option<JoinHandle<()>>,
}

/// Samples taken and to take, readable while the render runs (by another
/// thread: the Python module's progress callback).
#[derive(Default, Debug)]
pub struct ProgressCounts {
    done: AtomicU64,
    total: AtomicU64,
    finished: AtomicBool,
}

impl ProgressCounts {
    /// Samples taken so far.
    pub fn done(&self) -> u64 {
        self.done.load(Ordering::Relaxed)
    }

    /// Samples the render will take (it changes once, when adaptive
    /// sampling chooses the pixels' counts).
    pub fn total(&self) -> u64 {
        self.total.load(Ordering::Relaxed)
    }
}

impl Progress {
    /// Progress towards `total` samples: a bar where `show` and stderr is a
    /// terminal, a line every `log_every` where `show` and it is not,
    /// nothing otherwise. The counts go to `shared` where given.
    pub fn new(
        total: u64,
        show: bool,
        log_every: Duration,
        start: Instant,
        shared: Option<Arc<ProgressCounts>>,
    ) -> Self {
        let counts = shared.unwrap_or_default();
        counts.done.store(0, Ordering::Relaxed);
        counts.finished.store(false, Ordering::Relaxed);
        counts.total.store(total, Ordering::Relaxed);
        let bar = if show {
            bar(total)
        } else {
            ProgressBar::hidden()
        };
        let logger = (show && !std::io::stderr().is_terminal()).then(|| {
            let counts = counts.clone();
            std::thread::spawn(move || log_progress(&counts, start, log_every))
        });
        Self {
            bar,
            counts,
            logger,
        }
    }

    /// Counts `samples` more taken.
    pub fn add(&self, samples: u64) {
        self.counts.done.fetch_add(samples, Ordering::Relaxed);
        self.bar.inc(samples);
    }

    /// The total changed (adaptive sampling chose the pixels' counts).
    pub fn set_total(&self, total: u64) {
        self.counts.total.store(total, Ordering::Relaxed);
        self.bar.set_length(total);
    }

    /// Clears the bar and stops the progress lines.
    pub fn finish(&mut self) {
        self.bar.finish_and_clear();
        self.counts.finished.store(true, Ordering::Relaxed);
        if let Some(logger) = self.logger.take() {
            let _ = logger.join();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

fn bar(total: u64) -> ProgressBar {
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}%  {human_pos}/{human_len} samples  {rate}  ETA {eta}",
        )
        .expect("valid template")
        .with_key("rate", |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
            let _ = write!(w, "{:.2} M samples/s", state.per_sec() / 1e6);
        }),
    );
    bar
}

/// A progress line every `every` until the render finishes: for logs,
/// where no bar can be drawn.
fn log_progress(counts: &ProgressCounts, start: Instant, every: Duration) {
    let mut next = every;
    while !counts.finished.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50).min(every));
        let elapsed = start.elapsed();
        if elapsed < next {
            continue;
        }
        next += every;
        let d = counts.done.load(Ordering::Relaxed);
        let total = counts.total.load(Ordering::Relaxed);
        let rate = d as f64 / elapsed.as_secs_f64();
        let eta = if d > 0 {
            format!("{:.0} s", (total - d.min(total)) as f64 / rate)
        } else {
            "unknown".into()
        };
        eprintln!(
            "progress: {:.1}% ({d} of {total} samples), {:.2} M samples/s, {:.0} s elapsed, ETA {eta}",
            100.0 * d as f64 / total.max(1) as f64,
            rate / 1e6,
            elapsed.as_secs_f64(),
        );
    }
}
