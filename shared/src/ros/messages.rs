//! The ROS messages fusiond reads ([`crate::ros_msgs`], re-exported here) and
//! the samples each gives: a message is read as a kind by that kind's own
//! declaration (`FromRos`, beside its wire type), dispatched from the kind
//! list; which kinds a message type gives ([`MessageType::kinds`]) is what the
//! kinds declare of it.

pub use crate::ros_msgs::*;
use crate::sample::{Sample, SampleKind};

/// Generates the dispatch from a kind to its [`FromRos`] from the kind list.
macro_rules! ros_kinds {
    ($($(#[$doc:meta])* $variant:ident = $code:literal, $name:literal, $module:ident, $ty:ident;)*) => {
        /// The sample of `kind` in `message`, as the kind reads it.
        fn convert<H: Stamp>(kind: SampleKind, message: Message<'_, H>, sensor: u32, seq: u64) -> Result<Sample, String> {
            match kind {
                $(SampleKind::$variant => <crate::sample::$ty as FromRos>::from_ros(message, sensor, seq).map(Sample::from),)*
            }
        }

        /// The message types a kind is read from ([`FromRos::MESSAGES`]).
        pub fn messages_of(kind: SampleKind) -> &'static [MessageType] {
            match kind {
                $(SampleKind::$variant => <crate::sample::$ty as FromRos>::MESSAGES,)*
            }
        }
    };
}
crate::for_each_sample_kind!(ros_kinds);

impl MessageType {
    /// The kinds a message of this type gives, in kind order: each kind that
    /// declares it among its [`FromRos::MESSAGES`].
    pub fn kinds(self) -> Vec<SampleKind> {
        SampleKind::ALL.iter().copied().filter(|&k| messages_of(k).contains(&self)).collect()
    }
}

/// What a decoded message gives for `kind`, numbered `seq` of sensor `sensor`:
/// a sample, or why there is none.
pub trait Convert {
    /// The sample of `kind`.
    fn sample(&self, kind: SampleKind, sensor: u32, seq: u64) -> Result<Sample, String>;
}

/// Each message type's [`Convert`]: the kind's own reading of it.
macro_rules! convert_by_kind {
    ($($ty:ident),*) => {
        $(impl<H: Stamp> Convert for $ty<H> {
            fn sample(&self, kind: SampleKind, sensor: u32, seq: u64) -> Result<Sample, String> {
                convert(kind, Message::$ty(self), sensor, seq)
            }
        })*
    };
}
convert_by_kind!(
    Imu,
    Odometry,
    NavSatFix,
    TwistWithCovarianceStamped,
    PoseWithCovarianceStamped,
    FluidPressure,
    MagneticField
);

#[cfg(test)]
mod tests {
    use super::*;

    /// The kinds each message type gives, as the kinds declare them.
    #[test]
    fn each_message_type_gives_the_kinds_that_read_it() {
        use SampleKind as K;
        let gives = |t: MessageType| t.kinds();
        assert_eq!(gives(MessageType::Imu), [K::Imu, K::Attitude]);
        assert_eq!(gives(MessageType::Odometry), [K::Odometry, K::Twist, K::Pose]);
        assert_eq!(gives(MessageType::NavSatFix), [K::Geodetic]);
        assert_eq!(gives(MessageType::TwistWithCovarianceStamped), [K::Odometry, K::Twist]);
        assert_eq!(gives(MessageType::PoseWithCovarianceStamped), [K::Pose]);
        assert_eq!(gives(MessageType::FluidPressure), [K::Barometer]);
        assert_eq!(gives(MessageType::MagneticField), [K::Magnetometer]);
    }

    /// A twist gives the whole twist to `twist` (its 6×6 covariance row-major)
    /// and its forward speed with that variance to `odometry`.
    #[test]
    fn a_twist_is_a_twist_or_a_forward_speed() {
        let mut covariance = [[0.0; 6]; 6];
        for (i, row) in covariance.iter_mut().enumerate() {
            row[i] = 0.01 * (i + 1) as f64;
        }
        covariance[0][5] = 0.001;
        let twist = TwistWithCovariance {
            twist: Twist { linear: Vector3 { x: 1.5, y: -0.1, z: 0.0 }, angular: Vector3 { x: 0.0, y: 0.0, z: 0.3 } },
            covariance,
        };
        let header = Ros2Header { sec: 0, nanosec: 7, frame_id: String::new() };
        let t = TwistWithCovarianceStamped { header, twist };
        let Ok(Sample::Twist(s)) = t.sample(SampleKind::Twist, 2, 3) else { panic!() };
        assert_eq!((s.header.t_ns, s.header.sensor, s.header.seq), (7, 2, 3));
        assert_eq!((s.linear_mps, s.angular_radps), ([1.5, -0.1, 0.0], [0.0, 0.0, 0.3]));
        assert_eq!((s.cov[0], s.cov[5], s.cov[35]), (0.01, 0.001, 0.06));
        let Ok(Sample::Odometry(o)) = t.sample(SampleKind::Odometry, 2, 3) else { panic!() };
        assert_eq!((o.speed_mps, o.var_m2ps2), (1.5, 0.01));
        assert!(t.sample(SampleKind::Barometer, 2, 3).is_err());
    }
}
