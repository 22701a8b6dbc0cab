//! The largest state's rows (`vehicle21` in the latency bench, `daemon_steps
//! vehicle21`) measure what they say: its config builds 21 error states, and
//! the barometer's and the pose sensor's samples are fused, not refused.

use fusion_benches::latency::{VEHICLE_IMUS_AT_REST, VEHICLE21_CONFIG, vehicle21_extras};
use fusion_daemon::config::{Config, WithModel, with_model};
use fusion_daemon::engine::{Engine, EngineConfig};
use fusion_daemon::measurement::Steps;
use fusion_shared::{GeodeticSample, ImuSample, OdometrySample, Sample, SampleKind};

struct Drive<'a>(&'a Config);

impl WithModel for Drive<'_> {
    type Output = (usize, Vec<(SampleKind, u64, u64)>);
    fn run<M: Steps>(self, model: M) -> Self::Output {
        let mut engine = Engine::new(model, EngineConfig::from_config(self.0));
        let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
        for k in 0..3000u64 {
            let t = 1_000_000_000 + k * 1_000_000;
            let mut instant = Vec::new();
            instant.extend(vehicle21_extras(t, k));
            if k % 100 == 50 {
                instant.push(Sample::Geodetic(GeodeticSample::new(t, 3, k / 100, 48.1316, 11.5494, 519.0, cov)));
            }
            if k % 20 == 10 {
                instant.push(Sample::Odometry(OdometrySample::new(t, 0, k / 20, 0.0, 0.01)));
            }
            instant.push(Sample::Imu(ImuSample::new(t, 0, k, VEHICLE_IMUS_AT_REST[0], [0.0; 3])));
            instant.push(Sample::Imu(ImuSample::new(t, 1, k, VEHICLE_IMUS_AT_REST[1], [0.0; 3])));
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
