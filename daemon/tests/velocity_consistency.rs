//! The `linear` model with GNSS velocity on simulated drives: consistent (NEES of
//! position and velocity per degree of freedom near 1) and more accurate than
//! without the velocity.
//!
//! Monte Carlo over 20 drives of 20 s: 200 Hz world-frame IMU (0.1 m/s² noise per
//! sample, so σₐ = 0.1 is the true process noise), 10 Hz fixes (0.5 m, 0.8 m
//! vertical) and 10 Hz velocities (0.05 m/s, 0.1 m/s vertical), both arriving
//! 20–120 ms late. NEES over the final estimates after the first 2 s.

use fusion_client::sim::{Scenario, ScenarioConfig, VelocityConfig};
use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig, Entry};
use fusion_daemon::model::Model;
use fusion_daemon::model::linear::LinearModel;
use nalgebra::{Matrix6, Vector6};

const CONFIG: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.1\n[filter]\n\
    initial_state = [0, 0, 0, 0, 0, 0]\ninitial_covariance_diagonal = [100, 100, 100, 225, 225, 225]\n";

/// (NEES sum over p and v, count, position squared error sum).
#[allow(non_snake_case)]
fn run(seed: u64, velocity: bool) -> (f64, u64, f64) {
    let mut c = ScenarioConfig { seed, duration_s: 20.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.imu.accel_noise_std = 0.1;
    if velocity {
        c.aiding.push(std::sync::Arc::new(VelocityConfig::default()));
    }
    let scenario = Scenario::generate(&c);
    let config = Config::parse(CONFIG).unwrap();
    let mut engine = Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let (mut nees, mut n, mut sq) = (0.0, 0u64, 0.0);
    let mut take = |e: &Entry<_>| {
        if e.key.t_ns < scenario.start_ns + 2_000_000_000 {
            return;
        }
        let truth = scenario.truth_at(e.key.t_ns);
        let x = LinearModel::x(&e.state);
        let err =
            Vector6::from_iterator((0..6).map(|i| x[i] - if i < 3 { truth.pos_m[i] } else { truth.vel_mps[i - 3] }));
        let P = Matrix6::from_column_slice(&LinearModel::covariance(&e.state));
        nees += (err.transpose() * P.try_inverse().unwrap() * err)[(0, 0)];
        sq += err.fixed_rows::<3>(0).norm_squared();
        n += 1;
    };
    for a in &scenario.arrivals {
        engine.insert(&a.sample, None, &mut take);
    }
    engine.flush(&mut take);
    (nees, n, sq)
}

#[test]

fn velocity_keeps_the_filter_consistent_and_lowers_the_position_error() {
    let (mut with, mut without) = ((0.0, 0, 0.0), (0.0, 0, 0.0));
    for seed in 1..=20 {
        let (a, b) = (run(seed, true), run(seed, false));
        with = (with.0 + a.0, with.1 + a.1, with.2 + a.2);
        without = (without.0 + b.0, without.1 + b.1, without.2 + b.2);
    }
    let nees_with = with.0 / with.1 as f64 / 6.0;
    let nees_without = without.0 / without.1 as f64 / 6.0;
    let (rmse_with, rmse_without) = ((with.2 / with.1 as f64).sqrt(), (without.2 / without.1 as f64).sqrt());
    println!(
        "NEES/dof of p, v: {nees_with:.3} with velocity, {nees_without:.3} without; \
         position RMSE {rmse_with:.3} m with velocity, {rmse_without:.3} m without"
    );
    assert!((0.8..=1.25).contains(&nees_with), "NEES/dof with velocity {nees_with}");
    assert!(rmse_with < rmse_without, "RMSE {rmse_with} with velocity, {rmse_without} without");
}
