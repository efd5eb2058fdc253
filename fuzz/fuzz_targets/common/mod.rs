//! What every target shares: an allocator that records the largest single
//! allocation, so that an input making the reader allocate more than 16
//! times its own size is a crash (the rule), however small the input.
//! libFuzzer's `-malloc_limit_mb` only sees allocations above a fixed size.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

pub struct Counting;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Buffers of a fixed size (the WAV reader's 64 KiB read buffer, a parser's
/// first table) are not driven by the input: below this, any size is fine.
const FIXED: usize = 1 << 20;

/// Runs `read` on an input of `len` bytes and panics if it allocated a single
/// block larger than `16 * len` (and than [`FIXED`]).
pub fn bounded(len: usize, read: impl FnOnce()) {
    LARGEST.store(0, Ordering::Relaxed);
    read();
    let largest = LARGEST.load(Ordering::Relaxed);
    let limit = (16 * len).max(FIXED);
    assert!(
        largest <= limit,
        "allocated {largest} bytes at once for a {len}-byte input (limit {limit})"
    );
}
