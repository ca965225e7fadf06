//! Whose code an experiment follows where the paper is silent: the `stack`
//! key of an experiment file.
//!
//! The paper (section IV) takes its environment from gymnasium-robotics'
//! `manipulate.py` and "most hyperparameters" from OpenAI's HER baselines. Two
//! of their choices change what is learned and fmsr's own defaults differ
//! from them (`docs/design.md`, "The paper's stack"):
//!
//! | setting | `stack = "fmsr"` (default) | `stack = "paper"` |
//! |---|---|---|
//! | `env.goal_distance` | `"full"`: the angle between orientations, `[0, pi]`, `w >= 0` observed | `"gym"`: `2 arccos(w)` over `[0, 2 pi]`, the engine's sign observed |
//! | `networks.target_clip` | `"reward_bounds"`: each agent's reward bounds over `1 - gamma` | `"her_baselines"`: `[-1 / (1 - gamma), 0]` for every agent |
//! | `networks.normalizer_stats` | `"sampled_batches"`: every training batch | `"stored_episodes"`: `T` relabelled rows of each stored episode |
//!
//! `stack = "paper"` owns these keys: a value that contradicts it is an error
//! naming both, as for [`method`](fmsr_core::method::Method). Under
//! `stack = "fmsr"` each is free (the attribution runs set one alone).
//! Everything else the paper's stack did that fmsr knows of is already the
//! default of both (the table of `docs/design.md`).

use serde::{Deserialize, Serialize};

use fmsr_envs::shadow_hand::GoalDistance;
use fmsr_nn::{NormalizerStats, TargetClip};

/// Whose code the settings the paper leaves open follow; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Stack {
    /// fmsr's own defaults, each setting free (every run on record before
    /// the preset existed).
    #[default]
    Fmsr,
    /// gymnasium-robotics' distance, HER baselines' target clip and
    /// normaliser statistics, as the paper's code had them.
    Paper,
}

/// A setting that a [`Stack`] decides: its key and the value each stack gives it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Owned {
    /// The dotted key in an experiment file.
    pub key: &'static str,
    /// The value under `stack = "paper"`, as TOML writes it.
    pub paper: &'static str,
}

impl Stack {
    /// The settings `stack = "paper"` decides.
    pub const OWNED: [Owned; 3] = [
        Owned { key: "env.goal_distance", paper: "gym" },
        Owned { key: "networks.target_clip", paper: "her_baselines" },
        Owned { key: "networks.normalizer_stats", paper: "stored_episodes" },
    ];

    /// The name in files: `"fmsr"` or `"paper"`.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Self::Fmsr => "fmsr",
            Self::Paper => "paper",
        }
    }

    /// The goal distance this stack sets (`None`: the file's own, or its default).
    #[must_use]
    pub fn goal_distance(self) -> Option<GoalDistance> {
        (self == Self::Paper).then_some(GoalDistance::Gym)
    }

    /// The critics' target clip this stack sets (`None`: the file's own, or its default).
    #[must_use]
    pub fn target_clip(self) -> Option<TargetClip> {
        (self == Self::Paper).then_some(TargetClip::HerBaselines)
    }

    /// The normalisers' statistics this stack sets (`None`: the file's own, or its default).
    #[must_use]
    pub fn normalizer_stats(self) -> Option<NormalizerStats> {
        (self == Self::Paper).then_some(NormalizerStats::StoredEpisodes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Guards that the table of owned keys says what the preset sets: a key
    // added to one and not the other would let a file contradict the preset
    // silently.
    #[test]
    fn the_owned_keys_are_what_the_paper_stack_sets() {
        let distance = toml::Value::try_from(Stack::Paper.goal_distance().unwrap()).unwrap();
        let clip = toml::Value::try_from(Stack::Paper.target_clip().unwrap()).unwrap();
        let stats = toml::Value::try_from(Stack::Paper.normalizer_stats().unwrap()).unwrap();
        assert_eq!(distance.as_str(), Some(Stack::OWNED[0].paper));
        assert_eq!(clip.as_str(), Some(Stack::OWNED[1].paper));
        assert_eq!(stats.as_str(), Some(Stack::OWNED[2].paper));
        assert_eq!(Stack::Fmsr.goal_distance(), None);
        assert_eq!(Stack::Fmsr.target_clip(), None);
        assert_eq!(Stack::Fmsr.normalizer_stats(), None);
        assert_eq!(Stack::default(), Stack::Fmsr);
    }
}
