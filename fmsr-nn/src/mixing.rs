//! Information sharing on the device: the consensus step of eq. 8 as one
//! contraction of the mixing matrix with the stacked trunk layers (or their
//! gradients), with no copy to the host.
//!
//! For a trunk layer of all `A` agents, `W: [A, in, out]` (the agent groups'
//! stacks concatenated in agent order when there are several), flattened to
//! `[A, in * out]`:
//!
//! ```text
//! W_i <- sum_j M[i][j] W_j   for all i at once:   W <- M W     (eq. 8)
//! ```
//!
//! and the same for the biases: one matmul per parameter tensor whatever the
//! number of agents.

use burn::module::{Param, ParamId};
use burn::optim::GradientsParams;
use burn::tensor::{Device, Tensor, TensorData};
use fmsr_core::agent::Communicator;
use fmsr_graph::MixingMatrix;

use crate::error::NnError;
use crate::net::{StackedMlp, leaf};

/// `M` as an `[A, A]` tensor on `device`.
fn matrix(m: &MixingMatrix, device: &Device) -> Tensor<2> {
    let n = m.n();
    let values = (0..n).flat_map(|i| (0..n).map(move |j| m.get(i, j).unwrap_or(0.0) as f32)).collect::<Vec<_>>();
    Tensor::from_data(TensorData::new(values, [n, n]), device)
}

/// `M x` over the agent axis of the parts `xs[g]: [A_g, r, c]`, split back into the parts.
fn mix_parts(xs: Vec<Tensor<3>>, m: &Tensor<2>) -> Vec<Tensor<3>> {
    let sizes: Vec<usize> = xs.iter().map(|x| x.dims()[0]).collect();
    let x = if xs.len() == 1 { xs.into_iter().next().expect("one part") } else { Tensor::cat(xs, 0) };
    let [a, r, c] = x.dims();
    let mixed = m.clone().matmul(x.reshape([a, r * c])).reshape([a, r, c]);
    if sizes.len() == 1 {
        return vec![mixed];
    }
    let mut at = 0;
    sizes
        .into_iter()
        .map(|s| {
            let part = mixed.clone().narrow(0, at, s);
            at += s;
            part
        })
        .collect()
}

fn check(n: usize, m: &MixingMatrix, what: &str) -> Result<(), NnError> {
    if m.n() != n {
        return Err(NnError::Sharing {
            reason: format!("{what}: the mixing matrix has {} nodes, there are {n} agents", m.n()),
        });
    }
    Ok(())
}

/// Mixes the trunk parameters of `stacks` (one per agent group, in agent
/// order); every trunk parameter becomes a new leaf with the same id.
pub(crate) fn mix_stacks(mut stacks: Vec<&mut StackedMlp>, m: &MixingMatrix) -> Result<(), NnError> {
    let Some(first) = stacks.first() else { return Ok(()) };
    let agents: usize = stacks.iter().map(|s| s.layers[0].weight.val().dims()[0]).sum();
    check(agents, m, "trunk parameters")?;
    let mt = matrix(m, &first.layers[0].weight.val().inner().device());
    let depth = first.layers.len().saturating_sub(2);
    for l in 1..=depth {
        for weight in [true, false] {
            let param = |s: &StackedMlp| -> Param<Tensor<3>> {
                if weight { s.layers[l].weight.clone() } else { s.layers[l].bias.clone() }
            };
            let parts = stacks.iter().map(|s| param(s).val().inner()).collect();
            for (s, mixed) in stacks.iter_mut().zip(mix_parts(parts, &mt)) {
                let id = param(s).id;
                let new = leaf(id, Tensor::from_inner(mixed));
                if weight { s.layers[l].weight = new } else { s.layers[l].bias = new }
            }
        }
    }
    Ok(())
}

/// Mixes the gradients of the trunk parameters `ids[g]` held by `grads[g]`
/// (one per agent group, in agent order; the same layers in the same order).
pub(crate) fn mix_gradients(
    grads: &mut [GradientsParams],
    ids: &[Vec<(ParamId, ParamId)>],
    agents: usize,
    m: &MixingMatrix,
    device: &Device,
) -> Result<(), NnError> {
    check(agents, m, "trunk gradients")?;
    let mt = matrix(m, device);
    let depth = ids.first().map_or(0, Vec::len);
    for l in 0..depth {
        for weight in [true, false] {
            // The parameter of layer `l` in every group, in agent order.
            let layer: Vec<ParamId> = ids.iter().map(|v| if weight { v[l].0 } else { v[l].1 }).collect();
            let parts = grads
                .iter_mut()
                .zip(&layer)
                .map(|(g, &id)| {
                    g.remove::<3>(id).ok_or(NnError::Sharing { reason: "a trunk parameter has no gradient".into() })
                })
                .collect::<Result<Vec<_>, _>>()?;
            for ((g, &id), mixed) in grads.iter_mut().zip(&layer).zip(mix_parts(parts, &mt)) {
                g.register::<3>(id, mixed);
            }
        }
    }
    Ok(())
}

/// Averages every gradient `ids` held by `grads` over the workers (on the host).
pub(crate) fn all_reduce(
    grads: &mut GradientsParams,
    ids: &[(ParamId, ParamId)],
    comm: &dyn Communicator,
) -> Result<(), NnError> {
    for &id in ids.iter().flat_map(|(w, b)| [w, b]) {
        if let Some(g) = grads.remove::<3>(id) {
            let device = g.device();
            let shape = g.shape();
            let mut v = g
                .into_data()
                .try_into_vec::<f32>()
                .map_err(|e| NnError::Backend { what: "gradient", reason: format!("{e:?}") })?;
            comm.all_reduce_mean(&mut v);
            grads.register::<3>(id, Tensor::from_data(TensorData::new(v, shape), &device));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use fmsr_graph::{Graph, MetropolisHastings};
    use proptest::prelude::*;

    use super::*;
    use crate::net::{StackLayout, StackedMlp};

    fn stack(layout: &StackLayout, flats: &[Vec<f32>]) -> StackedMlp {
        StackedMlp::from_flats(layout, flats, &Device::flex(), 0)
    }

    proptest! {
        // Guards eq. 8 across agent groups: mixing the trunks of three
        // single-agent stacks equals mixing one stack of the three, and keeps
        // the agents' average trunk (M is doubly stochastic).
        #[test]
        fn mixing_does_not_depend_on_the_grouping(
            flats in prop::collection::vec(prop::collection::vec(-1.0f32..1.0, 2 * 4 + 4 + 2 * (4 * 4 + 4) + 4 + 1), 3)
        ) {
            let m = MetropolisHastings::matrix(&Graph::ring(3));
            let all = StackLayout::new(&[2; 3], 4, 3, &[1; 3], 1);
            let one = StackLayout::new(&[2], 4, 3, &[1], 1);
            let mut whole = stack(&all, &flats);
            mix_stacks(vec![&mut whole], &m).unwrap();
            let mut parts: Vec<StackedMlp> = flats.iter().map(|f| stack(&one, std::slice::from_ref(f))).collect();
            mix_stacks(parts.iter_mut().collect(), &m).unwrap();
            let whole = whole.to_flats(&all).unwrap();
            let trunk = all.shapes[0].trunk();
            for (i, p) in parts.iter().enumerate() {
                let p = &p.to_flats(&one).unwrap()[0];
                for (a, b) in p.iter().zip(&whole[i]) {
                    prop_assert!((a - b).abs() <= 1e-6, "agent {i}: {a} against {b}");
                }
            }
            for k in trunk {
                let before: f32 = flats.iter().map(|f| f[k]).sum();
                let after: f32 = whole.iter().map(|f| f[k]).sum();
                prop_assert!((before - after).abs() <= 1e-5, "average moved at {k}");
            }
        }
    }
}
