//! The auxiliary states of the `ins` model: states beyond the core 15 that a
//! configuration brings, each a random walk (constant in `F`, its density's
//! variance added to `Q`), after the core in the order of their
//! [`fusion_shared::snapshot::aux`] bits. [`KINDS`] is the one table of them:
//!
//! | kind | states per instance | unit | instances (bits) | brought by |
//! |---|---|---|---|---|
//! | odometry scale | `k` | – | one (`ODOMETRY_SCALE`) | `[model.odometry_scale]` ([`OdometryScale`]) |
//! | barometer bias | `b` | m | one per barometer (`BARO_BIASES`) | each barometer (`[sensor.barometer]`, [`BarometerConfig`]) |
//! | pose map frame | `ψ, t_e, t_n, t_u` | rad, m | one (`POSE_FRAME_*`) | a pose sensor with an estimated frame (`[sensor.pose]`, [`PoseConfig`]) |
//!
//! A snapshot carries at most [`MAX_AUX`] of them (its room is 22 states and a
//! 21×21 covariance): a configuration that brings more is refused with the
//! count. Two estimated map frames (eight states) never fit.
//!
//! The barometer's bias and the pose frame are set from their sensor's first
//! sample (and the frame again at each re-initialisation of the localiser) by
//! `augment`: the new states are a function of the state and the sample,
//! `a = g(x, z)`, and enter the covariance with their correlation to the rest,
//! `P_aa = G_x P G_xᵀ + G_z R G_zᵀ`, `P_ax = G_x P` (the linearised state
//! augmentation of SLAM; Bailey and Durrant-Whyte, "Simultaneous localisation
//! and mapping (SLAM): Part II", 2006): that sample moves no other state, and
//! the estimate does not jump.

#![allow(non_snake_case)]

use fusion_shared::snapshot::aux as bits;
use nalgebra::{SMatrix, SVector};

use super::OdometryScale;
use super::{InsModel, InsState, MAX_AUX, N, NOMINAL};
use crate::filter::{FilterError, KalmanFilter};
pub use crate::measurement::barometer::settings::{BarometerConfig, BarometerProgress};
pub use crate::measurement::pose::progress::{PoseProgress, PreviousPose};
pub use crate::measurement::pose::settings::PoseConfig;

/// The barometer's bias state's parameters (`[sensor.barometer]`).
pub type BaroBias = BarometerConfig;
/// A pose sensor's map frame state's parameters (`[sensor.pose]`).
pub type PoseFrame = PoseConfig;

/// Standard deviation given the barometer's bias before its first sample sets
/// it, m (nothing observes it before).
const UNSET_BIAS_STD_M: f64 = 100.0;
/// Standard deviation given the pose frame's origin before the first pose sets
/// it, m.
const UNSET_ORIGIN_STD_M: f64 = 1000.0;

/// The error-state index of auxiliary state `bit` among the states `present`
/// (bits of [`fusion_shared::snapshot::aux`]): [`N`] plus the number of lower
/// bits present, if `bit` is.
#[inline]
pub const fn index(present: u32, bit: u32) -> Option<usize> {
    if present & bit == 0 { None } else { Some(N + (present & (bit - 1)).count_ones() as usize) }
}

/// One kind of auxiliary state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AuxKind {
    /// What the states are.
    pub name: &'static str,
    /// The snapshot bit of each instance's first state (its other states take
    /// the next bits).
    pub instances: &'static [u32],
    /// States per instance.
    pub len: usize,
}

/// The odometry scale factor (`[model.odometry_scale]`).
pub const SCALE: AuxKind = AuxKind { name: "odometry scale", instances: &[bits::ODOMETRY_SCALE], len: 1 };
/// A barometer's bias, one per barometer.
pub const BARO: AuxKind = AuxKind { name: "barometer bias", instances: &bits::BARO_BIASES, len: 1 };
/// A pose sensor's map frame, when it is estimated.
pub const FRAME: AuxKind = AuxKind { name: "pose map frame", instances: &[bits::POSE_FRAME_YAW], len: 4 };
/// Every kind of auxiliary state.
pub const KINDS: [AuxKind; 3] = [SCALE, BARO, FRAME];

/// Which auxiliary states the model has, with their parameters: the
/// instances of each of [`KINDS`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AuxStates {
    /// The odometry scale factor.
    pub odometry_scale: Option<OdometryScale>,
    /// Each barometer's bias: its sensor id and parameters, in the
    /// configuration's order (the first is `BARO_BIAS`).
    pub barometers: [Option<(u32, BaroBias)>; MAX_AUX],
    /// A pose sensor's map frame (yaw, origin).
    pub pose: Option<PoseFrame>,
}

impl AuxStates {
    /// These states with barometer `sensor`'s bias after the barometers'
    /// already there (none beyond [`MAX_AUX`] of them).
    pub fn with_barometer(mut self, sensor: u32, bias: BaroBias) -> Self {
        if let Some(slot) = self.barometers.iter_mut().find(|b| b.is_none()) {
            *slot = Some((sensor, bias));
        }
        self
    }

    /// The instances of each of [`KINDS`] present, in its order.
    const fn counts(&self) -> [usize; KINDS.len()] {
        let mut barometers = 0;
        while barometers < MAX_AUX && self.barometers[barometers].is_some() {
            barometers += 1;
        }
        [self.odometry_scale.is_some() as usize, barometers, self.pose.is_some() as usize]
    }

    /// How many states the instances number, whether they fit a snapshot
    /// ([`MAX_AUX`]) or not.
    pub const fn wanted(&self) -> usize {
        let (counts, mut total, mut k) = (self.counts(), 0, 0);
        while k < KINDS.len() {
            total += counts[k] * KINDS[k].len;
            k += 1;
        }
        total
    }

    /// The [`fusion_shared::snapshot::aux`] bits of the states present.
    pub const fn bits(&self) -> u32 {
        let (counts, mut b, mut k) = (self.counts(), 0, 0);
        while k < KINDS.len() {
            let kind = &KINDS[k];
            let mut i = 0;
            while i < counts[k] && i < kind.instances.len() {
                let mut j = 0;
                while j < kind.len {
                    b |= kind.instances[i] << j;
                    j += 1;
                }
                i += 1;
            }
            k += 1;
        }
        b
    }

    /// Number of auxiliary error states.
    pub const fn len(&self) -> usize {
        self.bits().count_ones() as usize
    }

    /// Whether there are none.
    pub const fn is_empty(&self) -> bool {
        self.bits() == 0
    }

    /// Which of the barometers sensor `sensor` is (its bias's bit is
    /// `BARO_BIASES[i]`), if it has a bias state.
    #[inline]
    pub fn barometer(&self, sensor: u32) -> Option<usize> {
        self.barometers.iter().position(|b| matches!(b, Some((id, _)) if *id == sensor))
    }

    /// Initial value, standard deviation and random-walk variance per second
    /// of each auxiliary error state, in state order (of their bits).
    fn entries(&self) -> ([f64; MAX_AUX], [f64; MAX_AUX], [f64; MAX_AUX]) {
        // (bit, value, σ, random walk) of each state, then in bit order.
        let mut states = [(u32::MAX, 0.0, 1.0, 0.0); MAX_AUX];
        let mut n = 0;
        let mut push = |bit: u32, v: f64, s: f64, rw: f64| {
            if n < MAX_AUX {
                states[n] = (bit, v, s, rw * rw);
                n += 1;
            }
        };
        if let Some(k) = self.odometry_scale {
            push(bits::ODOMETRY_SCALE, k.initial, k.initial_std, k.random_walk);
        }
        for (b, bit) in self.barometers.iter().zip(bits::BARO_BIASES) {
            if let Some((_, b)) = b {
                push(bit, 0.0, UNSET_BIAS_STD_M, b.bias_random_walk_m);
            }
        }
        if let Some(p) = self.pose {
            push(bits::POSE_FRAME_YAW, 0.0, std::f64::consts::PI, p.frame_yaw_random_walk_deg.to_radians());
            for bit in [bits::POSE_FRAME_EAST, bits::POSE_FRAME_NORTH, bits::POSE_FRAME_UP] {
                push(bit, 0.0, UNSET_ORIGIN_STD_M, p.frame_origin_random_walk_m);
            }
        }
        states[..n].sort_by_key(|s| s.0);
        let (mut x, mut sd, mut q) = ([0.0; MAX_AUX], [1.0; MAX_AUX], [0.0; MAX_AUX]);
        for (i, (_, v, s, rw)) in states[..n].iter().enumerate() {
            (x[i], sd[i], q[i]) = (*v, *s, *rw);
        }
        (x, sd, q)
    }
}

/// Where the auxiliary states that are set from a sample stand (part of the
/// filter state: a rewind restores it with the rest). Each kind that sets
/// states keeps its own bookkeeping, of a type of its own.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AuxProgress {
    /// Each barometer's ([`BarometerProgress`]), in the order of
    /// [`AuxStates::barometers`].
    pub barometers: [BarometerProgress; MAX_AUX],
    /// The pose sensor's ([`PoseProgress`]).
    pub pose: PoseProgress,
    /// Times states were set from a sample (`augment`), and the error-state
    /// indices of the last ones set (first, count): the smoother's record of
    /// that step (`smoother_record`).
    pub sets: u32,
    /// See `sets`.
    pub last_set: (u8, u8),
}

impl InsModel {
    /// The same model with auxiliary states `aux` after the core (`E` is [`N`]
    /// plus their number): their initial values and variances appended to
    /// `x₀` and `P₀` (uncorrelated).
    pub fn with_aux<const E: usize>(self, aux: AuxStates) -> Result<InsModel<E>, FilterError> {
        if E != N + aux.len() || aux.len() != aux.wanted() {
            return Err(FilterError::StateDimension { got: E, expected: N + aux.wanted() });
        }
        let (x, sd, q) = aux.entries();
        let mut P = SMatrix::<f64, E, E>::zeros();
        P.fixed_view_mut::<N, N>(0, 0).copy_from(&self.initial.P());
        for i in N..E {
            P[(i, i)] = sd[i - N] * sd[i - N];
        }
        let initial = KalmanFilter::new(SVector::zeros(), P)?;
        let mut x0 = self.x0;
        x0[NOMINAL..NOMINAL + aux.len()].copy_from_slice(&x[..aux.len()]);
        Ok(InsModel {
            noise: self.noise,
            gravity: self.gravity,
            x0,
            initial,
            gate: self.gate,
            lockout: self.lockout,
            alignment_samples: self.alignment_samples,
            course: self.course,
            nonholonomic: self.nonholonomic,
            standstill: self.standstill,
            yaw_unobserved: self.yaw_unobserved,
            aux,
            aux_noise: q,
            frames: self.frames,
        })
    }

    /// The same model with the odometry scale factor as its one auxiliary state.
    pub fn with_odometry_scale(self, scale: OdometryScale) -> Result<InsModel<{ N + 1 }>, FilterError> {
        self.with_aux(AuxStates { odometry_scale: Some(scale), ..AuxStates::default() })
    }
}

/// Sets the `K` auxiliary states at `first..first + K` from a sample `z` with
/// noise covariance `R`: their nominal values to `a`, their error covariance
/// to `P_aa = G_x P G_xᵀ + G_z R G_zᵀ` and their cross-covariance to
/// `P_ax = G_x P`, with `G_x = ∂a/∂δx` (its columns of the states being set
/// are ignored: they are replaced) and `G_z = ∂a/∂z`. The filter's other
/// entries are unchanged; a result that is not a covariance leaves the state
/// as it was and is refused.
pub(crate) fn augment<const D: usize, const K: usize, const M: usize>(
    s: &mut InsState<D>,
    first: usize,
    a: &SVector<f64, K>,
    Gx: &SMatrix<f64, K, D>,
    Gz: &SMatrix<f64, K, M>,
    R: &SMatrix<f64, M, M>,
) -> Result<(), FilterError> {
    let mut Gx = *Gx;
    for c in first..first + K {
        Gx.column_mut(c).fill(0.0);
    }
    let mut P = s.kf.P();
    for c in first..first + K {
        P.column_mut(c).fill(0.0);
        P.row_mut(c).fill(0.0);
    }
    let cross = Gx * P; // K×D, zero in the set states' columns
    let Paa = Gx * P * Gx.transpose() + Gz * R * Gz.transpose();
    for (r, i) in (first..first + K).enumerate() {
        for j in 0..D {
            P[(i, j)] = cross[(r, j)];
            P[(j, i)] = cross[(r, j)];
        }
    }
    P.fixed_view_mut::<K, K>(first, first).copy_from(&Paa);
    if nalgebra::Cholesky::new(P).is_none() {
        return Err(FilterError::CovarianceNotPositiveDefinite);
    }
    s.kf.set_state(SVector::zeros(), P)?;
    for (r, i) in (first..first + K).enumerate() {
        s.nominal[i + 1] = a[r];
    }
    s.aux.sets = s.aux.sets.wrapping_add(1);
    s.aux.last_set = (first as u8, K as u8);
    Ok(())
}

/// Prior variance the smoother's record gives a state set from a sample: no
/// information on it before the step.
const UNINFORMED: f64 = 1e12;

/// The smoother's record of a step that set states from a sample
/// ([`augment`]; `set` = (first index, count)): the new states do not continue
/// the old ones, so their rows of the step's transition are zero and their
/// prior is uninformed (zero mean, variance [`UNINFORMED`], uncorrelated). The
/// smoothing then passes nothing of the new states back to the old ones, and
/// the old ones keep what the other states tell them (their correlation with
/// those before the step).
pub(super) fn smoother_record<const D: usize>(step: &mut crate::filter::RtsStep<f64, D>, set: (u8, u8)) {
    let (first, count) = (usize::from(set.0), usize::from(set.1));
    for i in first..(first + count).min(D) {
        step.F.row_mut(i).fill(0.0);
        step.P_prior.row_mut(i).fill(0.0);
        step.P_prior.column_mut(i).fill(0.0);
        step.P_prior[(i, i)] = UNINFORMED;
        step.x_prior[i] = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;
    use crate::model::ins::tests_support::model;

    #[test]
    fn the_states_follow_the_core_in_bit_order() {
        let every = AuxStates {
            odometry_scale: Some(OdometryScale::default()),
            pose: Some(PoseFrame::default()),
            ..AuxStates::default()
        }
        .with_barometer(9, BaroBias::default());
        assert_eq!(every.len(), 6);
        assert_eq!(index(every.bits(), bits::ODOMETRY_SCALE), Some(N));
        assert_eq!(index(every.bits(), bits::BARO_BIAS), Some(N + 1));
        assert_eq!(index(every.bits(), bits::POSE_FRAME_YAW), Some(N + 2));
        assert_eq!(index(every.bits(), bits::POSE_FRAME_UP), Some(N + 5));
        let baro = AuxStates::default().with_barometer(9, BaroBias::default());
        assert_eq!(index(baro.bits(), bits::BARO_BIAS), Some(N));
        assert_eq!(index(baro.bits(), bits::ODOMETRY_SCALE), None);
        // A second barometer's bias follows the map frame (its bit is higher).
        let two = every.with_barometer(12, BaroBias::default());
        assert_eq!((two.wanted(), two.barometer(12), two.barometer(3)), (7, Some(1), None));
        let two = AuxStates { odometry_scale: None, ..two };
        assert_eq!((two.len(), two.wanted()), (6, 6));
        assert_eq!(index(two.bits(), bits::BARO_BIASES[1]), Some(N + 5));
        assert_eq!(index(two.bits(), bits::POSE_FRAME_YAW), Some(N + 1));
        let m = model().with_aux::<{ N + 6 }>(every).unwrap();
        let s = m.initial_state();
        assert_eq!(InsModel::x_of(&s).len(), N + 7);
        assert_eq!(s.odometry_scale(), Some(1.0));
        assert!(model().with_aux::<{ N + 2 }>(every).is_err(), "the dimension must be the states'");
    }

    /// A state set from a sample, `a = z − x₀` (as the barometer's bias is set):
    /// its variance is `P₀₀ + R`, its covariance with `x₀` is `−P₀₀`, and
    /// nothing else changes.
    #[test]
    fn augmenting_correlates_the_new_state_with_what_it_came_from() {
        let m = model().with_aux::<{ N + 1 }>(AuxStates::default().with_barometer(9, BaroBias::default()));
        let m = m.unwrap();
        let mut s = m.initial_state();
        let before = s.kf.P();
        let mut Gx = SMatrix::<f64, 1, { N + 1 }>::zeros();
        Gx[(0, 2)] = -1.0;
        let R = SMatrix::<f64, 1, 1>::new(4.0);
        augment(&mut s, N, &SVector::<f64, 1>::new(7.0), &Gx, &SMatrix::<f64, 1, 1>::new(1.0), &R).unwrap();
        let P = s.kf.P();
        assert_eq!(s.aux_value(N), 7.0);
        assert!((P[(N, N)] - (before[(2, 2)] + 4.0)).abs() < 1e-12);
        assert!((P[(N, 2)] + before[(2, 2)]).abs() < 1e-12 && P[(2, N)] == P[(N, 2)]);
        assert_eq!(P.fixed_view::<N, N>(0, 0), before.fixed_view::<N, N>(0, 0));
    }
}
