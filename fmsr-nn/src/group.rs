//! A group of agents whose networks are stacked ([`crate::Stacking`]): their
//! actors, critics, targets and optimisers as [`StackedMlp`]s, the constant
//! tensors that place their actions in the joint action, and their share of a
//! sampled batch.
//!
//! Agent `i`'s loss depends only on agent `i`'s parameters, so one backward
//! pass of the sum of a group's losses gives each agent its own gradient, as
//! separate per-agent updates would.

use std::ops::Range;

use burn::module::ParamId;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use fmsr_core::sharing::NetworkKind;

use crate::error::NnError;
use crate::net::{Critics, StackLayout, StackedMlp, StackedMlpConfig};

/// A group's online and target networks and their optimisers.
#[derive(Clone)]
pub(crate) struct Nets {
    /// Online actors, on the autodiff device.
    pub(crate) actors: StackedMlp,
    /// Target actors, on the plain device.
    pub(crate) actor_targets: StackedMlp,
    /// Online critics, on the autodiff device.
    pub(crate) critics: Critics,
    /// Target critics, on the plain device.
    pub(crate) critic_targets: Critics,
    pub(crate) actor_optim: ModuleOptimizer,
    pub(crate) critic_optim: ModuleOptimizer,
    /// Each agent's gradient norm limit before a step (0: none; [`crate::clip`]).
    pub(crate) grad_clip_norm: f32,
}

impl Nets {
    /// Every parameter id of `kind`, `(weight, bias)` per layer.
    pub(crate) fn ids(&self, kind: NetworkKind) -> Vec<(ParamId, ParamId)> {
        match kind {
            NetworkKind::Actors => self.actors.ids(),
            NetworkKind::Critics => self.critics.nets.iter().flat_map(StackedMlp::ids).collect(),
        }
    }

    /// The trunk parameter ids of `kind` (every critic's, critic by critic).
    pub(crate) fn trunk_ids(&self, kind: NetworkKind) -> Vec<(ParamId, ParamId)> {
        match kind {
            NetworkKind::Actors => self.actors.trunk_ids(),
            NetworkKind::Critics => self.critics.nets.iter().flat_map(StackedMlp::trunk_ids).collect(),
        }
    }

    /// The number of stacks of `kind` (1 for the actors, one per critic).
    pub(crate) fn copies(&self, kind: NetworkKind) -> usize {
        match kind {
            NetworkKind::Actors => 1,
            NetworkKind::Critics => self.critics.nets.len(),
        }
    }

    /// Stack `c` of `kind` (the actors, or critic `c`).
    pub(crate) fn stack_mut(&mut self, kind: NetworkKind, c: usize) -> &mut StackedMlp {
        match kind {
            NetworkKind::Actors => &mut self.actors,
            NetworkKind::Critics => &mut self.critics.nets[c],
        }
    }

    fn gradients(&self, kind: NetworkKind, loss: Tensor<1>) -> GradientsParams {
        match kind {
            NetworkKind::Actors => GradientsParams::from_grads(loss.backward(), &self.actors),
            NetworkKind::Critics => GradientsParams::from_grads(loss.backward(), &self.critics),
        }
    }

    /// One Adam step of the networks of `kind`.
    pub(crate) fn optimize(&mut self, kind: NetworkKind, lr: f64, mut grads: GradientsParams) {
        if self.grad_clip_norm > 0.0 {
            crate::clip::clip_by_agent_norm(&mut grads, &self.ids(kind), self.grad_clip_norm);
        }
        match kind {
            NetworkKind::Actors => self.actors = self.actor_optim.step(lr, self.actors.clone(), grads),
            NetworkKind::Critics => self.critics = self.critic_optim.step(lr, self.critics.clone(), grads),
        }
    }

    /// The losses `[A]` of `kind` read back, and one backward pass of their
    /// sum; with `fused` the optimiser steps at once and no gradients are returned.
    pub(crate) fn step(
        &mut self,
        kind: NetworkKind,
        loss: Tensor<1>,
        lr: f64,
        fused: bool,
    ) -> Result<(Vec<f32>, Option<GradientsParams>), NnError> {
        let values = to_vec1(loss.clone(), "loss")?;
        let grads = self.gradients(kind, loss.sum());
        if fused {
            self.optimize(kind, lr, grads);
            return Ok((values, None));
        }
        Ok((values, Some(grads)))
    }
}

/// Constant tensors that place a group's padded action blocks in the
/// agent-major joint action of all agents, on the plain device.
#[derive(Clone)]
pub(crate) struct Joint {
    /// `[A, d_max, action_dim]`: `select[i][k][off_i + k] = 1` for `k < d_i`.
    select: Tensor<3>,
    /// `[A, 1, action_dim]`: 1 on the columns of every agent but `i`.
    others: Tensor<3>,
    /// `[A, 1, d_max]`: 1 on agent `i`'s first `d_i` columns.
    pub(crate) mask: Tensor<3>,
    /// `[A]`: `1 / d_i`.
    pub(crate) inv_dim: Tensor<1>,
}

impl Joint {
    /// For agents of action widths `dims` whose blocks start at `offsets` in a
    /// joint action of `width` columns.
    pub(crate) fn new(dims: &[usize], offsets: &[usize], width: usize, device: &Device) -> Self {
        let (a, dmax) = (dims.len(), dims.iter().copied().max().unwrap_or(0));
        let mut select = vec![0.0f32; a * dmax * width];
        let mut others = vec![1.0f32; a * width];
        let mut mask = vec![0.0f32; a * dmax];
        for (i, (&d, &off)) in dims.iter().zip(offsets).enumerate() {
            for k in 0..d {
                select[(i * dmax + k) * width + off + k] = 1.0;
                others[i * width + off + k] = 0.0;
                mask[i * dmax + k] = 1.0;
            }
        }
        let inv = dims.iter().map(|&d| 1.0 / d as f32).collect::<Vec<_>>();
        Self {
            select: Tensor::from_data(TensorData::new(select, [a, dmax, width]), device),
            others: Tensor::from_data(TensorData::new(others, [a, 1, width]), device),
            mask: Tensor::from_data(TensorData::new(mask, [a, 1, dmax]), device),
            inv_dim: Tensor::from_data(TensorData::new(inv, [a]), device),
        }
    }

    /// The group's share `[n, action_dim]` of the joint action for its agents'
    /// actions `mu: [A, n, d_max]` (zero outside the group's columns).
    pub(crate) fn join(&self, mu: Tensor<3>) -> Tensor<2> {
        let [_, n, _] = mu.dims();
        let width = self.select.dims()[2];
        mu.matmul(self.select.clone()).sum_dim(0).reshape([n, width])
    }

    /// Every agent's global critic input `[A, n, obs + goal + action_dim]` on the
    /// autodiff device: `[x, g]` and the sampled joint action with agent `i`'s
    /// block replaced by its `mu_i` (`mu: [A, n, d_max]`, with gradient).
    fn with_own(&self, mu: Tensor<3>, og: &Tensor<2>, actions: &Tensor<2>) -> Tensor<3> {
        let [a, n, _] = mu.dims();
        let ogd = og.dims()[1];
        let joint = self.own_joint(mu, actions);
        let og = Tensor::from_inner(og.clone().unsqueeze_dim::<3>(0).expand([a, n, ogd]));
        Tensor::cat(vec![og, joint], 2)
    }

    /// The sampled joint action with agent `i`'s block replaced by its `mu_i`,
    /// for every agent: `[A, n, action_dim]` on the autodiff device.
    fn own_joint(&self, mu: Tensor<3>, actions: &Tensor<2>) -> Tensor<3> {
        let sampled = Tensor::from_inner(actions.clone().unsqueeze_dim::<3>(0) * self.others.clone());
        mu.matmul(Tensor::from_inner(self.select.clone())) + sampled
    }
}

/// What a group's critics see ([`crate::CriticView`]).
#[derive(Clone)]
pub(crate) enum CriticInput {
    /// `[x, g]` and the joint action: one input row for all agents.
    Global,
    /// Agent `i`'s padded actor input, then the actions it sees in the joint
    /// action's columns: `select[i]` (`[A, action_dim, width]`) places them
    /// right after its own actor input, in a critic input `width` wide.
    Local { select: Box<Tensor<3>>, width: usize },
}

impl CriticInput {
    /// For agents `agents` whose critics see the actions of the agents in
    /// `sets[i]` (own first), with actor inputs `inputs` and action widths
    /// `actions` (all agents), in a joint action of `width` columns.
    pub(crate) fn local(
        agents: Range<usize>,
        sets: &[Vec<usize>],
        inputs: &[usize],
        actions: &[usize],
        width: usize,
        device: &Device,
    ) -> Self {
        let offset = |j: usize| actions[..j].iter().sum::<usize>();
        let cols = |i: usize| inputs[i] + sets[i].iter().map(|&j| actions[j]).sum::<usize>();
        let out = agents.clone().map(cols).max().unwrap_or(0);
        let mut select = vec![0.0f32; agents.len() * width * out];
        for (k, i) in agents.clone().enumerate() {
            let mut o = inputs[i];
            for &j in &sets[i] {
                for c in 0..actions[j] {
                    select[(k * width + offset(j) + c) * out + o] = 1.0;
                    o += 1;
                }
            }
        }
        let select = Tensor::from_data(TensorData::new(select, [agents.len(), width, out]), device);
        Self::Local { select: Box::new(select), width: out }
    }
}

impl Group {
    /// Every agent's critic input for the group's padded actor inputs `x`
    /// (`[A, n, in_max]`) and joint actions `joint` (`[1, n, action_dim]`),
    /// on the plain device; `global` is the input of a global critic.
    pub(crate) fn critic_input(&self, global: &Tensor<3>, x: &Tensor<3>, joint: &Tensor<3>) -> Tensor<3> {
        match &self.critic_view {
            CriticInput::Global => global.clone(),
            CriticInput::Local { select, width } => pad(x.clone(), *width) + joint.clone().matmul(*select.clone()),
        }
    }

    /// Every agent's critic input with its own action replaced by `mu`
    /// (`[A, n, d_max]`, with gradient) on the autodiff device, for a batch's
    /// `[x, g]` rows `og`, joint actions `actions` and the group's padded
    /// actor inputs `x`.
    pub(crate) fn critic_input_own(
        &self,
        mu: Tensor<3>,
        og: &Tensor<2>,
        actions: &Tensor<2>,
        x: &GroupBatch,
    ) -> Tensor<3> {
        match &self.critic_view {
            CriticInput::Global => self.joint.with_own(mu, og, actions),
            CriticInput::Local { select, width } => {
                let joint = self.joint.own_joint(mu, actions);
                Tensor::from_inner(pad(x.x_now.clone(), *width)) + joint.matmul(Tensor::from_inner(*select.clone()))
            }
        }
    }
}

/// `x: [A, n, d]` with zero columns up to `width`.
fn pad(x: Tensor<3>, width: usize) -> Tensor<3> {
    let [a, n, d] = x.dims();
    if d >= width {
        return x;
    }
    let zeros = Tensor::zeros([a, n, width - d], &x.device());
    Tensor::cat(vec![x, zeros], 2)
}

/// A group's share of a sampled batch, on the device.
#[derive(Clone)]
pub(crate) struct GroupBatch {
    /// Its agents' normalised actor inputs at `t`, zero-padded: `[A, n, in_max]`.
    pub(crate) x_now: Tensor<3>,
    /// The same at `t + 1`.
    pub(crate) x_next: Tensor<3>,
    /// Its agents' rewards, `[A, n, 1]`.
    pub(crate) rewards: Tensor<3>,
    /// Its agents' Q-target bounds `[lo, hi] / (1 - gamma)` (`clip_return`), `[A, 1, 1]` each.
    pub(crate) lo: Tensor<3>,
    pub(crate) hi: Tensor<3>,
}

/// A group of agents `agents` (contiguous) with stacked networks.
#[derive(Clone)]
pub(crate) struct Group {
    pub(crate) agents: Range<usize>,
    pub(crate) nets: Nets,
    pub(crate) actor_layout: StackLayout,
    pub(crate) critic_layout: StackLayout,
    pub(crate) joint: Joint,
    /// What its critics see.
    pub(crate) critic_view: CriticInput,
    /// The host copy of the actors that rollouts act with, made lazily after each update phase.
    pub(crate) act_cache: Option<StackedMlp>,
}

/// What a group's networks are built from.
pub(crate) struct GroupSpec<'a> {
    /// Each agent's actor input width.
    pub(crate) inputs: &'a [usize],
    /// Each agent's action width.
    pub(crate) actions: &'a [usize],
    /// Each agent's critic input width.
    pub(crate) critic_inputs: &'a [usize],
    /// Whose actions each agent's critic sees, own first, when it does not
    /// see the global input (`None`: it does).
    pub(crate) critic_sets: Option<&'a [Vec<usize>]>,
    pub(crate) hidden: usize,
    pub(crate) layers: usize,
    pub(crate) seed: u64,
    pub(crate) critics: usize,
    /// The critics' leading layers held once for the group ([`crate::CriticTying`]).
    pub(crate) critic_shared: usize,
    pub(crate) head_mult: usize,
    /// Whether information sharing mixes the actors' / critics' trunks (they then start equal).
    pub(crate) same_trunks: (bool, bool),
    pub(crate) adam: AdamConfig,
    /// Each agent's gradient norm limit (0: none).
    pub(crate) grad_clip_norm: f64,
}

/// First parameter id of network kind `kind` (0 actors, 1 target actors,
/// `2 + 2c` critic `c`, `3 + 2c` its target) of group `g`.
fn id_base(g: usize, kind: u64) -> u64 {
    ((g as u64 + 1) << 24) | (kind << 16)
}

/// Every agent starts from the trunk of `first`, the network of agent 0 of
/// all agents, so mixing begins at consensus.
fn set_trunks(flats: &mut [Vec<f32>], layout: &StackLayout, first: &StackedMlpConfig) {
    let (flat0, shape0) = (&first.initial()[0], &first.layout().shapes[0]);
    let trunk0 = &flat0[shape0.trunk()];
    for (flat, shape) in flats.iter_mut().zip(&layout.shapes) {
        let r = shape.trunk();
        if r.len() == trunk0.len() {
            flat[r].copy_from_slice(trunk0);
        }
    }
}

impl Group {
    /// The networks of agents `agents`, each initialised as the per-agent
    /// network of the same seed: agent `i`'s actor from ChaCha8 stream `8i`,
    /// its critic `c` from `8i + 1 + 2c`. Online networks on the autodiff twin
    /// of `device`, targets on `device`.
    pub(crate) fn new(g: usize, agents: Range<usize>, spec: &GroupSpec<'_>, width: usize, device: &Device) -> Self {
        let ad_device = device.clone().autodiff();
        let r = agents.clone();
        let actor = |range: Range<usize>| {
            StackedMlpConfig::new(
                spec.inputs[range.clone()].to_vec(),
                spec.hidden,
                spec.layers,
                spec.actions[range.clone()].to_vec(),
            )
            .with_head_mult(spec.head_mult)
            .with_seed(spec.seed)
            .with_streams(range.map(|i| 8 * i as u64).collect())
        };
        let critic = |range: Range<usize>, c: usize| {
            StackedMlpConfig::new(
                spec.critic_inputs[range.clone()].to_vec(),
                spec.hidden,
                spec.layers,
                vec![1; range.len()],
            )
            .with_seed(spec.seed)
            .with_streams(range.map(|i| 8 * i as u64 + 1 + 2 * c as u64).collect())
            .with_shared_layers(spec.critic_shared)
        };
        let actor_config = actor(r.clone());
        let (actor_layout, critic_layout) = (actor_config.layout(), critic(r.clone(), 0).layout());
        let mut actor_flats = actor_config.initial();
        if spec.same_trunks.0 {
            set_trunks(&mut actor_flats, &actor_layout, &actor(0..1));
        }
        let critic_flats: Vec<Vec<Vec<f32>>> = (0..spec.critics)
            .map(|c| {
                let mut f = critic(r.clone(), c).initial();
                if spec.same_trunks.1 {
                    set_trunks(&mut f, &critic_layout, &critic(0..1, c));
                }
                f
            })
            .collect();
        let critics_on = |dev: &Device, kind: u64| Critics {
            nets: critic_flats
                .iter()
                .enumerate()
                .map(|(c, f)| StackedMlp::from_flats(&critic_layout, f, dev, id_base(g, kind + 2 * c as u64)))
                .collect(),
        };
        let nets = Nets {
            actors: StackedMlp::from_flats(&actor_layout, &actor_flats, &ad_device, id_base(g, 0)),
            actor_targets: StackedMlp::from_flats(&actor_layout, &actor_flats, device, id_base(g, 1)),
            critics: critics_on(&ad_device, 2),
            critic_targets: critics_on(device, 3),
            actor_optim: spec.adam.init(),
            critic_optim: spec.adam.init(),
            grad_clip_norm: spec.grad_clip_norm as f32,
        };
        let offsets: Vec<usize> = r.clone().map(|i| spec.actions[..i].iter().sum()).collect();
        let joint = Joint::new(&spec.actions[r.clone()], &offsets, width, device);
        let critic_view = match spec.critic_sets {
            None => CriticInput::Global,
            Some(sets) => CriticInput::local(r, sets, spec.inputs, spec.actions, width, device),
        };
        Self { agents, nets, actor_layout, critic_layout, joint, critic_view, act_cache: None }
    }

    /// Number of agents.
    pub(crate) fn len(&self) -> usize {
        self.agents.len()
    }

    /// The group's agents' padded action width.
    pub(crate) fn max_action(&self) -> usize {
        self.joint.mask.dims()[2]
    }

    /// The actors' input width (padded).
    pub(crate) fn input_width(&self) -> usize {
        self.actor_layout.stacked.layers[0].0
    }
}

/// Reads a 1-d tensor back to the host.
pub(crate) fn to_vec1(t: Tensor<1>, what: &'static str) -> Result<Vec<f32>, NnError> {
    t.inner().into_data().try_into_vec::<f32>().map_err(|e| NnError::Backend { what, reason: format!("{e:?}") })
}
