//! What the benches that run a whole experiment share.

/// The experiment a bench times: `FMSR_EPOCH_CONFIG`, else the paper's block
/// config (a bench binary carried to another machine has no checkout at the
/// path it was built in, so it names the file there).
pub fn config_path() -> std::path::PathBuf {
    match std::env::var_os("FMSR_EPOCH_CONFIG") {
        Some(path) => std::path::PathBuf::from(path),
        None => std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/block_dense_fmsr_is.toml"),
    }
}
