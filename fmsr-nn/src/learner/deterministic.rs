//! What the deterministic-actor rules (MADDPG, MATD3) share: the target
//! actors' next actions, the deterministic policy-gradient step and acting
//! with HER baselines' exploration ([`crate::explore`]).

use burn::tensor::Tensor;
use burn::tensor::activation::tanh;
use fmsr_core::policy::{ActMode, PolicyOutput};

use super::{BatchTensors, Learner};
use crate::config::Teammates;
use crate::error::NnError;
use crate::explore;

/// `tanh(mu'_j(o'_j))` of every agent's target actor, agent-major `[n, action_dim]`.
pub(crate) fn target_actions(l: &mut Learner, b: &BatchTensors) -> Result<Tensor<2>, NnError> {
    l.joint_of(|g, group| Ok(tanh(group.nets.actor_targets.forward(b.groups[g].x_next.clone()))))
}

/// The deterministic policy-gradient step of MADDPG and MATD3 (eq. 5 with
/// HER's action penalty), on each agent's first critic, a group's agents at once:
///
/// ```text
/// L_i = -mean Q_i1(x, g, a_1..mu_i(o_i)..a_N) + action_l2 * mean mu_i(o_i)^2
/// ```
pub(crate) fn actor_step(
    l: &mut Learner,
    b: &BatchTensors,
    action_l2: f64,
    teammates: Teammates,
) -> Result<Vec<f32>, NnError> {
    let current;
    let b = match teammates {
        Teammates::Replay => b,
        Teammates::Current => {
            current = l.with_current_actions(b, |head, _| tanh(head))?;
            &current
        }
    };
    l.actor_step(|g, group, critics| {
        let (joint, na) = (&group.joint, group.len());
        let mu = tanh(group.nets.actors.forward(Tensor::from_inner(b.groups[g].x_now.clone())))
            * Tensor::from_inner(joint.mask.clone());
        let q = critics.nets[0].forward(joint.with_own(mu.clone(), &b.og, &b.actions));
        let penalty = mu.square().sum_dim(2).mean_dim(1).reshape([na]) * Tensor::from_inner(joint.inv_dim.clone());
        Ok(q.mean_dim(1).reshape([na]).neg() + penalty.mul_scalar(action_l2 as f32))
    })
}

/// `tanh` of the heads, with exploration in [`ActMode::Explore`].
pub(crate) fn deterministic_act(
    l: &mut Learner,
    inputs: &[Vec<f32>],
    n: usize,
    mode: ActMode,
    noise: (f64, f64),
) -> Result<PolicyOutput, NnError> {
    let mut actions = l.heads(inputs, n)?;
    actions.iter_mut().flatten().for_each(|v| *v = v.tanh());
    if mode == ActMode::Explore {
        explore::perturb(&mut actions, n, noise.0 as f32, noise.1 as f32, &mut l.rng);
    }
    Ok(PolicyOutput::actions(actions))
}
