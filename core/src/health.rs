//! Health of the live estimate: initialising, ok, or degraded with reasons.
//!
//! - A stream is stale when no sample of a sensor of that kind has arrived for
//!   longer than its kind's timeout (daemon clock). The health is "initialising"
//!   until a sample of each group the measurement modules name was processed
//!   ([`measurement::Needed`]: the IMU, and a position or geodetic fix, the
//!   latter only for a model that needs one: [`HealthMonitor::without_position`]).
//! - The NIS of the last `N` measurements of a sensor is persistently out of
//!   bounds when the sum over the `k` fused ones leaves the two-sided χ²_{mk}
//!   band at the configured probability, `m` the kind's innovation dimension (the
//!   sum of `k` independent χ²ₘ variables is χ²_{mk}: Bar-Shalom et al. 2001,
//!   §5.4.2, the time-average NIS test), or
//!   when more than half of them were gated (the filter locked itself out). Too
//!   large means filter and sensor disagree, too small that the filter is far too
//!   pessimistic; of a kind whose samples are another filter's estimate (an
//!   AHRS's attitude, [`measurement::Measurement::FILTERED`]) only too large
//!   counts: its errors are correlated over seconds, and the sample-to-sample
//!   scatter the innovations see is far below the absolute error it declares
//!   (robot_localization's test1 bag: a mean NIS of 0.22 for 3 degrees of
//!   freedom). A gated outlier now and then is the gate doing its job and
//!   leaves the sum alone. "Persistently": the window is out of its band for
//!   a window's worth of that sensor's measurements in a row ([`PERSISTENCE`]),
//!   so that a stretch of large but normal values (the χ² tail, an outlier just
//!   inside the gate) evaluated in window after overlapping window does not
//!   flag a consistent filter. A measurement the model refuses before it can use
//!   it (odometry before the attitude is known) is no evidence either way and
//!   does not enter the window.
//! - Samples are lost when a sensor's sequence numbers had a gap recently.
//! - The filter re-initialised itself from the fixes recently, after a lock-out
//!   ([`crate::model::lockout`]).
//!
//! Pure and allocation-free after construction; the daemon evaluates it on every
//! snapshot and on a timer while nothing arrives.

use fusion_shared::SampleKind;
use fusion_shared::snapshot::{MAX_SENSORS, health};
use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::measurement::{self, MAX_INNOVATION_DIM};
use crate::model::StepOutcome;
use crate::sensor_table::SensorRow;
use crate::setting::{ConfigError, invalid};

/// Number of sample kinds.
const KINDS: usize = SampleKind::COUNT;
const _: () = assert!(KINDS <= 32, "the kinds of a group are bits of a u32");

/// Longest NIS window.
pub const MAX_NIS_WINDOW: usize = 256;

/// How long a loss keeps the `samples lost` reason set, ns.
pub const LOSS_HOLD_NS: u64 = 5_000_000_000;

/// How long a re-initialisation keeps the `re-initialised after a lock-out` reason set, ns.
pub const REINITIALISED_HOLD_NS: u64 = 10_000_000_000;

/// Health settings (the `[health]` config table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HealthConfig {
    /// Per kind (index [`SampleKind::index`]): a stream is stale after this long without a
    /// sample, ns (`<kind>_timeout_ns`).
    pub timeouts_ns: [u64; KINDS],
    /// Measurements in the NIS window.
    pub nis_window: usize,
    /// Probability of the two-sided NIS band.
    pub nis_probability: f64,
}

impl HealthConfig {
    /// The stale timeout of `kind`, ns.
    pub fn timeout_ns(&self, kind: SampleKind) -> u64 {
        self.timeouts_ns[kind.index()]
    }
}

impl Default for HealthConfig {
    /// Each kind's own timeout ([`measurement::Measurement::TIMEOUT_NS`]), a window
    /// of 20 and a band of 0.999.
    fn default() -> Self {
        let mut timeouts_ns = [0; KINDS];
        for &k in SampleKind::ALL {
            timeouts_ns[k.index()] = measurement::default_timeout_ns(k);
        }
        Self { timeouts_ns, nis_window: 20, nis_probability: 0.999 }
    }
}

/// The `[health]` table as written: the timeouts are keyed by kind name
/// (`<kind>_timeout_ns`), so they are checked by [`HealthConfig::from_table`].
#[derive(Debug, Default, serde::Deserialize)]
pub struct HealthTable {
    nis_window: Option<usize>,
    nis_probability: Option<f64>,
    #[serde(flatten)]
    timeouts: std::collections::BTreeMap<String, u64>,
}

impl HealthConfig {
    /// The settings of a `[health]` table: each kind's timeout by its name (an
    /// unknown name is an error that lists the known ones), the NIS window and
    /// band; what the table leaves out keeps its default.
    pub fn from_table(table: HealthTable) -> Result<Self, ConfigError> {
        let mut health = HealthConfig::default();
        for (key, value) in table.timeouts {
            let kind = key.strip_suffix("_timeout_ns").and_then(SampleKind::from_name).ok_or_else(|| {
                let known: Vec<String> = SampleKind::ALL.iter().map(|k| format!("{}_timeout_ns", k.name())).collect();
                invalid(
                    format!("health.{key}"),
                    format!("unknown key; known: nis_window, nis_probability, {}", known.join(", ")),
                )
            })?;
            if value == 0 {
                return Err(invalid(format!("health.{key}"), "must be > 0"));
            }
            health.timeouts_ns[kind.index()] = value;
        }
        health.nis_window = table.nis_window.unwrap_or(health.nis_window);
        health.nis_probability = table.nis_probability.unwrap_or(health.nis_probability);
        if !(1..=MAX_NIS_WINDOW).contains(&health.nis_window) {
            return Err(invalid(
                "health.nis_window",
                format!("must be in 1..={MAX_NIS_WINDOW}, got {}", health.nis_window),
            ));
        }
        if !(health.nis_probability > 0.0 && health.nis_probability < 1.0) {
            return Err(invalid(
                "health.nis_probability",
                format!("must be in (0, 1), got {}", health.nis_probability),
            ));
        }
        Ok(health)
    }
}

/// The health at one evaluation: what a snapshot carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HealthNow {
    /// [`health::INITIALISING`], [`health::OK`] or [`health::DEGRADED`].
    pub state: u32,
    /// Reason bits ([`health`]).
    pub reasons: u32,
    /// Bit `i`: sensor `i` of the engine's sensor table (and of the snapshot's
    /// `sensors`) is stale, so a user sees which of several IMUs is gone.
    pub stale_sensors: u32,
    /// Bit `i`: sensor `i`'s NIS is persistently out of its band (which
    /// sensor the reason `nis out of bounds` is about).
    pub nis_sensors: u32,
}

impl HealthNow {
    /// Before anything was evaluated.
    pub const INITIALISING: HealthNow =
        HealthNow { state: health::INITIALISING, reasons: 0, stale_sensors: 0, nis_sensors: 0 };

    /// State and reasons.
    pub fn pair(&self) -> (u32, u32) {
        (self.state, self.reasons)
    }
}

/// A sensor's NIS window as the evaluation reads it: the count and sum of the
/// fused values, summed when a value comes in (not on every evaluation), and
/// the evaluation's own state. One cache line per sensor: a snapshot's health
/// evaluation reads these and nothing else of the window
/// ([`HealthMonitor::evaluate`]); the values themselves are kept apart
/// (the monitor's `values`) and read only when one comes in.
#[derive(Debug, Clone, Copy, Default)]
#[repr(align(64))]
struct NisWindow {
    next: usize,
    len: usize,
    fused: usize,
    sum: f64,
    /// Measurements recorded, and as of the last evaluation.
    records: u64,
    evaluated: u64,
    /// Measurements in a row after which the full window was out of its band.
    streak: u64,
    /// Whether the last evaluation found the window persistently out of its
    /// band. It stands until a measurement comes in: the streak moves only then.
    persistent: bool,
}

const _: () = assert!(std::mem::size_of::<NisWindow>() == 64, "a window's scalars fill one cache line");

/// How long a sensor's NIS window must stay out of its band before the health
/// says so, in windows' worth of that sensor's measurements in a row: one
/// (a real inconsistency is flagged after two windows, 2 s of 10 Hz fixes with
/// the default window of 20).
pub const PERSISTENCE: (usize, usize) = (1, 1);

/// Tracks what the health needs beyond the engine's counters.
#[derive(Debug, Clone)]
pub struct HealthMonitor {
    config: HealthConfig,
    /// `bands[m][k]`: χ²_{mk} band for the NIS sum of `k` fused measurements of
    /// innovation dimension `m`.
    bands: Box<[[(f64, f64); MAX_NIS_WINDOW + 1]; MAX_INNOVATION_DIM + 1]>,
    windows: [NisWindow; MAX_SENSORS],
    /// Per sensor: the window's NIS values, a ring of `nis_window` (`None`
    /// for a gated measurement).
    values: Box<[[Option<f64>; MAX_NIS_WINDOW]; MAX_SENSORS]>,
    /// The groups of kinds the health waits for ([`measurement::Needed`]), each
    /// once, in `needed_groups[..needed_len]`: bit `k.index()` for each kind `k`
    /// of the group. Read for every snapshot: a few masks, not one per kind.
    needed_groups: [u32; KINDS],
    needed_len: usize,
    lost_seen: [u64; MAX_SENSORS],
    last_loss_ns: Option<u64>,
    reinitialisations_seen: u64,
    last_reinitialisation_ns: Option<u64>,
    /// Sensors whose measurements have fewer dimensions than their kind's
    /// ([`SampleKind::innovation_dim`]): an AHRS fused for roll and pitch only.
    fewer_dims: [Option<(SampleKind, u32, usize)>; MAX_SENSORS],
}

impl HealthMonitor {
    /// A monitor with `config` (window clamped to 1..=[`MAX_NIS_WINDOW`]).
    pub fn new(mut config: HealthConfig) -> Self {
        config.nis_window = config.nis_window.clamp(1, MAX_NIS_WINDOW);
        let tail = (1.0 - config.nis_probability) / 2.0;
        let mut bands = Box::new([[(0.0, f64::INFINITY); MAX_NIS_WINDOW + 1]; MAX_INNOVATION_DIM + 1]);
        for (m, bands) in bands.iter_mut().enumerate().skip(1) {
            for (k, band) in bands.iter_mut().enumerate().take(config.nis_window + 1).skip(1) {
                if let Ok(chi2) = ChiSquared::new((m * k) as f64) {
                    *band = (chi2.inverse_cdf(tail), chi2.inverse_cdf(1.0 - tail));
                }
            }
        }
        let mut needed_groups = [0; KINDS];
        let mut needed_len = 0;
        for &k in SampleKind::ALL {
            if let Some(group) = measurement::needed(k) {
                let mask = Self::group_mask(group);
                if !needed_groups[..needed_len].contains(&mask) {
                    needed_groups[needed_len] = mask;
                    needed_len += 1;
                }
            }
        }
        Self {
            config,
            bands,
            windows: [NisWindow::default(); MAX_SENSORS],
            values: Box::new([[None; MAX_NIS_WINDOW]; MAX_SENSORS]),
            needed_groups,
            needed_len,
            lost_seen: [0; MAX_SENSORS],
            last_loss_ns: None,
            reinitialisations_seen: 0,
            last_reinitialisation_ns: None,
            fewer_dims: [None; MAX_SENSORS],
        }
    }

    /// The same monitor with the innovation dimensions of the configured
    /// sensors of `frames` that fuse fewer than their kind's (an attitude
    /// sensor with `[sensor.attitude] yaw = false`: 2; a twist or pose sensor
    /// with `fuse = [...]`: as many as it names): their NIS is judged against
    /// χ² of that many degrees of freedom.
    pub fn with_frames(mut self, frames: &crate::frames::Frames) -> Self {
        let fewer = frames.sensors().iter().filter_map(|m| {
            let dims = crate::measurement::fused_dim(m);
            (dims < m.kind.innovation_dim()).then_some((m.kind, m.id, dims))
        });
        for (slot, f) in self.fewer_dims.iter_mut().zip(fewer) {
            *slot = Some(f);
        }
        self
    }

    /// The innovation dimension of sensor `sensor` of `kind`.
    fn innovation_dim(&self, kind: SampleKind, sensor: u32) -> usize {
        if self.fewer_dims[0].is_none() {
            return kind.innovation_dim();
        }
        let own = self.fewer_dims.iter().flatten().find(|(k, id, _)| *k == kind && *id == sensor);
        own.map_or(kind.innovation_dim(), |(_, _, m)| *m)
    }

    /// The monitor for a model that dead-reckons ([`crate::model::Model::NEEDS_POSITION`]
    /// false): no absolute position is waited for; `initialising` lasts until
    /// the model is ready and the IMU was processed.
    pub fn without_position(mut self) -> Self {
        let position = Self::group_mask(measurement::Needed::Position);
        let (groups, mut kept) = (self.needed_groups, 0);
        for &mask in groups[..self.needed_len].iter().filter(|&&mask| mask != position) {
            self.needed_groups[kept] = mask;
            kept += 1;
        }
        self.needed_len = kept;
        self
    }

    /// The kinds of `group`: bit `k.index()` for each kind `k` in it.
    fn group_mask(group: measurement::Needed) -> u32 {
        let kinds = SampleKind::ALL.iter().filter(|&&k| measurement::needed(k) == Some(group));
        kinds.fold(0, |mask, k| mask | 1 << k.index())
    }

    /// The band for the NIS sum of `k` fused measurements of innovation dimension `m`.
    pub fn nis_band(&self, m: usize, k: usize) -> (f64, f64) {
        self.bands[m.min(MAX_INNOVATION_DIM)][k.min(MAX_NIS_WINDOW)]
    }

    /// Records the outcome of a processed measurement of sensor slot `slot`;
    /// `exact`: the sample is a reading without noise ([`measurement::exact`]).
    pub fn record(&mut self, slot: usize, outcome: &StepOutcome, exact: bool) {
        let value = match outcome {
            // An exact reading (wheels that stand) has an NIS far below its
            // χ² band by nature: its noise is not the configured one. It says
            // nothing of the filter's consistency (a stop would read as a fault).
            StepOutcome::Fused { .. } if exact => return,
            StepOutcome::Fused { nis } => Some(*nis),
            StepOutcome::Gated { .. } => None,
            // Not a test of the filter's consistency: the model could not use
            // the measurement yet (or its innovation covariance; counted as refused).
            StepOutcome::Refused | StepOutcome::Propagated => return,
        };
        let (Some(w), Some(values)) = (self.windows.get_mut(slot), self.values.get_mut(slot)) else { return };
        values[w.next] = value;
        w.next = (w.next + 1) % self.config.nis_window;
        w.len = (w.len + 1).min(self.config.nis_window);
        w.records += 1;
        let fused = values[..w.len].iter().flatten();
        (w.fused, w.sum) = fused.fold((0, 0.0), |(k, sum), v| (k + 1, sum + v));
    }

    /// Health state, reason bits and stale sensors at `now_ns` for the engine's
    /// sensors. `initialised` is the model's own readiness (e.g. alignment done),
    /// `reinitialisations` the model's count of re-initialisations
    /// ([`crate::model::Diagnostics::reinitialisations`]).
    pub fn evaluate(
        &mut self,
        sensors: &[SensorRow],
        now_ns: u64,
        initialised: bool,
        reinitialisations: u64,
    ) -> HealthNow {
        let mut reasons = 0;
        let mut stale_sensors = 0;
        let mut nis_sensors = 0;
        let mut seen = 0u32;
        for (i, s) in sensors.iter().enumerate().take(MAX_SENSORS) {
            if s.stats.processed > 0 {
                seen |= 1 << s.kind.index();
            }
            if s.last_arrival_ns.is_some_and(|t| now_ns.saturating_sub(t) > self.config.timeout_ns(s.kind)) {
                reasons |= health::stale(s.kind);
                stale_sensors |= 1 << i;
            }
            if s.stats.lost > self.lost_seen[i] {
                self.last_loss_ns = Some(now_ns);
            }
            self.lost_seen[i] = s.stats.lost;
            let window = self.config.nis_window;
            let w = &self.windows[i];
            // The measurements since the last evaluation count towards the
            // streak only once the window is full (each after it filled).
            // Without any, the streak and so the verdict stand.
            let new = w.records - w.evaluated;
            if new > 0 {
                let (lo, hi) = self.nis_band(self.innovation_dim(s.kind, s.sensor), w.fused);
                // Another filter's estimate: only a large NIS is evidence.
                let band = (if measurement::filtered(s.kind) { 0.0 } else { lo }, hi);
                let w = &mut self.windows[i];
                w.evaluated = w.records;
                w.persistent = Self::judge(w, new, window, band);
            }
            if self.windows[i].persistent {
                reasons |= health::NIS_OUT_OF_BOUNDS;
                nis_sensors |= 1 << i;
            }
        }
        if self.last_loss_ns.is_some_and(|t| now_ns.saturating_sub(t) < LOSS_HOLD_NS) {
            reasons |= health::SAMPLES_LOST;
        }
        if reinitialisations > self.reinitialisations_seen {
            self.last_reinitialisation_ns = Some(now_ns);
        }
        self.reinitialisations_seen = reinitialisations;
        if self.last_reinitialisation_ns.is_some_and(|t| now_ns.saturating_sub(t) < REINITIALISED_HOLD_NS) {
            reasons |= health::REINITIALISED;
        }
        // Each group that some kind belongs to needs a processed sample of one of its kinds.
        let waiting = self.needed_groups[..self.needed_len].iter().any(|&group| seen & group == 0);
        let state = if !initialised || waiting {
            health::INITIALISING
        } else if reasons != 0 {
            health::DEGRADED
        } else {
            health::OK
        };
        HealthNow { state, reasons, stale_sensors, nis_sensors }
    }

    /// Moves the streak of window `w` by the `new` measurements that came in
    /// since its last evaluation (`band`: the χ² band for its fused count) and
    /// returns whether it is now persistently out of its band.
    fn judge(w: &mut NisWindow, new: u64, window: usize, (lo, hi): (f64, f64)) -> bool {
        if w.len < window {
            w.streak = 0;
            return false;
        }
        let full_for = w.records.saturating_sub(window as u64 - 1);
        let out = 2 * w.fused < w.len || w.sum < lo || w.sum > hi;
        w.streak = if out { w.streak + new.min(full_for) } else { 0 };
        let persist = (window * PERSISTENCE.0).div_ceil(PERSISTENCE.1).max(1) as u64;
        w.streak >= persist
    }
}

#[cfg(test)]
mod tests;
