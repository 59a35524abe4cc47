//! Process-wide allocator settings for batch runs, and an allocator for a process whose
//! malloc is not the program's own.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::{Mutex, TryLockError};

/// Keeps freed memory in the process for the next frame instead of handing it back to the
/// operating system.
///
/// Every frame allocates and frees the same buffers (file bytes, decoded images, remap
/// tables, warped images, encoded PNG). glibc's malloc returns such blocks to the kernel on
/// every free (munmap of a block above the mmap threshold, a trim of a heap's top, or the
/// unmapping of a thread's whole heap), so each frame's buffers come back as fresh pages,
/// each faulted in and zeroed by the kernel: about 530 page faults a KITTI frame, 8 % of the
/// CPU of a conversion, and 47 000 a six-camera stitch frame, 0.08 CPU-s of its kernel time
/// (docs/performance.md). Every block is taken from one heap grown by brk (no mmap, one
/// arena: a thread's arena is an mmapped heap of at most 64 MiB, which serves a large block
/// by mmap and unmaps itself once empty) and that heap is never trimmed, so the blocks stay
/// in malloc's free lists. Peak RSS is about unchanged, since a frame's working set is what
/// is kept. A no-op outside glibc.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: mallopt only sets malloc parameters; it is called before any other thread
        // exists (at the start of main).
        unsafe {
            libc::mallopt(libc::M_ARENA_MAX, 1);
            libc::mallopt(libc::M_MMAP_MAX, 0);
            libc::mallopt(libc::M_TRIM_THRESHOLD, libc::c_int::MAX);
        }
    }
}

/// A global allocator that keeps freed large blocks for the next allocation of their size,
/// for a process whose allocator the program does not own (the Python module: Python's
/// process, where [`keep_freed_memory`] would change every library's malloc).
///
/// A training loader allocates and frees the same large buffers every sample (a scan's points,
/// a decoded image, a table, a depth map): glibc serves each from a fresh mapping or a heap top
/// it trimmed, so every page of them is faulted in and zeroed again, a third of a KITTI sample's
/// time in `RandomCameraDataset`. Blocks of [`KeepLarge::MIN`] bytes or more are rounded up to a
/// size class (eighths of a power of two) and, when freed, kept in a few slots (at most
/// [`KeepLarge::KEPT_BYTES`] in all) for the next block of the same class; everything else goes
/// to the system's allocator unchanged.
pub struct KeepLarge {
    kept: Mutex<Kept>,
}

/// The kept blocks: (class, address) in the first `len` slots.
struct Kept {
    blocks: [(usize, usize); KeepLarge::SLOTS],
    len: usize,
    bytes: usize,
}

impl KeepLarge {
    /// The smallest block kept, bytes.
    pub const MIN: usize = 256 * 1024;
    /// The most bytes kept.
    pub const KEPT_BYTES: usize = 128 << 20;
    /// The most blocks kept.
    const SLOTS: usize = 32;
    /// The largest alignment of a kept block (malloc's own).
    const ALIGN: usize = 16;

    /// An allocator keeping nothing yet.
    pub const fn new() -> Self {
        Self {
            kept: Mutex::new(Kept {
                blocks: [(0, 0); Self::SLOTS],
                len: 0,
                bytes: 0,
            }),
        }
    }

    /// The size class of a large block: `size` rounded up to an eighth of its power of two.
    fn class(size: usize) -> usize {
        let step = (size.next_power_of_two() / 8).max(4096);
        size.div_ceil(step) * step
    }

    fn is_large(layout: &Layout) -> bool {
        layout.size() >= Self::MIN && layout.align() <= Self::ALIGN
    }

    /// The slots, unless another thread holds them: then the block is the system's, as if
    /// none were kept. Never waiting keeps a process forked while a thread held the lock (a
    /// loader's workers) from waiting forever: its slots are just not used.
    fn kept(&self) -> Option<std::sync::MutexGuard<'_, Kept>> {
        match self.kept.try_lock() {
            Ok(kept) => Some(kept),
            // (nothing here panics while holding the lock: the slots stay whole)
            Err(TryLockError::Poisoned(e)) => Some(e.into_inner()),
            Err(TryLockError::WouldBlock) => None,
        }
    }

    /// A kept block of `class`, taken out.
    fn take(&self, class: usize) -> Option<*mut u8> {
        let mut kept = self.kept()?;
        let len = kept.len;
        let at = kept.blocks[..len].iter().position(|&(c, _)| c == class)?;
        let (_, address) = kept.blocks[at];
        kept.blocks[at] = kept.blocks[len - 1];
        kept.len -= 1;
        kept.bytes -= class;
        Some(address as *mut u8)
    }

    /// Keeps `ptr` (a block of `class`) if there is room.
    fn keep(&self, class: usize, ptr: *mut u8) -> bool {
        let Some(mut kept) = self.kept() else {
            return false;
        };
        if kept.len == Self::SLOTS || kept.bytes + class > Self::KEPT_BYTES {
            return false;
        }
        let len = kept.len;
        kept.blocks[len] = (class, ptr as usize);
        kept.len += 1;
        kept.bytes += class;
        true
    }

    /// The system's layout of a large block.
    fn class_layout(layout: &Layout) -> Layout {
        // SAFETY: the class is at least the size (so non-zero) and below isize::MAX for any
        // size a Layout allows, rounded to a multiple of 4096; the alignment is the layout's
        unsafe { Layout::from_size_align_unchecked(Self::class(layout.size()), layout.align()) }
    }
}

impl Default for KeepLarge {
    fn default() -> Self {
        Self::new()
    }
}

// SAFETY: every block comes from `System` with its class layout, is handed out to one owner
// at a time (taken out of the slots under the lock), and goes back to `System` with the same
// layout; small and over-aligned blocks are the system's own.
unsafe impl GlobalAlloc for KeepLarge {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !Self::is_large(&layout) {
            return System.alloc(layout);
        }
        let class = Self::class_layout(&layout);
        self.take(class.size())
            .unwrap_or_else(|| System.alloc(class))
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !Self::is_large(&layout) {
            return System.alloc_zeroed(layout);
        }
        let class = Self::class_layout(&layout);
        match self.take(class.size()) {
            Some(ptr) => {
                std::ptr::write_bytes(ptr, 0, layout.size());
                ptr
            }
            None => System.alloc_zeroed(class),
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if !Self::is_large(&layout) {
            return System.dealloc(ptr, layout);
        }
        let class = Self::class_layout(&layout);
        if !self.keep(class.size(), ptr) {
            System.dealloc(ptr, class);
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY (of the new layout): the caller's contract on new_size and the alignment
        let new = Layout::from_size_align_unchecked(new_size, layout.align());
        match (Self::is_large(&layout), Self::is_large(&new)) {
            (false, false) => System.realloc(ptr, layout, new_size),
            (true, true) if Self::class(layout.size()) == Self::class(new_size) => ptr,
            _ => {
                let moved = self.alloc(new);
                if !moved.is_null() {
                    std::ptr::copy_nonoverlapping(ptr, moved, layout.size().min(new_size));
                    self.dealloc(ptr, layout);
                }
                moved
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn large(size: usize) -> Layout {
        Layout::from_size_align(size, 8).unwrap()
    }

    #[test]
    fn a_freed_large_block_serves_the_next_of_its_class_zeroed_when_asked() {
        let keep = KeepLarge::new();
        unsafe {
            let a = keep.alloc(large(3_000_000));
            std::ptr::write_bytes(a, 7, 3_000_000);
            keep.dealloc(a, large(3_000_000));
            // (3 000 000 and 2 900 000 share the class of eighths of 4 MiB)
            let b = keep.alloc_zeroed(large(2_900_000));
            assert_eq!(b, a, "the kept block again");
            let bytes = std::slice::from_raw_parts(b, 2_900_000);
            assert!(bytes.iter().all(|&x| x == 0));
            // another class is not served by it
            keep.dealloc(b, large(2_900_000));
            let c = keep.alloc(large(1_000_000));
            assert_ne!(c, b);
            keep.dealloc(c, large(1_000_000));
        }
        assert_eq!(keep.kept().unwrap().len, 2);
    }

    #[test]
    fn a_held_lock_sends_blocks_to_the_system_without_waiting() {
        let keep = KeepLarge::new();
        let held = keep.kept.lock().unwrap();
        unsafe {
            let a = keep.alloc(large(1_000_000));
            std::ptr::write_bytes(a, 1, 1_000_000);
            keep.dealloc(a, large(1_000_000));
        }
        assert_eq!(held.len, 0, "nothing kept while the lock was held");
    }

    #[test]
    fn blocks_beyond_the_slots_or_bytes_go_back_to_the_system() {
        let keep = KeepLarge::new();
        let size = 40 << 20;
        unsafe {
            let blocks: Vec<*mut u8> = (0..4).map(|_| keep.alloc(large(size))).collect();
            for &b in &blocks {
                keep.dealloc(b, large(size));
            }
        }
        let kept = keep.kept().unwrap();
        assert_eq!(kept.len, 3, "128 MiB hold three 40 MiB blocks");
        assert!(kept.bytes <= KeepLarge::KEPT_BYTES);
    }

    #[test]
    fn realloc_keeps_the_contents_across_classes_and_small_blocks_pass_through() {
        let keep = KeepLarge::new();
        unsafe {
            let small = Layout::from_size_align(1000, 8).unwrap();
            let p = keep.alloc(small);
            std::ptr::write_bytes(p, 3, 1000);
            let q = keep.realloc(p, small, 300_000);
            assert!(std::slice::from_raw_parts(q, 1000).iter().all(|&x| x == 3));
            std::ptr::write_bytes(q.add(1000), 4, 299_000);
            // within its class: the same block
            let r = keep.realloc(q, large(300_000), 310_000);
            assert_eq!(r, q);
            let s = keep.realloc(r, large(310_000), 2_000_000);
            let bytes = std::slice::from_raw_parts(s, 300_000);
            assert!(bytes[..1000].iter().all(|&x| x == 3) && bytes[1000..].iter().all(|&x| x == 4));
            let t = keep.realloc(s, large(2_000_000), 500);
            assert!(std::slice::from_raw_parts(t, 500).iter().all(|&x| x == 3));
            keep.dealloc(t, Layout::from_size_align(500, 8).unwrap());
            // a kept block: the 310 000 one's class went back to the slots
            assert_eq!(keep.kept().unwrap().len, 2);
        }
    }
}
