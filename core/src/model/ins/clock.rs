//! An estimate of how late the velocity sensors' timestamps are, beyond the
//! configured `time_offset_ns`: a diagnostic for setting that offset, not a
//! state of the filter.
//!
//! A velocity stamped `t` but valid at `t − τ` measures `v(t − τ) ≈ v(t) − a(t) τ`.
//! The filter's own estimate follows late samples (it is corrected by them), so
//! its residuals hide the lag; the IMU does not. With `V(t)` the IMU's velocity
//! change integrated since the start (`Σ (R f + g) dt`, the nominal steps
//! without the corrections) and `w` the measured velocity with the lever arm's
//! rotational part taken out (`z − R (ω × l)`):
//!
//! ```text
//! u_k = w_k − V(t_k) ≈ c − a_k τ + e_k
//! ```
//!
//! `c` the unknown start velocity plus the slow drift of the integration, taken
//! as constant over a window of [`WINDOW_NS`]. Centred in each window, least
//! squares gives
//!
//! ```text
//! τ̂ = −Σ (a_k − ā)ᵀ (u_k − ū) / Σ |a_k − ā|²,   σ_τ² = σ² / Σ |a_k − ā|²
//! ```
//!
//! over the horizontal components, with `σ²` the mean variance of the samples'
//! horizontal components. It needs the acceleration to change within windows
//! (driving, braking, turning); a steady cruise adds nothing. `a_k` is the mean
//! acceleration since the previous velocity sample, `(V(t_k) − V(t_{k−1})) /
//! (t_k − t_{k−1})`: one IMU sample's noise (0.3 m/s² for a MEMS IMU at 200 Hz)
//! in the regressor would bias `τ̂` towards 0 by half. (Estimating a
//! measurement's delay against the inertial solution is the usual way of
//! calibrating GNSS/INS latency; Groves 2013, §14.1.4 and §16.4.)
//!
//! What it is worth: `V` is integrated with the filter's attitude and
//! accelerometer bias, and a filter fed late samples partly explains them by a
//! heading and bias error, so `τ̂` reads low: about half of a 100 ms lag on
//! simulated car drives (`daemon/tests/time_offset.rs`), and 0 within its σ once
//! the offset is right. Add the estimate to `time_offset_ns` and run again until
//! it reads 0: each round halves what is left.

use nalgebra::{Matrix3, Vector2, Vector3};

use super::{InsModel, InsState};

/// The window over which the integration's constant is taken as constant, ns.
pub const WINDOW_NS: u64 = 5_000_000_000;

/// The estimate's systematic scatter, s: the standard deviation of `τ̂` over
/// 100 simulated 60 s drives with a right clock (9.5 ms;
/// `daemon/tests/time_offset.rs`), rounded up.
pub const SYSTEMATIC_S: f64 = 0.010;

/// The running sums of the estimate (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ClockEstimate {
    /// `V(t)`: the IMU's horizontal velocity change since the start, m/s
    /// (world east, north).
    pub(super) integrated: Vector2<f64>,
    /// `V` at the previous velocity sample, and its time (0: none yet).
    last_v: Vector2<f64>,
    last_ns: u64,
    /// The open window: its first sample's time, samples, `Σ a`, `Σ u`, `Σ |a|²`, `Σ aᵀu`.
    start_ns: u64,
    n: u32,
    sum_a: Vector2<f64>,
    sum_u: Vector2<f64>,
    sum_aa: f64,
    sum_au: f64,
    /// The closed windows: `Σ |a − ā|²`, `Σ (a − ā)ᵀ(u − ū)`, samples, `Σ σ²`.
    sxx: f64,
    sxy: f64,
    samples: u64,
    sum_var: f64,
}

impl ClockEstimate {
    /// `(τ̂, σ_τ, samples)`, s; `None` before a closed window with a changing
    /// acceleration.
    ///
    /// `σ_τ² = σ² / Σ |a_k − ā|² + σ_sys²`: the white-noise part (module docs)
    /// and the estimator's own systematic scatter [`SYSTEMATIC_S`]. The
    /// integration's drift within a window is no constant and the filter's
    /// attitude errors are not white, so the white-noise part alone (about 3 ms
    /// on a 60 s drive) claimed far more than the estimate knows: advice from it
    /// was wrong on 13 of 100 simulated drives with a right clock.
    pub fn estimate(&self) -> Option<(f64, f64, u64)> {
        if !(self.sxx > 0.0 && self.samples > 0) {
            return None;
        }
        let var = self.sum_var / self.samples as f64;
        let sd = (var / self.sxx + SYSTEMATIC_S * SYSTEMATIC_S).sqrt();
        Some((-self.sxy / self.sxx, sd, self.samples))
    }

    /// Takes one sample into the open window: its mean acceleration `a`, its
    /// `u = w − V` and the mean variance `var` of its components.
    fn add(&mut self, a: Vector2<f64>, u: Vector2<f64>, var: f64) {
        self.n += 1;
        self.sum_a += a;
        self.sum_u += u;
        self.sum_aa += a.norm_squared();
        self.sum_au += a.dot(&u);
        self.samples += 1;
        self.sum_var += var;
    }

    /// Closes the open window into the totals.
    fn close(&mut self) {
        if self.n >= 2 {
            let n = f64::from(self.n);
            self.sxx += self.sum_aa - self.sum_a.norm_squared() / n;
            self.sxy += self.sum_au - self.sum_a.dot(&self.sum_u) / n;
        }
        (self.n, self.sum_a, self.sum_u, self.sum_aa, self.sum_au) = (0, Vector2::zeros(), Vector2::zeros(), 0.0, 0.0);
    }
}

impl<const D: usize> InsModel<D> {
    /// Takes a velocity sample at `t_ns` (the state propagated to it, before its
    /// update): `w` the measured velocity less the lever arm's rotational part,
    /// `R` its covariance.
    pub(crate) fn observe_velocity(&self, s: &mut InsState<D>, t_ns: u64, w: &Vector3<f64>, R: &Matrix3<f64>) {
        if !s.ready {
            return;
        }
        let c = &mut s.clock;
        let (t0, v0) = (c.last_ns, c.last_v);
        (c.last_ns, c.last_v) = (t_ns, c.integrated);
        let dt = t_ns.saturating_sub(t0) as f64 * 1e-9;
        if t0 == 0 || !(dt > 0.0 && dt <= 1.0) {
            c.close();
            return;
        }
        let a = (c.integrated - v0) / dt;
        if c.n > 0 && t_ns.saturating_sub(c.start_ns) > WINDOW_NS {
            c.close();
        }
        if c.n == 0 {
            c.start_ns = t_ns;
        }
        let u = Vector2::new(w.x, w.y) - c.integrated;
        c.add(a, u, 0.5 * (R[(0, 0)] + R[(1, 1)]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact data `u = c − a τ` in two windows with different constants: the
    /// estimate is τ, whatever the constants.
    #[test]
    fn the_window_constants_drop_out() {
        let mut e = ClockEstimate::default();
        let tau = 0.08;
        for (w, c) in [(0.0, Vector2::new(3.0, -1.0)), (1.0, Vector2::new(-7.0, 2.0))] {
            for k in 0..20 {
                let t = k as f64 * 0.1;
                let a = Vector2::new((t + w).sin(), (2.0 * t).cos() + 0.1 * t);
                e.add(a, c - a * tau, 0.0025);
            }
            e.close();
        }
        let (est, sd, n) = e.estimate().unwrap();
        assert!((est - tau).abs() < 1e-12, "{est}");
        assert!(sd > 0.0 && n == 40);
    }
}
