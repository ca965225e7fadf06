//! The training loop of Algorithm 1: epochs x cycles x (rollouts, then batches
//! of updates), with exploration, occupancy estimation, shadow rewards,
//! per-epoch evaluation and checkpoints.
//!
//! Each cycle: `episodes_per_cycle` rollouts with exploration noise (Gaussian
//! `noise_eps`, and with probability `random_eps` a uniformly random joint action,
//! as HER baselines) are stored in the shared replay buffer and their features
//! update the occupancy estimate `lambda` (eq. 1); then `batches` updates, each on
//! one HER batch shared by all agents with every agent's reward `r_i` (eq. 7) computed
//! from the current `lambda`; then the target networks move (eq. 9). At the end of an
//! epoch the deterministic policy is evaluated on fresh seeded episodes.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::agent::{Agent, LearnStats, ObservationLayout, SaveState};
use crate::config::ShadowConfig;
use crate::env::Env;
use crate::error::CoreError;
use crate::occupancy::{DiscountedOccupancy, OccupancyEstimator};
use crate::replay::{Episode, HerConfig, ReplayBuffer};
use crate::shadow::AgentRewards;
use crate::spec::{JointAction, StepInfo, StepOutcome};

/// Settings of the training loop (defaults: the paper's, DESIGN.md 3.10).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainerConfig {
    /// Seed of every random choice of the trainer (episode seeds, noise, sampling).
    pub seed: u64,
    /// Epochs (paper: 400).
    pub epochs: usize,
    /// Cycles per epoch (paper: 25).
    pub cycles: usize,
    /// Rollouts per cycle (HER baselines: 2 per worker).
    pub episodes_per_cycle: usize,
    /// Updates per cycle (paper: 25).
    pub batches: usize,
    /// Samples per update (256).
    pub batch_size: usize,
    /// Replay capacity in transitions (1e6).
    pub buffer_size: usize,
    /// Std of the Gaussian exploration noise on actions in `[-1, 1]` (0.2).
    pub noise_eps: f32,
    /// Probability of a uniformly random joint action (0.3).
    pub random_eps: f32,
    /// Hindsight relabelling.
    pub her: HerConfig,
    /// Discount; `None` is `1 - 1/T`.
    pub gamma: Option<f64>,
    /// Evaluation episodes at the end of every epoch (paper: 50).
    pub eval_episodes: usize,
    /// Shadow rewards.
    pub shadow: ShadowConfig,
}

impl Default for TrainerConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            epochs: 400,
            cycles: 25,
            episodes_per_cycle: 2,
            batches: 25,
            batch_size: 256,
            buffer_size: 1_000_000,
            noise_eps: 0.2,
            random_eps: 0.3,
            her: HerConfig::default(),
            gamma: None,
            eval_episodes: 50,
            shadow: ShadowConfig::default(),
        }
    }
}

impl TrainerConfig {
    /// Checks every value, naming the key of the first impossible one.
    pub fn validate(&self) -> Result<(), CoreError> {
        let bad = |key: &str, reason: &str| Err(CoreError::InvalidConfig { key: key.into(), reason: reason.into() });
        for (key, v) in [
            ("cycles", self.cycles),
            ("episodes_per_cycle", self.episodes_per_cycle),
            ("batch_size", self.batch_size),
            ("buffer_size", self.buffer_size),
        ] {
            if v == 0 {
                return bad(key, "must be at least 1");
            }
        }
        if !(0.0..=1.0).contains(&self.random_eps) {
            return bad("random_eps", "must be in [0, 1]");
        }
        if !(self.noise_eps.is_finite() && self.noise_eps >= 0.0) {
            return bad("noise_eps", "must be finite and nonnegative");
        }
        if let Some(g) = self.gamma
            && !(0.0..1.0).contains(&g)
        {
            return bad("gamma", "must be in [0, 1)");
        }
        Ok(())
    }

    /// The discount for episodes of length `horizon`: `gamma` or `1 - 1/T`.
    #[must_use]
    pub fn gamma_for(&self, horizon: usize) -> f64 {
        self.gamma.unwrap_or(1.0 - 1.0 / horizon as f64)
    }
}

/// Statistics of one epoch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct EpochStats {
    /// Epoch index, from 0.
    pub epoch: usize,
    /// Success rate of the evaluation episodes (deterministic policy).
    pub success_rate: f64,
    /// Success rate of the training rollouts (with exploration).
    pub train_success_rate: f64,
    /// Fraction of evaluation episodes that ended with the object dropped.
    pub drop_rate: f64,
    /// Mean per-step value of each feature over the evaluation episodes.
    pub eval_feature_rates: Vec<f64>,
    /// Mean per-step value of each feature over the training rollouts.
    pub train_feature_rates: Vec<f64>,
    /// Mean undiscounted return of each agent (task + shadow) over the training rollouts.
    pub returns: Vec<f64>,
    /// The occupancy estimate `lambda_k` at the end of the epoch.
    pub occupancy: Vec<f64>,
    /// Mean critic loss of each agent over the epoch's updates.
    pub critic_loss: Vec<f64>,
    /// Mean actor loss of each agent over the epoch's updates.
    pub actor_loss: Vec<f64>,
    /// Environment steps so far.
    pub env_steps: u64,
    /// Updates so far.
    pub updates: u64,
    /// Environment steps per second in this epoch (rollouts and evaluation).
    pub env_steps_per_sec: f64,
    /// Updates per second in this epoch.
    pub updates_per_sec: f64,
    /// Wall time of the epoch (s).
    pub seconds: f64,
}

/// Result of evaluating the deterministic policy on a set of seeded episodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct EvalSummary {
    /// Episodes run.
    pub episodes: usize,
    /// Fraction that ended within the success threshold.
    pub success_rate: f64,
    /// Fraction that ended with the object dropped.
    pub drop_rate: f64,
    /// Mean per-step value of each feature.
    pub feature_rates: Vec<f64>,
    /// Final goal distance of each episode.
    pub final_distances: Vec<f32>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct TrainerState {
    epoch: usize,
    rng: ChaCha8Rng,
    env_steps: u64,
    updates: u64,
    occupancy: DiscountedOccupancy,
    history: Vec<EpochStats>,
}

/// The training loop; see the [module docs](self).
#[derive(Debug)]
pub struct Trainer<E, A> {
    config: TrainerConfig,
    env: E,
    agent: A,
    layout: ObservationLayout,
    replay: ReplayBuffer,
    rewards: AgentRewards,
    q_bounds: Vec<(f32, f32)>,
    state: TrainerState,
}

fn env_err<E: std::error::Error + Send + Sync + 'static>(e: E) -> CoreError {
    CoreError::Env(Box::new(e))
}

fn agent_err<E: std::error::Error + Send + Sync + 'static>(e: E) -> CoreError {
    CoreError::Agent(Box::new(e))
}

/// A well-mixed 64-bit hash (splitmix64), used to derive evaluation seeds.
#[must_use]
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Standard normal sample by the Box-Muller transform.
fn gaussian<R: Rng + ?Sized>(rng: &mut R) -> f32 {
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random::<f64>();
    ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
}

impl<E: Env, A: Agent> Trainer<E, A> {
    /// A trainer of `agent` on `env`, whose actors see inputs laid out by `layout`.
    pub fn new(config: TrainerConfig, env: E, agent: A, layout: ObservationLayout) -> Result<Self, CoreError> {
        config.validate()?;
        let spec = env.spec().clone();
        spec.validate()?;
        if layout.spec() != &spec {
            return Err(CoreError::InvalidConfig {
                key: "layout".into(),
                reason: "the observation layout was built for another environment spec".into(),
            });
        }
        if agent.num_agents() != spec.agents.len() {
            return Err(CoreError::Dimension {
                what: "learner agents",
                expected: spec.agents.len(),
                found: agent.num_agents(),
            });
        }
        let gamma = config.gamma_for(spec.episode_len);
        let rewards = config.shadow.agent_rewards(&spec)?;
        let q_bounds = rewards
            .step_bounds(spec.reward_range)
            .into_iter()
            .map(|(lo, hi)| ((lo / (1.0 - gamma)) as f32, (hi / (1.0 - gamma)) as f32))
            .collect();
        let occupancy = config.shadow.occupancy(&spec, gamma)?;
        let replay = ReplayBuffer::new(&spec, config.buffer_size)?;
        let state = TrainerState {
            epoch: 0,
            rng: ChaCha8Rng::seed_from_u64(config.seed),
            env_steps: 0,
            updates: 0,
            occupancy,
            history: Vec::new(),
        };
        Ok(Self { config, env, agent, layout, replay, rewards, q_bounds, state })
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &TrainerConfig {
        &self.config
    }

    /// The learner.
    #[must_use]
    pub fn agent(&self) -> &A {
        &self.agent
    }

    /// The learner, mutably.
    pub fn agent_mut(&mut self) -> &mut A {
        &mut self.agent
    }

    /// The environment, mutably.
    pub fn env_mut(&mut self) -> &mut E {
        &mut self.env
    }

    /// The statistics of every finished epoch.
    #[must_use]
    pub fn history(&self) -> &[EpochStats] {
        &self.state.history
    }

    /// Epochs finished so far.
    #[must_use]
    pub fn epoch(&self) -> usize {
        self.state.epoch
    }

    /// The current occupancy estimate, one value per feature.
    #[must_use]
    pub fn occupancy(&self) -> &[f64] {
        self.state.occupancy.estimate()
    }

    /// The per-agent bounds of the Q targets (`clip_return`).
    #[must_use]
    pub fn q_bounds(&self) -> &[(f32, f32)] {
        &self.q_bounds
    }

    /// How actor inputs are assembled.
    #[must_use]
    pub fn layout(&self) -> &ObservationLayout {
        &self.layout
    }

    /// The environment.
    #[must_use]
    pub fn env(&self) -> &E {
        &self.env
    }

    /// The replay buffer.
    #[must_use]
    pub fn replay(&self) -> &ReplayBuffer {
        &self.replay
    }

    /// Runs one episode from `seed`; with `explore`, exploration noise and random
    /// actions are drawn from the trainer's RNG.
    pub fn rollout(&mut self, seed: u64, explore: bool) -> Result<Episode, CoreError> {
        self.rollout_with(seed, explore, &mut |_, _| {})
    }

    /// As [`Trainer::rollout`], calling `on_step(env, outcome)` after every step
    /// (e.g. to read contacts for the grasp metrics).
    pub fn rollout_with(
        &mut self,
        seed: u64,
        explore: bool,
        on_step: &mut dyn FnMut(&E, &StepOutcome),
    ) -> Result<Episode, CoreError> {
        let spec = self.env.spec().clone();
        let mut obs = self.env.reset(seed).map_err(env_err)?;
        obs.validate(&spec)?;
        let mut prev = JointAction::zeros(spec.action_dim);
        let mut episode = Episode {
            observations: Vec::with_capacity(spec.episode_len + 1),
            actions: Vec::with_capacity(spec.episode_len),
            infos: Vec::with_capacity(spec.episode_len),
        };
        for _ in 0..spec.episode_len {
            let inputs = self.layout.actor_inputs(&obs, &prev);
            let actions = self.agent.act(&inputs, 1).map_err(agent_err)?;
            let mut joint = JointAction::from_agents(&spec.agents, &actions)?;
            if explore {
                let rng = &mut self.state.rng;
                for v in &mut joint.0 {
                    *v = (*v + self.config.noise_eps * gaussian(rng)).clamp(-1.0, 1.0);
                }
                if rng.random::<f32>() < self.config.random_eps {
                    for v in &mut joint.0 {
                        *v = rng.random_range(-1.0..=1.0);
                    }
                }
            }
            let outcome = self.env.step(&joint).map_err(env_err)?;
            outcome.observation.validate(&spec)?;
            on_step(&self.env, &outcome);
            if outcome.info.features.len() != spec.features.len() {
                return Err(CoreError::Dimension {
                    what: "step features",
                    expected: spec.features.len(),
                    found: outcome.info.features.len(),
                });
            }
            episode.observations.push(obs);
            episode.actions.push(joint.clone());
            episode.infos.push(outcome.info);
            obs = outcome.observation;
            prev = joint;
        }
        episode.observations.push(obs);
        self.state.env_steps += spec.episode_len as u64;
        Ok(episode)
    }

    /// Evaluates the deterministic policy on one episode per seed. Success is
    /// a final goal distance below `threshold`, or with `None` the environment's
    /// own success flag at the last step (its training threshold).
    pub fn evaluate(&mut self, seeds: &[u64], threshold: Option<f32>) -> Result<EvalSummary, CoreError> {
        let k = self.env.spec().features.len();
        let mut summary = EvalSummary { episodes: seeds.len(), feature_rates: vec![0.0; k], ..EvalSummary::default() };
        let (mut successes, mut drops, mut steps) = (0usize, 0usize, 0usize);
        for &seed in seeds {
            let ep = self.rollout(seed, false)?;
            let last = ep.observations.last().expect("an episode has T + 1 >= 2 observations");
            let d = self.env.goal_distance(&last.achieved_goal, &last.desired_goal);
            let success = match threshold {
                Some(t) => d < t,
                None => ep.infos.last().is_some_and(|i| i.is_success),
            };
            successes += usize::from(success);
            drops += usize::from(ep.infos.iter().any(|i| i.dropped));
            summary.final_distances.push(d);
            accumulate_features(&ep.infos, &mut summary.feature_rates);
            steps += ep.infos.len();
        }
        let n = seeds.len().max(1) as f64;
        summary.success_rate = successes as f64 / n;
        summary.drop_rate = drops as f64 / n;
        summary.feature_rates.iter_mut().for_each(|r| *r /= steps.max(1) as f64);
        Ok(summary)
    }

    /// The evaluation seeds of epoch `epoch`: fresh every epoch, fixed by the config seed.
    #[must_use]
    pub fn eval_seeds(&self, epoch: usize) -> Vec<u64> {
        (0..self.config.eval_episodes as u64)
            .map(|i| splitmix64(splitmix64(self.config.seed ^ 0xE7A1_5EED) ^ ((epoch as u64) << 32) ^ i))
            .collect()
    }

    /// Runs one epoch and returns (and records) its statistics.
    pub fn run_epoch(&mut self) -> Result<EpochStats, CoreError> {
        let start = Instant::now();
        let spec = self.env.spec().clone();
        let n_agents = spec.agents.len();
        let k = spec.features.len();
        let steps_before = self.state.env_steps;
        let mut update_time = 0.0f64;
        let mut updates = 0u64;
        let mut returns = vec![0.0f64; n_agents];
        let mut train_features = vec![0.0f64; k];
        let (mut train_success, mut train_episodes, mut train_steps) = (0usize, 0usize, 0usize);
        let mut losses = LearnStats { critic_loss: vec![0.0; n_agents], actor_loss: vec![0.0; n_agents] };
        let mut reward_buf = vec![0.0f32; n_agents];
        for _ in 0..self.config.cycles {
            for _ in 0..self.config.episodes_per_cycle {
                let seed = self.state.rng.random::<u64>();
                let ep = self.rollout(seed, true)?;
                self.replay.store(&ep)?;
                self.state.occupancy.observe_episode(&ep.features())?;
                let lambda = self.state.occupancy.estimate();
                for (t, info) in ep.infos.iter().enumerate() {
                    let o = &ep.observations[t + 1];
                    let task = self.env.goal_reward(&o.achieved_goal, &o.desired_goal);
                    self.rewards.compute(task, &info.features, lambda, &mut reward_buf);
                    returns.iter_mut().zip(&reward_buf).for_each(|(r, v)| *r += f64::from(*v));
                }
                accumulate_features(&ep.infos, &mut train_features);
                train_success += usize::from(ep.infos.last().is_some_and(|i| i.is_success));
                train_episodes += 1;
                train_steps += ep.infos.len();
            }
            let t0 = Instant::now();
            for _ in 0..self.config.batches {
                let Trainer { env, replay, rewards, layout, state, config, q_bounds, agent, .. } = &mut *self;
                let lambda = state.occupancy.estimate();
                let mut batch = replay.sample(
                    config.batch_size,
                    &config.her,
                    layout,
                    &mut state.rng,
                    &|a, d| env.goal_reward(a, d),
                    &|task, phi, out| rewards.compute(task, phi, lambda, out),
                )?;
                batch.q_bounds.clone_from(q_bounds);
                let stats = agent.learn(&batch).map_err(agent_err)?;
                for (acc, v) in losses.critic_loss.iter_mut().zip(&stats.critic_loss) {
                    *acc += v;
                }
                for (acc, v) in losses.actor_loss.iter_mut().zip(&stats.actor_loss) {
                    *acc += v;
                }
                updates += 1;
            }
            if self.config.batches > 0 {
                self.agent.update_targets().map_err(agent_err)?;
            }
            update_time += t0.elapsed().as_secs_f64();
        }
        self.state.updates += updates;
        let epoch = self.state.epoch;
        let seeds = self.eval_seeds(epoch);
        let eval = self.evaluate(&seeds, None)?;
        let seconds = start.elapsed().as_secs_f64();
        let env_steps = self.state.env_steps - steps_before;
        let per_update = |v: &Vec<f32>| v.iter().map(|x| f64::from(*x) / updates.max(1) as f64).collect();
        let stats = EpochStats {
            epoch,
            success_rate: eval.success_rate,
            train_success_rate: train_success as f64 / train_episodes.max(1) as f64,
            drop_rate: eval.drop_rate,
            eval_feature_rates: eval.feature_rates,
            train_feature_rates: train_features.iter().map(|v| v / train_steps.max(1) as f64).collect(),
            returns: returns.iter().map(|r| r / train_episodes.max(1) as f64).collect(),
            occupancy: self.state.occupancy.estimate().to_vec(),
            critic_loss: per_update(&losses.critic_loss),
            actor_loss: per_update(&losses.actor_loss),
            env_steps: self.state.env_steps,
            updates: self.state.updates,
            env_steps_per_sec: env_steps as f64 / (seconds - update_time).max(1e-9),
            updates_per_sec: updates as f64 / update_time.max(1e-9),
            seconds,
        };
        self.state.history.push(stats.clone());
        self.state.epoch += 1;
        Ok(stats)
    }

    /// Runs the remaining epochs up to `config.epochs`, calling `on_epoch` after
    /// each (e.g. to log and write a checkpoint).
    pub fn train(
        &mut self,
        mut on_epoch: impl FnMut(&mut Self, &EpochStats) -> Result<(), CoreError>,
    ) -> Result<(), CoreError> {
        while self.state.epoch < self.config.epochs {
            let stats = self.run_epoch()?;
            on_epoch(self, &stats)?;
        }
        Ok(())
    }
}

fn accumulate_features(infos: &[StepInfo], acc: &mut [f64]) {
    for info in infos {
        for (a, v) in acc.iter_mut().zip(&info.features) {
            *a += f64::from(*v);
        }
    }
}

const MAGIC: &[u8; 8] = b"FMSRCKPT";
const VERSION: u32 = 1;

/// FNV-1a, 64 bit: a checksum that detects corrupted checkpoints.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

#[derive(Serialize, Deserialize)]
struct CheckpointMeta {
    config: TrainerConfig,
    state: TrainerState,
    has_replay: bool,
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder,
/// flushed to disk, then renamed over `path`. A crash leaves either the old or the
/// new file, never a torn one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), CoreError> {
    let io = |source| CoreError::Io { path: path.to_path_buf(), source };
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io)?;
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp: PathBuf = dir.join(format!(".{file_name}.tmp{}", std::process::id()));
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.sync_all().map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io)?;
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

impl<E: Env, A: SaveState> Trainer<E, A> {
    /// Writes a checkpoint of everything training needs to continue: the
    /// learner's state, the trainer's RNG, counters, occupancy estimate and
    /// history, and (if `include_replay`) the replay buffer. With the replay
    /// buffer, resuming continues exactly as an uninterrupted run.
    pub fn save_checkpoint(&self, path: &Path, include_replay: bool) -> Result<(), CoreError> {
        let meta =
            CheckpointMeta { config: self.config.clone(), state: self.state.clone(), has_replay: include_replay };
        let meta =
            serde_json::to_vec(&meta).map_err(|e| CoreError::Corrupt { path: path.into(), reason: e.to_string() })?;
        let agent = self.agent.save_state().map_err(agent_err)?;
        let replay = if include_replay { self.replay.to_bytes() } else { Vec::new() };
        let mut body = Vec::with_capacity(meta.len() + agent.len() + replay.len() + 24);
        for section in [&meta, &agent, &replay] {
            body.extend_from_slice(&(section.len() as u64).to_le_bytes());
            body.extend_from_slice(section);
        }
        let mut out = Vec::with_capacity(body.len() + 20);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&fnv1a(&body).to_le_bytes());
        out.extend_from_slice(&body);
        write_atomic(path, &out)
    }

    /// Restores a checkpoint written by [`Trainer::save_checkpoint`]. The
    /// checkpoint must come from the same configuration, except `epochs`, which
    /// may be raised to train longer. A corrupted, truncated or mismatched file
    /// is an error naming the problem.
    pub fn load_checkpoint(&mut self, path: &Path) -> Result<(), CoreError> {
        let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_end(&mut bytes))
            .map_err(|source| CoreError::Io { path: path.into(), source })?;
        if bytes.len() < 20 || &bytes[..8] != MAGIC {
            return Err(corrupt("not an fmsr checkpoint (bad magic)".into()));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != VERSION {
            return Err(corrupt(format!("checkpoint version {version}, this build reads {VERSION}")));
        }
        let sum = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
        let body = &bytes[20..];
        if fnv1a(body) != sum {
            return Err(corrupt("checksum mismatch (truncated or corrupted file)".into()));
        }
        let mut sections = Vec::with_capacity(3);
        let mut rest = body;
        for _ in 0..3 {
            if rest.len() < 8 {
                return Err(corrupt("truncated section header".into()));
            }
            let len = u64::from_le_bytes(rest[..8].try_into().expect("8 bytes")) as usize;
            rest = &rest[8..];
            if rest.len() < len {
                return Err(corrupt("truncated section".into()));
            }
            sections.push(&rest[..len]);
            rest = &rest[len..];
        }
        let meta: CheckpointMeta = serde_json::from_slice(sections[0]).map_err(|e| corrupt(e.to_string()))?;
        let mut expected = self.config.clone();
        expected.epochs = meta.config.epochs;
        if meta.config != expected {
            return Err(CoreError::InvalidConfig {
                key: "checkpoint".into(),
                reason: format!("{} was written with a different configuration", path.display()),
            });
        }
        if meta.state.occupancy.estimate().len() != self.env.spec().features.len() {
            return Err(corrupt("occupancy has a different number of features".into()));
        }
        let replay = if meta.has_replay {
            let r = ReplayBuffer::from_bytes(sections[2]).map_err(|e| corrupt(format!("replay buffer: {e}")))?;
            if !r.is_compatible(self.env.spec()) {
                return Err(corrupt("replay buffer of another environment spec".into()));
            }
            Some(r)
        } else {
            None
        };
        self.agent.load_state(sections[1]).map_err(agent_err)?;
        if let Some(r) = replay {
            self.replay = r;
        }
        self.state = meta.state;
        Ok(())
    }
}
