//! One check over the kind list ([`super::each_observation`], generated from
//! it): each kind's observation of the INS error state ([`Observe`]) against
//! central differences of its residual, `H = −∂y/∂δx`. The state moves, tilted
//! and turning, with every auxiliary state (the odometry scale, a barometer's
//! bias, an estimated map frame: 21 error states), and each kind's sensor is
//! off the IMU and, where its samples are in its own axes, rotated. Each
//! sample's attitude is the one the state predicts, where the rotation
//! residuals are linear in the error; the other components are off it.

#![allow(non_snake_case)]

use fusion_shared::geodesy::Datum;
use fusion_shared::{
    AttitudeSample, BarometerSample, GeodeticSample, HeadingSample, ImuSample, MagnetometerSample, OdometrySample,
    PoseSample, PositionSample, SampleKind, TwistSample, VelocitySample,
};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::{Measurement, Observe, attitude, pose};
use crate::frames::{Frames, SensorConfig};
use crate::model::Model;
use crate::model::StepOutcome;
use crate::model::ins::observability::heading;
use crate::model::ins::tests_support::{model, moving, numeric_jacobian, set_aux_value};
use crate::model::ins::{AuxStates, InsModel, InsState, N, OdometryScale};

/// Every auxiliary state.
const E: usize = N + 6;

/// A sample of a kind near what sensor `id` of its kind reads in `s`.
pub(super) trait Example {
    /// The sample.
    fn example(m: &InsModel<E>, s: &InsState<E>) -> Self;
}

/// The model, the state, and the kinds checked so far.
pub(super) struct Checker {
    model: InsModel<E>,
    state: InsState<E>,
    /// Kinds whose observation was checked.
    pub checked: Vec<&'static str>,
    /// The sample of each kind, in kind order.
    pub samples: Vec<fusion_shared::Sample>,
}

/// The sensor of each kind: its id is the kind's code.
const SENSORS: &str = r#"
[[sensor]]
name = "imu"
id = 1
kinds = ["imu"]
[[sensor]]
name = "fix"
id = 2
kinds = ["position"]
lever_arm_m = [0.5, -0.2, 1.1]
[[sensor]]
name = "doppler"
id = 3
kinds = ["velocity"]
lever_arm_m = [0.5, -0.2, 1.1]
[[sensor]]
name = "gnss"
id = 4
kinds = ["geodetic"]
lever_arm_m = [-0.4, 0.3, 1.4]
[[sensor]]
name = "wheels"
id = 5
kinds = ["odometry"]
lever_arm_m = [-0.3, 0.1, -0.2]
[[sensor]]
name = "dual antenna"
id = 6
kinds = ["heading"]
[[sensor]]
name = "compass"
id = 7
kinds = ["magnetometer"]
axes = "frd"
rotation_rpy_deg = [2, -3, 90]
[sensor.magnetic]
declination_deg = 3.5
inclination_deg = 64.5
strength_ut = 48.5
[[sensor]]
name = "visual odometry"
id = 8
kinds = ["twist"]
rotation_rpy_deg = [0, 10, 5]
lever_arm_m = [0.8, 0.1, 1.0]
[[sensor]]
name = "baro"
id = 9
kinds = ["barometer"]
lever_arm_m = [0.2, 0.0, 0.6]
[[sensor]]
name = "slam"
id = 10
kinds = ["pose"]
axes = "frd"
rotation_rpy_deg = [0, 10, 0]
lever_arm_m = [0.8, 0, 1.2]
[[sensor]]
name = "ahrs"
id = 11
kinds = ["attitude"]
rotation_rpy_deg = [1, -2, 30]
"#;

/// Where the datum is (the geodetic fixes').
fn datum() -> Datum {
    Datum::new(48.137, 11.575, 519.0).unwrap()
}

impl Checker {
    /// The model with every auxiliary state and [`SENSORS`], at a moving state
    /// whose attitude is known (σ 0.01 rad) and whose auxiliary states are set.
    pub(super) fn new() -> Self {
        #[derive(serde::Deserialize)]
        struct Sensors {
            sensor: Vec<SensorConfig>,
        }
        let sensors: Sensors = toml::from_str(SENSORS).unwrap();
        let frames = Frames::from_config(Some(datum()), &sensors.sensor, Default::default(), &super::Kinds).unwrap();
        let (every, _) = super::aux_states(AuxStates::default().with_odometry_scale(OdometryScale::default()), &frames);
        let model = model().with_frames(frames).with_aux::<E>(every).unwrap();
        let mut state = moving(&model);
        let mut P = state.filter().P();
        for i in 6..9 {
            P[(i, i)] = 1e-4;
        }
        state.filter_mut().set_state(nalgebra::SVector::zeros(), P).unwrap();
        set_aux_value(&mut state, N, 1.03);
        set_aux_value(&mut state, N + 1, 2.5);
        state.aux_progress_mut().mark_set(fusion_shared::snapshot::aux::BARO_BIAS);
        for (k, v) in [0.3, 10.0, -5.0, 1.0].into_iter().enumerate() {
            set_aux_value(&mut state, N + 2 + k, v);
        }
        state.aux_progress_mut().kinds.pose.aligned(0);
        Self { model, state, checked: Vec::new(), samples: Vec::new() }
    }

    /// Checks kind `T` (`name`): an observation with `H = −∂y/∂δx`; none
    /// for the IMU alone; and what it declares it observes
    /// ([`Measurement::observes`]) against its `H`: it sees the turn of the
    /// whole trajectory about world up, `N` of [`crate::model::ins::observability`],
    /// exactly when it declares a heading or a horizontal position (a kind
    /// that gives one and does not say so fails here).
    pub(super) fn kind<
        T: Observe<InsModel<E>, M, E> + Measurement + Example + Into<fusion_shared::Sample> + Copy,
        const M: usize,
    >(
        &mut self,
        name: &'static str,
    ) {
        let (m, s) = (&self.model, &self.state);
        let sample = T::example(m, s);
        self.samples.push(sample.into());
        let Some(o) = sample.observe(m, s) else {
            assert_eq!(name, "imu", "{name}: no observation where its fusion updates with one");
            return;
        };
        let numeric = numeric_jacobian(s, |x| sample.observe(m, x).unwrap().y);
        let scale = o.H.amax().max(1.0);
        assert!(o.H.amax() > 0.0, "{name}: H is zero");
        assert!((o.H + numeric).amax() < 1e-6 * scale, "{name}: H + ∂y/∂δx =\n{}", o.H + numeric);
        assert!(nalgebra::Cholesky::new(o.R).is_some(), "{name}: R is not a covariance");
        let mut turn = heading::<E>(&s.q());
        turn.fixed_rows_mut::<3>(0).copy_from(&Vector3::z().cross(&s.p()));
        turn.fixed_rows_mut::<3>(3).copy_from(&Vector3::z().cross(&s.v()));
        let sees_turn = (o.H * turn).amax() > 1e-9 * scale * turn.amax();
        let mounted = m.frames().sensors().iter().find(|x| x.kind == T::KIND).expect("every kind has its sensor");
        let declared = mounted.observes.heading || mounted.observes.horizontal_position;
        assert_eq!(
            declared, sees_turn,
            "{name}: declares a heading or a horizontal position: {declared}; its H sees the turn about up: {sees_turn}"
        );
        self.checked.push(name);
    }
}

/// A diagonal 3×3 covariance, row-major.
fn diag3(v: f64) -> [f64; 9] {
    [v, 0.0, 0.0, 0.0, v, 0.0, 0.0, 0.0, v]
}

/// `q` as `[w, x, y, z]`: the reading of a predicted attitude (where the
/// rotation residual `Log(Ŝᵀ Z)` is linear in the error; away from it, by a
/// factor `J_r⁻¹(y) ≈ I + ½[y]×`).
fn wxyz(q: UnitQuaternion<f64>) -> [f64; 4] {
    let c = q.quaternion().coords;
    [c[3], c[0], c[1], c[2]]
}

impl Example for ImuSample {
    fn example(_: &InsModel<E>, _: &InsState<E>) -> Self {
        ImuSample::new(0, 1, 0, [0.3, 4.8, 9.8], [0.01, -0.02, 0.4])
    }
}

impl Example for PositionSample {
    fn example(_: &InsModel<E>, s: &InsState<E>) -> Self {
        PositionSample::new(0, 2, 0, (s.p() + Vector3::new(0.3, -0.2, 1.0)).into(), diag3(0.25))
    }
}

impl Example for VelocitySample {
    fn example(_: &InsModel<E>, s: &InsState<E>) -> Self {
        VelocitySample::new(0, 3, 0, (s.v() + Vector3::new(0.1, 0.2, -0.1)).into(), diag3(0.01))
    }
}

impl Example for GeodeticSample {
    fn example(_: &InsModel<E>, s: &InsState<E>) -> Self {
        let (lat, lon, h) = datum().to_geodetic((s.p() + Vector3::new(-0.2, 0.4, 1.3)).into());
        GeodeticSample::new(0, 4, 0, lat, lon, h, diag3(0.25))
    }
}

impl Example for OdometrySample {
    fn example(_: &InsModel<E>, _: &InsState<E>) -> Self {
        OdometrySample::new(0, 5, 0, 12.4, 0.01)
    }
}

impl Example for HeadingSample {
    fn example(_: &InsModel<E>, _: &InsState<E>) -> Self {
        HeadingSample::new(0, 6, 0, 2.25, 1e-3)
    }
}

impl Example for MagnetometerSample {
    fn example(_: &InsModel<E>, _: &InsState<E>) -> Self {
        MagnetometerSample::new(0, 7, 0, [18.0, 6.0, 42.0], diag3(0.25))
    }
}

impl Example for TwistSample {
    fn example(_: &InsModel<E>, _: &InsState<E>) -> Self {
        TwistSample::new(0, 8, 0, [11.8, 0.3, 1.9], [0.02, 0.05, 0.38], TwistSample::diagonal_cov([0.05; 3], [0.01; 3]))
    }
}

impl Example for BarometerSample {
    fn example(_: &InsModel<E>, s: &InsState<E>) -> Self {
        // The pressure 0.7 m above the state's altitude plus its bias (the
        // inverse of the International Standard Atmosphere's pressure altitude).
        let h = s.p().z + 2.5 + 0.7;
        let pa = 101_325.0 * (1.0 - h / 44_330.77).powf(1.0 / 0.190263);
        BarometerSample::new(0, 9, 0, pa, 100.0)
    }
}

impl Example for PoseSample {
    fn example(m: &InsModel<E>, s: &InsState<E>) -> Self {
        let frame = pose::MapFrame::estimated(s).unwrap();
        let (p, S, _) = pose::pose(s, m.frames().mount(SampleKind::Pose, 10), &frame);
        let q = UnitQuaternion::from_matrix(&S);
        let at = p + Vector3::new(0.2, -0.1, 0.05);
        PoseSample::new(0, 10, 0, at.into(), wxyz(q), TwistSample::diagonal_cov([0.05; 3], [0.01; 3]), 0)
    }
}

impl Example for AttitudeSample {
    fn example(m: &InsModel<E>, s: &InsState<E>) -> Self {
        let C = m.frames().mount(SampleKind::Attitude, 11).rotation;
        let (S, _): (Matrix3<f64>, _) = attitude::full(s, &C);
        AttitudeSample::new(0, 11, 0, wxyz(UnitQuaternion::from_matrix(&S)), diag3(1e-4))
    }
}

/// Every kind but the IMU has an observation, and each `H` is its residual's
/// Jacobian (up to sign).
#[test]
fn every_kinds_jacobian_matches_central_differences() {
    let mut checker = Checker::new();
    super::each_observation(&mut checker);
    assert_eq!(checker.checked.len(), SampleKind::COUNT - 1, "checked: {:?}", checker.checked);
}

/// The `linear` model fuses the IMU, the position and geodetic fixes and the
/// velocity ([`crate::fuses!`]); every other kind it refuses by default: not
/// accepted (a configured sensor fails the start-up), and a sample leaves the
/// state as it was.
#[test]
fn the_linear_model_refuses_every_kind_it_does_not_list() {
    use crate::measurement::Steps;
    use crate::model::linear::LinearModel;
    let mut checker = Checker::new();
    super::each_observation(&mut checker);
    let linear = LinearModel::new(0.3, [0.0; 6], [1.0; 6], None).unwrap().with_frames(Frames::new(Some(datum())));
    let fused = [SampleKind::Imu, SampleKind::Position, SampleKind::Velocity, SampleKind::Geodetic];
    assert_eq!(checker.samples.len(), SampleKind::COUNT);
    for sample in &checker.samples {
        let kind = sample.kind();
        assert_eq!(LinearModel::accepts(kind), fused.contains(&kind), "{kind:?}");
        let mut s = linear.initial_state();
        linear.step(&mut s, &fusion_shared::Sample::Imu(ImuSample::new(0, 1, 0, [0.0; 3], [0.0; 3])));
        let before = s;
        let outcome = linear.step(&mut s, sample);
        if fused.contains(&kind) {
            assert_ne!(outcome, StepOutcome::Refused, "{kind:?}");
        } else {
            assert_eq!((outcome, s), (StepOutcome::Refused, before), "{kind:?}");
        }
    }
}

/// The `linear` model's observations ([`Observe`] for it: the position and
/// geodetic fixes and the velocity): `H = −∂y/∂x` by central differences,
/// and each is what the model updates with: the NIS of the sample's step is
/// `yᵀ (H P Hᵀ + R)⁻¹ y` of its observation.
#[test]
fn the_linear_models_observations_are_what_it_updates_with() {
    use crate::measurement::Steps;
    use crate::model::linear::{LinearModel, LinearState, N as L};
    let linear = LinearModel::new(0.3, [0.0; 6], [1.0; 6], None).unwrap().with_frames(Frames::new(Some(datum())));
    let mut s = linear.initial_state();
    linear.step(&mut s, &fusion_shared::Sample::Imu(ImuSample::new(0, 1, 0, [0.0; 3], [0.0; 3])));
    let x = nalgebra::SVector::<f64, L>::from([3.0, -1.5, 0.4, 1.2, 0.3, -0.1]);
    let P = nalgebra::SMatrix::<f64, L, L>::from_fn(|i, j| if i == j { 0.5 + 0.1 * i as f64 } else { 0.05 });
    s.filter_mut().set_state(x, P).unwrap();
    let (lat, lon, h) = datum().to_geodetic([2.6, -1.1, 1.5]);
    fn check<T: Observe<LinearModel, 3, L> + Into<fusion_shared::Sample> + Copy>(
        name: &str,
        linear: &LinearModel,
        s: &LinearState,
        sample: T,
    ) {
        let o = sample.observe(linear, s).expect("an observation");
        let mut numeric = nalgebra::SMatrix::<f64, 3, L>::zeros();
        for j in 0..L {
            let at = |d: f64| {
                let mut x = *s;
                let mut moved = *s.filter().x();
                moved[j] += d;
                x.filter_mut().set_state(moved, s.filter().P()).unwrap();
                sample.observe(linear, &x).unwrap().y
            };
            numeric.set_column(j, &((at(1e-6) - at(-1e-6)) / 2e-6));
        }
        assert!((o.H + numeric).amax() < 1e-8, "{name}: H + ∂y/∂x =\n{}", o.H + numeric);
        let S = o.H * s.filter().P() * o.H.transpose() + o.R;
        let expected = (o.y.transpose() * S.try_inverse().unwrap() * o.y)[0];
        let mut after = *s;
        let StepOutcome::Fused { nis } = linear.step(&mut after, &sample.into()) else { panic!("{name}: not fused") };
        assert!((nis - expected).abs() < 1e-9 * expected.max(1.0), "{name}: NIS {nis}, of its observation {expected}");
    }
    check("position", &linear, &s, PositionSample::new(0, 2, 0, [3.4, -1.9, 1.0], diag3(0.25)));
    check("velocity", &linear, &s, VelocitySample::new(0, 3, 0, [1.0, 0.6, 0.1], diag3(0.04)));
    check("geodetic", &linear, &s, GeodeticSample::new(0, 4, 0, lat, lon, h, diag3(0.25)));
}
