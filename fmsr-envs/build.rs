//! Only with the `mujoco` feature: makes `libmujoco.so.3.17.0` (fetched by
//! `scripts/setup_mujoco.sh` into the directory `MUJOCO_DYNAMIC_LINK_DIR`, which
//! `.cargo/config.toml` sets to `target/mujoco/lib`) loadable at run time without
//! exports:
//!
//! - a link to it in this crate's `OUT_DIR`, announced as a native search path, so
//!   `cargo run`/`cargo test`/`cargo bench` of every package that depends on
//!   fmsr-envs put it on the loader path (Cargo adds the search paths inside its
//!   output directory to `LD_LIBRARY_PATH`);
//! - an rpath to the library's directory in this crate's own tests.
//!
//! A binary started outside Cargo needs `LD_LIBRARY_PATH=<repo>/target/mujoco/lib`.

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
    let Some(lib) = std::fs::read_dir(&dir).ok().and_then(|entries| {
        entries.filter_map(Result::ok).map(|e| e.path()).find(|p| {
            p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("libmujoco.so.") && !p.is_symlink())
        })
    }) else {
        println!("cargo:warning=no libmujoco.so.* in {}; run scripts/setup_mujoco.sh", dir.display());
        return;
    };
    println!("cargo:rerun-if-changed={}", lib.display());
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR")).join("mujoco-lib");
    let _ = std::fs::create_dir_all(&out);
    let link = out.join(lib.file_name().expect("a file name"));
    let _ = std::fs::remove_file(&link);
    #[cfg(unix)]
    let linked = std::os::unix::fs::symlink(&lib, &link);
    #[cfg(not(unix))]
    let linked = std::fs::copy(&lib, &link).map(drop);
    if let Err(e) = linked {
        println!("cargo:warning=cannot link {} into {}: {e}", lib.display(), out.display());
    }
    println!("cargo:rustc-link-search=native={}", out.display());
    println!("cargo:rustc-link-arg-tests=-Wl,-rpath,{}", dir.display());
}
