//! fmsr-nn's integration tests, one test binary: each module is one former
//! `tests/*.rs` file and opens with what it guards; burn is linked once, not
//! once per file (`docs/design.md`, "Tests and CI's build"). Select a module's tests by its path:
//! `cargo test -p fmsr-nn --test nn_integration -- sharing::`.

mod common;

mod communicator;
mod critic_learns;
mod critic_view;
mod determinism;
mod per_agent_reference;
mod policy_state;
mod save_state;
mod shapes;
mod shared_critics;
mod sharing;
mod teammates;
mod user_sac;
