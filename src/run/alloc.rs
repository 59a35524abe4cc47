//! Process-wide allocator settings for batch runs.

/// Keeps freed memory in the process for the next frame instead of handing it back to the
/// operating system.
///
/// Every frame allocates and frees the same few megabytes (file bytes, decoded image, warped
/// image, encoded PNG). glibc's malloc returns such blocks to the kernel (munmap, or a trim of
/// the thread's heap) on every free, so each frame's buffers come back as fresh pages, each
/// faulted in and zeroed by the kernel: about 530 page faults a KITTI frame, 8 % of the CPU of
/// a conversion (docs/performance.md). With fixed thresholds the blocks stay in malloc's free
/// lists; peak RSS is unchanged, since a frame's working set is what is kept. A no-op outside
/// glibc.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: mallopt only sets malloc parameters; it is called before any other thread
        // exists (at the start of main).
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
            libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
        }
    }
}
