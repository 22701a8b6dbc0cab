//! What a recording of fusiond holds (feature `json`): the topics, their JSON
//! messages and JSON Schemas. `fusionctl record` writes them to MCAP, `fusiond
//! replay` reads them back, and Foxglove and PlotJuggler open them as they are.
//!
//! | topic | schema | one message per |
//! |---|---|---|
//! | `/fusion/samples/<kind>` | `fusion.<Type>` (JSON Schema of the kind's JSON form) | input sample, in fusiond's processing order |
//! | `/fusion/state` | `fusion.StateSnapshot` ([`SnapshotJson`]) | snapshot |
//! | `/fusion/pose` | `foxglove.PoseInFrame` | snapshot with an input |
//! | `/fusion/location` | `foxglove.LocationFix` | snapshot with an input, once a datum is set |
//!
//! Every message is JSON (`message_encoding` `json`, `schema_encoding`
//! `jsonschema`). Numbers are written so that they read back to the same bits;
//! a non-finite number is written as `null` (JSON has no NaN), so a sample
//! carrying one reads back as a malformed message.
//!
//! A sample message is the kind's JSON-lines object (see [`crate::jsonl`]) with
//! the header's `sent_ns`, and `kind` when it is not the payload's. Its log time
//! is when fusiond received it (from the snapshot that reports it); its publish
//! time the sender's `sent_ns`.

use serde::{Deserialize, Serialize};

use crate::snapshot::{INPUT_NONE, health, model};
use crate::{Sample, SampleKind, StateSnapshot};

/// `message_encoding` of every channel.
pub const MESSAGE_ENCODING: &str = "json";
/// `encoding` of every schema.
pub const SCHEMA_ENCODING: &str = "jsonschema";
/// Every snapshot, in full.
pub const STATE_TOPIC: &str = "/fusion/state";
/// Schema name of [`STATE_TOPIC`].
pub const STATE_SCHEMA: &str = "fusion.StateSnapshot";
/// The estimated pose of each snapshot with an input.
pub const POSE_TOPIC: &str = "/fusion/pose";
/// Schema name of [`POSE_TOPIC`].
pub const POSE_SCHEMA: &str = "foxglove.PoseInFrame";
/// The estimated position in latitude, longitude and height, once a datum is set.
pub const LOCATION_TOPIC: &str = "/fusion/location";
/// Schema name of [`LOCATION_TOPIC`].
pub const LOCATION_SCHEMA: &str = "foxglove.LocationFix";
/// Frame of the poses: the local ENU frame of the filter.
pub const WORLD_FRAME: &str = "enu";
/// Prefix of the sample topics (`/fusion/samples/<kind>`).
pub const SAMPLE_TOPIC_PREFIX: &str = "/fusion/samples/";

/// The topic of the samples of `kind`.
pub fn sample_topic(kind: SampleKind) -> String {
    format!("{SAMPLE_TOPIC_PREFIX}{}", kind.name())
}

/// The kind whose samples `topic` carries, if it is a sample topic.
pub fn kind_of_topic(topic: &str) -> Option<SampleKind> {
    topic.strip_prefix(SAMPLE_TOPIC_PREFIX).and_then(SampleKind::from_name)
}

/// Generates the per-kind functions from the one list of kinds.
macro_rules! recorded_kinds {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident;)*) => {
        /// Schema name and JSON Schema of the samples of `kind`.
        pub fn sample_schema(kind: SampleKind) -> (String, String) {
            let schema = match kind {
                $(SampleKind::$variant => schemars::schema_for!(crate::sample::$ty),)*
            };
            (format!("fusion.{}", schema_title(&schema)), schema.as_value().to_string())
        }

        /// Appends the message of `sample` (its kind's JSON object) to `out`.
        pub fn write_sample(sample: &Sample, out: &mut Vec<u8>) {
            // Plain numbers and arrays into a Vec cannot fail.
            let _ = match sample {
                $(Sample::$variant(s) => serde_json::to_writer(&mut *out, s),)*
            };
        }

        /// Reads a message of a sample of `kind`.
        pub fn parse_sample(kind: SampleKind, message: &[u8]) -> Result<Sample, serde_json::Error> {
            match kind {
                $(SampleKind::$variant => serde_json::from_slice::<crate::sample::$ty>(message).map(Sample::from),)*
            }
        }
    };
}
crate::for_each_sample_kind!(recorded_kinds);

fn schema_title(schema: &schemars::Schema) -> String {
    schema.get("title").and_then(|t| t.as_str()).unwrap_or("Sample").to_string()
}

/// The JSON Schema of [`SnapshotJson`].
pub fn state_schema() -> String {
    schemars::schema_for!(SnapshotJson).as_value().to_string()
}

/// A kind code's name, `"none"` for [`INPUT_NONE`] or an unknown code.
fn kind_name(code: u32) -> String {
    SampleKind::from_code(code).map_or("none", |k| k.name()).to_string()
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// The estimate after one sample, as JSON: what a `fusiond replay` output line
/// holds, and what a snapshot's JSON ([`SnapshotJson`]) gives first. `K` and
/// `V` are how the kind's name and the numbers are held (owned to read,
/// borrowed to write without copying).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct EstimateJson<K = String, V = Vec<f64>> {
    /// Time of validity of the estimate, ns.
    pub t_ns: u64,
    /// Kind of the newest processed sample (`"imu"`, `"odometry"`, …).
    pub kind: K,
    /// Its sensor id.
    pub sensor: u32,
    /// Its sequence number.
    pub seq: u64,
    /// State vector.
    pub x: V,
    /// Covariance, row-major.
    #[serde(rename = "P")]
    pub p: V,
    /// NIS of the newest sample if it was a measurement.
    pub nis: Option<f64>,
    /// Whether that measurement was fused.
    pub accepted: Option<bool>,
}

/// A snapshot as JSON: the `/fusion/state` messages and `fusionctl echo`'s
/// lines. The replay output's fields come first ([`EstimateJson`], whose
/// fields it gives as its own: `snapshot.t_ns`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[schemars(title = "StateSnapshot")]
pub struct SnapshotJson {
    /// The estimate.
    #[serde(flatten)]
    pub estimate: EstimateJson,
    /// Snapshot sequence number.
    pub snapshot_seq: u64,
    /// When fusiond published it, ns.
    pub publish_ns: u64,
    /// `linear` or `ins`.
    pub model: String,
    /// The sample that made this snapshot (kind `none` for a health-only one).
    pub input: InputJson,
    /// `initialising`, `ok` or `degraded`.
    pub health: String,
    /// Why it is not ok.
    pub health_reasons: Vec<String>,
    /// Sensors whose stream went stale.
    pub stale_sensors: Vec<SensorJson>,
    /// Sensors whose NIS is persistently out of its band (none in recordings
    /// made before it was recorded).
    #[serde(default)]
    pub nis_sensors: Vec<SensorJson>,
    /// The datum of the ENU frame, once set.
    pub datum: Option<DatumJson>,
    /// Counters per sensor.
    pub counters: Vec<CountersJson>,
    /// Rewinds since start.
    pub rewinds: u64,
    /// Samples counted against no sensor.
    pub unknown_sensor: u64,
    /// Re-initialisations from position fixes after a lock-out.
    pub reinitialisations: u64,
    /// Readers refused a slot.
    pub readers_refused: u64,
    /// A late sample's correction not yet in this estimate (`null`: settled,
    /// the estimate includes every sample received). Absent in recordings of
    /// fusiond before wire v7.
    #[serde(default)]
    pub pending: Option<PendingJson>,
    /// Samples re-processed in fusiond's idle time since start.
    #[serde(default)]
    pub background_steps: u64,
    /// The vehicle was detected standing still (`[model.standstill]`). Absent in
    /// recordings of fusiond before wire v8.
    #[serde(default)]
    pub standing: bool,
    /// Standstill updates fused since start.
    #[serde(default)]
    pub standstill_updates: u64,
    /// The auxiliary states after the model's own in `x` and `P`, in order
    /// (`odometry_scale`). Absent in recordings of fusiond before wire v9.
    #[serde(default)]
    pub aux_states: Vec<String>,
    /// How late the velocity sensors' stamps look beyond their configured
    /// offset (`null`: no estimate). Absent before wire v9.
    #[serde(default)]
    pub velocity_offset: Option<OffsetJson>,
    /// Samples refused in validation since start, by reason (the reasons with
    /// a count; [`crate::snapshot::rejection`]). Absent before wire v10.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub rejections: std::collections::BTreeMap<String, u64>,
}

/// [`StateSnapshot::velocity_time_offset`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct OffsetJson {
    /// The estimate, ns (positive: late).
    pub ns: f64,
    /// Its standard deviation, ns.
    pub std_ns: f64,
    /// Samples it is from.
    pub samples: u64,
}

/// A correction still to land ([`StateSnapshot::pending_steps`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct PendingJson {
    /// Later samples still to re-process.
    pub steps: u64,
    /// Time of validity of the oldest sample whose effect is not yet in the estimate, ns.
    pub since_t_ns: u64,
}

/// The input of a snapshot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct InputJson {
    /// Time of validity, ns.
    pub t_ns: u64,
    /// Kind, `none` for a health-only snapshot.
    pub kind: String,
    /// Sensor id.
    pub sensor: u32,
    /// Sequence number.
    pub seq: u64,
    /// When its sender sent it, ns (0 unknown).
    pub sent_ns: u64,
    /// When fusiond received it, ns.
    pub received_ns: u64,
    /// Later samples re-processed because it came late.
    pub replayed: u32,
}

/// A sensor by kind and id.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SensorJson {
    /// Kind.
    pub kind: String,
    /// Id.
    pub sensor: u32,
}

/// The datum of the ENU frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct DatumJson {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Height above the WGS-84 ellipsoid, m.
    pub height_m: f64,
}

/// One sensor's counters (see [`crate::Counters`]), its kind and id first
/// and its last NIS after them, in one flat object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct CountersJson {
    /// Its kind's name.
    pub kind: String,
    /// Its sensor id.
    pub sensor: u32,
    /// What became of its samples.
    #[serde(flatten)]
    pub counts: crate::Counters,
    /// NIS of the sensor's last measurement.
    pub last_nis: Option<f64>,
}

impl From<&StateSnapshot> for SnapshotJson {
    fn from(s: &StateSnapshot) -> Self {
        let counters = s
            .sensor_counters()
            .iter()
            .map(|c| CountersJson {
                kind: kind_name(c.kind),
                sensor: c.sensor,
                counts: c.counts,
                last_nis: finite(c.last_nis),
            })
            .collect();
        let estimate = EstimateJson {
            t_ns: s.t_ns,
            kind: kind_name(s.sample_kind),
            sensor: s.sample_sensor,
            seq: s.sample_seq,
            x: s.state().to_vec(),
            p: s.covariance().to_vec(),
            nis: finite(s.nis),
            accepted: s.accepted(),
        };
        Self {
            estimate,
            snapshot_seq: s.seq,
            publish_ns: s.publish_ns,
            model: model::name(s.model).to_string(),
            input: InputJson {
                t_ns: s.input_t_ns,
                kind: kind_name(s.input_kind),
                sensor: s.input_sensor,
                seq: s.input_seq,
                sent_ns: s.input_sent_ns,
                received_ns: s.input_received_ns,
                replayed: s.input_replayed,
            },
            health: health::name(s.health).to_string(),
            health_reasons: s.health_reason_names().map(str::to_string).collect(),
            stale_sensors: s
                .stale_sensor_counters()
                .map(|c| SensorJson { kind: kind_name(c.kind), sensor: c.sensor })
                .collect(),
            nis_sensors: s
                .nis_sensor_counters()
                .map(|c| SensorJson { kind: kind_name(c.kind), sensor: c.sensor })
                .collect(),
            datum: s.datum().map(|d| DatumJson {
                lat_deg: d.latitude_deg,
                lon_deg: d.longitude_deg,
                height_m: d.height_m,
            }),
            counters,
            rewinds: s.rewinds,
            unknown_sensor: s.unknown_sensor,
            reinitialisations: s.reinitialisations,
            readers_refused: s.readers_refused,
            pending: (!s.settled()).then_some(PendingJson { steps: s.pending_steps, since_t_ns: s.pending_since_t_ns }),
            background_steps: s.background_steps,
            standing: s.standing(),
            standstill_updates: s.standstill_updates,
            rejections: s
                .rejection_counts()
                .map(|(code, n)| (crate::snapshot::rejection::name(code).to_string(), n))
                .collect(),
            aux_states: crate::snapshot::aux::ALL
                .iter()
                .filter(|(bit, _)| s.aux_states & bit != 0)
                .map(|(_, name)| name.to_string())
                .collect(),
            velocity_offset: s.velocity_time_offset().map(|(ns, std_ns, samples)| OffsetJson { ns, std_ns, samples }),
        }
    }
}

impl std::ops::Deref for SnapshotJson {
    type Target = EstimateJson;

    fn deref(&self) -> &EstimateJson {
        &self.estimate
    }
}

impl SnapshotJson {
    /// Whether the snapshot reports a processed sample (not health only).
    pub fn has_input(&self) -> bool {
        self.input.kind != kind_name(INPUT_NONE)
    }
}

/// `foxglove.Time` of a CLOCK_MONOTONIC time in ns.
fn foxglove_time(t_ns: u64) -> serde_json::Value {
    serde_json::json!({"sec": t_ns / 1_000_000_000, "nsec": t_ns % 1_000_000_000})
}

/// The name of the MCAP metadata record of a recording's clocks.
pub const CLOCK_METADATA: &str = "fusion.clock";
/// Its key: the wall clock's lead over CLOCK_MONOTONIC when the recording
/// started, ns. The log and publish times of every message are wall-clock
/// (that CLOCK_MONOTONIC time plus it); the times inside the messages stay
/// CLOCK_MONOTONIC (fusiond's clock), but for the `foxglove.*` messages' `timestamp`.
pub const CLOCK_OFFSET_KEY: &str = "wall_minus_monotonic_ns";

/// The `foxglove.PoseInFrame` of a snapshot: position in the ENU frame and, for
/// `ins`, the attitude (body → ENU); identity for `linear`. Its timestamp is
/// wall-clock: the estimate's time plus `wall_offset_ns` (see [`CLOCK_OFFSET_KEY`]).
pub fn pose_in_frame(s: &StateSnapshot, wall_offset_ns: u64) -> serde_json::Value {
    let x = s.state();
    let p = |i: usize| x.get(i).copied().unwrap_or(0.0);
    // ins: x = [p, v, q_wxyz, b_a, b_g].
    let (qw, qx, qy, qz) = if s.model == model::INS { (p(6), p(7), p(8), p(9)) } else { (1.0, 0.0, 0.0, 0.0) };
    serde_json::json!({
        "timestamp": foxglove_time(s.t_ns.saturating_add(wall_offset_ns)),
        "frame_id": WORLD_FRAME,
        "pose": {
            "position": {"x": p(0), "y": p(1), "z": p(2)},
            "orientation": {"x": qx, "y": qy, "z": qz, "w": qw},
        },
    })
}

/// The `foxglove.LocationFix` of a snapshot's position, once a datum is set,
/// with the position covariance (ENU, m²).
pub fn location_fix(s: &StateSnapshot, wall_offset_ns: u64) -> Option<serde_json::Value> {
    let (lat, lon, height) = s.position_geodetic()?;
    let n = s.cov_dim as usize;
    let cov = s.covariance();
    let c: Vec<f64> = (0..3).flat_map(|r| (0..3).map(move |c| (r, c))).map(|(r, c)| cov[r * n + c]).collect();
    Some(serde_json::json!({
        "timestamp": foxglove_time(s.t_ns.saturating_add(wall_offset_ns)),
        "frame_id": WORLD_FRAME,
        "latitude": lat,
        "longitude": lon,
        "altitude": height,
        "position_covariance": c,
        "position_covariance_type": 3,
    }))
}

/// The JSON Schema of `foxglove.PoseInFrame` (Foxglove's schema, the fields used here).
pub const POSE_IN_FRAME_JSON_SCHEMA: &str = r#"{"title":"foxglove.PoseInFrame","description":"A timestamped pose for an object or reference frame in 3D space","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}},"description":"Timestamp of pose"},"frame_id":{"type":"string","description":"Frame of reference for pose position and orientation"},"pose":{"title":"foxglove.Pose","description":"Pose in 3D space","type":"object","properties":{"position":{"title":"foxglove.Vector3","description":"Point denoting position in 3D space","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}},"required":["x","y","z"]},"orientation":{"title":"foxglove.Quaternion","description":"Quaternion denoting orientation in 3D space","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}},"required":["x","y","z","w"]}},"required":["position","orientation"]}},"required":["timestamp","frame_id","pose"]}"#;

/// The JSON Schema of `foxglove.LocationFix` (Foxglove's schema, the fields used here).
pub const LOCATION_FIX_JSON_SCHEMA: &str = r#"{"title":"foxglove.LocationFix","description":"A navigation satellite fix for any Global Navigation Satellite System","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}},"description":"Timestamp of the message"},"frame_id":{"type":"string","description":"Frame for the sensor. Latitude and longitude readings are at the origin of the frame."},"latitude":{"type":"number","description":"Latitude in degrees"},"longitude":{"type":"number","description":"Longitude in degrees"},"altitude":{"type":"number","description":"Altitude in meters"},"position_covariance":{"type":"array","items":{"type":"number"},"minItems":9,"maxItems":9,"description":"Position covariance (m^2) defined relative to a tangential plane through the reported position. The components are East, North, and Up (ENU), in row-major order."},"position_covariance_type":{"title":"foxglove.PositionCovarianceType","oneOf":[{"title":"UNKNOWN","const":0},{"title":"APPROXIMATED","const":1},{"title":"DIAGONAL_KNOWN","const":2},{"title":"KNOWN","const":3}]}},"required":["timestamp","frame_id","latitude","longitude","altitude","position_covariance","position_covariance_type"]}"#;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ImuSample, PositionSample};

    #[test]
    fn sample_messages_round_trip_with_the_live_header() {
        let mut imu = ImuSample::new(7, 2, 3, [0.1, 1.0 / 3.0, -2e-300], [1e300, 0.0, -0.5]);
        imu.header.sent_ns = 99;
        let mut pos = PositionSample::new(9, 0, 0, [std::f64::consts::PI; 3], [1.0; 9]);
        pos.header.kind = 77; // a faulty sender's header, kept as it was
        for (kind, sample) in [(SampleKind::Imu, Sample::Imu(imu)), (SampleKind::Position, Sample::Position(pos))] {
            let mut m = Vec::new();
            write_sample(&sample, &mut m);
            assert_eq!(parse_sample(kind, &m).unwrap(), sample, "{}", String::from_utf8_lossy(&m));
            assert_eq!(kind_of_topic(&sample_topic(kind)), Some(kind));
        }
        assert!(parse_sample(SampleKind::Imu, br#"{"t_ns": 1}"#).is_err());
        assert_eq!(kind_of_topic("/fusion/state"), None);
    }

    #[test]
    fn every_schema_is_json_and_names_its_type() {
        for &kind in SampleKind::ALL {
            let (name, schema) = sample_schema(kind);
            let v: serde_json::Value = serde_json::from_str(&schema).unwrap();
            assert!(name.starts_with("fusion.") && name.ends_with("Sample"), "{name}");
            assert!(v["properties"]["t_ns"].is_object() && v["properties"]["seq"].is_object(), "{schema}");
        }
        let state: serde_json::Value = serde_json::from_str(&state_schema()).unwrap();
        assert!(state["properties"]["P"].is_object());
        for s in [POSE_IN_FRAME_JSON_SCHEMA, LOCATION_FIX_JSON_SCHEMA] {
            assert!(serde_json::from_str::<serde_json::Value>(s).is_ok());
        }
    }

    #[test]
    fn a_snapshot_reads_back_equal() {
        let mut s = StateSnapshot {
            model: model::INS,
            state_len: 16,
            cov_dim: 15,
            input_kind: SampleKind::Imu as u32,
            ..Default::default()
        };
        s.x[6] = 1.0;
        s.x[0] = 1.0 / 3.0;
        s.cov[0] = 2e-17;
        let j = SnapshotJson::from(&s);
        let back: SnapshotJson = serde_json::from_str(&serde_json::to_string(&j).unwrap()).unwrap();
        assert_eq!(back, j);
        assert!(j.has_input());
        assert_eq!(pose_in_frame(&s, 0)["pose"]["orientation"]["w"], 1.0);
        assert!(location_fix(&s, 0).is_none(), "no datum, no location");
        // The foxglove timestamp is wall-clock: the estimate's time plus the offset.
        s.t_ns = 5_500_000_000;
        assert_eq!(pose_in_frame(&s, 1_700_000_000_000_000_000)["timestamp"]["sec"], 1_700_000_005u64);
        assert_eq!(pose_in_frame(&s, 1_700_000_000_000_000_000)["timestamp"]["nsec"], 500_000_000u64);
    }
}
