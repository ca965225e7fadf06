//! Information sharing on the device: the consensus step of eq. 8 applied to
//! the trunk layers of every agent's actor or critic, or to their gradients,
//! with tensor operations on the networks' own device (no copy to the host).
//!
//! ```text
//! W_i <- sum_j M[i][j] W_j,   b_i <- sum_j M[i][j] b_j      for every trunk layer
//! ```

use burn::module::{Param, ParamId};
use burn::nn::Linear;
use burn::optim::GradientsParams;
use burn::tensor::{Tensor, TensorData};
use fmsr_core::agent::Communicator;
use fmsr_core::sharing::{NetworkGroup, SharedParameters};
use fmsr_graph::MixingMatrix;

use crate::error::NnError;
use crate::learner::AgentNets;

/// `sum_j M[i][j] x_j` for every `i`, on the tensors' device.
fn mix_tensors<const D: usize>(xs: &[Tensor<D>], m: &MixingMatrix) -> Vec<Tensor<D>> {
    (0..xs.len())
        .map(|i| {
            let mut acc: Option<Tensor<D>> = None;
            for (j, x) in xs.iter().enumerate() {
                let w = m.get(i, j).unwrap_or(0.0);
                if w == 0.0 {
                    continue;
                }
                let term = x.clone().mul_scalar(w as f32);
                acc = Some(match acc {
                    Some(a) => a + term,
                    None => term,
                });
            }
            acc.unwrap_or_else(|| xs[i].clone().zeros_like())
        })
        .collect()
}

fn check(n: usize, m: &MixingMatrix, what: &'static str) -> Result<(), NnError> {
    if m.n() != n {
        return Err(NnError::Sharing {
            reason: format!("{what}: the mixing matrix has {} nodes, there are {n} agents", m.n()),
        });
    }
    Ok(())
}

/// Mixes the parameters of the trunks `trunks[i]` (agent `i`'s hidden -> hidden
/// layers, all of the same shapes): each becomes a new leaf with the same id.
pub(crate) fn mix_layers(trunks: &mut [&mut [Linear]], m: &MixingMatrix) -> Result<(), NnError> {
    check(trunks.len(), m, "trunk parameters")?;
    let Some(depth) = trunks.first().map(|t| t.len()) else { return Ok(()) };
    if trunks.iter().any(|t| t.len() != depth) {
        return Err(NnError::Sharing { reason: "the agents' trunks have different depths".into() });
    }
    for l in 0..depth {
        let ws: Vec<Tensor<2>> = trunks.iter().map(|t| t[l].weight.val().detach()).collect();
        for (t, w) in trunks.iter_mut().zip(mix_tensors(&ws, m)) {
            t[l].weight = crate::net::leaf(t[l].weight.id, w.detach());
        }
        let bs: Option<Vec<Tensor<1>>> = trunks.iter().map(|t| t[l].bias.as_ref().map(|b| b.val().detach())).collect();
        if let Some(bs) = bs {
            for (t, b) in trunks.iter_mut().zip(mix_tensors(&bs, m)) {
                let id = t[l].bias.as_ref().map_or_else(ParamId::new, |p| p.id);
                t[l].bias = Some(crate::net::leaf(id, b.detach()));
            }
        }
    }
    Ok(())
}

/// The ids of the weight and bias of every layer of `trunk`, in order.
pub(crate) fn trunk_ids(trunk: &[Linear]) -> Vec<(ParamId, Option<ParamId>)> {
    trunk.iter().map(|l| (l.weight.id, l.bias.as_ref().map(|b: &Param<Tensor<1>>| b.id))).collect()
}

/// Mixes the gradients of the trunk parameters `ids[i]` held by `grads[i]`.
pub(crate) fn mix_gradients(
    grads: &mut [GradientsParams],
    ids: &[Vec<(ParamId, Option<ParamId>)>],
    m: &MixingMatrix,
) -> Result<(), NnError> {
    check(grads.len(), m, "trunk gradients")?;
    let Some(depth) = ids.first().map(Vec::len) else { return Ok(()) };
    for l in 0..depth {
        mix_grad::<2>(grads, &ids.iter().map(|v| v[l].0).collect::<Vec<_>>(), m)?;
        if let Some(bias) = ids.iter().map(|v| v[l].1).collect::<Option<Vec<_>>>() {
            mix_grad::<1>(grads, &bias, m)?;
        }
    }
    Ok(())
}

fn mix_grad<const D: usize>(grads: &mut [GradientsParams], ids: &[ParamId], m: &MixingMatrix) -> Result<(), NnError> {
    let gs: Vec<Tensor<D>> = grads
        .iter()
        .zip(ids)
        .map(|(g, &id)| g.get::<D>(id).ok_or(NnError::Sharing { reason: "a trunk parameter has no gradient".into() }))
        .collect::<Result<_, _>>()?;
    for ((g, &id), mixed) in grads.iter_mut().zip(ids).zip(mix_tensors(&gs, m)) {
        g.register(id, mixed);
    }
    Ok(())
}

/// The trunk parameter ids of agent `a`'s networks of `group` (every critic's).
pub(crate) fn group_trunk_ids(
    a: &AgentNets,
    group: NetworkGroup,
) -> Vec<(burn::module::ParamId, Option<burn::module::ParamId>)> {
    match group {
        NetworkGroup::Actors => trunk_ids(&a.actor.trunk),
        NetworkGroup::Critics => {
            a.critics.nets.iter().flat_map(|c| trunk_ids(c.hidden.get(1..).unwrap_or(&[]))).collect()
        }
    }
}

/// Every agent's gradients of one group, as information sharing sees them.
pub(crate) struct GradHolder<'a> {
    pub(crate) grads: &'a mut [GradientsParams],
    pub(crate) ids: &'a [Vec<(burn::module::ParamId, Option<burn::module::ParamId>)>],
}

impl SharedParameters for GradHolder<'_> {
    type Error = NnError;

    fn consensus_step(&mut self, _: NetworkGroup, mixing: &fmsr_graph::MixingMatrix) -> Result<(), NnError> {
        mix_gradients(self.grads, self.ids, mixing)
    }
}

/// Every agent's networks, as information sharing sees them.
pub(crate) struct ParamHolder<'a> {
    pub(crate) agents: &'a mut [AgentNets],
}

impl SharedParameters for ParamHolder<'_> {
    type Error = NnError;

    fn consensus_step(&mut self, group: NetworkGroup, mixing: &fmsr_graph::MixingMatrix) -> Result<(), NnError> {
        match group {
            NetworkGroup::Actors => {
                let mut trunks: Vec<&mut [Linear]> =
                    self.agents.iter_mut().map(|a| a.actor.trunk.as_mut_slice()).collect();
                mix_layers(&mut trunks, mixing)
            }
            NetworkGroup::Critics => {
                let k = self.agents.first().map_or(0, |a| a.critics.nets.len());
                for c in 0..k {
                    let mut trunks: Vec<&mut [Linear]> =
                        self.agents.iter_mut().map(|a| a.critics.nets[c].trunk_mut()).collect();
                    mix_layers(&mut trunks, mixing)?;
                }
                Ok(())
            }
        }
    }
}

/// Averages every gradient of `layers` held by `grads` over the workers (on the host).
pub(crate) fn all_reduce(
    grads: &mut GradientsParams,
    layers: &[&Linear],
    comm: &dyn Communicator,
) -> Result<(), NnError> {
    fn one<const D: usize>(
        grads: &mut GradientsParams,
        id: burn::module::ParamId,
        comm: &dyn Communicator,
    ) -> Result<(), NnError> {
        if let Some(g) = grads.remove::<D>(id) {
            let device = g.device();
            let shape = g.shape();
            let mut v = g
                .into_data()
                .try_into_vec::<f32>()
                .map_err(|e| NnError::Backend { what: "gradient", reason: format!("{e:?}") })?;
            comm.all_reduce_mean(&mut v);
            grads.register::<D>(id, Tensor::from_data(TensorData::new(v, shape), &device));
        }
        Ok(())
    }
    for l in layers {
        one::<2>(grads, l.weight.id, comm)?;
        if let Some(b) = &l.bias {
            one::<1>(grads, b.id, comm)?;
        }
    }
    Ok(())
}
