//! Gradient clipping by norm, agent by agent: each agent's gradient (its
//! row of every stacked parameter of a group's networks) is scaled so that
//! its L2 norm over the whole network is at most the limit, as PyTorch's
//! `clip_grad_norm_` does for one agent's network. Stacked agents stay
//! independent: one agent's large gradient never scales another's.

use burn::module::ParamId;
use burn::optim::GradientsParams;
use burn::tensor::Tensor;

/// Added to a norm before dividing by it.
const EPS: f32 = 1e-6;

/// Scales the gradients of `ids` in `grads`, row by row of their leading
/// (agent) dimension, so that each row's joint norm over every parameter is
/// at most `max`; rows under it are unchanged. Stacks with another number
/// of rows (a stack held once for a group of several agents) are clipped
/// among themselves by the same rule.
pub(crate) fn clip_by_agent_norm(grads: &mut GradientsParams, ids: &[(ParamId, ParamId)], max: f32) {
    let ids: Vec<ParamId> = ids.iter().flat_map(|&(w, b)| [w, b]).collect();
    // Each agent's squared norm `[rows, 1, 1]`, per number of rows.
    let mut sums: Vec<(usize, Tensor<3>)> = Vec::new();
    for &id in &ids {
        let Some(g) = grads.get::<3>(id) else { continue };
        let rows = g.dims()[0];
        let squares = g.clone().mul(g).sum_dim(2).sum_dim(1);
        match sums.iter_mut().find(|(r, _)| *r == rows) {
            Some((_, sum)) => *sum = sum.clone() + squares,
            None => sums.push((rows, squares)),
        }
    }
    let scales: Vec<(usize, Tensor<3>)> = sums
        .into_iter()
        .map(|(rows, sum)| (rows, sum.sqrt().add_scalar(EPS).recip().mul_scalar(max).clamp_max(1.0)))
        .collect();
    for &id in &ids {
        let Some(g) = grads.remove::<3>(id) else { continue };
        let rows = g.dims()[0];
        let scale = scales.iter().find(|(r, _)| *r == rows).map(|(_, s)| s.clone());
        grads.register::<3>(id, scale.map_or(g.clone(), |s| g * s));
    }
}

#[cfg(test)]
mod tests {
    use burn::tensor::{Device, TensorData};
    use proptest::prelude::*;

    use super::*;

    fn rows(t: Tensor<3>) -> Vec<Vec<f32>> {
        let [a, ..] = t.dims();
        let v = t.into_data().try_to_vec::<f32>().unwrap();
        v.chunks(v.len() / a).map(<[f32]>::to_vec).collect()
    }

    proptest! {
        // Guards the clip's promise: every agent's joint norm over all its
        // parameters ends at most `max`, in its own direction; an agent under
        // it keeps its gradient; no agent's gradient scales another's.
        #[test]
        fn each_agent_is_clipped_alone(
            w in prop::collection::vec(-3.0f32..3.0, 3 * 2 * 2),
            b in prop::collection::vec(-3.0f32..3.0, 3 * 2),
            max in 0.1f32..6.0,
        ) {
            let device = Device::flex();
            let (wid, bid) = (ParamId::new(), ParamId::new());
            let mut grads = GradientsParams::new();
            grads.register::<3>(wid, Tensor::from_data(TensorData::new(w.clone(), [3, 2, 2]), &device));
            grads.register::<3>(bid, Tensor::from_data(TensorData::new(b.clone(), [3, 1, 2]), &device));
            clip_by_agent_norm(&mut grads, &[(wid, bid)], max);
            let (w2, b2) = (rows(grads.get::<3>(wid).unwrap()), rows(grads.get::<3>(bid).unwrap()));
            for i in 0..3 {
                let before: Vec<f32> = w[i * 4..(i + 1) * 4].iter().chain(&b[i * 2..(i + 1) * 2]).copied().collect();
                let after: Vec<f32> = w2[i].iter().chain(&b2[i]).copied().collect();
                let norm = |v: &[f32]| v.iter().map(|x| x * x).sum::<f32>().sqrt();
                let scale = (max / (norm(&before) + EPS)).min(1.0);
                prop_assert!(norm(&after) <= max * (1.0 + 1e-4), "agent {i}: {} > {max}", norm(&after));
                for (x, y) in before.iter().zip(&after) {
                    prop_assert!((x * scale - y).abs() <= 1e-5 * (1.0 + x.abs()), "agent {i}: {x} * {scale} != {y}");
                }
            }
        }
    }
}
