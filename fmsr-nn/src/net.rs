//! The networks: flat parameter vectors (the learner's master copy, what Adam,
//! polyak averaging, consensus and checkpoints work on) and the burn modules
//! built from them for the forward and backward passes.

use burn::module::{Module, Param, ParamId};
use burn::nn::Linear;
use burn::tensor::activation::{relu, tanh};
use burn::tensor::{Device, Gradients, Tensor, TensorData};
use rand::Rng;
use rand::SeedableRng;
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

    /// The burn layers of `flat` on `device`; with `grad` their parameters
    /// require gradients (`device` must then be an autodiff device).
    pub(crate) fn linears(&self, flat: &[f32], device: &Device, grad: bool) -> Vec<Linear> {
        let mut at = 0;
        self.layers
            .iter()
            .map(|&(i, o)| {
                let w = Tensor::<2>::from_data(TensorData::new(flat[at..at + i * o].to_vec(), [i, o]), device);
                at += i * o;
                let b = Tensor::<1>::from_data(TensorData::new(flat[at..at + o].to_vec(), [o]), device);
                at += o;
                let (w, b) = if grad { (w.require_grad(), b.require_grad()) } else { (w, b) };
                Linear {
                    weight: Param::initialized(ParamId::new(), w),
                    bias: Some(Param::initialized(ParamId::new(), b)),
                }
            })
            .collect()
    }
}

/// Reads the gradients of `layers` (in flat order) into one vector; a layer
/// the loss does not reach gets zeros.
pub(crate) fn flat_grads(layers: &[&Linear], grads: &Gradients, out: &mut Vec<f32>) -> Result<(), NnError> {
    out.clear();
    for layer in layers {
        let w = layer.weight.val();
        let [i, o] = w.dims();
        push_grad(w.grad(grads).map(|t| t.into_data()), i * o, out)?;
        if let Some(b) = &layer.bias {
            push_grad(b.val().grad(grads).map(|t| t.into_data()), o, out)?;
        }
    }
    Ok(())
}

fn push_grad(data: Option<TensorData>, len: usize, out: &mut Vec<f32>) -> Result<(), NnError> {
    match data {
        Some(d) => {
            let v =
                d.try_into_vec::<f32>().map_err(|e| NnError::Backend { what: "gradient", reason: format!("{e:?}") })?;
            if v.len() != len {
                return Err(NnError::Backend {
                    what: "gradient",
                    reason: format!("expected {len} values, found {}", v.len()),
                });
            }
            out.extend_from_slice(&v);
        }
        None => out.extend(std::iter::repeat_n(0.0, len)),
    }
    Ok(())
}

/// Reads a 2-d tensor back as a row-major vector.
pub(crate) fn to_vec(t: Tensor<2>, what: &'static str) -> Result<Vec<f32>, NnError> {
    t.into_data().try_into_vec::<f32>().map_err(|e| NnError::Backend { what, reason: format!("{e:?}") })
}

/// A row-major `rows x cols` matrix as a tensor on `device`.
pub(crate) fn matrix(values: Vec<f32>, rows: usize, cols: usize, device: &Device) -> Tensor<2> {
    Tensor::<2>::from_data(TensorData::new(values, [rows, cols]), device)
}

/// The actor of one agent: own input layer -> trunk (hidden -> hidden, the
/// same shape for every agent, mixed by information sharing) -> own head,
/// ReLU between layers and tanh on the output, so actions lie in `[-1, 1]`.
#[derive(Module, Debug)]
pub struct Actor {
    /// `actor_input_dim(i) -> hidden`.
    pub input: Linear,
    /// `layers - 1` layers `hidden -> hidden`.
    pub trunk: Vec<Linear>,
    /// `hidden -> action_dim(i)`.
    pub head: Linear,
}

impl Actor {
    /// Builds the actor of `shape` from its flat parameters.
    pub(crate) fn from_flat(shape: &NetShape, flat: &[f32], device: &Device, grad: bool) -> Result<Self, NnError> {
        let mut layers = shape.linears(flat, device, grad);
        let head = layers.pop();
        let mut rest = layers.into_iter();
        match (rest.next(), head) {
            (Some(input), Some(head)) => Ok(Self { input, trunk: rest.collect(), head }),
            _ => Err(NnError::InvalidConfig { key: "layers", reason: "an actor needs at least two layers".into() }),
        }
    }

    /// `mu(x)` for a batch `x` of normalised actor inputs, `[n, input] -> [n, action]`.
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let mut h = relu(self.input.forward(x));
        for layer in &self.trunk {
            h = relu(layer.forward(h));
        }
        tanh(self.head.forward(h))
    }

    /// The layers in flat order.
    pub(crate) fn layers(&self) -> Vec<&Linear> {
        std::iter::once(&self.input).chain(&self.trunk).chain(std::iter::once(&self.head)).collect()
    }
}

/// The critic of one agent: `[global obs, goal, joint action] -> hidden x layers -> Q`,
/// ReLU between layers. Its "trunk" for information sharing is its hidden -> hidden layers.
#[derive(Module, Debug)]
pub struct Critic {
    /// The hidden layers, the first `critic_input_dim -> hidden`.
    pub hidden: Vec<Linear>,
    /// `hidden -> 1`.
    pub out: Linear,
}

impl Critic {
    /// Builds the critic of `shape` from its flat parameters.
    pub(crate) fn from_flat(shape: &NetShape, flat: &[f32], device: &Device, grad: bool) -> Result<Self, NnError> {
        let mut hidden = shape.linears(flat, device, grad);
        match hidden.pop() {
            Some(out) => Ok(Self { hidden, out }),
            None => Err(NnError::InvalidConfig { key: "layers", reason: "a critic needs at least one layer".into() }),
        }
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
}

/// Adam on a flat parameter vector, exactly as HER baselines' MPI Adam:
/// `t += 1; a = lr * sqrt(1 - b2^t) / (1 - b1^t); m = b1 m + (1 - b1) g;
/// v = b2 v + (1 - b2) g^2; theta -= a * m / (sqrt(v) + eps)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FlatAdam {
    /// Steps taken.
    pub t: u64,
    /// First moment.
    pub m: Vec<f32>,
    /// Second moment.
    pub v: Vec<f32>,
}

impl FlatAdam {
    /// Zero state for `n` parameters.
    #[must_use]
    pub fn new(n: usize) -> Self {
        Self { t: 0, m: vec![0.0; n], v: vec![0.0; n] }
    }

    /// One step of learning rate `lr` on `params` with gradient `grad`.
    pub fn step(&mut self, params: &mut [f32], grad: &[f32], lr: f64, beta1: f64, beta2: f64, eps: f64) {
        self.t += 1;
        let t = self.t.min(i32::MAX as u64) as i32;
        let a = (lr * (1.0 - beta2.powi(t)).sqrt() / (1.0 - beta1.powi(t))) as f32;
        let (b1, b2, eps) = (beta1 as f32, beta2 as f32, eps as f32);
        for (((p, &g), m), v) in params.iter_mut().zip(grad).zip(&mut self.m).zip(&mut self.v) {
            *m = b1 * *m + (1.0 - b1) * g;
            *v = b2 * *v + (1.0 - b2) * (g * g);
            *p -= a * *m / (v.sqrt() + eps);
        }
    }
}
