//! A global allocator that records the largest single allocation, and aborts the process
//! naming the mutant being run when one exceeds [`HARD_LIMIT`]: an allocation sized from an
//! unchecked header would otherwise abort (or swap) without saying which file did it.

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Write;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Largest single allocation the readers may ever make on the test fixtures (1 GiB).
pub const HARD_LIMIT: usize = 1 << 30;

/// The allocator: the system's, with a record of the largest request.
pub struct Guard;

static LARGEST: AtomicUsize = AtomicUsize::new(0);
static LABEL: Mutex<String> = Mutex::new(String::new());

#[global_allocator]
static GUARD: Guard = Guard;

fn note(size: usize) {
    LARGEST.fetch_max(size, Ordering::Relaxed);
    if size > HARD_LIMIT {
        // No allocation from here on: a locked stderr and fixed text.
        let mut e = std::io::stderr().lock();
        let _ = writeln!(
            e,
            "\nallocation of {size} bytes (over {HARD_LIMIT}) while running:"
        );
        if let Ok(l) = LABEL.try_lock() {
            let _ = e.write_all(l.as_bytes());
        }
        let _ = writeln!(e);
        std::process::abort();
    }
}

unsafe impl GlobalAlloc for Guard {
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

/// Name what runs next (printed if it allocates over the limit).
pub fn set_label(label: &str) {
    let s = label.to_string();
    *LABEL.lock().unwrap_or_else(|p| p.into_inner()) = s;
}

/// Forget the largest allocation so far.
pub fn reset_largest() {
    LARGEST.store(0, Ordering::Relaxed);
}

/// The largest single allocation since the last reset (bytes, any thread).
pub fn largest() -> usize {
    LARGEST.load(Ordering::Relaxed)
}
