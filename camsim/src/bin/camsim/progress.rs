//! Progress on stderr, the command line's alone: the library reports through callbacks.
//!
//! [`Progress`] prints one step per line (rewritten in place on a terminal); [`RenderBar`]
//! draws the render's bar on a terminal, redrawn every 200 ms by a thread of its own, fed by
//! the tracer's per-tile callback.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use host_tracer::tracer::render::RenderProgress;

/// Progress of a benchmark on stderr: one line rewritten in place on a terminal, a line per
/// step otherwise (logs).
pub struct Progress {
    label: &'static str,
    terminal: bool,
}

impl Progress {
    /// A printer whose lines start with `label`.
    pub fn new(label: &'static str) -> Self {
        Self {
            label,
            terminal: std::io::stderr().is_terminal(),
        }
    }

    /// Reports a step.
    pub fn step(&mut self, what: &str) {
        if self.terminal {
            eprint!("\r\x1b[K{}: {what}", self.label);
        } else {
            eprintln!("{}: {what}", self.label);
        }
    }

    /// Ends the line on a terminal.
    pub fn finish(self) {
        if self.terminal {
            eprintln!();
        }
    }
}

#[derive(Default)]
struct BarState {
    latest: Option<RenderProgress>,
    begin: Option<Instant>,
    completed: bool,
}

/// The render's progress bar; silent unless stderr is a terminal.
pub struct RenderBar {
    terminal: bool,
    state: Mutex<BarState>,
    stop: AtomicBool,
}

impl RenderBar {
    /// A bar (drawn only on a terminal).
    pub fn new() -> Self {
        Self {
            terminal: std::io::stderr().is_terminal(),
            state: Mutex::new(BarState::default()),
            stop: AtomicBool::new(false),
        }
    }

    /// Records the render's progress (called from the render's worker threads).
    pub fn update(&self, p: RenderProgress) {
        if let Ok(mut s) = self.state.lock() {
            s.begin.get_or_insert_with(Instant::now);
            s.latest = Some(p);
        }
    }

    /// Draws the bar complete and ends its line, if it was started and not yet finished.
    pub fn finish_line(&self) {
        if let Ok(mut s) = self.state.lock() {
            Self::draw(&mut s, self.terminal, true);
        }
    }

    fn draw(s: &mut BarState, terminal: bool, finish: bool) {
        let (Some(p), Some(begin)) = (s.latest, s.begin) else {
            return;
        };
        if !terminal || s.completed {
            return;
        }
        let done = if finish { p.total } else { p.done };
        let width = 30;
        let filled = done * width / p.total.max(1);
        eprint!(
            "\r\x1b[Krender [{}{}] {:>3}%  {:.1} s",
            "#".repeat(filled),
            " ".repeat(width - filled),
            done * 100 / p.total.max(1),
            begin.elapsed().as_secs_f64()
        );
        if finish || done == p.total {
            eprintln!();
            s.completed = true;
        }
    }

    /// Runs `work` with this bar redrawn every 200 ms beside it (on a terminal), then ends the
    /// bar's line.
    pub fn during<T>(&self, work: impl FnOnce(&Self) -> T) -> T {
        let result = std::thread::scope(|scope| {
            if self.terminal {
                scope.spawn(|| {
                    while !self.stop.load(Ordering::Relaxed) {
                        if let Ok(mut s) = self.state.lock() {
                            Self::draw(&mut s, true, false);
                        }
                        std::thread::sleep(Duration::from_millis(200));
                    }
                });
            }
            let result = work(self);
            self.stop.store(true, Ordering::Relaxed);
            result
        });
        self.finish_line();
        result
    }
}
