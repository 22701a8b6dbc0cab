//! Ground truth: a smooth, car-like 3-D trajectory in closed form.
//!
//! Each axis is `p(t) = v₀ t + Σ aᵢ sin(ωᵢ t + φᵢ)`, so position, velocity,
//! acceleration and jerk are exact at any time. Forward speed stays within about
//! 3–15 m/s; the heading swings by up to ±70° (turns); the height changes gently
//! (small pitch). Phases come from a seed, so Monte-Carlo runs drive different
//! roads. Every drive starts at the world origin.
//!
//! Stops ([`CarTrajectory::with_stops`]) slow the same road down: the car is at
//! road time `τ(t) = ∫ s dt` with a speed factor `s(t)` that falls from 1 to 0 over
//! [`STOP_RAMP_S`] (`s = ½(1 + cos(π u / T))`), stays 0 while the car stands and
//! rises back. With `′` the derivative by `τ`: `v = p′ s`,
//! `a = p″ s² + p′ ṡ`, `j = p‴ s³ + 3 p″ s ṡ + p′ s̈`, `ω = ω_τ s`, and the
//! attitude is the road's at `τ` (it does not change while the car stands).
//!
//! Attitude (body forward-left-up to world ENU, `R = Rz(ψ) Ry(θ) Rx(φ)`): the
//! nose points along the velocity (yaw `ψ = atan2(v_y, v_x)`, pitch
//! `θ = −atan2(v_z, v_h)`), with a small roll `φ = 0.03 sin(0.5 t + φ₀)`. Body
//! rates follow from the Euler-angle rates (Groves 2013, eq. 2.58 inverted):
//! `ω = [φ̇ − ψ̇ sin θ, θ̇ cos φ + ψ̇ sin φ cos θ, −θ̇ sin φ + ψ̇ cos φ cos θ]`.

use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Truth at one instant (world ENU).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthState {
    /// Time, s since the start of the trajectory.
    pub t_s: f64,
    /// Position, m.
    pub pos_m: Vector3<f64>,
    /// Velocity, m/s.
    pub vel_mps: Vector3<f64>,
    /// Acceleration, m/s² (gravity not included).
    pub acc_mps2: Vector3<f64>,
    /// Jerk, m/s³.
    pub jerk_mps3: Vector3<f64>,
    /// Attitude: rotates body (forward-left-up) vectors into world (ENU).
    pub attitude: UnitQuaternion<f64>,
    /// Angular rate of the body, body frame, rad/s.
    pub omega_body_radps: Vector3<f64>,
}

impl TruthState {
    /// Specific force in the body frame, `f = Rᵀ (a − g)` with `g = [0, 0, −gravity]`:
    /// what an ideal accelerometer measures.
    pub fn specific_force_mps2(&self, gravity_mps2: f64) -> Vector3<f64> {
        self.attitude.inverse_transform_vector(&(self.acc_mps2 + Vector3::new(0.0, 0.0, gravity_mps2)))
    }

    /// World position of the point at lever arm `l` (body frame, m): `p + R l`.
    pub fn antenna_position(&self, l: &Vector3<f64>) -> Vector3<f64> {
        self.pos_m + self.attitude * l
    }

    /// World velocity of the point at lever arm `l`: `v + R (ω × l)`.
    pub fn antenna_velocity(&self, l: &Vector3<f64>) -> Vector3<f64> {
        self.vel_mps + self.attitude * self.omega_body_radps.cross(l)
    }

    /// Body-frame velocity of the point at lever arm `l`: `Rᵀ v + ω × l`.
    pub fn body_velocity(&self, l: &Vector3<f64>) -> Vector3<f64> {
        self.attitude.inverse_transform_vector(&self.vel_mps) + self.omega_body_radps.cross(l)
    }

    /// Yaw of the body's forward axis from east, counter-clockwise, rad in (−π, π].
    pub fn yaw_rad(&self) -> f64 {
        let x = self.attitude * Vector3::x();
        x.y.atan2(x.x)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Term {
    amplitude: f64,
    omega: f64,
    phase: f64,
}

/// A stop of a drive: the car brakes to a standstill, stands, reverses for a
/// while if it is to, and drives off.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stop {
    /// When the braking starts, s since the start of the drive.
    pub at_s: f64,
    /// How long the car stands still, s.
    pub duration_s: f64,
    /// How long it then reverses, s (0: it does not): back along the road it
    /// came, up to [`REVERSE_SPEED`] of the road's speed and back to rest.
    pub reverse_s: f64,
}

/// Braking to a stop, and pulling away after it, each take this long, s.
pub const STOP_RAMP_S: f64 = 4.0;

/// The most a reversing car drives backwards, as a fraction of the road's
/// speed there: its speed factor goes from 0 to `−REVERSE_SPEED` and back,
/// `s = −r ½(1 − cos(2π w / R))` over the `R` seconds of reversing.
pub const REVERSE_SPEED: f64 = 0.25;

impl std::str::FromStr for Stop {
    type Err = String;

    /// `AT:SECONDS[:REVERSE]`, e.g. `20:60` (braking from 20 s into the drive,
    /// standing for 60 s) or `20:5:4` (then reversing for 4 s).
    fn from_str(text: &str) -> Result<Self, String> {
        let bad = || format!("{text:?}: expected AT:SECONDS[:REVERSE] (all >= 0), e.g. 20:60 or 20:5:4");
        let (at, rest) = text.split_once(':').ok_or_else(bad)?;
        let (duration, reverse) = rest.split_once(':').unwrap_or((rest, "0"));
        let number = |t: &str| t.trim().parse::<f64>().ok().filter(|v| v.is_finite() && *v >= 0.0).ok_or_else(bad);
        Ok(Self { at_s: number(at)?, duration_s: number(duration)?, reverse_s: number(reverse)? })
    }
}

impl Stop {
    /// A stop of `duration_s` at `at_s`, without reversing.
    pub const fn new(at_s: f64, duration_s: f64) -> Self {
        Self { at_s, duration_s, reverse_s: 0.0 }
    }

    /// When the car drives at full speed again, s.
    pub fn end_s(&self) -> f64 {
        self.at_s + 2.0 * STOP_RAMP_S + self.duration_s + self.reverse_s
    }

    /// Whether the car reverses at `t_s`.
    pub fn reversing(&self, t_s: f64) -> bool {
        let from = self.at_s + STOP_RAMP_S + self.duration_s;
        self.reverse_s > 0.0 && t_s > from && t_s < from + self.reverse_s
    }

    /// Whether the car stands still at `t_s`.
    pub fn standing(&self, t_s: f64) -> bool {
        t_s >= self.at_s + STOP_RAMP_S && t_s <= self.at_s + STOP_RAMP_S + self.duration_s
    }

    /// Road time lost by `t_s` (`∫ (1 − s)`), and `s`, `ṡ`, `s̈` at `t_s`.
    fn warp(&self, t_s: f64) -> (f64, f64, f64, f64) {
        use std::f64::consts::PI;
        let (ramp, stand, back, r) = (STOP_RAMP_S, self.duration_s, self.reverse_s, REVERSE_SPEED);
        let u = t_s - self.at_s;
        let k = PI / ramp;
        // Road time lost while reversing: ∫ (1 − s) over its R seconds.
        let reversed = back * (1.0 + 0.5 * r);
        if u <= 0.0 {
            (0.0, 1.0, 0.0, 0.0)
        } else if u < ramp {
            let (sin, cos) = (k * u).sin_cos();
            (0.5 * u - sin / (2.0 * k), 0.5 * (1.0 + cos), -0.5 * k * sin, -0.5 * k * k * cos)
        } else if u <= ramp + stand {
            (0.5 * ramp + (u - ramp), 0.0, 0.0, 0.0)
        } else if u < ramp + stand + back {
            let w = u - ramp - stand;
            let c = 2.0 * PI / back;
            let (sin, cos) = (c * w).sin_cos();
            let lost = 0.5 * ramp + stand + w + r * (0.5 * w - sin / (2.0 * c));
            (lost, -0.5 * r * (1.0 - cos), -0.5 * r * c * sin, -0.5 * r * c * c * cos)
        } else if u < 2.0 * ramp + stand + back {
            let w = u - ramp - stand - back;
            let (sin, cos) = (k * w).sin_cos();
            let lost = 0.5 * ramp + stand + reversed + 0.5 * w + sin / (2.0 * k);
            (lost, 0.5 * (1.0 - cos), 0.5 * k * sin, 0.5 * k * k * cos)
        } else {
            (ramp + stand + reversed, 1.0, 0.0, 0.0)
        }
    }
}

/// A car-like trajectory (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct CarTrajectory {
    roll_phase: f64,
    origin_m: [f64; 3],
    drift_mps: [f64; 3],
    axes: [[Term; 2]; 3],
    stops: Vec<Stop>,
}

impl CarTrajectory {
    /// The trajectory of `seed`.
    pub fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7261_6a65_6374_6f72);
        let mut phase = || rng.random_range(0.0..std::f64::consts::TAU);
        // x: forward drift 9 m/s ± 5 m/s; y: turns; z: gentle hills.
        let axes = [
            [Term { amplitude: 25.0, omega: 0.2, phase: phase() }, Term { amplitude: 2.0, omega: 0.7, phase: phase() }],
            [
                Term { amplitude: 55.0, omega: 0.1, phase: phase() },
                Term { amplitude: 12.0, omega: 0.33, phase: phase() },
            ],
            [Term { amplitude: 3.0, omega: 0.05, phase: phase() }, Term { amplitude: 0.4, omega: 0.3, phase: phase() }],
        ];
        let roll_phase = phase();
        let mut traj = Self { roll_phase, origin_m: [0.0; 3], drift_mps: [9.0, 0.0, 0.0], axes, stops: Vec::new() };
        // The drive starts at the world origin.
        let start = traj.at(0.0).pos_m;
        traj.origin_m = [-start.x, -start.y, -start.z];
        traj
    }

    /// The same road with `stops` (each after the end of the one before, the
    /// first at or after 0), or why not.
    pub fn with_stops(mut self, stops: &[Stop]) -> Result<Self, String> {
        let mut end = 0.0;
        for stop in stops {
            if !(stop.at_s.is_finite() && stop.duration_s.is_finite() && stop.duration_s >= 0.0) {
                return Err(format!("stop at {} s for {} s: not finite, or negative", stop.at_s, stop.duration_s));
            }
            if stop.at_s < end {
                return Err(format!("stop at {} s starts before the one before it has ended ({end} s)", stop.at_s));
            }
            end = stop.end_s();
        }
        self.stops = stops.to_vec();
        Ok(self)
    }

    /// The stops of this drive.
    pub fn stops(&self) -> &[Stop] {
        &self.stops
    }

    /// Whether the car stands still at `t_s`.
    pub fn standing(&self, t_s: f64) -> bool {
        self.stops.iter().any(|s| s.standing(t_s))
    }

    /// The truth at `t_s` seconds.
    pub fn at(&self, t_s: f64) -> TruthState {
        let Some(stop) = self.stops.iter().rev().find(|s| t_s > s.at_s) else {
            return self.road(t_s);
        };
        let lost_before: f64 = self.stops.iter().take_while(|s| s.at_s < stop.at_s).map(|s| s.warp(f64::MAX).0).sum();
        let (lost, s, s1, s2) = stop.warp(t_s);
        let road = self.road(t_s - lost_before - lost);
        if s == 1.0 {
            return TruthState { t_s, ..road };
        }
        TruthState {
            t_s,
            vel_mps: road.vel_mps * s,
            acc_mps2: road.acc_mps2 * (s * s) + road.vel_mps * s1,
            jerk_mps3: road.jerk_mps3 * (s * s * s) + road.acc_mps2 * (3.0 * s * s1) + road.vel_mps * s2,
            omega_body_radps: road.omega_body_radps * s,
            ..road
        }
    }

    /// The truth at road time `t_s` (the trajectory without stops).
    fn road(&self, t_s: f64) -> TruthState {
        let mut s = TruthState {
            t_s,
            pos_m: Vector3::zeros(),
            vel_mps: Vector3::zeros(),
            acc_mps2: Vector3::zeros(),
            jerk_mps3: Vector3::zeros(),
            attitude: UnitQuaternion::identity(),
            omega_body_radps: Vector3::zeros(),
        };
        for axis in 0..3 {
            s.pos_m[axis] = self.origin_m[axis] + self.drift_mps[axis] * t_s;
            s.vel_mps[axis] = self.drift_mps[axis];
            for term in &self.axes[axis] {
                let (sin, cos) = (term.omega * t_s + term.phase).sin_cos();
                let (a, w) = (term.amplitude, term.omega);
                s.pos_m[axis] += a * sin;
                s.vel_mps[axis] += a * w * cos;
                s.acc_mps2[axis] -= a * w * w * sin;
                s.jerk_mps3[axis] -= a * w * w * w * cos;
            }
        }
        let (v, a) = (s.vel_mps, s.acc_mps2);
        let vh2 = v.x * v.x + v.y * v.y;
        let vh = vh2.sqrt();
        let yaw = v.y.atan2(v.x);
        let yaw_rate = (v.x * a.y - v.y * a.x) / vh2;
        let pitch = -v.z.atan2(vh);
        let vh_rate = (v.x * a.x + v.y * a.y) / vh;
        let pitch_rate = -(vh * a.z - v.z * vh_rate) / (vh2 + v.z * v.z);
        let (roll_amplitude, roll_omega) = (0.03, 0.5);
        let roll = roll_amplitude * (roll_omega * t_s + self.roll_phase).sin();
        let roll_rate = roll_amplitude * roll_omega * (roll_omega * t_s + self.roll_phase).cos();
        s.attitude = UnitQuaternion::from_rotation_matrix(&Rotation3::from_euler_angles(roll, pitch, yaw));
        let (sp, cp) = pitch.sin_cos();
        let (sr, cr) = roll.sin_cos();
        s.omega_body_radps = Vector3::new(
            roll_rate - yaw_rate * sp,
            pitch_rate * cr + yaw_rate * sr * cp,
            -pitch_rate * sr + yaw_rate * cr * cp,
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_are_consistent() {
        let traj = CarTrajectory::new(3);
        let h = 1e-4;
        for t in [0.0, 3.3, 17.0, 59.0] {
            let (a, b, c) = (traj.at(t - h), traj.at(t), traj.at(t + h));
            assert!(((c.pos_m - a.pos_m) / (2.0 * h) - b.vel_mps).amax() < 1e-6);
            assert!(((c.vel_mps - a.vel_mps) / (2.0 * h) - b.acc_mps2).amax() < 1e-6);
            assert!(((c.acc_mps2 - a.acc_mps2) / (2.0 * h) - b.jerk_mps3).amax() < 1e-6);
        }
    }

    #[test]
    fn body_rates_are_the_derivative_of_the_attitude() {
        // Ṙ = R [ω]×: compare the central difference of R with R [ω]×.
        let traj = CarTrajectory::new(5);
        let h = 1e-5;
        for t in [0.5, 7.0, 23.0, 41.0] {
            let r = |t: f64| traj.at(t).attitude.to_rotation_matrix().into_inner();
            let s = traj.at(t);
            let r_dot = (r(t + h) - r(t - h)) / (2.0 * h);
            let expect = r(t) * s.omega_body_radps.cross_matrix();
            assert!((r_dot - expect).amax() < 1e-6, "t {t}: {r_dot} vs {expect}");
        }
    }

    #[test]
    fn the_nose_points_along_the_velocity_and_gravity_is_sensed_upward() {
        let traj = CarTrajectory::new(8);
        for t in [1.0, 13.0, 30.0] {
            let s = traj.at(t);
            let forward = s.attitude * Vector3::x();
            assert!((forward - s.vel_mps.normalize()).norm() < 1e-9);
            // Level-ish vehicle: the accelerometer's z axis reads about +g.
            let f = s.specific_force_mps2(9.80665);
            assert!((f.z - 9.80665).abs() < 0.5, "{f}");
            assert!((s.attitude * f - (s.acc_mps2 + Vector3::new(0.0, 0.0, 9.80665))).norm() < 1e-12);
        }
    }

    #[test]
    fn stops_keep_the_derivatives_consistent_and_stand_still() {
        let stop = Stop::new(5.0, 10.0);
        let traj = CarTrajectory::new(3).with_stops(&[stop, Stop::new(30.0, 2.0)]).unwrap();
        let h = 1e-4;
        for t in [2.0, 5.5, 7.9, 12.0, 19.2, 22.0, 31.0, 36.5, 45.0] {
            let (a, b, c) = (traj.at(t - h), traj.at(t), traj.at(t + h));
            assert!(((c.pos_m - a.pos_m) / (2.0 * h) - b.vel_mps).amax() < 1e-6, "t {t}");
            assert!(((c.vel_mps - a.vel_mps) / (2.0 * h) - b.acc_mps2).amax() < 1e-6, "t {t}");
            assert!(((c.acc_mps2 - a.acc_mps2) / (2.0 * h) - b.jerk_mps3).amax() < 1e-5, "t {t}");
            let r = |t: f64| traj.at(t).attitude.to_rotation_matrix().into_inner();
            let r_dot = (r(t + h) - r(t - h)) / (2.0 * h);
            assert!((r_dot - r(t) * b.omega_body_radps.cross_matrix()).amax() < 1e-6, "t {t}");
        }
        // Standing: the same pose from the end of the braking to the start of pulling away.
        let (first, last) = (traj.at(5.0 + STOP_RAMP_S), traj.at(5.0 + STOP_RAMP_S + 10.0));
        assert_eq!(first.pos_m, last.pos_m);
        assert_eq!(first.attitude, last.attitude);
        assert!(traj.at(12.0).vel_mps.norm() == 0.0 && traj.at(12.0).omega_body_radps.norm() == 0.0);
        assert!(traj.standing(12.0) && !traj.standing(20.0));
        // After the stops the road goes on where it was, late by the time stood and braked.
        let lost = STOP_RAMP_S + 10.0 + STOP_RAMP_S + 2.0;
        assert!((traj.at(60.0).pos_m - CarTrajectory::new(3).at(60.0 - lost).pos_m).norm() < 1e-9);
        // Without stops the trajectory is the road's, bit for bit.
        let plain = CarTrajectory::new(3);
        assert_eq!(plain.clone().with_stops(&[]).unwrap().at(7.0), plain.at(7.0));
        assert!(CarTrajectory::new(3).with_stops(&[stop, Stop::new(10.0, 1.0)]).is_err());
        assert!(CarTrajectory::new(3).with_stops(&[Stop::new(1.0, f64::NAN)]).is_err());
        assert_eq!("20:60".parse::<Stop>(), Ok(Stop::new(20.0, 60.0)));
        assert_eq!("20:5:4".parse::<Stop>(), Ok(Stop { at_s: 20.0, duration_s: 5.0, reverse_s: 4.0 }));
        for bad in ["20", "20:-1", "x:5", "nan:5", "5:inf", "", "5:1:-2"] {
            assert!(bad.parse::<Stop>().is_err(), "{bad}");
        }
    }

    /// Reversing: the car drives backwards (its velocity against its nose,
    /// up to a quarter of the road's speed), the derivatives stay consistent,
    /// and it comes back to rest before pulling away; the road then goes on,
    /// late by what braking, standing and reversing lost.
    #[test]
    fn reversing_drives_backwards_with_consistent_derivatives() {
        let stop = Stop { at_s: 5.0, duration_s: 2.0, reverse_s: 4.0 };
        let traj = CarTrajectory::new(3).with_stops(&[stop]).unwrap();
        let h = 1e-4;
        for t in [6.0, 10.5, 11.3, 12.0, 13.0, 14.9, 15.5, 17.0, 20.0] {
            let (a, b, c) = (traj.at(t - h), traj.at(t), traj.at(t + h));
            assert!(((c.pos_m - a.pos_m) / (2.0 * h) - b.vel_mps).amax() < 1e-6, "t {t}");
            assert!(((c.vel_mps - a.vel_mps) / (2.0 * h) - b.acc_mps2).amax() < 1e-6, "t {t}");
            assert!(((c.acc_mps2 - a.acc_mps2) / (2.0 * h) - b.jerk_mps3).amax() < 1e-5, "t {t}");
        }
        let mid = traj.at(5.0 + STOP_RAMP_S + 2.0 + 2.0);
        let forward = mid.attitude * Vector3::x();
        assert!(stop.reversing(mid.t_s) && forward.dot(&mid.vel_mps) < -0.5, "backwards: {}", mid.vel_mps);
        let road = CarTrajectory::new(3);
        let lost = STOP_RAMP_S + 2.0 + 4.0 * (1.0 + 0.5 * REVERSE_SPEED);
        assert!((traj.at(40.0).pos_m - road.at(40.0 - lost).pos_m).norm() < 1e-9);
        assert!(!stop.reversing(8.0) && !stop.reversing(16.0) && stop.end_s() == 5.0 + 8.0 + 2.0 + 4.0);
    }

    #[test]
    fn drives_start_at_the_origin() {
        assert!(CarTrajectory::new(9).at(0.0).pos_m.norm() < 1e-12);
    }

    #[test]
    fn speed_is_car_like() {
        for seed in 0..20 {
            let traj = CarTrajectory::new(seed);
            for i in 0..600 {
                let v = traj.at(i as f64 * 0.1).vel_mps;
                let speed = v.norm();
                assert!((2.5..=19.0).contains(&speed), "seed {seed} t {i}: {speed}");
                assert!(v.x > 0.0, "never reverses");
            }
        }
    }
}
