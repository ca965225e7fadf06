//! The hyperparameters: the networks and optimiser every algorithm shares
//! ([`NetworkConfig`]) and each algorithm's own ([`MaddpgConfig`],
//! [`Matd3Config`], [`MasacConfig`]). The discount is not here: it has one
//! owner, the trainer (`trainer.gamma`), and is passed to the learners.

use burn::config::Config;
use burn::tensor::Tensor;
use serde::{Deserialize, Serialize};

use crate::error::NnError;

fn bad<T>(key: &'static str, reason: &str) -> Result<T, NnError> {
    Err(NnError::InvalidConfig { key, reason: reason.to_owned() })
}

fn check_all(checks: &[(&'static str, bool, &str)]) -> Result<(), NnError> {
    for &(key, ok, reason) in checks {
        if !ok {
            return bad(key, reason);
        }
    }
    Ok(())
}

fn in_unit(v: f64) -> bool {
    v.is_finite() && (0.0..=1.0).contains(&v)
}

fn nonneg(v: f64) -> bool {
    v.is_finite() && v >= 0.0
}

/// The networks, optimisers and input normalisers of every agent; defaults
/// are HER baselines' (docs/design.md 3.10): 3 x 256 hidden, Adam with learning
/// rates 1e-3, inputs normalised and clipped to +-5.
///
/// ```
/// use fmsr_nn::NetworkConfig;
/// let config = NetworkConfig::new().with_hidden(64).with_seed(7);
/// assert_eq!((config.hidden, config.layers, config.seed), (64, 3, 7));
/// assert!(config.validate().is_ok());
/// assert!(NetworkConfig::new().with_layers(0).validate().is_err());
/// ```
#[derive(Config, Debug, PartialEq)]
pub struct NetworkConfig {
    /// Width of every hidden layer.
    #[config(default = 256)]
    pub hidden: usize,
    /// Number of hidden layers (>= 1). The actor is input layer -> `layers - 1`
    /// trunk layers (hidden -> hidden, the part information sharing mixes) ->
    /// head; the critic is `layers` hidden layers -> 1.
    #[config(default = 3)]
    pub layers: usize,
    /// Adam learning rate of the actors.
    #[config(default = 1e-3)]
    pub lr_actor: f64,
    /// Adam learning rate of the critics.
    #[config(default = 1e-3)]
    pub lr_critic: f64,
    /// Adam's `beta_1`.
    #[config(default = 0.9)]
    pub adam_beta1: f64,
    /// Adam's `beta_2`.
    #[config(default = 0.999)]
    pub adam_beta2: f64,
    /// Adam's `epsilon` (1e-8 as TensorFlow and HER baselines).
    #[config(default = 1e-8)]
    pub adam_epsilon: f64,
    /// Normalised inputs are clipped to `[-clip_obs, clip_obs]`.
    #[config(default = 5.0)]
    pub clip_obs: f64,
    /// Smallest standard deviation of the normalisers: `std = max(sqrt(var), norm_eps)`.
    #[config(default = 0.01)]
    pub norm_eps: f64,
    /// Seed of the weight initialisation, exploration noise and replay sampling.
    #[config(default = 0)]
    pub seed: u64,
    /// OS threads over which the agent groups' updates are split (1 =
    /// sequential); with one group (`stacking = "all"`) one thread. Results do
    /// not depend on it.
    #[config(default = 2)]
    pub threads: usize,
    /// How the agents' networks are stacked into batched modules.
    #[config(default = "Stacking::Auto")]
    pub stacking: Stacking,
    /// Which parts of the critics the agents hold once for all (default: none, the paper's MAGCLA).
    #[config(default = "CriticTying::PerAgent")]
    pub critic: CriticTying,
    /// The bounds every critic's target `y_i` is clipped to (`clip_return`;
    /// default: each agent's reward bounds over `1 - gamma`).
    #[config(default = "TargetClip::RewardBounds")]
    pub target_clip: TargetClip,
    /// Which rows the input normalisers' statistics are taken from (default:
    /// every sampled training batch).
    #[config(default = "NormalizerStats::SampledBatches")]
    pub normalizer_stats: NormalizerStats,
    /// The critics' loss on their TD error (default: squared, eq. 7).
    #[config(default = "CriticLoss::Squared")]
    pub critic_loss: CriticLoss,
    /// Every gradient element of the actors and critics is clipped to
    /// `[-grad_clip_value, grad_clip_value]` before the Adam step; 0 (the
    /// default) clips nothing. Element-wise, so stacked agents stay independent.
    #[config(default = 0.0)]
    pub grad_clip_value: f64,
    /// Each agent's gradient of its actor, and of its critics together, is
    /// scaled so that its L2 norm over the whole network is at most
    /// `grad_clip_norm` before the Adam step (after worker averaging and
    /// gradient sharing), as PyTorch's `clip_grad_norm_` on one agent's
    /// network; 0 (the default) clips nothing. One agent's gradient never
    /// scales another's.
    #[config(default = 0.0)]
    pub grad_clip_norm: f64,
}

/// The critics' loss on the TD error `d = Q_i(x, g, a) - y_i`, averaged over the batch.
///
/// ```text
/// squared   d^2                                        (default; eq. 7, HER baselines)
/// huber     d^2 / 2 where |d| <= 1, |d| - 1/2 beyond    (smooth L1: large errors weigh linearly)
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CriticLoss {
    /// The squared TD error (default).
    #[default]
    Squared,
    /// The Huber loss with threshold 1.
    Huber,
}

/// A critic loss on the TD error: maps `d = Q - y` (`[agents, rows, 1]`, one
/// critic of one group) to the per-element loss, which the learner averages
/// over the rows and sums over the critics. [`CriticLoss`] is one; a rule of
/// a user's crate passes its own (any `Fn(Tensor<3>) -> Tensor<3> + Sync`) to
/// [`crate::Learner::critic_step_with`].
///
/// ```
/// use fmsr_nn::burn::tensor::Tensor;
/// use fmsr_nn::{CriticLoss, TdLoss};
/// let d = Tensor::<3>::from_floats([[[-3.0], [0.5]]], &Default::default());
/// let l: Vec<f32> = CriticLoss::Huber.loss(d.clone()).into_data().try_to_vec::<f32>().unwrap();
/// assert_eq!(l, [2.5, 0.125]);
/// // A loss of one's own: the absolute error.
/// let abs = |d: Tensor<3>| d.abs();
/// let l: Vec<f32> = abs.loss(d).into_data().try_to_vec::<f32>().unwrap();
/// assert_eq!(l, [3.0, 0.5]);
/// ```
pub trait TdLoss: Sync {
    /// The per-element loss of the TD errors `d`, of `d`'s shape.
    fn loss(&self, d: Tensor<3>) -> Tensor<3>;
}

impl TdLoss for CriticLoss {
    fn loss(&self, d: Tensor<3>) -> Tensor<3> {
        match self {
            Self::Squared => d.square(),
            Self::Huber => {
                let abs = d.clone().abs();
                let linear = abs.clone().sub_scalar(0.5);
                linear.mask_where(abs.lower_equal_elem(1.0), d.square().mul_scalar(0.5))
            }
        }
    }
}

impl<F: Fn(Tensor<3>) -> Tensor<3> + Sync> TdLoss for F {
    fn loss(&self, d: Tensor<3>) -> Tensor<3> {
        self(d)
    }
}

/// The rows from which the input normalisers' running mean and variance are
/// taken.
///
/// ```text
/// sampled_batches   every training batch, as sampled (HER-relabelled), before the step that reads it (default)
/// stored_episodes   T rows per stored episode, sampled from it with HER relabelling, when it is stored
/// ```
///
/// HER baselines (`her/ddpg.py`, `store_episode`) do the second: each batch
/// of new episodes adds as many relabelled transitions, drawn from those
/// episodes alone, as they hold. Sampled batches draw from the whole buffer,
/// so there an episode enters the statistics as often as it is sampled,
/// older ones more than newer ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum NormalizerStats {
    /// Every sampled training batch (default).
    #[default]
    SampledBatches,
    /// `T` relabelled transitions of each episode when it is stored (HER baselines', the paper's stack).
    StoredEpisodes,
}

/// The bounds of the critics' targets `y_i = r_i + gamma Q'_i(...)` (eq. 7).
///
/// ```text
/// reward_bounds   [lo_i, hi_i] / (1 - gamma)   each agent's per-step reward bounds (default)
/// her_baselines   [-1 / (1 - gamma), 0]        every agent, whatever its reward
/// ```
///
/// HER baselines (`her/experiment/config.py`, `clip_pos_returns = True`,
/// `clip_return = 1 / (1 - gamma)`; `her/ddpg.py` clips every target to
/// `(-clip_return, 0)`), whose hyperparameters the paper takes: with T = 100
/// and gamma = 0.99 that is `[-100, 0]`. Its ceiling of 0 cuts every positive
/// value a shadow reward adds, so under it the shadow reward can only lower a
/// critic's values; `reward_bounds` lets an agent whose reward can be
/// positive (`alpha z_k > 0`) learn positive values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum TargetClip {
    /// Each agent's per-step reward bounds over `1 - gamma` (default).
    #[default]
    RewardBounds,
    /// HER baselines': `[-1 / (1 - gamma), 0]` for every agent (the paper's stack).
    HerBaselines,
}

impl TargetClip {
    /// Each agent's target bounds from its per-step reward bounds `reward`
    /// and the discount.
    ///
    /// ```
    /// use fmsr_nn::TargetClip;
    /// let reward = [(-3.0, 0.0), (-3.0, 2.0)];
    /// let bounds = TargetClip::RewardBounds.bounds(&reward, 0.99);
    /// assert!((bounds[1].1 - 200.0).abs() < 1e-3);
    /// let her = TargetClip::HerBaselines.bounds(&reward, 0.99);
    /// assert!(her.iter().all(|&(lo, hi)| (lo + 100.0).abs() < 1e-3 && hi == 0.0));
    /// ```
    #[must_use]
    pub fn bounds(self, reward: &[(f64, f64)], gamma: f64) -> Vec<(f32, f32)> {
        let scale = 1.0 / (1.0 - gamma);
        match self {
            Self::RewardBounds => reward.iter().map(|&(lo, hi)| ((lo * scale) as f32, (hi * scale) as f32)).collect(),
            Self::HerBaselines => vec![(-scale as f32, 0.0); reward.len()],
        }
    }
}

/// Which parts of the critics the agents hold once for all of them (tied
/// weights): an ablation of the paper's design, in which every agent trains
/// its own critic (MAGCLA, section III). Named so that "sharing" means only
/// information sharing (eq. 8), which mixes networks that stay the agents'
/// own; it was once `CriticSharing` (still an alias).
///
/// Every critic sees the same input, the global observation, the goal and the
/// joint action, so a shared part computes one value for all agents:
///
/// ```text
/// per_agent      Q_i(x, g, a) = w_i . h_i(x, g, a) + b_i      six trunks, six heads (default)
/// shared_trunk   Q_i(x, g, a) = w_i . h(x, g, a) + b_i        one trunk, a head per agent
/// shared         Q_i(x, g, a) = Q(x, g, a)                    one critic for all
/// ```
///
/// A shared part is trained on the sum of the agents' TD losses (eq. 7), so
/// it takes the sum of their gradients. `shared` fits agents that share one
/// reward (Sparse): with different rewards one critic would regress on their
/// mean. Both need one stack of every agent ([`Stacking::All`], which
/// [`Stacking::Auto`] then chooses) and no information sharing of the critics
/// (a shared trunk is already at consensus).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CriticTying {
    /// Each agent its own critic (the paper's MAGCLA; default).
    #[default]
    PerAgent,
    /// One critic trunk (every hidden layer) for all agents, a head per agent.
    SharedTrunk,
    /// One critic for all agents, head included.
    Shared,
}

impl CriticTying {
    /// How many of the critic's `layers + 1` linear layers (input first) are
    /// held once for all agents.
    ///
    /// ```
    /// use fmsr_nn::CriticTying;
    /// assert_eq!(CriticTying::PerAgent.shared_layers(3), 0);
    /// assert_eq!(CriticTying::SharedTrunk.shared_layers(3), 3);
    /// assert_eq!(CriticTying::Shared.shared_layers(3), 4);
    /// ```
    #[must_use]
    pub fn shared_layers(self, layers: usize) -> usize {
        match self {
            Self::PerAgent => 0,
            Self::SharedTrunk => layers,
            Self::Shared => layers + 1,
        }
    }
}

/// What each agent's critic sees, declared by an update rule
/// ([`crate::UpdateRule::CRITIC_VIEW`]); the learner builds the critics to match.
///
/// ```text
/// global      Q_i(x, g, a_1 .. a_N)                 MADDPG / MAGCLA (the paper's; default)
/// own         Q_i(o_i, a_i)                         independent learners (IDDPG)
/// neighbours  Q_i(o_i, a_i, a_j for j in N(i))      a critic over the observation graph
/// ```
///
/// `o_i` is agent `i`'s actor input ([`fmsr_core::agent::ObservationLayout`]:
/// its observation, the goal, its neighbours' previous actions), normalised as
/// its actor's; `N(i)` its neighbours in that layout. A critic that does not
/// see the global input needs a critic per agent ([`CriticTying::PerAgent`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CriticView {
    /// The global observation, the goal and every agent's action.
    #[default]
    Global,
    /// The agent's own actor input and its own action.
    Own,
    /// The agent's own actor input, its own action and its neighbours' actions.
    Neighbours,
}

/// How the agents' networks are grouped into stacked modules
/// ([`crate::StackedMlp`]): every group's layers are `[agents of the group,
/// in, out]` tensors, one batched matmul per layer and group.
///
/// Measured on a 2-core CPU (`flex`, batch 256, six agents): a stack of all
/// six agents' critics steps 1.4x slower than six single-agent stacks, its
/// 1.5 MB layer tensors falling out of the cache that the 256 kB ones stay in
/// (Adam alone 1.7x), and one stack cannot be split over threads by agent. On
/// an accelerator the opposite holds: kernel launches, not arithmetic, set the
/// speed, and one stack keeps their number independent of the agents.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Stacking {
    /// `per_agent` on burn's CPU backend (`flex`), `all` on any other device (default).
    #[default]
    Auto,
    /// One group per agent, the groups on `threads` worker threads.
    PerAgent,
    /// One group of every agent (padded to the widest actor input and action).
    All,
}

impl NetworkConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] naming the first impossible value.
    pub fn validate(&self) -> Result<(), NnError> {
        check_all(&[
            ("networks.hidden", self.hidden > 0, "must be at least 1"),
            ("networks.layers", self.layers > 0, "must be at least 1"),
            ("networks.threads", self.threads > 0, "must be at least 1"),
            ("networks.lr_actor", nonneg(self.lr_actor), "must be finite and >= 0"),
            ("networks.lr_critic", nonneg(self.lr_critic), "must be finite and >= 0"),
            ("networks.clip_obs", self.clip_obs.is_finite() && self.clip_obs > 0.0, "must be finite and > 0"),
            ("networks.norm_eps", self.norm_eps.is_finite() && self.norm_eps > 0.0, "must be finite and > 0"),
            ("networks.grad_clip_value", nonneg(self.grad_clip_value), "must be finite and >= 0 (0: no clipping)"),
            ("networks.grad_clip_norm", nonneg(self.grad_clip_norm), "must be finite and >= 0 (0: no clipping)"),
            ("networks.adam_beta1", (0.0..1.0).contains(&self.adam_beta1), "must lie in [0, 1)"),
            ("networks.adam_beta2", (0.0..1.0).contains(&self.adam_beta2), "must lie in [0, 1)"),
            ("networks.adam_epsilon", self.adam_epsilon.is_finite() && self.adam_epsilon > 0.0, "must be > 0"),
            (
                "networks.critic",
                self.critic == CriticTying::PerAgent || self.stacking != Stacking::PerAgent,
                "shared critics need the agents in one stack: set networks.stacking to \"all\" or \"auto\"",
            ),
        ])
    }
}

/// Which actions of the other agents enter agent `i`'s actor loss
/// `Q_i(x, g, a_1 .. mu_i(o_i) .. a_N)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Teammates {
    /// The joint action stored in the replay buffer (HER baselines' and
    /// MADDPG's choice; default). Up to `random_eps` of them are random.
    ///
    /// Kept as the default by measurement: on the block task (Dense+FMSR+IS,
    /// 220k env steps, one seed) [`Teammates::Current`] learned no faster and
    /// cost more per update (the project's `docs/notebook/results.md`).
    #[default]
    Replay,
    /// The teammates' current deterministic policies at the sampled
    /// observations, without gradient.
    Current,
}

/// MADDPG (HER baselines' DDPG per agent): deterministic actors, one critic
/// each, exploration by Gaussian noise and random joint actions.
///
/// ```
/// use fmsr_nn::MaddpgConfig;
/// assert!(MaddpgConfig::new().validate().is_ok());
/// assert!(MaddpgConfig::new().with_polyak(1.5).validate().is_err());
/// ```
#[derive(Config, Debug, PartialEq)]
pub struct MaddpgConfig {
    /// Which teammates' actions enter the actor loss.
    #[config(default = "Teammates::Replay")]
    pub teammates: Teammates,
    /// Polyak coefficient of the target networks, which move once per cycle:
    /// `theta' <- polyak * theta' + (1 - polyak) * theta` (eq. 9).
    #[config(default = 0.95)]
    pub polyak: f64,
    /// Weight of the action L2 penalty `mean(mu(s)^2)` in the actor loss.
    #[config(default = 1.0)]
    pub action_l2: f64,
    /// Std of the Gaussian exploration noise on actions in `[-1, 1]`.
    #[config(default = 0.2)]
    pub noise_eps: f64,
    /// Probability of a uniformly random joint action while exploring.
    #[config(default = 0.3)]
    pub random_eps: f64,
}

impl MaddpgConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] naming the first impossible value.
    pub fn validate(&self) -> Result<(), NnError> {
        check_all(&[
            ("maddpg.polyak", in_unit(self.polyak), "must lie in [0, 1]"),
            ("maddpg.action_l2", nonneg(self.action_l2), "must be finite and >= 0"),
            ("maddpg.noise_eps", nonneg(self.noise_eps), "must be finite and >= 0"),
            ("maddpg.random_eps", in_unit(self.random_eps), "must lie in [0, 1]"),
        ])
    }
}

/// MATD3 (TD3 per agent, Fujimoto et al. 2018): twin critics with the
/// smaller target, target policy smoothing and delayed actor updates.
///
/// ```
/// use fmsr_nn::Matd3Config;
/// assert_eq!(Matd3Config::new().policy_delay, 2);
/// assert!(Matd3Config::new().with_policy_delay(0).validate().is_err());
/// ```
#[derive(Config, Debug, PartialEq)]
pub struct Matd3Config {
    /// Which teammates' actions enter the actor loss.
    #[config(default = "Teammates::Replay")]
    pub teammates: Teammates,
    /// Polyak coefficient of the target networks, which move once per cycle.
    #[config(default = 0.95)]
    pub polyak: f64,
    /// Weight of the action L2 penalty in the actor loss.
    #[config(default = 1.0)]
    pub action_l2: f64,
    /// Std of the Gaussian exploration noise.
    #[config(default = 0.2)]
    pub noise_eps: f64,
    /// Probability of a uniformly random joint action while exploring.
    #[config(default = 0.3)]
    pub random_eps: f64,
    /// Std of the smoothing noise on target actions.
    #[config(default = 0.2)]
    pub target_noise: f64,
    /// The smoothing noise is clipped to `[-target_noise_clip, target_noise_clip]`.
    #[config(default = 0.5)]
    pub target_noise_clip: f64,
    /// Actors (and their sharing) update once every `policy_delay` critic updates.
    #[config(default = 2)]
    pub policy_delay: usize,
}

impl Matd3Config {
    /// Checks every value.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] naming the first impossible value.
    pub fn validate(&self) -> Result<(), NnError> {
        check_all(&[
            ("matd3.polyak", in_unit(self.polyak), "must lie in [0, 1]"),
            ("matd3.action_l2", nonneg(self.action_l2), "must be finite and >= 0"),
            ("matd3.noise_eps", nonneg(self.noise_eps), "must be finite and >= 0"),
            ("matd3.random_eps", in_unit(self.random_eps), "must lie in [0, 1]"),
            ("matd3.target_noise", nonneg(self.target_noise), "must be finite and >= 0"),
            ("matd3.target_noise_clip", nonneg(self.target_noise_clip), "must be finite and >= 0"),
            ("matd3.policy_delay", self.policy_delay > 0, "must be at least 1"),
        ])
    }
}

/// MASAC (soft actor-critic per agent, Haarnoja et al. 2018): tanh-Gaussian
/// actors, twin critics, and an entropy temperature tuned automatically
/// towards a target entropy.
///
/// ```
/// use fmsr_nn::MasacConfig;
/// assert!(MasacConfig::new().validate().is_ok());
/// assert!(MasacConfig::new().with_initial_temperature(0.0).validate().is_err());
/// ```
#[derive(Config, Debug, PartialEq)]
pub struct MasacConfig {
    /// Which teammates' actions enter the actor loss.
    #[config(default = "Teammates::Replay")]
    pub teammates: Teammates,
    /// Polyak coefficient of the target critics, which move once per cycle.
    #[config(default = 0.95)]
    pub polyak: f64,
    /// Initial entropy temperature `alpha_i` of every agent.
    #[config(default = 0.05)]
    pub initial_temperature: f64,
    /// Adam learning rate of `log alpha_i`.
    #[config(default = 1e-3)]
    pub lr_temperature: f64,
    /// Target entropy per action dimension; agent `i`'s target is this times
    /// its action dimension (the usual `-dim(A_i)` with the default -1).
    #[config(default = -1.0)]
    pub target_entropy_per_dim: f64,
    /// Smallest log standard deviation of the Gaussian.
    #[config(default = -5.0)]
    pub log_std_min: f64,
    /// Largest log standard deviation of the Gaussian.
    #[config(default = 2.0)]
    pub log_std_max: f64,
    /// Probability of a uniformly random joint action while exploring (HER's
    /// extra exploration; 0 leaves exploration to the policy's entropy).
    #[config(default = 0.0)]
    pub random_eps: f64,
}

impl MasacConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] naming the first impossible value.
    pub fn validate(&self) -> Result<(), NnError> {
        check_all(&[
            ("masac.polyak", in_unit(self.polyak), "must lie in [0, 1]"),
            (
                "masac.initial_temperature",
                self.initial_temperature.is_finite() && self.initial_temperature > 0.0,
                "must be finite and > 0",
            ),
            ("masac.lr_temperature", nonneg(self.lr_temperature), "must be finite and >= 0"),
            ("masac.target_entropy_per_dim", self.target_entropy_per_dim.is_finite(), "must be finite"),
            (
                "masac.log_std_max",
                self.log_std_min.is_finite() && self.log_std_max.is_finite() && self.log_std_min < self.log_std_max,
                "must be finite and above log_std_min",
            ),
            ("masac.random_eps", in_unit(self.random_eps), "must lie in [0, 1]"),
        ])
    }
}
