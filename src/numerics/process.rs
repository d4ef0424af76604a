//! Process-wide settings for the solver's access pattern, made once by a front end
//! ([`configure`]): the allocator's thresholds, and faer's default parallelism.
//!
//! **Parallelism.** faer's operations that take no explicit parallelism (products written
//! with `*`, its decompositions called as methods) use a process-wide default. The dense
//! matrices here have a few hundred to a few thousand rows: threading inside one small
//! product costs more than it gains, so the default is sequential, and the places that pay
//! for two threads ask for them explicitly ([`crate::numerics::lu`],
//! [`crate::numerics::parallel`]); sweeps run in parallel over their points instead.
//!
//! **Allocator.**
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

/// The settings of this module: sequential faer by default, large blocks kept in the heap and
/// freed pages in the process. A front end (the command line, the Python module, a benchmark)
/// calls it at its start; calling it again changes nothing.
pub fn configure() {
    faer::set_global_parallelism(faer::Par::Seq);
    keep_freed_pages();
}

/// Keeps large blocks in the heap and freed pages in the process (glibc on Linux; elsewhere the
/// system allocator's own policy stays).
fn keep_freed_pages() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes two tuning parameters of glibc's allocator, under the
    // allocator's own lock.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
        libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD);
    }
}
