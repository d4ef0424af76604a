//! Process-wide settings for the solver's access pattern, made once by a front end
//! ([`configure`]): the allocator's thresholds, and faer's default parallelism; and the memory
//! this process may still use ([`available_memory`]).
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

/// The memory this process can still allocate, and what limits it.
#[derive(Clone, Debug, PartialEq)]
pub struct Available {
    pub bytes: u64,
    /// What sets the limit: `cgroup limit`, `address-space limit (ulimit -v)` or `free memory
    /// (MemAvailable)`.
    pub source: &'static str,
}

/// The memory this process can still allocate: the least of what its control group allows
/// beyond its use (a Slurm job's memory limit), what its address-space limit (`ulimit -v`)
/// allows beyond its virtual size, and the memory the system has available. `None` where none
/// of them can be read.
pub fn available_memory() -> Option<Available> {
    use sysinfo::{MemoryRefreshKind, ProcessRefreshKind, ProcessesToUpdate, System};
    let mut system = System::new();
    system.refresh_memory_specifics(MemoryRefreshKind::nothing().with_ram());
    let mut limits = Vec::new();
    if system.available_memory() > 0 {
        limits.push(Available {
            bytes: system.available_memory(),
            source: "free memory (MemAvailable)",
        });
    }
    if let Some(cgroup) = system.cgroup_limits() {
        limits.push(Available {
            bytes: cgroup.free_memory,
            source: "cgroup limit",
        });
    }
    if let Some(limit) = address_space_limit() {
        let pid = sysinfo::get_current_pid().ok();
        if let Some(pid) = pid {
            system.refresh_processes_specifics(
                ProcessesToUpdate::Some(&[pid]),
                false,
                ProcessRefreshKind::nothing().with_memory(),
            );
        }
        let used = pid
            .and_then(|p| system.process(p))
            .map_or(0, |p| p.virtual_memory());
        limits.push(Available {
            bytes: limit.saturating_sub(used),
            source: "address-space limit (ulimit -v)",
        });
    }
    limits.into_iter().min_by_key(|a| a.bytes)
}

/// The soft limit of this process's address space (`RLIMIT_AS`), where one is set.
fn address_space_limit() -> Option<u64> {
    #[cfg(unix)]
    {
        let mut limit = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit writes the limits into the struct it is given.
        let ok = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } == 0;
        (ok && limit.rlim_cur != libc::RLIM_INFINITY).then_some(limit.rlim_cur)
    }
    #[cfg(not(unix))]
    {
        None
    }
}
