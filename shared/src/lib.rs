//! fusion-shared: the wire contract of fusiond and nothing else.
//!
//! - [`sample`]: what sensor processes publish: one [`SampleHeader`] and a payload per
//!   kind ([`ImuSample`], [`PositionSample`], [`VelocitySample`], …); [`SampleKind`] lists
//!   the kinds, [`for_each_sample_kind!`] is the list they come from.
//! - [`snapshot`]: [`StateSnapshot`], what fusiond publishes.
//! - [`config_record`]: the configuration fusiond publishes for recorders.
//! - [`exit`]: the exit statuses and the error line of every fusion binary.
//! - [`geodesy`]: WGS-84 geodetic coordinates ↔ the local ENU frame of a datum.
//! - [`service`]: service names under a namespace, QoS, and how every side opens them.
//! - `jsonl` (feature `json`): the JSON-lines sample format of replay files.
//! - `recording` (feature `json`): the topics, messages and schemas of an MCAP
//!   recording (`fusionctl record`, `fusiond replay --input RUN.mcap`).
//! - `mcap_scan` (feature `mcap`): where an MCAP file stops being readable.
//! - `ros` (feature `ros`): ROS 1 and ROS 2 bags as samples, through a topic map.
//! - [`transport`]: [`transport::Ipc`], the iceoryx2 service type of every port
//!   (iceoryx2's `ipc` with pooled per-loan state: no allocation per sample).
//! - [`permissions`]: only this user may touch fusiond's shared memory.
//! - [`time`]: [`now_ns`], the one clock of the system (CLOCK_MONOTONIC, ns).
//!
//! Every type here is `#[repr(C)]` with fixed-width fields only, units in the field
//! names, SI units, world frame ENU and body frame forward-left-up (REP-103).

pub mod config_record;
pub mod exit;
pub mod geodesy;
#[cfg(feature = "json")]
pub mod jsonl;
#[cfg(feature = "mcap")]
pub mod mcap_scan;
pub mod permissions;
#[cfg(feature = "json")]
pub mod recording;
#[cfg(feature = "ros")]
pub mod ros;
#[cfg(feature = "ros")]
pub mod ros_msgs;
pub mod sample;
pub mod service;
pub mod snapshot;
pub mod time;
pub mod transport;

// Every kind's wire type, whatever the kinds are (see `for_each_sample_kind!`).
pub use sample::*;
pub use snapshot::{Counters, Health, HealthReason, Model, Outcome, SensorCounters, StateSnapshot};
pub use time::now_ns;
