//! The iceoryx2 service type of fusiond's ports: iceoryx2's `ipc` service with
//! its per-loan reference count kept in recycled storage.
//!
//! iceoryx2 0.10's `ipc::Service` creates an `Rc` for the shared state of every
//! loaned chunk (`Publisher::loan_uninit`, also behind `send_copy`:
//! `port/details/chunk_mut_shared_state.rs`). That is one heap allocation and
//! one free per published sample, on the publisher's hot path. The service type
//! chooses that reference count through its `ArcThreadSafetyPolicy`; [`Ipc`] is
//! `ipc::Service` with [`Pooled`] in that place, which takes its storage from a
//! per-thread free list and gives it back there. After the first few samples a
//! publisher allocates nothing.
//!
//! The domain's node-id counter is kept by [`crate::permissions::OwnerOnly`],
//! `ipc::Service`'s storage without the access for everyone. Every other part
//! of [`Ipc`] (shared memory, connections, events, storage, naming) is
//! `ipc::Service`'s, so the files and the shared-memory layout are the same: a process using plain `iceoryx2::prelude::ipc::Service` talks to
//! fusiond's services unchanged (`daemon/tests/raw_iceoryx2.rs` checks it).

use core::cell::Cell;
use core::fmt;
use core::marker::PhantomData;
use core::ops::Deref;
use core::ptr::NonNull;
use std::alloc::Layout;

use iceoryx2_bb_elementary_traits::testing::abandonable::Abandonable;
use iceoryx2_bb_elementary_traits::zero_copy_send::ZeroCopySend;
use iceoryx2_cal::arc_sync_policy::{ArcSyncPolicy, ArcSyncPolicyCreationError, LockGuard};
use iceoryx2_cal::shm_allocator::bump_allocator::BumpAllocator;
use iceoryx2_cal::shm_allocator::pool_allocator::PoolAllocator;
use iceoryx2_cal::{
    bag, dynamic_storage, event, hash, monitoring, reactor, resizable_shared_memory, serialize, shared_memory,
    static_storage, zero_copy_connection,
};

/// iceoryx2's `ipc` service with pooled reference counts: ports are
/// single-threaded (`!Send`), like `ipc::Service`'s, and loaning a sample
/// allocates nothing once the pool holds a block.
#[derive(Debug, Clone)]
pub struct Ipc {}

impl iceoryx2::service::Service for Ipc {
    type StaticStorage = static_storage::recommended::Ipc;
    type ConfigSerializer = serialize::recommended::Recommended;
    type PersistentDynamicStorage<T: fmt::Debug + Send + Sync + ZeroCopySend + 'static> =
        crate::permissions::OwnerOnly<T>;
    type Bag = bag::recommended::Recommended;
    type DynamicStorage<T: fmt::Debug + Send + Sync + ZeroCopySend + 'static> = dynamic_storage::recommended::Ipc<T>;
    type ServiceNameHasher = hash::recommended::Recommended;
    type SharedMemory = shared_memory::recommended::Ipc<PoolAllocator>;
    type ResizableSharedMemory = resizable_shared_memory::recommended::Ipc<PoolAllocator>;
    type Connection = zero_copy_connection::recommended::Ipc;
    type Event = event::recommended::Ipc;
    type Monitoring = monitoring::recommended::Ipc;
    type Reactor = reactor::recommended::Ipc;
    type ArcThreadSafetyPolicy<T: Send + fmt::Debug + Abandonable> = Pooled<T>;
    type BlackboardMgmt<KeyType: Send + Sync + fmt::Debug + ZeroCopySend + 'static> =
        dynamic_storage::recommended::Ipc<KeyType>;
    type BlackboardPayload = shared_memory::recommended::Ipc<BumpAllocator>;
    type UniqueId = iceoryx2::unique_id_generator::unique_system_id::UniqueSystemId;
}

impl iceoryx2::service::internal::ServiceInternal<Ipc> for Ipc {}

/// Size classes of the free lists: multiples of [`GRANULE`] up to
/// `CLASSES * GRANULE` bytes. Larger or more strictly aligned values are
/// allocated and freed directly (iceoryx2's port states, created once per port).
const CLASSES: usize = 16;
/// Size and alignment granule of the pooled blocks.
const GRANULE: usize = 16;

/// A freed block, linked through its own first bytes.
struct FreeBlock {
    next: *mut FreeBlock,
}

/// This thread's free lists, one per size class. The blocks are freed when the
/// thread ends.
struct FreeLists {
    heads: [Cell<*mut FreeBlock>; CLASSES],
}

impl Drop for FreeLists {
    fn drop(&mut self) {
        for (class, head) in self.heads.iter().enumerate() {
            let mut block = head.replace(core::ptr::null_mut());
            while !block.is_null() {
                // SAFETY: every block on list `class` was allocated with `class_layout(class)`
                // and is owned by the list; its first bytes hold the link.
                let next = unsafe { (*block).next };
                unsafe { std::alloc::dealloc(block.cast(), class_layout(class)) };
                block = next;
            }
        }
    }
}

thread_local! {
    static FREE: FreeLists = const { FreeLists { heads: [const { Cell::new(core::ptr::null_mut()) }; CLASSES] } };
}

/// The layouts of the size classes, `(class + 1) * GRANULE` bytes aligned to
/// `GRANULE`; checked when compiling.
const CLASS_LAYOUTS: [Layout; CLASSES] = {
    let mut layouts = [Layout::new::<FreeBlock>(); CLASSES];
    let mut class = 0;
    while class < CLASSES {
        layouts[class] = match Layout::from_size_align((class + 1) * GRANULE, GRANULE) {
            Ok(layout) => layout,
            Err(_) => panic!("invalid size class layout"),
        };
        class += 1;
    }
    layouts
};

/// The layout of the blocks of size class `class` (`class < CLASSES`).
fn class_layout(class: usize) -> Layout {
    CLASS_LAYOUTS[class]
}

/// The size class of `layout`, if its blocks are pooled.
fn class_of(layout: Layout) -> Option<usize> {
    (layout.align() <= GRANULE && layout.size() <= CLASSES * GRANULE)
        .then(|| layout.size().max(1).div_ceil(GRANULE) - 1)
}

/// A block for `layout`: from this thread's free list if there is one, else
/// from the global allocator. Null when memory is exhausted.
fn take_block(layout: Layout) -> *mut u8 {
    match class_of(layout) {
        Some(class) => {
            let pooled = FREE
                .try_with(|lists| {
                    let head = lists.heads[class].get();
                    if !head.is_null() {
                        // SAFETY: the list owns `head`, a block of this class holding its link.
                        lists.heads[class].set(unsafe { (*head).next });
                    }
                    head
                })
                .unwrap_or(core::ptr::null_mut());
            if pooled.is_null() {
                // SAFETY: the class layout has a non-zero size.
                unsafe { std::alloc::alloc(class_layout(class)) }
            } else {
                pooled.cast()
            }
        }
        // SAFETY: `layout` has a non-zero size (it holds at least the count).
        None => unsafe { std::alloc::alloc(layout) },
    }
}

/// Gives back a block that [`take_block`] returned for `layout`.
///
/// # Safety
/// `block` came from `take_block(layout)` and is no longer used.
unsafe fn give_block(block: *mut u8, layout: Layout) {
    match class_of(layout) {
        Some(class) => {
            let kept = FREE
                .try_with(|lists| {
                    let block = block.cast::<FreeBlock>();
                    // SAFETY: the block is at least GRANULE bytes, aligned to GRANULE, and unused.
                    unsafe { block.write(FreeBlock { next: lists.heads[class].get() }) };
                    lists.heads[class].set(block);
                })
                .is_ok();
            if !kept {
                // The thread is ending: its lists are gone.
                // SAFETY: allocated with this class's layout.
                unsafe { std::alloc::dealloc(block, class_layout(class)) };
            }
        }
        // SAFETY: allocated with `layout` by `take_block`.
        None => unsafe { std::alloc::dealloc(block, layout) },
    }
}

/// A pooled value with its count of handles.
#[repr(C)]
struct Shared<T> {
    handles: Cell<usize>,
    value: T,
}

/// A reference-counted, single-threaded handle like `Rc<T>`, whose storage
/// comes from and goes back to a per-thread free list ([`Ipc`]'s
/// `ArcThreadSafetyPolicy`).
///
/// It is neither `Send` nor `Sync`, so a handle is created, cloned and dropped
/// on one thread, and a block always returns to the list it came from.
pub struct Pooled<T> {
    shared: NonNull<Shared<T>>,
    /// Owns a `Shared<T>`; `!Send`, `!Sync` like `Rc`.
    _owns: PhantomData<(Shared<T>, *const ())>,
}

impl<T> Pooled<T> {
    fn shared(&self) -> &Shared<T> {
        // SAFETY: the block lives while any handle does.
        unsafe { self.shared.as_ref() }
    }
}

impl<T> Clone for Pooled<T> {
    fn clone(&self) -> Self {
        let handles = &self.shared().handles;
        handles.set(handles.get() + 1);
        Self { shared: self.shared, _owns: PhantomData }
    }
}

impl<T> Drop for Pooled<T> {
    fn drop(&mut self) {
        let handles = &self.shared().handles;
        let left = handles.get() - 1;
        handles.set(left);
        if left == 0 {
            let block = self.shared.as_ptr();
            // SAFETY: this was the last handle: drop the value, then give back the block
            // that `new` took for this layout.
            unsafe {
                core::ptr::drop_in_place(&raw mut (*block).value);
                give_block(block.cast(), Layout::new::<Shared<T>>());
            }
        }
    }
}

impl<T: fmt::Debug> fmt::Debug for Pooled<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("Pooled").field(&self.shared().value).finish()
    }
}

impl<T: Abandonable> Abandonable for Pooled<T> {
    unsafe fn abandon_in_place(this: NonNull<Self>) {
        // SAFETY: the caller passes a valid handle that is not used afterwards.
        let this = unsafe { this.as_ref() };
        let handles = &this.shared().handles;
        if handles.get() == 1 {
            // The last handle: abandon the value (its block stays allocated), as
            // iceoryx2's `SingleThreaded` does with its `Rc`.
            // SAFETY: no other handle exists, so nothing else reaches the value.
            unsafe { T::abandon_in_place(NonNull::new_unchecked(&raw mut (*this.shared.as_ptr()).value)) };
        } else {
            handles.set(handles.get() - 1);
        }
    }
}

/// Access to a [`Pooled`] value for as long as the handle is borrowed.
pub struct PooledGuard<'parent, T> {
    value: &'parent T,
}

impl<T> Deref for PooledGuard<'_, T> {
    type Target = T;

    fn deref(&self) -> &T {
        self.value
    }
}

impl<'parent, T: Send + Abandonable> LockGuard<'parent, T> for PooledGuard<'parent, T> {}

impl<T: Send + fmt::Debug + Abandonable> ArcSyncPolicy<T> for Pooled<T> {
    type LockGuard<'parent>
        = PooledGuard<'parent, T>
    where
        Self: 'parent,
        T: 'parent;

    fn new(value: T) -> Result<Self, ArcSyncPolicyCreationError> {
        let block = take_block(Layout::new::<Shared<T>>()).cast::<Shared<T>>();
        let Some(shared) = NonNull::new(block) else {
            return Err(ArcSyncPolicyCreationError::InsufficientResources);
        };
        // SAFETY: the block is unused, large and aligned enough for `Shared<T>`.
        unsafe { shared.write(Shared { handles: Cell::new(1), value }) };
        Ok(Self { shared, _owns: PhantomData })
    }

    fn lock(&self) -> PooledGuard<'_, T> {
        PooledGuard { value: &self.shared().value }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug)]
    struct Probe<'a> {
        drops: &'a Cell<u32>,
        payload: [u64; 3],
    }
    impl Drop for Probe<'_> {
        fn drop(&mut self) {
            self.drops.set(self.drops.get() + 1);
        }
    }
    impl Abandonable for Probe<'_> {
        unsafe fn abandon_in_place(_: NonNull<Self>) {}
    }
    // SAFETY (test only): the probe stays on this thread.
    unsafe impl Send for Probe<'_> {}

    #[test]
    fn drops_once_after_the_last_handle_and_reuses_the_block() {
        let drops = Cell::new(0);
        let first = Pooled::new(Probe { drops: &drops, payload: [1, 2, 3] }).unwrap();
        let address = first.shared.as_ptr() as usize;
        let second = first.clone();
        assert_eq!(second.lock().payload, [1, 2, 3]);
        drop(first);
        assert_eq!(drops.get(), 0, "a handle is still alive");
        drop(second);
        assert_eq!(drops.get(), 1);
        // The next value of the same size takes the freed block.
        let again = Pooled::new(Probe { drops: &drops, payload: [4, 5, 6] }).unwrap();
        assert_eq!(again.shared.as_ptr() as usize, address);
        assert_eq!(again.lock().payload, [4, 5, 6]);
    }

    #[test]
    fn size_classes_cover_small_values_and_leave_large_ones_alone() {
        assert_eq!(class_of(Layout::new::<Shared<u8>>()), Some(0));
        assert_eq!(class_of(Layout::from_size_align(48, 8).unwrap()), Some(2));
        assert_eq!(class_of(Layout::from_size_align(49, 8).unwrap()), Some(3));
        assert_eq!(class_of(Layout::from_size_align(256, 16).unwrap()), Some(15));
        assert_eq!(class_of(Layout::from_size_align(257, 8).unwrap()), None);
        assert_eq!(class_of(Layout::from_size_align(32, 32).unwrap()), None);
        // A large value works too, just without the pool.
        #[derive(Debug)]
        struct Large([u64; 64]);
        impl Abandonable for Large {
            unsafe fn abandon_in_place(_: NonNull<Self>) {}
        }
        let large = Pooled::new(Large([7; 64])).unwrap();
        assert_eq!(large.clone().lock().0[63], 7);
    }
}
