//! The networks: burn modules that live across updates, built once by
//! [`ActorConfig::init`] / [`CriticConfig::init`] on a device.
//!
//! Weights are Glorot-uniform and biases zero (TensorFlow's dense default, as
//! in HER baselines), drawn from a ChaCha8 stream per network, so learners are
//! reproducible independently of burn's global RNG. Parameter ids are derived
//! from the network's `id_base`, so a learner built again from the same config
//! has the same ids, and optimiser records saved by one load into the other.

use burn::config::Config;
use burn::module::{Module, Param, ParamId};
use burn::nn::Linear;
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::NnError;

/// The layer sizes of a fully connected network, `(inputs, outputs)` per layer.
///
/// Parameters are flattened layer by layer, each layer as its weight
/// `[inputs, outputs]` (row major, burn's [`Linear`] layout) followed by its bias.
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

    /// The burn layers holding `flat` on `device`, with parameter ids
    /// `id_base + 2k` (weight) and `id_base + 2k + 1` (bias) for layer `k`.
    /// On an autodiff device the parameters require gradients.
    pub(crate) fn linears(&self, flat: &[f32], device: &Device, id_base: u64) -> Vec<Linear> {
        let mut at = 0;
        self.layers
            .iter()
            .enumerate()
            .map(|(k, &(i, o))| {
                let w = Tensor::<2>::from_data(TensorData::new(flat[at..at + i * o].to_vec(), [i, o]), device);
                at += i * o;
                let b = Tensor::<1>::from_data(TensorData::new(flat[at..at + o].to_vec(), [o]), device);
                at += o;
                let id = id_base + 2 * k as u64;
                Linear { weight: leaf(ParamId::from(id), w), bias: Some(leaf(ParamId::from(id + 1), b)) }
            })
            .collect()
    }
}

/// A parameter holding `t`, requiring gradients on an autodiff device.
pub(crate) fn leaf<const D: usize>(id: ParamId, t: Tensor<D>) -> Param<Tensor<D>> {
    let t = if t.device().is_autodiff() { t.require_grad() } else { t };
    Param::initialized(id, t)
}

/// Reads `layers` back into one flat vector (the [`NetShape`] layout).
pub(crate) fn flatten(layers: &[&Linear], out: &mut Vec<f32>) -> Result<(), NnError> {
    for layer in layers {
        out.extend(read(layer.weight.val().inner().into_data(), "weights")?);
        if let Some(b) = &layer.bias {
            out.extend(read(b.val().inner().into_data(), "biases")?);
        }
    }
    Ok(())
}

fn read(data: TensorData, what: &'static str) -> Result<Vec<f32>, NnError> {
    data.try_into_vec::<f32>().map_err(|e| NnError::Backend { what, reason: format!("{e:?}") })
}

/// Moves each parameter of `target` towards the same parameter of `online`:
/// `theta' <- polyak * theta' + (1 - polyak) * theta` (eq. 9, HER's convention).
fn soft_update_linear(target: &mut Linear, online: &Linear, polyak: f32) {
    let mix = |t: Tensor<2>, o: Tensor<2>| t.mul_scalar(polyak) + o.inner().mul_scalar(1.0 - polyak);
    let w = mix(target.weight.val(), online.weight.val());
    target.weight = Param::initialized(target.weight.id, w);
    if let (Some(tb), Some(ob)) = (&target.bias, &online.bias) {
        let b = tb.val().mul_scalar(polyak) + ob.val().inner().mul_scalar(1.0 - polyak);
        target.bias = Some(Param::initialized(tb.id, b));
    }
}

/// Builds an [`Actor`]: `input -> hidden` (own), `layers - 1` trunk layers
/// `hidden -> hidden` (the same shape for every agent, mixed by information
/// sharing), `hidden -> output` (own head).
///
/// ```
/// use fmsr_nn::{ActorConfig, Device};
/// let actor = ActorConfig::new(5, 16, 3, 2).with_seed(7).init(&Device::flex());
/// assert_eq!(actor.trunk.len(), 2);
/// assert_eq!(actor.shape().num_params(), 5 * 16 + 16 + 2 * (16 * 16 + 16) + 16 * 2 + 2);
/// ```
#[derive(Config, Debug, PartialEq)]
pub struct ActorConfig {
    /// Width of the actor input.
    pub input: usize,
    /// Width of every hidden layer.
    pub hidden: usize,
    /// Number of hidden layers (>= 1).
    pub layers: usize,
    /// Width of the head's output.
    pub output: usize,
    /// Seed of the weight initialisation.
    #[config(default = 0)]
    pub seed: u64,
    /// ChaCha8 stream of the weight initialisation (one per network of a seed).
    #[config(default = 0)]
    pub stream: u64,
    /// First parameter id (see [`NetShape`]).
    #[config(default = 0)]
    pub id_base: u64,
}

impl ActorConfig {
    /// The layer sizes.
    #[must_use]
    pub fn shape(&self) -> NetShape {
        NetShape::mlp(self.input, self.hidden, self.layers, self.output)
    }

    /// The actor on `device`, initialised from `seed` and `stream`.
    #[must_use]
    pub fn init(&self, device: &Device) -> Actor {
        let shape = self.shape();
        Actor::from_flat(&shape, &shape.init(self.seed, self.stream), device, self.id_base)
    }
}

/// The actor of one agent: own input layer -> trunk -> own head, ReLU between
/// layers. [`Actor::forward`] returns the head's pre-activation; each algorithm
/// applies its own squashing (tanh for MADDPG/MATD3, a tanh-Gaussian for MASAC).
#[derive(Module, Debug)]
pub struct Actor {
    /// `actor_input_dim(i) -> hidden`.
    pub input: Linear,
    /// `layers - 1` layers `hidden -> hidden`.
    pub trunk: Vec<Linear>,
    /// `hidden -> output`.
    pub head: Linear,
}

impl Actor {
    /// The actor of `shape` holding `flat` on `device` (ids from `id_base`).
    pub(crate) fn from_flat(shape: &NetShape, flat: &[f32], device: &Device, id_base: u64) -> Self {
        Self::from_layers(shape.linears(flat, device, id_base))
    }

    fn from_layers(mut layers: Vec<Linear>) -> Self {
        let head = layers.pop().expect("NetShape::mlp has at least two layers");
        let mut rest = layers.into_iter();
        let input = rest.next().expect("NetShape::mlp has at least two layers");
        Self { input, trunk: rest.collect(), head }
    }

    /// The head's output for a batch `x` of normalised actor inputs, `[n, input] -> [n, output]`.
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let mut h = relu(self.input.forward(x));
        for layer in &self.trunk {
            h = relu(layer.forward(h));
        }
        self.head.forward(h)
    }

    /// The layers in flat order.
    pub(crate) fn layers(&self) -> Vec<&Linear> {
        std::iter::once(&self.input).chain(&self.trunk).chain(std::iter::once(&self.head)).collect()
    }

    /// The layer sizes.
    #[must_use]
    pub fn shape(&self) -> NetShape {
        NetShape { layers: self.layers().iter().map(|l| dims(l)).collect() }
    }

    /// All parameters, flattened in [`NetShape`] order.
    ///
    /// # Errors
    /// [`NnError::Backend`] if the device cannot read them back.
    pub fn to_flat(&self) -> Result<Vec<f32>, NnError> {
        let mut out = Vec::with_capacity(self.shape().num_params());
        flatten(&self.layers(), &mut out)?;
        Ok(out)
    }

    /// The same actor holding `flat` (same ids, same device).
    pub(crate) fn with_flat(&self, flat: &[f32]) -> Self {
        let device = self.input.weight.val().device();
        Self::from_flat(&self.shape(), flat, &device, self.input.weight.id.val())
    }

    /// `self <- polyak * self + (1 - polyak) * online`.
    pub(crate) fn soft_update(&mut self, online: &Actor, polyak: f32) {
        soft_update_linear(&mut self.input, &online.input, polyak);
        for (t, o) in self.trunk.iter_mut().zip(&online.trunk) {
            soft_update_linear(t, o, polyak);
        }
        soft_update_linear(&mut self.head, &online.head, polyak);
    }
}

/// Builds a [`Critic`]: `input -> hidden x layers -> 1`.
///
/// ```
/// use fmsr_nn::{CriticConfig, Device};
/// let critic = CriticConfig::new(10, 16, 2).init(&Device::flex());
/// assert_eq!(critic.hidden.len(), 2);
/// ```
#[derive(Config, Debug, PartialEq)]
pub struct CriticConfig {
    /// Width of the critic input `[x, g, a_1 .. a_N]`.
    pub input: usize,
    /// Width of every hidden layer.
    pub hidden: usize,
    /// Number of hidden layers (>= 1).
    pub layers: usize,
    /// Seed of the weight initialisation.
    #[config(default = 0)]
    pub seed: u64,
    /// ChaCha8 stream of the weight initialisation.
    #[config(default = 0)]
    pub stream: u64,
    /// First parameter id (see [`NetShape`]).
    #[config(default = 0)]
    pub id_base: u64,
}

impl CriticConfig {
    /// The layer sizes.
    #[must_use]
    pub fn shape(&self) -> NetShape {
        NetShape::mlp(self.input, self.hidden, self.layers, 1)
    }

    /// The critic on `device`, initialised from `seed` and `stream`.
    #[must_use]
    pub fn init(&self, device: &Device) -> Critic {
        let shape = self.shape();
        Critic::from_flat(&shape, &shape.init(self.seed, self.stream), device, self.id_base)
    }
}

/// The critic of one agent: `[global obs, goal, joint action] -> hidden x layers -> Q`,
/// ReLU between layers. Its trunk for information sharing is its hidden -> hidden layers.
#[derive(Module, Debug)]
pub struct Critic {
    /// The hidden layers, the first `critic_input_dim -> hidden`.
    pub hidden: Vec<Linear>,
    /// `hidden -> 1`.
    pub out: Linear,
}

impl Critic {
    /// The critic of `shape` holding `flat` on `device` (ids from `id_base`).
    pub(crate) fn from_flat(shape: &NetShape, flat: &[f32], device: &Device, id_base: u64) -> Self {
        Self::from_layers(shape.linears(flat, device, id_base))
    }

    fn from_layers(mut hidden: Vec<Linear>) -> Self {
        let out = hidden.pop().expect("NetShape::mlp has at least two layers");
        Self { hidden, out }
    }

    /// `Q(x)` for a batch `x` of critic inputs, `[n, input] -> [n, 1]`.
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let mut h = x;
        for layer in &self.hidden {
            h = relu(layer.forward(h));
        }
        self.out.forward(h)
    }

    /// The layers in flat order.
    pub(crate) fn layers(&self) -> Vec<&Linear> {
        self.hidden.iter().chain(std::iter::once(&self.out)).collect()
    }

    /// The hidden -> hidden layers (what information sharing mixes).
    pub(crate) fn trunk_mut(&mut self) -> &mut [Linear] {
        let n = self.hidden.len();
        if n < 2 { &mut [] } else { &mut self.hidden[1..] }
    }

    /// The layer sizes.
    #[must_use]
    pub fn shape(&self) -> NetShape {
        NetShape { layers: self.layers().iter().map(|l| dims(l)).collect() }
    }

    /// All parameters, flattened in [`NetShape`] order.
    ///
    /// # Errors
    /// [`NnError::Backend`] if the device cannot read them back.
    pub fn to_flat(&self) -> Result<Vec<f32>, NnError> {
        let mut out = Vec::with_capacity(self.shape().num_params());
        flatten(&self.layers(), &mut out)?;
        Ok(out)
    }

    /// The same critic holding `flat` (same ids, same device).
    pub(crate) fn with_flat(&self, flat: &[f32]) -> Self {
        let device = self.out.weight.val().device();
        let id = self.layers()[0].weight.id.val();
        Self::from_flat(&self.shape(), flat, &device, id)
    }

    /// `self <- polyak * self + (1 - polyak) * online`.
    pub(crate) fn soft_update(&mut self, online: &Critic, polyak: f32) {
        for (t, o) in self.hidden.iter_mut().zip(&online.hidden) {
            soft_update_linear(t, o, polyak);
        }
        soft_update_linear(&mut self.out, &online.out, polyak);
    }
}

/// One or two critics of an agent (MATD3 and MASAC learn twin critics), one
/// module so that one optimiser steps both.
#[derive(Module, Debug)]
pub struct Critics {
    /// The critics.
    pub nets: Vec<Critic>,
}

fn dims(l: &Linear) -> (usize, usize) {
    let [i, o] = l.weight.val().dims();
    (i, o)
}
