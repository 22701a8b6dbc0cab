//! f32 against f64, Joseph against UDU (`fusion_benches::precision`): the stress
//! case where single-precision Joseph loses positive definiteness and UDU does
//! not, and the `ins` model's error-state filter in f32 over an hour's drive. The
//! example `precision` prints all the tables of the report.

#[path = "../../daemon/tests/common/heartbeat.rs"]
mod heartbeat;

use fusion_benches::precision::{Comparison, compare, drives, ins_runs, linear_runs, table, time_ordered};

fn row<'a>(rows: &'a [Comparison], name: &str) -> &'a Comparison {
    rows.iter().find(|c| c.name == name).expect("a run of that name")
}

#[test]
fn f32_joseph_loses_positive_definiteness_with_very_accurate_fixes_and_f32_udu_does_not() {
    // Fixes of σ 0.1 mm on a start of σ 100 m: the first updates shrink the
    // position variance by 10¹², beyond what f32 (ε ≈ 6·10⁻⁸) can cancel.
    let (scenario, model) = drives::linear(30.0, 1e-4, 1);
    let rows = compare(&mut linear_runs(&model), &time_ordered(&scenario), |t| scenario.truth_at(t).pos_m);
    eprintln!("{}", table(&rows));
    let (joseph, udu, udu64) = (row(&rows, "f32 joseph"), row(&rows, "f32 udu"), row(&rows, "f64 udu"));
    assert!(joseph.not_positive_definite > 0, "f32 Joseph kept P positive definite: {joseph:?}");
    assert!(joseph.min_correlation_eigenvalue < 0.0);
    assert_eq!(udu.not_positive_definite, 0, "{udu:?}");
    assert!(udu.min_correlation_eigenvalue > 0.1, "{udu:?}");
    // Against the f64 run the f32 UDU's position standard deviations stay as
    // close as the f64 UDU's do (both differ from f64 Joseph's rounding of the
    // first fix by the same amount).
    assert!(udu.max_position_sd_rel_diff <= udu64.max_position_sd_rel_diff + 1e-4, "{udu:?} against {udu64:?}");
    assert!(udu.end_position_diff_m < 1e-3, "{udu:?}");
}

/// An hour of 200 Hz `ins` with 10 Hz fixes: the error-state filter in f32, in
/// either form, stays positive definite and within 0.1 mm and 0.01 % (position
/// σ) of f64 (35 s in the test profile; the figures of the report come from the
/// example `precision` in release).
#[test]
fn one_hour_of_ins_in_f32_stays_positive_definite_and_close_to_f64() {
    let _beat = heartbeat::Heartbeat::start("an hour of ins in f32 and f64", std::time::Duration::from_secs(40));
    let (scenario, model) = drives::ins(3600.0, 0.5, 2);
    let rows = compare(&mut ins_runs(&model), &time_ordered(&scenario), |t| scenario.truth_at(t).pos_m);
    eprintln!("{}", table(&rows));
    assert_eq!(rows[0].steps, 756_002);
    for name in ["f64 udu", "f32 joseph", "f32 udu"] {
        let c = row(&rows, name);
        assert_eq!((c.not_positive_definite, c.refused), (0, 0), "{c:?}");
        assert!(c.max_position_diff_m < 1e-4 && c.max_position_sd_rel_diff < 1e-4, "{c:?}");
    }
}
