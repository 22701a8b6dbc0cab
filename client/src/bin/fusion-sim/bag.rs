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
use serde::Deserialize;

/// The `[[sensor]]` keys a topic map needs; the rest of the file is fusiond's.
#[derive(Deserialize)]
struct TopicMap {
    #[serde(default)]
    sensor: Vec<SensorTopic>,
}

#[derive(Deserialize)]
struct SensorTopic {
    name: String,
    id: u32,
    kinds: Vec<String>,
    topic: Option<String>,
}

/// The topic map of the fusiond configuration at `path`.
pub fn routes(path: &Path) -> anyhow::Result<Vec<Route>> {
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
    Ok(routes)
}

/// Reads the bag at `path` on a thread of its own, calling `each` with every
/// sample (or why a message gave none) restamped onto this host's clock from
/// `now_ns` on; stops reading when `each` returns false. Returns what the bag gave.
pub fn samples(
    path: &Path,
    routes: &[Route],
    now_ns: u64,
    mut each: impl FnMut(u64, Result<Sample, String>) -> bool,
) -> anyhow::Result<BagSummary> {
    std::thread::scope(|scope| {
        let (tx, rx) = crossbeam::channel::bounded::<BagItem>(4096);
        let reader = scope.spawn(move || read_bag(path, routes, |item| drop(tx.send(item))));
        let mut offset: Option<i128> = None;
        for item in rx.iter() {
            let sample = item.sample.map(|mut s| {
                let t = i128::from(s.t_ns());
                let shift = *offset.get_or_insert(i128::from(now_ns) - t);
                s.header_mut().t_ns = (t + shift).clamp(0, i128::from(u64::MAX)) as u64;
                s
            });
            if !each(item.position, sample) {
                break;
            }
        }
        drop(rx);
        let summary = reader.join().map_err(|_| anyhow::anyhow!("the bag's reader failed"))?;
        summary.with_context(|| path.display().to_string())
    })
}
