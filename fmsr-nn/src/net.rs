//! The networks: the actors (or critics) of a group of agents as one burn
//! module whose layers hold all of them at once ([`crate::Stacking`] chooses
//! the groups), built once by [`StackedMlpConfig::init`] on a device and
//! living there across updates.
//!
//! Layer `k` of `A` agents is one weight `W_k: [A, in_k, out_k]` and one bias
//! `b_k: [A, 1, out_k]`; for inputs `X: [A, n, in_k]` (or `[1, n, in_k]`,
//! broadcast when all agents see the same input, as the critics do)
//!
//! ```text
//! H_k = relu(H_{k-1} W_k + b_k)      one batched matmul for all agents
//! ```
//!
//! so the kernels of a forward or backward pass, of an Adam step, of polyak
//! averaging and of a consensus step do not grow with the agents of a stack.
//!
//! Agents whose actors differ in input or output width are padded to the
//! widest: agent `i`'s input occupies the first `in_i` rows of the input
//! layer (the other rows are zero, and stay zero: their inputs are zero, so
//! their gradients are); its head's outputs occupy, for each of the
//! `head_mult` output blocks (MASAC's mean and log-std), the first `d_i`
//! columns of a block of `d_max`. Padded outputs are masked by the learner
//! before they reach any loss, so their parameters receive no gradient
//! either. Padding keeps one matmul per layer; grouping agents of equal shape
//! would need one per group, and the Shadow Hand's six agents have five shapes.
//!
//! Weights are Glorot-uniform and biases zero (TensorFlow's dense default, as
//! in HER baselines), drawn per agent from a ChaCha8 stream in the agent's own
//! [`NetShape`], so a network starts as the per-agent network of the same seed
//! would. Parameter ids are derived from `id_base`, so a learner built again
//! from the same config has the same ids and reads its optimiser records back.

use burn::config::Config;
use burn::module::{Module, Param, ParamId};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::NnError;

/// The layer sizes of one agent's fully connected network, `(inputs, outputs)` per layer.
///
/// Parameters are flattened layer by layer, each layer as its weight
/// `[inputs, outputs]` (row major) followed by its bias: the layout of saved
/// states and of the per-agent accessors.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct NetShape {
    /// `(inputs, outputs)` of each linear layer, in order.
    pub layers: Vec<(usize, usize)>,
}

impl NetShape {
    /// `input -> hidden x layers -> output`.
    ///
    /// ```
    /// use fmsr_nn::NetShape;
    /// let s = NetShape::mlp(3, 8, 2, 1);
    /// assert_eq!(s.layers, vec![(3, 8), (8, 8), (8, 1)]);
    /// assert_eq!(s.num_params(), 3 * 8 + 8 + 8 * 8 + 8 + 8 + 1);
    /// assert_eq!(s.trunk(), 32..104);
    /// ```
    #[must_use]
    pub fn mlp(input: usize, hidden: usize, layers: usize, output: usize) -> Self {
        let mut v = Vec::with_capacity(layers + 1);
        let mut prev = input;
        for _ in 0..layers {
            v.push((prev, hidden));
            prev = hidden;
        }
        v.push((prev, output));
        Self { layers: v }
    }

    /// Total number of parameters.
    #[must_use]
    pub fn num_params(&self) -> usize {
        self.layers.iter().map(|&(i, o)| i * o + o).sum()
    }

    /// Offset of layer `k` in the flat vector.
    #[must_use]
    pub fn offset(&self, k: usize) -> usize {
        self.layers[..k].iter().map(|&(i, o)| i * o + o).sum()
    }

    /// The flat range of the trunk: the hidden -> hidden layers `1..layers.len() - 1`
    /// (empty with a single hidden layer).
    #[must_use]
    pub fn trunk(&self) -> std::ops::Range<usize> {
        let n = self.layers.len();
        if n < 3 {
            let o = self.offset(n.min(1));
            return o..o;
        }
        self.offset(1)..self.offset(n - 1)
    }

    /// Glorot-uniform weights and zero biases (TensorFlow's dense default, as in HER baselines);
    /// `stream` separates the networks built from one seed.
    #[must_use]
    pub fn init(&self, seed: u64, stream: u64) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        let mut flat = Vec::with_capacity(self.num_params());
        for &(i, o) in &self.layers {
            let limit = (6.0 / (i + o) as f64).sqrt() as f32;
            flat.extend((0..i * o).map(|_| rng.random_range(-limit..=limit)));
            flat.extend(std::iter::repeat_n(0.0, o));
        }
        flat
    }
}

/// Where each agent's network sits in a stack: the agents' own shapes, the
/// padded shape of the stack, and the stack column of each head output.
#[derive(Debug, Clone, PartialEq)]
pub struct StackLayout {
    /// Each agent's own layer sizes.
    pub shapes: Vec<NetShape>,
    /// The stack's layer sizes (each the widest over the agents).
    pub stacked: NetShape,
    /// `head_cols[i][c]`: the stack column of agent `i`'s head output `c`.
    pub head_cols: Vec<Vec<usize>>,
    /// The first `shared` layers are held once for all agents (default 0).
    pub shared: usize,
}

impl StackLayout {
    /// Agents with inputs `inputs[i]` and `head_mult` output blocks of
    /// `outputs[i]` each, `layers` hidden layers of `hidden`.
    ///
    /// ```
    /// use fmsr_nn::StackLayout;
    /// let s = StackLayout::new(&[3, 5], 8, 2, &[1, 2], 2);
    /// assert_eq!(s.stacked.layers, vec![(5, 8), (8, 8), (8, 4)]);
    /// // agent 0: mean in column 0, log-std in column 2 (blocks of 2).
    /// assert_eq!(s.head_cols, vec![vec![0, 2], vec![0, 1, 2, 3]]);
    /// ```
    #[must_use]
    pub fn new(inputs: &[usize], hidden: usize, layers: usize, outputs: &[usize], head_mult: usize) -> Self {
        let max_in = inputs.iter().copied().max().unwrap_or(0);
        let max_out = outputs.iter().copied().max().unwrap_or(0);
        let shapes =
            inputs.iter().zip(outputs).map(|(&i, &o)| NetShape::mlp(i, hidden, layers, head_mult * o)).collect();
        let head_cols = outputs
            .iter()
            .map(|&d| (0..head_mult).flat_map(|j| (0..d).map(move |k| j * max_out + k)).collect())
            .collect();
        Self { shapes, stacked: NetShape::mlp(max_in, hidden, layers, head_mult * max_out), head_cols, shared: 0 }
    }

    /// The same layout with its first `shared` layers held once for all
    /// agents (capped at the number of layers).
    ///
    /// ```
    /// use fmsr_nn::StackLayout;
    /// let s = StackLayout::new(&[3, 3], 8, 2, &[1, 1], 1).with_shared(2);
    /// assert_eq!((0..3).map(|k| s.copies(k)).collect::<Vec<_>>(), vec![1, 1, 2]);
    /// ```
    #[must_use]
    pub fn with_shared(mut self, shared: usize) -> Self {
        self.shared = shared.min(self.stacked.layers.len());
        self
    }

    /// Number of agents.
    #[must_use]
    pub fn agents(&self) -> usize {
        self.shapes.len()
    }

    /// How many copies layer `k` holds: 1 for a shared layer, else one per agent.
    #[must_use]
    pub fn copies(&self, k: usize) -> usize {
        if k < self.shared { 1 } else { self.agents() }
    }

    /// Each layer of the stack as host data `(weight [A, in, out], bias [A, 1, out])`
    /// holding every agent's flat parameters (padding zero).
    fn pack(&self, flats: &[Vec<f32>]) -> Vec<(Vec<f32>, Vec<f32>)> {
        let last = self.stacked.layers.len() - 1;
        self.stacked
            .layers
            .iter()
            .enumerate()
            .map(|(k, &(si, so))| {
                let a = self.copies(k);
                let (mut w, mut b) = (vec![0.0; a * si * so], vec![0.0; a * so]);
                for (i, (shape, flat)) in self.shapes.iter().zip(flats).take(a).enumerate() {
                    let (ni, no) = shape.layers[k];
                    let at = shape.offset(k);
                    for c in 0..no {
                        let col = if k == last { self.head_cols[i][c] } else { c };
                        for r in 0..ni {
                            w[(i * si + r) * so + col] = flat[at + r * no + c];
                        }
                        b[i * so + col] = flat[at + ni * no + c];
                    }
                }
                (w, b)
            })
            .collect()
    }

    /// The inverse of [`StackLayout::pack`]: every agent's flat parameters.
    fn unpack(&self, layers: &[(Vec<f32>, Vec<f32>)]) -> Vec<Vec<f32>> {
        let last = self.stacked.layers.len() - 1;
        self.shapes
            .iter()
            .enumerate()
            .map(|(i, shape)| {
                let mut flat = Vec::with_capacity(shape.num_params());
                for (k, ((w, b), &(si, so))) in layers.iter().zip(&self.stacked.layers).enumerate() {
                    let (ni, no) = shape.layers[k];
                    let col = |c: usize| if k == last { self.head_cols[i][c] } else { c };
                    let j = if k < self.shared { 0 } else { i };
                    for r in 0..ni {
                        flat.extend((0..no).map(|c| w[(j * si + r) * so + col(c)]));
                    }
                    flat.extend((0..no).map(|c| b[j * so + col(c)]));
                }
                flat
            })
            .collect()
    }
}

/// `A` dense layers of equal shape, one per agent: `y_a = x_a W_a + b_a` with
/// `W: [A, in, out]` and `b: [A, 1, out]`, one batched matmul for all agents.
#[derive(Module, Debug)]
pub struct StackedLinear {
    /// `[agents, inputs, outputs]`.
    pub weight: Param<Tensor<3>>,
    /// `[agents, 1, outputs]`.
    pub bias: Param<Tensor<3>>,
}

impl StackedLinear {
    /// `[A or 1, n, in] -> [A, n, out]`.
    pub fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        x.matmul(self.weight.val()) + self.bias.val()
    }
}

/// A parameter holding `t`, requiring gradients on an autodiff device.
pub(crate) fn leaf<const D: usize>(id: ParamId, t: Tensor<D>) -> Param<Tensor<D>> {
    let t = if t.device().is_autodiff() { t.require_grad() } else { t };
    Param::initialized(id, t)
}

/// Builds a [`StackedMlp`] of agents with inputs `inputs[i]` and heads of
/// `head_mult * outputs[i]`, agent `i` initialised from `seed` on ChaCha8
/// stream `streams[i]`.
///
/// ```
/// use fmsr_nn::{Device, StackedMlpConfig};
/// let config = StackedMlpConfig::new(vec![5, 3], 16, 3, vec![2, 1]).with_streams(vec![0, 8]);
/// let actors = config.init(&Device::flex())?;
/// assert_eq!(actors.layers.len(), 4);
/// assert_eq!(actors.layers[0].weight.val().dims(), [2, 5, 16]);
/// # Ok::<(), fmsr_nn::NnError>(())
/// ```
#[derive(Config, Debug, PartialEq)]
pub struct StackedMlpConfig {
    /// Each agent's input width.
    pub inputs: Vec<usize>,
    /// Width of every hidden layer.
    pub hidden: usize,
    /// Number of hidden layers (>= 1).
    pub layers: usize,
    /// Each agent's output width (per output block).
    pub outputs: Vec<usize>,
    /// Output blocks of each head (2 for MASAC's mean and log-std).
    #[config(default = 1)]
    pub head_mult: usize,
    /// Seed of the weight initialisation.
    #[config(default = 0)]
    pub seed: u64,
    /// ChaCha8 stream of each agent (default `0, 1, 2, ...`).
    #[config(default = "Vec::new()")]
    pub streams: Vec<u64>,
    /// First parameter id: layer `k` has ids `id_base + 2k` (weight) and `+ 1` (bias).
    #[config(default = 0)]
    pub id_base: u64,
    /// The first `shared_layers` layers are held once for all agents
    /// ([`StackLayout::with_shared`]; at most `layers + 1`, default 0).
    #[config(default = 0)]
    pub shared_layers: usize,
}

impl StackedMlpConfig {
    /// Where each agent sits in the stack.
    #[must_use]
    pub fn layout(&self) -> StackLayout {
        StackLayout::new(&self.inputs, self.hidden, self.layers, &self.outputs, self.head_mult)
            .with_shared(self.shared_layers)
    }

    /// Every agent's initial flat parameters.
    #[must_use]
    pub fn initial(&self) -> Vec<Vec<f32>> {
        let stream = |i: usize| self.streams.get(i).copied().unwrap_or(i as u64);
        self.layout().shapes.iter().enumerate().map(|(i, s)| s.init(self.seed, stream(i))).collect()
    }

    /// The networks on `device`.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] for no agents, a zero width or mismatched lists.
    pub fn init(&self, device: &Device) -> Result<StackedMlp, NnError> {
        let bad = |reason: &str| Err(NnError::InvalidConfig { key: "networks", reason: reason.into() });
        if self.inputs.is_empty() || self.inputs.len() != self.outputs.len() {
            return bad("need one input and one output width per agent, and at least one agent");
        }
        if self.hidden == 0
            || self.layers == 0
            || self.head_mult == 0
            || self.inputs.contains(&0)
            || self.outputs.contains(&0)
        {
            return bad("every width and the number of layers must be positive");
        }
        if self.shared_layers > self.layers + 1 {
            return bad("more shared layers than the network has");
        }
        let same = |v: &[usize]| v.iter().all(|&w| w == v[0]);
        if (self.shared_layers > 0 && !same(&self.inputs)) || (self.shared_layers > self.layers && !same(&self.outputs))
        {
            return bad("shared layers need agents of one input width (and, for a shared head, one output width)");
        }
        let layout = self.layout();
        Ok(StackedMlp::from_flats(&layout, &self.initial(), device, self.id_base))
    }
}

/// Every agent's network of one kind (actor or critic) as one stack of
/// [`StackedLinear`] layers, ReLU between them. The actor is input layer
/// (own) -> trunk (layers `1..L-1`, the same shape for every agent, mixed by
/// information sharing) -> head (own); the critic has the same structure,
/// its trunk being its hidden -> hidden layers.
#[derive(Module, Debug)]
pub struct StackedMlp {
    /// The layers, input first.
    pub layers: Vec<StackedLinear>,
}

impl StackedMlp {
    /// The stack holding every agent's `flats` (laid out by `layout`) on `device`.
    #[must_use]
    pub fn from_flats(layout: &StackLayout, flats: &[Vec<f32>], device: &Device, id_base: u64) -> Self {
        let layers = layout
            .pack(flats)
            .into_iter()
            .zip(&layout.stacked.layers)
            .enumerate()
            .map(|(k, ((w, b), &(i, o)))| {
                let (id, a) = (id_base + 2 * k as u64, layout.copies(k));
                let w = Tensor::<3>::from_data(TensorData::new(w, [a, i, o]), device);
                let b = Tensor::<3>::from_data(TensorData::new(b, [a, 1, o]), device);
                StackedLinear { weight: leaf(ParamId::from(id), w), bias: leaf(ParamId::from(id + 1), b) }
            })
            .collect();
        Self { layers }
    }

    /// Every agent's flat parameters ([`NetShape`] layout), read back from the device.
    ///
    /// # Errors
    /// [`NnError::Backend`] if the device cannot read them back.
    pub fn to_flats(&self, layout: &StackLayout) -> Result<Vec<Vec<f32>>, NnError> {
        let host = self
            .layers
            .iter()
            .map(|l| {
                Ok((
                    read(l.weight.val().inner().into_data(), "weights")?,
                    read(l.bias.val().inner().into_data(), "biases")?,
                ))
            })
            .collect::<Result<Vec<_>, NnError>>()?;
        Ok(layout.unpack(&host))
    }

    /// The outputs for inputs `x: [A or 1, n, in]`: `[A, n, out]`, before any squashing.
    pub fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        let last = self.layers.len() - 1;
        let mut h = x;
        for (k, layer) in self.layers.iter().enumerate() {
            h = layer.forward(h);
            if k < last {
                h = relu(h);
            }
        }
        h
    }

    /// The trunk: layers `1..L-1` (hidden -> hidden), what information sharing mixes.
    pub fn trunk_mut(&mut self) -> &mut [StackedLinear] {
        let n = self.layers.len();
        if n < 3 { &mut [] } else { &mut self.layers[1..n - 1] }
    }

    /// The trunk's parameter ids, `(weight, bias)` per layer.
    pub(crate) fn trunk_ids(&self) -> Vec<(ParamId, ParamId)> {
        let n = self.layers.len();
        self.layers.get(1..n.saturating_sub(1)).unwrap_or(&[]).iter().map(|l| (l.weight.id, l.bias.id)).collect()
    }

    /// Every parameter's id.
    pub(crate) fn ids(&self) -> Vec<(ParamId, ParamId)> {
        self.layers.iter().map(|l| (l.weight.id, l.bias.id)).collect()
    }

    /// `self <- polyak * self + (1 - polyak) * online` (eq. 9), whole tensors.
    pub(crate) fn soft_update(&mut self, online: &StackedMlp, polyak: f32) {
        let mix = |t: Tensor<3>, o: Tensor<3>| t.mul_scalar(polyak) + o.inner().mul_scalar(1.0 - polyak);
        for (t, o) in self.layers.iter_mut().zip(&online.layers) {
            t.weight = Param::initialized(t.weight.id, mix(t.weight.val(), o.weight.val()));
            t.bias = Param::initialized(t.bias.id, mix(t.bias.val(), o.bias.val()));
        }
    }

    /// The same stack on `device` as plain (no autodiff) tensors: the host
    /// copy the rollouts act with.
    #[must_use]
    pub fn copy_to(&self, device: &Device) -> Self {
        let copy = |p: &Param<Tensor<3>>| {
            Param::initialized(p.id, Tensor::<3>::from_data(p.val().inner().into_data(), device))
        };
        Self {
            layers: self
                .layers
                .iter()
                .map(|l| StackedLinear { weight: copy(&l.weight), bias: copy(&l.bias) })
                .collect(),
        }
    }

    /// The same stack (ids, device) holding every agent's `flats`, laid out by `layout`.
    #[must_use]
    pub fn with_flats(&self, layout: &StackLayout, flats: &[Vec<f32>]) -> Self {
        let first = &self.layers[0].weight;
        Self::from_flats(layout, flats, &first.val().device(), first.id.val())
    }
}

fn read(data: TensorData, what: &'static str) -> Result<Vec<f32>, NnError> {
    data.try_into_vec::<f32>().map_err(|e| NnError::Backend { what, reason: format!("{e:?}") })
}

/// One or two critic stacks (MATD3 and MASAC learn twin critics), one module
/// so that one optimiser steps both.
#[derive(Module, Debug)]
pub struct Critics {
    /// The stacks, each holding one critic of every agent.
    pub nets: Vec<StackedMlp>,
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// Agents with inputs `ins`, outputs `outs` (per block) and their flat parameters.
    fn agents() -> impl Strategy<Value = (Vec<usize>, Vec<usize>, usize, usize, Vec<Vec<f32>>)> {
        (1usize..4, 1usize..3, 1usize..3)
            .prop_flat_map(|(n, layers, head_mult)| {
                (
                    prop::collection::vec(1usize..6, n),
                    prop::collection::vec(1usize..4, n),
                    Just(layers),
                    Just(head_mult),
                )
            })
            .prop_flat_map(|(ins, outs, layers, head_mult)| {
                let layout = StackLayout::new(&ins, 3, layers, &outs, head_mult);
                let flats = layout
                    .shapes
                    .iter()
                    .map(|s| prop::collection::vec(-1.0f32..1.0, s.num_params()))
                    .collect::<Vec<_>>();
                (Just(ins), Just(outs), Just(layers), Just(head_mult), flats)
            })
    }

    /// Agents of one shape whose first `shared` layers are agent 0's.
    fn shared_agents() -> impl Strategy<Value = (usize, usize, usize, Vec<Vec<f32>>)> {
        (1usize..4, 1usize..3)
            .prop_flat_map(|(n, layers)| (Just(n), Just(layers), 0..=layers + 1))
            .prop_flat_map(|(n, layers, shared)| {
                let shape = NetShape::mlp(2, 3, layers, 1);
                let flats = prop::collection::vec(prop::collection::vec(-1.0f32..1.0, shape.num_params()), n);
                (Just(n), Just(layers), Just(shared), flats)
            })
            .prop_map(|(n, layers, shared, mut flats)| {
                let end = NetShape::mlp(2, 3, layers, 1).offset(shared);
                let first = flats[0][..end].to_vec();
                flats.iter_mut().for_each(|f| f[..end].copy_from_slice(&first));
                (n, layers, shared, flats)
            })
    }

    proptest! {
        // Guards shared layers: a stack holding its first layers once returns
        // every agent's whole network, and computes for each agent what the
        // agent's own network computes, on one input broadcast to all (the
        // critics' TD step) and on an input per agent (their actor step).
        #[test]
        fn shared_layers_keep_every_agents_network((n, layers, shared, flats) in shared_agents(), x in -1.0f32..1.0) {
            let layout = StackLayout::new(&vec![2; n], 3, layers, &vec![1; n], 1).with_shared(shared);
            let device = Device::flex();
            let stack = StackedMlp::from_flats(&layout, &flats, &device, 0);
            prop_assert_eq!(stack.layers[0].weight.val().dims()[0], if shared > 0 { 1 } else { n });
            prop_assert_eq!(&stack.to_flats(&layout).unwrap(), &flats);
            let input = |rows: usize| Tensor::<3>::from_data(TensorData::new([x, -0.5 * x].repeat(rows), [rows, 1, 2]), &device);
            for rows in [1, n] {
                let y = stack.forward(input(rows)).into_data().try_to_vec::<f32>().unwrap();
                for (i, flat) in flats.iter().enumerate() {
                    let single = StackLayout::new(&[2], 3, layers, &[1], 1);
                    let own = StackedMlp::from_flats(&single, std::slice::from_ref(flat), &device, 0);
                    let yi = own.forward(input(1)).into_data().try_to_vec::<f32>().unwrap()[0];
                    let yi_stack = y[if y.len() == 1 { 0 } else { i }];
                    prop_assert!((yi_stack - yi).abs() <= 1e-5 * (1.0 + yi.abs()), "agent {i}, {rows} input rows");
                }
            }
        }

        // Guards the stacking layout: every agent's parameters come back
        // exactly from a stack, whatever the padding.
        #[test]
        fn stacks_return_every_agents_parameters((ins, outs, layers, mult, flats) in agents()) {
            let layout = StackLayout::new(&ins, 3, layers, &outs, mult);
            let stack = StackedMlp::from_flats(&layout, &flats, &Device::flex(), 0);
            prop_assert_eq!(stack.to_flats(&layout).unwrap(), flats);
        }

        // Guards the padding: a stack computes for each agent what the agent's
        // own network computes on its own input (zero-padded), in the agent's
        // own output columns.
        #[test]
        fn a_stack_computes_each_agents_network((ins, outs, layers, mult, flats) in agents(), x in -1.0f32..1.0) {
            let layout = StackLayout::new(&ins, 3, layers, &outs, mult);
            let device = Device::flex();
            let stack = StackedMlp::from_flats(&layout, &flats, &device, 0);
            let width = layout.stacked.layers[0].0;
            let mut input = vec![0.0f32; ins.len() * width];
            for (i, &d) in ins.iter().enumerate() {
                for k in 0..d {
                    input[i * width + k] = x * (k as f32 + 1.0) / d as f32;
                }
            }
            let y = stack.forward(Tensor::from_data(TensorData::new(input.clone(), [ins.len(), 1, width]), &device));
            let w = y.dims()[2];
            let y = y.into_data().try_to_vec::<f32>().unwrap();
            for (i, shape) in layout.shapes.iter().enumerate() {
                let single = StackLayout { shapes: vec![shape.clone()], stacked: shape.clone(), head_cols: vec![(0..shape.layers.last().unwrap().1).collect()], shared: 0 };
                let own = StackedMlp::from_flats(&single, &flats[i..=i], &device, 0);
                let xi = input[i * width..i * width + ins[i]].to_vec();
                let yi = own.forward(Tensor::from_data(TensorData::new(xi, [1, 1, ins[i]]), &device)).into_data().try_to_vec::<f32>().unwrap();
                for (c, &col) in layout.head_cols[i].iter().enumerate() {
                    prop_assert!((y[i * w + col] - yi[c]).abs() <= 1e-5 * (1.0 + yi[c].abs()), "agent {i} output {c}");
                }
            }
        }
    }
}
