//! New timelines: a recording's clock set ahead or back, a sensor on another clock.

use super::*;

/// A recording whose clock was set an hour ahead or back halfway (a robot's
/// wall clock stepped by NTP): without a clock, the first
/// [`JUMP_CONFIRMATION`] samples after the step are refused with the way they
/// jump, the next one begins a new timeline, and from it the run is bit for
/// bit a fresh engine's on the rest of the recording; every entry before it
/// was handed out final, as a fresh engine's on the first half. Nothing is
/// counted lost, rate-limited, restarted or too late.
#[test]
fn without_a_clock_a_clock_set_ahead_or_back_starts_a_new_timeline() {
    let hour = 3_600_000_000_000i128;
    for (step, why) in [(hour, Rejection::TimeJump), (-hour, Rejection::TimeStepBack)] {
        let clean = stream();
        let half = clean.len() / 2;
        let mut stepped = clean.clone();
        // The first half stamped an hour later than the second for a step back.
        let moved = if step > 0 { &mut stepped[half..] } else { &mut stepped[..half] };
        moved.iter_mut().for_each(|s| s.header_mut().t_ns += hour as u64);
        let mut e = engine(None);
        let mut finals = Vec::new();
        let mut sink = |x: &Entry<_>| {
            finals.push((x.key, LinearModel::x(&x.state).to_vec(), LinearModel::covariance(&x.state).to_vec()))
        };
        let outcomes: Vec<Insert> = stepped.iter().map(|s| e.insert(s, None, &mut sink)).collect();
        e.flush(&mut sink);
        let confirm = half + JUMP_CONFIRMATION as usize;
        assert!(outcomes[half..confirm].iter().all(|o| *o == Insert::Rejected(why)), "{step}: {outcomes:?}");
        assert!(matches!(outcomes[confirm], Insert::Processed { replayed: 0, .. }), "{step}: {:?}", outcomes[confirm]);
        assert!(outcomes[..half].iter().chain(&outcomes[confirm..]).all(|o| matches!(o, Insert::Processed { .. })));
        assert_eq!(e.stats().new_timelines, 1);
        let first_new = stepped[half].t_ns() as i128;
        let newest_old = stepped[..half].iter().map(|s| s.t_ns()).max().unwrap() as i128;
        assert_eq!(e.stats().last_timeline_step_ns, first_new - newest_old);
        let mut expect = run(&mut engine(None), &stepped[..half]);
        expect.extend(run(&mut engine(None), &stepped[confirm..]));
        assert_eq!(finals, expect, "{step}: the old timeline's run, then a fresh engine's on the new one");
        for row in e.sensors() {
            let n = row.stats;
            assert_eq!((n.lost, n.rate_limited, n.restarts, n.too_late, n.duplicate), (0, 0, 0, 0, 0), "{step}: {n:?}");
        }
        assert_accounted(&e);
    }
}

/// A sensor stamping on another clock, an hour behind the others, among them:
/// each of its samples is refused as stepping back (no run forms while the
/// others' samples come between), and the others' estimate is as without it.
#[test]
fn without_a_clock_a_sensor_an_hour_behind_the_others_is_refused_as_stepping_back() {
    let hour = 3_600_000_000_000u64;
    let mut clean: Vec<Sample> = stream().into_iter().filter(|s| s.kind() == SampleKind::Imu).collect();
    clean.iter_mut().for_each(|s| s.header_mut().t_ns += 2 * hour);
    let mut mixed = Vec::new();
    for (k, s) in clean.iter().enumerate() {
        mixed.push(*s);
        if k % 2 == 0 {
            let mut fix = pos(0, k as u64 / 2, 0.0);
            fix.header_mut().t_ns = s.t_ns() + 1_000_000 - hour;
            mixed.push(fix);
        }
    }
    let (mut a, mut b) = (engine(None), engine(None));
    let expect = run(&mut a, &clean);
    let got = run(&mut b, &mixed);
    assert_eq!(expect, got);
    // Never valid, the fixes take no sensor row: counted engine-wide.
    assert_eq!(b.stats().rejections[Rejection::TimeStepBack.code() as usize], 200);
    assert_eq!((b.stats().unknown_sensor, b.stats().new_timelines), (200, 0));
}
