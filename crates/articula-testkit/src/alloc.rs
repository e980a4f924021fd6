//! A counting global allocator for the "a step allocates nothing" tests.
//!
//! A test binary installs it as its global allocator and measures a closure with
//! [`count_allocations`]:
//!
//! ```
//! #[global_allocator]
//! static ALLOCATOR: articula_testkit::CountingAllocator = articula_testkit::CountingAllocator;
//!
//! fn main() {
//!     let n = articula_testkit::count_allocations(|| {
//!         std::hint::black_box(vec![1u8; 8]);
//!     });
//!     assert_eq!(n, 1);
//! }
//! ```
//! Only the calling thread counts, while it
//! runs the closure, so the test harness's other threads (and other tests of the binary running
//! in parallel) cannot add to a count.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, counting `alloc`, `alloc_zeroed` and `realloc` calls on threads inside
/// [`count_allocations`].
pub struct CountingAllocator;

thread_local! {
    static ENABLED: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<usize> = const { Cell::new(0) };
    static BYTES: Cell<usize> = const { Cell::new(0) };
}

fn note(bytes: usize) {
    // `try_with`: the allocator may run while a thread's locals are being torn down.
    if ENABLED.try_with(Cell::get).unwrap_or(false) {
        let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        let _ = BYTES.try_with(|c| c.set(c.get() + bytes));
    }
}

// SAFETY: every call forwards to `System` with the caller's arguments; counting touches only
// thread-local cells, which allocate nothing.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Runs `f` with counting on (this thread only) and returns the number of allocations
/// (`alloc`, `alloc_zeroed` and `realloc` calls) it made. Counts only in a binary whose global
/// allocator is [`CountingAllocator`]; calls nest (the inner count is included in the outer).
pub fn count_allocations(f: impl FnOnce()) -> usize {
    let (was_on, outer) = (ENABLED.with(Cell::get), COUNT.with(Cell::get));
    COUNT.with(|c| c.set(0));
    ENABLED.with(|e| e.set(true));
    f();
    ENABLED.with(|e| e.set(was_on));
    let n = COUNT.with(Cell::get);
    COUNT.with(|c| c.set(outer + if was_on { n } else { 0 }));
    n
}

/// Runs `f` with counting on (this thread only) and returns the bytes it asked for: the sum of
/// the sizes of its `alloc`, `alloc_zeroed` and `realloc` calls (frees not subtracted), for
/// tests of how a workspace grows with the model. Counts only in a binary whose global
/// allocator is [`CountingAllocator`]; do not nest it in [`count_allocations`].
pub fn count_allocated_bytes(f: impl FnOnce()) -> usize {
    BYTES.with(|c| c.set(0));
    count_allocations(f);
    BYTES.with(Cell::get)
}
