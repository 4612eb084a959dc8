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
    /// Moves `items` over; their vector is freed once they are copied, so
    /// that a build does not hold both longer than it must. Arrays of at
    /// least 2 MiB are aligned to 2 MiB and advised before their first write.
    pub fn from_vec(items: Vec<T>) -> Self {
        Self::from_slice(&items)
    }

    fn from_slice(items: &[T]) -> Self {
        let size = std::mem::size_of_val(items);
        if size == 0 {
            return Self {
                ptr: NonNull::dangling(),
                len: items.len(),
                layout: Layout::new::<()>(),
            };
        }
        let align = if size >= HUGE_PAGE {
            HUGE_PAGE
        } else {
            std::mem::align_of::<T>()
        };
        let layout = Layout::from_size_align(size, align).expect("a slice's size fits a layout");
        // SAFETY: the layout has a non-zero size.
        let raw = unsafe { alloc::alloc(layout) };
        let Some(ptr) = NonNull::new(raw as *mut T) else {
            alloc::handle_alloc_error(layout)
        };
        if align == HUGE_PAGE {
            advise_huge(raw, size);
        }
        // SAFETY: `ptr` holds `size` bytes, aligned for T, apart from `items`.
        unsafe { std::ptr::copy_nonoverlapping(items.as_ptr(), ptr.as_ptr(), items.len()) };
        Self {
            ptr,
            len: items.len(),
            layout,
        }
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
            // SAFETY: allocated in `from_slice` with this layout.
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
            let array = HugeArray::from_slice(&items);
            assert_eq!(&array[..], &items[..]);
            if n * 8 >= HUGE_PAGE {
                assert_eq!(array.as_ptr() as usize % HUGE_PAGE, 0);
            }
        }
    }
}
