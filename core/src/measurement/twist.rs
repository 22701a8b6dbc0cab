//! Twist: the linear and angular velocity of a sensor's frame in its own axes,
//! from visual or lidar odometry.
//!
//! With the sensor's mounting `C = C_bs` (body ← sensor) and lever arm `l`, the
//! attitude `R`, the body rate `ω = ω_m − b_g` (the held IMU rate less the gyro
//! bias) and `v_b = Rᵀ v`, the sensor's frame moves with
//!
//! ```text
//! z = [ Cᵀ (v_b + ω × l) ]  + n,   n ~ N(0, Σ)   (Σ: the sample's 6×6 covariance)
//!     [ Cᵀ ω             ]
//!
//! H = [ 0   CᵀRᵀ   Cᵀ[v_b]×   0   Cᵀ[l]× ]
//!     [ 0   0      0          0   −Cᵀ    ]
//! ```
//!
//! (local attitude error `R_trueᵀ ≈ (I − [δθ]×) Rᵀ`, so `δ(Rᵀ v) = Rᵀ δv + [v_b]× δθ`;
//! `ω_true = ω − δb_g`, so `δ(ω × l) = [l]× δb_g`; Groves 2013, eq. 14.121 and
//! §16.2.1, as for wheel odometry). The held IMU rate carries the gyro's white
//! noise, which enters `h` too: with the gyro noise density `σ_g` over the IMU's
//! sampling interval `Δt` (the mean of `n` IMUs: `σ_g²/n`),
//! `R = Σ + G (σ_g²/(n Δt)) Gᵀ`, `G = [−Cᵀ[l]×; Cᵀ]`. The linear part observes the
//! velocity and, through the attitude, heading and tilt; the angular part the gyro
//! bias.
//!
//! - `ins`: the update above, Joseph form, gated, injected and reset; refused
//!   until roll and pitch are known to [`nonholonomic::MAX_ATTITUDE_SD`] (as
//!   wheel odometry, [`nonholonomic::tilt_known`]: a body-frame velocity needs
//!   the tilt, not the heading). While the vehicle stands, `ω` is held at 0 and the bias
//!   columns are 0.
//! - `linear`: refused (no attitude); a config naming a twist sensor is refused
//!   at start-up.
//!
//! Validation, of the components `[sensor.twist] fuse` selects (all six
//! without it; the others are never looked at): finite; |linear| ≤
//! [`MAX_SPEED_MPS`], |angular| ≤ `[validation] gyro_range_radps`; their
//! covariance block symmetric positive definite, a variance below
//! [`VARIANCE_FLOOR`](super::components::VARIANCE_FLOOR) (a driver's 0) taken
//! as it. Not required by the health; stale after 1 s once seen.

#![allow(non_snake_case)]

pub mod settings;
pub use settings::TwistConfig;

use fusion_shared::{SampleKind, TwistSample};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3, Vector6};

use super::odometry::MAX_SPEED_MPS;
use super::components::{selected_covariance, selected_finite};
use super::{Fuse, Limits, Measurement, Needed, Observation, Observe, Rejection};
use crate::frames::Mount;
use crate::model::ins::nonholonomic;
use crate::model::ins::{InsModel, InsState};
use crate::model::{Model, StepOutcome};
use crate::setting::ConfigError;

impl Measurement for TwistSample {
    const RANK: u8 = 2;
    /// A body-frame velocity and rate: the tilt, neither the heading nor the
    /// position.
    fn observes(_: Option<&TwistConfig>) -> super::Observes {
        super::Observes { tilt: true, ..super::Observes::NOTHING }
    }
    const LOCKOUT: super::LockoutRule = super::LockoutRule::Resets;
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = None;
    const ROTATED: bool = true;
    type Settings = TwistConfig;
    const TABLE: Option<&'static str> = Some("twist");
    const TABLE_DOC: &'static str = r#"#   [sensor.twist]                         # twist, optional
#   fuse = ["vx", "vy", "vz", "vroll", "vpitch", "vyaw"]   # the components fused (default all)
"#;

    fn settings(table: Option<&toml::Value>, key: &dyn Fn(&str) -> String) -> Result<Option<TwistConfig>, ConfigError> {
        table.map(|t| super::read_table(t, key)).transpose()
    }

    fn fused_dim(settings: &TwistConfig) -> usize {
        settings.fuse.count()
    }

    const VALIDATES_AS_SELECTED: bool = true;

    fn validate(&self, limits: &Limits) -> Result<(), Rejection> {
        self.validate_as(limits, None)
    }

    /// The selected components only (`[sensor.twist] fuse`; all six without
    /// it): finite, within range, their covariance block positive definite
    /// with a zero variance floored ([`selected_covariance`]). What is not
    /// selected (a drone driver's zero variances, NaN) is never looked at.
    fn validate_as(&self, limits: &Limits, settings: Option<&TwistConfig>) -> Result<(), Rejection> {
        let mask = settings.map_or([true; 6], |c| c.fuse.mask);
        selected_finite(&self.linear_mps, &self.angular_radps, &mask)?;
        let pick = |v: &[f64; 3], from: usize| Vector3::from_fn(|i, _| if mask[from + i] { v[i] } else { 0.0 });
        if pick(&self.linear_mps, 0).norm() > MAX_SPEED_MPS
            || pick(&self.angular_radps, 3).norm() > limits.gyro_range_radps
        {
            return Err(Rejection::OutOfRange);
        }
        selected_covariance(&self.cov, &mask).map(drop)
    }
}

/// `h` and `H` of the twist of a sensor mounted at `mount`.
pub fn twist<const D: usize>(s: &InsState<D>, mount: &Mount) -> (Vector6<f64>, SMatrix<f64, 6, D>) {
    let R = s.q().to_rotation_matrix().into_inner();
    let Ct = mount.rotation.transpose();
    let l = mount.lever_arm;
    let v_b = R.transpose() * s.v();
    let w = InsModel::<D>::body_rate(s);
    let mut h = Vector6::zeros();
    h.fixed_rows_mut::<3>(0).copy_from(&(Ct * (v_b + w.cross(&l))));
    h.fixed_rows_mut::<3>(3).copy_from(&(Ct * w));
    let mut H = SMatrix::<f64, 6, D>::zeros();
    H.fixed_view_mut::<3, 3>(0, 3).copy_from(&(Ct * R.transpose()));
    H.fixed_view_mut::<3, 3>(0, 6).copy_from(&(Ct * v_b.cross_matrix()));
    // While standing `ω` is 0 whatever `b_g` is ([`InsModel::body_rate`]).
    if !s.standing() {
        H.fixed_view_mut::<3, 3>(0, 12).copy_from(&(Ct * l.cross_matrix()));
        H.fixed_view_mut::<3, 3>(3, 12).copy_from(&(-Ct));
    }
    (h, H)
}

/// The gyro's white noise in `h` (see the module doc), 6×6; zero while standing
/// and before the IMU's interval is known.
pub(super) fn gyro_noise<const D: usize>(model: &InsModel<D>, s: &InsState<D>, mount: &Mount) -> SMatrix<f64, 6, 6> {
    let (Some(dt), Some((_, _, n))) = (s.held_imu().interval_s(), s.held_imu().mean()) else { return SMatrix::zeros() };
    if s.standing() {
        return SMatrix::zeros();
    }
    let q = model.noise().gyroscope_noise_density.powi(2) / (f64::from(n) * dt);
    let Ct = mount.rotation.transpose();
    let mut G = SMatrix::<f64, 6, 3>::zeros();
    G.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-Ct * mount.lever_arm.cross_matrix()));
    G.fixed_view_mut::<3, 3>(3, 0).copy_from(&Ct);
    G * (Matrix3::identity() * q) * G.transpose()
}

impl<const D: usize> Fuse<InsModel<D>> for TwistSample {
    fn fuse(&self, model: &InsModel<D>, s: &mut InsState<D>) -> (StepOutcome, Option<SVector<f64, D>>) {
        let Some(o) = self.observe(model, s) else { return (StepOutcome::Refused, None) };
        let keep = super::settings::<TwistSample>(model.frames(), self.header.sensor).map_or([true; 6], |c| c.fuse.mask);
        model.update_residual_selected(s, &o.y, &o.H, &o.R, &keep)
    }
}

/// `y = z − h` of [`twist`], `R` the sample's plus the gyro's noise carried by
/// the lever arm (`gyro_noise`); all six components (a sensor's
/// `[sensor.twist] fuse` selects among them when fused; the sample's
/// covariance is its selected block, a zero variance floored:
/// [`selected_covariance`]). `None` while the tilt is unknown: body-frame
/// velocities need the tilt, not the heading.
impl<const D: usize> Observe<InsModel<D>, 6, D> for TwistSample {
    fn observe(&self, model: &InsModel<D>, s: &InsState<D>) -> Option<Observation<6, D>> {
        if !nonholonomic::tilt_known(s) {
            return None;
        }
        let mount = model.frames().mount(SampleKind::Twist, self.header.sensor);
        let mut z = Vector6::zeros();
        z.fixed_rows_mut::<3>(0).copy_from(&Vector3::from(self.linear_mps));
        z.fixed_rows_mut::<3>(3).copy_from(&Vector3::from(self.angular_radps));
        let (h, H) = twist(s, mount);
        let mask = super::settings::<TwistSample>(model.frames(), self.header.sensor).map_or([true; 6], |c| c.fuse.mask);
        let R = selected_covariance(&self.cov, &mask).ok()? + gyro_noise(model, s, mount);
        Some(Observation { y: z - h, H, R })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Axes;
    use crate::model::ins::tests_support::{model, moving, moving_scaled_state, moving_state, numeric_jacobian};

    fn cov() -> [f64; 36] {
        TwistSample::diagonal_cov([0.05; 3], [0.01; 3])
    }

    #[test]
    fn every_bad_value_has_its_reason() {
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        let twist = |lin, ang, cov| TwistSample::new(0, 0, 0, lin, ang, cov).validate(&limits);
        assert_eq!(twist([10.0, 0.0, 0.0], [0.0, 0.0, 0.3], cov()), Ok(()));
        assert_eq!(twist([f64::NAN, 0.0, 0.0], [0.0; 3], cov()), Err(Rejection::NonFinite));
        assert_eq!(twist([0.0; 3], [0.0, f64::INFINITY, 0.0], cov()), Err(Rejection::NonFinite));
        assert_eq!(twist([200.0, 0.0, 0.0], [0.0; 3], cov()), Err(Rejection::OutOfRange));
        assert_eq!(twist([0.0; 3], [0.0, 0.0, 40.0], cov()), Err(Rejection::OutOfRange));
        let mut asym = cov();
        asym[1] = 1e-3;
        assert_eq!(twist([0.0; 3], [0.0; 3], asym), Err(Rejection::CovarianceNotSymmetric));
        let mut not_spd = cov();
        (not_spd[5], not_spd[30]) = (0.1, 0.1);
        assert_eq!(twist([0.0; 3], [0.0; 3], not_spd), Err(Rejection::CovarianceNotPositiveDefinite));
    }

    /// Against central differences, for a mounted sensor (rotated FRD axes, a
    /// lever arm), with and without the odometry scale state.
    #[test]
    fn jacobian_matches_numerical_differentiation() {
        let mount = Mount::new(Axes::Frd, [0.1, -0.2, 1.3], [0.4, -0.3, 0.8]);
        let s = moving_state();
        let (h, H) = twist(&s, &mount);
        let numeric = numeric_jacobian(&s, |x| twist(x, &mount).0);
        assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
        let w = InsModel::body_rate(&s);
        let v_b = s.q().inverse_transform_vector(&s.v());
        let expected_linear = mount.rotation.transpose() * (v_b + w.cross(&mount.lever_arm));
        assert!((h.fixed_rows::<3>(0) - expected_linear).norm() < 1e-12);
        let s = moving_scaled_state();
        let numeric = numeric_jacobian(&s, |x| twist(x, &mount).0);
        assert!((twist(&s, &mount).1 - numeric).amax() < 1e-7);
    }

    /// The gyro's noise in `h`: the angular block gets `σ_g²/Δt` per axis, the
    /// linear block `|l|²`-sized terms across the lever arm.
    #[test]
    fn the_held_rates_noise_is_in_r() {
        let m = model();
        let mut s = moving_state();
        let mount = Mount::new(Axes::Flu, [0.0; 3], [0.0, 0.0, 1.0]);
        assert_eq!(gyro_noise(&m, &s, &mount), SMatrix::<f64, 6, 6>::zeros(), "interval unknown");
        crate::model::ins::tests_support::hold_imu(&mut s, 5_000_000, Vector3::new(0.3, 4.8, 9.8), Vector3::new(0.01, -0.02, 0.4));
        let q = gyro_noise(&m, &s, &mount);
        let expected = 0.001f64.powi(2) / 0.005;
        assert!((q[(5, 5)] - expected).abs() < 1e-15 && (q[(3, 3)] - expected).abs() < 1e-15);
        // l along z: x and y linear components see the rate noise about y and x.
        assert!((q[(0, 0)] - expected).abs() < 1e-15 && q[(2, 2)].abs() < 1e-18, "{q}");
    }

    /// Before the attitude is known the sample is refused; afterwards a twist of
    /// the true motion leaves the state nearly where it is, and one that says
    /// the vehicle goes 1 m/s faster moves the velocity towards it.
    #[test]
    fn it_is_fused_once_the_attitude_is_known() {
        let m = model();
        let mut s = moving_state();
        let (h, _) = twist(&s, &Mount::IDENTITY);
        let sample = |lin: Vector3<f64>| {
            TwistSample::new(1, 0, 0, lin.into(), h.fixed_rows::<3>(3).into_owned().into(), cov())
        };
        let before = s;
        assert_eq!(sample(h.fixed_rows::<3>(0).into()).fuse(&m, &mut s), (StepOutcome::Refused, None));
        assert_eq!(s, before);
        s.filter_mut().reset_error(|P| (6..9).for_each(|i| P[(i, i)] = 1e-4));
        let faster = h.fixed_rows::<3>(0) + Vector3::new(1.0, 0.0, 0.0);
        let speed = s.v().norm();
        let (out, _) = sample(faster).fuse(&m, &mut s);
        assert!(matches!(out, StepOutcome::Fused { .. }), "{out:?}");
        assert!(s.v().norm() > speed + 0.5, "{} -> {}", speed, s.v().norm());
    }

    /// `[sensor.twist] fuse = ["vx", "vyaw"]`: a sample whose sideways speed
    /// is 5 m/s off (a skid-steer's wheels do not measure it) is fused for its
    /// forward speed and yaw rate alone, the NIS of those two; all six
    /// components, the same sample is gated.
    #[test]
    fn selected_components_alone_are_fused() {
        let toml = "name = \"wheels\"\nid = 4\nkinds = [\"twist\"]\n[twist]\nfuse = [\"vx\", \"vyaw\"]\n";
        let sensor: crate::frames::SensorConfig = ::toml::from_str(toml).unwrap();
        let frames = crate::frames::Frames::from_config(None, &[sensor], Default::default(), &crate::measurement::Kinds).unwrap();
        let gate = crate::filter::ChiSquareGate::new(0.999).ok();
        let mut x0 = [0.0; 16];
        x0[6] = 1.0;
        let m = InsModel::new(crate::model::ins::tests_support::NOISE, 9.80665, x0, [1.0; 15], gate, 0)
            .unwrap()
            .with_frames(frames);
        let mut s = moving(&m);
        s.filter_mut().reset_error(|P| (0..15).for_each(|i| P[(i, i)] = 1e-4));
        let (h, _) = twist(&s, &Mount::IDENTITY);
        let mut z = h;
        z[0] += 0.01;
        z[1] += 5.0;
        let sample = |sensor| TwistSample::new(1, sensor, 0, z.fixed_rows::<3>(0).into(), z.fixed_rows::<3>(3).into(), cov());
        let before = s;
        let (out, _) = sample(4).fuse(&m, &mut s);
        let StepOutcome::Fused { nis } = out else { panic!("{out:?}") };
        assert!(nis < 1.0, "the forward speed's 0.01 m/s and the yaw rate alone: {nis}");
        let lateral = |s: &InsState| s.q().inverse_transform_vector(&s.v()).y;
        assert!((lateral(&s) - lateral(&before)).abs() < 1e-3, "{} -> {}", lateral(&before), lateral(&s));
        // Sensor 5 has no selection: all six, gated.
        let mut all = before;
        assert!(matches!(sample(5).fuse(&m, &mut all).0, StepOutcome::Gated { .. }));
        // Unknown or no components are configuration errors.
        for (fuse, said) in [("[\"vw\"]", "unknown component \"vw\""), ("[]", "selects no component")] {
            let toml = format!("name = \"w\"\nid = 4\nkinds = [\"twist\"]\n[twist]\nfuse = {fuse}\n");
            let sensor = ::toml::from_str::<crate::frames::SensorConfig>(&toml).unwrap();
            let e = crate::frames::Frames::from_config(None, &[sensor], Default::default(), &crate::measurement::Kinds)
                .unwrap_err()
                .to_string();
            assert!(e.contains("sensor[0] (\"w\").twist"), "{e}");
            assert!(e.contains(said) && e.contains("vx, vy, vz, vroll, vpitch, vyaw"), "{e}");
        }
    }
}

