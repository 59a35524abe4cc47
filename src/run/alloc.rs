//! Process-wide allocator settings for batch runs.

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
