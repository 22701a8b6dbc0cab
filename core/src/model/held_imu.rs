//! The IMU values a model holds between samples (zero-order hold), combined over
//! several IMUs ([`crate::frames::ImuSet`]).
//!
//! `average` takes the mean of the samples of one instant (each rotated into the
//! body frame first), so an IMU that is stale, rejected as invalid or out of range
//! at an instant is simply not in that instant's mean; `failover` holds the
//! samples of one IMU and hands over to the next alive one when it goes quiet.
//! Both decide from sample timestamps only, so a replay decides as the live daemon
//! did.
//!
//! The mean of `n` IMUs with independent white noise of density σ has density
//! `σ/√n`: the `ins` model scales its white-noise process noise by `1/n` for an
//! interval held with an `n`-sample mean (the bias random walks are left as
//! configured: the mean's bias changes whenever the set of IMUs does).

use nalgebra::Vector3;

use crate::frames::{Combine, ImuSet, MAX_IMUS};

/// The IMU values a model holds between samples, combined over several IMUs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldImu {
    sum_f: Vector3<f64>,
    sum_w: Vector3<f64>,
    /// Samples in the sums (all of the instant `t_ns`); 0: nothing held yet.
    count: u32,
    t_ns: u64,
    /// Time from the instant before to the one held, ns (0: not yet known).
    interval_ns: u64,
    /// Failover: the index of the IMU in use.
    active: u8,
    /// Bit `i`: IMU `i` sent a sample; `last_t_ns[i]`: the time of its latest.
    seen: u8,
    /// Average: the IMUs in the sums, and those of the instant before.
    mask: u8,
    prev_mask: u8,
    last_t_ns: [u64; MAX_IMUS],
}

/// What [`HeldImu::hold`] did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Held {
    /// Held (alone, or into the mean of its instant).
    Held,
    /// Held, and the IMUs in use changed: the one before went quiet and this one
    /// took over (failover), or the set of IMUs in the mean of the last instant
    /// differs from the one before (average). Either way the biases now held
    /// are partly another IMU's.
    Switched,
    /// Not held: another IMU is in use (failover).
    Standby,
    /// Not held: an IMU id that is not configured.
    Unknown,
}

impl HeldImu {
    /// Nothing held yet.
    pub const EMPTY: HeldImu = HeldImu {
        sum_f: Vector3::new(0.0, 0.0, 0.0),
        sum_w: Vector3::new(0.0, 0.0, 0.0),
        count: 0,
        t_ns: 0,
        interval_ns: 0,
        active: 0,
        seen: 0,
        mask: 0,
        prev_mask: 0,
        last_t_ns: [0; MAX_IMUS],
    };

    /// The held specific force (or acceleration) and rate, the mean over the
    /// `n` samples of their instant, and `n`; `None` before the first sample.
    #[inline]
    pub fn mean(&self) -> Option<(Vector3<f64>, Vector3<f64>, u32)> {
        match self.count {
            0 => None,
            1 => Some((self.sum_f, self.sum_w, 1)),
            n => Some((self.sum_f / f64::from(n), self.sum_w / f64::from(n), n)),
        }
    }

    /// The time between the last two instants held, s: the IMU's sampling
    /// interval (`None` before the second).
    pub fn interval_s(&self) -> Option<f64> {
        (self.interval_ns > 0).then_some(self.interval_ns as f64 * 1e-9)
    }

    /// When the next instant is due at the interval of the last two, ns:
    /// where a model expects its next IMU sample (`None` before the second
    /// instant). The engine may propagate to it ahead of the sample
    /// (`Engine::step_ahead`).
    #[inline]
    pub fn next_ns(&self) -> Option<u64> {
        (self.count > 0 && self.interval_ns > 0).then(|| self.t_ns.saturating_add(self.interval_ns))
    }

    /// Average: whether the instant held still lacks a sample of an IMU that
    /// was in the mean of the instant before (`false` in failover, for one IMU,
    /// and before the second instant). The live loop holds back the snapshot
    /// of such an instant until the sample comes, another sample does, or a
    /// bounded wait ([`crate::frames::ImuConfig::instant_wait_ns`]) passes.
    #[inline]
    pub fn awaiting(&self) -> bool {
        self.count > 0 && self.prev_mask & !self.mask != 0
    }

    /// The configured index of the IMU in use (failover).
    pub fn active(&self) -> usize {
        usize::from(self.active)
    }

    /// Holds a sample of IMU `sensor` at `t_ns` (values in the body frame) as
    /// `set` combines them.
    pub fn hold(&mut self, set: &ImuSet, sensor: u32, t_ns: u64, f: Vector3<f64>, w: Vector3<f64>) -> Held {
        let Some(i) = set.index(sensor) else { return Held::Unknown };
        let after_ns = set.config.failover_after_ns;
        // Failover: the first sample, or one of a higher-priority IMU at the very
        // instant of the first, so the start does not depend on which process came
        // first.
        let starting = self.count == 0 || (self.seen.count_ones() == 1 && t_ns == self.t_ns && i < self.active());
        let outcome = match set.config.combine {
            Combine::Average => {
                if self.count > 0 && self.t_ns == t_ns {
                    self.sum_f += f;
                    self.sum_w += w;
                    self.count += 1;
                    self.mask |= 1 << i;
                    self.note(i, t_ns);
                    return Held::Held;
                }
                // A new instant: the one just finished is complete.
                let changed = self.prev_mask != 0 && self.mask != self.prev_mask;
                (self.prev_mask, self.mask) = (self.mask, 1 << i);
                if changed { Held::Switched } else { Held::Held }
            }
            Combine::Failover if i == self.active() => Held::Held,
            Combine::Failover if starting => {
                self.active = i as u8;
                Held::Held
            }
            Combine::Failover if !self.alive(self.active(), t_ns, after_ns) => {
                self.active = i as u8;
                Held::Switched
            }
            Combine::Failover => {
                self.note(i, t_ns);
                return Held::Standby;
            }
        };
        self.note(i, t_ns);
        if self.count > 0 && t_ns > self.t_ns {
            self.interval_ns = t_ns - self.t_ns;
        }
        (self.sum_f, self.sum_w, self.count, self.t_ns) = (f, w, 1, t_ns);
        outcome
    }

    /// IMU `k` sent a sample no longer than `after_ns` before `t_ns`.
    fn alive(&self, k: usize, t_ns: u64, after_ns: u64) -> bool {
        self.seen & (1 << k) != 0 && t_ns <= self.last_t_ns[k].saturating_add(after_ns)
    }

    fn note(&mut self, i: usize, t_ns: u64) {
        self.seen |= 1 << i;
        self.last_t_ns[i] = self.last_t_ns[i].max(t_ns);
    }
}

/// The IMU instants of any model that holds IMU samples ([`super::Model::held_imu`]):
/// the machinery of the live loop and the engine's idle steps, beside what a
/// model is (its state, its step, its snapshot).
pub trait Instants: super::Model {
    /// Whether the IMU instant `state` holds is still open: several IMUs are
    /// averaged ([`crate::frames::Combine::Average`]) and one that was in the
    /// instant before has not yet sent its sample of this one
    /// ([`HeldImu::awaiting`]). The live loop publishes one snapshot per IMU
    /// instant, after the sample that completes it.
    fn instant_open(state: &Self::State) -> bool;

    /// When the model expects its next input at `state`, ns: the next IMU
    /// instant at the interval of the last two ([`HeldImu::next_ns`]); `None`
    /// if it does not know. The engine propagates to it while idle
    /// (`Engine::step_ahead`), so that the sample's own step is only its fusion.
    fn next_input_ns(state: &Self::State) -> Option<u64>;
}

impl<M: super::Model> Instants for M {
    #[inline]
    fn instant_open(state: &M::State) -> bool {
        M::held_imu(state).is_some_and(HeldImu::awaiting)
    }

    #[inline]
    fn next_input_ns(state: &M::State) -> Option<u64> {
        M::held_imu(state)?.next_ns()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(combine: Combine) -> crate::frames::Frames {
        let imu = |name: &str, id| crate::frames::SensorConfig {
            name: name.into(),
            id,
            kinds: vec!["imu".into()],
            axes: crate::frames::Axes::Flu,
            rotation_rpy_deg: [0.0; 3],
            lever_arm_m: [0.0; 3],
            time_offset_ns: 0,
            topic: None,
            tables: toml::Table::new(),
        };
        let config = crate::frames::ImuConfig { combine, failover_after_ns: 20, ..Default::default() };
        crate::frames::Frames::from_config(None, &[imu("a", 4), imu("b", 9)], config, &crate::measurement::Kinds)
            .unwrap()
    }

    /// The samples of one instant are averaged; a new instant starts afresh; an
    /// IMU missing at an instant is simply not in its mean; an unknown id is not held.
    #[test]
    fn average_takes_the_mean_of_each_instant() {
        let frames = set(Combine::Average);
        let imus = frames.imus();
        let mut h = HeldImu::EMPTY;
        assert_eq!(h.mean(), None);
        let v = |x: f64| Vector3::new(x, 0.0, 0.0);
        assert_eq!(h.hold(imus, 4, 100, v(1.0), v(10.0)), Held::Held);
        assert_eq!(h.mean(), Some((v(1.0), v(10.0), 1)));
        assert!(!h.awaiting(), "the first instant: nothing known to await");
        assert_eq!(h.next_ns(), None, "no interval yet");
        assert_eq!(h.hold(imus, 9, 100, v(2.0), v(20.0)), Held::Held);
        assert_eq!(h.mean(), Some((v(1.5), v(15.0), 2)));
        assert!(!h.awaiting());
        assert_eq!(h.hold(imus, 9, 110, v(3.0), v(30.0)), Held::Held);
        assert_eq!(h.mean(), Some((v(3.0), v(30.0), 1)), "IMU 4 missing at 110");
        assert!(h.awaiting(), "IMU 4 was in the instant before");
        // Seen at the start of the next instant: 110 had another set than 100.
        assert_eq!(h.hold(imus, 9, 120, v(3.0), v(30.0)), Held::Switched);
        assert!(!h.awaiting(), "110 had IMU 9 alone");
        assert_eq!(h.hold(imus, 9, 130, v(3.0), v(30.0)), Held::Held);
        assert_eq!(h.hold(imus, 5, 130, v(9.0), v(9.0)), Held::Unknown);
        assert_eq!(h.mean(), Some((v(3.0), v(30.0), 1)));
        assert_eq!(h.next_ns(), Some(140), "the next instant, one interval on");
    }

    /// Failover: the first IMU heard is used, the other stands by; after
    /// `failover_after_ns` of silence of the one in use the other takes over and
    /// stays in use when the first comes back.
    #[test]
    fn failover_hands_over_when_the_imu_in_use_goes_quiet() {
        let frames = set(Combine::Failover);
        let imus = frames.imus();
        let mut h = HeldImu::EMPTY;
        let v = |x: f64| Vector3::new(x, 0.0, 0.0);
        assert_eq!(h.hold(imus, 4, 100, v(1.0), v(1.0)), Held::Held);
        assert_eq!(h.hold(imus, 9, 105, v(2.0), v(2.0)), Held::Standby);
        assert_eq!(h.hold(imus, 9, 120, v(2.0), v(2.0)), Held::Standby, "20 ns of silence is not yet dead");
        assert_eq!(h.mean().unwrap().0, v(1.0));
        assert_eq!(h.hold(imus, 9, 121, v(3.0), v(3.0)), Held::Switched);
        assert_eq!((h.mean().unwrap().0, h.active()), (v(3.0), 1));
        assert_eq!(h.hold(imus, 4, 125, v(1.0), v(1.0)), Held::Standby, "no fail-back while the other is alive");
        assert_eq!(h.hold(imus, 9, 130, v(4.0), v(4.0)), Held::Held);
        assert!(!h.awaiting(), "failover awaits no other IMU");

        // At the start, the first-listed IMU wins an instant both sample at,
        // whichever arrives first.
        let mut h = HeldImu::EMPTY;
        assert_eq!(h.hold(imus, 9, 100, v(2.0), v(2.0)), Held::Held);
        assert_eq!(h.hold(imus, 4, 100, v(1.0), v(1.0)), Held::Held);
        assert_eq!((h.active(), h.mean().unwrap().0), (0, v(1.0)));
        assert_eq!(h.hold(imus, 9, 105, v(2.0), v(2.0)), Held::Standby);
    }
}
