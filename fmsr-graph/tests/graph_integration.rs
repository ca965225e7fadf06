//! fmsr-graph's integration tests, one test binary (`docs/design.md`,
//! "Tests and CI's build"): hand-computed values and property tests, a module each.

mod known_values;
mod properties;
