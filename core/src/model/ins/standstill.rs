//! Standstill: detected from the IMU and the speed, and while it lasts a
//! zero-velocity and zero-rate update and a held attitude. A pseudo-measurement
//! of the `ins` model, like the motion constraint ([`super::nonholonomic`]).
//!
//! **Detection** (the moving-variance and angular-rate-energy tests of Skog,
//! Händel, Nilsson and Rantakokko, "Zero-velocity detection — an algorithm
//! evaluation", IEEE T-BME 57(11), 2010, normalised by the configured noise):
//! the IMU samples are summed over windows of `window_ns`. A window of `n`
//! samples over `D` seconds from `k` IMUs has a per-IMU rate `r = n / (k D)`, so
//! one sample at rest has the white-noise variance `σ_a² r` per accelerometer
//! axis and `σ_g² r` per gyro axis (density² × rate). The window is *quiet* when
//!
//! ```text
//! T_f = s_f² / (σ_a² r) ≤ γ,   T_ω = s_ω² / (σ_g² r) ≤ γ,
//! T_m = Σᵢ (ω̄ᵢ − b_g,ᵢ)² / (σ_g² r / n + P_bg,ii) ≤ χ²₃(1 − 10⁻⁶) = 30.66,
//! T_a = aᵀ Σ_a⁻¹ a ≤ 30.66,   a = R (f̄ − b_a) + g,   Σ_a = σ_a² r / n I + J P Jᵀ,
//! J = [R [f̄ − b_a]×, R] on (δθ, δb_a)
//! ```
//!
//! with `s_f²`, `s_ω²` the per-axis sample variances of the body specific force
//! and rate over the window, `ω̄`, `f̄` their means, `γ` = `imu_threshold` and `P`
//! the error covariance. The variance tests see vibration and jolts. The mean
//! tests see what a smooth motion leaves: `T_m` a steady turn (its rate varies
//! little), `T_a` a smooth acceleration (a car braking to a stop or pulling away
//! accelerates smoothly, so `s_f²` hardly rises, but `a`, the acceleration the
//! mean specific force implies, is not zero). At rest each is χ²₃ (a mean of `n`
//! white samples less estimates whose covariance is `P`), so a standing vehicle
//! fails one once in about 10⁶ windows; with a 200 Hz MEMS IMU a turn of 0.7°/s
//! or an acceleration of a few tenths of a m/s² fails them. An IMU alone
//! cannot tell a stop from a smooth cruise (a simulated one, or a real one on a
//! smooth road), so standing also needs the speed: every odometry speed of the
//! window (or, if none came in it, the last one, if it came within the last two
//! windows) at most `odometry_speed_mps`; else the
//! estimated speed `|v|` at most `max_speed_mps`.
//!
//! **Wheels reading exactly 0** in a window (every odometry speed of it, and at
//! least one) are a ground robot's best evidence of rest: encoders that do not
//! move. The mean tests then give way, since they fail for an estimate whose
//! biases are not learnt yet (a gyro bias outside its σ makes `T_m` fail at
//! rest, and with it every standstill that would have taught the bias): the
//! wheels stand for `T_a` (no translation), and `T_m` becomes a bound on the
//! bias-corrected mean rate, every axis at most [`WHEELS_STILL_MAX_RATE_RADPS`]
//! (2°/s: above a MEMS gyro's turn-on bias, below a skid-steer robot's turn on
//! the spot, which its forward speed of 0 does not show). The variance tests
//! stay.
//!
//! **While standing**, at the end of every quiet window, one update of six rows
//! (Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
//! Systems*, 2nd ed. 2013, §15.3.1 zero-velocity and §15.3.2 zero-angular-rate
//! updates):
//!
//! ```text
//! ZUPT   0 = v + n_v          y = −v            H = [0 I 0 0 0]   R = σ_zv² I
//! ZARU   ω̄ = b_g + n_ω̄        y = ω̄ − b_g       H = [0 0 0 0 I]   R = (σ_g² r / n) I
//! ```
//!
//! (`σ_zv` = `velocity_std_mps`; the ZARU noise is that of the mean of `n` white
//! samples). It is not gated: the detection is its evidence, and the velocity
//! error it must remove is largest when the vehicle has just stopped after a
//! stretch without GNSS (where a χ² gate would refuse every update, and the
//! drift would go on). A filter error (a covariance that is not positive
//! definite) ends the standstill.
//!
//! After the first of a stop (a full update: the velocity error the vehicle
//! stopped with, left by the braking, does carry information on the yaw), the
//! updates do not move the **yaw**: nothing at rest observes it, yet the
//! correlations the drive left between the yaw and the velocity and the biases
//! would let every zero-velocity update nudge it (by a few hundredths of a degree
//! each, zero on average: over 20 simulated stops the RMS yaw error was the same
//! before and after a minute of such updates, while the yaw wandered by up to
//! 0.45°). The world yaw error is `ψ = uᵀ δθ` with `u = Rᵀ e_z` (the up axis in the
//! body frame), so the attitude rows of the gain are projected off `u`,
//! `K_θ ← (I − u uᵀ) K_θ`, and the covariance takes the Joseph form with that gain,
//! `P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ`, which is exact for any gain: the yaw is
//! a *consider* direction of the Schmidt–Kalman filter (Schmidt 1966; Brink,
//! "Partial-update Schmidt–Kalman filter", J. Guid. Control Dyn. 40(9), 2017).
//! Its variance and its correlations stay honest; only its value is held.
//! And the attitude is **held**: a standing vehicle does not turn, so the
//! propagation uses `ω = 0` (the gyro is not integrated), adds no attitude noise
//! and no `δθ`–`δb_g` coupling (the `−I dt` block of `F` is 0): the yaw, which
//! nothing observes at rest, does not wander with the gyro's white noise and bias
//! error. For the same reason the `δv`–`δθ` block of `F` is linearised at the
//! specific force of a body at rest, `Rᵀ(−g)`, instead of at the noisy sample:
//! `A = −R [Rᵀ(−g)]× = −[−g]× R` has no yaw column, while the horizontal noise of
//! a sample would couple the yaw error into the velocity at random, and the
//! zero-velocity updates would then "observe" the yaw and move it (the spurious
//! information of an EKF linearised at noisy values; Huang, Mourikis and
//! Roumeliotis, "Observability-based rules for designing consistent EKF SLAM
//! estimators", IJRR 29(5), 2010). So the yaw and its variance stay what the
//! first update of the stop left.
//!
//! **Motion ends it** at once: an odometry speed above `odometry_speed_mps`, or an
//! IMU sample whose bias-corrected rate exceeds [`EXIT_SIGMAS`] standard
//! deviations of one sample at rest on any axis (either starts a new window, so a
//! standstill starts again only after a whole window without motion); otherwise
//! the next window that is not quiet.
//!
//! Everything it keeps is in the filter state ([`Detector`]), so a rewind replays
//! it exactly.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use super::error_state::{ProcessNoise, Transition};
use crate::model::StepOutcome;
use crate::model::ins::{InsModel, InsState, inject_and_reset};

/// Rows of the standstill update: three of velocity, three of gyro bias.
pub const INNOVATION_DIM: usize = 6;

/// The bound of the mean tests `T_m` and `T_a`: χ²₃ at 1 − 10⁻⁶ (tables: 30.664).
pub const MEAN_CHI2: f64 = 30.664;

/// With wheels reading exactly 0, the most the bias-corrected mean rate of a
/// window may be on any axis, rad/s (2°/s).
pub const WHEELS_STILL_MAX_RATE_RADPS: f64 = 0.035;

/// Standard deviations of one sample at rest beyond which a gyro axis ends a
/// standstill at once (a false end, once in about 10⁸ samples, costs one window).
pub const EXIT_SIGMAS: f64 = 6.0;

/// The detector's and the updates' parameters (`[model.standstill]`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Standstill {
    /// Length of a detection window, ns (default 200 ms).
    #[serde(default = "Standstill::default_window_ns")]
    pub window_ns: u64,
    /// `γ`: the most a quiet window's variance may be, as a multiple of the
    /// variance the noise densities give at rest (default 3).
    #[serde(default = "Standstill::default_imu_threshold")]
    pub imu_threshold: f64,
    /// Estimated speed above which the vehicle is not standing, m/s (default 0.3);
    /// used when no odometry came in the last two windows.
    #[serde(default = "Standstill::default_max_speed")]
    pub max_speed_mps: f64,
    /// Odometry speed at or below which it says standing, m/s (default 0.01).
    #[serde(default = "Standstill::default_odometry_speed")]
    pub odometry_speed_mps: f64,
    /// `σ_zv`: standard deviation of the zero-velocity update, m/s (default 0.01).
    #[serde(default = "Standstill::default_velocity_std")]
    pub velocity_std_mps: f64,
}

impl Default for Standstill {
    fn default() -> Self {
        Self {
            window_ns: Self::default_window_ns(),
            imu_threshold: Self::default_imu_threshold(),
            max_speed_mps: Self::default_max_speed(),
            odometry_speed_mps: Self::default_odometry_speed(),
            velocity_std_mps: Self::default_velocity_std(),
        }
    }
}

impl Standstill {
    fn default_window_ns() -> u64 {
        200_000_000
    }
    fn default_imu_threshold() -> f64 {
        3.0
    }
    fn default_max_speed() -> f64 {
        0.3
    }
    fn default_odometry_speed() -> f64 {
        0.01
    }
    fn default_velocity_std() -> f64 {
        0.01
    }
}

/// The detector's state: the sums of the current window, whether the vehicle
/// stands, the last odometry speed. Part of [`InsState`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Detector {
    /// Time of the window's first sample.
    start_ns: Option<u64>,
    /// Time of its last sample.
    last_ns: u64,
    /// Samples in it.
    n: u32,
    sum_f: [f64; 3],
    sum_ff: f64,
    sum_w: [f64; 3],
    sum_ww: f64,
    /// Standing: the attitude is held and the updates are due.
    pub(crate) standing: bool,
    /// Time and value of the last odometry speed, m/s.
    odometry: Option<(u64, f64)>,
    /// The largest odometry speed (magnitude) in the current window, m/s.
    window_odometry: Option<f64>,
    /// Standstill updates fused.
    pub(crate) updates: u64,
}

impl Detector {
    /// Whether the vehicle is standing (the attitude is held).
    pub fn standing(&self) -> bool {
        self.standing
    }

    /// Notes an odometry speed at `t_ns`; one above `c.odometry_speed_mps` ends
    /// a standstill at once, and the window it falls in does not count for a new
    /// one (so a standstill starts again only after a whole window without motion).
    pub(crate) fn odometry(&mut self, c: &Standstill, t_ns: u64, speed_mps: f64) {
        self.odometry = Some((t_ns, speed_mps));
        self.window_odometry = Some(self.window_odometry.map_or(speed_mps.abs(), |m| m.max(speed_mps.abs())));
        if speed_mps.abs() > c.odometry_speed_mps && self.standing {
            self.standing = false;
            self.clear_window();
            self.window_odometry = Some(speed_mps.abs());
        }
    }

    /// The per-IMU sample rate of the current window so far, Hz: `n − 1`
    /// intervals over the span from its first sample to its last, shared by
    /// `imus` IMUs; `None` before two samples.
    fn rate_hz(&self, imus: u32) -> Option<f64> {
        let span_s = self.last_ns.saturating_sub(self.start_ns?) as f64 * 1e-9;
        (self.n >= 2 && span_s > 0.0).then(|| f64::from(self.n - 1) / (f64::from(imus.max(1)) * span_s))
    }

    fn clear_window(&mut self) {
        let (standing, odometry, updates) = (self.standing, self.odometry, self.updates);
        *self = Self { standing, odometry, updates, ..Self::default() };
    }
}

impl<const D: usize> InsState<D> {
    /// Whether the vehicle stands still (detected; the attitude is held).
    pub fn standing(&self) -> bool {
        self.still.standing()
    }
    /// Standstill updates fused so far.
    pub fn standstill_updates(&self) -> u64 {
        self.still.updates
    }
}

impl<const D: usize> InsModel<D> {
    /// The strapdown step of a standing vehicle (the module docs): the body does
    /// not turn (`ω = 0`: no gyro integration, no attitude noise, no `δθ`–`δb_g`
    /// coupling), and `F`'s `δv`–`δθ` block is linearised at the specific force of
    /// a body at rest, `Rᵀ(−g)`, not at the noisy sample: `A = −R [Rᵀ(−g)]× =
    /// −[−g]× R`, which leaves the yaw error out of `δv`. Out of line: the moving
    /// step's code stays as it was.
    #[cold]
    #[inline(never)]
    pub(super) fn mechanise_at_rest(
        &self,
        s: &InsState<D>,
        f_m: Vector3<f64>,
        dt: f64,
        Q: &mut ProcessNoise,
    ) -> (Vector3<f64>, Vector3<f64>, UnitQuaternion<f64>, Transition) {
        let (p, v, q, mut F) = self.mechanise(s, f_m, s.b_g(), dt);
        Q.theta = 0.0;
        F.gyro_dt = 0.0;
        let R = s.q().to_rotation_matrix().into_inner();
        F.A = -(-self.g()).cross_matrix() * R;
        (p, v, q, F)
    }
}

/// The statistics of a finished window.
struct Window {
    /// `T_f`, `T_ω`, `T_m`, `T_a` of the module docs.
    tests: [f64; 4],
    /// Mean body rate, rad/s.
    mean_w: Vector3<f64>,
    /// Variance of one gyro sample at rest, `σ_g² r`, (rad/s)².
    sample_var_w: f64,
    n: f64,
}

/// The tests of the window summed in `s.still` (`imus` IMUs in it).
fn window<const D: usize>(model: &InsModel<D>, s: &InsState<D>, imus: u32) -> Option<Window> {
    let d = &s.still;
    let n = f64::from(d.n);
    let rate = d.rate_hz(imus).filter(|_| d.n >= 3)?;
    let noise = model.noise();
    let sample_var_f = noise.accelerometer_noise_density.powi(2) * rate;
    let sample_var_w = noise.gyroscope_noise_density.powi(2) * rate;
    let mean = |s: &[f64; 3]| Vector3::new(s[0], s[1], s[2]) / n;
    let (mean_f, mean_w) = (mean(&d.sum_f), mean(&d.sum_w));
    // Per-axis sample variance: (Σ|x|² − n |x̄|²) / (3 (n − 1)).
    let var = |ss: f64, m: &Vector3<f64>| ((ss - n * m.norm_squared()) / (3.0 * (n - 1.0))).max(0.0);
    let P = s.kf.P();
    let b_g = s.b_g();
    let mean_rate: f64 = (0..3).map(|i| (mean_w[i] - b_g[i]).powi(2) / (sample_var_w / n + P[(12 + i, 12 + i)])).sum();
    // T_a: r = R (f̄ − b_a) + g against Cov(r) = σ_a² r / n I + J P Jᵀ, J = [R [f̄ − b_a]×, R]
    // on (δθ, δb_a).
    let R = s.q().to_rotation_matrix().into_inner();
    let phi = mean_f - s.b_a();
    let r = R * phi + model.g();
    let mut J = SMatrix::<f64, 3, 6>::zeros();
    J.fixed_view_mut::<3, 3>(0, 0).copy_from(&(R * phi.cross_matrix()));
    J.fixed_view_mut::<3, 3>(0, 3).copy_from(&R);
    let cov = Matrix3::identity() * (sample_var_f / n) + J * P.fixed_view::<6, 6>(6, 6) * J.transpose();
    let mean_force = cov.cholesky().map_or(f64::INFINITY, |c| r.dot(&c.solve(&r)));
    let tests = [var(d.sum_ff, &mean_f) / sample_var_f, var(d.sum_ww, &mean_w) / sample_var_w, mean_rate, mean_force];
    Some(Window { tests, mean_w, sample_var_w, n })
}

/// Whether the speed allows standing at `t_ns`: every odometry speed of the
/// window; without one in it, the last one if it is recent; else the estimate's.
fn slow<const D: usize>(c: &Standstill, d: &Detector, s: &InsState<D>, t_ns: u64) -> bool {
    if let Some(max) = d.window_odometry {
        return max <= c.odometry_speed_mps;
    }
    match d.odometry {
        Some((at, speed)) if t_ns.saturating_sub(at) <= 2 * c.window_ns => speed.abs() <= c.odometry_speed_mps,
        _ => s.v().norm() <= c.max_speed_mps,
    }
}

/// Takes one IMU sample (body specific force `f`, rate `w`, already held) at
/// `t_ns`; at the end of a window decides whether the vehicle stands and, if
/// it does, fuses the standstill update, whose correction it returns.
pub fn observe<const D: usize>(
    c: &Standstill,
    model: &InsModel<D>,
    s: &mut InsState<D>,
    t_ns: u64,
    f: Vector3<f64>,
    w: Vector3<f64>,
) -> Option<SVector<f64, D>> {
    let b_g = s.b_g();
    let imus = s.imu.mean().map_or(1, |(_, _, k)| k);
    let d = &mut s.still;
    if d.standing
        && let Some(rate) = d.rate_hz(imus)
        && (w - b_g).amax() > EXIT_SIGMAS * model.noise().gyroscope_noise_density * rate.sqrt()
    {
        d.standing = false;
        d.clear_window();
    }
    let start = *d.start_ns.get_or_insert(t_ns);
    d.last_ns = t_ns;
    d.n += 1;
    for i in 0..3 {
        d.sum_f[i] += f[i];
        d.sum_w[i] += w[i];
    }
    d.sum_ff += f.norm_squared();
    d.sum_ww += w.norm_squared();
    if t_ns.saturating_sub(start) < c.window_ns {
        return None;
    }
    let stats = window(model, s, imus);
    let d = s.still;
    s.still.clear_window();
    let Some(stats) = stats else {
        s.still.standing = false;
        return None;
    };
    let [t_f, t_w, t_m, t_a] = stats.tests;
    let still_mean = if d.window_odometry == Some(0.0) {
        (stats.mean_w - b_g).amax() <= WHEELS_STILL_MAX_RATE_RADPS
    } else {
        t_m <= MEAN_CHI2 && t_a <= MEAN_CHI2
    };
    let quiet = t_f <= c.imu_threshold && t_w <= c.imu_threshold && still_mean;
    if !(quiet && slow(c, &d, s, t_ns)) {
        s.still.standing = false;
        return None;
    }
    let entering = !s.still.standing;
    s.still.standing = true;
    let (outcome, injected) = fuse(c, model, s, &stats, entering);
    if matches!(outcome, StepOutcome::Fused { .. }) {
        s.still.updates += 1;
    } else {
        s.still.standing = false;
    }
    injected
}

/// The ZUPT and ZARU rows of the module docs, as one update: the first of a
/// standstill (`entering`) a full one, the others with the yaw held.
fn fuse<const D: usize>(
    c: &Standstill,
    model: &InsModel<D>,
    s: &mut InsState<D>,
    w: &Window,
    entering: bool,
) -> (StepOutcome, Option<SVector<f64, D>>) {
    let mut H = SMatrix::<f64, INNOVATION_DIM, D>::zeros();
    let mut R = SMatrix::<f64, INNOVATION_DIM, INNOVATION_DIM>::zeros();
    let (v, b_g) = (s.v(), s.b_g());
    let mut y = SVector::<f64, INNOVATION_DIM>::zeros();
    let zaru_var = w.sample_var_w / w.n;
    for i in 0..3 {
        H[(i, 3 + i)] = 1.0;
        H[(3 + i, 12 + i)] = 1.0;
        R[(i, i)] = c.velocity_std_mps * c.velocity_std_mps;
        R[(3 + i, 3 + i)] = zaru_var;
        y[i] = -v[i];
        y[3 + i] = w.mean_w[i] - b_g[i];
    }
    if entering {
        return model.update_residual_gated(s, &y, &H, &R, None);
    }
    consider_yaw_update(s, &y, &H, &R)
}

/// The update of `y`, `H`, `R` with the yaw as a consider direction (see the
/// module docs); the correction is injected and returned. Not gated.
fn consider_yaw_update<const D: usize>(
    s: &mut InsState<D>,
    y: &SVector<f64, INNOVATION_DIM>,
    H: &SMatrix<f64, INNOVATION_DIM, D>,
    R: &SMatrix<f64, INNOVATION_DIM, INNOVATION_DIM>,
) -> (StepOutcome, Option<SVector<f64, D>>) {
    let P = s.kf.P();
    let PHt = P * H.transpose();
    let S = H * PHt + R;
    let Some(chol) = S.cholesky() else {
        return (StepOutcome::Refused, None);
    };
    let mut K = chol.solve(&PHt.transpose()).transpose();
    let u = s.q().to_rotation_matrix().into_inner().transpose() * Vector3::z();
    for c in 0..INNOVATION_DIM {
        let k = Vector3::new(K[(6, c)], K[(7, c)], K[(8, c)]);
        let k = k - u * u.dot(&k);
        for i in 0..3 {
            K[(6 + i, c)] = k[i];
        }
    }
    let dx = K * y;
    let I_KH = SMatrix::<f64, D, D>::identity() - K * H;
    let P_new = I_KH * P * I_KH.transpose() + K * R * K.transpose();
    let nis = y.dot(&chol.solve(y));
    if s.kf.set_state(dx, P_new).is_err() {
        return (StepOutcome::Refused, None);
    }
    (StepOutcome::Fused { nis }, Some(inject_and_reset(s)))
}

#[cfg(test)]
mod tests;
