//! A user's algorithm in one file: independent DDPG (IDDPG), which this crate
//! does not ship, written against the public traits alone ([`Policy`],
//! [`Algorithm`]) and trained by the crate's [`Trainer`] like MADDPG.
//!
//! IDDPG (as BenchMARL ships it) gives every agent a DDPG of its own: agent
//! `i`'s critic sees only what its actor sees, `o_i` (here the actor input of
//! the [`ObservationLayout`]: its local observation, its neighbours', the
//! goal), and its own action `a_i`, not the global state and joint action of
//! MADDPG's centralised critics:
//!
//! ```text
//! y_i = clip(r_i + gamma * Q'_i(o'_i, mu'_i(o'_i)), lo_i / (1 - gamma), hi_i / (1 - gamma))
//! L_i = mean (Q_i(o_i, a_i) - y_i)^2                  critic
//! J_i = -mean Q_i(o_i, mu_i(o_i)) + l2 * mean mu_i^2  actor
//! ```
//!
//! with HER replay from [`ReplayBuffer`] and each agent's reward `r_i` (eq. 7,
//! shadow rewards included) from the trainer's [`RewardModel`]. The networks
//! are fmsr-nn's [`StackedMlp`]s: all agents' actors in one stack, all
//! critics in another, each agent's widths padded to the widest (padded inputs
//! are zero and padded outputs are cut off, so they change nothing).
//!
//! Saved state holds the networks, normalisers, replay position and RNG, not
//! Adam's moments: a resumed IDDPG run restarts them, so it does not repeat an
//! uninterrupted one exactly (the shipped learners do).
//!
//! `cargo run --release --example custom_algorithm` trains it on TeamReach;
//! `tests/custom_algorithm.rs` checks that it learns.

use burn::module::{Module, Param};
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use fmsr::core::replay::ReplayBuffer;
use fmsr::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// What can go wrong in IDDPG.
#[derive(Debug, thiserror::Error)]
pub enum IddpgError {
    /// The replay buffer or a shape check of fmsr-core.
    #[error(transparent)]
    Core(#[from] CoreError),
    /// Building the networks.
    #[error(transparent)]
    Nn(#[from] NnError),
    /// Reading values back from the device.
    #[error("reading {0} back from the device")]
    Readback(&'static str),
    /// A saved state that does not decode or does not fit.
    #[error("IDDPG state: {0}")]
    State(String),
}

/// IDDPG's settings (HER baselines' DDPG defaults where they apply).
#[derive(Debug, Clone, PartialEq)]
pub struct IddpgConfig {
    /// Hidden width of actors and critics.
    pub hidden: usize,
    /// Hidden layers.
    pub layers: usize,
    /// Adam's learning rates.
    pub lr_actor: f64,
    /// Adam's learning rate of the critics.
    pub lr_critic: f64,
    /// Target networks move by `1 - polyak` towards the online ones each cycle.
    pub polyak: f32,
    /// Std of the Gaussian action noise while exploring.
    pub noise_eps: f32,
    /// Probability of a uniformly random action while exploring.
    pub random_eps: f32,
    /// Weight of the actions' L2 penalty in the actor loss.
    pub action_l2: f32,
    /// Replay capacity (transitions), batch size, gradient steps per cycle, HER.
    pub replay: ReplayConfig,
    /// Seed of the weights and of every random draw.
    pub seed: u64,
}

impl Default for IddpgConfig {
    fn default() -> Self {
        Self {
            hidden: 64,
            layers: 2,
            lr_actor: 1e-3,
            lr_critic: 1e-3,
            polyak: 0.95,
            noise_eps: 0.2,
            random_eps: 0.3,
            action_l2: 1.0,
            replay: ReplayConfig { buffer_size: 100_000, batch_size: 128, batches: 20, ..ReplayConfig::default() },
            seed: 0,
        }
    }
}

/// Independent DDPG; see the [module docs](self).
pub struct Iddpg {
    config: IddpgConfig,
    layout: ObservationLayout,
    gamma: f32,
    /// Each agent's actor input width, action width and the widest of each.
    inputs: Vec<usize>,
    actions: Vec<usize>,
    in_max: usize,
    act_max: usize,
    device: Device,
    actors: StackedMlp,
    critics: StackedMlp,
    actor_targets: StackedMlp,
    critic_targets: StackedMlp,
    actor_optim: ModuleOptimizer,
    critic_optim: ModuleOptimizer,
    norms: Vec<Normalizer>,
    replay: ReplayBuffer,
    rng: ChaCha8Rng,
}

impl std::fmt::Debug for Iddpg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Iddpg").field("config", &self.config).finish_non_exhaustive()
    }
}

/// What [`Algorithm::save_state`] writes.
#[derive(Serialize, Deserialize)]
struct SavedState {
    nets: [Vec<Vec<f32>>; 4],
    norms: Vec<Normalizer>,
    rng: ChaCha8Rng,
}

impl Iddpg {
    /// IDDPG for the agents of `layout`, with discount `gamma`, on burn's CPU device.
    ///
    /// # Errors
    /// Invalid replay settings or network widths.
    pub fn new(layout: ObservationLayout, gamma: f64, config: IddpgConfig) -> Result<Self, IddpgError> {
        config.replay.validate()?;
        let spec = layout.spec().clone();
        let inputs: Vec<usize> = (0..spec.agents.len()).map(|i| layout.actor_input_dim(i)).collect();
        let actions: Vec<usize> = spec.agents.iter().map(|a| a.action_slots.len()).collect();
        let (in_max, act_max) = (max(&inputs), max(&actions));
        let device = Device::flex();
        let ad = device.clone().autodiff();
        let actor = StackedMlpConfig::new(inputs.clone(), config.hidden, config.layers, actions.clone())
            .with_seed(config.seed)
            .with_id_base(0);
        let critic = StackedMlpConfig::new(
            vec![in_max + act_max; inputs.len()],
            config.hidden,
            config.layers,
            vec![1; inputs.len()],
        )
        .with_seed(config.seed.wrapping_add(1))
        .with_id_base(100);
        Ok(Self {
            norms: inputs.iter().map(|&d| Normalizer::new(d, 1e-2, 5.0)).collect(),
            replay: ReplayBuffer::new(&spec, config.replay.buffer_size)?,
            rng: ChaCha8Rng::seed_from_u64(config.seed),
            actors: actor.init(&ad)?,
            actor_targets: actor.init(&device)?,
            critics: critic.init(&ad)?,
            critic_targets: critic.init(&device)?,
            actor_optim: AdamConfig::new().init(),
            critic_optim: AdamConfig::new().init(),
            gamma: gamma as f32,
            config,
            layout,
            inputs,
            actions,
            in_max,
            act_max,
            device,
        })
    }

    /// Every agent's normalised actor inputs (`n` rows each) as `[A, n, in_max]`.
    fn observations(&self, rows: &[Vec<f32>], n: usize, device: &Device) -> Tensor<3> {
        let mut data = vec![0.0; rows.len() * n * self.in_max];
        for (i, agent) in rows.iter().enumerate() {
            let mut x = agent.clone();
            self.norms[i].normalize(&mut x);
            for r in 0..n {
                let (d, at) = (self.inputs[i], (i * n + r) * self.in_max);
                data[at..at + d].copy_from_slice(&x[r * d..(r + 1) * d]);
            }
        }
        Tensor::from_data(TensorData::new(data, [rows.len(), n, self.in_max]), device)
    }

    /// `tanh` of the actors' heads with each agent's padded columns zeroed.
    fn squash(&self, heads: Tensor<3>) -> Tensor<3> {
        let a = self.actions.len();
        let mask: Vec<f32> =
            (0..a).flat_map(|i| (0..self.act_max).map(move |k| f32::from(u8::from(k < self.actions[i])))).collect();
        let mask = Tensor::<3>::from_data(TensorData::new(mask, [a, 1, self.act_max]), &heads.device());
        heads.tanh() * mask
    }

    /// Each agent's replayed action `a_i` of the batch, `[A, n, act_max]`.
    fn replayed_actions(&self, batch: &Batch) -> Tensor<3> {
        let (a, n, dim) = (self.actions.len(), batch.size, self.layout.spec().action_dim);
        let mut data = vec![0.0; a * n * self.act_max];
        for (i, agent) in self.layout.spec().agents.iter().enumerate() {
            for r in 0..n {
                for (k, &slot) in agent.action_slots.iter().enumerate() {
                    data[(i * n + r) * self.act_max + k] = batch.actions[r * dim + slot];
                }
            }
        }
        Tensor::from_data(TensorData::new(data, [a, n, self.act_max]), &self.device)
    }

    /// One critic and one actor step on a sampled batch; returns their losses.
    fn learn(&mut self, batch: &Batch, bounds: &[(f64, f64)]) -> Result<(Vec<f64>, Vec<f64>), IddpgError> {
        let (a, n) = (self.actions.len(), batch.size);
        for (norm, rows) in self.norms.iter_mut().zip(&batch.actor_inputs) {
            norm.update(rows, &SingleProcess);
        }
        let (x, x_next) = (
            self.observations(&batch.actor_inputs, n, &self.device),
            self.observations(&batch.next_actor_inputs, n, &self.device),
        );
        // Critic: y_i = clip(r_i + gamma Q'_i(o'_i, mu'_i(o'_i))).
        let next_a = self.squash(self.actor_targets.forward(x_next.clone()));
        let q_next = self.critic_targets.forward(Tensor::cat(vec![x_next, next_a], 2));
        let scale = 1.0 / (1.0 - f64::from(self.gamma));
        let per_agent = |f: &dyn Fn(usize) -> f32| {
            Tensor::<3>::from_data(TensorData::new((0..a).map(f).collect::<Vec<f32>>(), [a, 1, 1]), &self.device)
        };
        let rewards: Vec<f32> = batch.rewards.concat();
        let r = Tensor::<3>::from_data(TensorData::new(rewards, [a, n, 1]), &self.device);
        let lo = per_agent(&|i| (bounds[i].0 * scale) as f32).expand([a, n, 1]);
        let hi = per_agent(&|i| (bounds[i].1 * scale) as f32).expand([a, n, 1]);
        let y = Tensor::from_inner((r + q_next.mul_scalar(self.gamma)).max_pair(lo).min_pair(hi));
        let input = Tensor::from_inner(Tensor::cat(vec![x.clone(), self.replayed_actions(batch)], 2));
        let critic_loss = (self.critics.forward(input) - y).square().mean_dim(1).reshape([a]);
        let critic_values = read(critic_loss.clone(), "critic loss")?;
        let grads = GradientsParams::from_grads(critic_loss.sum().backward(), &self.critics);
        self.critics = self.critic_optim.step(self.config.lr_critic, self.critics.clone(), grads);
        // Actor: -Q_i(o_i, mu_i(o_i)) + l2 mu_i^2, through a critic without gradients.
        let x = Tensor::from_inner(x);
        let mu = self.squash(self.actors.forward(x.clone()));
        let q = self.critics.clone().no_grad().forward(Tensor::cat(vec![x, mu.clone()], 2));
        let l2 = mu.square().mean_dim(2).mean_dim(1).mul_scalar(self.config.action_l2);
        let actor_loss = (l2 - q.mean_dim(1)).reshape([a]);
        let actor_values = read(actor_loss.clone(), "actor loss")?;
        let grads = GradientsParams::from_grads(actor_loss.sum().backward(), &self.actors);
        self.actors = self.actor_optim.step(self.config.lr_actor, self.actors.clone(), grads);
        Ok((critic_values, actor_values))
    }
}

/// `target <- polyak target + (1 - polyak) online`, layer by layer.
fn soft_update(target: &mut StackedMlp, online: &StackedMlp, polyak: f32) {
    let mix = |t: Tensor<3>, o: Tensor<3>| t.mul_scalar(polyak) + o.inner().mul_scalar(1.0 - polyak);
    for (t, o) in target.layers.iter_mut().zip(&online.layers) {
        t.weight = Param::initialized(t.weight.id, mix(t.weight.val(), o.weight.val()));
        t.bias = Param::initialized(t.bias.id, mix(t.bias.val(), o.bias.val()));
    }
}

fn max(widths: &[usize]) -> usize {
    widths.iter().copied().max().unwrap_or(0)
}

fn read<const D: usize>(t: Tensor<D>, what: &'static str) -> Result<Vec<f64>, IddpgError> {
    let values = t.inner().into_data().try_into_vec::<f32>().map_err(|_| IddpgError::Readback(what))?;
    Ok(values.into_iter().map(f64::from).collect())
}

impl Policy for Iddpg {
    type Error = IddpgError;

    fn num_agents(&self) -> usize {
        self.actions.len()
    }

    fn act(&mut self, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, IddpgError> {
        let x = self.observations(inputs, n, &self.device);
        let out = read(self.squash(self.actors.valid().forward(x)), "actions")?;
        let mut actions = Vec::with_capacity(self.actions.len());
        for (i, &d) in self.actions.iter().enumerate() {
            let mut agent = Vec::with_capacity(n * d);
            for r in 0..n {
                let mut row: Vec<f32> = out[(i * n + r) * self.act_max..][..d].iter().map(|&v| v as f32).collect();
                if mode == ActMode::Explore {
                    // Each agent explores on its own: Gaussian noise, or a uniform random action.
                    let random = self.rng.random::<f32>() < self.config.random_eps;
                    for v in &mut row {
                        let noise: f32 = StandardNormal.sample(&mut self.rng);
                        *v = (*v + self.config.noise_eps * noise).clamp(-1.0, 1.0);
                        if random {
                            *v = self.rng.random_range(-1.0..=1.0);
                        }
                    }
                }
                agent.extend(row);
            }
            actions.push(agent);
        }
        Ok(PolicyOutput::actions(actions))
    }
}

impl Algorithm for Iddpg {
    fn store(&mut self, episode: &Episode) -> Result<(), IddpgError> {
        Ok(self.replay.store(episode)?)
    }

    fn update(&mut self, rewards: &dyn RewardModel) -> Result<UpdateStats, IddpgError> {
        let agents = self.actions.len();
        let mut stats = UpdateStats {
            critic_loss: vec![0.0; agents],
            actor_loss: vec![0.0; agents],
            updates: 0,
            ..Default::default()
        };
        if self.replay.episodes() == 0 {
            return Ok(stats);
        }
        let bounds = rewards.reward_bounds();
        let her = self.config.replay.her;
        for _ in 0..self.config.replay.batches {
            let batch = self.replay.sample(
                self.config.replay.batch_size,
                &her,
                &self.layout,
                &mut self.rng,
                &|achieved, desired| rewards.goal_reward(achieved, desired),
                &|task, phi, out| rewards.agent_rewards(task, phi, out),
            )?;
            let (critic, actor) = self.learn(&batch, &bounds)?;
            for i in 0..agents {
                stats.critic_loss[i] += critic[i];
                stats.actor_loss[i] += actor[i];
            }
            stats.updates += 1;
        }
        let k = stats.updates as f64;
        stats.critic_loss.iter_mut().chain(stats.actor_loss.iter_mut()).for_each(|l| *l /= k);
        soft_update(&mut self.actor_targets, &self.actors, self.config.polyak);
        soft_update(&mut self.critic_targets, &self.critics, self.config.polyak);
        Ok(stats)
    }

    fn save_state(&self, _include_storage: bool) -> Result<Vec<u8>, IddpgError> {
        let flats = |m: &StackedMlp, widths: (&[usize], &[usize])| {
            m.to_flats(
                &StackedMlpConfig::new(widths.0.to_vec(), self.config.hidden, self.config.layers, widths.1.to_vec())
                    .layout(),
            )
        };
        let critic_in = vec![self.in_max + self.act_max; self.inputs.len()];
        let ones = vec![1; self.inputs.len()];
        let state = SavedState {
            nets: [
                flats(&self.actors, (&self.inputs, &self.actions))?,
                flats(&self.actor_targets, (&self.inputs, &self.actions))?,
                flats(&self.critics, (&critic_in, &ones))?,
                flats(&self.critic_targets, (&critic_in, &ones))?,
            ],
            norms: self.norms.clone(),
            rng: self.rng.clone(),
        };
        serde_json::to_vec(&state).map_err(|e| IddpgError::State(e.to_string()))
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), IddpgError> {
        let state: SavedState = serde_json::from_slice(bytes).map_err(|e| IddpgError::State(e.to_string()))?;
        if state.norms.len() != self.norms.len() || state.norms.iter().zip(&self.inputs).any(|(n, &d)| n.dim() != d) {
            return Err(IddpgError::State("saved for other agents or input widths".into()));
        }
        let layout = |i: &[usize], o: &[usize]| {
            StackedMlpConfig::new(i.to_vec(), self.config.hidden, self.config.layers, o.to_vec()).layout()
        };
        let critic_in = vec![self.in_max + self.act_max; self.inputs.len()];
        let (actor, critic) = (layout(&self.inputs, &self.actions), layout(&critic_in, &vec![1; self.inputs.len()]));
        let [a, at, c, ct] = state.nets;
        self.actors = self.actors.with_flats(&actor, &a);
        self.actor_targets = self.actor_targets.with_flats(&actor, &at);
        self.critics = self.critics.with_flats(&critic, &c);
        self.critic_targets = self.critic_targets.with_flats(&critic, &ct);
        self.norms = state.norms;
        self.rng = state.rng;
        Ok(())
    }

    fn storage_capacity(&self) -> usize {
        self.replay.capacity_episodes()
    }

    fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), IddpgError> {
        Ok(self.replay.restore_log(total, episodes)?)
    }
}

/// Trains IDDPG on TeamReach (three agents of 1, 2 and 3 action values, dense
/// reward, no shadow rewards) for `epochs` epochs of 10 cycles; returns the
/// success rate on 100 held-out episodes (goal within 0.1).
///
/// # Errors
/// Errors of the environment, the trainer or IDDPG.
pub fn train_team_reach(seed: u64, epochs: usize) -> anyhow::Result<f64> {
    let env = TeamReachConfig::default().init()?;
    let spec = env.spec().clone();
    let layout = ObservationLayout::from_graph(spec.clone(), &Graph::ring(3))?;
    let config = TrainerConfig {
        seed,
        epochs,
        cycles: 10,
        episodes_per_cycle: 2,
        eval_episodes: 20,
        shadow: ShadowConfig { enabled: false, ..ShadowConfig::default() },
        ..TrainerConfig::default()
    };
    let iddpg =
        Iddpg::new(layout.clone(), config.gamma_for(spec.episode_len), IddpgConfig { seed, ..IddpgConfig::default() })?;
    let mut trainer = Trainer::new(config, env, iddpg, layout)?;
    trainer.train(|_, s| {
        println!("  epoch {}: train success {:.2}, eval success {:.2}", s.epoch, s.train_success_rate, s.success_rate);
        Ok(())
    })?;
    let seeds: Vec<u64> = (0..100).map(|i| 10_000 + i).collect();
    Ok(trainer.evaluate(&seeds, Some(0.1))?.success_rate)
}

fn main() -> anyhow::Result<()> {
    println!("IDDPG on TeamReach:");
    let success = train_team_reach(1, 12)?;
    println!("success on 100 held-out episodes: {success:.2}");
    Ok(())
}
