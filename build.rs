//! Only with the `mujoco` feature: an rpath to MuJoCo's library directory
//! (`MUJOCO_DYNAMIC_LINK_DIR`, which `.cargo/config.toml` sets to
//! `target/mujoco/lib` and `scripts/setup_mujoco.sh` fills) in the `fmsr`
//! binary, its examples and benches, so `target/release/fmsr` built with
//! `--features mujoco` starts without `LD_LIBRARY_PATH`.

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    if std::env::var_os("CARGO_FEATURE_MUJOCO").is_none() {
        return;
    }
    let Some(dir) = std::env::var_os("MUJOCO_DYNAMIC_LINK_DIR").map(PathBuf::from) else {
        // mujoco-rs' own build script explains what is missing.
        return;
    };
    let dir = dir.canonicalize().unwrap_or(dir);
    for kind in ["bins", "examples", "benches", "tests"] {
        println!("cargo:rustc-link-arg-{kind}=-Wl,-rpath,{}", dir.display());
    }
}
