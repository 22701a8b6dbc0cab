//! Tests of `fusionctl top`.

use super::*;
use fusion_shared::SampleKind;
use ratatui::Terminal;
use ratatui::backend::TestBackend;

fn screen(view: &View) -> String {
    screen_of(view, 140, 30)
}

fn screen_of(view: &View, width: u16, height: u16) -> String {
    let mut terminal = Terminal::new(TestBackend::new(width, height)).unwrap();
    terminal.draw(|frame| draw(frame, view)).unwrap();
    let buffer = terminal.backend().buffer();
    (0..buffer.area.height)
        .map(|y| (0..buffer.area.width).map(|x| buffer[(x, y)].symbol()).collect::<String>() + "\n")
        .collect()
}

#[test]
fn the_dashboard_shows_health_sensors_estimate_and_latency() {
    let mut s = StateSnapshot {
        model: model::LINEAR,
        health: health::DEGRADED,
        health_reasons: health::IMU_STALE,
        state_len: 6,
        cov_dim: 6,
        sensor_count: 2,
        input_kind: SampleKind::Position as u32,
        input_sent_ns: 1_000,
        publish_ns: 51_000,
        ..Default::default()
    };
    s.x[0] = 12.5;
    s.cov[0] = 0.25;
    s.sensors[0].kind = SampleKind::Imu as u32;
    s.sensors[0].counts.received = 400;
    s.sensors[1].kind = SampleKind::Position as u32;
    s.sensors[1].sensor = 1;
    s.sensors[1].counts.received = 10;
    s.sensors[1].counts.gated = 3;
    s.sensors[1].last_nis = 2.5;
    let start = Instant::now();
    let mut view = View::new("test-ns");
    view.add(&s, start);
    s.sensors[0].counts.received = 1200;
    view.add(&s, start + RATE_WINDOW);
    let text = screen(&view);
    assert!(text.contains("estimate settled (every sample received is in); 0 of 2"), "{text}");
    (s.pending_steps, s.pending_since_t_ns) = (12, 1_500_000_000);
    view.add(&s, start + RATE_WINDOW);
    let text = screen(&view);
    assert!(text.contains("provisional: lacks the late sample at t 1.500 s, 12 later samples"), "{text}");
    assert!(!text.contains("standing still"), "{text}");
    s.standing = 1;
    view.add(&s, start + RATE_WINDOW);
    assert!(screen(&view).contains("to re-process; standing still (attitude held)"), "{}", screen(&view));
    for needle in [
        "namespace test-ns",
        "health degraded (imu stale)",
        "model linear",
        "imu 0",
        "position 1",
        "400.0", // (1200 − 400) / 2 s
        "2.50",
        "p_x m",
        "12.5000",
        "0.5000", // √0.25
        "p50 50.0",
        "q: quit",
    ] {
        assert!(text.contains(needle), "{needle:?} not on the screen:\n{text}");
    }
}

/// At 80×26 a vehicle's dashboard shows the whole `ins` estimate (with the
/// odometry scale, and roll, pitch and yaw), every sensor and whole column
/// names, below a header wrapped to four lines (at 80×24 two sensors are
/// said to be hidden: the next test).
#[test]
fn at_80_by_26_the_whole_ins_estimate_and_every_sensor_show() {
    use fusion_shared::snapshot::aux;
    let mut s = StateSnapshot {
        model: model::INS,
        health: health::OK,
        state_len: 17,
        cov_dim: 16,
        aux_states: aux::ODOMETRY_SCALE,
        sensor_count: 6,
        ..Default::default()
    };
    s.x[6] = 1.0;
    s.x[16] = 1.0098;
    (0..16).for_each(|i| s.cov[i * 16 + i] = 1e-4);
    let kinds = [(SampleKind::Imu, 0), (SampleKind::Imu, 1), (SampleKind::Geodetic, 3), (SampleKind::Velocity, 3)];
    let more = [(SampleKind::Odometry, 0), (SampleKind::Magnetometer, 0)];
    for (i, (kind, id)) in kinds.iter().chain(more.iter()).enumerate() {
        s.sensors[i].kind = *kind as u32;
        s.sensors[i].sensor = *id;
        s.sensors[i].counts.received = 123_456;
    }
    s.sensors[5].counts.refused = 4321;
    let mut view = View::new("vehicle");
    view.add(&s, Instant::now());
    let text = screen_of(&view, 80, 26);
    for (name, _) in s.state_layout() {
        let name = name.replace("rad/s", "deg/h");
        assert!(text.contains(&name), "{name:?} not on the 80x26 screen:\n{text}");
    }
    for needle in [
        "roll deg",
        "pitch deg",
        "yaw deg",
        "1.0098",
        "imu 0",
        "imu 1",
        "geodetic 3",
        "velocity 3",
        "odometry 0",
        "magnetometer 0",
        "recv",
        "fused",
        "gated",
        "refus",
        "4321",
        "2late",
        "inval",
        "lost",
        "other",
        "NIS",
        "123456",
        "q: quit",
    ] {
        assert!(text.contains(needle), "{needle:?} not on the 80x24 screen:\n{text}");
    }
}

/// At 80×24 with every auxiliary state and more sensors than fit: the
/// rows that do not fit are said, the states' names are whole, and the
/// gyroscope biases are in deg/h as in the plots.
#[test]
fn at_80_by_24_hidden_sensors_are_said_and_names_are_whole() {
    use fusion_shared::snapshot::aux;
    let mut s = StateSnapshot {
        model: model::INS,
        health: health::OK,
        state_len: 22,
        cov_dim: 21,
        aux_states: aux::ODOMETRY_SCALE | aux::BARO_BIAS | aux::POSE_FRAME,
        sensor_count: 9,
        ..Default::default()
    };
    s.x[6] = 1.0;
    s.x[15] = 1e-4; // b_gz: 20.63 deg/h
    (0..21).for_each(|i| s.cov[i * 21 + i] = 1e-8);
    for i in 0..9 {
        s.sensors[i].kind = SampleKind::Imu as u32;
        s.sensors[i].sensor = i as u32;
    }
    let mut view = View::new("vehicle");
    view.add(&s, Instant::now());
    let text = screen_of(&view, 80, 24);
    for (_, name) in &aux::ALL[..6] {
        assert!(text.contains(name), "{name:?} cut or missing:\n{text}");
    }
    assert!(text.contains("b_gz deg/h") && text.contains("20.63"), "{text}");
    let shown = (0..9).filter(|i| text.contains(&format!("imu {i} "))).count();
    assert!(shown < 9 && text.contains(&format!("… {} more", 9 - shown)), "{shown} shown:\n{text}");
    assert!(text.contains(&format!("({shown} of 9 shown")), "{text}");
}

/// Every sample refused: the dashboard says so, by reason with its setting.
#[test]
fn refusals_show_with_their_setting() {
    let mut s = StateSnapshot::default();
    s.rejections[rejection::PAST_TIMESTAMP as usize] = 1072;
    let mut view = View::new("ns");
    view.add(&s, Instant::now());
    let text = screen(&view);
    assert!(
        text.contains("refused in validation: 1072 (timestamp too far in the past 1072: [validation] max_past_ns)"),
        "{text}"
    );
}

/// At 80 and 100 columns the header's lines wrap between words instead of
/// being cut (the health's reasons, the re-initialisations' count, the
/// snapshots read); from 120 to 143 columns the sensor table keeps its
/// narrow form, whose names and headers fit, and from 144 on the wide one.
#[test]
fn the_header_wraps_and_the_table_fits_at_every_width() {
    let mut s = StateSnapshot {
        model: model::INS,
        health: health::DEGRADED,
        health_reasons: health::NIS_OUT_OF_BOUNDS
            | health::SAMPLES_LOST
            | health::stale(SampleKind::Velocity)
            | health::stale(SampleKind::Geodetic),
        state_len: 16,
        cov_dim: 15,
        sensor_count: 2,
        reinitialisations: 7,
        seq: 123_456,
        ..Default::default()
    };
    s.x[6] = 1.0;
    s.sensors[0].kind = SampleKind::Magnetometer as u32;
    s.sensors[0].sensor = 12;
    s.sensors[1].kind = SampleKind::Imu as u32;
    let mut view = View::new("vehicle");
    view.add(&s, Instant::now());
    let words = |t: &str| t.split_whitespace().map(String::from).collect::<Vec<_>>();
    for width in [80, 100, 120, 130, 144, 145, 160] {
        let text = screen_of(&view, width, 40);
        let flat = words(&text).join(" ");
        for said in [
            "(nis out of bounds, samples lost, velocity stale, geodetic stale)",
            "re-initialisations 7",
            "read were provisional",
            "magnetometer 12",
        ] {
            assert!(flat.contains(said), "{width} columns: {said:?} cut:\n{text}");
        }
        let heads: &[&str] = if width >= WIDE { &["too late", "restarts"] } else { &["2late", "other"] };
        for head in heads {
            assert!(text.contains(head), "{width} columns: {head:?}:\n{text}");
        }
    }
}

#[test]
fn before_the_first_snapshot_it_says_what_it_waits_for() {
    let mut view = View::new("ns");
    view.daemon_running = Some(true);
    let text = screen(&view);
    assert!(text.contains("waiting for its first snapshot"), "{text}");
    // A wrong namespace: no fusiond, said as `fusionctl state` says it.
    view.daemon_running = Some(false);
    let text = screen(&view);
    assert!(text.contains("no fusiond runs in namespace") && !text.contains("first snapshot"), "{text}");
}
