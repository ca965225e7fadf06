//! The hyperparameters of the DDPG learner.

use burn::config::Config;

use crate::error::NnError;

/// Hyperparameters of [`crate::DdpgLearner`]; the defaults are those of HER
/// baselines and DESIGN.md 3.10 (3 x 256 hidden, learning rates 1e-3, polyak
/// 0.95, action L2 1.0, gamma 1 - 1/T with T = 100, normalised inputs clipped
/// to +-5).
///
/// ```
/// use fmsr_nn::DdpgConfig;
/// let config = DdpgConfig::new().with_hidden(64).with_seed(7);
/// assert_eq!((config.hidden, config.layers, config.seed), (64, 3, 7));
/// assert!(config.validate().is_ok());
/// assert!(DdpgConfig::new().with_polyak(1.5).validate().is_err());
/// ```
#[derive(Config, Debug, PartialEq)]
pub struct DdpgConfig {
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
    /// Polyak coefficient of the target networks: `theta' <- polyak * theta' + (1 - polyak) * theta`.
    #[config(default = 0.95)]
    pub polyak: f64,
    /// Weight of the action L2 penalty `mean(mu(s)^2)` in the actor loss.
    #[config(default = 1.0)]
    pub action_l2: f64,
    /// Discount factor of the critic target.
    #[config(default = 0.99)]
    pub gamma: f64,
    /// Normalised inputs are clipped to `[-clip_obs, clip_obs]`.
    #[config(default = 5.0)]
    pub clip_obs: f64,
    /// Smallest standard deviation of the normalisers: `std = max(sqrt(var), norm_eps)`.
    #[config(default = 0.01)]
    pub norm_eps: f64,
    /// Adam's `beta_1`.
    #[config(default = 0.9)]
    pub adam_beta1: f64,
    /// Adam's `beta_2`.
    #[config(default = 0.999)]
    pub adam_beta2: f64,
    /// Adam's `epsilon` (1e-8 as TensorFlow and HER baselines' MPI Adam).
    #[config(default = 1e-8)]
    pub adam_epsilon: f64,
    /// Seed of the weight initialisation.
    #[config(default = 0)]
    pub seed: u64,
    /// OS threads over which the agents' updates are split (1 = sequential).
    /// Results do not depend on it.
    #[config(default = 2)]
    pub threads: usize,
}

impl DdpgConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] naming the first impossible value.
    pub fn validate(&self) -> Result<(), NnError> {
        let bad = |key, reason: &str| Err(NnError::InvalidConfig { key, reason: reason.to_owned() });
        if self.hidden == 0 {
            return bad("hidden", "must be at least 1");
        }
        if self.layers == 0 {
            return bad("layers", "must be at least 1");
        }
        if self.threads == 0 {
            return bad("threads", "must be at least 1");
        }
        let in_unit = |v: f64| v.is_finite() && (0.0..=1.0).contains(&v);
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        let checks: [(&'static str, bool, &str); 10] = [
            ("lr_actor", nonneg(self.lr_actor), "must be finite and >= 0"),
            ("lr_critic", nonneg(self.lr_critic), "must be finite and >= 0"),
            ("polyak", in_unit(self.polyak), "must lie in [0, 1]"),
            ("action_l2", nonneg(self.action_l2), "must be finite and >= 0"),
            ("gamma", in_unit(self.gamma), "must lie in [0, 1]"),
            ("clip_obs", self.clip_obs.is_finite() && self.clip_obs > 0.0, "must be finite and > 0"),
            ("norm_eps", self.norm_eps.is_finite() && self.norm_eps > 0.0, "must be finite and > 0"),
            ("adam_beta1", self.adam_beta1.is_finite() && (0.0..1.0).contains(&self.adam_beta1), "must lie in [0, 1)"),
            ("adam_beta2", self.adam_beta2.is_finite() && (0.0..1.0).contains(&self.adam_beta2), "must lie in [0, 1)"),
            ("adam_epsilon", self.adam_epsilon.is_finite() && self.adam_epsilon > 0.0, "must be finite and > 0"),
        ];
        for (key, ok, reason) in checks {
            if !ok {
                return bad(key, reason);
            }
        }
        Ok(())
    }
}
