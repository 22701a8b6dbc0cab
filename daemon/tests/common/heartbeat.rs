//! A line on the terminal every few seconds while a long test runs, so that
//! `cargo test` never sits silent (the test harness captures only `print!`
//! and `eprintln!`; these lines go straight to stderr). Also used by
//! `benches/tests` through `#[path]`.

use std::io::Write;
use std::sync::mpsc::{RecvTimeoutError, Sender, channel};
use std::time::{Duration, Instant};

/// How often a long test says it is still running.
const EVERY: Duration = Duration::from_secs(5);

/// Says `<what>: still running (N s of about T s)` every 5 s until dropped.
pub struct Heartbeat {
    /// Dropped with the heartbeat: its thread then ends.
    _stop: Sender<()>,
}

impl Heartbeat {
    /// Starts the lines for a test that takes about `expected`.
    pub fn start(what: &'static str, expected: Duration) -> Self {
        let (stop, stopped) = channel::<()>();
        let start = Instant::now();
        std::thread::spawn(move || {
            while let Err(RecvTimeoutError::Timeout) = stopped.recv_timeout(EVERY) {
                let line = format!(
                    "{what}: still running ({} s of about {} s)\n",
                    start.elapsed().as_secs(),
                    expected.as_secs()
                );
                let _ = std::io::stderr().write_all(line.as_bytes());
            }
        });
        Self { _stop: stop }
    }
}
