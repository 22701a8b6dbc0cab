//! `fusion-sim run --input robot.bag --config robot.toml`: a ROS 1 bag or a
//! ROS 2 bag (MCAP) published live, its topics mapped by the `[[sensor]] topic`
//! keys of a fusiond configuration ([`fusion_shared::ros`]).
//!
//! The bag's stamps are of the robot's clock, not of this host's
//! CLOCK_MONOTONIC, which fusiond checks samples against: every stamp is moved
//! by one offset so that the first sample is stamped now, and the samples are
//! published paced by their stamps (their order and spacing kept).

use std::path::Path;

use anyhow::Context;
use fusion_shared::Sample;
use fusion_shared::ros::{BagItem, BagSummary, Route, read_bag};
use fusion_shared::time::{DEFAULT_MAX_JUMP_NS, TimeJumps};
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

/// Reads the bag at `path` on a thread of its own, calling `each` with every
/// sample (or why a message gave none) restamped onto this host's clock from
/// `now_ns` on; stops reading when `each` returns false. A stamp more than
/// `max_jump_ns` ahead of the bag's others is refused as `fusiond replay`
/// refuses it ([`TimeJumps`]): it would stop the stream until then. Returns
/// what the bag gave, and how many samples were refused so.
pub fn samples(
    path: &Path,
    config: &BagConfig,
    now_ns: u64,
    mut each: impl FnMut(u64, Result<Sample, String>) -> bool,
) -> anyhow::Result<(BagSummary, u64)> {
    std::thread::scope(|scope| {
        let (tx, rx) = crossbeam::channel::bounded::<BagItem>(4096);
        let reader = scope.spawn(move || read_bag(path, &config.routes, |item| drop(tx.send(item))));
        let mut offset: Option<i128> = None;
        let mut jumps = TimeJumps::new(config.max_jump_ns);
        let mut jumped = 0;
        for item in rx.iter() {
            let sample = item.sample.and_then(|mut s| {
                let t = i128::from(s.t_ns());
                if !jumps.admit(s.t_ns()) {
                    jumped += 1;
                    return Err(format!(
                        "its stamp jumps more than [validation] max_jump_ns ({} s) ahead of the bag's others",
                        config.max_jump_ns as f64 * 1e-9
                    ));
                }
                let shift = *offset.get_or_insert(i128::from(now_ns) - t);
                s.header_mut().t_ns = (t + shift).clamp(0, i128::from(u64::MAX)) as u64;
                Ok(s)
            });
            if !each(item.position, sample) {
                break;
            }
        }
        drop(rx);
        let summary = reader.join().map_err(|_| anyhow::anyhow!("the bag's reader failed"))?;
        Ok((summary.with_context(|| path.display().to_string())?, jumped))
    })
}
