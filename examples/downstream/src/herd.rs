//! A user's task: `Herd`. Three agents move along a line; the goal is a
//! position for their mean. The stability feature `together` is on while
//! the agents stay within 0.5 of each other. Registered by name
//! (`fmsr::tasks::Task`), fmsr's own command trains, resumes, exports and
//! evaluates it from a config that says `task = "herd"`, here with this
//! crate's own algorithm (`fixed_sac`, `sac.rs`), and reports the task's own
//! measures of each evaluation episode: the herd's spread at the end (read
//! from the environment) and the steps it took to first reach the goal (from
//! the episode).

use std::path::Path;

use anyhow::{Result, bail};
use fmsr_core::prelude::*;
use rand::{RngExt, SeedableRng};
use serde::{Deserialize, Serialize};

/// Agents of the herd.
pub const AGENTS: usize = 3;

/// The `[herd]` section of an experiment config.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HerdConfig {
    /// How far one step at full action moves an agent.
    pub speed: f32,
    /// Steps per episode.
    pub episode_len: usize,
    /// Success: the mean within this distance of the goal.
    pub threshold: f32,
}

impl Default for HerdConfig {
    fn default() -> Self {
        Self { speed: 0.15, episode_len: 20, threshold: 0.1 }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum HerdError {
    #[error(transparent)]
    Core(#[from] CoreError),
    #[error("herd.{key}: {reason}")]
    Config { key: &'static str, reason: &'static str },
}

/// The herding task.
pub struct Herd {
    spec: EnvSpec,
    config: HerdConfig,
    x: [f32; AGENTS],
    goal: f32,
}

impl Herd {
    /// A herd of `config`.
    ///
    /// # Errors
    /// A speed or threshold that is not positive, episodes of no step.
    pub fn new(config: HerdConfig) -> Result<Self, HerdError> {
        if config.speed.is_nan() || config.speed <= 0.0 {
            return Err(HerdError::Config { key: "speed", reason: "must be positive" });
        }
        if config.threshold.is_nan() || config.threshold <= 0.0 {
            return Err(HerdError::Config { key: "threshold", reason: "must be positive" });
        }
        let agents =
            (0..AGENTS).map(|i| AgentSpec { name: format!("a{i}"), action_slots: vec![i], local_obs_dim: 2 }).collect();
        let spec = EnvSpec {
            agents,
            action_dim: AGENTS,
            obs_dim: AGENTS,
            goal_dim: 1,
            episode_len: config.episode_len,
            features: vec!["together".into()],
            reward_range: (-4.0, 0.0),
        };
        spec.validate()?;
        Ok(Self { spec, config, x: [0.0; AGENTS], goal: 0.0 })
    }

    fn mean(&self) -> f32 {
        self.x.iter().sum::<f32>() / AGENTS as f32
    }

    /// The distance between the two agents farthest apart.
    #[must_use]
    pub fn spread(&self) -> f32 {
        self.x.iter().fold(f32::MIN, |m, &x| m.max(x)) - self.x.iter().fold(f32::MAX, |m, &x| m.min(x))
    }

    fn observation(&self) -> Observation {
        let mean = self.mean();
        Observation {
            global: self.x.to_vec(),
            locals: self.x.iter().map(|&x| vec![x, x - mean]).collect(),
            achieved_goal: vec![mean],
            desired_goal: vec![self.goal],
        }
    }
}

impl Env for Herd {
    type Error = HerdError;

    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64) -> Result<Observation, HerdError> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        for x in &mut self.x {
            *x = rng.random_range(-1.0..1.0);
        }
        self.goal = rng.random_range(-1.0..1.0);
        Ok(self.observation())
    }

    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, HerdError> {
        action.validate(&self.spec)?;
        for (x, a) in self.x.iter_mut().zip(&action.0) {
            *x = (*x + self.config.speed * a).clamp(-2.0, 2.0);
        }
        let obs = self.observation();
        let spread = self.spread();
        let distance = self.goal_distance(&obs.achieved_goal, &obs.desired_goal);
        Ok(StepOutcome {
            reward: self.goal_reward(&obs.achieved_goal, &obs.desired_goal),
            terminated: false,
            truncated: false,
            info: StepInfo {
                is_success: distance < self.config.threshold,
                features: vec![f32::from(u8::from(spread < 0.5))],
                dropped: false,
            },
            observation: obs,
        })
    }

    fn goal_distance(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        (achieved[0] - desired[0]).abs()
    }

    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        RewardType::Dense.reward(self.goal_distance(achieved, desired), self.config.threshold)
    }
}

/// The task fmsr's configs choose by `task = "herd"`.
pub struct HerdTask;

impl fmsr::tasks::Task for HerdTask {
    const NAME: &'static str = "herd";
    type Config = HerdConfig;
    type Env = Herd;

    fn env(config: &HerdConfig) -> Result<Herd, HerdError> {
        Herd::new(*config)
    }

    const MEASURES: &'static [&'static str] = &["final_spread", "steps_to_goal"];

    /// The herd's spread at the end; the steps until the mean first came
    /// within the threshold (all of the episode's if it never did).
    fn measure(env: &Herd, episode: &Episode) -> Vec<f64> {
        let first = episode.infos.iter().position(|i| i.is_success);
        vec![f64::from(env.spread()), first.map_or(episode.infos.len(), |i| i + 1) as f64]
    }
}

/// The herd, trained by this crate's `fixed_sac` with shadow rewards and
/// information sharing over a chain; every agent gets the shadow reward of
/// `together`.
const CONFIG: &str = r#"
name = "downstream_herd"
method = "dense_fmsr_is"
task = "herd"
algorithm = "fixed_sac"

[herd]
speed = 0.2

[graph]
edges = [["a0", "a1"], ["a1", "a2"]]

[trainer]
seed = 1
epochs = 1
cycles = 4
eval_episodes = 4

[trainer.shadow]
alpha = 0.05
assignment = { agents = [
  { agent = "a0", shadow = ["together"] },
  { agent = "a1", shadow = ["together"] },
  { agent = "a2", shadow = ["together"] },
] }

[replay]
batches = 4
batch_size = 64

[networks]
hidden = 32
layers = 2

[eval]
episodes = 20
"#;

/// Registers the task (and `fixed_sac`, `sac.rs`), then trains, resumes,
/// exports, evaluates and reports a run of it with fmsr's command in `dir`.
///
/// # Errors
/// Registration, the command's errors, or a run that does not hold what it should.
pub fn run_by_name(dir: &Path) -> Result<()> {
    fmsr::tasks::register::<HerdTask>()?;
    fmsr::algorithms::register::<crate::sac::FixedSac>()?;
    let (config, run, policy) = (dir.join("herd.toml"), dir.join("herd-run"), dir.join("herd.fmsr"));
    std::fs::write(&config, CONFIG)?;
    let arg = |p: &Path| p.to_string_lossy().into_owned();
    let fmsr = |args: &[&str]| fmsr::cli::run(std::iter::once("fmsr").chain(args.iter().copied()));
    fmsr(&["train", "--config", &arg(&config), "--out", &arg(&run), "--quiet"])?;
    fmsr(&["train", "--out", &arg(&run), "--resume", "--epochs", "2", "--quiet"])?;
    fmsr(&["eval", &arg(&run)])?;
    fmsr(&["export", &arg(&run), "--out", &arg(&policy)])?;
    fmsr(&["eval", &arg(&policy)])?;
    let report_dir = dir.join("herd-report");
    fmsr(&["report", &arg(&run), "--out", &arg(&report_dir)])?;
    let summary = std::fs::read_to_string(report_dir.join("summary.md"))?;
    if !summary.contains("## herd") || !report_dir.join("fig3_herd.png").exists() {
        bail!("the herd report has no section or learning curves of the task `herd`");
    }
    if !summary.contains("`final_spread` (mean ± std)") || !summary.contains("`steps_to_goal` (mean ± std)") {
        bail!("the herd report does not give the task's own measures");
    }
    let written = std::fs::read_to_string(run.join("config.toml"))?;
    let report: fmsr::task_eval::TaskEvalReport = serde_json::from_slice(&std::fs::read(run.join("task-eval.json"))?)?;
    if !written.contains("task = \"herd\"")
        || !written.contains("[herd]")
        || !written.contains("episode_len = 20")
        || report.task != "herd"
        || report.epochs != 2
        || report.episodes != 20
        || report.measures != ["final_spread", "steps_to_goal"]
        || !report.records.iter().all(|r| {
            matches!(r.measures[..], [spread, steps] if (0.0..=4.0).contains(&spread) && (1.0..=20.0).contains(&steps))
        })
    {
        bail!("the herd run's config.toml or task-eval.json do not hold the fixed_sac herd run of 2 epochs and its measures");
    }
    println!(
        "fmsr's command trained, resumed, exported, evaluated and reported this crate's herd by name with fixed_sac: \
         success {}/{} (the zero action {}/{}), final spread {:.3}",
        report.successes,
        report.episodes,
        report.still_successes,
        report.episodes,
        report.measure(0).map_or(f64::NAN, |m| m.mean)
    );
    Ok(())
}
