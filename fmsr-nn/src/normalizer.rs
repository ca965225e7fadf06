//! Running mean / standard deviation normaliser of network inputs (as HER baselines).

use fmsr_core::agent::Communicator;
use serde::{Deserialize, Serialize};

/// Running normaliser of `dim`-dimensional inputs:
/// `mean = sum / count`, `std = max(sqrt(sumsq / count - mean^2), eps)`,
/// `normalize(x) = clip((x - mean) / std, -clip, clip)`.
/// Before any update the mean is 0 and the std 1.
///
/// ```
/// use fmsr_nn::Normalizer;
/// let mut n = Normalizer::new(1, 0.01, 5.0);
/// n.update(&[1.0, 3.0], &fmsr_core::agent::SingleProcess);
/// assert_eq!(n.mean(), vec![2.0]);
/// assert_eq!(n.std(), vec![1.0]);
/// let mut x = vec![4.0, 100.0];
/// n.normalize(&mut x);
/// assert_eq!(x, vec![2.0, 5.0]);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Normalizer {
    dim: usize,
    eps: f64,
    clip: f64,
    sum: Vec<f64>,
    sumsq: Vec<f64>,
    count: f64,
    /// Cached `mean` and `1 / std` as f32.
    mean: Vec<f32>,
    inv_std: Vec<f32>,
}

impl Normalizer {
    /// A normaliser of `dim` values with smallest std `eps` and clip range `clip`.
    #[must_use]
    pub fn new(dim: usize, eps: f64, clip: f64) -> Self {
        Self {
            dim,
            eps,
            clip,
            sum: vec![0.0; dim],
            sumsq: vec![0.0; dim],
            count: 0.0,
            mean: vec![0.0; dim],
            inv_std: vec![1.0; dim],
        }
    }

    /// Number of values per row.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of rows seen (summed over workers).
    #[must_use]
    pub fn count(&self) -> f64 {
        self.count
    }

    /// Adds the rows of `rows` (row major, a multiple of `dim` long) to the
    /// statistics; the batch sums are averaged over `comm`'s workers and scaled
    /// back, so every worker holds the same statistics.
    pub fn update(&mut self, rows: &[f32], comm: &dyn Communicator) {
        if self.dim == 0 || rows.is_empty() {
            return;
        }
        let n = rows.len() / self.dim;
        let mut sum = vec![0.0f64; self.dim];
        let mut sumsq = vec![0.0f64; self.dim];
        for row in rows.chunks_exact(self.dim) {
            for ((s, q), &x) in sum.iter_mut().zip(&mut sumsq).zip(row) {
                let x = f64::from(x);
                *s += x;
                *q += x * x;
            }
        }
        let workers = comm.workers().max(1);
        if workers > 1 {
            // Only the multi-worker path goes through f32, as MPI would.
            let mut buf: Vec<f32> = sum.iter().chain(&sumsq).map(|&v| v as f32).collect();
            buf.push(n as f32);
            comm.all_reduce_mean(&mut buf);
            let w = workers as f64;
            for k in 0..self.dim {
                sum[k] = f64::from(buf[k]) * w;
                sumsq[k] = f64::from(buf[self.dim + k]) * w;
            }
            self.count += f64::from(buf[2 * self.dim]) * w;
        } else {
            self.count += n as f64;
        }
        for k in 0..self.dim {
            self.sum[k] += sum[k];
            self.sumsq[k] += sumsq[k];
        }
        self.recompute();
    }

    fn recompute(&mut self) {
        if self.count <= 0.0 {
            self.mean = vec![0.0; self.dim];
            self.inv_std = vec![1.0; self.dim];
            return;
        }
        let eps2 = self.eps * self.eps;
        for k in 0..self.dim {
            let mean = self.sum[k] / self.count;
            let var = (self.sumsq[k] / self.count - mean * mean).max(eps2);
            self.mean[k] = mean as f32;
            self.inv_std[k] = (1.0 / var.sqrt()) as f32;
        }
    }

    /// The current mean.
    #[must_use]
    pub fn mean(&self) -> Vec<f32> {
        self.mean.clone()
    }

    /// The current standard deviation.
    #[must_use]
    pub fn std(&self) -> Vec<f32> {
        self.inv_std.iter().map(|&v| 1.0 / v).collect()
    }

    /// Normalises the rows of `rows` in place.
    pub fn normalize(&self, rows: &mut [f32]) {
        if self.dim == 0 {
            return;
        }
        let clip = self.clip as f32;
        for row in rows.chunks_exact_mut(self.dim) {
            for ((x, &m), &s) in row.iter_mut().zip(&self.mean).zip(&self.inv_std) {
                *x = ((*x - m) * s).clamp(-clip, clip);
            }
        }
    }
}
