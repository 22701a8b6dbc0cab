//! Samples stamped with no time among a stream's.

use super::*;

/// Samples whose timestamps are no time (0, `u64::MAX`) or far from the others
/// (an hour back or ahead), in place of four of the stream's IMU samples and
/// with their sequence numbers, live (a clock) and in replay (none): each is
/// refused or dropped and counted as such, the estimate is the stream's
/// without them, and no sample is counted lost: each one's number is no gap.
#[test]
fn samples_stamped_with_no_time_leave_the_sequence_accounting_as_it_was() {
    // The stream 100 s from the clock's start, so that 0 is no time near it.
    let offset = 100_000_000_000;
    for now in [Some(offset + 2_000_000_000), None] {
        let mut clean = stream();
        clean.iter_mut().for_each(|s| s.header_mut().t_ns += offset);
        let mut hostile = clean.clone();
        let imu_at: Vec<usize> =
            (0..hostile.len()).filter(|&i| hostile[i].kind() == fusion_shared::SampleKind::Imu).collect();
        let hour = 3_600_000_000_000u64;
        for (&i, t) in imu_at[100..].iter().step_by(50).zip([0, u64::MAX, 1, hour]) {
            let t = if t == 1 { hostile[i].t_ns().saturating_sub(hour) } else { t };
            let t = if t == hour { hostile[i].t_ns() + hour } else { t };
            hostile[i].header_mut().t_ns = t;
        }
        let (mut a, mut b) = (engine(None), engine(None));
        for (x, y) in clean.iter().zip(&hostile) {
            if x == y {
                a.insert(x, now, &mut |_| {});
            }
            b.insert(y, now, &mut |_| {});
        }
        let imu = b.sensors()[0].stats;
        assert_eq!(latest(&a), latest(&b), "{now:?}: {imu:?} {:?}", b.stats());
        assert_eq!(imu.processed + imu.invalid + imu.too_late, 400, "{now:?}: {imu:?}");
        assert_eq!((imu.lost, imu.restarts, imu.duplicate), (0, 0, 0), "{now:?}: {imu:?}");
        assert_accounted(&b);
    }
}
