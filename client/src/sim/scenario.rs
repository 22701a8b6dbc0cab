//! A whole simulated drive: every sensor's samples merged in arrival order.
//!
//! Each sensor is an iterator of [`Arrival`]s in timestamp order, so the same
//! code serves a file writer (merge by arrival time) and live publishers (pace by
//! arrival time). All randomness comes from seeded ChaCha8 streams, one per
//! sensor: the same configuration and seed give the same samples, bit for bit,
//! and adding a sensor leaves the others' samples unchanged.

use std::sync::Arc;

use fusion_shared::Sample;

use super::AidingSim;
use super::arrival::{Arrival, to_ns};
use super::imu::{ImuConfig, ImuOutput, ImuSim};
use super::position::PositionConfig;
use super::trajectory::{CarTrajectory, Stop, TruthState};

/// A whole recorded drive: every sensor's samples merged in arrival order.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// The truth behind the samples.
    pub trajectory: CarTrajectory,
    /// Trajectory time 0, ns.
    pub start_ns: u64,
    /// Samples in arrival order (ties: timestamp order).
    pub arrivals: Vec<Arrival>,
}

/// Settings of a recorded drive.
#[derive(Debug, Clone)]
pub struct ScenarioConfig {
    /// Seed of the trajectory and all noise.
    pub seed: u64,
    /// Length, s.
    pub duration_s: f64,
    /// Trajectory time 0, ns.
    pub start_ns: u64,
    /// IMU settings.
    pub imu: ImuConfig,
    /// Further IMUs (each with its own sensor id, mounting, noise and biases).
    pub extra_imus: Vec<ImuConfig>,
    /// What the IMU measures.
    pub imu_output: ImuOutput,
    /// Position settings.
    pub position: PositionConfig,
    /// Further sensors (velocity, …), each with its own settings.
    pub aiding: Vec<Arc<dyn AidingSim>>,
    /// Stops of the drive, in order (see [`CarTrajectory::with_stops`]).
    pub stops: Vec<Stop>,
    /// GNSS outages (tunnels, garages): no position, geodetic, velocity or
    /// heading sample valid within one of them.
    pub outages: Vec<Outage>,
}

/// A GNSS outage: from `at_s` for `duration_s` seconds of the drive, no sample
/// of a GNSS kind (position, geodetic, velocity, heading) is valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outage {
    /// Its start, s since the start of the drive.
    pub at_s: f64,
    /// Its length, s.
    pub duration_s: f64,
}

impl Outage {
    /// Whether `sample` (of a drive that started at `start_ns`) falls in it.
    pub fn hides(&self, sample: &Sample, start_ns: u64) -> bool {
        let t = (sample.t_ns() as f64 - start_ns as f64) * 1e-9;
        Self::darkens(sample.kind()) && t >= self.at_s && t < self.at_s + self.duration_s
    }

    /// Whether an outage hides samples of `kind` (the GNSS receiver's).
    pub fn darkens(kind: fusion_shared::SampleKind) -> bool {
        use fusion_shared::SampleKind::{Geodetic, Heading, Position, Velocity};
        matches!(kind, Position | Geodetic | Velocity | Heading)
    }

    /// How much of the first `until_s` seconds of the drive it covers, s.
    pub fn within_s(&self, until_s: f64) -> f64 {
        ((self.at_s + self.duration_s).min(until_s) - self.at_s.max(0.0)).max(0.0)
    }
}

/// The arrivals of one sensor stream without the samples `outages` hide, their
/// sequence numbers closed up: a receiver in a tunnel sends nothing, so nothing
/// is lost.
pub fn without_outages(
    arrivals: impl Iterator<Item = Arrival>,
    outages: Vec<Outage>,
    start_ns: u64,
) -> impl Iterator<Item = Arrival> {
    let mut hidden = 0u64;
    arrivals.filter_map(move |mut a| {
        if outages.iter().any(|o| o.hides(&a.sample, start_ns)) {
            hidden += 1;
            return None;
        }
        let h = a.sample.header_mut();
        h.seq -= hidden;
        Some(a)
    })
}

impl std::str::FromStr for Outage {
    type Err = String;

    /// `AT:SECONDS`, e.g. `20:45` (from 20 s into the drive, for 45 s).
    fn from_str(text: &str) -> Result<Self, String> {
        let stop: Stop = text.parse()?;
        Ok(Self { at_s: stop.at_s, duration_s: stop.duration_s })
    }
}

impl Default for ScenarioConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            duration_s: 20.0,
            start_ns: 1_000_000_000,
            imu: ImuConfig::default(),
            extra_imus: Vec::new(),
            imu_output: ImuOutput::WorldAcceleration,
            position: PositionConfig::default(),
            aiding: Vec::new(),
            stops: Vec::new(),
            outages: Vec::new(),
        }
    }
}

impl ScenarioConfig {
    /// Every sensor besides the IMUs: the position sensor (unless its rate is
    /// 0), then `aiding`.
    pub fn aiding_sims(&self) -> impl Iterator<Item = &dyn AidingSim> {
        let position: &dyn AidingSim = &self.position;
        let position = (self.position.rate_hz > 0.0).then_some(position);
        position.into_iter().chain(self.aiding.iter().map(|a| &**a))
    }

    /// The drive's truth: the trajectory of `seed` with `stops`, or why the
    /// stops are not valid.
    pub fn trajectory(&self) -> Result<CarTrajectory, String> {
        CarTrajectory::new(self.seed).with_stops(&self.stops)
    }

    /// Every IMU: `imu`, then `extra_imus`.
    pub fn imus(&self) -> impl Iterator<Item = &ImuConfig> {
        std::iter::once(&self.imu).chain(&self.extra_imus)
    }
}

impl Scenario {
    /// Simulates a drive.
    ///
    /// # Panics
    /// If `config.stops` are out of order or not finite: check them first with
    /// [`ScenarioConfig::trajectory`] (as `fusion-sim` does).
    pub fn generate(config: &ScenarioConfig) -> Self {
        let trajectory = config.trajectory().unwrap_or_else(|e| panic!("ScenarioConfig::stops: {e}"));
        let end_ns = config.start_ns + to_ns(config.duration_s);
        let imu = config.imus().flat_map(|imu| {
            ImuSim::new(trajectory.clone(), imu.clone(), config.imu_output, config.start_ns, config.seed)
                .take_while(|a| a.sample.t_ns() <= end_ns)
        });
        let aiding = config.aiding_sims().flat_map(|sim| {
            let arrivals = sim.arrivals(&trajectory, config.start_ns, config.seed);
            without_outages(arrivals, config.outages.clone(), config.start_ns).take_while(|a| a.sample.t_ns() <= end_ns)
        });
        let mut arrivals: Vec<Arrival> = imu.chain(aiding).collect();
        arrivals.sort_by_key(|a| (a.arrival_ns, a.sample.t_ns()));
        Self { trajectory, start_ns: config.start_ns, arrivals }
    }

    /// The truth at a sample time, ns.
    pub fn truth_at(&self, t_ns: u64) -> TruthState {
        self.trajectory.at((t_ns as f64 - self.start_ns as f64) * 1e-9)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn positions_arrive_late_and_out_of_order() {
        let s = Scenario::generate(&ScenarioConfig {
            imu: ImuConfig { rate_hz: 200.0, jitter_ns: 500_000, ..Default::default() },
            ..Default::default()
        });
        let n_imu = s.arrivals.iter().filter(|a| matches!(a.sample, Sample::Imu(_))).count();
        let n_pos = s.arrivals.len() - n_imu;
        // 20 s at 200 Hz; the last one may jitter past the end.
        assert!((4000..=4001).contains(&n_imu) && n_pos == 201, "{n_imu} {n_pos}");
        // Arrival order differs from timestamp order.
        let out_of_order = s.arrivals.windows(2).filter(|w| w[1].sample.t_ns() < w[0].sample.t_ns()).count();
        assert!(out_of_order > 150);
        for a in &s.arrivals {
            let delay = a.arrival_ns - a.sample.t_ns();
            if let Sample::Position(_) = a.sample {
                assert!((20_000_000..=120_000_000).contains(&delay));
            }
        }
    }

    #[test]
    fn outliers_are_flagged_and_far_off() {
        let s = Scenario::generate(&ScenarioConfig {
            position: PositionConfig { outlier_probability: 0.1, dropout_probability: 0.1, ..Default::default() },
            ..Default::default()
        });
        let mut outliers = 0;
        for a in &s.arrivals {
            if let Sample::Position(p) = a.sample {
                let err = (Vector3::from(p.pos_m) - s.truth_at(p.header.t_ns).pos_m).norm();
                assert_eq!(a.outlier, err > 10.0, "err {err}");
                outliers += a.outlier as usize;
            }
        }
        assert!(outliers > 5);
    }

    #[test]
    fn the_same_seed_gives_the_same_drive() {
        let c = ScenarioConfig { duration_s: 2.0, ..Default::default() };
        assert_eq!(Scenario::generate(&c).arrivals, Scenario::generate(&c).arrivals);
    }

    #[test]
    fn an_outage_hides_the_gnss_kinds_inside_it_and_loses_nothing() {
        let plain = ScenarioConfig { duration_s: 10.0, ..Default::default() };
        let tunnel = ScenarioConfig { outages: vec![Outage { at_s: 3.0, duration_s: 4.0 }], ..plain.clone() };
        let (before, after) = (Scenario::generate(&plain), Scenario::generate(&tunnel));
        let t = |a: &Arrival| (a.sample.t_ns() - plain.start_ns) as f64 * 1e-9;
        let fixes = |s: &Scenario| -> Vec<Arrival> {
            s.arrivals.iter().filter(|a| matches!(a.sample, Sample::Position(_))).copied().collect()
        };
        let (all, kept) = (fixes(&before), fixes(&after));
        assert_eq!(kept.len(), all.iter().filter(|a| !(3.0..7.0).contains(&t(a))).count());
        assert!(kept.iter().all(|a| !(3.0..7.0).contains(&t(a))));
        // Sequence numbers close up: a receiver in a tunnel sends nothing, nothing is lost.
        assert!(kept.iter().enumerate().all(|(i, a)| a.sample.header().seq == i as u64));
        // The IMU is not hidden.
        let imu = |s: &Scenario| s.arrivals.iter().filter(|a| matches!(a.sample, Sample::Imu(_))).count();
        assert_eq!(imu(&before), imu(&after));
        assert_eq!("20:45".parse::<Outage>(), Ok(Outage { at_s: 20.0, duration_s: 45.0 }));
        assert!("20".parse::<Outage>().is_err());
    }
}
