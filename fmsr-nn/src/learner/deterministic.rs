//! What the deterministic-actor rules (MADDPG, MATD3, a user's IDDPG) share:
//! the target actors' next actions, the deterministic policy-gradient step
//! and acting with HER baselines' exploration ([`crate::explore`]).

use burn::tensor::Tensor;
use burn::tensor::activation::tanh;
use fmsr_core::policy::{ActMode, PolicyOutput};

use super::{BatchTensors, Learner};
use crate::config::Teammates;
use crate::error::NnError;
use crate::explore;

impl Learner {
    /// `tanh(mu'_j(o'_j))` of every agent's target actor at `t + 1`,
    /// agent-major `[rows, joint_width]`: the next actions of
    /// [`Learner::critic_step`].
    ///
    /// # Errors
    /// Backend errors.
    pub fn target_actions(&mut self, b: &BatchTensors) -> Result<Tensor<2>, NnError> {
        self.joint_of(|g, group| Ok(tanh(group.nets.actor_targets.forward(b.groups[g].x_next.clone()))))
    }

    /// One optimiser step of every agent's actor by the deterministic policy
    /// gradient (eq. 5 with HER's action penalty), on each agent's first critic:
    ///
    /// ```text
    /// L_i = -mean Q_i1(.., mu_i(o_i), ..) + action_l2 * mean mu_i(o_i)^2
    /// ```
    ///
    /// where the critic sees its rule's [`crate::CriticView`] with agent `i`'s
    /// own action replaced by `mu_i(o_i)`, the other agents' actions the
    /// sampled ones ([`Teammates::Replay`]) or their actors' current ones.
    /// Worker averaging and information sharing of the actors happen here.
    /// Returns each agent's loss.
    ///
    /// # Errors
    /// Backend errors.
    pub fn deterministic_actor_step(
        &mut self,
        b: &BatchTensors,
        action_l2: f64,
        teammates: Teammates,
    ) -> Result<Vec<f32>, NnError> {
        let current;
        let b = match teammates {
            Teammates::Replay => b,
            Teammates::Current => {
                current = self.with_current_actions(b, |head, _| tanh(head))?;
                &current
            }
        };
        self.actor_step(|g, group, critics| {
            let (joint, na) = (&group.joint, group.len());
            let mu = tanh(group.nets.actors.forward(Tensor::from_inner(b.groups[g].x_now.clone())))
                * Tensor::from_inner(joint.mask.clone());
            let q = critics.nets[0].forward(group.critic_input_own(mu.clone(), &b.og, &b.actions, &b.groups[g]));
            let penalty = mu.square().sum_dim(2).mean_dim(1).reshape([na]) * Tensor::from_inner(joint.inv_dim.clone());
            Ok(q.mean_dim(1).reshape([na]).neg() + penalty.mul_scalar(action_l2 as f32))
        })
    }

    /// `tanh` of the actors' heads for `n` rows of raw actor inputs per agent,
    /// with HER baselines' exploration in [`ActMode::Explore`]: Gaussian noise
    /// of std `noise_eps`, then a uniformly random action with probability
    /// `random_eps`, drawn from [`Learner::rng`].
    ///
    /// # Errors
    /// [`NnError::Dimension`] / [`NnError::NotFinite`] for inputs that do not fit, backend errors.
    pub fn deterministic_act(
        &mut self,
        inputs: &[Vec<f32>],
        n: usize,
        mode: ActMode,
        noise_eps: f64,
        random_eps: f64,
    ) -> Result<PolicyOutput, NnError> {
        let mut actions = self.heads(inputs, n)?;
        actions.iter_mut().flatten().for_each(|v| *v = v.tanh());
        if mode == ActMode::Explore {
            explore::perturb(&mut actions, n, noise_eps as f32, random_eps as f32, &mut self.rng);
        }
        Ok(PolicyOutput::actions(actions))
    }
}
