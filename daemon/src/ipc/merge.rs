//! The merge of `fusiond run`'s sample subscribers: which port's sample goes
//! next. Pure: it sees each port's [`Heads`] and the newest key processed.
//!
//! - The oldest in-order sample (at or after the newest processed; at equal
//!   time the lower rank) goes first: under a backlog the kinds are fused in
//!   time order, not one kind's batch ahead of another's.
//! - A late sample (older than the newest processed: its snapshot is
//!   provisional anyway) waits while in-order samples go, at most
//!   [`MAX_PASSED_OVER`] in a row, so that the in-order sample's snapshot does
//!   not wait for its rewind, and the late one is not made too late.
//! - A port keeps a late head in a slot of its own ([`Heads::late`]) and shows
//!   the sample behind it: a late or retransmitted head does not hold back the
//!   in-order samples queued behind it.
//! - A blocked port (its publishers gave their share of the turn and have more)
//!   bounds every other: no sample at or after the oldest it gave this turn goes
//!   before its unseen ones; with none left below the bound, the turn ends.
//! - The next sample of an instant goes alone ([`goes_alone`]): a port whose
//!   head has the very key of the newest sample processed (the second IMU
//!   sample of an instant) is the oldest in-order sample there can be, and
//!   the other ports need not be polled for it.

/// A sample's place in the merge: `(t_ns, rank of its kind)`.
pub type Key = (u64, u8);

/// In-order samples handed out at most before a late one that waits: under a
/// backlog, a late sample must not wait until it is too late.
pub const MAX_PASSED_OVER: u32 = 64;

/// What a port holds for the merge: the keys of its pending (next in its
/// queue) and late samples, and while it is blocked (its publishers have given
/// their share of the turn and have more) the oldest key its next samples can
/// have: no sample at or after it may go before them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Heads {
    /// The key of the port's next sample.
    pub pending: Option<Key>,
    /// The key of the late sample the port holds aside.
    pub late: Option<Key>,
    /// While blocked: the bound on every other port's samples.
    pub bound: Option<Key>,
}

impl Heads {
    /// A port with nothing.
    pub const EMPTY: Heads = Heads { pending: None, late: None, bound: None };

    /// Whether the port holds a sample (pending or late).
    pub fn holds(&self) -> bool {
        self.pending.is_some() || self.late.is_some()
    }
}

/// The port whose sample goes next and whether it is its late slot's, given
/// the ports' `heads` and the `newest` key processed; `passed_over` counts the
/// in-order samples handed out while a late one waited. `None`: nothing may go
/// (the turn ends).
pub fn pick(heads: &[Heads], newest: Option<Key>, passed_over: &mut u32) -> Option<(usize, bool)> {
    let bound = heads.iter().filter_map(|h| h.bound).min();
    let mergeable = |key: Key| bound.is_none_or(|b| key < b);
    // The oldest in-order sample, and the oldest late one (a late slot's, or a
    // head that is late behind a full late slot).
    let mut in_order: Option<(Key, usize)> = None;
    let mut late: Option<(Key, usize, bool)> = None;
    for (i, head) in heads.iter().enumerate() {
        if let Some(key) = head.late.filter(|&k| mergeable(k))
            && late.is_none_or(|(k, ..)| key < k)
        {
            late = Some((key, i, true));
        }
        let Some(key) = head.pending.filter(|&k| mergeable(k)) else { continue };
        if newest.is_none_or(|n| key >= n) {
            if in_order.is_none_or(|(k, _)| key < k) {
                in_order = Some((key, i));
            }
        } else if late.is_none_or(|(k, ..)| key < k) {
            late = Some((key, i, false));
        }
    }
    match (in_order, late) {
        (Some((_, i)), None) => {
            *passed_over = 0;
            Some((i, false))
        }
        (Some((_, i)), Some(_)) if *passed_over < MAX_PASSED_OVER => {
            *passed_over += 1;
            Some((i, false))
        }
        (_, Some((_, i, slot))) => {
            *passed_over = 0;
            Some((i, slot))
        }
        (None, None) => None,
    }
}

/// Whether a port's head goes next without a look at the other ports: its
/// pending sample has the key of the `newest` processed (another sample of
/// the same kind at the same time: the next IMU sample of an instant), and
/// the port holds no late sample and bounds nothing.
///
/// Every in-order sample's key is at or after `newest`, and only the port of
/// one kind has keys of its rank, so no port can hold an in-order sample that
/// goes first: [`pick`] would pick this one, if the last [`pick`] saw no late
/// sample waiting and no port blocked (the caller's condition, kept from the
/// last full look, since a late sample or a bound only appears where a port
/// is polled). A late sample that arrived meanwhile waits at most for the
/// instant's other samples, one per IMU.
pub fn goes_alone(head: &Heads, newest: Option<Key>) -> bool {
    head.pending.is_some() && head.pending == newest && head.late.is_none() && head.bound.is_none()
}

/// The port an idle scan polls besides the IMU's: of the `others` ports
/// before it, the next active one after `last`, in turn (`None`: none is
/// active). Successive scans poll each active port once in as many scans as
/// there are active ones.
pub fn scanned_next(others: usize, last: usize, active: impl Fn(usize) -> bool) -> Option<usize> {
    (1..=others).map(|step| (last + step) % others).find(|&i| active(i))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every active port is scanned once in as many scans as there are active
    /// ones, an inactive one never; with none active, none.
    #[test]
    fn a_scan_reaches_every_active_port_in_turn() {
        let others = 9;
        for mask in [0u32, 0b1, 0b100_000_000, 0b101_010_011, 0b111_111_111] {
            let active = |i: usize| mask & (1 << i) != 0;
            let count = mask.count_ones() as usize;
            let mut last = 0;
            for _ in 0..3 {
                let mut seen = 0u32;
                for _ in 0..count {
                    let i = scanned_next(others, last, active).expect("an active port");
                    assert!(active(i));
                    seen |= 1 << i;
                    last = i;
                }
                assert_eq!(seen, mask, "one round of scans covers every active port");
            }
            if count == 0 {
                assert_eq!(scanned_next(others, last, active), None);
            }
        }
    }

    /// Wherever [`goes_alone`] says a port's head goes alone, [`pick`] over
    /// every port (none with a late sample or a bound, as after a clean pick)
    /// picks it.
    #[test]
    fn a_head_that_goes_alone_is_what_the_merge_picks() {
        let newest = Some((100, 0));
        let keys = [None, Some((100, 0)), Some((100, 1)), Some((100, 5)), Some((101, 0)), Some((250, 2))];
        let mut checked = 0;
        for a in keys {
            for b in keys {
                for c in keys {
                    let heads = [a, b, c].map(|pending| Heads { pending, late: None, bound: None });
                    // One port per kind: a rank appears in one port only.
                    let ranks: Vec<u8> = heads.iter().filter_map(|h| h.pending.map(|k| k.1)).collect();
                    if (1..ranks.len()).any(|i| ranks[..i].contains(&ranks[i])) {
                        continue;
                    }
                    for (i, head) in heads.iter().enumerate() {
                        if goes_alone(head, newest) {
                            assert_eq!(pick(&heads, newest, &mut 0), Some((i, false)), "{heads:?}");
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 10);
        let at = |pending, late, bound| Heads { pending, late, bound };
        assert!(!goes_alone(&at(Some((100, 0)), Some((90, 0)), None), newest), "a late sample waits");
        assert!(!goes_alone(&at(Some((100, 0)), None, Some((100, 0))), newest), "blocked");
        assert!(!goes_alone(&at(Some((101, 0)), None, None), newest), "a later sample");
        assert!(!goes_alone(&at(None, None, None), None));
    }

    fn head(pending: Option<u64>, late: Option<u64>, bound: Option<u64>) -> Heads {
        let key = |t: Option<u64>| t.map(|t| (t, 1));
        Heads { pending: key(pending), late: key(late), bound: key(bound) }
    }

    #[test]
    fn the_oldest_in_order_sample_goes_first() {
        let mut passed = 0;
        let heads = [head(Some(30), None, None), head(Some(20), None, None), head(None, None, None)];
        assert_eq!(pick(&heads, Some((10, 1)), &mut passed), Some((1, false)));
        assert_eq!(pick(&[Heads::EMPTY; 3], Some((10, 1)), &mut passed), None);
        // At equal time the lower rank.
        let heads =
            [Heads { pending: Some((20, 3)), ..Heads::EMPTY }, Heads { pending: Some((20, 0)), ..Heads::EMPTY }];
        assert_eq!(pick(&heads, None, &mut passed), Some((1, false)));
    }

    /// A late sample waits while in-order ones go, at most MAX_PASSED_OVER in a
    /// row; its slot's sample is the one handed out then.
    #[test]
    fn a_late_sample_waits_for_in_order_ones_but_not_for_ever() {
        let mut passed = 0;
        let heads = [head(Some(50), Some(5), None), head(Some(60), None, None)];
        for _ in 0..MAX_PASSED_OVER {
            assert_eq!(pick(&heads, Some((40, 1)), &mut passed), Some((0, false)));
        }
        assert_eq!(pick(&heads, Some((40, 1)), &mut passed), Some((0, true)), "the late slot's turn");
        assert_eq!(passed, 0);
        // A late head behind a full slot waits too, and the older late one goes first.
        let heads = [head(Some(7), Some(5), None), head(Some(6), None, None)];
        assert_eq!(pick(&heads, Some((40, 1)), &mut passed), Some((0, true)));
    }

    /// A blocked port's bound holds back every sample at or after it; with none
    /// below it, the turn ends.
    #[test]
    fn a_blocked_port_bounds_the_others() {
        let mut passed = 0;
        let heads = [head(Some(30), None, Some(25)), head(Some(20), None, None)];
        assert_eq!(pick(&heads, None, &mut passed), Some((1, false)));
        let heads = [head(Some(30), None, Some(25)), head(Some(26), None, None)];
        assert_eq!(pick(&heads, None, &mut passed), None);
    }
}
