//! Tests of `fusionctl plot`.

use super::*;

/// CLOCK_MONOTONIC seconds are said as such; a ROS bag's wall-clock
/// stamps as the date they are.
#[test]
fn time_zero_is_said_on_its_own_clock() {
    assert_eq!(time_zero(12.5), "12.500 s of CLOCK_MONOTONIC");
    assert_eq!(time_zero(1_478_087_696.25), "2016-11-02 11:54:56.250 UTC (the input's wall-clock stamps)");
    assert!(time_zero(951_782_400.0 + 1e8).starts_with("2003-"), "{}", time_zero(951_782_400.0 + 1e8));
    assert!(time_zero(1_709_164_800.0).starts_with("2024-02-29 00:00:00.000"), "a leap day");
}

/// A σ that drops at every fix (10 Hz) and grows between them (100 Hz
/// samples) over 100 s, on 500 columns: one edge point a column, the
/// highest and lowest of its teeth, not 10 000 bars.
#[test]
fn a_saw_tooth_band_is_drawn_as_its_edge() {
    let band: Vec<(f64, f64, f64)> = (0..10_000).map(|i| (i as f64 * 0.01, 0.0, 1.0 + (i % 10) as f64 * 0.1)).collect();
    let edge = pages::envelope(&band, 0.0..100.0, 500);
    assert_eq!(edge.len(), 500);
    assert!(edge.iter().all(|e| (e.1 - 1.9).abs() < 1e-12 && (e.2 + 1.9).abs() < 1e-12), "{:?}", &edge[..3]);
    assert!(edge.windows(2).all(|w| w[1].0 > w[0].0));
}

/// No tick reads `-0`.
#[test]
fn no_tick_reads_minus_zero() {
    for v in [-0.0, -1e-17, -1e-300] {
        assert!(!pages::tick(&v).starts_with('-'), "{v}: {}", pages::tick(&v));
    }
    assert_eq!(pages::tick(&-2.5), "-2.5");
}
