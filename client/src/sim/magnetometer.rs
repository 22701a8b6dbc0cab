//! Simulated magnetometer: the Earth's field in the sensor's axes plus white
//! noise, with its mounting, random dropouts and disturbances (a passing lorry, a
//! steel bridge: a field added for a while).

use fusion_shared::{SampleKind, MagnetometerSample, Sample, earth_field_enu};
use nalgebra::{Matrix3, Vector3};

use super::arrival::{Reading, Sensor, SensorSim};

/// A disturbance: from `at_s` into the drive for `duration_s`, `field_ut` (world
/// frame, ENU) adds to the Earth's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagneticDisturbance {
    /// Start, s since the start of the drive.
    pub at_s: f64,
    /// Length, s.
    pub duration_s: f64,
    /// The field it adds, µT, ENU.
    pub field_ut: [f64; 3],
}

/// Magnetometer simulation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct MagnetometerConfig {
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Standard deviation of the white noise per axis, µT (reported in the covariance).
    pub noise_std_ut: f64,
    /// The Earth's field: declination (degrees east), inclination (degrees
    /// down), strength (µT). Default: Munich (WMM 2025: 3.5°, 64.5°, 48.5 µT).
    pub declination_deg: f64,
    /// See `declination_deg`.
    pub inclination_deg: f64,
    /// See `declination_deg`.
    pub strength_ut: f64,
    /// `C_bs`: the sensor's axes into the body frame (body ← sensor); the sensor
    /// reports `C_bsᵀ` times the body-frame field.
    pub rotation: Matrix3<f64>,
    /// Probability that a sample is lost.
    pub dropout_probability: f64,
    /// Disturbances.
    pub disturbances: Vec<MagneticDisturbance>,
    /// Delay from time of validity to publication: uniform in [min, max], ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// Sensor id.
    pub sensor: u32,
}

impl Default for MagnetometerConfig {
    fn default() -> Self {
        Self {
            rate_hz: 20.0,
            noise_std_ut: 0.5,
            declination_deg: 3.5,
            inclination_deg: 64.5,
            strength_ut: 48.5,
            rotation: Matrix3::identity(),
            dropout_probability: 0.0,
            disturbances: Vec::new(),
            delay_min_ns: 1_000_000,
            delay_max_ns: 5_000_000,
            sensor: 0,
        }
    }
}

/// Simulated magnetometer samples (an endless iterator); the memory is the Earth's field, µT ENU.
pub type MagnetometerSim = SensorSim<MagnetometerConfig>;

impl Sensor for MagnetometerConfig {
    const KIND: SampleKind = SampleKind::Magnetometer;
    const SALT: u64 = 0x6d61_6700;
    type Memory = Vector3<f64>;

    super::arrival::usual_timing!();

    fn memory(&self) -> Vector3<f64> {
        Vector3::from(earth_field_enu(self.declination_deg, self.inclination_deg, self.strength_ut))
    }

    fn read(&self, mut r: Reading<'_, Vector3<f64>>) -> Option<Sample> {
        let c = self;
        let noise = r.normal3() * c.noise_std_ut;
        if r.lost(c.dropout_probability) {
            return None;
        }
        let t_s = r.t_s;
        let added: Vector3<f64> = c
            .disturbances
            .iter()
            .filter(|d| (d.at_s..d.at_s + d.duration_s).contains(&t_s))
            .map(|d| Vector3::from(d.field_ut))
            .sum();
        let body = r.truth.attitude.inverse_transform_vector(&(*r.memory + added));
        let field = c.rotation.transpose() * body + noise;
        let var = c.noise_std_ut * c.noise_std_ut;
        let cov = [var, 0.0, 0.0, 0.0, var, 0.0, 0.0, 0.0, var];
        Some(Sample::Magnetometer(MagnetometerSample::new(r.t_ns, c.sensor, r.seq, field.into(), cov)))
    }
}



/// `fusion-sim`'s flags of the magnetometer.
#[cfg(feature = "cli")]
#[derive(clap::Args, Clone, Debug)]
pub struct MagnetometerFlags {
    /// Magnetometer rate, Hz; 0: none (sensor id 0; `--dropouts` applies).
    #[arg(long, default_value_t = 0.0)]
    pub magnetometer_rate: f64,
    /// Magnetometer noise per axis, µT.
    #[arg(long, default_value_t = 0.5)]
    pub magnetometer_noise_ut: f64,
    /// The magnetometer's mount, `AXES:ROLL,PITCH,YAW` (degrees; body ← sensor),
    /// as `--imu-mount`.
    #[arg(long, default_value = "flu:0,0,0")]
    pub magnetometer_mount: String,
    /// The Earth's field: declination (degrees east), inclination (degrees
    /// down), strength (µT) (default: Munich, 3.5,64.5,48.5).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub magnetic_field: Option<Vec<f64>>,
    /// A magnetic disturbance, `AT:SECONDS:MICROTESLA`: a field of MICROTESLA
    /// pointing east adds to the Earth's from AT s into the drive for SECONDS (a
    /// passing lorry, a steel bridge). Repeatable.
    #[arg(long, value_name = "AT:SECONDS:MICROTESLA")]
    pub magnetic_disturbance: Vec<String>,
}

#[cfg(feature = "cli")]
impl super::flags::KindFlags for fusion_shared::MagnetometerSample {
    type Flags = MagnetometerFlags;

    fn apply(
        f: &MagnetometerFlags,
        drive: &super::flags::DriveFlags,
        _all: &super::flags::KindsFlags,
        c: &mut super::ScenarioConfig,
    ) -> anyhow::Result<()> {
        use std::sync::Arc;
        if f.magnetometer_rate <= 0.0 {
            return Ok(());
        }
        let defaults = MagnetometerConfig::default();
        let field = super::flags::triple("--magnetic-field", f.magnetic_field.as_deref())?.unwrap_or([
            defaults.declination_deg,
            defaults.inclination_deg,
            defaults.strength_ut,
        ]);
        let disturbances = f.magnetic_disturbance.iter().map(|d| parse_disturbance(d)).collect::<Result<_, _>>()?;
        c.aiding.push(Arc::new(MagnetometerConfig {
            rate_hz: f.magnetometer_rate,
            noise_std_ut: f.magnetometer_noise_ut,
            declination_deg: field[0],
            inclination_deg: field[1],
            strength_ut: field[2],
            rotation: super::flags::parse_mount("--magnetometer-mount", &f.magnetometer_mount)?,
            dropout_probability: drive.dropouts,
            disturbances,
            ..defaults
        }));
        Ok(())
    }
}

/// A magnetic disturbance, `AT:SECONDS:MICROTESLA` (a field pointing east).
#[cfg(feature = "cli")]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::trajectory::CarTrajectory;

    /// Without noise the sensor reads the Earth's field turned into its axes:
    /// strength kept, the mount undone; a disturbance adds its field; dropouts
    /// leave gaps in the sequence numbers.
    #[test]
    fn it_reads_the_field_in_its_axes() {
        let trajectory = CarTrajectory::new(3);
        let rotation = nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 1.0).into_inner();
        let disturbance = MagneticDisturbance { at_s: 1.0, duration_s: 1.0, field_ut: [0.0, 0.0, -20.0] };
        let c = MagnetometerConfig { noise_std_ut: 0.0, rotation, disturbances: vec![disturbance], ..Default::default() };
        let earth = Vector3::from(earth_field_enu(3.5, 64.5, 48.5));
        for a in MagnetometerSim::new(trajectory.clone(), c.clone(), 0, 1).take(60) {
            let Sample::Magnetometer(m) = a.sample else { panic!() };
            let t = m.header.t_ns as f64 * 1e-9;
            let truth = trajectory.at(t);
            let world = truth.attitude * (rotation * Vector3::from(m.field_ut));
            let disturbed = (1.0..2.0).contains(&t);
            let expected = if disturbed { earth + Vector3::new(0.0, 0.0, -20.0) } else { earth };
            assert!((world - expected).norm() < 1e-9, "{t}: {world} vs {expected}");
        }
        let lossy = MagnetometerConfig { dropout_probability: 0.5, ..c };
        let seqs: Vec<u64> = MagnetometerSim::new(trajectory, lossy, 0, 1).take(100).map(|a| a.sample.header().seq).collect();
        assert!(seqs.windows(2).any(|w| w[1] > w[0] + 1) && seqs.windows(2).all(|w| w[1] > w[0]));
        assert!(seqs[99] > 150 && seqs[99] < 260, "about half lost: {}", seqs[99]);
    }
}
