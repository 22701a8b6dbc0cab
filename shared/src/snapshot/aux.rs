//! Auxiliary states of
//! [`StateSnapshot::aux_states`](super::StateSnapshot::aux_states): states a
//! model carries beyond its own layout
//! ([`Model::state_layout`](super::Model::state_layout)) when configured. Each
//! is one entry of the state vector and one of the covariance, after the
//! model's own (first the state entries, then their covariance indices), in
//! the order of the bits.
//!
//! Each sensor kind declares the states its sensors bring, with their bits
//! and names, in its wire type's file ([`AuxKind`], `WireSample::AUX`); the
//! model's own are [`MODEL`]. [`KINDS`] and [`ALL`] are generated from the kind
//! list. The constants below name the bits of today's kinds.

use crate::sample::{AuxKind, BarometerSample, PoseSample};

/// The odometry scale factor `k` (odometry speed = `k` × true speed;
/// `ins` with `[model.odometry_scale]`).
pub const ODOMETRY_SCALE: u32 = 1;
/// The `ins` model's own auxiliary states (not a sensor's): the odometry
/// scale factor.
pub const MODEL: AuxKind = AuxKind { what: "odometry scale", len: 1, states: &[(ODOMETRY_SCALE, "odometry_scale")] };
/// The first barometer's bias `b`, m (pressure altitude = height + `b`;
/// `ins` with a barometer). The others' follow the pose frame
/// ([`BARO_BIASES`]).
pub const BARO_BIAS: u32 = BARO_BIASES[0];
/// The yaw `ψ` of a pose sensor's map frame in the world frame, rad (`ins`
/// with a pose sensor whose frame is estimated; the four `POSE_FRAME_*`
/// bits come together).
pub const POSE_FRAME_YAW: u32 = PoseSample::AUX.states[0].0;
/// The east component of the map frame's origin in the world frame, m.
pub const POSE_FRAME_EAST: u32 = PoseSample::AUX.states[1].0;
/// The north component of the map frame's origin in the world frame, m.
pub const POSE_FRAME_NORTH: u32 = PoseSample::AUX.states[2].0;
/// The up component of the map frame's origin in the world frame, m.
pub const POSE_FRAME_UP: u32 = PoseSample::AUX.states[3].0;
/// The four bits of the pose sensor's map frame.
pub const POSE_FRAME: u32 = PoseSample::AUX.bits();
/// Each barometer's bias, m, in the order of the barometers in the
/// configuration's `[[sensor]]` list: the first is [`BARO_BIAS`].
pub const BARO_BIASES: [u32; 6] = {
    let mut b = [0; 6];
    let mut i = 0;
    while i < b.len() {
        b[i] = BarometerSample::AUX.first_bit(i);
        i += 1;
    }
    b
};
/// Every barometer's bias bit.
pub const BARO_BIAS_ANY: u32 = BarometerSample::AUX.bits();
/// The most auxiliary states a snapshot carries (its room: 22 states, a
/// 21×21 covariance).
pub const MAX: usize = 6;

/// Generates [`KINDS`] from the kind list.
macro_rules! every_kind {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident;)*) => {
        /// The auxiliary states of the model ([`MODEL`]) and of each sample
        /// kind, in kind order.
        pub const KINDS: [AuxKind; 1 + crate::sample::SampleKind::COUNT] =
            [MODEL, $(<crate::sample::$ty as crate::sample::WireSample>::AUX),*];
    };
}
crate::for_each_sample_kind!(every_kind);

/// How many auxiliary states are declared.
const COUNT: usize = {
    let (mut n, mut k) = (0, 0);
    while k < KINDS.len() {
        n += KINDS[k].states.len();
        k += 1;
    }
    n
};

/// Every auxiliary state with its bit and its name (with unit), in state
/// order (of the bits).
pub const ALL: [(u32, &str); COUNT] = {
    let mut all = [(0, ""); COUNT];
    let (mut n, mut k) = (0, 0);
    while k < KINDS.len() {
        let mut i = 0;
        while i < KINDS[k].states.len() {
            // Insertion by bit.
            let mut j = n;
            while j > 0 && all[j - 1].0 > KINDS[k].states[i].0 {
                all[j] = all[j - 1];
                j -= 1;
            }
            all[j] = KINDS[k].states[i];
            n += 1;
            i += 1;
        }
        k += 1;
    }
    all
};

const _: () = {
    let mut k = 0;
    while k < KINDS.len() {
        assert!(KINDS[k].is_well_formed(), "a kind's auxiliary states: whole instances of consecutive bits");
        k += 1;
    }
    assert!(ALL[0].0 == 1, "the first state's bit is 1");
    let mut i = 1;
    while i < ALL.len() {
        assert!(ALL[i].0 == ALL[i - 1].0 << 1, "one bit per state, none twice, none skipped");
        i += 1;
    }
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bits_and_names_are_the_kinds_in_bit_order() {
        let names: Vec<_> = ALL.iter().map(|(_, n)| *n).collect();
        assert_eq!(
            names[..6],
            [
                "odometry_scale",
                "baro_bias_m",
                "pose_frame_yaw_rad",
                "pose_frame_east_m",
                "pose_frame_north_m",
                "pose_frame_up_m"
            ]
        );
        assert_eq!((BARO_BIASES, BARO_BIAS_ANY, POSE_FRAME), ([2, 64, 128, 256, 512, 1024], 1986, 60));
        assert_eq!(
            ALL[6..11],
            [
                (64, "baro_bias_2_m"),
                (128, "baro_bias_3_m"),
                (256, "baro_bias_4_m"),
                (512, "baro_bias_5_m"),
                (1024, "baro_bias_6_m")
            ]
        );
        let broken = AuxKind { what: "x", len: 2, states: &[(4, "a"), (16, "b")] };
        assert!(!broken.is_well_formed() && PoseSample::AUX.is_well_formed());
    }
}
