//! Exploration of the deterministic-actor algorithms (MADDPG, MATD3), as HER
//! baselines: Gaussian noise of std `noise_eps` on every action, clipped to
//! `[-1, 1]`, and with probability `random_eps` a uniformly random joint
//! action instead. Every draw comes from the algorithm's seeded RNG.

use rand::{Rng, RngExt};
use rand_distr::{Distribution, StandardNormal};

/// A standard normal sample as `f32`: [`rand_distr::StandardNormal`] (ziggurat).
pub(crate) fn gaussian<R: Rng + ?Sized>(rng: &mut R) -> f32 {
    StandardNormal.sample(rng)
}

/// Adds the noise to `n` rows of every agent's actions, then replaces whole
/// rows (all agents at once) by uniform random joint actions with probability `random_eps`.
pub(crate) fn perturb<R: Rng + ?Sized>(
    actions: &mut [Vec<f32>],
    n: usize,
    noise_eps: f32,
    random_eps: f32,
    rng: &mut R,
) {
    for agent in actions.iter_mut() {
        for v in agent.iter_mut() {
            *v = (*v + noise_eps * gaussian(rng)).clamp(-1.0, 1.0);
        }
    }
    randomize(actions, n, random_eps, rng);
}

/// Replaces each of the `n` rows by a uniform random joint action with probability `random_eps`.
pub(crate) fn randomize<R: Rng + ?Sized>(actions: &mut [Vec<f32>], n: usize, random_eps: f32, rng: &mut R) {
    for row in 0..n {
        if rng.random::<f32>() < random_eps {
            for agent in actions.iter_mut() {
                let d = agent.len() / n.max(1);
                for v in &mut agent[row * d..(row + 1) * d] {
                    *v = rng.random_range(-1.0..=1.0);
                }
            }
        }
    }
}
