//! fmsr-envs' integration tests, one test binary: each module is one former
//! `tests/*.rs` file and opens with what it guards (`docs/design.md`, "Tests and CI's build").
//! Select a module's tests by its path:
//! `cargo test -p fmsr-envs --test envs_integration -- goal_distance::`.
//! `mujoco_parity` is compiled with the feature `mujoco` only.

mod engine;
mod goal_distance;
mod mujoco_parity;
mod render;
mod shadow_hand_model;
mod shadow_hand_partition;
mod shadow_hand_physics;
mod shadow_hand_settings;
