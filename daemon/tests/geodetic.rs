//! Geodetic GNSS fixes end to end through the engine: the first valid fix sets
//! the datum, every fix is fused exactly as the position fix at its ENU
//! coordinates about that datum, and impossible coordinates are rejected,
//! counted, and leave the estimate alone.

use std::sync::Arc;

use fusion_client::sim::{GeodeticConfig, Scenario, ScenarioConfig};
use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig, Insert};
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::linear::LinearModel;
use fusion_daemon::validate::Rejection;
use fusion_shared::geodesy::Datum;
use fusion_shared::{GeodeticSample, PositionSample, Sample, SampleKind};

const LINEAR: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.1\n[filter]\n\
    initial_state = [0, 0, 0, 0, 0, 0]\ninitial_covariance_diagonal = [100, 100, 100, 225, 225, 225]\n";

/// A drive with geodetic fixes only (the ENU fixes left out), in arrival order.
fn geodetic_drive(datum: Datum) -> Vec<Sample> {
    let mut c = ScenarioConfig { seed: 5, duration_s: 10.0, ..Default::default() };
    c.imu.rate_hz = 200.0;
    c.imu.accel_noise_std = 0.1;
    c.aiding.push(Arc::new(GeodeticConfig { datum, ..Default::default() }));
    let arrivals = Scenario::generate(&c).arrivals;
    arrivals.into_iter().map(|a| a.sample).filter(|s| s.kind() != SampleKind::Position).collect()
}

fn engine(config: &str) -> Engine<LinearModel> {
    let config = Config::parse(config).unwrap();
    Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config))
}

/// The same drive with each geodetic fix replaced by the position fix at its ENU
/// coordinates about `datum` (same time, sensor, sequence number, covariance).
fn as_enu(samples: &[Sample], datum: &Datum) -> Vec<Sample> {
    let to_enu = |s: &Sample| match *s {
        Sample::Geodetic(g) => {
            let h = g.header;
            let pos = datum.to_enu(g.lat_deg, g.lon_deg, g.height_m);
            Sample::Position(PositionSample::new(h.t_ns, h.sensor, h.seq, pos, g.cov_enu_m2))
        }
        other => other,
    };
    samples.iter().map(to_enu).collect()
}

#[test]
fn the_first_fix_sets_the_datum_and_fixes_fuse_as_their_enu_coordinates() {
    // Just beside the antimeridian, on the side from which the drive crosses it
    // (a longitude difference taken naively would be 360°).
    let crosses = |samples: &[Sample]| {
        let lon = |s: &Sample| match s {
            Sample::Geodetic(g) => Some(g.lon_deg),
            _ => None,
        };
        samples.iter().filter_map(lon).any(|l| l < 0.0) && samples.iter().filter_map(lon).any(|l| l > 0.0)
    };
    let (datum, samples) = [179.9995, -179.9995]
        .into_iter()
        .map(|lon| Datum::new(-16.80, lon, 12.0).unwrap())
        .map(|d| (d, geodetic_drive(d)))
        .find(|(_, s)| crosses(s))
        .expect("the drive crosses the antimeridian from one side");
    let Some(Sample::Geodetic(first)) = samples.iter().find(|s| s.kind() == SampleKind::Geodetic).copied() else {
        panic!("no geodetic fix")
    };
    assert!(datum.longitude_deg.abs() > 179.0);

    let mut geodetic = engine(LINEAR);
    let mut outputs = Vec::new();
    for s in &samples {
        geodetic.insert(s, None, &mut |e| outputs.push(*e));
    }
    geodetic.flush(&mut |e| outputs.push(*e));
    let picked = *geodetic.model().frames().datum().expect("a datum");
    assert_eq!(picked, Datum::new(first.lat_deg, first.lon_deg, first.height_m).unwrap());

    let mut enu = engine(LINEAR);
    let mut reference = Vec::new();
    for s in &as_enu(&samples, &picked) {
        enu.insert(s, None, &mut |e| reference.push(*e));
    }
    enu.flush(&mut |e| reference.push(*e));
    assert_eq!(outputs.len(), reference.len());
    let fused =
        outputs.iter().filter(|e| e.sample.kind() == SampleKind::Geodetic && e.outcome.accepted() == Some(true));
    assert!(fused.count() > 90, "the fixes are fused");
    for (a, b) in outputs.iter().zip(&reference) {
        let (xa, xb) = (LinearModel::x(&a.state), LinearModel::x(&b.state));
        let worst = xa.iter().zip(xb).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-6, "{xa:?} against {xb:?}");
    }
}

#[test]
fn a_configured_datum_is_kept_and_reported_in_snapshots() {
    let datum = Datum::new(78.2232, 15.6267, 30.0).unwrap();
    let config = format!("{LINEAR}[datum]\nlatitude_deg = 78.2232\nlongitude_deg = 15.6267\nheight_m = 30.0\n");
    let samples = geodetic_drive(datum);
    let mut e = engine(&config);
    for s in &samples {
        e.insert(s, None, &mut |_| {});
    }
    assert_eq!(e.model().frames().datum(), Some(&datum));
    let mut snap = fusion_shared::StateSnapshot::default();
    fusion_daemon::snapshot::fill(&mut snap, &e, None, fusion_daemon::health::HealthNow::INITIALISING);
    assert_eq!(snap.datum(), Some(datum));
    // The estimate, back in geodetic coordinates, is near the last fix.
    let (lat, lon, _) = snap.position_geodetic().unwrap();
    let Some(Sample::Geodetic(last)) = samples.iter().rev().find(|s| s.kind() == SampleKind::Geodetic).copied() else {
        panic!("no fix")
    };
    let off = datum.to_enu(lat, lon, last.height_m);
    let fix = datum.to_enu(last.lat_deg, last.lon_deg, last.height_m);
    assert!((off[0] - fix[0]).hypot(off[1] - fix[1]) < 3.0, "{off:?} {fix:?}");
}

#[test]
fn impossible_fixes_are_rejected_counted_and_change_nothing() {
    let samples = geodetic_drive(GeodeticConfig::default().datum);
    let mut clean = engine(LINEAR);
    let mut dirty = engine(LINEAR);
    for s in &samples {
        clean.insert(s, None, &mut |_| {});
        dirty.insert(s, None, &mut |_| {});
    }
    let t = samples.iter().map(|s| s.t_ns()).max().unwrap();
    let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
    let mut not_spd = cov;
    not_spd[0] = -0.25;
    let bad = [
        (GeodeticSample::new(t, 3, 10_000, 90.5, 11.5, 500.0, cov), Rejection::OutOfRange),
        (GeodeticSample::new(t, 3, 10_001, 48.1, -180.5, 500.0, cov), Rejection::OutOfRange),
        (GeodeticSample::new(t, 3, 10_002, f64::NAN, 11.5, 500.0, cov), Rejection::NonFinite),
        (GeodeticSample::new(t, 3, 10_003, 48.1, 11.5, 500.0, not_spd), Rejection::CovarianceNotPositiveDefinite),
    ];
    for (s, why) in bad {
        assert_eq!(dirty.insert(&Sample::Geodetic(s), None, &mut |_| {}), Insert::Rejected(why));
    }
    assert_eq!(clean.latest().unwrap().state, dirty.latest().unwrap().state);
    assert_eq!(clean.model().frames().datum(), dirty.model().frames().datum());
    let g = dirty.totals(Some(SampleKind::Geodetic));
    assert_eq!(g.invalid, 4);
}

/// Invalid fixes before the first valid one do not become the datum.
#[test]
fn an_invalid_first_fix_does_not_set_the_datum() {
    let mut e = engine(LINEAR);
    let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
    let bad = GeodeticSample::new(1_000, 3, 0, 95.0, 11.5, 500.0, cov);
    assert!(matches!(e.insert(&Sample::Geodetic(bad), None, &mut |_| {}), Insert::Rejected(_)));
    assert!(e.model().frames().datum().is_none());
    let good = GeodeticSample::new(2_000, 3, 1, 48.1, 11.5, 500.0, cov);
    e.insert(&Sample::Geodetic(good), None, &mut |_| {});
    assert_eq!(e.model().frames().datum(), Some(&Datum::new(48.1, 11.5, 500.0).unwrap()));
}

/// The `ins` model fuses geodetic fixes as well (on δp).
#[test]
fn the_ins_model_fuses_geodetic_fixes() {
    let config = Config::parse(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[filter]\n\
         initial_state = [0,0,0, 0,0,0, 1,0,0,0, 0,0,0, 0,0,0]\n\
         initial_covariance_diagonal = [100,100,100, 1,1,1, 0.01,0.01,0.01, 0.01,0.01,0.01, 1e-6,1e-6,1e-6]\n",
    )
    .unwrap();
    let mut e = Engine::new(InsModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
    let cov = [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64];
    let datum = Datum::new(48.1, 11.5, 500.0).unwrap();
    e.insert(&Sample::Geodetic(GeodeticSample::new(1_000, 3, 0, 48.1, 11.5, 500.0, cov)), None, &mut |_| {});
    let (lat, lon, h) = datum.to_geodetic([10.0, -5.0, 1.0]);
    let out = e.insert(&Sample::Geodetic(GeodeticSample::new(2_000, 3, 1, lat, lon, h, cov)), None, &mut |_| {});
    assert!(matches!(out, Insert::Processed { outcome: fusion_daemon::model::StepOutcome::Fused { .. }, .. }));
    // The first fix (at the datum) left δp with about R: the second moves p half way.
    let p = &InsModel::x(&e.latest().unwrap().state)[..3];
    assert!((p[0] - 5.0).abs() < 0.1 && (p[1] + 2.5).abs() < 0.1, "{p:?}");
}
