//! The engine's history: entries in processing order, each in a fixed slot, so
//! that a late sample inserted before 100 others moves 100 four-byte indices
//! rather than 100 entries of up to 2.4 KB (the INS state), and every slot is
//! allocated and written once, at start.
//!
//! The history also keeps the entry that left it last (the *base*: the state
//! before the oldest entry) in its slot, and steps a new entry in the slot it
//! will occupy ([`History::insert_with`]), so that a state is copied once per
//! processed sample (from the entry before it) and not moved in and out.

use std::collections::VecDeque;
use std::ops::{Index, IndexMut};

/// A bounded sequence of entries with O(1) access by position and cheap
/// insertion anywhere, and each entry's ordering key `K` in an array of its own.
///
/// The keys are searched when a late sample is placed: a binary search over
/// the entries themselves would read one cache line in each of a dozen entries
/// kilobytes apart (cold when a fix comes every 100 ms), over the keys a few
/// lines of one small array.
pub(super) struct History<E, K> {
    /// Every slot, written at construction: the kernel maps pages on first write,
    /// so no page fault is left for the live path. Three more than the capacity:
    /// the base, the slot reserved ahead ([`History::reserve_next`]) and the one
    /// prepared after it ([`History::prepare_after_next`]).
    slots: Vec<E>,
    /// Slot of each entry, in processing order.
    order: VecDeque<u32>,
    /// Key of each entry, in processing order (beside `order`).
    keys: VecDeque<K>,
    /// Free slots; the one freed last is reused first (the most recently touched).
    free: Vec<u32>,
    /// Slot of the entry that left the front last, kept until the next one leaves.
    base: Option<u32>,
    /// The slot the next insert writes, taken out of `free` ahead of it
    /// ([`History::reserve_next`]).
    reserved: Option<u32>,
    /// The slot the insert after the reserved one writes, taken out of `free`
    /// and written ahead of it ([`History::prepare_after_next`]).
    prepared: Option<u32>,
    /// Most entries in `order`.
    capacity: usize,
}

impl<E: Copy, K: Copy> History<E, K> {
    /// Room for `capacity` entries, the base, a reserved and a prepared slot;
    /// every slot starts as `filler`.
    pub fn new(capacity: usize, filler: E) -> Self {
        let capacity = capacity.min(u32::MAX as usize - 3);
        Self {
            slots: vec![filler; capacity + 3],
            order: VecDeque::with_capacity(capacity),
            keys: VecDeque::with_capacity(capacity),
            free: (0..=capacity as u32 + 2).rev().collect(),
            base: None,
            reserved: None,
            prepared: None,
            capacity,
        }
    }

    /// Entries held.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether no entry is held.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The newest entry.
    pub fn back(&self) -> Option<&E> {
        self.order.back().map(|&s| &self.slots[s as usize])
    }

    /// The entry that left the front last, if one has.
    pub fn base(&self) -> Option<&E> {
        self.base.map(|s| &self.slots[s as usize])
    }

    /// Entries in order.
    pub fn iter(&self) -> impl Iterator<Item = &E> {
        self.order.iter().map(|&s| &self.slots[s as usize])
    }

    /// The key of entry `index`.
    pub fn key(&self, index: usize) -> K {
        self.keys[index]
    }

    /// The keys in order.
    pub fn keys(&self) -> impl Iterator<Item = &K> {
        self.keys.iter()
    }

    /// Inserts an entry with `key` at position `index` (`0..=len`), written in
    /// its slot by `write(before, slot)`: `before` is the entry before it (the
    /// base when `index` is 0, if there is one), `slot` holds a stale entry to
    /// overwrite, or what was written in the reserved slot
    /// ([`reserve_next`](Self::reserve_next)); after it, the next insert takes
    /// the prepared one ([`prepare_after_next`](Self::prepare_after_next)).
    /// Returns false, writing nothing, when the history is full.
    pub fn insert_with(&mut self, index: usize, key: K, write: impl FnOnce(Option<&E>, &mut E)) -> bool {
        if self.order.len() >= self.capacity {
            return false;
        }
        let Some(slot) = self.reserved.take().or_else(|| self.prepared.take()).or_else(|| self.free.pop()) else {
            return false;
        };
        let before = if index == 0 { self.base } else { self.order.get(index - 1).copied() };
        // A free slot is never the base nor in `order`, so the two are disjoint.
        match before.and_then(|b| self.slots.get_disjoint_mut([b as usize, slot as usize]).ok()) {
            Some([before, new]) => write(Some(before), new),
            None => write(None, &mut self.slots[slot as usize]),
        }
        if index == self.order.len() {
            // The in-order case: `insert` would take its general path.
            self.order.push_back(slot);
            self.keys.push_back(key);
        } else {
            self.order.insert(index, slot);
            self.keys.insert(index, key);
        }
        true
    }

    /// The slot the next insert writes, reserved for it, and the entry an
    /// append steps from (the newest, else the base): for writing the next
    /// entry ahead of its insert. The next [`insert_with`](Self::insert_with),
    /// wherever it inserts, takes this slot as it is (a prepared slot becomes
    /// the reserved one). A slot is always free for it (beyond the capacity,
    /// the base and the prepared slot).
    pub fn reserve_next(&mut self) -> Option<(Option<&E>, &mut E)> {
        if self.reserved.is_none() {
            self.reserved = self.prepared.take().or_else(|| self.free.pop());
        }
        let slot = self.reserved? as usize;
        match self.order.back().copied().or(self.base) {
            // The reserved slot is neither in `order` nor the base.
            Some(b) => {
                let [before, next] = self.slots.get_disjoint_mut([b as usize, slot]).ok()?;
                Some((Some(before), next))
            }
            None => Some((None, &mut self.slots[slot])),
        }
    }

    /// Prepares the slot the insert after the next one writes: takes it out of
    /// `free` (once) and writes the reserved entry into it, so that its cache
    /// lines are this core's, modified, when that insert copies a state in.
    /// Does nothing before [`reserve_next`](Self::reserve_next).
    ///
    /// A free slot was last written when its entry was stepped, a history ago:
    /// its lines are in a far cache or in memory, and a state of 2.4 KB copied
    /// into it costs its sample one miss per 64 bytes, which stall the stores
    /// behind them. The second IMU sample of an instant (and a fix stamped at
    /// an IMU instant) steps into this slot right after the first, on the path
    /// to the snapshot. What is written here is never read: the insert
    /// overwrites the whole entry.
    pub fn prepare_after_next(&mut self) {
        let Some(reserved) = self.reserved else { return };
        if self.prepared.is_none() {
            self.prepared = self.free.pop();
        }
        // The reserved and the prepared slot are two distinct free slots.
        if let Some(prepared) = self.prepared
            && let Ok([from, to]) = self.slots.get_disjoint_mut([reserved as usize, prepared as usize])
        {
            *to = *from;
        }
    }

    /// Entry `index` (`0..len`), mutable, and the entry before it (the base when
    /// `index` is 0, if there is one): for re-stepping an entry from the one
    /// before it.
    pub fn before_mut(&mut self, index: usize) -> Option<(Option<&E>, &mut E)> {
        let slot = *self.order.get(index)? as usize;
        let before = if index == 0 { self.base } else { self.order.get(index - 1).copied() };
        match before {
            // A base is never in `order`, and `order` holds distinct slots.
            Some(b) => {
                let [before, entry] = self.slots.get_disjoint_mut([b as usize, slot]).ok()?;
                Some((Some(before), entry))
            }
            None => Some((None, &mut self.slots[slot])),
        }
    }

    /// Reads the slots the next in-order inserts touch: the newest entry (copied
    /// from), the oldest and the base (the next eviction), and the next free
    /// (or reserved) slot and the prepared one (written).
    pub fn warm(&self) {
        let next = self.reserved.as_ref().or(self.free.last());
        let slots = [self.order.back(), self.order.front(), self.base.as_ref(), next, self.prepared.as_ref()];
        for slot in slots.into_iter().flatten() {
            // A copy through `black_box` reads every cache line of the entry.
            std::hint::black_box(self.slots[*slot as usize]);
        }
    }

    /// Frees the base (the entry that left the front last): an entry inserted
    /// at the front next steps from the initial state. For an empty history
    /// whose past no longer counts (a new timeline).
    pub fn forget_base(&mut self) {
        if let Some(old) = self.base.take() {
            self.free.push(old);
        }
    }

    /// Removes the oldest entry, which becomes the base, and returns it.
    pub fn pop_front(&mut self) -> Option<&E> {
        let slot = self.order.pop_front()?;
        self.keys.pop_front();
        if let Some(old) = self.base.replace(slot) {
            self.free.push(old);
        }
        Some(&self.slots[slot as usize])
    }
}

impl<E, K> Index<usize> for History<E, K> {
    type Output = E;
    fn index(&self, i: usize) -> &E {
        &self.slots[self.order[i] as usize]
    }
}

impl<E, K> IndexMut<usize> for History<E, K> {
    fn index_mut(&mut self, i: usize) -> &mut E {
        &mut self.slots[self.order[i] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn behaves_like_a_deque_with_insertion() {
        let mut h = History::new(4, 0u64);
        let put = |h: &mut History<u64, u64>, i, v| h.insert_with(i, v, |_, e| *e = v);
        assert!(put(&mut h, 0, 10) && put(&mut h, 1, 30) && put(&mut h, 1, 20));
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [10, 20, 30]);
        assert_eq!(h.keys().copied().collect::<Vec<_>>(), [10, 20, 30], "the keys beside the entries");
        assert!(put(&mut h, 0, 5));
        assert!(!put(&mut h, 4, 40), "full: refused");
        assert_eq!(h.pop_front().copied(), Some(5));
        assert_eq!(h.base().copied(), Some(5), "the entry that left is the base");
        assert_eq!(h.key(0), 10);
        assert!(put(&mut h, 3, 40));
        h[1] += 1;
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [10, 21, 30, 40]);
        assert_eq!((h.iter().next().copied(), h.back().copied(), h.len()), (Some(10), Some(40), 4));
        assert_eq!(h.base().copied(), Some(5), "a full history keeps its base");
        while h.pop_front().is_some() {}
        assert!(h.is_empty());
        assert_eq!(h.base().copied(), Some(40));
    }

    #[test]
    fn a_new_entry_is_written_from_the_one_before_it() {
        let mut h = History::new(3, 0u64);
        // The first entry has nothing before it.
        assert!(h.insert_with(0, (), |before, e| *e = before.map_or(1, |b| b + 1)));
        assert!(h.insert_with(1, (), |before, e| *e = before.map_or(1, |b| b + 1)));
        assert!(h.insert_with(1, (), |before, e| *e = 10 * before.copied().unwrap_or(0)));
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [1, 10, 2]);
        h.pop_front();
        // At the front, the base (the entry that left) is the one before.
        assert!(h.insert_with(0, (), |before, e| *e = 100 + before.copied().unwrap_or(0)));
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [101, 10, 2]);
        let (before, entry) = h.before_mut(2).unwrap();
        *entry += *before.unwrap();
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [101, 10, 12]);
        // At the front, the one before is the base.
        let (before, entry) = h.before_mut(0).unwrap();
        assert_eq!((before.copied(), *entry), (Some(1), 101));
        assert!(h.before_mut(3).is_none());
        let mut fresh = History::new(2, 0u64);
        assert!(fresh.insert_with(0, (), |_, e| *e = 7));
        assert!(matches!(fresh.before_mut(0), Some((None, 7))), "nothing before the first entry of all");
    }

    /// The slot reserved ahead is written from the newest entry (else the
    /// base), and the next insert, wherever it goes, finds it as written: also
    /// in a full history with a base.
    #[test]
    fn the_next_entry_can_be_written_ahead_in_its_slot() {
        let mut h = History::new(2, 0u64);
        let (before, next) = h.reserve_next().unwrap();
        assert_eq!(before, None);
        *next = 1;
        assert!(h.insert_with(0, (), |_, e| assert_eq!(*e, 1, "the slot as written ahead")));
        assert!(h.insert_with(1, (), |_, e| *e = 2));
        h.pop_front();
        // Full (two entries and the base): a slot is still free to reserve.
        assert!(h.insert_with(1, (), |_, e| *e = 3));
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [2, 3]);
        let (before, next) = h.reserve_next().unwrap();
        assert_eq!(before.copied(), Some(3), "written from the newest");
        *next = 4;
        let (_, again) = h.reserve_next().unwrap();
        assert_eq!(*again, 4, "the same slot until an insert takes it");
        assert!(!h.insert_with(2, (), |_, _| unreachable!()), "full: refused, the slot stays reserved");
        h.pop_front();
        // A late insert takes it too.
        assert!(h.insert_with(0, (), |before, e| *e += 10 * before.copied().unwrap()));
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [24, 3]);
        while h.pop_front().is_some() {}
        let (before, _) = h.reserve_next().unwrap();
        assert_eq!(before.copied(), Some(3), "empty: from the base");
    }

    /// The slot prepared after the reserved one holds a copy of it, and the
    /// insert after the next takes it as written; a reserve takes it when no
    /// slot is reserved. Also full: three slots beyond the capacity.
    #[test]
    fn the_slot_after_the_next_is_prepared_with_a_copy() {
        let mut h = History::new(2, 0u64);
        h.prepare_after_next();
        assert!(h.prepared.is_none(), "nothing reserved: nothing to prepare");
        *h.reserve_next().unwrap().1 = 7;
        h.prepare_after_next();
        assert!(h.insert_with(0, (), |_, e| assert_eq!(*e, 7, "the reserved slot")));
        assert!(h.insert_with(1, (), |_, e| assert_eq!(*e, 7, "the prepared slot: a copy")));
        h[1] = 8;
        h.pop_front();
        assert!(h.insert_with(1, (), |_, e| *e = 8));
        // Full, with a base: a reserved and a prepared slot still.
        *h.reserve_next().unwrap().1 = 9;
        h.prepare_after_next();
        let (reserved, prepared) = (h.reserved.unwrap(), h.prepared.unwrap());
        assert!(!h.insert_with(2, (), |_, _| unreachable!()), "full: refused, both slots stay");
        assert_eq!((h.reserved, h.prepared), (Some(reserved), Some(prepared)));
        h.pop_front();
        assert!(h.insert_with(1, (), |_, e| assert_eq!(*e, 9)));
        h.pop_front();
        // Prepared, none reserved: the next reserve takes the prepared slot.
        let (_, next) = h.reserve_next().unwrap();
        assert_eq!(*next, 9, "the prepared slot, reserved");
        assert_eq!((h.reserved, h.prepared), (Some(prepared), None));
        // Every slot is distinct: the entries, the base, the reserved and the prepared.
        h.prepare_after_next();
        let mut used: Vec<u32> = h.order.iter().copied().chain(h.base).chain(h.reserved).chain(h.prepared).collect();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used.len(), h.order.len() + 3);
    }
}
