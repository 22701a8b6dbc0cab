//! `fusion-sim`'s simulated drive as flags: the trajectory, the IMUs and every
//! aiding sensor's rate, noise, mounting and faults, built into a
//! [`ScenarioConfig`].

use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use fusion_client::sim::AidingSim;
use fusion_client::sim::{
    AttitudeConfig, BarometerConfig, FixPhase, GeodeticConfig, HeadingConfig, ImuConfig, ImuOutput, LocaliserReset,
    MagneticDisturbance, MagnetometerConfig, MapFrame, OdometryConfig, Outage, PoseConfig, PositionConfig,
    ScenarioConfig, Stop, TwistConfig, VelocityConfig,
};
use fusion_shared::geodesy::Datum;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// Sensor and trajectory settings.
#[derive(Args, Clone)]
pub(crate) struct SimArgs {
    /// Seed of the trajectory and all noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Length of the drive, s.
    #[arg(long, default_value_t = 20.0)]
    duration: f64,
    /// IMU rate, Hz.
    #[arg(long, default_value_t = 400.0)]
    imu_rate: f64,
    /// One IMU per mount (sensor ids 0, 1, …): its axes and its rotation into
    /// the body frame, `AXES:ROLL,PITCH,YAW` (degrees, body ← IMU, as in the
    /// config's `[[sensor]]`), e.g. `frd:3,-2,90`. Default: one IMU, `flu:0,0,0`.
    #[arg(long)]
    imu_mount: Vec<String>,
    /// IMU timestamp jitter, ± µs.
    #[arg(long, default_value_t = 0)]
    imu_jitter_us: u64,
    /// IMU acceleration noise, m/s² per sample.
    #[arg(long, default_value_t = 0.05)]
    accel_noise: f64,
    /// IMU angular-rate noise, rad/s per sample.
    #[arg(long, default_value_t = 0.001)]
    gyro_noise: f64,
    /// Standard deviation of the accelerometer's turn-on bias, m/s² (body output).
    #[arg(long, default_value_t = 0.0)]
    accel_bias: f64,
    /// Standard deviation of the gyroscope's turn-on bias, rad/s.
    #[arg(long, default_value_t = 0.0)]
    gyro_bias: f64,
    /// Accelerometer bias random walk, m/s³/√Hz (Kalibr).
    #[arg(long, default_value_t = 0.0)]
    accel_random_walk: f64,
    /// Gyroscope bias random walk, rad/s²/√Hz (Kalibr).
    #[arg(long, default_value_t = 0.0)]
    gyro_random_walk: f64,
    /// Position rate, Hz.
    #[arg(long, default_value_t = 10.0)]
    position_rate: f64,
    /// Horizontal position noise, m (vertical: 1.6×).
    #[arg(long, default_value_t = 0.5)]
    position_noise: f64,
    /// Smallest position delay, ms.
    #[arg(long, default_value_t = 20)]
    position_delay_min_ms: u64,
    /// Largest position delay, ms.
    #[arg(long, default_value_t = 120)]
    position_delay_max_ms: u64,
    /// Velocity (GNSS Doppler) rate, Hz; 0: no velocity sensor.
    #[arg(long, default_value_t = 0.0)]
    velocity_rate: f64,
    /// Horizontal velocity noise, m/s (vertical: 2×).
    #[arg(long, default_value_t = 0.05)]
    velocity_noise: f64,
    /// Geodetic GNSS (latitude, longitude, height) rate, Hz; 0: no such receiver.
    #[arg(long, default_value_t = 0.0)]
    geodetic_rate: f64,
    /// Horizontal noise of the geodetic fixes, m (vertical: 1.6×).
    #[arg(long, default_value_t = 0.5)]
    geodetic_noise: f64,
    /// The GNSS antenna's lever arm (position, velocity, geodetic fixes): x,y,z
    /// in the body frame, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    lever_arm: Option<Vec<f64>>,
    /// Wheel odometry rate, Hz; 0: none.
    #[arg(long, default_value_t = 0.0)]
    odometry_rate: f64,
    /// Odometry speed noise, m/s.
    #[arg(long, default_value_t = 0.05)]
    odometry_noise: f64,
    /// Odometry relative scale error (e.g. 0.002: 0.2 % fast).
    #[arg(long, default_value_t = 0.002, allow_hyphen_values = true)]
    odometry_scale_error: f64,
    /// Report only the noise in the odometry's variance, not the scale error
    /// too (for a fusiond that estimates the scale: `[model.odometry_scale]`).
    #[arg(long)]
    odometry_noise_only_variance: bool,
    /// Odometry reference point (rear axle) in the body frame: x,y,z, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    odometry_lever_arm: Option<Vec<f64>>,
    /// Heading (dual-antenna GNSS) rate, Hz; 0: none.
    #[arg(long, default_value_t = 0.0)]
    heading_rate: f64,
    /// Heading noise, degrees.
    #[arg(long, default_value_t = 0.5)]
    heading_noise_deg: f64,
    /// Attitude (an AHRS's orientation) rate, Hz; 0: none (sensor id 0).
    #[arg(long, default_value_t = 0.0)]
    attitude_rate: f64,
    /// Attitude noise per axis, degrees.
    #[arg(long, default_value_t = 0.5)]
    attitude_noise_deg: f64,
    /// A constant error of the AHRS's yaw, degrees (a magnetic yaw indoors).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    attitude_yaw_error_deg: f64,
    /// The AHRS's mount, `AXES:ROLL,PITCH,YAW` (degrees; body ← sensor).
    #[arg(long, default_value = "flu:0,0,0")]
    attitude_mount: String,
    /// Magnetometer rate, Hz; 0: none (sensor id 0; `--dropouts` applies).
    #[arg(long, default_value_t = 0.0)]
    magnetometer_rate: f64,
    /// Magnetometer noise per axis, µT.
    #[arg(long, default_value_t = 0.5)]
    magnetometer_noise_ut: f64,
    /// The magnetometer's mount, `AXES:ROLL,PITCH,YAW` (degrees; body ← sensor),
    /// as `--imu-mount`.
    #[arg(long, default_value = "flu:0,0,0")]
    magnetometer_mount: String,
    /// The Earth's field: declination (degrees east), inclination (degrees
    /// down), strength (µT) (default: Munich, 3.5,64.5,48.5).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    magnetic_field: Option<Vec<f64>>,
    /// Twist (visual or lidar odometry) rate, Hz; 0: none (sensor id 0;
    /// `--dropouts` applies).
    #[arg(long, default_value_t = 0.0)]
    twist_rate: f64,
    /// Twist noise per axis: linear m/s, angular rad/s.
    #[arg(long, value_delimiter = ',', default_value = "0.05,0.01")]
    twist_noise: Vec<f64>,
    /// The twist sensor's mount, `AXES:ROLL,PITCH,YAW` (degrees; body ← sensor).
    #[arg(long, default_value = "flu:0,0,0")]
    twist_mount: String,
    /// The twist sensor's origin in the body frame: x,y,z, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    twist_lever_arm: Option<Vec<f64>>,
    /// Barometer rate, Hz; 0: none (sensor id 0; `--dropouts` applies).
    #[arg(long, default_value_t = 0.0)]
    barometer_rate: f64,
    /// Barometer noise, Pa (1 Pa is about 8 cm of height).
    #[arg(long, default_value_t = 3.0)]
    barometer_noise_pa: f64,
    /// The barometer's port in the body frame: x,y,z, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    barometer_lever_arm: Option<Vec<f64>>,
    /// Pose (a localiser: lidar SLAM, VIO) rate, Hz; 0: none (sensor id 0;
    /// `--dropouts` applies).
    #[arg(long, default_value_t = 0.0)]
    pose_rate: f64,
    /// Pose noise per axis: position m, attitude rad.
    #[arg(long, value_delimiter = ',', default_value = "0.05,0.005")]
    pose_noise: Vec<f64>,
    /// The pose sensor's mount, `AXES:ROLL,PITCH,YAW` (degrees; body ← sensor).
    #[arg(long, default_value = "flu:0,0,0")]
    pose_mount: String,
    /// The pose sensor's origin in the body frame: x,y,z, m.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pose_lever_arm: Option<Vec<f64>>,
    /// The localiser's map frame in the world, `YAW:EAST,NORTH,UP` (degrees, m).
    #[arg(long, default_value = "34.4:20,-15,0.5", allow_hyphen_values = true)]
    pose_frame: String,
    /// A re-initialisation of the localiser, `AT:YAW:EAST,NORTH,UP[:silent]`:
    /// from AT s into the drive its map frame is this one; its reset counter
    /// says so unless `silent`.
    #[arg(long, value_name = "AT:YAW:EAST,NORTH,UP[:silent]", allow_hyphen_values = true)]
    localiser_reset: Option<String>,
    /// A magnetic disturbance, `AT:SECONDS:MICROTESLA`: a field of MICROTESLA
    /// pointing east adds to the Earth's from AT s into the drive for SECONDS (a
    /// passing lorry, a steel bridge). Repeatable.
    #[arg(long, value_name = "AT:SECONDS:MICROTESLA")]
    magnetic_disturbance: Vec<String>,
    /// Where trajectory position 0 is: latitude (deg), longitude (deg), height
    /// above the WGS-84 ellipsoid (m) (default: Munich, 48.1316,11.5494,519).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    datum: Option<Vec<f64>>,
    /// Probability of a lost fix.
    #[arg(long, default_value_t = 0.0)]
    dropouts: f64,
    /// Probability of a gross outlier.
    #[arg(long, default_value_t = 0.0)]
    outliers: f64,
    /// What the IMU measures: `world` acceleration with gravity removed (the
    /// linear model) or `body` specific force and angular rate (a real IMU).
    #[arg(long, value_enum, default_value_t = ImuKind::World)]
    imu_output: ImuKind,
    /// A stop of the car, `AT:SECONDS[:REVERSE]`: it brakes from AT s into the
    /// drive, stands still for SECONDS (4 s after braking starts), reverses for
    /// REVERSE s if given (up to a quarter of the road's speed backwards) and
    /// drives off (4 s to full speed). Repeat for more stops, in order.
    #[arg(long, value_name = "AT:SECONDS[:REVERSE]")]
    stop: Vec<Stop>,
    /// A GNSS outage (a tunnel), `AT:SECONDS`: no position, geodetic, velocity or
    /// heading sample valid from AT s into the drive for SECONDS. Repeatable.
    #[arg(long, value_name = "AT:SECONDS")]
    outage: Vec<Outage>,
    /// How late the position or GNSS receiver's clock is, ms: a fix valid at `t` is
    /// stamped `t + LAG` (what `[[sensor]] time_offset_ns` undoes).
    #[arg(long, default_value_t = 0)]
    fix_clock_lag_ms: u64,
    /// The GNSS receiver's fix type from AT s into the drive on, `AT:TYPE` with
    /// TYPE `rtk_fixed` (2 cm, reported 1.4 cm), `rtk_float` (0.3 m, reported
    /// 5 cm), `3d` (1.5 m, reported 0.8 m) or `none` (10 m); the geodetic fixes
    /// then carry the fix type, satellites and DOPs. Repeatable, in order.
    #[arg(long, value_name = "AT:TYPE")]
    fix_phase: Vec<FixPhase>,
    /// Trajectory time 0 as a sample timestamp, ns (record only).
    #[arg(long, default_value_t = 1_000_000_000)]
    start_ns: u64,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum ImuKind {
    World,
    Body,
}

/// One aiding sensor's simulation, if its rate asks for one.
type Aiding = anyhow::Result<Option<Arc<dyn AidingSim>>>;

impl SimArgs {
    /// The drive as the flags give it: the trajectory, the IMUs, the
    /// position fixes and each aiding sensor whose rate is above 0.
    pub(crate) fn scenario(&self) -> anyhow::Result<ScenarioConfig> {
        let mut c = ScenarioConfig {
            seed: self.seed,
            duration_s: self.duration,
            start_ns: self.start_ns,
            stops: self.stop.clone(),
            outages: self.outage.clone(),
            ..Default::default()
        };
        c.trajectory().map_err(|e| anyhow::anyhow!("--stop: {e}"))?;
        self.imus(&mut c)?;
        self.position(&mut c)?;
        let aiding = [
            self.velocity(&c.position),
            self.odometry(),
            self.magnetometer(),
            self.twist(),
            self.barometer(),
            self.pose(),
            self.attitude(),
            self.heading(),
            self.geodetic(&c.position),
        ];
        for sim in aiding {
            c.aiding.extend(sim?);
        }
        Ok(c)
    }

    /// The IMU's noise and output, one per `--imu-mount`.
    fn imus(&self, c: &mut ScenarioConfig) -> anyhow::Result<()> {
        c.imu.rate_hz = self.imu_rate;
        c.imu.jitter_ns = self.imu_jitter_us * 1000;
        c.imu.accel_noise_std = self.accel_noise;
        c.imu.gyro_noise_std = self.gyro_noise;
        c.imu.accel_bias_std = self.accel_bias;
        c.imu.gyro_bias_std = self.gyro_bias;
        c.imu.accel_random_walk = self.accel_random_walk;
        c.imu.gyro_random_walk = self.gyro_random_walk;
        c.imu_output = match self.imu_output {
            ImuKind::World => ImuOutput::WorldAcceleration,
            ImuKind::Body => ImuOutput::BodySpecificForce,
        };
        let mounts = if self.imu_mount.is_empty() { vec!["flu:0,0,0".to_string()] } else { self.imu_mount.clone() };
        for (i, mount) in mounts.iter().enumerate() {
            let imu = ImuConfig { sensor: i as u32, rotation: parse_mount("--imu-mount", mount)?, ..c.imu.clone() };
            if i == 0 {
                c.imu = imu;
            } else {
                c.extra_imus.push(imu);
            }
        }
        Ok(())
    }

    /// The position fixes (at the GNSS antenna's lever arm).
    fn position(&self, c: &mut ScenarioConfig) -> anyhow::Result<()> {
        c.position.rate_hz = self.position_rate;
        c.position.noise_std_m = self.position_noise;
        c.position.vertical_noise_std_m = 1.6 * self.position_noise;
        c.position.delay_min_ns = self.position_delay_min_ms * 1_000_000;
        c.position.delay_max_ns = self.position_delay_max_ms * 1_000_000;
        c.position.dropout_probability = self.dropouts;
        c.position.outlier_probability = self.outliers;
        c.position.lever_arm_m = triple("--lever-arm", self.lever_arm.as_deref())?.unwrap_or([0.0; 3]);
        c.position.clock_lag_ns = self.fix_clock_lag_ms.saturating_mul(1_000_000);
        Ok(())
    }

    /// The GNSS velocities: the position fixes' receiver (its delays, its
    /// antenna, its clock), with the geodetic fixes' id when there are some.
    fn velocity(&self, fix: &PositionConfig) -> Aiding {
        if self.velocity_rate <= 0.0 {
            return Ok(None);
        }
        let defaults = VelocityConfig::default();
        let gnss_id = GeodeticConfig::default().fix.sensor;
        Ok(Some(Arc::new(VelocityConfig {
            rate_hz: self.velocity_rate,
            noise_std_mps: self.velocity_noise,
            vertical_noise_std_mps: 2.0 * self.velocity_noise,
            delay_min_ns: fix.delay_min_ns,
            delay_max_ns: fix.delay_max_ns,
            sensor: if self.geodetic_rate > 0.0 { gnss_id } else { defaults.sensor },
            lever_arm_m: fix.lever_arm_m,
            clock_lag_ns: fix.clock_lag_ns,
        })))
    }

    fn odometry(&self) -> Aiding {
        if self.odometry_rate <= 0.0 {
            return Ok(None);
        }
        let defaults = OdometryConfig::default();
        let arm = triple("--odometry-lever-arm", self.odometry_lever_arm.as_deref())?;
        Ok(Some(Arc::new(OdometryConfig {
            rate_hz: self.odometry_rate,
            noise_std_mps: self.odometry_noise,
            scale_error: self.odometry_scale_error,
            scale_in_variance: !self.odometry_noise_only_variance,
            lever_arm_m: arm.unwrap_or(defaults.lever_arm_m),
            ..defaults
        })))
    }

    fn magnetometer(&self) -> Aiding {
        if self.magnetometer_rate <= 0.0 {
            return Ok(None);
        }
        let defaults = MagnetometerConfig::default();
        let field = triple("--magnetic-field", self.magnetic_field.as_deref())?.unwrap_or([
            defaults.declination_deg,
            defaults.inclination_deg,
            defaults.strength_ut,
        ]);
        let disturbances = self.magnetic_disturbance.iter().map(|d| parse_disturbance(d)).collect::<Result<_, _>>()?;
        Ok(Some(Arc::new(MagnetometerConfig {
            rate_hz: self.magnetometer_rate,
            noise_std_ut: self.magnetometer_noise_ut,
            declination_deg: field[0],
            inclination_deg: field[1],
            strength_ut: field[2],
            rotation: parse_mount("--magnetometer-mount", &self.magnetometer_mount)?,
            dropout_probability: self.dropouts,
            disturbances,
            ..defaults
        })))
    }

    fn twist(&self) -> Aiding {
        if self.twist_rate <= 0.0 {
            return Ok(None);
        }
        let [linear, angular] = <[f64; 2]>::try_from(self.twist_noise.clone())
            .map_err(|_| anyhow::anyhow!("--twist-noise: expected LINEAR,ANGULAR, e.g. 0.05,0.01"))?;
        Ok(Some(Arc::new(TwistConfig {
            rate_hz: self.twist_rate,
            linear_noise_mps: linear,
            angular_noise_radps: angular,
            rotation: parse_mount("--twist-mount", &self.twist_mount)?,
            lever_arm_m: triple("--twist-lever-arm", self.twist_lever_arm.as_deref())?.unwrap_or([0.0; 3]),
            dropout_probability: self.dropouts,
            ..Default::default()
        })))
    }

    fn barometer(&self) -> Aiding {
        if self.barometer_rate <= 0.0 {
            return Ok(None);
        }
        Ok(Some(Arc::new(BarometerConfig {
            rate_hz: self.barometer_rate,
            noise_pa: self.barometer_noise_pa,
            lever_arm_m: triple("--barometer-lever-arm", self.barometer_lever_arm.as_deref())?.unwrap_or([0.0; 3]),
            dropout_probability: self.dropouts,
            ..Default::default()
        })))
    }

    fn pose(&self) -> Aiding {
        if self.pose_rate <= 0.0 {
            return Ok(None);
        }
        let [position, attitude] = <[f64; 2]>::try_from(self.pose_noise.clone())
            .map_err(|_| anyhow::anyhow!("--pose-noise: expected POSITION,ATTITUDE, e.g. 0.05,0.005"))?;
        Ok(Some(Arc::new(PoseConfig {
            rate_hz: self.pose_rate,
            position_noise_m: position,
            attitude_noise_rad: attitude,
            frame: parse_map_frame("--pose-frame", &self.pose_frame)?,
            reset: self.localiser_reset.as_deref().map(parse_localiser_reset).transpose()?,
            rotation: parse_mount("--pose-mount", &self.pose_mount)?,
            lever_arm_m: triple("--pose-lever-arm", self.pose_lever_arm.as_deref())?.unwrap_or([0.0; 3]),
            dropout_probability: self.dropouts,
            ..Default::default()
        })))
    }

    fn attitude(&self) -> Aiding {
        if self.attitude_rate <= 0.0 {
            return Ok(None);
        }
        Ok(Some(Arc::new(AttitudeConfig {
            rate_hz: self.attitude_rate,
            noise_std_rad: self.attitude_noise_deg.to_radians(),
            yaw_error_rad: self.attitude_yaw_error_deg.to_radians(),
            rotation: parse_mount("--attitude-mount", &self.attitude_mount)?,
            ..Default::default()
        })))
    }

    fn heading(&self) -> Aiding {
        if self.heading_rate <= 0.0 {
            return Ok(None);
        }
        Ok(Some(Arc::new(HeadingConfig {
            rate_hz: self.heading_rate,
            noise_std_rad: self.heading_noise_deg.to_radians(),
            ..Default::default()
        })))
    }

    /// The geodetic fixes: the position fixes' receiver, its datum and its
    /// fix phases.
    fn geodetic(&self, fix: &PositionConfig) -> Aiding {
        if self.geodetic_rate <= 0.0 {
            return Ok(None);
        }
        let mut g = GeodeticConfig::default();
        g.fix = PositionConfig {
            rate_hz: self.geodetic_rate,
            noise_std_m: self.geodetic_noise,
            vertical_noise_std_m: 1.6 * self.geodetic_noise,
            delay_min_ns: fix.delay_min_ns,
            delay_max_ns: fix.delay_max_ns,
            dropout_probability: self.dropouts,
            outlier_probability: self.outliers,
            lever_arm_m: fix.lever_arm_m,
            clock_lag_ns: fix.clock_lag_ns,
            ..g.fix
        };
        if let Some([lat, lon, h]) = triple("--datum", self.datum.as_deref())? {
            g.datum = Datum::new(lat, lon, h).context("--datum")?;
        }
        if self.fix_phase.windows(2).any(|w| w[1].at_s < w[0].at_s) {
            anyhow::bail!("--fix-phase: give the phases in order of their start");
        }
        g.phases = self.fix_phase.clone();
        Ok(Some(Arc::new(g)))
    }
}

/// Three comma-separated numbers of option `name`, if given.
fn triple(name: &str, values: Option<&[f64]>) -> anyhow::Result<Option<[f64; 3]>> {
    values
        .map(|v| {
            <[f64; 3]>::try_from(v).map_err(|_| anyhow::anyhow!("{name}: expected three numbers X,Y,Z, got {v:?}"))
        })
        .transpose()
}

/// A sensor mount (`--imu-mount`, `--magnetometer-mount`, `--twist-mount`), `AXES:ROLL,PITCH,YAW`
/// (degrees), as the rotation body ← sensor.
fn parse_mount(flag: &str, text: &str) -> anyhow::Result<Matrix3<f64>> {
    let bad = || anyhow::anyhow!("{flag} {text:?}: expected AXES:ROLL,PITCH,YAW, e.g. frd:3,-2,90");
    let (axes, angles) = text.split_once(':').ok_or_else(bad)?;
    let flip = match axes {
        "flu" => Vector3::new(1.0, 1.0, 1.0),
        "frd" => Vector3::new(1.0, -1.0, -1.0),
        _ => return Err(bad()),
    };
    let rpy: Vec<f64> =
        angles.split(',').map(|a| a.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
    let [roll, pitch, yaw] = <[f64; 3]>::try_from(rpy).map_err(|_| bad())?.map(f64::to_radians);
    Ok(UnitQuaternion::from_euler_angles(roll, pitch, yaw).to_rotation_matrix().into_inner()
        * Matrix3::from_diagonal(&flip))
}

/// A magnetic disturbance, `AT:SECONDS:MICROTESLA` (a field pointing east).
fn parse_disturbance(text: &str) -> anyhow::Result<MagneticDisturbance> {
    let bad = || anyhow::anyhow!("--magnetic-disturbance {text:?}: expected AT:SECONDS:MICROTESLA, e.g. 12:3:20");
    let values: Vec<f64> =
        text.split(':').map(|v| v.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
    let [at_s, duration_s, ut] = <[f64; 3]>::try_from(values).map_err(|_| bad())?;
    if !(at_s >= 0.0 && duration_s > 0.0 && ut.is_finite()) {
        return Err(bad());
    }
    Ok(MagneticDisturbance { at_s, duration_s, field_ut: [ut, 0.0, 0.0] })
}

/// A map frame, `YAW:EAST,NORTH,UP` (degrees, m).
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
