//! The auxiliary states of the `ins` model: states beyond the core 15 that a
//! configuration brings, each a random walk (constant in `F`, its density's
//! variance added to `Q`), after the core in the order of their
//! [`fusion_shared::snapshot::aux`] bits. Which there are is declared by their
//! kinds, not here: a sensor kind's wire type gives the bits and names of the
//! states each of its sensors brings (`WireSample::AUX`), and its
//! `Measurement::aux_priors` their priors and random walks from the sensor's
//! settings; the model's own (the odometry scale, `[model.odometry_scale]`)
//! are [`fusion_shared::snapshot::aux::MODEL`]. Today:
//!
//! | kind | states per instance | unit | instances (bits) | brought by |
//! |---|---|---|---|---|
//! | odometry scale | `k` | – | one (`ODOMETRY_SCALE`) | `[model.odometry_scale]` ([`OdometryScale`]) |
//! | barometer bias | `b` | m | one per barometer (`BARO_BIASES`) | each barometer (`[sensor.barometer]`) |
//! | pose map frame | `ψ, t_e, t_n, t_u` | rad, m | one (`POSE_FRAME_*`) | a pose sensor with an estimated frame (`[sensor.pose]`) |
//!
//! A snapshot carries at most [`MAX_AUX`] of them (its room is 22 states and a
//! 21×21 covariance): a configuration that brings more is refused with the
//! count. Two estimated map frames (eight states) never fit.
//!
//! A kind's states may be set from its sensor's first sample (the barometer's
//! bias, and the pose frame again at each re-initialisation of the localiser)
//! by `augment`: the new states are a function of the state and the sample,
//! `a = g(x, z)`, and enter the covariance with their correlation to the rest,
//! `P_aa = G_x P G_xᵀ + G_z R G_zᵀ`, `P_ax = G_x P` (the linearised state
//! augmentation of SLAM; Bailey and Durrant-Whyte, "Simultaneous localisation
//! and mapping (SLAM): Part II", 2006): that sample moves no other state, and
//! the estimate does not jump. [`AuxProgress`] records which have been set.

#![allow(non_snake_case)]

use fusion_shared::SampleKind;
use fusion_shared::snapshot::aux::KINDS;
use nalgebra::{SMatrix, SVector};

use super::OdometryScale;
use super::{InsModel, InsState, MAX_AUX, N, NOMINAL};
use crate::filter::{FilterError, KalmanFilter};

/// The error-state index of auxiliary state `bit` among the states `present`
/// (bits of [`fusion_shared::snapshot::aux`]): [`N`] plus the number of lower
/// bits present, if `bit` is.
#[inline]
pub const fn index(present: u32, bit: u32) -> Option<usize> {
    if present & bit == 0 { None } else { Some(N + (present & (bit - 1)).count_ones() as usize) }
}

/// One auxiliary state's prior and process noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AuxPrior {
    /// Its initial value (before a sample sets it, if one does).
    pub initial: f64,
    /// Its initial standard deviation.
    pub std: f64,
    /// Its random-walk density, per √s.
    pub random_walk: f64,
}

/// One auxiliary state the model has.
#[derive(Debug, Clone, Copy, PartialEq)]
struct AuxState {
    /// Its snapshot bit.
    bit: u32,
    /// The sensor that brings it (kind, id); `None`: the model's own.
    owner: Option<(SampleKind, u32)>,
    /// Its prior.
    prior: AuxPrior,
}

/// Which auxiliary states the model has, with their priors: the instances of
/// each kind of [`KINDS`] that the configuration brings, in bit order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AuxStates {
    /// The states, in bit order (the first `len`).
    states: [AuxState; MAX_AUX],
    /// How many states are held.
    len: usize,
    /// Instances brought, per kind of [`KINDS`], whether they fit or not.
    counts: [usize; KINDS.len()],
}

impl Default for AuxStates {
    fn default() -> Self {
        let none = AuxState { bit: 0, owner: None, prior: AuxPrior { initial: 0.0, std: 1.0, random_walk: 0.0 } };
        Self { states: [none; MAX_AUX], len: 0, counts: [0; KINDS.len()] }
    }
}

impl AuxStates {
    /// These states with the model's own (the odometry scale factor `scale`).
    pub fn with_odometry_scale(self, scale: OdometryScale) -> Self {
        let prior = AuxPrior { initial: scale.initial, std: scale.initial_std, random_walk: scale.random_walk };
        self.with_instance(0, None, &[prior])
    }

    /// These states with those sensor `sensor` of kind `kind` brings (one
    /// prior per state of its kind's instance, [`fusion_shared::sample::AuxKind`];
    /// none: it brings none), after those of its kind already there.
    pub fn with_sensor(self, kind: SampleKind, sensor: u32, priors: &[AuxPrior]) -> Self {
        if priors.is_empty() { self } else { self.with_instance(1 + kind.index(), Some((kind, sensor)), priors) }
    }

    /// Adds the next instance of `KINDS[k]`, if its kind declares one more and
    /// it fits; it is counted either way ([`fits`](Self::fits)).
    fn with_instance(mut self, k: usize, owner: Option<(SampleKind, u32)>, priors: &[AuxPrior]) -> Self {
        let (kind, instance) = (&KINDS[k], self.counts[k]);
        debug_assert_eq!(priors.len(), kind.len, "a prior per state of a {} instance", kind.what);
        self.counts[k] += 1;
        if instance >= kind.instances() || priors.len() != kind.len || self.len + kind.len > MAX_AUX {
            return self;
        }
        for (j, prior) in priors.iter().enumerate() {
            let bit = kind.first_bit(instance) << j;
            // Insertion by bit.
            let mut i = self.len;
            while i > 0 && self.states[i - 1].bit > bit {
                self.states[i] = self.states[i - 1];
                i -= 1;
            }
            self.states[i] = AuxState { bit, owner, prior: *prior };
            self.len += 1;
        }
        self
    }

    /// How many states the configuration brings, whether they fit a snapshot
    /// ([`MAX_AUX`]) or not.
    pub fn wanted(&self) -> usize {
        KINDS.iter().zip(self.counts).map(|(k, n)| k.len * n).sum()
    }

    /// Whether every state brought is held: none beyond a snapshot's room,
    /// no kind with more instances than it declares.
    pub fn fits(&self) -> bool {
        self.len == self.wanted()
    }

    /// What the configuration brings, kind by kind, for a message: "2
    /// barometer bias (1 state each, at most 6)".
    pub fn describe(&self) -> String {
        let each = KINDS.iter().zip(self.counts).filter(|(_, n)| *n > 0);
        let each = each.map(|(k, n)| {
            let states = if k.len == 1 { "state" } else { "states" };
            format!("{n} {} ({} {states} each, at most {})", k.what, k.len, k.instances())
        });
        each.collect::<Vec<_>>().join(", ")
    }

    /// The [`fusion_shared::snapshot::aux`] bits of the states held.
    pub fn bits(&self) -> u32 {
        self.held().iter().fold(0, |b, s| b | s.bit)
    }

    /// Number of auxiliary error states.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The bit of the first of the states sensor `sensor` of kind `kind`
    /// brings, if it has states.
    #[inline]
    pub fn first_bit(&self, kind: SampleKind, sensor: u32) -> Option<u32> {
        self.held().iter().find(|s| s.owner == Some((kind, sensor))).map(|s| s.bit)
    }

    /// The states held, in bit order.
    fn held(&self) -> &[AuxState] {
        &self.states[..self.len]
    }

    /// Initial value, standard deviation and random-walk variance per second
    /// of each auxiliary error state, in state order (of their bits).
    fn entries(&self) -> ([f64; MAX_AUX], [f64; MAX_AUX], [f64; MAX_AUX]) {
        let (mut x, mut sd, mut q) = ([0.0; MAX_AUX], [1.0; MAX_AUX], [0.0; MAX_AUX]);
        for (i, s) in self.held().iter().enumerate() {
            (x[i], sd[i], q[i]) = (s.prior.initial, s.prior.std, s.prior.random_walk * s.prior.random_walk);
        }
        (x, sd, q)
    }
}

/// Where the auxiliary states that are set from a sample stand (part of the
/// filter state: a rewind restores it with the rest): which have been set
/// (`augment` records it for every kind), and each kind's own bookkeeping, as
/// its file declares it ([`fusion_shared::sample::KindProgress`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AuxProgress {
    /// The [`fusion_shared::snapshot::aux`] bits of the states set from a
    /// sample.
    set: u32,
    /// Each kind's bookkeeping, under its module's name.
    pub kinds: fusion_shared::sample::KindsProgress,
    /// Times states were set from a sample (`augment`), and the error-state
    /// indices of the last ones set (the first of their block, and a bit for
    /// each one set of it): the smoother's record of that step (`smoother_record`).
    pub(super) sets: u32,
    /// See `sets`.
    pub(super) last_set: (u8, u8),
}

impl AuxProgress {
    /// Whether auxiliary state `bit` has been set from a sample.
    #[inline]
    pub fn is_set(&self, bit: u32) -> bool {
        self.set & bit != 0
    }

    /// Records that state `bit` has been set (a test's state).
    #[cfg(test)]
    pub(crate) fn mark_set(&mut self, bit: u32) {
        self.set |= bit;
    }
}

impl InsModel {
    /// The same model with auxiliary states `aux` after the core (`E` is [`N`]
    /// plus their number): their initial values and variances appended to
    /// `x₀` and `P₀` (uncorrelated).
    pub fn with_aux<const E: usize>(self, aux: AuxStates) -> Result<InsModel<E>, FilterError> {
        if E != N + aux.len() || !aux.fits() {
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
            gravity_reference: self.gravity_reference,
            yaw_unobserved: self.yaw_unobserved,
            aux,
            aux_noise: q,
            frames: self.frames,
        })
    }

    /// The same model with the odometry scale factor as its one auxiliary state.
    pub fn with_odometry_scale(self, scale: OdometryScale) -> Result<InsModel<{ N + 1 }>, FilterError> {
        self.with_aux(AuxStates::default().with_odometry_scale(scale))
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
    augment_some(s, first, &[true; K], a, Gx, Gz, R)
}

/// [`augment`] of the states among `first..first + K` that `set` marks: the
/// others keep their value, variance and correlations, and count among the
/// states `G_x` maps from (their columns of `G_x` are read; their rows of
/// `a`, `G_x` and `G_z` are not).
pub(crate) fn augment_some<const D: usize, const K: usize, const M: usize>(
    s: &mut InsState<D>,
    first: usize,
    set: &[bool; K],
    a: &SVector<f64, K>,
    Gx: &SMatrix<f64, K, D>,
    Gz: &SMatrix<f64, K, M>,
    R: &SMatrix<f64, M, M>,
) -> Result<(), FilterError> {
    let rows = || (0..K).filter(|&r| set[r]);
    let mut Gx = *Gx;
    for r in rows() {
        Gx.column_mut(first + r).fill(0.0);
    }
    let mut P = s.kf.P();
    for r in rows() {
        P.column_mut(first + r).fill(0.0);
        P.row_mut(first + r).fill(0.0);
    }
    let cross = Gx * P; // K×D, zero in the set states' columns
    let Paa = Gx * P * Gx.transpose() + Gz * R * Gz.transpose();
    for r in rows() {
        for j in 0..D {
            P[(first + r, j)] = cross[(r, j)];
            P[(j, first + r)] = cross[(r, j)];
        }
    }
    for (r, c) in rows().flat_map(|r| rows().map(move |c| (r, c))) {
        P[(first + r, first + c)] = Paa[(r, c)];
    }
    if nalgebra::Cholesky::new(P).is_none() {
        return Err(FilterError::CovarianceNotPositiveDefinite);
    }
    s.kf.set_state(SVector::zeros(), P)?;
    let mut mask = 0u8;
    for r in rows() {
        s.nominal[first + r + 1] = a[r];
        s.aux.set |= aux_bit(s.aux_bits, first + r);
        mask |= 1 << r;
    }
    s.aux.sets = s.aux.sets.wrapping_add(1);
    s.aux.last_set = (first as u8, mask);
    Ok(())
}

/// The bit of error state `i` among the auxiliary states `present` (0 for a
/// core state): the inverse of [`index`].
fn aux_bit(present: u32, i: usize) -> u32 {
    let mut rest = present;
    for _ in N..i {
        rest &= rest.wrapping_sub(1);
    }
    if i < N { 0 } else { rest & rest.wrapping_neg() }
}

/// Prior variance the smoother's record gives a state set from a sample: no
/// information on it before the step.
const UNINFORMED: f64 = 1e12;

/// The smoother's record of a step that set states from a sample
/// ([`augment_some`]; `set` = (first index, the bits of those set from it)): the new states do not continue
/// the old ones, so their rows of the step's transition are zero and their
/// prior is uninformed (zero mean, variance [`UNINFORMED`], uncorrelated). The
/// smoothing then passes nothing of the new states back to the old ones, and
/// the old ones keep what the other states tell them (their correlation with
/// those before the step).
pub(super) fn smoother_record<const D: usize>(step: &mut crate::filter::RtsStep<f64, D>, set: (u8, u8)) {
    let first = usize::from(set.0);
    for i in (0..8).filter(|r| set.1 & (1 << r) != 0).map(|r| first + r).filter(|&i| i < D) {
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
    use crate::model::ins::tests_support::{barometer, estimated_frame, model};
    use fusion_shared::snapshot::aux as bits;

    #[test]
    fn the_states_follow_the_core_in_bit_order() {
        let every = AuxStates::default().with_odometry_scale(OdometryScale::default());
        let every = estimated_frame(barometer(every, 9), 3);
        assert_eq!((every.len(), every.fits()), (6, true));
        assert_eq!(index(every.bits(), bits::ODOMETRY_SCALE), Some(N));
        assert_eq!(index(every.bits(), bits::BARO_BIAS), Some(N + 1));
        assert_eq!(index(every.bits(), bits::POSE_FRAME_YAW), Some(N + 2));
        assert_eq!(index(every.bits(), bits::POSE_FRAME_UP), Some(N + 5));
        assert_eq!(every.first_bit(SampleKind::Pose, 3), Some(bits::POSE_FRAME_YAW));
        let baro = barometer(AuxStates::default(), 9);
        assert_eq!(index(baro.bits(), bits::BARO_BIAS), Some(N));
        assert_eq!(index(baro.bits(), bits::ODOMETRY_SCALE), None);
        // A second barometer's bias follows the map frame (its bit is higher).
        let two = barometer(every, 12);
        assert_eq!((two.wanted(), two.fits(), two.first_bit(SampleKind::Barometer, 12)), (7, false, None));
        let two = barometer(estimated_frame(barometer(AuxStates::default(), 9), 3), 12);
        assert_eq!(
            (two.len(), two.wanted(), two.first_bit(SampleKind::Barometer, 12)),
            (6, 6, Some(bits::BARO_BIASES[1]))
        );
        assert_eq!(index(two.bits(), bits::BARO_BIASES[1]), Some(N + 5));
        assert_eq!(index(two.bits(), bits::POSE_FRAME_YAW), Some(N + 1));
        // A second estimated frame: more instances than the pose kind declares.
        let frames = estimated_frame(estimated_frame(AuxStates::default(), 1), 2);
        assert_eq!((frames.len(), frames.wanted(), frames.fits()), (4, 8, false));
        assert_eq!(frames.describe(), "2 pose map frame (4 states each, at most 1)");
        let m = model().with_aux::<{ N + 6 }>(every).unwrap();
        let s = m.initial_state();
        assert_eq!(InsModel::x_of(&s).len(), N + 7);
        assert_eq!(s.odometry_scale(), Some(1.0));
        assert!(model().with_aux::<{ N + 2 }>(every).is_err(), "the dimension must be the states'");
        assert!(model().with_aux::<{ N + 4 }>(frames).is_err(), "states that do not fit are refused");
    }

    /// A state set from a sample, `a = z − x₀` (as the barometer's bias is set):
    /// its variance is `P₀₀ + R`, its covariance with `x₀` is `−P₀₀`, and
    /// nothing else changes. It is recorded as set, by its bit.
    #[test]
    fn augmenting_correlates_the_new_state_with_what_it_came_from() {
        let aux = barometer(estimated_frame(AuxStates::default(), 1), 9);
        let m = model().with_aux::<{ N + 5 }>(aux).unwrap();
        let mut s = m.initial_state();
        let before = s.kf.P();
        let mut Gx = SMatrix::<f64, 1, { N + 5 }>::zeros();
        Gx[(0, 2)] = -1.0;
        let R = SMatrix::<f64, 1, 1>::new(4.0);
        augment(&mut s, N, &SVector::<f64, 1>::new(7.0), &Gx, &SMatrix::<f64, 1, 1>::new(1.0), &R).unwrap();
        let P = s.kf.P();
        assert_eq!(s.aux_value(N), 7.0);
        assert!((P[(N, N)] - (before[(2, 2)] + 4.0)).abs() < 1e-12);
        assert!((P[(N, 2)] + before[(2, 2)]).abs() < 1e-12 && P[(2, N)] == P[(N, 2)]);
        assert_eq!(P.fixed_view::<N, N>(0, 0), before.fixed_view::<N, N>(0, 0));
        assert!(s.aux.is_set(bits::BARO_BIAS) && !s.aux.is_set(bits::POSE_FRAME_YAW));
        let (a, Gx, I) =
            (SVector::<f64, 2>::zeros(), SMatrix::<f64, 2, { N + 5 }>::zeros(), SMatrix::<f64, 2, 2>::identity());
        augment(&mut s, N + 3, &a, &Gx, &I, &I).unwrap();
        assert!(s.aux.is_set(bits::POSE_FRAME_NORTH) && s.aux.is_set(bits::POSE_FRAME_UP));
        assert!(!s.aux.is_set(bits::POSE_FRAME_EAST));
        assert_eq!((aux_bit(aux.bits(), 3), aux_bit(aux.bits(), N + 4)), (0, bits::POSE_FRAME_UP));
    }
}
