//! Lock-out recovery: a filter whose position fixes have all been gated for long
//! enough re-initialises its position and velocity from the fixes.
//!
//! A gate protects the estimate from outliers, but a filter that is itself wrong
//! (a first sample stamped with an uninitialised clock, a long dead-reckoning
//! drift, a position jump it never saw) gates every fix from then on and never
//! recovers. PX4 EKF2 resets position and velocity to GNSS when its fusion has
//! been rejected for longer than a timeout (`EKF2_GPS_CHECK`, `reset_timeout_max`);
//! this is the same rule on the fix stream, in sample time:
//!
//! - A run starts at the first gated fix; a fused fix ends it.
//! - When the run holds at least `fixes` gated fixes and spans at least
//!   `after_ns` (`[gating] lockout_fixes`, `lockout_ns`), the filter is
//!   re-initialised from the last fix and the first fix of the run:
//!
//! ```text
//! p = z_n                         P_pp = R_n
//! v = (z_n − z_1) / Δt            P_vv = (R_1 + R_n) / Δt² + P₀,vv
//! ```
//!
//! every other state keeps its value with its initial variance `P₀`, and all
//! cross-covariances are zero. `Δt` is the time between the two fixes (at least
//! `after_ns`); `P₀,vv` (the configured initial velocity variance) covers the
//! acceleration over the run that the mean velocity does not. The fix positions
//! are of the body origin (the `ins` model takes the lever arm off first).
//!
//! **Every other kind** that a gate can refuse (wheel odometry, twist, heading,
//! magnetometer, attitude, pose, barometer) has the same rule, per kind, on its
//! own samples ([`KindRuns`]): a run starts at its first gated sample and a
//! fused one ends it; when the run holds at least `fixes` samples spanning at
//! least `after_ns`, the next sample of that kind resets the states it
//! observes to what it says instead of being gated. With the residual `y`, the
//! Jacobian `H` and `S = H P Hᵀ + R`, the prior is forgotten along what the
//! sample observes,
//!
//! ```text
//! A = Hᵀ (H Hᵀ)⁻¹,    P ← P + A (y yᵀ + S) Aᵀ,
//! ```
//!
//! so that `H P Hᵀ` grows by `y yᵀ + S` and the innovation is plausible again
//! (`NIS < 1`), and the sample is fused without the gate: the estimate takes
//! what the sample says in the directions it observes (PX4 EKF2 resets a
//! velocity or a heading to its aid source after `reset_timeout_max`), and
//! keeps everything else with its correlations. Wheels that a wrong velocity
//! estimate had locked out take hold again; an outlier is still gated (it makes
//! no run of the whole timeout).
//!
//! The runs live in the filter state, so a rewind replays them exactly and live
//! equals replay. Each re-initialisation and reset is counted in the state
//! ([`Lockout::count`]); the health reports it and the daemon logs it.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, SMatrix, Vector3};

use fusion_shared::SampleKind;

use crate::model::StepOutcome;
use crate::setting::{ConfigError, invalid};

/// When a run of gated fixes re-initialises the filter (`[gating] lockout_ns`
/// and `lockout_fixes`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LockoutConfig {
    /// Shortest span of the run, first to last gated fix, ns (> 0).
    pub after_ns: u64,
    /// Fewest gated fixes in the run (≥ 2).
    pub fixes: u32,
}

impl Default for LockoutConfig {
    /// 5 s and 5 fixes.
    fn default() -> Self {
        Self { after_ns: 5_000_000_000, fixes: 5 }
    }
}

impl LockoutConfig {
    /// The settings of `[gating] lockout_ns` and `lockout_fixes` (the defaults
    /// where absent); `None` when `lockout_ns` is 0 (recovery off). At least 2
    /// fixes.
    pub fn from_keys(lockout_ns: Option<u64>, lockout_fixes: Option<u32>) -> Result<Option<Self>, ConfigError> {
        let default = Self::default();
        let after_ns = lockout_ns.unwrap_or(default.after_ns);
        let fixes = lockout_fixes.unwrap_or(default.fixes);
        if fixes < 2 {
            return Err(invalid("gating.lockout_fixes", format!("must be at least 2, got {fixes}")));
        }
        Ok((after_ns > 0).then_some(Self { after_ns, fixes }))
    }
}

/// The run of gated fixes so far, and the re-initialisations made.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Lockout {
    run: Option<Run>,
    count: u64,
}

/// What a run of gated samples of a kind does: each kind declares its own
/// (`Measurement::LOCKOUT`), and the model follows it without naming kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LockoutRule {
    /// Nothing: the kind is never gated (the IMU drives the propagation), or
    /// a run of it is no sign of a wrong state by itself (a world velocity).
    None,
    /// The run re-initialises the position and velocity from the fixes
    /// ([`Lockout::observe`], which the kind's fusion calls): the position
    /// and geodetic fixes.
    Reinitialises,
    /// The run resets what the kind observes ([`KindRuns`]): the kinds fused
    /// through a residual.
    Resets,
}

/// The runs of gated samples of each kind fused through a residual (every
/// kind but the IMU and the fixes, which re-initialise instead), and the
/// resets they made (see the module doc). Compact (it is copied with the
/// filter state into the history at every sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KindRuns {
    /// Per kind ([`SampleKind::index`]): the first gated sample of its run, ns
    /// (`u64::MAX`: no run).
    first_ns: [u64; SampleKind::COUNT],
    /// How many (saturating).
    gated: [u16; SampleKind::COUNT],
    /// Bit per kind: its run is long enough.
    due: u16,
    /// The sample being fused resets (its run is due).
    resetting: bool,
    /// Its kind made the reset its own way ([`handled`](Self::handled)).
    handled: bool,
    resets: u32,
}

impl Default for KindRuns {
    fn default() -> Self {
        Self {
            first_ns: [u64::MAX; SampleKind::COUNT],
            gated: [0; SampleKind::COUNT],
            due: 0,
            resetting: false,
            handled: false,
            resets: 0,
        }
    }
}

impl KindRuns {
    /// Before a sample of `kind` is fused: whether its run is due, in which
    /// case the sample resets ([`resetting`](Self::resetting)).
    pub fn before(&mut self, kind: SampleKind) {
        self.resetting = self.due & (1 << kind.index()) != 0;
    }

    /// Whether the sample being fused resets what it observes (and its kind
    /// has not made the reset its own way).
    pub fn resetting(&self) -> bool {
        self.resetting && !self.handled
    }

    /// Whether the sample being fused is due to reset, however its kind
    /// makes the reset.
    pub fn due_now(&self) -> bool {
        self.resetting
    }

    /// The sample's kind made the reset its own way (a magnetometer turns the
    /// heading alone): the update is then an ordinary one, and the reset is
    /// counted when it is fused.
    pub fn handled(&mut self) {
        self.handled = true;
    }

    /// After a sample of `kind` at `t_ns` was fused with `outcome`, under the
    /// kind's rule: only a kind that [`LockoutRule::Resets`] has a run here
    /// (the fixes' is [`Lockout::observe`]'s).
    pub fn after(
        &mut self,
        config: Option<&LockoutConfig>,
        kind: SampleKind,
        rule: LockoutRule,
        t_ns: u64,
        outcome: &StepOutcome,
    ) {
        let reset = std::mem::take(&mut self.resetting);
        self.handled = false;
        let Some(c) = config.filter(|_| rule == LockoutRule::Resets) else { return };
        let i = kind.index();
        match outcome {
            StepOutcome::Fused { .. } => {
                self.resets += u32::from(reset);
                (self.first_ns[i], self.gated[i]) = (u64::MAX, 0);
                self.due &= !(1 << i);
            }
            StepOutcome::Gated { .. } => {
                if self.first_ns[i] == u64::MAX {
                    self.first_ns[i] = t_ns;
                }
                self.gated[i] = self.gated[i].saturating_add(1);
                if u32::from(self.gated[i]) >= c.fixes && t_ns.saturating_sub(self.first_ns[i]) >= c.after_ns {
                    self.due |= 1 << i;
                }
            }
            StepOutcome::Refused | StepOutcome::Propagated => {}
        }
    }

    /// Resets made so far.
    pub fn resets(&self) -> u64 {
        u64::from(self.resets)
    }
}

/// The first gated fix of a run, and how many followed.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Run {
    t_ns: u64,
    z: Vector3<f64>,
    R: Matrix3<f64>,
    fixes: u32,
}

/// What a re-initialisation sets: position and velocity with their covariances.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reinit {
    /// Position of the body origin, m.
    pub p: Vector3<f64>,
    /// Its covariance, m².
    pub P_p: Matrix3<f64>,
    /// Velocity, m/s.
    pub v: Vector3<f64>,
    /// Its covariance without the initial variance, m²/s² (the model adds `P₀,vv`).
    pub P_v: Matrix3<f64>,
}

impl Reinit {
    /// The covariance after the re-initialisation, for a model whose
    /// (error-)state starts with position (0..3) and velocity (3..6): `P₀` with
    /// those rows and columns replaced by `blockdiag(P_pp, P_vv + P₀,vv)`.
    pub fn covariance<const N: usize>(&self, P0: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
        let mut P = *P0;
        P.rows_mut(0, 6).fill(0.0);
        P.columns_mut(0, 6).fill(0.0);
        P.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.P_p);
        P.fixed_view_mut::<3, 3>(3, 3).copy_from(&(self.P_v + P0.fixed_view::<3, 3>(3, 3)));
        P
    }
}

impl Lockout {
    /// Re-initialisations from the fixes so far.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Takes the outcome of a fix of the body origin at `z` (covariance `R`) at
    /// `t_ns`; returns the re-initialisation when the run is long enough.
    pub fn observe(
        &mut self,
        config: Option<&LockoutConfig>,
        outcome: &StepOutcome,
        t_ns: u64,
        z: &Vector3<f64>,
        R: &Matrix3<f64>,
    ) -> Option<Reinit> {
        let config = config?;
        match outcome {
            StepOutcome::Fused { .. } => {
                self.run = None;
                None
            }
            StepOutcome::Gated { .. } => {
                let run = self.run.get_or_insert(Run { t_ns, z: *z, R: *R, fixes: 0 });
                run.fixes += 1;
                let span = t_ns.saturating_sub(run.t_ns);
                if run.fixes < config.fixes || span < config.after_ns || span == 0 {
                    return None;
                }
                let dt = span as f64 * 1e-9;
                let reinit = Reinit { p: *z, P_p: *R, v: (z - run.z) / dt, P_v: (run.R + R) / (dt * dt) };
                self.run = None;
                self.count += 1;
                Some(reinit)
            }
            // A refused update (S not positive definite) or a propagation says
            // nothing about the estimate against the fixes.
            StepOutcome::Refused | StepOutcome::Propagated => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GATED: StepOutcome = StepOutcome::Gated { nis: 1e6 };

    #[test]
    fn a_long_enough_run_of_gated_fixes_reinitialises_and_a_fused_fix_ends_the_run() {
        let config = LockoutConfig { after_ns: 1_000_000_000, fixes: 3 };
        let R = Matrix3::identity();
        let mut l = Lockout::default();
        let at = |t: u64| Vector3::new(10.0 * t as f64 * 1e-9, 0.0, 0.0);
        // 3 fixes over 0.5 s: not long enough; a fused fix starts over.
        for t in [0, 250_000_000, 500_000_000] {
            assert_eq!(l.observe(Some(&config), &GATED, t, &at(t), &R), None);
        }
        assert_eq!(l.observe(Some(&config), &StepOutcome::Fused { nis: 1.0 }, 600_000_000, &at(600_000_000), &R), None);
        // 2 fixes over 1 s: too few.
        let t0 = 1_000_000_000;
        assert_eq!(l.observe(Some(&config), &GATED, t0, &at(t0), &R), None);
        assert_eq!(l.observe(Some(&config), &GATED, t0 + 1_000_000_000, &at(t0 + 1_000_000_000), &R), None);
        let t = t0 + 2_000_000_000;
        let reinit = l.observe(Some(&config), &GATED, t, &at(t), &R).expect("3 fixes over 2 s");
        assert_eq!(reinit.p, at(t));
        assert!((reinit.v - Vector3::new(10.0, 0.0, 0.0)).norm() < 1e-12);
        assert!((reinit.P_v - Matrix3::identity() * 0.5).norm() < 1e-12);
        assert_eq!(l.count(), 1);
        // Without a config nothing happens.
        let mut off = Lockout::default();
        for t in 0..100u64 {
            assert_eq!(off.observe(None, &GATED, t * 1_000_000_000, &at(t), &R), None);
        }
        assert_eq!(off.count(), 0);
    }

    /// A kind's run: due after `fixes` gated samples spanning `after_ns`; the
    /// sample fused then is a reset (counted); a fused sample ends a run; the
    /// fixes and the IMU have no such run; nothing without a config.
    #[test]
    fn a_kind_locked_out_long_enough_resets_at_its_next_sample() {
        let config = LockoutConfig { after_ns: 1_000_000_000, fixes: 3 };
        let fused = StepOutcome::Fused { nis: 1.0 };
        let mut k = KindRuns::default();
        let wheels = SampleKind::Odometry;
        for t in [0, 500_000_000, 900_000_000] {
            k.before(wheels);
            assert!(!k.resetting());
            k.after(Some(&config), wheels, LockoutRule::Resets, t, &GATED);
        }
        // 3 gated over 0.9 s: not yet; a fourth at 1.0 s makes the run due.
        k.before(wheels);
        assert!(!k.resetting());
        k.after(Some(&config), wheels, LockoutRule::Resets, 1_000_000_000, &GATED);
        // Another kind's run is its own.
        k.before(SampleKind::Heading);
        assert!(!k.resetting());
        k.after(Some(&config), SampleKind::Heading, LockoutRule::Resets, 1_010_000_000, &fused);
        k.before(wheels);
        assert!(k.resetting(), "due");
        k.after(Some(&config), wheels, LockoutRule::Resets, 1_100_000_000, &fused);
        assert_eq!((k.resetting(), k.resets()), (false, 1));
        k.before(wheels);
        assert!(!k.resetting(), "the run ended with the reset");
        // A kind of another rule has no run here (the fixes re-initialise
        // instead); without a config nothing happens.
        let mut fixes = KindRuns::default();
        for t in 0..20u64 {
            fixes.before(SampleKind::Position);
            assert!(!fixes.resetting());
            fixes.after(Some(&config), SampleKind::Position, LockoutRule::Reinitialises, t * 1_000_000_000, &GATED);
        }
        let mut off = KindRuns::default();
        for t in 0..20u64 {
            off.before(wheels);
            assert!(!off.resetting());
            off.after(None, wheels, LockoutRule::Resets, t * 1_000_000_000, &GATED);
        }
    }

    use crate::engine::{Engine, EngineConfig, Entry, Insert};
    use crate::filter::ChiSquareGate;
    use crate::measurement::Steps;
    use crate::model::ins::{InsModel, tests_support};
    use crate::model::linear::LinearModel;
    use fusion_shared::{ImuSample, PositionSample, Sample};

    /// A vehicle at rest: IMU at 200 Hz reading `f` (gravity for the `ins`
    /// model, nothing for `linear`, whose input is the world acceleration), fixes at 10 Hz at the
    /// origin for 10 s, then 1 km east for 10 s (carried away unseen, or a fix
    /// source that jumped for good): every fix after the jump is gated.
    fn jump_stream(f: [f64; 3]) -> Vec<Sample> {
        let mut v = Vec::new();
        for i in 0..4000u64 {
            let t = i * 5_000_000;
            v.push(Sample::Imu(ImuSample::new(t, 0, i, f, [0.0; 3])));
            if i % 20 == 10 {
                let x = if t < 10_000_000_000 { 0.0 } else { 1000.0 };
                let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.25];
                v.push(Sample::Position(PositionSample::new(t, 1, i / 20, [x, 0.0, 0.0], cov)));
            }
        }
        v
    }

    /// Runs the stream; returns the final x, the re-initialisations, and the
    /// outcome of every fix after the jump.
    fn run<M: Steps>(model: M, f: [f64; 3]) -> (Vec<f64>, u64, Vec<bool>) {
        let config = EngineConfig { max_future_ns: u64::MAX, ..EngineConfig::default() };
        let mut engine = Engine::new(model, config);
        let mut after = Vec::new();
        for s in jump_stream(f) {
            let out = engine.insert(&s, None, &mut |_: &Entry<_>| {});
            if let (Sample::Position(_), Insert::Processed { outcome, .. }) = (&s, out)
                && s.t_ns() >= 10_000_000_000
            {
                after.push(outcome.accepted() == Some(true));
            }
        }
        let latest = engine.latest().unwrap();
        (M::x(&latest.state).to_vec(), M::diagnostics(&latest.state).reinitialisations, after)
    }

    const G: [f64; 3] = [0.0, 0.0, 9.80665];

    fn check(x: &[f64], reinitialisations: u64, after: &[bool]) {
        assert_eq!(reinitialisations, 1);
        // Gated for 5 s (51 fixes, the first at 10.05 s, the last at 15.05 s),
        // then fused from the next one on.
        let gated = after.iter().take_while(|f| !**f).count();
        assert_eq!(gated, 51, "{after:?}");
        assert!(after[gated..].iter().all(|f| *f), "{after:?}");
        assert!((x[0] - 1000.0).abs() < 0.5 && x[1].abs() < 0.5 && x[3].abs() < 0.5, "{x:?}");
    }

    #[test]
    fn a_linear_filter_locked_out_by_a_jump_recovers_from_the_fixes() {
        let gate = ChiSquareGate::new(0.999).ok();
        let p0 = [100.0, 100.0, 100.0, 10.0, 10.0, 10.0];
        let model = || LinearModel::new(0.3, [0.0; 6], p0, gate.clone()).unwrap();
        let (x, n, after) = run(model().with_lockout(Some(LockoutConfig::default())), [0.0; 3]);
        check(&x, n, &after);
        // Without it, the filter stays at the old place for good.
        let (x, n, after) = run(model(), [0.0; 3]);
        assert_eq!(n, 0);
        assert!(after.iter().all(|f| !*f) && x[0].abs() < 1.0, "{x:?}");
    }

    #[test]
    fn an_ins_locked_out_by_a_jump_recovers_from_the_fixes() {
        let gated = |lockout| {
            let mut x0 = [0.0; 16];
            x0[6] = 1.0;
            let mut p0 = [1.0; 15];
            p0[6..9].copy_from_slice(&[1e-4; 3]);
            InsModel::new(tests_support::NOISE, 9.80665, x0, p0, ChiSquareGate::new(0.999).ok(), 0)
                .unwrap()
                .with_lockout(lockout)
        };
        let (x, n, after) = run(gated(Some(LockoutConfig::default())), G);
        check(&x, n, &after);
        let (x, n, after) = run(gated(None), G);
        assert_eq!(n, 0);
        assert!(after.iter().all(|f| !*f) && x[0].abs() < 1.0, "{x:?}");
    }

    /// An `ins` model of a level vehicle at rest, its attitude known (1e-4 rad²).
    fn resting_ins(lockout: Option<LockoutConfig>) -> InsModel {
        let mut x0 = [0.0; 16];
        x0[6] = 1.0;
        let mut p0 = [1e-4; 15];
        p0[12..15].copy_from_slice(&[1e-8; 3]);
        InsModel::new(tests_support::NOISE, 9.80665, x0, p0, ChiSquareGate::new(0.999).ok(), 0)
            .unwrap()
            .with_lockout(lockout)
    }

    /// `n` IMU samples at rest at 200 Hz, with `aid(t, k)` (the `k`-th) after
    /// every `every`-th; whether each aid sample from 10 s on was fused.
    fn at_rest(engine: &mut Engine<InsModel>, n: u64, every: u64, aid: impl Fn(u64, u64) -> Sample) -> Vec<bool> {
        let mut after = Vec::new();
        for i in 0..n {
            let t = i * 5_000_000;
            let mut samples = vec![Sample::Imu(ImuSample::new(t, 0, i, G, [0.0; 3]))];
            if i % every == every / 2 {
                samples.push(aid(t, i / every));
            }
            for s in samples {
                let out = engine.insert(&s, None, &mut |_: &Entry<_>| {});
                if let (false, Insert::Processed { outcome, .. }) = (matches!(s, Sample::Imu(_)), out)
                    && s.t_ns() >= 10_000_000_000
                {
                    after.push(outcome.accepted() == Some(true));
                }
            }
        }
        after
    }

    /// Wheels reading 0 m/s for 10 s, then 2 m/s (a vehicle carried off
    /// unseen by its IMU): every odometry sample is gated against the
    /// confident velocity estimate. After 5 s of it the next sample resets the
    /// velocity along what the wheels observe, and the wheels are fused from
    /// then on; without lock-out recovery they stay gated for good.
    #[test]
    fn an_ins_whose_wheels_are_locked_out_resets_from_them() {
        use fusion_shared::OdometrySample;
        let run = |lockout| {
            let mut engine =
                Engine::new(resting_ins(lockout), EngineConfig { max_future_ns: u64::MAX, ..EngineConfig::default() });
            let after = at_rest(&mut engine, 4000, 4, |t, k| {
                let speed = if t < 10_000_000_000 { 0.0 } else { 2.0 };
                Sample::Odometry(OdometrySample::new(t, 0, k, speed, 1e-4))
            });
            let latest = engine.latest().unwrap();
            (
                <InsModel as crate::model::Model>::x(&latest.state).to_vec(),
                <InsModel as crate::model::Model>::diagnostics(&latest.state).reinitialisations,
                after,
            )
        };
        let (x, n, after) = run(Some(LockoutConfig::default()));
        assert_eq!(n, 1);
        // Gated for 5 s (251 samples at 50 Hz, 10.01 s to 15.01 s), then fused.
        let gated = after.iter().take_while(|f| !**f).count();
        assert_eq!(gated, 251, "{after:?}");
        assert!(after[gated..].iter().all(|f| *f), "{after:?}");
        assert!((x[3] - 2.0).abs() < 0.05 && x[4].abs() < 0.05, "{x:?}");
        let (x, n, after) = run(None);
        assert_eq!(n, 0);
        assert!(after.iter().all(|f| !*f) && x[3].abs() < 0.1, "{x:?}");
    }

    /// A device at rest, level, its heading known, whose magnetometer reads a
    /// field turned 40° about up from 10 s on (a heading change its gyro did
    /// not see, or a disturbance of the field's direction alone): gated
    /// against the known heading; after the lock-out the next sample turns the
    /// heading alone to the field's, and roll and pitch stay level (the
    /// generic reset forgot the tilt too and set it from the one vector).
    #[test]
    fn a_locked_out_magnetometer_turns_the_heading_alone() {
        use fusion_shared::MagnetometerSample;
        use nalgebra::{Rotation3, UnitQuaternion};
        let toml = "name = \"mag\"\nid = 0\nkinds = [\"magnetometer\"]\n\
                    [magnetic]\ndeclination_deg = 3.5\ninclination_deg = 64.5\nstrength_ut = 48.5\n";
        let sensor: crate::frames::SensorConfig = toml::from_str(toml).unwrap();
        let frames =
            crate::frames::Frames::from_config(None, &[sensor], Default::default(), &crate::measurement::Kinds)
                .unwrap();
        let earth = crate::measurement::settings::<MagnetometerSample>(&frames, 0).unwrap().world_ut;
        let model = resting_ins(Some(LockoutConfig::default())).with_frames(frames);
        let mut engine = Engine::new(model, EngineConfig { max_future_ns: u64::MAX, ..EngineConfig::default() });
        let turned = Rotation3::from_axis_angle(&Vector3::z_axis(), 40f64.to_radians()) * earth;
        let cov = [0.04, 0.0, 0.0, 0.0, 0.04, 0.0, 0.0, 0.0, 0.04];
        let after = at_rest(&mut engine, 5000, 10, |t, k| {
            let field = if t < 10_000_000_000 { earth } else { turned };
            Sample::Magnetometer(MagnetometerSample::new(t, 0, k, field.into(), cov))
        });
        let latest = engine.latest().unwrap();
        assert_eq!(<InsModel as crate::model::Model>::diagnostics(&latest.state).reinitialisations, 1);
        let gated = after.iter().take_while(|f| !**f).count();
        assert!(gated > 90 && after[gated..].iter().all(|f| *f), "{gated} gated, then {after:?}");
        let x = <InsModel as crate::model::Model>::x(&latest.state);
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(x[6], x[7], x[8], x[9]));
        let (roll, pitch, yaw) = q.euler_angles();
        assert!((yaw.to_degrees() + 40.0).abs() < 1.0, "yaw {:.2}°", yaw.to_degrees());
        assert!(roll.to_degrees().abs() < 0.5 && pitch.to_degrees().abs() < 0.5, "{roll} {pitch}: the tilt kept");
    }
}
