//! Sensor samples: what sensor processes publish and the daemon fuses.
//!
//! Layout rules (checked by `const` asserts below): `#[repr(C)]`, `ZeroCopySend`,
//! fixed-width fields only, explicit `_reserved` padding, 8-byte alignment, and an
//! explicit versioned type name: a reader built against another version fails to
//! open the service instead of misreading bytes. Timestamps are `u64` nanoseconds
//! of CLOCK_MONOTONIC ([`crate::now_ns`]).

use iceoryx2::prelude::ZeroCopySend;

/// The kind of a sample. Part of the processing-order key
/// `(t_ns, kind, sensor, seq)`: at equal time an IMU sample is processed before
/// a position sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum SampleKind {
    /// [`ImuSample`].
    Imu = 0,
    /// [`PositionSample`].
    Position = 1,
}

impl SampleKind {
    /// Lower-case name as used in JSON and logs: `"imu"`, `"position"`.
    pub const fn name(self) -> &'static str {
        match self {
            SampleKind::Imu => "imu",
            SampleKind::Position => "position",
        }
    }
}

/// One inertial measurement.
///
/// What `accel_mps2` means depends on the model the daemon runs: for `linear` it
/// is the world-frame (ENU) acceleration with gravity removed; for `ins` it is the
/// body-frame specific force `f = Rᵀ (a − g)`. `gyro_radps` is the body-frame
/// angular rate.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("fusion.ImuSample.v1")]
#[repr(C)]
pub struct ImuSample {
    /// Time of validity, ns of CLOCK_MONOTONIC.
    pub t_ns: u64,
    /// When the publisher sent it, ns of CLOCK_MONOTONIC (stamped by the client
    /// crate; 0 in files). Latency is measured from here.
    pub sent_ns: u64,
    /// Sequence number, increasing by one per sample of this sensor.
    pub seq: u64,
    /// Sensor id, unique among IMU sensors.
    pub sensor: u32,
    /// Explicit padding; write zero.
    pub _reserved: u32,
    /// Acceleration or specific force, m/s² (see the type's docs for the frame).
    pub accel_mps2: [f64; 3],
    /// Angular rate, rad/s, body frame.
    pub gyro_radps: [f64; 3],
}

/// One position fix with its covariance.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("fusion.PositionSample.v1")]
#[repr(C)]
pub struct PositionSample {
    /// Time of validity, ns of CLOCK_MONOTONIC.
    pub t_ns: u64,
    /// When the publisher sent it, ns of CLOCK_MONOTONIC (0 in files).
    pub sent_ns: u64,
    /// Sequence number, increasing by one per sample of this sensor.
    pub seq: u64,
    /// Sensor id, unique among position sensors.
    pub sensor: u32,
    /// Explicit padding; write zero.
    pub _reserved: u32,
    /// Position, m, world frame ENU.
    pub pos_m: [f64; 3],
    /// Covariance of `pos_m`, m², row-major 3×3; must be symmetric positive definite.
    pub cov_m2: [f64; 9],
}

/// A sample of either kind (not a wire type: each kind has its own service).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sample {
    /// Inertial sample.
    Imu(ImuSample),
    /// Position fix.
    Position(PositionSample),
}

impl Sample {
    /// Time of validity, ns.
    pub fn t_ns(&self) -> u64 {
        match self {
            Sample::Imu(s) => s.t_ns,
            Sample::Position(s) => s.t_ns,
        }
    }

    /// When the publisher sent it, ns (0 if unknown).
    pub fn sent_ns(&self) -> u64 {
        match self {
            Sample::Imu(s) => s.sent_ns,
            Sample::Position(s) => s.sent_ns,
        }
    }

    /// Sensor id.
    pub fn sensor(&self) -> u32 {
        match self {
            Sample::Imu(s) => s.sensor,
            Sample::Position(s) => s.sensor,
        }
    }

    /// Sequence number.
    pub fn seq(&self) -> u64 {
        match self {
            Sample::Imu(s) => s.seq,
            Sample::Position(s) => s.seq,
        }
    }

    /// The kind.
    pub fn kind(&self) -> SampleKind {
        match self {
            Sample::Imu(_) => SampleKind::Imu,
            Sample::Position(_) => SampleKind::Position,
        }
    }
}

const _: () = {
    assert!(core::mem::size_of::<ImuSample>() == 80);
    assert!(core::mem::align_of::<ImuSample>() == 8);
    assert!(core::mem::size_of::<PositionSample>() == 128);
    assert!(core::mem::align_of::<PositionSample>() == 8);
};
