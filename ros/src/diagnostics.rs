//! `diagnostic_msgs/msg/DiagnosticArray` on `/diagnostics`: what `rqt_robot_monitor`
//! and a robot's aggregator show of fusiond, one status per line:
//!
//! - `<node>: estimate`: OK when fusiond's health is `ok`, WARN while it
//!   initialises or is degraded (the reasons in the message), STALE when no
//!   snapshot came for two periods (fusiond not running);
//! - `<node>: <sensor name>`, one per sensor fusiond counts: its counters
//!   (received, fused, gated, refused, late, too late, duplicate, invalid,
//!   lost, rate limited), WARN when it is stale or its NIS out of bounds;
//! - `<node>: ROS input`: per topic the messages, the samples sent and what
//!   was refused, with its reason; WARN when anything was.

use std::collections::BTreeMap;

use fusion_shared::StateSnapshot;
use fusion_shared::ros::Route;
use fusion_shared::ros::messages::Ros2Header;
use fusion_shared::ros::ros2::{DiagnosticArray, DiagnosticStatus, KeyValue, level};
use fusion_shared::snapshot::health;

use crate::input::TopicCounts;

fn kv(key: &str, value: impl ToString) -> KeyValue {
    KeyValue { key: key.into(), value: value.to_string() }
}

fn status(level: u8, name: String, message: String, values: Vec<KeyValue>) -> DiagnosticStatus {
    DiagnosticStatus { level, name, message, hardware_id: String::new(), values }
}

/// What is reported on.
pub struct Report<'a> {
    /// The node's name (each status's prefix).
    pub node: &'a str,
    /// The newest snapshot, and whether it is stale.
    pub snapshot: Option<(&'a StateSnapshot, bool)>,
    /// The topic map (for the sensors' names).
    pub routes: &'a [Route],
    /// The ROS input's counts.
    pub input: &'a BTreeMap<String, TopicCounts>,
    /// Times the ROS clock's offset was taken again.
    pub clock_steps: u64,
}

/// The array for `report`, stamped `stamp_ns` (ROS time).
pub fn diagnostics(report: &Report<'_>, stamp_ns: u64) -> DiagnosticArray {
    let node = report.node;
    let mut out = vec![estimate(report)];
    if let Some((s, _)) = report.snapshot {
        for (i, c) in s.sensor_counters().iter().enumerate() {
            let kind = c.sample_kind().map_or("unknown kind", |k| k.name());
            let name = report
                .routes
                .iter()
                .find(|r| r.sensor == c.sensor && c.sample_kind().is_some_and(|k| r.kinds.contains(&k)))
                .map_or_else(|| format!("{kind} {}", c.sensor), |r| format!("{} ({kind})", r.name));
            let stale = s.stale_sensors & (1 << i) != 0;
            let nis = s.nis_sensors & (1 << i) != 0;
            let (lvl, msg) = match (stale, nis) {
                (true, _) => (level::WARN, "stale: no sample for longer than its kind's timeout"),
                (_, true) => (level::WARN, "NIS persistently out of its χ² band"),
                _ => (level::OK, "ok"),
            };
            let n = &c.counts;
            let values = vec![
                kv("received", n.received),
                kv("fused", n.fused),
                kv("gated", n.gated),
                kv("refused", n.refused),
                kv("late", n.late),
                kv("too late", n.too_late),
                kv("duplicate", n.duplicate),
                kv("invalid", n.invalid),
                kv("lost", n.lost),
                kv("rate limited", n.rate_limited),
                kv("last NIS", c.last_nis),
            ];
            out.push(status(lvl, format!("{node}: {name}"), msg.into(), values));
        }
    }
    let mut values = vec![kv("ROS clock steps", report.clock_steps)];
    let mut refused = 0;
    for (topic, c) in report.input {
        values.push(kv(&format!("{topic} messages"), c.messages));
        values.push(kv(&format!("{topic} samples"), c.samples));
        for (why, n) in &c.refused {
            refused += n;
            values.push(kv(&format!("{topic} refused: {why}"), n));
        }
    }
    let (lvl, msg) =
        if refused == 0 { (level::OK, "ok".to_string()) } else { (level::WARN, format!("{refused} refused")) };
    out.push(status(lvl, format!("{node}: ROS input"), msg, values));
    DiagnosticArray { header: Ros2Header::at(stamp_ns, ""), status: out }
}

fn estimate(report: &Report<'_>) -> DiagnosticStatus {
    let name = format!("{}: estimate", report.node);
    let Some((s, stale)) = report.snapshot else {
        return status(level::STALE, name, "no snapshot from fusiond yet".into(), Vec::new());
    };
    if stale {
        return status(level::STALE, name, "no snapshot from fusiond for two periods".into(), Vec::new());
    }
    let reasons: Vec<&str> = s.health_reason_names().collect();
    let lvl = if s.health == health::OK { level::OK } else { level::WARN };
    let mut message = health::name(s.health).to_string();
    if !reasons.is_empty() {
        message = format!("{message}: {}", reasons.join(", "));
    }
    let mut values = vec![kv("health", health::name(s.health)), kv("estimate time ns", s.t_ns)];
    if let Some(sd) = s.position_std() {
        values.push(kv("position std m", format!("{:.3} {:.3} {:.3}", sd[0], sd[1], sd[2])));
    }
    if let Some(sd) = s.roll_pitch_yaw_std() {
        let deg = sd.map(f64::to_degrees);
        values.push(kv("roll pitch yaw std deg", format!("{:.2} {:.2} {:.2}", deg[0], deg[1], deg[2])));
    }
    values.push(kv("rewinds", s.rewinds));
    values.push(kv("refused in validation", s.rejected()));
    status(lvl, name, message, values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_fusiond_is_stale_and_refusals_warn() {
        let mut input = BTreeMap::new();
        let mut c = TopicCounts { messages: 3, samples: 2, ..Default::default() };
        c.refused.insert("no attachment".into(), 1);
        input.insert("/imu/data".to_string(), c);
        let r = Report { node: "fusiond", snapshot: None, routes: &[], input: &input, clock_steps: 0 };
        let d = diagnostics(&r, 5);
        assert_eq!(d.status[0].level, level::STALE);
        let ros = d.status.last().unwrap();
        assert_eq!((ros.level, ros.message.as_str()), (level::WARN, "1 refused"));
        assert!(ros.values.iter().any(|v| v.key == "/imu/data refused: no attachment" && v.value == "1"));
    }
}
