//! Arbitrary bytes into the two parsers that read what users and peers hand in:
//! the JSONL sample parser of `fusiond replay` and the config. Neither may panic;
//! each gives a sample or config, or an error. Bounded for CI by the case count
//! (`PROPTEST_CASES` raises it for a longer run).

use fusion_daemon::config::Config;
use fusion_daemon::replay::{parse_line, replay};
use proptest::prelude::*;

/// Strings near the real formats, so the fuzzing goes past the first byte.
fn near_jsonl() -> impl Strategy<Value = String> {
    let keys = prop::sample::select(vec!["imu", "position", "velocity", "geodetic", "odometry", "heading", "x"]);
    let fields = prop::collection::vec(
        (
            prop::sample::select(vec![
                "t_ns", "sensor", "seq", "accel", "gyro", "pos", "cov", "vel", "lat_deg", "lon_deg", "speed", "yaw",
                "var",
            ]),
            prop_oneof![
                any::<u64>().prop_map(|v| v.to_string()),
                any::<f64>().prop_map(|v| format!("{v:?}")),
                prop::collection::vec(any::<f64>(), 0..10).prop_map(|v| format!("{v:?}")),
                Just("null".to_string()),
                Just("-1".to_string()),
                Just("1e999".to_string()),
            ],
        ),
        0..8,
    );
    (keys, fields).prop_map(|(k, f)| {
        let body: Vec<String> = f.iter().map(|(n, v)| format!("\"{n}\": {v}")).collect();
        format!("{{\"{k}\": {{{}}}}}", body.join(", "))
    })
}

fn near_config() -> impl Strategy<Value = String> {
    let tables = prop::sample::select(vec![
        "[model]",
        "[filter]",
        "[gating]",
        "[health]",
        "[validation]",
        "[datum]",
        "[[sensor]]",
        "[imu]",
        "[x]",
    ]);
    let keys = prop::sample::select(vec![
        "kind",
        "accel_noise_std",
        "initial_state",
        "initial_covariance_diagonal",
        "history_ns",
        "history_capacity",
        "probability",
        "max_sensors",
        "max_rate_hz",
        "max_burst",
        "max_past_ns",
        "latitude_deg",
        "id",
        "kinds",
        "axes",
        "rotation_rpy_deg",
        "lever_arm_m",
        "combine",
        "name",
    ]);
    let values = prop_oneof![
        any::<i64>().prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| format!("{v:?}")),
        Just("\"linear\"".to_string()),
        Just("\"ins\"".to_string()),
        Just("[0,0,0,0,0,0]".to_string()),
        Just("[\"imu\"]".to_string()),
        Just("nan".to_string()),
        Just("-inf".to_string()),
    ];
    prop::collection::vec((tables, prop::collection::vec((keys, values), 0..5)), 0..6).prop_map(|t| {
        t.iter()
            .map(|(table, kv)| {
                let lines: Vec<String> = kv.iter().map(|(k, v)| format!("{k} = {v}")).collect();
                format!("{table}\n{}\n", lines.join("\n"))
            })
            .collect()
    })
}

const CONFIG: &str = "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\ninitial_state = [0,0,0,0,0,0]\n\
                      initial_covariance_diagonal = [100,100,100,10,10,10]\n";

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(2000),
        ..ProptestConfig::default()
    })]

    #[test]
    fn the_sample_parser_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..300), text in near_jsonl()) {
        let _ = parse_line(&String::from_utf8_lossy(&bytes));
        let _ = parse_line(&text);
    }

    #[test]
    fn the_config_parser_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..300), text in near_config()) {
        let _ = Config::parse(&String::from_utf8_lossy(&bytes));
        let _ = Config::parse(&text);
    }

    /// Whole files of arbitrary lines through `fusiond replay`'s code: an error or
    /// a summary, never a panic; smoothing succeeds whenever filtering does.
    #[test]
    fn replay_of_arbitrary_lines_never_panics(
        lines in prop::collection::vec(prop_oneof![near_jsonl(), any::<String>()], 1..20),
        raw in prop::collection::vec(any::<u8>(), 0..200),
    ) {
        let config = Config::parse(CONFIG).unwrap();
        let mut input = lines.join("\n").into_bytes();
        input.push(b'\n');
        input.extend_from_slice(&raw);
        let plain = replay(&config, &input[..], Some(std::io::sink()), false);
        let smoothed = replay(&config, &input[..], Some(std::io::sink()), true);
        // `--smooth` never fails on input that plain replay accepts.
        prop_assert_eq!(plain.is_ok(), smoothed.is_ok(), "{:?} / {:?}", plain.err(), smoothed.err());
    }
}
