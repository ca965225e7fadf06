//! Estimates of the discounted state-action occupancy measure of the stability
//! features (paper eq. 1, docs/design.md 3.3).
//!
//! For a feature `phi_k(s, a)` in `[0, 1]` and one episode `s_0, a_0, ..., s_{T-1}, a_{T-1}`,
//!
//! ```text
//! lambda_k = (1 - gamma) * sum_{t=0}^{T-1} gamma^t * phi_k(s_t, a_t)
//! ```
//!
//! is the (normalised) discounted occupancy of the set of state-action pairs the
//! feature indicates. It lies in `[0, 1 - gamma^T]`. The estimate averages it over
//! the recent episodes of the current policy, by an exponential moving average or
//! over a window of episodes.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::error::CoreError;

/// Turns recorded feature trajectories into an estimate of the discounted
/// occupancy `lambda_k` of each feature.
pub trait OccupancyEstimator {
    /// Records one episode: `features[t][k] = phi_k(s_t, a_t)`.
    fn observe_episode(&mut self, features: &[Vec<f32>]) -> Result<(), CoreError>;

    /// The current estimate `lambda_k`, one value per feature.
    fn estimate(&self) -> &[f64];
}

/// The discounted occupancy of one episode's features (eq. 1):
/// `lambda_k = (1 - gamma) * sum_t gamma^t * phi_k(s_t, a_t)`.
///
/// ```
/// use fmsr_core::shadow::occupancy::episode_occupancy;
/// // Two steps, one feature on at t = 1 only, gamma = 0.5: (1 - 0.5) * 0.5 = 0.25.
/// let lambda = episode_occupancy(&[vec![0.0], vec![1.0]], 1, 0.5).unwrap();
/// assert_eq!(lambda, vec![0.25]);
/// ```
pub fn episode_occupancy(features: &[Vec<f32>], num_features: usize, gamma: f64) -> Result<Vec<f64>, CoreError> {
    let mut lambda = vec![0.0; num_features];
    let mut discount = 1.0;
    for (step, phi) in features.iter().enumerate() {
        if phi.len() != num_features {
            return Err(CoreError::Dimension { what: "feature vector", expected: num_features, found: phi.len() });
        }
        for (feature, (&value, acc)) in phi.iter().zip(lambda.iter_mut()).enumerate() {
            if !(0.0..=1.0).contains(&value) {
                return Err(CoreError::FeatureRange { feature, step, value });
            }
            *acc += discount * f64::from(value);
        }
        discount *= gamma;
    }
    for acc in &mut lambda {
        *acc *= 1.0 - gamma;
    }
    Ok(lambda)
}

/// How [`DiscountedOccupancy`] averages over episodes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Averaging {
    /// `lambda <- (1 - beta) * lambda + beta * lambda_episode`; the first episode sets it.
    Ema {
        /// Weight of the newest episode, in `(0, 1]`.
        beta: f64,
    },
    /// The mean over the last `episodes` episodes.
    Window {
        /// Number of episodes, at least 1.
        episodes: usize,
    },
}

impl Default for Averaging {
    fn default() -> Self {
        Averaging::Window { episodes: 50 }
    }
}

/// The discounted occupancy estimator of docs/design.md 3.3.
///
/// Before any episode is observed the estimate is 0 for every feature.
///
/// ```
/// use fmsr_core::shadow::occupancy::{Averaging, DiscountedOccupancy, OccupancyEstimator};
/// let mut occ = DiscountedOccupancy::new(1, 0.5, Averaging::Window { episodes: 2 }).unwrap();
/// occ.observe_episode(&[vec![1.0], vec![1.0]]).unwrap(); // 0.5 * (1 + 0.5) = 0.75
/// occ.observe_episode(&[vec![0.0], vec![0.0]]).unwrap(); // 0
/// assert_eq!(occ.estimate(), &[0.375]);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiscountedOccupancy {
    gamma: f64,
    averaging: Averaging,
    lambda: Vec<f64>,
    window: VecDeque<Vec<f64>>,
    episodes_seen: u64,
}

impl DiscountedOccupancy {
    /// A new estimator of `num_features` features with discount `gamma` in `[0, 1)`.
    pub fn new(num_features: usize, gamma: f64, averaging: Averaging) -> Result<Self, CoreError> {
        if !(0.0..1.0).contains(&gamma) {
            return Err(CoreError::InvalidConfig { key: "gamma".into(), reason: format!("{gamma} is not in [0, 1)") });
        }
        match averaging {
            Averaging::Ema { beta } if !(beta > 0.0 && beta <= 1.0) => {
                return Err(CoreError::InvalidConfig {
                    key: "occupancy.beta".into(),
                    reason: format!("{beta} is not in (0, 1]"),
                });
            }
            Averaging::Window { episodes: 0 } => {
                return Err(CoreError::InvalidConfig {
                    key: "occupancy.episodes".into(),
                    reason: "must be at least 1".into(),
                });
            }
            _ => {}
        }
        Ok(Self { gamma, averaging, lambda: vec![0.0; num_features], window: VecDeque::new(), episodes_seen: 0 })
    }

    /// Number of episodes observed so far.
    #[must_use]
    pub fn episodes_seen(&self) -> u64 {
        self.episodes_seen
    }

    /// The discount factor.
    #[must_use]
    pub fn gamma(&self) -> f64 {
        self.gamma
    }
}

impl OccupancyEstimator for DiscountedOccupancy {
    fn observe_episode(&mut self, features: &[Vec<f32>]) -> Result<(), CoreError> {
        let episode = episode_occupancy(features, self.lambda.len(), self.gamma)?;
        match self.averaging {
            Averaging::Ema { beta } => {
                let beta = if self.episodes_seen == 0 { 1.0 } else { beta };
                for (l, e) in self.lambda.iter_mut().zip(&episode) {
                    *l = (1.0 - beta) * *l + beta * e;
                }
            }
            Averaging::Window { episodes } => {
                self.window.push_back(episode);
                while self.window.len() > episodes {
                    self.window.pop_front();
                }
                let n = self.window.len() as f64;
                for (k, l) in self.lambda.iter_mut().enumerate() {
                    *l = self.window.iter().map(|e| e[k]).sum::<f64>() / n;
                }
            }
        }
        self.episodes_seen += 1;
        Ok(())
    }

    fn estimate(&self) -> &[f64] {
        &self.lambda
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn occupancy_of_a_known_sequence() {
        // gamma = 0.9, phi = [1, 0, 1]: (0.1) * (1 + 0 + 0.81) = 0.181
        let lambda = episode_occupancy(&[vec![1.0, 0.5], vec![0.0, 0.5], vec![1.0, 0.5]], 2, 0.9).unwrap();
        assert!((lambda[0] - 0.181).abs() < 1e-12);
        // constant 0.5: 0.1 * 0.5 * (1 + 0.9 + 0.81) = 0.1355
        assert!((lambda[1] - 0.1355).abs() < 1e-12);
    }

    #[test]
    fn always_on_feature_reaches_one_minus_gamma_to_the_t() {
        let gamma: f64 = 0.99;
        let lambda = episode_occupancy(&vec![vec![1.0]; 100], 1, gamma).unwrap();
        assert!((lambda[0] - (1.0 - gamma.powi(100))).abs() < 1e-12);
    }

    #[test]
    fn rejects_features_out_of_range_and_wrong_length() {
        assert!(matches!(
            episode_occupancy(&[vec![1.5]], 1, 0.9),
            Err(CoreError::FeatureRange { feature: 0, step: 0, .. })
        ));
        assert!(matches!(
            episode_occupancy(&[vec![0.5, 0.5]], 1, 0.9),
            Err(CoreError::Dimension { expected: 1, found: 2, .. })
        ));
        assert!(DiscountedOccupancy::new(1, 1.0, Averaging::default()).is_err());
        assert!(DiscountedOccupancy::new(1, 0.9, Averaging::Ema { beta: 0.0 }).is_err());
        assert!(DiscountedOccupancy::new(1, 0.9, Averaging::Window { episodes: 0 }).is_err());
    }

    #[test]
    fn ema_starts_at_first_episode_then_blends() {
        let mut occ = DiscountedOccupancy::new(1, 0.5, Averaging::Ema { beta: 0.25 }).unwrap();
        assert_eq!(occ.estimate(), &[0.0]);
        occ.observe_episode(&[vec![1.0]]).unwrap(); // 0.5
        assert_eq!(occ.estimate(), &[0.5]);
        occ.observe_episode(&[vec![0.0]]).unwrap(); // 0.75 * 0.5
        assert_eq!(occ.estimate(), &[0.375]);
    }

    /// Random episodes: `T` steps of `k` features in `[0, 1]`.
    fn episodes() -> impl proptest::strategy::Strategy<Value = Vec<Vec<Vec<f32>>>> {
        use proptest::prelude::*;
        (1usize..4, 1usize..30).prop_flat_map(|(k, t)| {
            prop::collection::vec(prop::collection::vec(prop::collection::vec(0.0f32..=1.0, k), t), 1..12)
        })
    }

    proptest::proptest! {
        // Guards eq. 1's range and the estimators' averaging on random
        // episodes: every episode's occupancy lies in [0, 1 - gamma^T] and is
        // the discounted sum written out; the window estimate is the mean of
        // the last min(seen, W) episodes (the fixed cases above only look at
        // a full window, so dividing by W before it fills went unseen); the
        // EMA estimate starts at the first episode and then blends with beta.
        #[test]
        fn estimates_average_the_episode_occupancies(
            eps in episodes(),
            gamma in 0.0f64..0.999,
            window in 1usize..6,
            beta in 0.01f64..=1.0,
        ) {
            let k = eps[0][0].len();
            let t = eps[0].len();
            let mut win = DiscountedOccupancy::new(k, gamma, Averaging::Window { episodes: window }).unwrap();
            let mut ema = DiscountedOccupancy::new(k, gamma, Averaging::Ema { beta }).unwrap();
            let mut seen: Vec<Vec<f64>> = Vec::new();
            let mut blended = vec![0.0; k];
            for ep in &eps {
                let lambda = episode_occupancy(ep, k, gamma).unwrap();
                for (f, &l) in lambda.iter().enumerate() {
                    let written: f64 = ep.iter().enumerate().map(|(s, phi)| gamma.powi(s as i32) * f64::from(phi[f])).sum();
                    proptest::prop_assert!((l - (1.0 - gamma) * written).abs() < 1e-12, "feature {}: {} vs {}", f, l, (1.0 - gamma) * written);
                    proptest::prop_assert!((0.0..=1.0 - gamma.powi(t as i32) + 1e-12).contains(&l), "{} outside [0, 1 - gamma^T]", l);
                }
                let b = if seen.is_empty() { 1.0 } else { beta };
                blended.iter_mut().zip(&lambda).for_each(|(x, l)| *x = (1.0 - b) * *x + b * l);
                seen.push(lambda);
                win.observe_episode(ep).unwrap();
                ema.observe_episode(ep).unwrap();
                let recent = &seen[seen.len().saturating_sub(window)..];
                for f in 0..k {
                    let mean = recent.iter().map(|l| l[f]).sum::<f64>() / recent.len() as f64;
                    proptest::prop_assert!((win.estimate()[f] - mean).abs() < 1e-12, "window: {} vs {}", win.estimate()[f], mean);
                    proptest::prop_assert!((ema.estimate()[f] - blended[f]).abs() < 1e-12, "ema: {} vs {}", ema.estimate()[f], blended[f]);
                }
            }
            proptest::prop_assert_eq!(win.episodes_seen(), eps.len() as u64);
        }
    }

    #[test]
    fn window_forgets_old_episodes() {
        let mut occ = DiscountedOccupancy::new(1, 0.5, Averaging::Window { episodes: 1 }).unwrap();
        occ.observe_episode(&[vec![1.0]]).unwrap();
        occ.observe_episode(&[vec![0.0]]).unwrap();
        assert_eq!(occ.estimate(), &[0.0]);
        assert_eq!(occ.episodes_seen(), 2);
    }
}
