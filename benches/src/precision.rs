//! Single against double precision, Joseph against UDU: the models' filters run
//! in `f32` and `f64`, in both forms, over the same drive, and compared with the
//! `f64` Joseph run.
//!
//! - `linear`: the whole model in the scalar type: `x⁻ = F x + G a`,
//!   `P⁻ = F P Fᵀ + Q` with the model's `F`, `G`, `Q`
//!   ([`LinearModel::transition_and_noise`]), position fixes with `H = [I 0]`.
//! - `ins`: the error-state filter in the scalar type; the nominal state is
//!   integrated in `f64` by the model's own strapdown step
//!   ([`InsModel::error_step`]), and each correction is injected by the model
//!   ([`InsModel::inject_error`]).
//!
//! Samples are fused in timestamp order (what the engine's rewind gives), without
//! gating, so that every run sees the same measurements.

#![allow(non_snake_case)]

use fusion_daemon::filter::{Form, KalmanFilter, UpdateOptions};
use fusion_daemon::model::advance_time;
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::linear::LinearModel;
use fusion_shared::Sample;
use nalgebra::{Cholesky, Matrix3, RealField, SMatrix, SVector, Vector3};

/// A scalar type the study runs in.
pub trait Real: RealField + Copy {
    /// Name (`"f32"`, `"f64"`).
    const NAME: &'static str;
    /// The value as `f64` (exact).
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    const NAME: &'static str = "f32";
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

impl Real for f64 {
    const NAME: &'static str = "f64";
    fn to_f64(self) -> f64 {
        self
    }
}

fn cast<T: Real, const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> SMatrix<T, R, C> {
    m.map(|v| T::from_subset(&v))
}

fn back<T: Real, const R: usize, const C: usize>(m: &SMatrix<T, R, C>) -> SMatrix<f64, R, C> {
    m.map(Real::to_f64)
}

/// One model's filter in one scalar type and form, fed a drive in time order.
pub trait StudyRun {
    /// Processes one sample.
    fn step(&mut self, sample: &Sample);
    /// Position estimate, m.
    fn position(&self) -> Vector3<f64>;
    /// Covariance, as the filter holds it (composed from the factors in the UDU
    /// form), in `f64`, and its size.
    fn covariance(&self) -> (Vec<f64>, usize);
    /// Steps the filter refused (a non-finite result or an indefinite `S`).
    fn refused(&self) -> u64;
}

/// The `linear` model's filter in `T`.
#[derive(Clone)]
pub struct LinearRun<'a, T: Real> {
    model: &'a LinearModel,
    kf: KalmanFilter<T, 6>,
    t: Option<u64>,
    accel: Vector3<f64>,
    refused: u64,
}

impl<'a, T: Real> LinearRun<'a, T> {
    /// From the model's initial state, in `form`.
    pub fn new(model: &'a LinearModel, form: Form) -> Self {
        let f = *model.initial_filter();
        let kf = KalmanFilter::new(cast(f.x()), cast(&f.P())).and_then(|k| k.with_form(form));
        Self { model, kf: kf.expect("the model's start is valid"), t: None, accel: Vector3::zeros(), refused: 0 }
    }
}

impl<T: Real> StudyRun for LinearRun<'_, T> {
    fn step(&mut self, sample: &Sample) {
        if let Some(dt) = advance_time(&mut self.t, sample.t_ns()) {
            let (F, Q) = self.model.transition_and_noise(dt);
            let (_, G) = LinearModel::transition(dt);
            let bu = G * self.accel;
            if self.kf.predict_with_input(&cast(&F), &cast(&bu), &cast(&Q)).is_err() {
                self.refused += 1;
            }
        }
        match sample {
            Sample::Imu(i) => self.accel = Vector3::from(i.accel_mps2),
            Sample::Position(p) => {
                let mut H = SMatrix::<f64, 3, 6>::zeros();
                H.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
                let (z, R) = (Vector3::from(p.pos_m), Matrix3::from_row_slice(&p.cov_m2));
                if self.kf.update(&cast(&z), &cast(&H), &cast(&R), UpdateOptions::default()).is_err() {
                    self.refused += 1;
                }
            }
            _ => {}
        }
    }
    fn position(&self) -> Vector3<f64> {
        back(&self.kf.x().fixed_rows::<3>(0).into_owned())
    }
    fn covariance(&self) -> (Vec<f64>, usize) {
        (back(&self.kf.P()).as_slice().to_vec(), 6)
    }
    fn refused(&self) -> u64 {
        self.refused
    }
}

/// The `ins` model's error-state filter in `T` (nominal state in `f64`).
#[derive(Clone)]
pub struct InsRun<'a, T: Real> {
    model: &'a InsModel,
    nominal: [f64; 16],
    kf: KalmanFilter<T, 15>,
    t: Option<u64>,
    held: Option<(Vector3<f64>, Vector3<f64>)>,
    refused: u64,
}

impl<'a, T: Real> InsRun<'a, T> {
    /// From the model's initial state, in `form`.
    pub fn new(model: &'a InsModel, form: Form) -> Self {
        let P0 = model.initial_filter().P();
        let kf = KalmanFilter::new(SVector::zeros(), cast(&P0)).and_then(|k| k.with_form(form));
        let kf = kf.expect("the model's start is valid");
        Self { model, nominal: model.initial_nominal(), kf, t: None, held: None, refused: 0 }
    }
}

impl<T: Real> StudyRun for InsRun<'_, T> {
    fn step(&mut self, sample: &Sample) {
        if let Some(dt) = advance_time(&mut self.t, sample.t_ns())
            && let Some((f, w)) = self.held
        {
            let (nominal, F, Q) = self.model.error_step(&self.nominal, f, w, dt);
            match self.kf.predict(&cast(&F), &cast(&Q)) {
                Ok(()) => self.nominal = nominal,
                Err(_) => self.refused += 1,
            }
        }
        match sample {
            Sample::Imu(i) => self.held = Some((Vector3::from(i.accel_mps2), Vector3::from(i.gyro_radps))),
            Sample::Position(p) => {
                let z = Vector3::from(p.pos_m);
                let y = z - Vector3::new(self.nominal[0], self.nominal[1], self.nominal[2]);
                let mut H = SMatrix::<f64, 3, 15>::zeros();
                H.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
                let R = Matrix3::from_row_slice(&p.cov_m2);
                let options = UpdateOptions::default();
                if self.kf.update_nonlinear(&cast(&y), &SVector::zeros(), &cast(&H), &cast(&R), options).is_err() {
                    self.refused += 1;
                    return;
                }
                let dx = back(self.kf.x());
                let G = cast::<T, 15, 15>(&InsModel::inject_error(&mut self.nominal, &dx));
                let half = T::from_subset(&0.5);
                self.kf.reset_transform(
                    |P| {
                        let m = G * *P * G.transpose();
                        *P = (m + m.transpose()) * half;
                    },
                    || G,
                );
            }
            _ => {}
        }
    }
    fn position(&self) -> Vector3<f64> {
        Vector3::new(self.nominal[0], self.nominal[1], self.nominal[2])
    }
    fn covariance(&self) -> (Vec<f64>, usize) {
        (back(&self.kf.P()).as_slice().to_vec(), 15)
    }
    fn refused(&self) -> u64 {
        self.refused
    }
}

/// How one run ended against the `f64` Joseph run of the same drive.
#[derive(Debug, Clone, Default)]
pub struct Comparison {
    /// `"f32 udu"`, …
    pub name: String,
    /// Samples processed.
    pub steps: u64,
    /// Position difference at the end, m.
    pub end_position_diff_m: f64,
    /// Largest position difference at any fix, m.
    pub max_position_diff_m: f64,
    /// Covariance difference at the end, relative to the largest entry.
    pub end_covariance_rel_diff: f64,
    /// Largest relative difference of a position standard deviation at any fix.
    pub max_position_sd_rel_diff: f64,
    /// Fixes after which `P` was checked.
    pub checks: u64,
    /// Of those, how often `P` was not positive definite (no Cholesky factor in
    /// `f64` of the matrix the filter holds, or a diagonal entry ≤ 0).
    pub not_positive_definite: u64,
    /// Smallest eigenvalue of the correlation matrix of `P` seen (1 for
    /// uncorrelated states, 0 for singular, negative for indefinite).
    pub min_correlation_eigenvalue: f64,
    /// Steps the filter refused.
    pub refused: u64,
    /// Position error against the truth at the end, m.
    pub end_position_error_m: f64,
}

/// Smallest eigenvalue of the correlation matrix `D^-½ P D^-½`, or −∞ if a
/// variance is not positive.
fn min_correlation_eigenvalue(p: &[f64], n: usize) -> f64 {
    let d: Vec<f64> = (0..n).map(|i| p[i * n + i]).collect();
    if d.iter().any(|v| v.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)) {
        return f64::NEG_INFINITY;
    }
    let c = nalgebra::DMatrix::from_fn(n, n, |r, k| p[r * n + k] / (d[r] * d[k]).sqrt());
    c.symmetric_eigenvalues().min()
}

/// Runs every run over `samples` (time-ordered) in lockstep, the first being the
/// reference, and compares each with it at every position fix and at the end.
/// `truth_at(t)` is the true position.
pub fn compare(
    runs: &mut [(String, Box<dyn StudyRun + '_>)],
    samples: &[Sample],
    truth_at: impl Fn(u64) -> Vector3<f64>,
) -> Vec<Comparison> {
    let mut out: Vec<Comparison> = runs
        .iter()
        .map(|(name, _)| Comparison { name: name.clone(), min_correlation_eigenvalue: 1.0, ..Default::default() })
        .collect();
    for s in samples {
        for (_, run) in runs.iter_mut() {
            run.step(s);
        }
        if !matches!(s, Sample::Position(_)) {
            continue;
        }
        let reference = (runs[0].1.position(), runs[0].1.covariance());
        for ((_, run), c) in runs.iter().zip(out.iter_mut()) {
            let (p, n) = run.covariance();
            c.checks += 1;
            let m = nalgebra::DMatrix::from_row_slice(n, n, &p);
            let pd = (0..n).all(|i| m[(i, i)] > 0.0) && Cholesky::new(m).is_some();
            c.not_positive_definite += u64::from(!pd);
            c.min_correlation_eigenvalue = c.min_correlation_eigenvalue.min(min_correlation_eigenvalue(&p, n));
            c.max_position_diff_m = c.max_position_diff_m.max((run.position() - reference.0).norm());
            let sd_rel = (0..3)
                .map(|i| {
                    let (a, b) = (p[i * n + i].max(0.0).sqrt(), reference.1.0[i * n + i].sqrt());
                    (a - b).abs() / b
                })
                .fold(0.0, f64::max);
            c.max_position_sd_rel_diff = c.max_position_sd_rel_diff.max(sd_rel);
        }
    }
    let t_end = samples.last().map_or(0, Sample::t_ns);
    let (ref_pos, (ref_p, _)) = (runs[0].1.position(), runs[0].1.covariance());
    let scale = ref_p.iter().fold(0f64, |m, v| m.max(v.abs()));
    for ((_, run), c) in runs.iter().zip(out.iter_mut()) {
        let (p, _) = run.covariance();
        c.steps = samples.len() as u64;
        c.end_position_diff_m = (run.position() - ref_pos).norm();
        c.end_covariance_rel_diff = p.iter().zip(&ref_p).fold(0f64, |m, (a, b)| m.max((a - b).abs())) / scale;
        c.refused = run.refused();
        c.end_position_error_m = (run.position() - truth_at(t_end)).norm();
    }
    out
}

/// The four runs of a model: `f64` Joseph (the reference), `f64` UDU, `f32`
/// Joseph, `f32` UDU.
pub fn linear_runs(model: &LinearModel) -> Vec<(String, Box<dyn StudyRun + '_>)> {
    vec![
        ("f64 joseph".into(), Box::new(LinearRun::<f64>::new(model, Form::Joseph))),
        ("f64 udu".into(), Box::new(LinearRun::<f64>::new(model, Form::Udu))),
        ("f32 joseph".into(), Box::new(LinearRun::<f32>::new(model, Form::Joseph))),
        ("f32 udu".into(), Box::new(LinearRun::<f32>::new(model, Form::Udu))),
    ]
}

/// The four runs of the `ins` model, as [`linear_runs`].
pub fn ins_runs(model: &InsModel) -> Vec<(String, Box<dyn StudyRun + '_>)> {
    vec![
        ("f64 joseph".into(), Box::new(InsRun::<f64>::new(model, Form::Joseph))),
        ("f64 udu".into(), Box::new(InsRun::<f64>::new(model, Form::Udu))),
        ("f32 joseph".into(), Box::new(InsRun::<f32>::new(model, Form::Joseph))),
        ("f32 udu".into(), Box::new(InsRun::<f32>::new(model, Form::Udu))),
    ]
}

/// A drive's samples in the order the engine fuses them.
pub fn time_ordered(scenario: &fusion_client::sim::Scenario) -> Vec<Sample> {
    let mut samples: Vec<Sample> = scenario.arrivals.iter().map(|a| a.sample).collect();
    samples.sort_by_key(|s| (s.t_ns(), s.kind() as u32));
    samples
}

/// The comparisons as a Markdown table.
pub fn table(rows: &[Comparison]) -> String {
    let mut t = String::from(
        "| run | end Δp | max Δp | end ΔP (rel.) | max Δσ_p (rel.) | not PD | min corr. eig. | refused | end error vs truth |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for c in rows {
        t.push_str(&format!(
            "| {} | {:.3e} m | {:.3e} m | {:.2e} | {:.2e} | {} of {} | {:.2e} | {} | {:.3} m |\n",
            c.name,
            c.end_position_diff_m,
            c.max_position_diff_m,
            c.end_covariance_rel_diff,
            c.max_position_sd_rel_diff,
            c.not_positive_definite,
            c.checks,
            c.min_correlation_eigenvalue,
            c.refused,
            c.end_position_error_m
        ));
    }
    t
}

/// The drives of the study.
pub mod drives {
    use fusion_client::sim::{ImuConfig, ImuOutput, Scenario, ScenarioConfig};
    use fusion_daemon::config::Config;
    use fusion_daemon::model::ins::InsModel;
    use fusion_daemon::model::linear::LinearModel;

    /// A `linear` drive of `seconds`: 200 Hz IMU (σ 0.1 m/s²), 10 Hz fixes with
    /// standard deviation `fix_sd_m`, and its model (σ_a 0.3 m/s², P₀ 10⁴ m² and
    /// 10² m²/s²: a start far less certain than the fixes).
    pub fn linear(seconds: f64, fix_sd_m: f64, seed: u64) -> (Scenario, LinearModel) {
        let mut c = ScenarioConfig { seed, duration_s: seconds, ..Default::default() };
        c.imu.rate_hz = 200.0;
        c.imu.accel_noise_std = 0.1;
        c.position.noise_std_m = fix_sd_m;
        c.position.vertical_noise_std_m = fix_sd_m;
        let config = Config::parse(
            "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\n\
             initial_covariance_diagonal = [1e4,1e4,1e4,100,100,100]\n",
        )
        .expect("valid config");
        (Scenario::generate(&c), LinearModel::from_config(&config).expect("a linear config"))
    }

    /// An `ins` drive of `seconds`: 200 Hz body-frame IMU with automotive MEMS
    /// noise and turn-on biases, 10 Hz fixes of standard deviation `fix_sd_m`, and
    /// its model, started at the truth with the prior of the consistency tests.
    pub fn ins(seconds: f64, fix_sd_m: f64, seed: u64) -> (Scenario, InsModel) {
        const SIGMA0: [f64; 5] = [0.5, 0.3, 0.02, 0.05, 0.0005];
        let mut c = ScenarioConfig { seed, duration_s: seconds, ..Default::default() };
        c.imu = ImuConfig {
            accel_bias_std: SIGMA0[3],
            gyro_bias_std: SIGMA0[4],
            ..ImuConfig::kalibr(200.0, 0.02, 0.001, 0.001, 1e-5)
        };
        c.imu_output = ImuOutput::BodySpecificForce;
        c.position.noise_std_m = fix_sd_m;
        c.position.vertical_noise_std_m = fix_sd_m;
        let scenario = Scenario::generate(&c);
        let t0 = scenario.arrivals.iter().map(|a| a.sample.t_ns()).min().unwrap_or(0);
        let truth = scenario.truth_at(t0);
        let q = truth.attitude.quaternion().coords;
        let (p, v) = (truth.pos_m, truth.vel_mps);
        let x0 = [p.x, p.y, p.z, v.x, v.y, v.z, q[3], q[0], q[1], q[2], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let list = |v: &[f64]| v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(", ");
        let p0: Vec<f64> = SIGMA0.iter().flat_map(|s| [s * s; 3]).collect();
        let config = Config::parse(&format!(
            "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
             accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
             initial_state = [{}]\ninitial_covariance_diagonal = [{}]\n",
            list(&x0),
            list(&p0)
        ))
        .expect("valid config");
        (scenario, InsModel::from_config(&config).expect("an ins config"))
    }
}
