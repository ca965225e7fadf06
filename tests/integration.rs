//! The root crate's integration tests, one test binary: each module is one
//! former `tests/*.rs` file and opens with what it guards. One binary links
//! burn, rapier and the crate once instead of once per file (`docs/design.md`,
//! "Tests and CI's build"). Select a module's tests by its path:
//! `cargo test --test integration -- cli::`.
//!
//! `tests/mpi.rs` (run under `mpirun`, feature `mpi`) and `tests/gpu.rs`
//! (feature `wgpu`) stay binaries of their own.

mod common;

mod checkpoint;
mod cli;
mod custom_algorithm;
mod custom_task;
mod evaluation;
mod fuzz;
mod golden;
mod learning;
mod rescue;
mod shipped;
mod user_shadow_reward;
