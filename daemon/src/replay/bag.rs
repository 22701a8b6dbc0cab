//! `fusiond replay --input robot.bag`: a ROS 1 bag or a ROS 2 bag (MCAP) through
//! the engine, its topics mapped to sensors by `[[sensor]] topic`
//! ([`fusion_shared::ros`]).
//!
//! The bag is read on a thread of its own and its samples handed over through
//! a bounded channel: memory stays bounded by the history window (or, with
//! smoothing, by the run), whatever the bag's size.

use std::io::Write;
use std::path::Path;

use fusion_shared::ros::{BagError, BagSummary, Route, read_bag};

use super::{InputItem, NoCheck, ReplayError, ReplaySummary, replay_items, samples_read};
use crate::config::Config;
use crate::frames::SensorConfig;

/// Samples in flight between the bag's reader and the engine.
const CHANNEL_CAPACITY: usize = 4096;

/// Why a bag replay did not run.
#[derive(Debug, thiserror::Error)]
pub enum BagReplayError {
    /// The configuration maps no topic.
    #[error(
        "no [[sensor]] has a topic: give each sensor the ROS topic it is read from (topic = \"/imu/data\"; see the \
         ground-robot page of the guide)"
    )]
    NoTopics,
    /// The bag could not be read, or does not fit the topic map.
    #[error(transparent)]
    Bag(#[from] BagError),
    /// The replay failed.
    #[error(transparent)]
    Replay(#[from] ReplayError),
}

/// The topic map of a bag replay: each `[[sensor]]` of `config` with a
/// `topic`, its kinds under its id.
pub fn routes(config: &Config) -> Vec<Route> {
    // The kinds were checked when the configuration was read.
    let route = |s: &SensorConfig| Route::of_sensor(&s.name, s.id, &s.kinds, s.topic.as_deref());
    config.sensors.iter().filter_map(|s| route(s).ok().flatten()).collect()
}

/// Replays the bag at `path` with `config` (whose `[[sensor]] topic`s map the
/// bag's topics), writing estimates to `output`; returns the replay's summary
/// and the bag's.
pub fn replay_bag(
    config: &Config,
    path: &Path,
    output: Option<impl Write>,
    smooth: bool,
) -> Result<(ReplaySummary, BagSummary), BagReplayError> {
    let routes = routes(config);
    if routes.is_empty() {
        return Err(BagReplayError::NoTopics);
    }
    std::thread::scope(|scope| {
        let (tx, rx) = crossbeam::channel::bounded(CHANNEL_CAPACITY);
        let reader = scope.spawn(move || {
            // A replay that stopped drops the receiver: the rest is read and let go.
            read_bag(path, &routes, |item| drop(tx.send(item)))
        });
        let items = rx.into_iter().map(|item: fusion_shared::ros::BagItem| {
            Ok(InputItem { position: item.position, received_ns: None, sample: item.sample })
        });
        let replayed = replay_items(config, items, output, smooth, &mut NoCheck);
        let bag = reader.join().unwrap_or_else(|_| Err(BagError::Format("the bag's reader failed".into())))?;
        Ok((replayed.map(samples_read)?, bag))
    })
}
