//! Auxiliary states of
//! [`StateSnapshot::aux_states`](super::StateSnapshot::aux_states): states a
//! model carries beyond its own layout
//! ([`Model::state_layout`](super::Model::state_layout)) when configured. Each
//! is one entry of the state vector and one of the covariance, after the
//! model's own (first the state entries, then their covariance indices), in
//! the order of the bits.

/// The odometry scale factor `k` (odometry speed = `k` × true speed;
/// `ins` with `[model.odometry_scale]`).
pub const ODOMETRY_SCALE: u32 = 1;
/// The first barometer's bias `b`, m (pressure altitude = height + `b`;
/// `ins` with a barometer). The others' follow the pose frame
/// ([`BARO_BIASES`]).
pub const BARO_BIAS: u32 = 2;
/// The yaw `ψ` of a pose sensor's map frame in the world frame, rad (`ins`
/// with a pose sensor whose frame is estimated; the four `POSE_FRAME_*`
/// bits come together).
pub const POSE_FRAME_YAW: u32 = 4;
/// The east component of the map frame's origin in the world frame, m.
pub const POSE_FRAME_EAST: u32 = 8;
/// The north component of the map frame's origin in the world frame, m.
pub const POSE_FRAME_NORTH: u32 = 16;
/// The up component of the map frame's origin in the world frame, m.
pub const POSE_FRAME_UP: u32 = 32;
/// The four bits of the pose sensor's map frame.
pub const POSE_FRAME: u32 = POSE_FRAME_YAW | POSE_FRAME_EAST | POSE_FRAME_NORTH | POSE_FRAME_UP;
/// Each barometer's bias, m, in the order of the barometers in the
/// configuration's `[[sensor]]` list: the first is [`BARO_BIAS`].
pub const BARO_BIASES: [u32; 6] = [BARO_BIAS, 64, 128, 256, 512, 1024];
/// Every barometer's bias bit.
pub const BARO_BIAS_ANY: u32 = BARO_BIAS | 64 | 128 | 256 | 512 | 1024;
/// The most auxiliary states a snapshot carries (its room: 22 states, a
/// 21×21 covariance).
pub const MAX: usize = 6;

/// Every auxiliary state with its bit and its name (with unit), in state order.
pub const ALL: [(u32, &str); 11] = [
    (ODOMETRY_SCALE, "odometry_scale"),
    (BARO_BIAS, "baro_bias_m"),
    (POSE_FRAME_YAW, "pose_frame_yaw_rad"),
    (POSE_FRAME_EAST, "pose_frame_east_m"),
    (POSE_FRAME_NORTH, "pose_frame_north_m"),
    (POSE_FRAME_UP, "pose_frame_up_m"),
    (BARO_BIASES[1], "baro_bias_2_m"),
    (BARO_BIASES[2], "baro_bias_3_m"),
    (BARO_BIASES[3], "baro_bias_4_m"),
    (BARO_BIASES[4], "baro_bias_5_m"),
    (BARO_BIASES[5], "baro_bias_6_m"),
];

const _: () = {
    let mut i = 1;
    while i < ALL.len() {
        assert!(ALL[i].0 == ALL[i - 1].0 << 1, "one bit per state, in state order");
        i += 1;
    }
};
