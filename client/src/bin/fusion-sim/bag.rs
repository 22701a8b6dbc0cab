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

/// The bag's stamps that jumped: refused ones, and where a new timeline began.
#[derive(Debug, Default)]
pub struct Jumps {
    /// Samples refused as stamped more than `max_jump_ns` ahead of the others.
    pub ahead: u64,
    /// Samples refused as stamped more than `max_jump_ns` back behind them.
    pub back: u64,
    /// Each new timeline: the message's number in the bag, and the step, ns.
    pub timelines: Vec<(u64, i128)>,
}

impl std::fmt::Display for Jumps {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (n, way) in [(self.ahead, "ahead of"), (self.back, "back behind")] {
            if n > 0 {
                writeln!(
                    f,
                    "  {n} samples refused: stamped more than [validation] max_jump_ns {way} the bag's others"
                )?;
            }
        }
        for (position, step) in &self.timelines {
            writeln!(
                f,
                "  the bag's clock was set {} by {:.3} s at message {position}: a new timeline from there, published \
                 on from where the old one stopped",
                if *step < 0 { "back" } else { "ahead" },
                step.unsigned_abs() as f64 * 1e-9
            )?;
        }
        Ok(())
    }
}

/// Reads the bag at `path` on a thread of its own, calling `each` with every
/// sample (or why a message gave none) restamped onto this host's clock from
/// `now_ns` on; stops reading when `each` returns false. A stamp more than
/// `max_jump_ns` ahead of the bag's others, or back behind them, is refused as
/// `fusiond replay` refuses it ([`TimeJumps`]): it would stop the stream until
/// then, or be refused by fusiond as from another clock. A run of them is a
/// new timeline: its first sample is stamped the time the run spans after the
/// newest one published. Returns what the bag gave, and what jumped.
pub fn samples(
    path: &Path,
    config: &BagConfig,
    now_ns: u64,
    mut each: impl FnMut(u64, Result<Sample, String>) -> bool,
) -> anyhow::Result<(BagSummary, Jumps)> {
    std::thread::scope(|scope| {
        let (tx, rx) = crossbeam::channel::bounded::<BagItem>(4096);
        let reader = scope.spawn(move || read_bag(path, &config.routes, |item| drop(tx.send(item))));
        let mut offset: Option<i128> = None;
        let mut newest_out = i128::from(now_ns);
        let mut time = TimeJumps::new(config.max_jump_ns);
        let mut jumps = Jumps::default();
        let max_jump_s = config.max_jump_ns as f64 * 1e-9;
        for item in rx.iter() {
            let sample = item.sample.and_then(|mut s| {
                let t = i128::from(s.t_ns());
                match time.admit(s.t_ns()) {
                    Jump::Near => {}
                    Jump::Refused(way) => {
                        let (count, way) = match way {
                            Direction::Ahead => (&mut jumps.ahead, "ahead of"),
                            Direction::Back => (&mut jumps.back, "back behind"),
                        };
                        *count += 1;
                        return Err(format!(
                            "its stamp jumps more than [validation] max_jump_ns ({max_jump_s} s) {way} the bag's \
                             others"
                        ));
                    }
                    Jump::NewTimeline { step_ns, run_start_ns } => {
                        jumps.timelines.push((item.position, step_ns));
                        offset = Some(newest_out + (t - i128::from(run_start_ns)) - t);
                    }
                }
                let shift = *offset.get_or_insert(i128::from(now_ns) - t);
                let stamped = (t + shift).clamp(0, i128::from(u64::MAX));
                newest_out = newest_out.max(stamped);
                s.header_mut().t_ns = stamped as u64;
                Ok(s)
            });
            if !each(item.position, sample) {
                break;
            }
        }
        drop(rx);
        let summary = reader.join().map_err(|_| anyhow::anyhow!("the bag's reader failed"))?;
        Ok((summary.with_context(|| path.display().to_string())?, jumps))
    })
}
