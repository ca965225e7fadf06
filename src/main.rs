//! The `fmsr` command ([`fmsr::cli`]): train, evaluate and report the paper's experiments.

fn main() -> std::process::ExitCode {
    fmsr::cli::main()
}
