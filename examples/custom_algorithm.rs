//! A user's algorithm in one file: independent DDPG (IDDPG), which this crate
//! does not ship, as an update rule ([`UpdateRule`]) of fmsr-nn's one
//! off-policy learner, trained by the crate's [`Trainer`] like MADDPG.
//!
//! IDDPG (as BenchMARL ships it) gives every agent a DDPG of its own: agent
//! `i`'s critic sees only what its actor sees, `o_i` (the actor input of the
//! [`ObservationLayout`]: its local observation, the goal, its neighbours'
//! previous actions), and its own action `a_i`, not the global state and
//! joint action of MADDPG's centralised critics:
//!
//! ```text
//! y_i = clip(r_i + gamma * Q'_i(o'_i, mu'_i(o'_i)), lo_i / (1 - gamma), hi_i / (1 - gamma))
//! L_i = mean (Q_i(o_i, a_i) - y_i)^2                  critic
//! J_i = -mean Q_i(o_i, mu_i(o_i)) + l2 * mean mu_i^2  actor
//! ```
//!
//! What makes it IDDPG is one line, `CRITIC_VIEW = CriticView::Own`: the
//! learner builds each critic on `(o_i, a_i)` and its steps feed it that. The
//! rest comes from the crate: HER replay with each agent's reward `r_i`
//! (eq. 7, shadow rewards included), normalisers, information sharing over
//! the graph (eq. 8) and worker averaging inside the steps, polyak targets
//! (eq. 9), saved states with Adam's moments (resume, rescue points) and the
//! policy state (actors and normalisers, as policy files hold them).
//!
//! Its settings are a config section: with [`ConfiguredRule`] and one call,
//! `fmsr::algorithms::register::<IddpgRule>()`, experiment files say
//! `algorithm = "iddpg"` and `[iddpg]`, and fmsr's own command
//! ([`fmsr::cli`]) trains, resumes, exports, evaluates and reports it.
//!
//! `cargo run --release --example custom_algorithm` trains it on TeamReach
//! with information sharing; `cargo run --release --example custom_algorithm
//! -- train --config my_iddpg.toml` is the `fmsr` command with IDDPG
//! registered. `tests/custom_algorithm.rs` checks that it learns TeamReach,
//! and trains, resumes, exports and evaluates a Shadow Hand run by name.

use fmsr::core::policy::PolicyOutput;
use fmsr::experiment::ExperimentConfig;
use fmsr::nn::{
    BatchTensors, ConfiguredRule, CriticView, Learner, NnError, OffPolicy, StepLosses, Teammates, UpdateRule,
};
use fmsr::prelude::*;
use serde::{Deserialize, Serialize};

/// IDDPG's settings (HER baselines' DDPG defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IddpgConfig {
    /// Targets move by `1 - polyak` towards the online networks each cycle.
    pub polyak: f64,
    /// Std of the Gaussian action noise while exploring.
    pub noise_eps: f64,
    /// Probability of a uniformly random action while exploring.
    pub random_eps: f64,
    /// Weight of the actions' L2 penalty in the actor loss.
    pub action_l2: f64,
}

impl Default for IddpgConfig {
    fn default() -> Self {
        Self { polyak: 0.95, noise_eps: 0.2, random_eps: 0.3, action_l2: 1.0 }
    }
}

/// IDDPG's update rule: its settings are all it holds, and they are the
/// `[iddpg]` section of experiment configs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IddpgRule {
    /// The settings.
    pub config: IddpgConfig,
}

/// IDDPG: the crate's learner with this rule.
pub type Iddpg = OffPolicy<IddpgRule>;

impl UpdateRule for IddpgRule {
    const NAME: &'static str = "iddpg";
    const CRITIC_VIEW: CriticView = CriticView::Own;

    fn validate(&self) -> Result<(), NnError> {
        let c = &self.config;
        let bad = |key, reason: &str| Err(NnError::InvalidConfig { key, reason: reason.into() });
        if !(0.0..=1.0).contains(&c.polyak) {
            return bad("iddpg.polyak", "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&c.random_eps) {
            return bad("iddpg.random_eps", "must be in [0, 1]");
        }
        if !(c.noise_eps >= 0.0 && c.action_l2 >= 0.0) {
            return bad("iddpg.noise_eps / iddpg.action_l2", "must be non-negative");
        }
        Ok(())
    }

    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        l.deterministic_act(inputs, n, mode, self.config.noise_eps, self.config.random_eps)
    }

    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        let next = l.target_actions(b)?;
        let critic = l.critic_step(b, next)?;
        let actor = l.deterministic_actor_step(b, self.config.action_l2, Teammates::Replay)?;
        Ok(StepLosses { critic, actor: Some(actor) })
    }

    fn targets(&self) -> (f64, bool) {
        (self.config.polyak, true)
    }
}

impl ConfiguredRule for IddpgRule {
    type Config = IddpgConfig;

    fn default_config() -> IddpgConfig {
        IddpgConfig::default()
    }

    fn from_config(config: IddpgConfig) -> Self {
        Self { config }
    }
}

/// IDDPG's learner parts on TeamReach: a ring graph (each actor observes
/// its two neighbours, and information sharing mixes the actors over it),
/// small networks, HER replay.
///
/// # Errors
/// Errors of the graph or the layout.
pub fn team_reach_parts(env: &TeamReach, seed: u64, gamma: f64) -> anyhow::Result<LearnerParts> {
    let graph = Graph::ring(3);
    let layout = ObservationLayout::from_graph(env.spec().clone(), &graph)?;
    let replay = ReplayConfig { buffer_size: 100_000, batch_size: 128, batches: 20, ..ReplayConfig::default() };
    let networks = NetworkConfig::new().with_hidden(64).with_layers(2).with_seed(seed);
    Ok(LearnerParts::new(layout, networks, replay, gamma).with_sharing(SharingConfig::default().build(&graph)?))
}

/// Trains IDDPG on TeamReach (three agents of 1, 2 and 3 action values, no
/// shadow rewards; [`team_reach_parts`]) for `epochs` epochs of 10 cycles;
/// returns the trainer and the success rate on 100 held-out episodes (goal
/// within 0.1).
///
/// # Errors
/// Errors of the environment, the trainer or IDDPG.
pub fn train_team_reach(seed: u64, epochs: usize) -> anyhow::Result<(Trainer<TeamReach, Iddpg>, f64)> {
    let env = TeamReachConfig::default().init()?;
    let config = TrainerConfig {
        seed,
        epochs,
        cycles: 10,
        episodes_per_cycle: 2,
        eval_episodes: 20,
        shadow: ShadowConfig { enabled: false, ..ShadowConfig::default() },
        ..TrainerConfig::default()
    };
    let parts = team_reach_parts(&env, seed, config.gamma_for(env.spec().episode_len))?;
    let layout = parts.layout.clone();
    let mut trainer = Trainer::new(config, env, Iddpg::with_rule(parts, IddpgRule::default())?, layout)?;
    trainer.train(|_, s| {
        println!("  epoch {}: train success {:.2}, eval success {:.2}", s.epoch, s.train_success_rate, s.success_rate);
        Ok(())
    })?;
    let seeds: Vec<u64> = (0..100).map(|i| 10_000 + i).collect();
    let success = trainer.evaluate(&seeds, Some(0.1))?.success_rate;
    Ok((trainer, success))
}

/// IDDPG on the experiment `config` (a Shadow Hand task, its shadow rewards
/// and information sharing) in place of the algorithm it names: one trainer
/// on `envs`, built by the crate's experiment factory.
///
/// # Errors
/// The factory's errors naming the key that does not fit.
pub fn on_experiment<E: Env + Send>(config: &ExperimentConfig, envs: Vec<E>) -> anyhow::Result<Trainer<E, Iddpg>> {
    Ok(config.build_trainer_with(envs, |parts| Ok(Iddpg::with_rule(parts, IddpgRule::default())?))?)
}

/// With arguments, the `fmsr` command with IDDPG registered; without, IDDPG on TeamReach.
fn main() -> anyhow::Result<std::process::ExitCode> {
    if std::env::args().len() > 1 {
        fmsr::algorithms::register::<IddpgRule>()?;
        return Ok(fmsr::cli::main());
    }
    println!("IDDPG on TeamReach, actors sharing over a ring:");
    let (_, success) = train_team_reach(1, 12)?;
    println!("success on 100 held-out episodes: {success:.2}");
    Ok(std::process::ExitCode::SUCCESS)
}
