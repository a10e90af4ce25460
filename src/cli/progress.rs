//! The progress display of a render: a bar on a terminal, else a line a
//! minute on stderr.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Progress of a render: a bar on a terminal, else a line a minute.
pub struct Progress {
    bar: Option<ProgressBar>,
    quiet: bool,
    total: AtomicU64,
    done: AtomicU64,
    start: std::time::Instant,
    last_line: std::sync::Mutex<std::time::Instant>,
}

impl Progress {
    pub fn new(total: u64, done: u64, quiet: bool) -> Progress {
        let bar = (std::io::stderr().is_terminal() && !quiet).then(|| {
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template("{msg} [{bar:30}] {percent:>3}% {per_sec} ETA {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_message("paths");
            bar.set_draw_target(ProgressDrawTarget::stderr());
            bar.set_position(done);
            bar
        });
        Progress {
            bar,
            quiet,
            total: AtomicU64::new(total),
            done: AtomicU64::new(done),
            start: std::time::Instant::now(),
            last_line: std::sync::Mutex::new(std::time::Instant::now()),
        }
    }

    pub fn inc(&self, n: u64) {
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        if let Some(b) = &self.bar {
            b.inc(n);
        } else if !self.quiet
            && let Ok(mut last) = self.last_line.lock()
            && last.elapsed().as_secs() >= 60
        {
            *last = std::time::Instant::now();
            let secs = self.start.elapsed().as_secs_f64();
            let total = self.total.load(Ordering::Relaxed);
            eprintln!(
                "progress: {:.1} % of {} paths, {:.0} s elapsed",
                100.0 * done as f64 / total.max(1) as f64,
                total,
                secs
            );
        }
    }

    /// Adds `n` paths to the total (a noise target's allocation, known
    /// once its pilot is done).
    pub fn grow(&self, n: u64) {
        self.total.fetch_add(n, Ordering::Relaxed);
        if let Some(b) = &self.bar {
            b.inc_length(n);
        }
    }

    pub fn println(&self, msg: &str) {
        match &self.bar {
            Some(b) => b.println(msg),
            None if !self.quiet => eprintln!("{msg}"),
            None => {}
        }
    }

    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
