//! Allocator settings for the solver's access pattern.
//!
//! Every Newton iteration and eigenvalue solve allocates and drops dense matrices of 0.1-25 MB
//! (`3N x 3N` at `N = 60..400`, real and complex). glibc serves blocks above its mmap threshold
//! (128 KiB to start) with fresh mappings and trims freed memory at the top of the heap above
//! its trim threshold, so each such matrix is faulted in page by page again: `perf` put 11% of
//! `locate` on the default at `N = 60` in page faults and zeroing; with the thresholds below it
//! runs in 0.245 s against 0.275 s (medians of 6 alternated runs). Raising both keeps the pages
//! in the process; the memory held is at most the peak use.

/// Largest mmap threshold glibc accepts on 64-bit targets (`DEFAULT_MMAP_THRESHOLD_MAX`).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MMAP_THRESHOLD: libc::c_int = 32 << 20;

/// Freed memory at the top of the heap kept before it is returned to the kernel.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const TRIM_THRESHOLD: libc::c_int = 1 << 30;

/// Keeps large blocks in the heap and freed pages in the process (glibc on Linux; elsewhere the
/// system allocator's own policy stays). Call once, at the start of `main`, before threads start.
pub fn keep_freed_pages() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes two tuning parameters of glibc's allocator; it is called
    // before any other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
        libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD);
    }
}
