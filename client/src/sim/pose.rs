//! Simulated pose (a localiser: lidar SLAM, visual-inertial odometry): the
//! true position and attitude of the sensor's frame in a map frame of its own
//! (turned and shifted against the world), plus white noise, with its
//! mounting, random dropouts, arriving after a delay; and a re-initialisation
//! of the localiser at a set time (its map frame jumps, announced by the reset
//! counter or not).

use fusion_shared::{SampleKind, PoseSample, Sample};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::arrival::{Reading, Sensor, SensorSim};

/// A map frame: its yaw in the world frame (rad) and its origin (ENU, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapFrame {
    /// Yaw, rad.
    pub yaw_rad: f64,
    /// Origin, m.
    pub origin_m: [f64; 3],
}

/// A re-initialisation of the localiser: from `at_s` on its map frame is `frame`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocaliserReset {
    /// When, s of trajectory time.
    pub at_s: f64,
    /// The map frame after it.
    pub frame: MapFrame,
    /// Whether the reset counter says so (false: only the jump shows).
    pub announced: bool,
}

/// Pose simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseConfig {
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the position's white noise per axis, m.
    pub position_noise_m: f64,
    /// Standard deviation of the attitude's white noise per axis, rad.
    pub attitude_noise_rad: f64,
    /// The localiser's map frame at the start.
    pub frame: MapFrame,
    /// A re-initialisation, if any.
    pub reset: Option<LocaliserReset>,
    /// `C_bs`: the sensor's axes into the body frame (body ← sensor).
    pub rotation: Matrix3<f64>,
    /// The sensor's origin in the body frame, m.
    pub lever_arm_m: [f64; 3],
    /// Probability that a sample is lost.
    pub dropout_probability: f64,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
}

impl Default for PoseConfig {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            position_noise_m: 0.05,
            attitude_noise_rad: 0.005,
            frame: MapFrame { yaw_rad: 0.6, origin_m: [20.0, -15.0, 0.5] },
            reset: None,
            rotation: Matrix3::identity(),
            lever_arm_m: [0.0; 3],
            dropout_probability: 0.0,
            delay_min_ns: 40_000_000,
            delay_max_ns: 100_000_000,
            sensor: 0,
        }
    }
}

/// Simulated pose samples (an endless iterator).
pub type PoseSim = SensorSim<PoseConfig>;

impl Sensor for PoseConfig {
    const KIND: SampleKind = SampleKind::Pose;
    const SALT: u64 = 0x706f_7365;
    type Memory = ();

    super::arrival::usual_timing!();

    fn read(&self, mut r: Reading<'_, ()>) -> Option<Sample> {
        let c = self;
        let (n_p, n_a) = (r.normal3() * c.position_noise_m, r.normal3() * c.attitude_noise_rad);
        if r.lost(c.dropout_probability) {
            return None;
        }
        let (t_s, truth) = (r.t_s, r.truth);
        let (frame, counter) = match c.reset {
            Some(r) if t_s >= r.at_s => (r.frame, u32::from(r.announced)),
            _ => (c.frame, 0),
        };
        let map = Rotation3::from_axis_angle(&Vector3::z_axis(), frame.yaw_rad).into_inner();
        let body = truth.attitude.to_rotation_matrix().into_inner();
        let sensor = truth.pos_m + body * Vector3::from(c.lever_arm_m);
        let p = map.transpose() * (sensor - Vector3::from(frame.origin_m)) + n_p;
        let attitude = map.transpose() * body * c.rotation * Rotation3::new(n_a).into_inner();
        let q = UnitQuaternion::from_matrix(&attitude);
        let qc = q.quaternion().coords; // [x, y, z, w]
        let (sp, sa) = (c.position_noise_m, c.attitude_noise_rad);
        let cov = fusion_shared::TwistSample::diagonal_cov([sp; 3], [sa; 3]);
        let sample = PoseSample::new(r.t_ns, c.sensor, r.seq, p.into(), [qc[3], qc[0], qc[1], qc[2]], cov, counter);
        Some(Sample::Pose(sample))
    }
}



/// `fusion-sim`'s flags of the pose (a localiser: lidar SLAM, VIO).
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct PoseFlags {
    /// Pose (a localiser: lidar SLAM, VIO) rate, Hz; 0: none (sensor id 0;
    /// `--dropouts` applies).
    #[arg(long, default_value_t = 0.0)]
    pub pose_rate: f64,
    /// Pose noise per axis: position m, attitude rad.
    #[arg(long, value_delimiter = ',', default_value = "0.05,0.005")]
    pub pose_noise: Vec<f64>,
    /// The pose sensor's mount, `AXES:ROLL,PITCH,YAW` (degrees; body ← sensor).
    #[arg(long, default_value = "flu:0,0,0")]
    pub pose_mount: String,
    /// The pose sensor's origin in the body frame: x,y,z, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub pose_lever_arm: Option<Vec<f64>>,
    /// The localiser's map frame in the world, `YAW:EAST,NORTH,UP` (degrees, m).
    #[arg(long, default_value = "34.4:20,-15,0.5", allow_hyphen_values = true)]
    pub pose_frame: String,
    /// A re-initialisation of the localiser, `AT:YAW:EAST,NORTH,UP[:silent]`:
    /// from AT s into the drive its map frame is this one; its reset counter
    /// says so unless `silent`.
    #[arg(long, value_name = "AT:YAW:EAST,NORTH,UP[:silent]", allow_hyphen_values = true)]
    pub localiser_reset: Option<String>,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::PoseSample {
    type Flags = PoseFlags;

    fn apply(
        f: &PoseFlags,
        drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.pose_rate <= 0.0 {
            return Ok(());
        }
        let [position, attitude] =
            super::flags::pair("--pose-noise", &f.pose_noise, "POSITION,ATTITUDE, e.g. 0.05,0.005")?;
        c.aiding.push(Arc::new(PoseConfig {
            rate_hz: f.pose_rate,
            position_noise_m: position,
            attitude_noise_rad: attitude,
            frame: parse_map_frame("--pose-frame", &f.pose_frame)?,
            reset: f.localiser_reset.as_deref().map(parse_localiser_reset).transpose()?,
            rotation: super::flags::parse_mount("--pose-mount", &f.pose_mount)?,
            lever_arm_m: super::flags::triple("--pose-lever-arm", f.pose_lever_arm.as_deref())?.unwrap_or([0.0; 3]),
            dropout_probability: drive.dropouts,
            ..Default::default()
        }));
        Ok(())
    }
}

/// A map frame, `YAW:EAST,NORTH,UP` (degrees, m).
#[cfg(feature = "cli")]
fn parse_map_frame(flag: &str, s: &str) -> anyhow::Result<MapFrame> {
    let bad = || anyhow::anyhow!("{flag}: expected YAW:EAST,NORTH,UP (degrees, m), e.g. 30:20,-15,0.5; got {s:?}");
    let (yaw, origin) = s.split_once(':').ok_or_else(bad)?;
    let yaw: f64 = yaw.parse().map_err(|_| bad())?;
    let origin: Vec<f64> = origin.split(',').map(str::parse).collect::<Result<_, _>>().map_err(|_| bad())?;
    let origin: [f64; 3] = origin.try_into().map_err(|_| bad())?;
    if !(yaw.is_finite() && origin.iter().all(|v| v.is_finite())) {
        return Err(bad());
    }
    Ok(MapFrame { yaw_rad: yaw.to_radians(), origin_m: origin })
}

/// A localiser reset, `AT:YAW:EAST,NORTH,UP[:silent]`.
#[cfg(feature = "cli")]
fn parse_localiser_reset(s: &str) -> anyhow::Result<LocaliserReset> {
    let bad =
        || anyhow::anyhow!("--localiser-reset: expected AT:YAW:EAST,NORTH,UP[:silent], e.g. 30:-60:5,5,0; got {s:?}");
    let (at, rest) = s.split_once(':').ok_or_else(bad)?;
    let at: f64 = at.parse().map_err(|_| bad())?;
    let (frame, announced) = match rest.strip_suffix(":silent") {
        Some(frame) => (frame, false),
        None => (rest, true),
    };
    if !(at.is_finite() && at >= 0.0) {
        return Err(bad());
    }
    Ok(LocaliserReset { at_s: at, frame: parse_map_frame("--localiser-reset", frame).map_err(|_| bad())?, announced })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::CarTrajectory;

    /// Without noise the pose, taken back through the map frame, is the
    /// sensor's true position and attitude; after the reset the frame jumps
    /// and the counter says so.
    #[test]
    fn it_reads_the_pose_of_its_frame_in_the_map() {
        let trajectory = CarTrajectory::new(4);
        let rotation = Rotation3::from_euler_angles(0.0, 0.2, -0.3).into_inner();
        let arm = Vector3::new(0.8, 0.0, 1.2);
        let after = MapFrame { yaw_rad: -1.0, origin_m: [5.0, 5.0, 0.0] };
        let c = PoseConfig {
            position_noise_m: 0.0,
            attitude_noise_rad: 0.0,
            rotation,
            lever_arm_m: arm.into(),
            reset: Some(LocaliserReset { at_s: 2.0, frame: after, announced: true }),
            ..Default::default()
        };
        let mut reset_seen = false;
        for a in PoseSim::new(trajectory.clone(), c.clone(), 0, 1).take(40) {
            let Sample::Pose(s) = a.sample else { panic!() };
            let t = s.header.t_ns as f64 * 1e-9;
            let truth = trajectory.at(t);
            let frame = if t >= 2.0 { after } else { c.frame };
            assert_eq!(s.reset_counter, u32::from(t >= 2.0));
            reset_seen |= t >= 2.0;
            let map = Rotation3::from_axis_angle(&Vector3::z_axis(), frame.yaw_rad);
            let world = map * Vector3::from(s.position_m) + Vector3::from(frame.origin_m);
            assert!((world - truth.pos_m - truth.attitude * arm).norm() < 1e-9);
            let [w, x, y, z] = s.orientation_wxyz;
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
            let body = map * q.to_rotation_matrix() * Rotation3::from_matrix_unchecked(rotation.transpose());
            assert!((body.matrix() - truth.attitude.to_rotation_matrix().matrix()).amax() < 1e-9);
        }
        assert!(reset_seen);
    }
}
