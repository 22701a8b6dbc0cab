//! `fusion-sim run --input robot.bag --config robot.toml`: a ROS 1 bag or a
//! ROS 2 bag (MCAP) published live, its topics mapped by the `[[sensor]] topic`
//! keys of a fusiond configuration ([`fusion_shared::ros`]).
//!
//! The bag's stamps are of the robot's clock, not of this host's
//! CLOCK_MONOTONIC, which fusiond checks samples against: every stamp is moved
//! by one offset so that the first sample is stamped now, and the samples are
//! published paced by their stamps (their order and spacing kept). Where the
//! robot's clock was set (stepped ahead or back by more than `[validation]
//! max_jump_ns`, as `fusiond replay` tells it), the offset is taken again: the
//! new timeline goes on where the old one stopped, after the time its
//! refused samples span.

use std::path::Path;

use anyhow::Context;
use fusion_shared::Sample;
use fusion_shared::ros::{BagItem, BagSummary, Route, read_bag};
use fusion_shared::time::{DEFAULT_MAX_JUMP_NS, Direction, Jump, TimeJumps};
use serde::Deserialize;

/// The `[[sensor]]` keys a topic map needs, and `[validation] max_jump_ns`;
/// the rest of the file is fusiond's.
#[derive(Deserialize)]
struct TopicMap {
    #[serde(default)]
    sensor: Vec<SensorTopic>,
    #[serde(default)]
    validation: Validation,
}

#[derive(Deserialize, Default)]
struct Validation {
    max_jump_ns: Option<u64>,
}

/// What `fusion-sim run --input ROBOT.bag --config ROBOT.toml` takes from the
/// configuration.
pub struct BagConfig {
    /// The topic map.
    pub routes: Vec<Route>,
    /// `[validation] max_jump_ns`: a stamp this far ahead of the bag's others
    /// is refused, as `fusiond replay` refuses it ([`TimeJumps`]).
    pub max_jump_ns: u64,
}

#[derive(Deserialize)]
struct SensorTopic {
    name: String,
    id: u32,
    kinds: Vec<String>,
    topic: Option<String>,
}

/// The topic map of the fusiond configuration at `path`.
pub fn routes(path: &Path) -> anyhow::Result<BagConfig> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let map: TopicMap =
        toml::from_str(&text).with_context(|| format!("{}: not a fusiond configuration", path.display()))?;
    let routes: Vec<Route> = map
        .sensor
        .iter()
        .filter_map(|s| Route::of_sensor(&s.name, s.id, &s.kinds, s.topic.as_deref()).transpose())
        .collect::<Result<_, _>>()
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    anyhow::ensure!(
        !routes.is_empty(),
        "{}: no [[sensor]] has a topic: give each sensor the ROS topic it is read from (topic = \"/imu/data\")",
        path.display()
    );
    Ok(BagConfig { routes, max_jump_ns: map.validation.max_jump_ns.unwrap_or(DEFAULT_MAX_JUMP_NS) })
}

/// A recording's stamps that jumped: the ones sent out of pace, and where a
/// new timeline began.
#[derive(Debug)]
pub struct Jumps {
    /// Samples stamped more than `max_jump_ns` ahead of the others.
    pub ahead: u64,
    /// Samples stamped more than `max_jump_ns` back behind them.
    pub back: u64,
    /// New timelines begun.
    pub timelines_begun: u64,
    /// The first [`TIMELINES_SAID`] of them: the message's (or line's)
    /// number, and the step, ns.
    pub timelines: Vec<(u64, i128)>,
    /// What the numbers count: "message" (a bag's) or "line" (a file's).
    pub at: &'static str,
}

/// How many new timelines a summary names one by one.
pub const TIMELINES_SAID: usize = 10;

impl std::fmt::Display for Jumps {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (n, way) in [(self.ahead, "ahead of"), (self.back, "back behind")] {
            if n > 0 {
                writeln!(
                    f,
                    "  {n} samples stamped more than [validation] max_jump_ns {way} the others: published at once, \
                     not paced (fusiond refuses them by its clock, as replay refuses them)"
                )?;
            }
        }
        for (position, step) in &self.timelines {
            writeln!(
                f,
                "  the clock was set {} by {:.3} s at {} {position}: a new timeline from there, published on from \
                 where the old one stopped",
                if *step < 0 { "back" } else { "ahead" },
                step.unsigned_abs() as f64 * 1e-9,
                self.at
            )?;
        }
        if self.timelines_begun > self.timelines.len() as u64 {
            writeln!(f, "  … and {} more new timelines", self.timelines_begun - self.timelines.len() as u64)?;
        }
        Ok(())
    }
}

/// A recording's stamps moved onto this host's clock by one offset, taken
/// again where the recording's clock was set ([`TimeJumps`], as `fusiond
/// replay` tells it): the new timeline goes on where the old one stopped,
/// after the time its refused samples span. A stamp the rule refuses keeps
/// the offset and is sent out of pace: waiting for it would stop the stream
/// (an hour ahead, or `u64::MAX`), and withholding it would leave a gap in
/// its sensor's sequence that fusiond counts as lost.
pub struct Restamp {
    shift: Option<i128>,
    start_ns: i128,
    newest_out: i128,
    time: TimeJumps,
    /// What jumped so far.
    pub jumps: Jumps,
}

impl Restamp {
    /// The first stamp goes to `start_ns`, or is moved by `shift` when given;
    /// `at` names the input's positions ("message", "line").
    pub fn new(max_jump_ns: u64, start_ns: u64, shift: Option<i128>, at: &'static str) -> Self {
        let start_ns = i128::from(start_ns);
        let jumps = Jumps { ahead: 0, back: 0, timelines_begun: 0, timelines: Vec::new(), at };
        Self { shift, start_ns, newest_out: start_ns, time: TimeJumps::new(max_jump_ns), jumps }
    }

    /// The stamp on this host's clock of a sample stamped `t_ns` (the
    /// input's `position`), and whether it is paced by it.
    pub fn stamp(&mut self, position: u64, t_ns: u64) -> (u64, bool) {
        let t = i128::from(t_ns);
        let paced = match self.time.admit(t_ns) {
            Jump::Near => true,
            Jump::Refused(Direction::Ahead) => {
                self.jumps.ahead += 1;
                false
            }
            Jump::Refused(Direction::Back) => {
                self.jumps.back += 1;
                false
            }
            Jump::NewTimeline { step_ns, run_start_ns } => {
                self.jumps.timelines_begun += 1;
                if self.jumps.timelines.len() < TIMELINES_SAID {
                    self.jumps.timelines.push((position, step_ns));
                }
                self.shift = Some(self.newest_out + (t - i128::from(run_start_ns)) - t);
                true
            }
        };
        let start = self.start_ns;
        let shift = *self.shift.get_or_insert(start - t);
        let stamped = (t + shift).clamp(0, i128::from(u64::MAX));
        if paced {
            self.newest_out = self.newest_out.max(stamped);
        }
        (stamped as u64, paced)
    }
}

/// Reads the bag at `path` on a thread of its own, calling `each` with every
/// sample (or why a message gave none) restamped onto this host's clock from
/// `now_ns` on ([`Restamp`]), and whether it is paced by its stamp; stops
/// reading when `each` returns false. Returns what the bag gave, and what
/// jumped.
pub fn samples(
    path: &Path,
    config: &BagConfig,
    now_ns: u64,
    mut each: impl FnMut(u64, Result<(Sample, bool), String>) -> bool,
) -> anyhow::Result<(BagSummary, Jumps)> {
    std::thread::scope(|scope| {
        let (tx, rx) = crossbeam::channel::bounded::<BagItem>(4096);
        let reader = scope.spawn(move || read_bag(path, &config.routes, |item| drop(tx.send(item))));
        let mut restamp = Restamp::new(config.max_jump_ns, now_ns, None, "message");
        for item in rx.iter() {
            let sample = item.sample.map(|mut s| {
                let (t, paced) = restamp.stamp(item.position, s.t_ns());
                s.header_mut().t_ns = t;
                (s, paced)
            });
            if !each(item.position, sample) {
                break;
            }
        }
        drop(rx);
        let summary = reader.join().map_err(|_| anyhow::anyhow!("the bag's reader failed"))?;
        Ok((summary.with_context(|| path.display().to_string())?, restamp.jumps))
    })
}
