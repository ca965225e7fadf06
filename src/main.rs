//! The `fmsr` command ([`fmsr::cli`]): train, evaluate and report the paper's experiments.

fn main() -> std::process::ExitCode {
    if std::env::var_os("BURN_DEVICE").is_none() {
        // burn creates a loaded optimiser state on its default device (a GPU
        // backend's default adapter in a GPU build) before moving it to the
        // networks' device; on the CPU that always exists (fmsr_nn::device).
        // SAFETY: the first thing the process does, before any thread exists.
        unsafe { std::env::set_var("BURN_DEVICE", "flex") };
    }
    // Freed tensors' memory reused at the next step instead of faulted in
    // again (fmsr::allocator); `false` off glibc, where nothing changes.
    let _ = fmsr::allocator::keep_freed_memory();
    // The library's warnings, on stderr.
    log::set_logger(&STDERR).map(|()| log::set_max_level(log::LevelFilter::Warn)).ok();
    fmsr::cli::main()
}

/// Prints warnings and errors of the library as `warning: ...` / `error: ...`.
struct Stderr;

static STDERR: Stderr = Stderr;

impl log::Log for Stderr {
    fn enabled(&self, metadata: &log::Metadata<'_>) -> bool {
        metadata.level() <= log::Level::Warn
    }

    fn log(&self, record: &log::Record<'_>) {
        if self.enabled(record.metadata()) {
            eprintln!("{}: {}", record.level().as_str().to_lowercase(), record.args());
        }
    }

    fn flush(&self) {}
}
