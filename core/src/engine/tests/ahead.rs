//! Stepping ahead to the next IMU instant ([`Engine::step_ahead`]).

use super::*;

/// States stepped ahead ([`Engine::step_ahead`]) before every arrival: the
/// IMU samples on time start from them, and every decision and estimate is
/// the one of an engine that never steps ahead, bit for bit, through IMU
/// samples off their interval or missing, late fixes and pending rewinds,
/// and a history that evicts by capacity.
#[test]
fn stepping_ahead_changes_no_estimate() {
    for (seed, capacity) in [(1u64, 4096), (2, 4096), (3, 30), (4, 7)] {
        let mut rng = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let mut next = move |n: u64| {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (rng >> 33) % n
        };
        let mut arrivals = Vec::new();
        let (mut t, mut fixes) = (0, 0);
        for i in 0..600u64 {
            // Mostly on the 5 ms interval; now and then off it, or missing.
            t += match next(20) {
                0 => 3,
                1 => 10,
                _ => 5,
            };
            arrivals.push(imu(t, i));
            if next(8) == 0 {
                // A fix between two IMU samples or at one, on time or late.
                let late_ms = [0, 0, 11, 85][next(4) as usize];
                arrivals.push(pos(t.saturating_sub(late_ms) + next(3), fixes, fixes as f64 * 0.1));
                fixes += 1;
            }
        }
        let config = EngineConfig { history_capacity: capacity, ..cfg() };
        let (mut plain, mut ahead) = (Engine::new(model(), config), Engine::new(model(), config));
        let (mut want, mut got) = (Vec::new(), Vec::new());
        for (i, s) in arrivals.iter().enumerate() {
            if i % 3 == 0 {
                // Some of the rewinds settle in idle time, some are pending
                // while the next samples come.
                while plain.settle_step() {}
                while ahead.settle_step() {}
            }
            ahead.step_ahead();
            let a = plain.insert_deferred(s, None, &mut |e| record(&mut want, e));
            let b = ahead.insert_deferred(s, None, &mut |e| record(&mut got, e));
            assert_eq!(a, b, "seed {seed}, arrival {i}");
            assert_eq!(latest(&plain), latest(&ahead), "seed {seed}, arrival {i}");
        }
        plain.flush(&mut |e| record(&mut want, e));
        ahead.flush(&mut |e| record(&mut got, e));
        assert_eq!(got, want, "seed {seed}: final estimates");
        let stats = ahead.stats();
        assert!(stats.stepped_from_ahead > 300, "seed {seed}: {stats:?}");
        assert!(stats.stepped_ahead > stats.stepped_from_ahead, "seed {seed}: some discarded: {stats:?}");
        assert_eq!((plain.stats().stepped_ahead, plain.stats().stepped_from_ahead), (0, 0));
    }
}

/// A state stepped ahead is stepped once per newest state, only to a time
/// after it, and is discarded by anything that changes the history first.
#[test]
fn a_state_stepped_ahead_is_used_once_and_only_at_its_time() {
    let mut e = engine(None);
    let mut sink = |_: &Entry<_>| {};
    assert!(!e.step_ahead(), "nothing held: no next input known");
    e.insert_deferred(&imu(0, 0), None, &mut sink);
    assert!(!e.step_ahead(), "one instant: no interval yet");
    e.insert_deferred(&imu(5, 1), None, &mut sink);
    assert!(e.step_ahead(), "the next instant is due at 10 ms");
    assert!(!e.step_ahead(), "done already for this state");
    e.insert_deferred(&imu(10, 2), None, &mut sink);
    assert_eq!((e.stats().stepped_ahead, e.stats().stepped_from_ahead), (1, 1));
    // A fix before the next instant discards it; the one stepped after it is used.
    assert!(e.step_ahead());
    e.insert_deferred(&pos(12, 0, 1.0), None, &mut sink);
    assert!(e.step_ahead(), "from the fix's state to 15 ms");
    e.insert_deferred(&imu(15, 3), None, &mut sink);
    assert_eq!((e.stats().stepped_ahead, e.stats().stepped_from_ahead), (3, 2));
    // An IMU sample off the interval does not use it.
    assert!(e.step_ahead());
    e.insert_deferred(&imu(21, 4), None, &mut sink);
    assert_eq!(e.stats().stepped_from_ahead, 2);
    // A pending rewind: nothing is stepped ahead until it has settled.
    e.insert_deferred(&pos(19, 1, 1.0), None, &mut sink);
    assert!(e.correction().is_some());
    assert!(!e.step_ahead());
    while e.settle_step() {}
    assert!(e.step_ahead(), "to 27 ms");
}
