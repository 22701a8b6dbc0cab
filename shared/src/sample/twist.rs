//! Twist: the body's linear and angular velocity, as odometry from visual or
//! lidar odometry gives it.

use iceoryx2::prelude::ZeroCopySend;

use super::{SampleHeader, SampleKind};

/// The linear and angular velocity of the sensor's frame, in its own axes (its
/// mounting on the body is configuration: `[[sensor]] axes`, `rotation_rpy_deg`,
/// `lever_arm_m`), with their 6×6 covariance: a ROS `TwistWithCovariance` in the
/// child frame, from visual or lidar odometry.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[cfg_attr(feature = "json", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "json", serde(from = "TwistLine", into = "TwistLine"))]
#[type_name("fusion.TwistSample.v2")]
#[repr(C)]
pub struct TwistSample {
    /// Time, sensor, sequence number, kind [`SampleKind::Twist`].
    pub header: SampleHeader,
    /// Linear velocity of the sensor's origin, m/s, sensor axes; |v| ≤ 150 m/s.
    pub linear_mps: [f64; 3],
    /// Angular velocity, rad/s, sensor axes; |ω| ≤ `[validation] gyro_range_radps`.
    pub angular_radps: [f64; 3],
    /// Covariance of `[linear, angular]`, row-major 6×6 (m²/s², m·rad/s², rad²/s²);
    /// symmetric positive definite.
    pub cov: [f64; 36],
}

impl TwistSample {
    /// Values one sample gives a measurement update: the χ² degrees of freedom of
    /// its NIS.
    pub const INNOVATION_DIM: usize = 6;

    /// The auxiliary states a sensor of this kind brings: none.
    pub const AUX: crate::sample::AuxKind = crate::sample::AuxKind::NONE;

    /// A twist of sensor `sensor` with sequence number `seq` at `t_ns`.
    pub const fn new(
        t_ns: u64,
        sensor: u32,
        seq: u64,
        linear_mps: [f64; 3],
        angular_radps: [f64; 3],
        cov: [f64; 36],
    ) -> Self {
        Self { header: SampleHeader::new(SampleKind::Twist, t_ns, sensor, seq), linear_mps, angular_radps, cov }
    }

    /// A 6×6 diagonal covariance from the linear (m/s) and angular (rad/s)
    /// standard deviations of each axis.
    pub fn diagonal_cov(linear_std: [f64; 3], angular_std: [f64; 3]) -> [f64; 36] {
        let mut cov = [0.0; 36];
        for i in 0..3 {
            cov[i * 7] = linear_std[i] * linear_std[i];
            cov[(i + 3) * 7] = angular_std[i] * angular_std[i];
        }
        cov
    }
}

impl Default for TwistSample {
    fn default() -> Self {
        Self::new(0, 0, 0, [0.0; 3], [0.0; 3], [0.0; 36])
    }
}

#[cfg(feature = "json")]
super::json_form!(TwistSample, TwistLine {
    /// m/s, sensor axes.
    linear: [f64; 3] => linear_mps,
    /// rad/s, sensor axes.
    angular: [f64; 3] => angular_radps,
    /// row-major 6×6, linear then angular.
    #[serde(with = "matrix6")]
    #[schemars(with = "Vec<f64>", length(equal = 36))]
    cov: [f64; 36] => cov,
});

/// A row-major 6×6 matrix as a JSON array of 36 numbers (serde derives arrays up
/// to 32 only).
#[cfg(feature = "json")]
pub(crate) mod matrix6 {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(m: &[f64; 36], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(m.iter())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 36], D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        let n = v.len();
        v.try_into().map_err(|_| serde::de::Error::invalid_length(n, &"36 numbers (a row-major 6x6 matrix)"))
    }
}

const _: () = {
    assert!(core::mem::size_of::<TwistSample>() == 368);
    assert!(core::mem::align_of::<TwistSample>() == 8);
};

#[cfg(all(test, feature = "json"))]
mod tests {
    use super::*;
    use crate::Sample;
    use crate::jsonl::{format_sample, parse_sample};

    /// The 6×6 covariance goes through JSON lines as 36 numbers, and any other
    /// count is refused with the reason.
    #[test]
    fn json_lines_carry_the_whole_covariance() {
        let mut cov = TwistSample::diagonal_cov([0.05, 0.06, 0.07], [0.01, 0.02, 0.03]);
        cov[1] = 1e-4;
        cov[6] = 1e-4;
        let s = Sample::Twist(TwistSample::new(5, 2, 9, [1.0, -0.5, 0.1], [0.0, 0.1, -0.2], cov));
        let line = format_sample(&s);
        assert!(line.starts_with("{\"twist\":{\"t_ns\":5,\"sensor\":2,\"seq\":9,\"linear\":[1.0,-0.5,0.1]"), "{line}");
        assert_eq!(parse_sample(&line).unwrap(), s);
        let short = line.replace(",1e-4", "").replacen("0.0001,", "", 1);
        let e = parse_sample(&short).unwrap_err().to_string();
        assert!(e.contains("36 numbers"), "{e}");
    }
}

/// Nothing is kept between its samples.
impl crate::sample::KindProgress for TwistSample {
    type Progress = ();
}

crate::wire_layout!(TwistSample, "Linear (m/s) and angular (rad/s) velocity in the sensor's axes, with their covariance (row-major 6×6, linear then angular): visual or lidar odometry.", { header, linear_mps, angular_radps, cov });

/// The whole twist, an odometry's or a stamped one, with its 6×6 covariance.
#[cfg(feature = "ros")]
impl crate::ros_msgs::FromRos for TwistSample {
    const MESSAGES: &'static [crate::ros_msgs::MessageType] =
        &[crate::ros_msgs::MessageType::Odometry, crate::ros_msgs::MessageType::TwistWithCovarianceStamped];

    fn from_ros<H: crate::ros_msgs::Stamp>(
        m: crate::ros_msgs::Message<'_, H>,
        sensor: u32,
        seq: u64,
    ) -> Result<Self, String> {
        use crate::ros_msgs as ros;
        let Some(twist) = m.twist() else { return Err(ros::not_read("twist")) };
        let t = m.t_ns()?;
        let (v, w) = (twist.twist.linear.array(), twist.twist.angular.array());
        Ok(TwistSample::new(t, sensor, seq, v, w, ros::flat6(&twist.covariance)))
    }
}
