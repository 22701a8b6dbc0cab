//! Barometer: static pressure, fused as a pressure altitude against the height
//! with a bias state.
//!
//! The pressure `p` becomes the International Standard Atmosphere's altitude
//! `z = h_ISA(p)` ([`fusion_shared::sample::pressure_altitude_m`]) with variance
//! `(dh/dp)² σ_p²`. With the sensor's lever arm `l` (its port) and the bias `b`
//! (the pressure altitude of the world frame's origin plus the weather's
//! offset; an auxiliary state, [`crate::model::ins::aux`]):
//!
//! ```text
//! z = p_u + (R l)_u + b + n,   n ~ N(0, (dh/dp)² σ_p²)
//! H = [ e₃ᵀ   0   −e₃ᵀ R [l]×   0   0   …   1 (at b) ]
//! ```
//!
//! (local attitude error: `R Exp(δθ) l ≈ R l − R [l]× δθ`.) The first sample
//! sets `b = z − p_u − (R l)_u` with its covariance and its correlation with the
//! height (`aux::augment`, [`crate::model::ins::aux`]) and fuses nothing: the height
//! does not jump; from then on the barometer holds the height between GNSS
//! fixes (and through an outage it is the height's only source), and GNSS
//! fixes teach the bias.
//!
//! Ground effect and rotor wash: near the ground (below about one rotor
//! diameter) and in fast flight a multirotor's own airflow moves the static
//! pressure by up to several metres of altitude; the bias' random walk follows
//! slow changes only. Mount the port away from the airflow, or raise the
//! sample's variance when near the ground (see the user guide, sensor kinds).
//!
//! - `ins`: the update above, Joseph form, gated, injected and reset.
//! - `linear`: refused (no bias state); a config naming a barometer is refused
//!   at start-up.
//!
//! Validation: finite; pressure in (0, [`MAX_PRESSURE_PA`]] Pa; variance > 0
//! and below `MAX_PRESSURE_PA²`. Not required by the health; stale after 1 s
//! once seen.

#![allow(non_snake_case)]

pub mod settings;
pub use settings::BarometerConfig;

use fusion_shared::{BarometerSample, MAX_PRESSURE_PA, SampleKind, pressure_altitude_m, pressure_altitude_slope};
use nalgebra::{Matrix1, SMatrix, SVector, Vector1, Vector3};

use super::{Fuse, Limits, Measurement, Needed, Observation, Observe, Rejection, finite};
use crate::model::ins::aux::{AuxPrior, augment};
use crate::model::ins::{InsModel, InsState};
use crate::model::{Model, StepOutcome};
use crate::setting::ConfigError;

/// Standard deviation given the bias before its barometer's first sample sets
/// it, m (nothing observes it before).
const UNSET_BIAS_STD_M: f64 = 100.0;

impl Measurement for BarometerSample {
    const RANK: u8 = 2;
    /// A height: neither the heading, nor the horizontal position, nor the
    /// tilt.
    const LOCKOUT: super::LockoutRule = super::LockoutRule::Resets;
    const NEEDS_ENTRY: Option<&'static str> = Some("its entry makes its bias state at start-up");
    const TIMEOUT_NS: u64 = 1_000_000_000;
    const NEEDED: Option<Needed> = None;
    type Settings = BarometerConfig;
    const TABLE: Option<&'static str> = Some("barometer");
    const TABLE_DOC: &'static str = r#"#   [sensor.barometer]                     # barometer, optional: its bias state (set at the first sample)
#   bias_random_walk_m = 0.05              # how fast the weather moves it, m/sqrt(s)
"#;

    /// The defaults without the table.
    fn settings(table: Option<&toml::Value>, key: &dyn Fn(&str) -> String) -> Result<Option<BarometerConfig>, ConfigError> {
        super::read_table_or_default::<BarometerConfig>(table, key)?.check(key).map(Some)
    }

    /// The bias: zero and uninformed until the first sample sets it, then a
    /// random walk.
    fn aux_priors(settings: &BarometerConfig) -> Vec<AuxPrior> {
        vec![AuxPrior { initial: 0.0, std: UNSET_BIAS_STD_M, random_walk: settings.bias_random_walk_m }]
    }

    fn validate(&self, _: &Limits) -> Result<(), Rejection> {
        finite(&[self.pressure_pa, self.var_pa2])?;
        if !(self.pressure_pa > 0.0 && self.pressure_pa <= MAX_PRESSURE_PA) {
            return Err(Rejection::OutOfRange);
        }
        if !(self.var_pa2 > 0.0 && self.var_pa2 < MAX_PRESSURE_PA * MAX_PRESSURE_PA) {
            return Err(Rejection::VarianceNotPositive);
        }
        Ok(())
    }
}

/// `h` and `H` of the pressure altitude of a port at lever arm `l`, with the
/// bias at error-state index `bias` (`None`: without it, as it is set).
pub fn altitude<const D: usize>(s: &InsState<D>, l: &Vector3<f64>, bias: Option<usize>) -> (f64, SMatrix<f64, 1, D>) {
    let R = s.q().to_rotation_matrix().into_inner();
    let arm = R * l;
    let Rl = R * l.cross_matrix();
    let mut H = SMatrix::<f64, 1, D>::zeros();
    H[(0, 2)] = 1.0;
    for k in 0..3 {
        H[(0, 6 + k)] = -Rl[(2, k)];
    }
    let mut h = s.p().z + arm.z;
    if let Some(b) = bias {
        H[(0, b)] = 1.0;
        h += s.aux_value(b);
    }
    (h, H)
}

impl<const D: usize> Fuse<InsModel<D>> for BarometerSample {
    fn fuse(&self, model: &InsModel<D>, s: &mut InsState<D>) -> (StepOutcome, Option<SVector<f64, D>>) {
        let Some(r) = reading(self, model, s) else { return (StepOutcome::Refused, None) };
        if !s.aux_progress().is_set(r.bit) {
            return (set_bias(s, &r), None);
        }
        let o = observation(s, &r);
        model.update_residual(s, &o.y, &o.H, &o.R)
    }
}

/// What a sample of a configured barometer is fused with.
struct Reading {
    /// Its bias's bit ([`fusion_shared::snapshot::aux::BARO_BIASES`]).
    bit: u32,
    /// Its bias's error-state index.
    bias: usize,
    /// Its port's lever arm.
    arm: Vector3<f64>,
    /// The pressure altitude, m.
    z: f64,
    /// Its variance.
    R: Matrix1<f64>,
}

/// The sample's [`Reading`]; `None` for a barometer that is not configured
/// (it has no bias state).
fn reading<const D: usize>(sample: &BarometerSample, model: &InsModel<D>, s: &InsState<D>) -> Option<Reading> {
    let sensor = sample.header.sensor;
    let bit = model.aux().first_bit(SampleKind::Barometer, sensor)?;
    let bias = s.aux_index(bit)?;
    let arm = model.frames().mount(SampleKind::Barometer, sensor).lever_arm;
    let slope = pressure_altitude_slope(sample.pressure_pa);
    let R = Matrix1::new(slope * slope * sample.var_pa2);
    Some(Reading { bit, bias, arm, z: pressure_altitude_m(sample.pressure_pa), R })
}

/// Sets the bias of the reading's barometer from its first sample, by state
/// augmentation (see the module doc): `Propagated` (nothing fused), or
/// `Refused`.
fn set_bias<const D: usize>(s: &mut InsState<D>, r: &Reading) -> StepOutcome {
    let (h, H) = altitude(s, &r.arm, None);
    if augment(s, r.bias, &Vector1::new(r.z - h), &(-H), &Matrix1::new(1.0), &r.R).is_err() {
        return StepOutcome::Refused;
    }
    StepOutcome::Propagated
}

/// `y = z − (p_z + (R l)_z + b)` of [`altitude`], `z` the pressure altitude
/// and `b` the reading's barometer's bias.
fn observation<const D: usize>(s: &InsState<D>, r: &Reading) -> Observation<1, D> {
    let (h, H) = altitude(s, &r.arm, Some(r.bias));
    Observation { y: Vector1::new(r.z - h), H, R: r.R }
}

/// `observation` once the first sample of its barometer set the bias;
/// `None` before, and for a barometer without the bias state.
impl<const D: usize> Observe<InsModel<D>, 1, D> for BarometerSample {
    fn observe(&self, model: &InsModel<D>, s: &InsState<D>) -> Option<Observation<1, D>> {
        let r = reading(self, model, s)?;
        s.aux_progress().is_set(r.bit).then(|| observation(s, &r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ins::N;

    /// The bias' error-state index when it is the only auxiliary state.
    const ONLY_BIAS: usize = N;
    use crate::model::ins::tests_support::{model, moving_state, numeric_jacobian, set_aux_value};
    use crate::model::ins::AuxStates;
    use fusion_shared::snapshot::aux;
    use crate::model::ins::tests_support::barometer;

    /// An `ins` model with barometer 0 and its bias state.
    fn baro_model() -> InsModel<{ N + 1 }> {
        let sensor = toml::from_str("name = \"baro\"\nid = 0\nkinds = [\"barometer\"]\n").unwrap();
        let frames = crate::frames::Frames::from_config(None, &[sensor], Default::default(), &crate::measurement::Kinds).unwrap();
        let aux = barometer(AuxStates::default(), 0);
        model().with_frames(frames).with_aux(aux).unwrap()
    }

    #[test]
    fn every_bad_value_has_its_reason() {
        let limits = Limits { accel_range_mps2: 160.0, gyro_range_radps: 35.0 };
        let baro = |p, var| BarometerSample::new(0, 0, 0, p, var).validate(&limits);
        assert_eq!(baro(95_000.0, 4.0), Ok(()));
        assert_eq!(baro(0.0, 4.0), Err(Rejection::OutOfRange));
        assert_eq!(baro(-5.0, 4.0), Err(Rejection::OutOfRange));
        assert_eq!(baro(2e5, 4.0), Err(Rejection::OutOfRange));
        assert_eq!(baro(f64::NAN, 4.0), Err(Rejection::NonFinite));
        assert_eq!(baro(95_000.0, 0.0), Err(Rejection::VarianceNotPositive));
        assert_eq!(baro(95_000.0, f64::INFINITY), Err(Rejection::NonFinite));
    }

    /// Against central differences, with the bias state and a lever arm.
    #[test]
    fn jacobian_matches_numerical_differentiation() {
        let m = baro_model();
        let mut s = m.initial_state();
        let moving = moving_state();
        let x = InsModel::x_of(&moving);
        s.set(moving.p(), moving.v(), moving.q(), moving.b_a(), moving.b_g());
        assert_eq!(&InsModel::x_of(&s)[..16], x);
        set_aux_value(&mut s, ONLY_BIAS, 12.5);
        let l = Vector3::new(0.3, -0.2, 0.4);
        let (h, H) = altitude(&s, &l, Some(ONLY_BIAS));
        let numeric = numeric_jacobian(&s, |x| Vector1::new(altitude(x, &l, Some(ONLY_BIAS)).0));
        assert!((H - numeric).amax() < 1e-7, "{}", H - numeric);
        assert!((h - (s.p().z + (s.q() * l).z + 12.5)).abs() < 1e-12);
        assert_eq!(H[(0, ONLY_BIAS)], 1.0);
    }

    /// The first sample sets the bias and moves nothing; the next ones fuse,
    /// and a pressure that falls (the vehicle climbs) raises the height.
    #[test]
    fn the_first_sample_sets_the_bias_and_the_next_ones_fuse() {
        let m = baro_model();
        let mut s = m.initial_state();
        let z0 = s.p().z;
        let first = BarometerSample::new(0, 0, 0, 95_000.0, 4.0);
        assert_eq!(first.fuse(&m, &mut s).0, StepOutcome::Propagated);
        assert_eq!(s.p().z, z0, "the height does not jump");
        let b = s.aux_value(ONLY_BIAS);
        assert!((b - pressure_altitude_m(95_000.0)).abs() < 1e-9, "{b}");
        // Its variance: the height's plus the sample's; correlated with the height.
        let P = s.filter().P();
        let slope = pressure_altitude_slope(95_000.0);
        assert!((P[(ONLY_BIAS, ONLY_BIAS)] - (P[(2, 2)] + slope * slope * 4.0)).abs() < 1e-9);
        assert!((P[(ONLY_BIAS, 2)] + P[(2, 2)]).abs() < 1e-12);
        // Time passes: the height is uncertain again (2 m), the bias is not.
        let mut P = s.filter().P();
        P[(2, 2)] += 4.0;
        s.filter_mut().set_state(SVector::zeros(), P).unwrap();
        // 12 Pa less: about 1 m higher.
        let climbed = BarometerSample::new(0, 0, 1, 95_000.0 - 12.0, 4.0);
        assert!(matches!(climbed.fuse(&m, &mut s).0, StepOutcome::Fused { .. }));
        assert!(s.p().z > z0 + 0.3, "{}", s.p().z - z0);
    }

    /// Without the bias state, or from a barometer that is not the configured
    /// one (whose bias the state is), a sample is refused.
    #[test]
    fn without_its_bias_state_it_is_refused() {
        let m = model();
        let mut s = m.initial_state();
        let before = s;
        assert_eq!(BarometerSample::new(0, 0, 0, 95_000.0, 4.0).fuse(&m, &mut s).0, StepOutcome::Refused);
        assert_eq!(s, before);
        let m = baro_model();
        let mut s = m.initial_state();
        let before = s;
        assert_eq!(BarometerSample::new(0, 7, 0, 95_000.0, 4.0).fuse(&m, &mut s).0, StepOutcome::Refused);
        assert_eq!(s, before);
    }

    /// Two barometers: each has its bias (the second's bit follows the
    /// first's), set from its own first sample, and each fuses against its own.
    #[test]
    fn each_barometer_has_its_bias() {
        let sensors: Vec<crate::frames::SensorConfig> = (0..2)
            .map(|id| toml::from_str(&format!("name = \"baro{id}\"\nid = {id}\nkinds = [\"barometer\"]\n")).unwrap())
            .collect();
        let frames = crate::frames::Frames::from_config(None, &sensors, Default::default(), &crate::measurement::Kinds).unwrap();
        let (aux, _) = crate::measurement::aux_states(AuxStates::default(), &frames);
        assert_eq!(aux, barometer(barometer(AuxStates::default(), 0), 1), "the barometer's own priors");
        let m = model().with_frames(frames).with_aux::<{ N + 2 }>(aux).unwrap();
        let mut s = m.initial_state();
        assert_eq!((s.aux_index(aux::BARO_BIAS), s.aux_index(aux::BARO_BIASES[1])), (Some(N), Some(N + 1)));
        let (low, high) = (95_000.0, 95_000.0 - 60.0);
        assert_eq!(BarometerSample::new(0, 0, 0, low, 4.0).fuse(&m, &mut s).0, StepOutcome::Propagated);
        assert!(s.aux_progress().is_set(aux::BARO_BIAS) && !s.aux_progress().is_set(aux::BARO_BIASES[1]));
        assert_eq!(BarometerSample::new(0, 1, 0, high, 4.0).fuse(&m, &mut s).0, StepOutcome::Propagated);
        let (b0, b1) = (s.aux_value(N), s.aux_value(N + 1));
        assert!((b1 - b0 - (pressure_altitude_m(high) - pressure_altitude_m(low))).abs() < 1e-9, "{b0} {b1}");
        // Each reads what it read: no innovation, against its own bias.
        for (sensor, p) in [(0, low), (1, high)] {
            let out = BarometerSample::new(0, sensor, 1, p, 4.0).fuse(&m, &mut s).0;
            assert!(matches!(out, StepOutcome::Fused { nis } if nis < 1e-12), "{sensor}: {out:?}");
        }
        assert_eq!(BarometerSample::new(0, 2, 0, low, 4.0).fuse(&m, &mut s).0, StepOutcome::Refused, "unconfigured");
    }
}
