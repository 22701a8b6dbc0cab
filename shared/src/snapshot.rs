//! `StateSnapshot`: what fusiond publishes after every processed sample (several
//! IMUs averaged: after each IMU instant's last sample, see `[imu] instant_wait_ns`).
//!
//! A fixed-capacity, self-describing record: the estimate (up to 22 states and a
//! 21×21 covariance, enough for the INS model with every auxiliary state), the sample it is the estimate at,
//! the input sample that triggered it (with its send time, so any reader can
//! measure latency), health, and per-sensor counters.

use iceoryx2::prelude::ZeroCopySend;

use crate::SampleKind;
use crate::geodesy::Datum;

pub mod rejection;
mod typed;
pub use typed::{Health, HealthReason, Model, Outcome};

/// Largest state vector a snapshot carries.
pub const MAX_STATE: usize = 22;
/// Largest covariance side a snapshot carries.
pub const MAX_COV: usize = 21;
/// Entries of the covariance array (`MAX_COV²`).
pub const MAX_COV_LEN: usize = MAX_COV * MAX_COV;
/// Most sensors (of all kinds) a snapshot reports.
pub const MAX_SENSORS: usize = 16;
/// Entries of [`StateSnapshot::rejections`] (see [`rejection`]; entry 0 unused).
pub const MAX_REJECTIONS: usize = 16;
/// [`StateSnapshot::input_kind`] of a snapshot published without a new sample:
/// the health changed while no sample arrived (a stream went stale), or a late
/// sample's correction landed (the snapshot is then [settled](StateSnapshot::settled)).
/// Its other `input_*` fields are zero. No [`SampleKind`] has this code (theirs
/// start at 1).
pub const INPUT_NONE: u32 = 0;

/// The list of filter models: the only place a model is registered.
///
/// Each line is `Variant = code, "name", module, ModelType, ParamsType, cov_dim,
/// [layout];`: the [`Model`] variant, its code in snapshots
/// ([`StateSnapshot::model`], from 1, never reused), its name (`[model] kind`
/// in the config); for the daemon, its module (`core/src/model/<module>.rs`),
/// its model type and the type of its `[model]` parameters; and what a reader
/// needs of its snapshots: the side of its covariance and its state vector's
/// layout ([`Model::state_layout`]). `for_each_model!(callback)` expands to
/// `callback! { <the list> }`: this crate generates [`Model`] from it, the
/// daemon its `[model]` table and the mapping from a config to a model type.
#[macro_export]
macro_rules! for_each_model {
    ($callback:ident) => {
        $callback! {
            /// Constant velocity: state `[p, v]`, covariance 6×6 over the same.
            Linear = 1, "linear", linear, LinearModel, LinearParams, 6, [
                ("p_x m", Some(0)), ("p_y m", Some(1)), ("p_z m", Some(2)),
                ("v_x m/s", Some(3)), ("v_y m/s", Some(4)), ("v_z m/s", Some(5)),
            ];
            /// Error-state INS: state `[p, v, q_wxyz, b_a, b_g]` (16), covariance 15×15
            /// over `[δp, δv, δθ, δb_a, δb_g]`.
            Ins = 2, "ins", ins, InsModel, InsParams, 15, [
                ("p_x m", Some(0)), ("p_y m", Some(1)), ("p_z m", Some(2)),
                ("v_x m/s", Some(3)), ("v_y m/s", Some(4)), ("v_z m/s", Some(5)),
                ("q_w", None), ("q_x", None), ("q_y", None), ("q_z", None),
                ("b_ax m/s2", Some(9)), ("b_ay m/s2", Some(10)), ("b_az m/s2", Some(11)),
                ("b_gx rad/s", Some(12)), ("b_gy rad/s", Some(13)), ("b_gz rad/s", Some(14)),
            ];
        }
    };
}

/// Model codes of [`StateSnapshot::model`], as constants (for C: `FUSION_MODEL_*`;
/// `client/tests/c_header.rs` checks them against [`for_each_model!`](crate::for_each_model)).
pub mod model {
    /// The `linear` constant-velocity model (6 states).
    pub const LINEAR: u32 = 1;
    /// The error-state INS model (16 states, 15×15 covariance).
    pub const INS: u32 = 2;

    /// The name of a model code ("unknown" for none).
    pub const fn name(code: u32) -> &'static str {
        match super::Model::from_code(code) {
            Some(m) => m.name(),
            None => "unknown",
        }
    }
}

/// The smallest velocity time offset estimate worth acting on, ms: below, the
/// estimate's own systematic error (±11 ms on simulated drives with the offset
/// right).
pub const MIN_TIME_OFFSET_MS: f64 = 15.0;
/// The fewest velocity samples a time offset estimate is acted on from.
pub const MIN_TIME_OFFSET_SAMPLES: u64 = 20;

/// The offset to add to a sensor's `time_offset_ns`, ms, from an estimate of
/// `offset_ns` ± `std_ns` over `samples`: when it is clearly not 0 (beyond 3σ
/// and [`MIN_TIME_OFFSET_MS`], from at least [`MIN_TIME_OFFSET_SAMPLES`]).
pub fn time_offset_to_add_ms(offset_ns: f64, std_ns: f64, samples: u64) -> Option<f64> {
    let (ms, sd_ms) = (offset_ns * 1e-6, std_ns * 1e-6);
    (samples >= MIN_TIME_OFFSET_SAMPLES && ms.abs() > (3.0 * sd_ms).max(MIN_TIME_OFFSET_MS)).then_some(ms)
}

pub mod aux;
pub mod health;

/// Outcome codes of [`StateSnapshot::outcome`].
pub mod outcome {
    /// IMU sample: propagated and held; or a measurement that set a reference
    /// state (a barometer's bias, a pose sensor's map frame) and fused nothing.
    pub const PROPAGATED: u32 = 0;
    /// Measurement fused.
    pub const FUSED: u32 = 1;
    /// Measurement refused by the gate.
    pub const GATED: u32 = 2;
    /// Measurement refused by the model: one it cannot use (a GNSS fix type its
    /// quality refuses, odometry before the attitude is known, a disturbed
    /// magnetometer sample) or an innovation covariance not positive definite.
    pub const REFUSED: u32 = 3;
}

/// What became of the samples of one sensor (or of several, added up): the one
/// counters type of the engine, the snapshot and the replay summary.
/// `fused`, `gated` and `refused` describe the current estimates: a rewind that
/// changes a decision moves the count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize, schemars::JsonSchema))]
#[type_name("fusion.Counters.v3")]
#[repr(C)]
pub struct Counters {
    /// Samples that arrived.
    pub received: u64,
    /// Samples processed (in order or late).
    pub processed: u64,
    /// Measurements fused.
    pub fused: u64,
    /// Measurements refused by the gate.
    pub gated: u64,
    /// Measurements the model refused (see [`outcome::REFUSED`]).
    pub refused: u64,
    /// Samples processed late, by rewind and replay.
    pub late: u64,
    /// Samples dropped as older than the history.
    pub too_late: u64,
    /// Duplicates dropped.
    pub duplicate: u64,
    /// Samples rejected by validation.
    pub invalid: u64,
    /// Samples that never arrived: gaps in the sequence numbers (a subscriber
    /// buffer overflow, or the sensor skipped them). A gap filled later is taken back.
    pub lost: u64,
    /// Samples dropped because the sensor sent faster than `validation.max_rate_hz`
    /// (measured on the sample timestamps).
    pub rate_limited: u64,
    /// Times the sensor's sequence started again (a restarted driver): a sequence
    /// number at or below one seen, on a sample newer than any seen.
    pub restarts: u64,
}

impl Counters {
    /// The counters as an array, in field order (for element-wise arithmetic).
    const fn to_array(self) -> [u64; 12] {
        [
            self.received,
            self.processed,
            self.fused,
            self.gated,
            self.refused,
            self.late,
            self.too_late,
            self.duplicate,
            self.invalid,
            self.lost,
            self.rate_limited,
            self.restarts,
        ]
    }

    const fn from_array(a: [u64; 12]) -> Self {
        Self {
            received: a[0],
            processed: a[1],
            fused: a[2],
            gated: a[3],
            refused: a[4],
            late: a[5],
            too_late: a[6],
            duplicate: a[7],
            invalid: a[8],
            lost: a[9],
            rate_limited: a[10],
            restarts: a[11],
        }
    }

    /// Adds `other` counter by counter.
    pub fn add(&mut self, other: &Counters) {
        let (mut a, b) = (self.to_array(), other.to_array());
        a.iter_mut().zip(b).for_each(|(x, y)| *x = x.wrapping_add(y));
        *self = Self::from_array(a);
    }

    /// What happened since `before`, counter by counter. Counters that describe
    /// current estimates (fused, gated, refused) or take back (lost) may shrink
    /// through a rewind; their difference saturates at 0.
    pub fn since(&self, before: &Counters) -> Counters {
        let (mut a, b) = (self.to_array(), before.to_array());
        a.iter_mut().zip(b).for_each(|(x, y)| *x = x.saturating_sub(y));
        Self::from_array(a)
    }
}

/// Counters of one sensor, as in the engine.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("fusion.SensorCounters.v4")]
#[repr(C)]
pub struct SensorCounters {
    /// [`SampleKind`] code.
    pub kind: u32,
    /// Sensor id.
    pub sensor: u32,
    /// What became of its samples.
    pub counts: Counters,
    /// NIS of the measurement of this sensor processed last (NaN if none).
    pub last_nis: f64,
    /// Largest timestamp received, ns.
    pub last_t_ns: u64,
    /// When the daemon last received a sample of this sensor, ns of its clock.
    pub last_arrival_ns: u64,
    /// Bit `c`: samples of this sensor were refused in validation with
    /// [`rejection`] code `c` (their count is in `counts.invalid`, by reason
    /// in [`StateSnapshot::rejections`]).
    pub rejection_reasons: u32,
    /// The [`rejection`] code of its latest refused sample (0: none).
    pub last_rejection: u32,
}

impl SensorCounters {
    /// The kind, if the code is known.
    pub fn sample_kind(&self) -> Option<SampleKind> {
        SampleKind::from_code(self.kind)
    }

    /// The [`rejection`] codes this sensor's samples were refused with.
    pub fn rejection_codes(&self) -> impl Iterator<Item = u32> + use<> {
        let bits = self.rejection_reasons;
        (1..=rejection::COUNT as u32).filter(move |c| bits & (1 << c) != 0)
    }
}

/// The fusion state after one processed sample.
///
/// The state layout of each model (code in `model`):
///
/// | model | state `x` (nominal) | covariance (error state) |
/// |---|---|---|
/// | `linear` (1) | `[p (0..3), v (3..6)]` | 6×6 over `[p, v]` |
/// | `ins` (2) | `[p (0..3), v (3..6), q_wxyz (6..10), b_a (10..13), b_g (13..16)]` | 15×15 over `[δp, δv, δθ, δb_a, δb_g]` |
///
/// Units and frames: `p` m and `v` m/s in the world frame (ENU about the datum);
/// `q` rotates the body frame (forward-left-up) into the world frame; `b_a` (m/s²)
/// and `b_g` (rad/s) are the IMU's biases in the body frame. The attitude error
/// `δθ` is local, `q_true = q ⊗ Exp(δθ)`, in rad about the body axes (Solà 2017,
/// §5.3.3). Because the quaternion's 4 entries share 3 error states,
/// covariance row `i` lines up with state entry `i` only for `i < 6`.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("fusion.StateSnapshot.v12")]
#[repr(C)]
pub struct StateSnapshot {
    /// Sequence number of this snapshot (one per processed sample or IMU instant,
    /// from 0 per daemon run).
    pub seq: u64,
    /// When the daemon published it, ns of CLOCK_MONOTONIC.
    pub publish_ns: u64,

    /// Time of validity of the estimate: the newest processed sample's time, ns.
    pub t_ns: u64,
    /// Sequence number of the newest processed sample (the estimate is after it).
    pub sample_seq: u64,
    /// Its sensor id.
    pub sample_sensor: u32,
    /// Its kind ([`SampleKind`] code).
    pub sample_kind: u32,
    /// What processing it did ([`outcome`]).
    pub outcome: u32,
    /// [`model`] code.
    pub model: u32,
    /// NIS of the newest sample if it was a measurement, else NaN.
    pub nis: f64,

    /// The input sample that triggered this snapshot: its timestamp, ns. Equals
    /// `t_ns` when it arrived in order; older when it was fused late by rewind.
    /// With several IMUs averaged, an IMU instant's snapshot names the
    /// instant's last sample; its earlier ones have no snapshot of their own.
    pub input_t_ns: u64,
    /// When the input's publisher sent it, ns (0 if unknown).
    pub input_sent_ns: u64,
    /// When the daemon received the input, ns.
    pub input_received_ns: u64,
    /// Input sequence number.
    pub input_seq: u64,
    /// Input sensor id.
    pub input_sensor: u32,
    /// Input kind ([`SampleKind`] code), or [`INPUT_NONE`].
    pub input_kind: u32,
    /// Later samples re-processed because the input came late (0: in order).
    pub input_replayed: u32,

    /// [`health`] state.
    pub health: u32,
    /// [`health`] reason bits.
    pub health_reasons: u32,
    /// Entries of `x` in use.
    pub state_len: u32,
    /// Side of the covariance in use.
    pub cov_dim: u32,
    /// Entries of `sensors` in use.
    pub sensor_count: u32,

    /// State vector (first `state_len` entries).
    pub x: [f64; MAX_STATE],
    /// Covariance, row-major `cov_dim × cov_dim` (first `cov_dim²` entries).
    pub cov: [f64; MAX_COV_LEN],
    /// Counters per sensor (first `sensor_count` entries).
    pub sensors: [SensorCounters; MAX_SENSORS],
    /// Rewinds since start.
    pub rewinds: u64,
    /// Samples re-processed by rewinds since start.
    pub replayed: u64,
    /// Samples counted against no sensor row: the sensor table was full, or the
    /// sample was invalid and came from a sensor not seen before (an invalid
    /// sample never takes a row).
    pub unknown_sensor: u64,

    /// The datum of the world frame (ENU about it): latitude, degrees (WGS-84).
    /// Valid when `datum_set` is 1 (see [`StateSnapshot::datum`]).
    pub datum_lat_deg: f64,
    /// The datum's longitude, degrees.
    pub datum_lon_deg: f64,
    /// The datum's height above the WGS-84 ellipsoid, m.
    pub datum_height_m: f64,
    /// 1 when the world frame has a datum (configured, or the first geodetic
    /// fix), 0 before.
    pub datum_set: u32,
    /// Bit `i`: `sensors[i]` is stale (no sample for longer than its kind's
    /// timeout): which of several IMUs, say, is gone.
    pub stale_sensors: u32,
    /// Bit `i`: `sensors[i]`'s NIS is persistently out of its χ² band (reason `nis out of bounds`).
    pub nis_sensors: u32,
    /// Zero.
    pub reserved: u32,
    /// Times the filter re-initialised itself after a lock-out: from the
    /// position fixes (every fix gated for `[gating] lockout_ns`), or reset
    /// from another kind's samples (every sample of it gated as long).
    pub reinitialisations: u64,
    /// State readers refused because every reader slot (`[ipc] max_readers`)
    /// was taken, as the refused readers reported it.
    pub readers_refused: u64,
    /// 0 when this estimate is final for every sample received (settled). More
    /// while a late sample's correction is being worked in: the estimate then
    /// lacks that sample's effect, and this many later samples are still to be
    /// re-processed (in the daemon's idle time, between samples) before a
    /// snapshot includes it. See [`StateSnapshot::settled`].
    pub pending_steps: u64,
    /// While `pending_steps > 0`: the time of validity of the oldest received
    /// sample whose effect is not yet in this estimate, ns; 0 when settled.
    pub pending_since_t_ns: u64,
    /// Samples re-processed for late samples in the daemon's idle time since it
    /// started (the rewinds' work kept off the latency path). `fusiond replay
    /// --compare` does the same work at the same points, to reproduce every
    /// snapshot, provisional ones included.
    pub background_steps: u64,
    /// Standstill updates (zero velocity and zero rate) fused since the start
    /// (`ins` with `[model.standstill]`; 0 otherwise).
    pub standstill_updates: u64,
    /// 1 while the vehicle is detected standing still (`[model.standstill]`: the
    /// attitude is held and standstill updates are fused), 0 otherwise.
    pub standing: u32,
    /// The auxiliary states in the estimate, after the model's own: bits of
    /// [`aux`] (see [`StateSnapshot::state_layout`]).
    pub aux_states: u32,
    /// How late the velocity sensors' timestamps look beyond their configured
    /// `time_offset_ns`, estimated from their residuals while the vehicle
    /// accelerates (`ins`), ns; see [`StateSnapshot::velocity_time_offset`].
    pub velocity_offset_ns: f64,
    /// Its standard deviation, ns (0: no estimate yet).
    pub velocity_offset_std_ns: f64,
    /// Velocity samples it is estimated from.
    pub velocity_offset_samples: u64,
    /// Samples refused in validation since the start, by reason: entry `c`
    /// counts [`rejection`] code `c` (entry 0 is unused). Samples of every
    /// sensor, those without a row in `sensors` included. Snapshots are also
    /// published while every sample is refused (input kind [`INPUT_NONE`],
    /// at most 10 a second), so a reader sees why there is no estimate.
    pub rejections: [u64; MAX_REJECTIONS],
}

impl Default for StateSnapshot {
    fn default() -> Self {
        Self {
            seq: 0,
            publish_ns: 0,
            t_ns: 0,
            sample_seq: 0,
            sample_sensor: 0,
            sample_kind: 0,
            outcome: 0,
            model: 0,
            nis: f64::NAN,
            input_t_ns: 0,
            input_sent_ns: 0,
            input_received_ns: 0,
            input_seq: 0,
            input_sensor: 0,
            input_kind: INPUT_NONE,
            input_replayed: 0,
            health: health::INITIALISING,
            health_reasons: 0,
            state_len: 0,
            cov_dim: 0,
            sensor_count: 0,
            x: [0.0; MAX_STATE],
            cov: [0.0; MAX_COV_LEN],
            sensors: [SensorCounters::default(); MAX_SENSORS],
            rewinds: 0,
            replayed: 0,
            unknown_sensor: 0,
            datum_lat_deg: 0.0,
            datum_lon_deg: 0.0,
            datum_height_m: 0.0,
            datum_set: 0,
            stale_sensors: 0,
            nis_sensors: 0,
            reserved: 0,
            reinitialisations: 0,
            readers_refused: 0,
            pending_steps: 0,
            pending_since_t_ns: 0,
            background_steps: 0,
            standstill_updates: 0,
            standing: 0,
            aux_states: 0,
            velocity_offset_ns: 0.0,
            velocity_offset_std_ns: 0.0,
            velocity_offset_samples: 0,
            rejections: [0; MAX_REJECTIONS],
        }
    }
}

impl StateSnapshot {
    /// How late the velocity sensors' stamps look beyond the configured
    /// `time_offset_ns`, and its standard deviation, ns, with the samples it
    /// is from; `None` before an estimate. Add it to the offset when it is
    /// clearly not 0 (a few σ).
    pub fn velocity_time_offset(&self) -> Option<(f64, f64, u64)> {
        (self.velocity_offset_std_ns > 0.0).then_some((
            self.velocity_offset_ns,
            self.velocity_offset_std_ns,
            self.velocity_offset_samples,
        ))
    }

    /// The velocity time offset to add to `time_offset_ns`, ms, when the
    /// estimate says one clearly ([`time_offset_to_add_ms`]).
    pub fn velocity_time_offset_to_add_ms(&self) -> Option<f64> {
        let (ns, sd, n) = self.velocity_time_offset()?;
        time_offset_to_add_ms(ns, sd, n)
    }

    /// Whether the vehicle was detected standing still at this estimate's time
    /// (the field `standing`).
    pub const fn standing(&self) -> bool {
        self.standing != 0
    }

    /// The sensors that are stale ([`StateSnapshot::stale_sensors`]).
    pub fn stale_sensor_counters(&self) -> impl Iterator<Item = &SensorCounters> {
        self.sensors_of(self.stale_sensors)
    }

    /// The sensors whose NIS is persistently out of band ([`StateSnapshot::nis_sensors`]).
    pub fn nis_sensor_counters(&self) -> impl Iterator<Item = &SensorCounters> {
        self.sensors_of(self.nis_sensors)
    }

    /// The sensor rows whose bits are set in `bits`.
    fn sensors_of(&self, bits: u32) -> impl Iterator<Item = &SensorCounters> + use<'_> {
        self.sensor_counters().iter().enumerate().filter(move |(i, _)| *i < 32 && bits & (1 << i) != 0).map(|(_, c)| c)
    }

    /// The state vector in use.
    pub fn state(&self) -> &[f64] {
        &self.x[..(self.state_len as usize).min(MAX_STATE)]
    }

    /// The covariance in use, row-major.
    pub fn covariance(&self) -> &[f64] {
        let n = (self.cov_dim as usize).min(MAX_COV);
        &self.cov[..n * n]
    }

    /// Standard deviations (square roots of the covariance diagonal).
    pub fn std_devs(&self) -> impl Iterator<Item = f64> + '_ {
        let n = (self.cov_dim as usize).min(MAX_COV);
        (0..n).map(move |i| self.cov[i * n + i].max(0.0).sqrt())
    }

    /// The sensor counters in use.
    pub fn sensor_counters(&self) -> &[SensorCounters] {
        &self.sensors[..(self.sensor_count as usize).min(MAX_SENSORS)]
    }

    /// Whether the newest sample was a fused (`Some(true)`) or refused
    /// (`Some(false)`) measurement; `None` for an IMU sample.
    pub fn accepted(&self) -> Option<bool> {
        match self.outcome {
            outcome::PROPAGATED => None,
            outcome::FUSED => Some(true),
            _ => Some(false),
        }
    }

    /// The datum of the world frame, if it has one.
    pub fn datum(&self) -> Option<Datum> {
        (self.datum_set == 1).then_some(Datum {
            latitude_deg: self.datum_lat_deg,
            longitude_deg: self.datum_lon_deg,
            height_m: self.datum_height_m,
        })
    }

    /// The estimated position (`x[0..3]`, m ENU, in every model) as WGS-84
    /// latitude and longitude (degrees) and height above the ellipsoid (m), when
    /// the world frame has a datum.
    pub fn position_geodetic(&self) -> Option<(f64, f64, f64)> {
        let p = self.state().get(..3)?;
        Some(self.datum()?.to_geodetic([p[0], p[1], p[2]]))
    }

    /// Whether this estimate includes every sample fusiond had received when it
    /// published it: no late sample's correction is pending. A snapshot that is
    /// not settled is provisional: it lacks the effect of the sample at
    /// [`pending_since_t_ns`](Self::pending_since_t_ns), which a later snapshot
    /// includes (within the daemon's next idle moments; a snapshot with input
    /// kind [`INPUT_NONE`] is published when it lands).
    pub fn settled(&self) -> bool {
        self.pending_steps == 0
    }

    /// Samples refused in validation since the start: each reason's
    /// [`rejection`] code with its count, for the reasons with a count.
    pub fn rejection_counts(&self) -> impl Iterator<Item = (u32, u64)> + '_ {
        rejection::ALL.iter().map(|(c, _)| (*c, self.rejections[*c as usize])).filter(|(_, n)| *n > 0)
    }

    /// Samples refused in validation since the start, every reason.
    pub fn rejected(&self) -> u64 {
        self.rejections.iter().fold(0u64, |a, n| a.wrapping_add(*n))
    }

    /// The names of the health reason bits that are set.
    pub fn health_reason_names(&self) -> impl Iterator<Item = &'static str> + use<> {
        health::reason_names(self.health_reasons)
    }
}

const _: () = {
    assert!(core::mem::size_of::<Counters>() == 96);
    assert!(core::mem::size_of::<SensorCounters>() == 136);
    assert!(core::mem::align_of::<StateSnapshot>() == 8);
    assert!(
        core::mem::size_of::<StateSnapshot>()
            == 120
                + 8 * (MAX_STATE + MAX_COV * MAX_COV)
                + 136 * MAX_SENSORS
                + 24
                + 40
                + 16
                + 24
                + 16
                + 24
                + 8 * MAX_REJECTIONS
    );
};

crate::wire_layout!(Counters, "What became of a sensor's samples.", {
    received, processed, fused, gated, refused, late, too_late, duplicate, invalid, lost, rate_limited, restarts
});

crate::wire_layout!(SensorCounters, "One sensor's row of the snapshot.", {
    kind, sensor, counts, last_nis, last_t_ns, last_arrival_ns, rejection_reasons, last_rejection
});

crate::wire_layout!(StateSnapshot, "The fusion state after one processed sample.", {
    seq, publish_ns, t_ns, sample_seq, sample_sensor, sample_kind, outcome, model, nis, input_t_ns, input_sent_ns,
    input_received_ns, input_seq, input_sensor, input_kind, input_replayed, health, health_reasons, state_len, cov_dim,
    sensor_count, x, cov, sensors, rewinds, replayed, unknown_sensor, datum_lat_deg, datum_lon_deg, datum_height_m,
    datum_set, stale_sensors, nis_sensors, reserved, reinitialisations, readers_refused, pending_steps,
    pending_since_t_ns, background_steps, standstill_updates, standing, aux_states, velocity_offset_ns,
    velocity_offset_std_ns, velocity_offset_samples, rejections
});
