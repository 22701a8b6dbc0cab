//! The engine's history: entries in processing order, each in a fixed slot, so
//! that a late sample inserted before 100 others moves 100 four-byte indices
//! rather than 100 entries of up to 2.4 KB (the INS state), and every slot is
//! allocated and written once, at start.

use std::collections::VecDeque;
use std::ops::{Index, IndexMut};

/// A bounded sequence of entries with O(1) access by position and cheap
/// insertion anywhere.
pub(super) struct History<E> {
    /// Every slot, written at construction: the kernel maps pages on first write,
    /// so no page fault is left for the live path.
    slots: Vec<E>,
    /// Slot of each entry, in processing order.
    order: VecDeque<u32>,
    /// Free slots; the one freed last is reused first (the most recently touched).
    free: Vec<u32>,
}

impl<E: Copy> History<E> {
    /// Room for `capacity` entries; every slot starts as `filler`.
    pub fn new(capacity: usize, filler: E) -> Self {
        let capacity = capacity.min(u32::MAX as usize);
        Self {
            slots: vec![filler; capacity],
            order: VecDeque::with_capacity(capacity),
            free: (0..capacity as u32).rev().collect(),
        }
    }

    pub fn len(&self) -> usize {
        self.order.len()
    }

    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    pub fn front(&self) -> Option<&E> {
        self.order.front().map(|&s| &self.slots[s as usize])
    }

    pub fn back(&self) -> Option<&E> {
        self.order.back().map(|&s| &self.slots[s as usize])
    }

    pub fn iter(&self) -> impl Iterator<Item = &E> {
        self.order.iter().map(|&s| &self.slots[s as usize])
    }

    /// Inserts `entry` at position `index` (`len()` appends). The caller keeps the
    /// length below the capacity (the engine evicts first); a full history drops
    /// nothing and refuses the entry, returning `false`.
    pub fn insert(&mut self, index: usize, entry: E) -> bool {
        let Some(slot) = self.free.pop() else { return false };
        self.slots[slot as usize] = entry;
        self.order.insert(index, slot);
        true
    }

    /// Reads the entries an append touches next: the newest (the state it starts
    /// from), the oldest (evicted when the window moves on) and the slot it will
    /// write, so that they are in the cache when it comes.
    pub fn warm(&self) {
        for slot in [self.order.back(), self.order.front(), self.free.last()].into_iter().flatten() {
            // A copy through `black_box` reads every cache line of the entry.
            std::hint::black_box(self.slots[*slot as usize]);
        }
    }

    /// Removes the oldest entry; it stays readable until the next insert.
    pub fn pop_front(&mut self) -> Option<&E> {
        let slot = self.order.pop_front()?;
        self.free.push(slot);
        Some(&self.slots[slot as usize])
    }
}

impl<E> Index<usize> for History<E> {
    type Output = E;
    fn index(&self, i: usize) -> &E {
        &self.slots[self.order[i] as usize]
    }
}

impl<E> IndexMut<usize> for History<E> {
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
        assert!(h.insert(0, 10) && h.insert(1, 30) && h.insert(1, 20));
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [10, 20, 30]);
        assert!(h.insert(0, 5));
        assert!(!h.insert(4, 40), "full: refused");
        assert_eq!(h.pop_front().copied(), Some(5));
        assert!(h.insert(3, 40));
        h[1] += 1;
        assert_eq!(h.iter().copied().collect::<Vec<_>>(), [10, 21, 30, 40]);
        assert_eq!((h.front().copied(), h.back().copied(), h.len()), (Some(10), Some(40), 4));
        while h.pop_front().is_some() {}
        assert!(h.is_empty());
    }
}
