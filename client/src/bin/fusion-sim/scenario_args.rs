//! `fusion-sim`'s simulated drive as flags: the trajectory and its faults
//! here, each sensor's rate, noise and mounting declared by its kind
//! (`fusion_client::sim::flags`), built into a [`ScenarioConfig`].

use clap::Args;
use fusion_client::sim::flags::{DriveFlags, KindsFlags};
use fusion_client::sim::{Outage, ScenarioConfig, Stop};

/// Sensor and trajectory settings.
#[derive(Args, Clone)]
pub(crate) struct SimArgs {
    /// Seed of the trajectory and all noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Length of the drive, s.
    #[arg(long, default_value_t = 20.0)]
    duration: f64,
    /// A stop of the car, `AT:SECONDS[:REVERSE]`: it brakes from AT s into the
    /// drive, stands still for SECONDS (4 s after braking starts), reverses for
    /// REVERSE s if given (up to a quarter of the road's speed backwards) and
    /// drives off (4 s to full speed). Repeat for more stops, in order.
    #[arg(long, value_name = "AT:SECONDS[:REVERSE]")]
    stop: Vec<Stop>,
    /// A GNSS outage (a tunnel), `AT:SECONDS`: no position, geodetic, velocity or
    /// heading sample valid from AT s into the drive for SECONDS. Repeatable.
    #[arg(long, value_name = "AT:SECONDS")]
    outage: Vec<Outage>,
    /// Trajectory time 0 as a sample timestamp, ns (record only).
    #[arg(long, default_value_t = 1_000_000_000)]
    start_ns: u64,
    #[command(flatten)]
    drive: DriveFlags,
    #[command(flatten)]
    kinds: KindsFlags,
}

impl SimArgs {
    /// The drive as the flags give it: the trajectory, then each kind's
    /// sensor as its flags say (the IMUs, the position fixes, and each aiding
    /// sensor whose rate is above 0).
    pub(crate) fn scenario(&self) -> anyhow::Result<ScenarioConfig> {
        let mut c = ScenarioConfig {
            seed: self.seed,
            duration_s: self.duration,
            start_ns: self.start_ns,
            stops: self.stop.clone(),
            outages: self.outage.clone(),
            ..Default::default()
        };
        c.trajectory().map_err(|e| anyhow::anyhow!("--stop: {e}"))?;
        self.kinds.apply(&self.drive, &mut c)?;
        Ok(c)
    }
}
