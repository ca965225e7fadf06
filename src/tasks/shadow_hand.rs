//! The Shadow Hand as a registered task.

use fmsr_envs::EnvError;
use fmsr_envs::shadow_hand::{Engine, EnginePhysics, ShadowHand, ShadowHandConfig};
use serde::{Deserialize, Serialize};

use super::{SHADOW_HAND, Task};

/// The paper's task as a registered [`Task`]: the Shadow Hand turning a
/// block or an egg, on rapier or MuJoCo.
///
/// It is in the registry from the start, under [`SHADOW_HAND`], and its
/// environments are built through the same entry as a task of your own
/// crate ([`crate::tasks::TaskSettings::envs`]), so training runs it as it
/// runs any task. Its settings keep their place in an experiment's file: the
/// top-level `engine` and the `[env]` section, with the method's task
/// reward and the stack's goal distance applied
/// ([`crate::experiment::ExperimentConfig::task_settings`]). What it has
/// beyond other tasks is the paper's: its evaluation (contacts, grasp
/// measures, failure types: [`crate::evaluate`]), its renderings and the
/// report's tables.
pub struct ShadowHandTask;

/// The Shadow Hand's settings: its engine and its environment.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShadowHandSettings {
    /// The physics engine.
    #[serde(default)]
    pub engine: Engine,
    /// The object, thresholds, reward, goal distance and features.
    #[serde(default)]
    pub env: ShadowHandConfig,
}

impl Task for ShadowHandTask {
    const NAME: &'static str = SHADOW_HAND;
    type Config = ShadowHandSettings;
    type Env = ShadowHand<EnginePhysics>;

    fn env(config: &ShadowHandSettings) -> Result<Self::Env, EnvError> {
        config.env.clone().init_engine(config.engine)
    }
}
