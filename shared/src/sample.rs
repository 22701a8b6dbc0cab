//! Sensor samples: what sensor processes publish and the daemon fuses.
//!
//! Every sample starts with the same [`SampleHeader`] (time of validity, send time,
//! sequence number, sensor id, kind) followed by the payload of its kind. Each kind
//! has its own file (its wire type, its JSON-lines form) and one line in
//! [`for_each_sample_kind!`](crate::for_each_sample_kind), the one list of kinds in
//! the whole system (and a `mod` line here). From the list this file generates
//! [`SampleKind`], the in-process sum type [`Sample`] and the [`WireSample`] impls; the daemon
//! generates its measurement registry and the client its simulators from the same
//! list.
//!
//! Layout rules (checked by `const` asserts): `#[repr(C)]`, `ZeroCopySend`,
//! fixed-width fields only, explicit padding, 8-byte alignment, and an explicit
//! versioned type name (`fusion.<Type>.v2`): a reader built against another version
//! fails to open the service instead of misreading bytes. Timestamps are `u64`
//! nanoseconds of CLOCK_MONOTONIC ([`crate::now_ns`]).

use iceoryx2::prelude::ZeroCopySend;

/// The header every sample starts with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[type_name("fusion.SampleHeader.v2")]
#[repr(C)]
pub struct SampleHeader {
    /// Time of validity, ns of CLOCK_MONOTONIC.
    pub t_ns: u64,
    /// When the publisher sent it, ns of CLOCK_MONOTONIC (stamped by the client
    /// crate; 0 in files). Latency is measured from here.
    pub sent_ns: u64,
    /// Sequence number, increasing by one per sample of this sensor.
    pub seq: u64,
    /// Sensor id, unique among the sensors of this kind.
    pub sensor: u32,
    /// [`SampleKind`] code of the payload that follows. The daemon rejects a sample
    /// whose code is not the kind of the service it arrived on (0 never is: a
    /// zeroed sample is refused).
    pub kind: u32,
}

impl SampleHeader {
    /// A header of `kind` with time `t_ns`, sensor and sequence number (`sent_ns` 0).
    pub const fn new(kind: SampleKind, t_ns: u64, sensor: u32, seq: u64) -> Self {
        Self { t_ns, sent_ns: 0, seq, sensor, kind: kind as u32 }
    }
}

crate::wire_layout!(SampleHeader, "What every sample starts with.", { t_ns, sent_ns, seq, sensor, kind });

/// What the fusion keeps of one kind between its samples, inside the filter
/// state (a rewind restores it with the rest): each kind's file declares it
/// (`()`: nothing; a pose sensor's map frame alignment and last pose). The
/// state holds every kind's in one [`KindsProgress`], generated from the
/// kind list, so the model that holds it names no kind.
pub trait KindProgress {
    /// The kind's bookkeeping (compact and `Copy`: it is copied with the
    /// filter state into the history at every sample).
    type Progress: Copy + Default + PartialEq + std::fmt::Debug;
}

/// Where a kind's [`KindProgress`] is in [`KindsProgress`] (implemented for
/// every kind from the kind list): what lets a model hand a kind its own
/// bookkeeping and nothing else.
pub trait InKindsProgress: KindProgress {
    /// The kind's bookkeeping in `all`.
    fn of(all: &KindsProgress) -> &Self::Progress;
    /// The same, to change.
    fn of_mut(all: &mut KindsProgress) -> &mut Self::Progress;
}

/// A wire type of one sample kind.
pub trait WireSample:
    Copy + Default + PartialEq + std::fmt::Debug + ZeroCopySend + layout::WireLayout + 'static
{
    /// The kind of the payload.
    const KIND: SampleKind;
    /// Values one sample gives a measurement update: the χ² degrees of freedom
    /// of its NIS (0: a kind that drives the propagation, the IMU). Each kind's
    /// file states it.
    const INNOVATION_DIM: usize;
    /// The auxiliary states a sensor of this kind brings to a model that
    /// estimates them (the `ins` model): their snapshot bits and names. Each
    /// kind's file states it ([`AuxKind::NONE`] for most).
    const AUX: AuxKind;
    /// The header.
    fn header(&self) -> &SampleHeader;
    /// The header, to stamp.
    fn header_mut(&mut self) -> &mut SampleHeader;
    /// Wrapped in the sum type.
    fn into_sample(self) -> Sample;
    /// The payload of `sample` if it is of this kind.
    fn from_sample(sample: &Sample) -> Option<Self>;
}

/// The auxiliary states of one kind (a sensor kind's, or a model's own): the
/// snapshot bit and name of each state (the snapshot's `aux` module). A kind
/// brings one instance of `len` states per sensor (per model), in `[[sensor]]`
/// order, up to as many instances as it declares; an instance's states have
/// consecutive bits from its first. Bits are part of the wire format: never
/// reused, never moved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AuxKind {
    /// What the states are, in a message ("barometer bias").
    pub what: &'static str,
    /// States per instance.
    pub len: usize,
    /// The bit and name (with unit) of each state, instance after instance.
    pub states: &'static [(u32, &'static str)],
}

impl AuxKind {
    /// A kind that brings none.
    pub const NONE: AuxKind = AuxKind { what: "", len: 1, states: &[] };

    /// How many instances it declares (how many sensors of the kind may bring
    /// their states).
    pub const fn instances(&self) -> usize {
        self.states.len() / self.len
    }

    /// The bit of instance `i`'s first state (`i` < [`instances`](Self::instances)).
    pub const fn first_bit(&self, i: usize) -> u32 {
        self.states[i * self.len].0
    }

    /// Every bit of its states.
    pub const fn bits(&self) -> u32 {
        let (mut b, mut i) = (0, 0);
        while i < self.states.len() {
            b |= self.states[i].0;
            i += 1;
        }
        b
    }

    /// Whether the declaration is well formed: whole instances, each of
    /// consecutive single bits (checked at compile time for every kind).
    pub const fn is_well_formed(&self) -> bool {
        if self.len == 0 || !self.states.len().is_multiple_of(self.len) {
            return false;
        }
        let mut i = 0;
        while i < self.states.len() {
            let (bit, first) = (self.states[i].0, self.first_bit(i / self.len));
            if bit.count_ones() != 1 || bit != first << (i % self.len) {
                return false;
            }
            i += 1;
        }
        true
    }
}

/// Something done once per wire type, in registry order (see [`SampleKind::visit_all`]).
pub trait KindVisitor {
    /// Called with each wire type.
    fn visit<T: WireSample>(&mut self);
}

/// Something done with the wire type of one kind, chosen at run time (see
/// [`SampleKind::with_wire_type`]): decoding bytes of a kind named in a message.
pub trait KindFn {
    /// What the call gives.
    type Output;
    /// Called with the kind's wire type.
    fn call<T: WireSample>(self) -> Self::Output;
}

/// Something done with the payload of a [`Sample`] as its wire type (see
/// [`Sample::with_payload`]): encoding it, publishing it.
pub trait PayloadFn {
    /// What the call gives.
    type Output;
    /// Called with the payload.
    fn call<T: WireSample>(self, payload: &T) -> Self::Output;
}

/// The list of sample kinds: the only place a kind is registered.
///
/// Each line is `Variant = code, "name", module, WireType;`: the [`SampleKind`]
/// variant, its wire code (from 1, never reused), its lower-case name (service
/// `<ns>/<name>`, JSON-lines tag, config keys), the module of its files
/// (`shared/src/sample/<module>.rs`, `core/src/measurement/<module>.rs`,
/// `client/src/sim/<module>.rs`) and its wire type.
///
/// `for_each_sample_kind!(callback)` expands to `callback! { <the list> }`, so each
/// crate generates what it needs of every kind from this one list.
#[macro_export]
macro_rules! for_each_sample_kind {
    ($callback:ident) => {
        $callback! {
            /// [`ImuSample`](crate::sample::ImuSample): specific force (or acceleration) and angular rate.
            Imu = 1, "imu", imu, ImuSample;
            /// [`PositionSample`](crate::sample::PositionSample): a 3-D position fix in the world frame.
            Position = 2, "position", position, PositionSample;
            /// [`VelocitySample`](crate::sample::VelocitySample): a 3-D velocity in the world frame (GNSS Doppler).
            Velocity = 3, "velocity", velocity, VelocitySample;
            /// [`GeodeticSample`](crate::sample::GeodeticSample): a GNSS fix in WGS-84 latitude, longitude, height.
            Geodetic = 4, "geodetic", geodetic, GeodeticSample;
            /// [`OdometrySample`](crate::sample::OdometrySample): the forward speed from wheel odometry.
            Odometry = 5, "odometry", odometry, OdometrySample;
            /// [`HeadingSample`](crate::sample::HeadingSample): the yaw angle (dual-antenna GNSS, compass).
            Heading = 6, "heading", heading, HeadingSample;
            /// [`MagnetometerSample`](crate::sample::MagnetometerSample): the magnetic field vector in the sensor's axes.
            Magnetometer = 7, "magnetometer", magnetometer, MagnetometerSample;
            /// [`TwistSample`](crate::sample::TwistSample): linear and angular velocity in the sensor's axes (visual or lidar odometry).
            Twist = 8, "twist", twist, TwistSample;
            /// [`BarometerSample`](crate::sample::BarometerSample): static air pressure (a pressure altitude).
            Barometer = 9, "barometer", barometer, BarometerSample;
            /// [`PoseSample`](crate::sample::PoseSample): position and attitude in a localiser's map frame (SLAM, VIO).
            Pose = 10, "pose", pose, PoseSample;
            /// [`AttitudeSample`](crate::sample::AttitudeSample): an AHRS's orientation in the world frame.
            Attitude = 11, "attitude", attitude, AttitudeSample;
        }
    };
}

// Each kind's file. Declared here rather than by the macro below, so that tools
// that read the source without expanding macros (cbindgen, for the C header)
// find the wire types; a kind missing here fails to compile.
pub mod layout;

mod attitude;
mod barometer;
pub use barometer::{ISA_SEA_LEVEL_PA, MAX_PRESSURE_PA, pressure_altitude_m, pressure_altitude_slope};
mod geodetic;
pub use geodetic::fix;
mod heading;
mod imu;
mod magnetometer;
pub use magnetometer::earth_field_enu;
mod odometry;
mod pose;
pub use pose::progress as pose_progress;
mod position;
mod twist;
mod velocity;

/// Re-exports each kind's wire type, generates [`SampleKind`], [`Sample`] and the [`WireSample`]
/// impls from [`for_each_sample_kind!`](crate::for_each_sample_kind).
macro_rules! sample_kinds {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident;)*) => {
        $(
            pub use $module::$ty;
        )*

        /// The kind of a sample: its code on the wire ([`SampleHeader::kind`]) and in
        /// snapshots. Codes start at 1; 0 is the snapshot's `INPUT_NONE`.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[repr(u8)]
        pub enum SampleKind {
            $($(#[$doc])* $variant = $code,)*
        }

        impl SampleKind {
            /// Every kind, in code order.
            pub const ALL: &'static [SampleKind] = &[$(SampleKind::$variant),*];
            /// Number of kinds.
            pub const COUNT: usize = SampleKind::ALL.len();

            /// Position in [`SampleKind::ALL`] (`code − 1`): the index of per-kind arrays.
            pub const fn index(self) -> usize {
                self as usize - 1
            }

            /// Lower-case name, as in JSON, service names and logs.
            pub const fn name(self) -> &'static str {
                match self {
                    $(SampleKind::$variant => $name,)*
                }
            }

            /// Values one sample of this kind gives a measurement update (the χ²
            /// degrees of freedom of its NIS; [`WireSample::INNOVATION_DIM`]).
            pub const fn innovation_dim(self) -> usize {
                match self {
                    $(SampleKind::$variant => $ty::INNOVATION_DIM,)*
                }
            }

            /// The health reason of a stale stream of this kind.
            pub const fn stale_reason(self) -> &'static str {
                match self {
                    $(SampleKind::$variant => concat!($name, " stale"),)*
                }
            }

            /// The kind of a wire code, if it is one.
            pub const fn from_code(code: u32) -> Option<SampleKind> {
                match code {
                    $($code => Some(SampleKind::$variant),)*
                    _ => None,
                }
            }

            /// The kind of a name, if it is one.
            pub fn from_name(name: &str) -> Option<SampleKind> {
                SampleKind::ALL.iter().copied().find(|k| k.name() == name)
            }

            /// Calls `visitor` with each wire type, in code order.
            pub fn visit_all(visitor: &mut impl KindVisitor) {
                $(visitor.visit::<$ty>();)*
            }

            /// Calls `f` with this kind's wire type.
            pub fn with_wire_type<F: KindFn>(self, f: F) -> F::Output {
                match self {
                    $(SampleKind::$variant => f.call::<$ty>(),)*
                }
            }
        }

        /// Every kind's [`KindProgress`], each under its kind's module name
        /// (`pose`): what the fusion keeps between samples, in the filter state.
        #[derive(Debug, Clone, Copy, PartialEq, Default)]
        pub struct KindsProgress {
            $(#[doc = concat!("The ", $name, " kind's.")] pub $module: <$ty as KindProgress>::Progress,)*
        }

        $(impl InKindsProgress for $ty {
            #[inline]
            fn of(all: &KindsProgress) -> &Self::Progress {
                &all.$module
            }
            #[inline]
            fn of_mut(all: &mut KindsProgress) -> &mut Self::Progress {
                &mut all.$module
            }
        })*

        /// A sample of any kind (not a wire type: each kind has its own service).
        /// In JSON lines: `{"<kind name>": {…}}`. As large as the largest wire type
        /// (a pose's 6×6 covariance): samples live inline in the engine's
        /// fixed-capacity history, never boxed, so the hot path does not allocate.
        #[derive(Debug, Clone, Copy, PartialEq)]
        #[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
        #[allow(clippy::large_enum_variant)]
        pub enum Sample {
            $($(#[$doc])* #[cfg_attr(feature = "json", serde(rename = $name))] $variant($ty),)*
        }

        impl Sample {
            /// The header.
            pub fn header(&self) -> &SampleHeader {
                match self {
                    $(Sample::$variant(s) => &s.header,)*
                }
            }

            /// The header, to stamp.
            pub fn header_mut(&mut self) -> &mut SampleHeader {
                match self {
                    $(Sample::$variant(s) => &mut s.header,)*
                }
            }

            /// Calls `f` with the payload as its wire type.
            pub fn with_payload<F: PayloadFn>(&self, f: F) -> F::Output {
                match self {
                    $(Sample::$variant(s) => f.call(s),)*
                }
            }

            /// The kind of the payload (whatever the header says).
            pub fn kind(&self) -> SampleKind {
                match self {
                    $(Sample::$variant(_) => SampleKind::$variant,)*
                }
            }
        }

        $(
            impl WireSample for $ty {
                const KIND: SampleKind = SampleKind::$variant;
                const INNOVATION_DIM: usize = $ty::INNOVATION_DIM;
                const AUX: AuxKind = $ty::AUX;
                fn header(&self) -> &SampleHeader {
                    &self.header
                }
                fn header_mut(&mut self) -> &mut SampleHeader {
                    &mut self.header
                }
                fn into_sample(self) -> Sample {
                    Sample::$variant(self)
                }
                fn from_sample(sample: &Sample) -> Option<Self> {
                    match sample {
                        Sample::$variant(s) => Some(*s),
                        #[allow(unreachable_patterns)]
                        _ => None,
                    }
                }
            }

            impl From<$ty> for Sample {
                fn from(s: $ty) -> Sample {
                    Sample::$variant(s)
                }
            }
        )*
    };
}

crate::for_each_sample_kind!(sample_kinds);

impl Sample {
    /// Time of validity, ns.
    pub fn t_ns(&self) -> u64 {
        self.header().t_ns
    }

    /// When the publisher sent it, ns (0 if unknown).
    pub fn sent_ns(&self) -> u64 {
        self.header().sent_ns
    }

    /// Sensor id.
    pub fn sensor(&self) -> u32 {
        self.header().sensor
    }

    /// Sequence number.
    pub fn seq(&self) -> u64 {
        self.header().seq
    }
}

/// The JSON form of a wire type: the header's `t_ns`, `sensor` and `seq`
/// followed by the payload's fields (see [`crate::jsonl`]), and, only where
/// they say something, the header's `sent_ns` (not 0: a live sample) and `kind`
/// (not the payload's kind: a faulty sender, which the daemon refuses). With
/// its JSON Schema, for recordings (the `recording` module).
#[cfg(feature = "json")]
macro_rules! json_form {
    ($ty:ident, $line:ident { $($(#[$doc:meta])* $json:ident: $jty:ty => $field:ident),* $(,)? }) => {
        #[derive(serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
        #[serde(deny_unknown_fields)]
        pub(crate) struct $line {
            /// Time of validity, ns of CLOCK_MONOTONIC.
            t_ns: u64,
            /// Sensor id.
            sensor: u32,
            /// Sequence number.
            seq: u64,
            /// When the publisher sent it, ns of CLOCK_MONOTONIC (live samples only).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            sent_ns: Option<u64>,
            /// The header's kind code, only when it is not this kind's.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            kind: Option<u32>,
            $($(#[$doc])* $json: $jty,)*
        }

        impl From<$line> for $ty {
            fn from(l: $line) -> Self {
                let kind = <$ty as $crate::sample::WireSample>::KIND;
                let mut header = $crate::sample::SampleHeader::new(kind, l.t_ns, l.sensor, l.seq);
                header.sent_ns = l.sent_ns.unwrap_or(0);
                header.kind = l.kind.unwrap_or(kind as u32);
                Self { header, $($field: l.$json,)* }
            }
        }

        impl From<$ty> for $line {
            fn from(s: $ty) -> Self {
                let kind = <$ty as $crate::sample::WireSample>::KIND as u32;
                Self {
                    t_ns: s.header.t_ns,
                    sensor: s.header.sensor,
                    seq: s.header.seq,
                    sent_ns: (s.header.sent_ns != 0).then_some(s.header.sent_ns),
                    kind: (s.header.kind != kind).then_some(s.header.kind),
                    $($json: s.$field,)*
                }
            }
        }

        impl schemars::JsonSchema for $ty {
            fn schema_name() -> std::borrow::Cow<'static, str> {
                stringify!($ty).into()
            }
            fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
                <$line as schemars::JsonSchema>::json_schema(generator)
            }
        }
    };
}
#[cfg(feature = "json")]
pub(crate) use json_form;

const _: () = {
    assert!(core::mem::size_of::<SampleHeader>() == 32);
    assert!(core::mem::align_of::<SampleHeader>() == 8);
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_names_and_defaults_agree() {
        for &k in SampleKind::ALL {
            assert_eq!(SampleKind::from_code(k as u32), Some(k));
            assert_eq!(SampleKind::from_name(k.name()), Some(k));
            assert_ne!(k as u32, crate::snapshot::INPUT_NONE);
        }
        assert_eq!(SampleKind::from_code(0), None);
        assert_eq!(ImuSample::default().header.kind, SampleKind::Imu as u32);
        assert_eq!(PositionSample::default().header.kind, SampleKind::Position as u32);
        assert_eq!(VelocitySample::default().header.kind, SampleKind::Velocity as u32);
        struct Count(Vec<SampleKind>);
        impl KindVisitor for Count {
            fn visit<T: WireSample>(&mut self) {
                self.0.push(T::KIND);
            }
        }
        let mut c = Count(Vec::new());
        SampleKind::visit_all(&mut c);
        assert_eq!(c.0, SampleKind::ALL);
    }
}
