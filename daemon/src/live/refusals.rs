//! One warning per sensor and reason when samples are refused in validation,
//! and one per sensor whose samples the model refuses for good as configured
//! (a kind it does not use, a sensor without the entry its kind needs): the
//! first refusal is logged with what to change; the rest are counted
//! (snapshot, summary line, `fusionctl state`), never logged per sample.
//!
//! Bounded: the pairs already warned about are kept for [`TRACKED`] sensors
//! (those with a row and those without, as a flood of garbage ids has none);
//! beyond that, one warning per reason for all the others.

use fusion_shared::snapshot::rejection;
use fusion_shared::{Sample, SampleKind};

use crate::measurement::{self, Steps};
use crate::reorder::key_of;
use crate::validate::Rejection;

/// Sensors whose warned reasons are remembered one by one.
pub const TRACKED: usize = 32;

/// The (kind, sensor) pairs warned about, with the reason bits of each.
#[derive(Debug, Clone)]
pub struct RefusalWarnings {
    sensors: [(u32, u32, u32); TRACKED],
    len: usize,
    /// Reason bits warned about for the sensors beyond [`TRACKED`].
    others: u32,
}

impl Default for RefusalWarnings {
    fn default() -> Self {
        Self { sensors: [(0, 0, 0); TRACKED], len: 0, others: 0 }
    }
}

impl RefusalWarnings {
    /// Whether `sample`, refused for `why`, is the first of its sensor and
    /// reason (then it is remembered as warned about).
    pub fn first(&mut self, sample: &Sample, why: Rejection) -> bool {
        let key = key_of(sample);
        let (kind, sensor, bit) = (key.kind as u32, key.sensor, 1u32 << why.code());
        let bits = match self.sensors[..self.len].iter_mut().find(|(k, s, _)| *k == kind && *s == sensor) {
            Some((_, _, bits)) => bits,
            None if self.len < TRACKED => {
                self.sensors[self.len] = (kind, sensor, 0);
                self.len += 1;
                &mut self.sensors[self.len - 1].2
            }
            None => &mut self.others,
        };
        let first = *bits & bit == 0;
        *bits |= bit;
        first
    }

    /// Logs the first refusal of `sample`'s sensor for `why` (a rare event:
    /// once per sensor and reason), with the sample's time and the clock's.
    pub fn warn(&mut self, sample: &Sample, why: Rejection, now_ns: u64) {
        if !self.first(sample, why) {
            return;
        }
        let key = key_of(sample);
        tracing::warn!(
            kind = key.kind.name(),
            sensor = key.sensor,
            reason = why.reason(),
            sample_t_s = key.t_ns as f64 * 1e-9,
            clock_s = now_ns as f64 * 1e-9,
            "refusing samples of {} {}: {} ({}); further refusals of this sensor for this reason are counted \
             (`fusionctl state`, the summary line), not logged",
            key.kind.name(),
            key.sensor,
            why.reason(),
            rejection::advice(why.code()),
        );
    }
}

/// Why the model refuses every sample of a sensor, as configured: a refusal
/// that lasts, unlike one while the attitude is unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigRefusal {
    /// The model does not use this kind at all.
    NotUsed,
    /// The sensor has no `[[sensor]]` entry, and its kind needs one: what for,
    /// as the kind says ([`measurement::needs_entry`]: a barometer's bias
    /// state, a pose sensor's map frame, a magnetometer's Earth field).
    NoEntry(&'static str),
}

impl ConfigRefusal {
    /// Why `model` refuses `sample` for good, if it does (no allocation).
    pub fn of<M: Steps>(model: &M, sample: &Sample) -> Option<Self> {
        let (kind, sensor) = (sample.kind(), sample.sensor());
        if !M::accepts(kind) {
            return Some(Self::NotUsed);
        }
        let needs = measurement::needs_entry(kind)?;
        let configured = model.frames().sensors().iter().any(|m| m.kind == kind && m.id == sensor);
        (!configured).then_some(Self::NoEntry(needs))
    }

    /// The reason and what to set, for `kind` `sensor` under model `model`.
    pub fn advice(self, model: &str, kind: SampleKind, sensor: u32) -> String {
        let entry = format!("[[sensor]] kinds = [\"{}\"], id = {sensor}", kind.name());
        match self {
            Self::NotUsed => format!(
                "the {model} model does not use {} samples (see docs/sensor-kinds.md for the models that do)",
                kind.name()
            ),
            Self::NoEntry(why) => format!("no {} sensor {sensor} is configured ({why}): add `{entry}`", kind.name()),
        }
    }
}

/// One warning per sensor whose samples the model refuses for good
/// ([`ConfigRefusal`]); bounded like [`RefusalWarnings`].
#[derive(Debug, Clone)]
pub struct ModelRefusalWarnings {
    sensors: [(u32, u32); TRACKED],
    len: usize,
}

impl Default for ModelRefusalWarnings {
    fn default() -> Self {
        Self { sensors: [(0, 0); TRACKED], len: 0 }
    }
}

impl ModelRefusalWarnings {
    /// Called with a sample `model` refused: logs the first lasting refusal of
    /// its sensor with the reason and the key to set.
    pub fn warn<M: Steps>(&mut self, model: &M, sample: &Sample) {
        let pair = (sample.kind() as u32, sample.sensor());
        if self.sensors[..self.len].contains(&pair) {
            return;
        }
        let Some(why) = ConfigRefusal::of(model, sample) else { return };
        if self.len < TRACKED {
            self.sensors[self.len] = pair;
            self.len += 1;
        } else {
            return;
        }
        let (kind, sensor) = (sample.kind(), sample.sensor());
        tracing::warn!(
            kind = kind.name(),
            sensor,
            "refusing every sample of {} {sensor}: {}; the refusals are counted (`fusionctl state`, the summary line)",
            kind.name(),
            why.advice(fusion_shared::snapshot::model::name(M::CODE), kind, sensor),
        );
    }
}

#[cfg(test)]
mod tests {
    use fusion_shared::{ImuSample, PositionSample};

    use super::*;

    fn imu(sensor: u32) -> Sample {
        Sample::Imu(ImuSample::new(1, sensor, 0, [0.0; 3], [0.0; 3]))
    }

    #[test]
    fn each_sensor_and_reason_is_first_once() {
        let mut w = RefusalWarnings::default();
        assert!(w.first(&imu(0), Rejection::PastTimestamp));
        assert!(!w.first(&imu(0), Rejection::PastTimestamp));
        assert!(w.first(&imu(0), Rejection::NonFinite));
        assert!(w.first(&imu(1), Rejection::PastTimestamp));
        let fix = Sample::Position(PositionSample::new(1, 0, 0, [0.0; 3], [0.0; 9]));
        assert!(w.first(&fix, Rejection::PastTimestamp), "another kind with the same id");
        // A flood of ids: beyond TRACKED, one per reason for all of them.
        for id in 2..TRACKED as u32 + 10 {
            w.first(&imu(id), Rejection::WrongKind);
        }
        assert!(!w.first(&imu(1000), Rejection::WrongKind));
        assert!(w.first(&imu(1001), Rejection::OutOfRange));
        assert!(!w.first(&imu(1002), Rejection::OutOfRange));
    }
}
