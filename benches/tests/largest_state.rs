//! The largest state's rows (`vehicle21` in the latency bench, `daemon_steps
//! vehicle21`) measure what they say: its config builds 21 error states, and
//! the barometer's and the pose sensor's samples are fused, not refused.

use fusion_benches::latency::{VEHICLE21_CONFIG, vehicle_instant, vehicle21_extras};
use fusion_daemon::config::{Config, WithModel, with_model};
use fusion_daemon::engine::{Engine, EngineConfig};
use fusion_daemon::measurement::Steps;
use fusion_shared::{Sample, SampleKind};

struct Drive<'a>(&'a Config);

impl WithModel for Drive<'_> {
    type Output = (usize, Vec<(SampleKind, u64, u64)>);
    fn run<M: Steps>(self, model: M) -> Self::Output {
        let mut engine = Engine::new(model, EngineConfig::from_config(self.0));
        for k in 0..3000u64 {
            let t = 1_000_000_000 + k * 1_000_000;
            let mut instant: Vec<Sample> = vehicle21_extras(t, k).into_iter().collect();
            instant.extend(vehicle_instant(t, k));
            for s in &instant {
                engine.insert(s, None, &mut |_| {});
            }
        }
        let kinds = [SampleKind::Barometer, SampleKind::Pose, SampleKind::Geodetic, SampleKind::Odometry];
        let counts = kinds.iter().map(|&k| (k, engine.totals(Some(k)).received, engine.totals(Some(k)).fused));
        (M::COV_DIM, counts.collect())
    }
}

#[test]
fn the_largest_state_has_21_error_states_and_fuses_every_kind() {
    let config = Config::parse(VEHICLE21_CONFIG).unwrap();
    let (dim, counts) = with_model(&config, Drive(&config));
    assert_eq!(dim, 21);
    for (kind, received, fused) in counts {
        assert!(received > 5, "{kind:?}: {received}");
        if matches!(kind, SampleKind::Barometer | SampleKind::Pose) {
            // Their first sample sets their states; every other one is fused.
            assert_eq!(fused + 1, received, "{kind:?}: {fused} of {received} fused");
        } else {
            assert!(fused * 100 >= received * 95, "{kind:?}: {fused} of {received} fused");
        }
    }
}
