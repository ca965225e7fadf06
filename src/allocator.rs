//! The C allocator's settings for training, which a binary chooses
//! ([`keep_freed_memory`]); the library itself never changes them.
//!
//! glibc serves an allocation above its mmap threshold (128 KiB at first,
//! raised as memory is freed, at most 32 MiB) with a fresh mapping and
//! unmaps it when it is freed, and gives the top of its heap back to the
//! system beyond a trim threshold. An update at the paper's batch of 1024
//! makes and frees outputs of about 1 MB at every layer of every step; each
//! step then faults in and zeroes every page of them again. On the 2-core
//! Zen 3 VM the page faults took about 16 % of a batch-1024 update on one
//! thread (`perf`), and with the thresholds raised the update took 20-27 %
//! less time on one thread and 9-22 % less on two (three A/B pairs, the
//! long runs paused); at batch 256 no difference was seen.
//! `cargo bench --bench ddpg_update` measures both in one run.

/// Keeps freed memory in the process for the next allocations: glibc's mmap
/// threshold raised to 32 MiB (its largest) and its trim threshold to 1 GiB,
/// so that tensors of up to 32 MiB reuse the heap's pages instead of fresh
/// mappings (a larger allocation, such as the replay buffer, is mapped as
/// before). The process keeps the memory it freed until it ends, as a
/// training process reuses it at the next step. Returns whether the settings
/// were applied: only with glibc (Linux, GNU), `false` elsewhere.
///
/// It changes process-wide state: call it from a binary's `main`, as the
/// `fmsr` binary does.
///
/// ```
/// let applied = fmsr::allocator::keep_freed_memory();
/// assert_eq!(applied, cfg!(all(target_os = "linux", target_env = "gnu")));
/// ```
#[must_use]
pub fn keep_freed_memory() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: `mallopt` only sets glibc's allocator parameters; it takes
        // the allocator's lock and may be called from any thread at any time.
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20) == 1 && libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30) == 1
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        false
    }
}
