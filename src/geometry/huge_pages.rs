//! Memory the kernel may back with 2 MiB pages (Linux, where transparent
//! huge pages are "always" or "madvise"). `HugeArray` holds the BVH's nodes
//! and packets: rays on big meshes visit them all over tens of megabytes,
//! and with 4 KiB pages nearly every visit also misses the TLB (a page walk
//! before the cache miss itself). `advise` serves big buffers not yet
//! touched, such as the film's sums, whose first writes would otherwise
//! fault once every 4 KiB.

use std::alloc::{self, Layout};
use std::ops::Deref;
use std::ptr::NonNull;

/// The huge page size on x86-64 and most AArch64 kernels.
const HUGE_PAGE: usize = 2 << 20;

pub struct HugeArray<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
    layout: Layout,
}

// SAFETY: the array owns its items like a Box<[T]> does.
unsafe impl<T: Copy + Send> Send for HugeArray<T> {}
unsafe impl<T: Copy + Sync> Sync for HugeArray<T> {}

impl<T: Copy> HugeArray<T> {
    /// An empty array with room for exactly `capacity` items (which the
    /// caller writes, then counts in `len`).
    fn with_capacity(capacity: usize) -> Self {
        let size = capacity
            .checked_mul(std::mem::size_of::<T>())
            .expect("an array's size fits in memory");
        if size == 0 {
            return Self {
                ptr: NonNull::dangling(),
                len: 0,
                layout: Layout::new::<()>(),
            };
        }
        let align = if size >= HUGE_PAGE {
            HUGE_PAGE
        } else {
            std::mem::align_of::<T>()
        };
        let layout = Layout::from_size_align(size, align).expect("an array's size fits a layout");
        // SAFETY: the layout has a non-zero size.
        let raw = unsafe { alloc::alloc(layout) };
        let Some(ptr) = NonNull::new(raw as *mut T) else {
            alloc::handle_alloc_error(layout)
        };
        if align == HUGE_PAGE {
            advise_huge(raw, size);
        }
        Self {
            ptr,
            len: 0,
            layout,
        }
    }

    /// The array of `item(0)`, `item(1)` … `item(len − 1)`, made on every
    /// thread: each writes its items to their pages first, so the kernel's
    /// work of providing those pages is shared too.
    pub fn filled_in_parallel(len: usize, item: impl Fn(usize) -> T + Sync) -> Self
    where
        T: Send,
    {
        use rayon::prelude::*;
        struct Slots<T>(*mut T);
        // SAFETY: every index is written by one task only (below).
        unsafe impl<T: Send> Sync for Slots<T> {}
        let mut array = Self::with_capacity(len);
        let slots = Slots(array.ptr.as_ptr());
        let slots = &slots;
        (0..len).into_par_iter().with_min_len(4096).for_each(|i| {
            // SAFETY: `i < len`, the capacity; each i is visited once.
            unsafe { slots.0.add(i).write(item(i)) };
        });
        // Only now are the items counted: had `item` panicked, the array
        // would drop holding none (T is Copy: nothing else to drop).
        array.len = len;
        array
    }
}

/// Advises the whole 2 MiB pages inside `items` as huge pages; only memory
/// not yet touched (such as a zeroed Vec fresh from the allocator) gains.
pub fn advise<T>(items: &mut [T]) {
    let start = items.as_mut_ptr() as usize;
    let end = start + std::mem::size_of_val(items);
    let first = start.next_multiple_of(HUGE_PAGE);
    if end >= first + HUGE_PAGE {
        advise_huge(first as *mut u8, end - first);
    }
}

/// Only a hint: where it is refused the array keeps small pages.
fn advise_huge(start: *mut u8, size: usize) {
    #[cfg(target_os = "linux")]
    // SAFETY: the range lies in one allocation (rounded down to whole huge
    // pages from its 2 MiB-aligned start); madvise only changes how the
    // kernel backs it.
    unsafe {
        libc::madvise(
            start as *mut libc::c_void,
            size / HUGE_PAGE * HUGE_PAGE,
            libc::MADV_HUGEPAGE,
        );
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (start, size);
}

impl<T: Copy> Deref for HugeArray<T> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` holds `len` initialised items (or is dangling for none).
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Drop for HugeArray<T> {
    fn drop(&mut self) {
        if self.layout.size() > 0 {
            // SAFETY: allocated in `with_capacity` with this layout.
            unsafe { alloc::dealloc(self.ptr.as_ptr() as *mut u8, self.layout) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_what_it_was_given() {
        for n in [0usize, 1, 1000, (HUGE_PAGE / 8) + 3] {
            let items: Vec<u64> = (0..n as u64).map(|i| i * 7 + 1).collect();
            let array = HugeArray::filled_in_parallel(n, |i| items[i]);
            assert_eq!(&array[..], &items[..]);
            if n * 8 >= HUGE_PAGE {
                assert_eq!(array.as_ptr() as usize % HUGE_PAGE, 0);
            }
        }
    }
}
