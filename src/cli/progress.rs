//! Progress of a long `map` run on stderr: an indicatif bar when stderr is a terminal (frames,
//! points/s, ETA when the number of frames is known), a plain line every N frames when it is
//! not (a log file, CI; also with the total and an ETA when known), nothing with `--quiet`. Stdout is never touched, so `--json` stays
//! pure JSON.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use octoquant::pipeline::MapStats;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// How progress is shown.
pub enum Progress {
    /// Nothing (`--quiet`).
    Quiet,
    /// A bar redrawn in place (stderr is a terminal).
    Bar(ProgressBar),
    /// A plain line every `every` frames (stderr is not a terminal), with the total and an
    /// ETA when the number of frames is known.
    Lines {
        every: usize,
        total: Option<usize>,
        start: Instant,
    },
}

impl Progress {
    /// The progress display for stderr as it is: `quiet` wins; `every` is the plain-line
    /// interval (0: no plain lines); `total` the number of frames when known.
    pub fn new(quiet: bool, every: usize, total: Option<usize>) -> Progress {
        if quiet {
            return Progress::Quiet;
        }
        if !std::io::stderr().is_terminal() {
            return if every == 0 {
                Progress::Quiet
            } else {
                Progress::Lines {
                    every,
                    total,
                    start: Instant::now(),
                }
            };
        }
        let bar = match total {
            Some(n) => {
                let b = ProgressBar::with_draw_target(Some(n as u64), ProgressDrawTarget::stderr());
                b.set_style(
                    ProgressStyle::with_template(
                        "{msg} [{bar:30}] {pos}/{len} frames, {elapsed} (ETA {eta})",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
                );
                b
            }
            None => {
                let b = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
                b.set_style(
                    ProgressStyle::with_template("{spinner} {msg} {pos} frames, {elapsed}")
                        .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                );
                b
            }
        };
        bar.enable_steady_tick(Duration::from_millis(200));
        Progress::Bar(bar)
    }

    /// Frames known to come, once it is known (gives the bar and the lines an ETA).
    pub fn set_total(&mut self, n: usize) {
        match self {
            Progress::Bar(b) => b.set_length(n as u64),
            Progress::Lines { total, .. } => *total = Some(n),
            Progress::Quiet => {}
        }
    }

    /// After each inserted frame, with the run's statistics so far (`skipped` frames of a
    /// resumed run were inserted before this process started).
    pub fn update(&mut self, stats: &MapStats, points_here: usize, skipped: usize) {
        match self {
            Progress::Quiet => {}
            Progress::Bar(b) => {
                let secs = b.elapsed().as_secs_f64();
                if secs > 0.0 {
                    b.set_message(format!(
                        "inserting: {:.2} M points/s,",
                        points_here as f64 / secs / 1e6
                    ));
                }
                b.set_position(stats.frames as u64);
            }
            Progress::Lines {
                every,
                total,
                start,
            } => {
                let done = stats.frames;
                if done > skipped && (done - skipped).is_multiple_of(*every) {
                    let secs = start.elapsed().as_secs_f64();
                    let pps = if secs > 0.0 {
                        points_here as f64 / secs
                    } else {
                        0.0
                    };
                    let (of, eta) = match *total {
                        // the frames left at this process's own pace so far
                        Some(n) => {
                            let left = n.saturating_sub(done) as f64;
                            let eta = secs / (done - skipped) as f64 * left;
                            (format!("/{n}"), format!(", ETA {eta:.0} s"))
                        }
                        None => (String::new(), String::new()),
                    };
                    errln!(
                        "map: {done}{of} frames inserted, {} points, {pps:.0} points/s, {secs:.1} s{eta}",
                        stats.total.points
                    );
                }
            }
        }
    }

    /// Clear the bar (the summary follows on stdout).
    pub fn finish(&self) {
        if let Progress::Bar(b) = self {
            b.finish_and_clear();
        }
    }
}
