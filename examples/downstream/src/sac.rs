//! A user's algorithm registered by name: SAC with a fixed entropy
//! temperature (no temperature tuning, unlike fmsr's MASAC) and a Huber
//! critic loss of its own threshold, written on fmsr-nn's public learner view
//! in this crate, then trained, resumed, exported and evaluated by fmsr's own
//! command from a config that says `algorithm = "fixed_sac"`.

use std::path::Path;

use anyhow::{Result, bail};
use fmsr_core::policy::{ActMode, PolicyOutput};
use fmsr_nn::burn::tensor::Tensor;
use fmsr_nn::{BatchTensors, ConfiguredRule, Learner, NnError, SquashedGaussian, StepLosses, Teammates, UpdateRule};
use serde::{Deserialize, Serialize};

/// The `[fixed_sac]` section of an experiment config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FixedSacConfig {
    /// The entropy temperature `alpha` of every agent.
    pub temperature: f64,
    /// Targets move by `1 - polyak` towards the online critics each cycle.
    pub polyak: f64,
    /// Probability of a uniformly random action while exploring.
    pub random_eps: f64,
    /// The critics' Huber threshold: squared TD errors below it, linear beyond.
    pub huber_delta: f64,
}

impl Default for FixedSacConfig {
    fn default() -> Self {
        Self { temperature: 0.05, polyak: 0.95, random_eps: 0.3, huber_delta: 2.0 }
    }
}

/// The Huber loss of threshold `delta` on the TD errors `d`, written with
/// burn's tensor operations: `d^2 / 2` where `|d| <= delta`, `delta (|d| - delta / 2)` beyond.
fn huber(d: Tensor<3>, delta: f32) -> Tensor<3> {
    let abs = d.clone().abs();
    let linear = abs.clone().sub_scalar(delta / 2.0).mul_scalar(delta);
    linear.mask_where(abs.lower_equal_elem(delta), d.square().mul_scalar(0.5))
}

/// The rule: its settings are all it holds.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FixedSac {
    config: FixedSacConfig,
}

/// MASAC's clamp of the log standard deviations.
const DIST: SquashedGaussian = SquashedGaussian { log_std_min: -5.0, log_std_max: 2.0 };

impl UpdateRule for FixedSac {
    const NAME: &'static str = "fixed_sac";
    const CRITICS: usize = 2;
    const HEADS: usize = 2;

    fn validate(&self) -> Result<(), NnError> {
        let c = &self.config;
        if !(c.temperature >= 0.0
            && (0.0..=1.0).contains(&c.polyak)
            && (0.0..=1.0).contains(&c.random_eps)
            && c.huber_delta > 0.0)
        {
            return Err(NnError::InvalidConfig {
                key: "fixed_sac",
                reason: "temperature must be >= 0, polyak and random_eps in [0, 1], huber_delta > 0".into(),
            });
        }
        Ok(())
    }

    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        l.squashed_gaussian_act(inputs, n, mode, DIST, self.config.random_eps)
    }

    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        let alpha = vec![self.config.temperature as f32; l.num_agents()];
        let (next, soft) = l.sampled_next_actions(b, DIST, &alpha)?;
        let delta = self.config.huber_delta as f32;
        let critic = l.critic_step_with(b, next, Some(soft), &|d: Tensor<3>| huber(d, delta))?;
        let (actor, _) = l.squashed_gaussian_actor_step(b, DIST, &alpha, Teammates::Replay)?;
        Ok(StepLosses { critic, actor: Some(actor) })
    }

    fn targets(&self) -> (f64, bool) {
        (self.config.polyak, false)
    }
}

impl ConfiguredRule for FixedSac {
    type Config = FixedSacConfig;

    fn default_config() -> FixedSacConfig {
        FixedSacConfig::default()
    }

    fn from_config(config: FixedSacConfig) -> Self {
        Self { config }
    }
}

/// A Shadow Hand run of one update cycle an epoch: the egg, Dense+FMSR+IS.
const CONFIG: &str = r#"
name = "downstream_fixed_sac"
method = "dense_fmsr_is"
algorithm = "fixed_sac"
engine = "rapier"

[env]
object = "egg"

[trainer]
seed = 0
epochs = 1
cycles = 1
episodes_per_cycle = 2
eval_episodes = 1

[replay]
batches = 2
batch_size = 32

[networks]
hidden = 32
layers = 2

[eval]
episodes = 2

[fixed_sac]
temperature = 0.1
"#;

/// Registers the rule, then trains, resumes, exports and evaluates a run of
/// it with fmsr's command in `dir`.
///
/// # Errors
/// Registration, the command's errors, or a run that does not hold what it should.
pub fn run_by_name(dir: &Path) -> Result<()> {
    let d = Tensor::<3>::from_floats([[[-3.0], [0.5]]], &Default::default());
    let l: Vec<f32> = huber(d, 2.0).into_data().try_to_vec::<f32>().map_err(|e| anyhow::anyhow!("{e:?}"))?;
    if l != [4.0, 0.125] {
        bail!("the Huber loss of -3 and 0.5 at threshold 2 is {l:?}, not [4, 0.125]");
    }
    fmsr::algorithms::register::<FixedSac>()?;
    let (config, run, policy) = (dir.join("fixed_sac.toml"), dir.join("run"), dir.join("fixed_sac.fmsr"));
    std::fs::write(&config, CONFIG)?;
    let arg = |p: &Path| p.to_string_lossy().into_owned();
    let fmsr = |args: &[&str]| fmsr::cli::run(std::iter::once("fmsr").chain(args.iter().copied()));
    fmsr(&["train", "--config", &arg(&config), "--out", &arg(&run), "--quiet"])?;
    fmsr(&["train", "--out", &arg(&run), "--resume", "--epochs", "2", "--quiet"])?;
    fmsr(&["export", &arg(&run), "--out", &arg(&policy)])?;
    fmsr(&["eval", &arg(&policy)])?;
    let written = std::fs::read_to_string(run.join("config.toml"))?;
    let epochs = std::fs::read_to_string(run.join("metrics.csv"))?.lines().count() - 1;
    if !written.contains("algorithm = \"fixed_sac\"")
        || !written.contains("[fixed_sac]")
        || !written.contains("huber_delta = 2.0")
        || epochs != 2
    {
        bail!("the run's config.toml or metrics.csv do not hold the fixed_sac run of 2 epochs");
    }
    println!("fmsr's command trained, resumed, exported and evaluated this crate's fixed_sac by name");
    Ok(())
}
