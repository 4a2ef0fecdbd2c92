//! Dense layers of the learned networks at query time: `y = W x + b` (and
//! ReLU) in `f32`, weights packed at load into blocks of outputs that stay
//! in vector registers while the inputs stream past, compiled three times
//! — portable, AVX2 + FMA and AVX-512 — and chosen at run time as the
//! sphere fast path chooses (`TANDEM_SIMD`, [`SimdLevel`]).
//!
//! Packing: the outputs are cut into blocks of `K × LANES` (K = 1, 2 or 4
//! by the layer's width); block `b` stores, input after input, its
//! `K × LANES` weights contiguously, zero past the last output. A block's
//! accumulators start at the bias, take one broadcast-multiply-add per
//! input, and are written once.

use crate::collision::SimdLevel;

/// Outputs per accumulator (one 256-bit register of `f32`).
const LANES: usize = 8;

/// One dense layer; see the [module documentation](self).
#[derive(Debug, Clone)]
pub(crate) struct DenseLayer {
    pub(crate) inputs: usize,
    pub(crate) outputs: usize,
    /// Accumulators per block: 1, 2 or 4.
    k: usize,
    /// Weights in blocks (see the module documentation).
    packed: Vec<f32>,
    /// The bias, zero-padded to whole blocks.
    bias: Vec<f32>,
    isa: SimdLevel,
}

/// Equal weights and biases; the variant that runs does not count.
impl PartialEq for DenseLayer {
    fn eq(&self, other: &DenseLayer) -> bool {
        (self.inputs, self.outputs, &self.packed, &self.bias)
            == (other.inputs, other.outputs, &other.packed, &other.bias)
    }
}

impl DenseLayer {
    /// A layer from row-major `[out, in]` weights (PyTorch's convention),
    /// running the variant `TANDEM_SIMD` asks for or the best available.
    pub(crate) fn from_row_major(inputs: usize, outputs: usize, w: &[f32], bias: Vec<f32>) -> DenseLayer {
        let k = match outputs {
            0..=LANES => 1,
            9..=16 => 2,
            _ => 4,
        };
        let width = k * LANES;
        let blocks = outputs.div_ceil(width);
        let mut packed = vec![0.0; blocks * width * inputs];
        for o in 0..outputs {
            let (b, lane) = (o / width, o % width);
            for j in 0..inputs {
                packed[(b * inputs + j) * width + lane] = w[o * inputs + j];
            }
        }
        let mut padded = bias;
        padded.resize(blocks * width, 0.0);
        let isa = SimdLevel::best_up_to(SimdLevel::from_environment());
        DenseLayer { inputs, outputs, k, packed, bias: padded, isa }
    }

    /// The weights row-major `[out, in]`, and the bias.
    pub(crate) fn row_major(&self) -> (Vec<f32>, Vec<f32>) {
        let width = self.k * LANES;
        let mut w = vec![0.0f32; self.outputs * self.inputs];
        for o in 0..self.outputs {
            let (b, lane) = (o / width, o % width);
            for j in 0..self.inputs {
                w[o * self.inputs + j] = self.packed[(b * self.inputs + j) * width + lane];
            }
        }
        (w, self.bias[..self.outputs].to_vec())
    }

    /// Runs the best variant not above `wanted` that this CPU has; returns it.
    pub(crate) fn set_simd(&mut self, wanted: SimdLevel) -> SimdLevel {
        self.isa = SimdLevel::best_up_to(Some(wanted));
        self.isa
    }

    /// The variant that runs.
    pub(crate) fn simd(&self) -> SimdLevel {
        self.isa
    }

    /// `y = W x + b`, then ReLU when `relu`, into `y[..outputs]` (`x` holds
    /// at least `inputs` values). Allocates nothing.
    pub(crate) fn apply(&self, x: &[f32], y: &mut [f32], relu: bool) {
        match self.isa {
            // SAFETY: `isa` is only set through `SimdLevel::best_up_to`,
            // which checked every feature the variant enables on this CPU.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => unsafe { self.apply_avx512(x, y, relu) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => unsafe { self.apply_avx2(x, y, relu) },
            _ => self.apply_portable(x, y, relu),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    fn apply_avx512(&self, x: &[f32], y: &mut [f32], relu: bool) {
        self.apply_fma(x, y, relu);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn apply_avx2(&self, x: &[f32], y: &mut [f32], relu: bool) {
        self.apply_fma(x, y, relu);
    }

    /// The FMA kernel for this layer's block size (inlined into the
    /// variants above, which enable the features it needs).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn apply_fma(&self, x: &[f32], y: &mut [f32], relu: bool) {
        match self.k {
            1 => self.blocks_fma::<1>(x, y, relu),
            2 => self.blocks_fma::<2>(x, y, relu),
            _ => self.blocks_fma::<4>(x, y, relu),
        }
    }

    /// `K` accumulators of 8 lanes per block, one broadcast and `K` fused
    /// multiply-adds per input. Only reached from functions that enable
    /// AVX2 and FMA (see [`Self::apply`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn blocks_fma<const K: usize>(&self, x: &[f32], y: &mut [f32], relu: bool) {
        use std::arch::x86_64::{
            __m256, _mm256_fmadd_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_set1_ps, _mm256_setzero_ps,
            _mm256_storeu_ps,
        };
        let width = K * LANES;
        let x = &x[..self.inputs];
        let block_len = width * self.inputs;
        for (b, bias) in self.bias.chunks_exact(width).enumerate() {
            let weights = &self.packed[b * block_len..(b + 1) * block_len];
            // SAFETY (every load and store below): each reads or writes
            // LANES floats inside a slice of `width` = K × LANES floats at
            // offset k × LANES < width, and the caller enabled AVX2 + FMA.
            let mut acc: [__m256; K] = [unsafe { _mm256_setzero_ps() }; K];
            for (k, a) in acc.iter_mut().enumerate() {
                *a = unsafe { _mm256_loadu_ps(bias[k * LANES..].as_ptr()) };
            }
            for (xj, w) in x.iter().zip(weights.chunks_exact(width)) {
                let xv = unsafe { _mm256_set1_ps(*xj) };
                for (k, a) in acc.iter_mut().enumerate() {
                    *a = unsafe { _mm256_fmadd_ps(_mm256_loadu_ps(w[k * LANES..].as_ptr()), xv, *a) };
                }
            }
            let mut block = [0.0f32; 4 * LANES];
            for (k, a) in acc.iter().enumerate() {
                let v = if relu { unsafe { _mm256_max_ps(*a, _mm256_setzero_ps()) } } else { *a };
                unsafe { _mm256_storeu_ps(block[k * LANES..].as_mut_ptr(), v) };
            }
            let end = ((b + 1) * width).min(self.outputs);
            y[b * width..end].copy_from_slice(&block[..end - b * width]);
        }
    }

    /// The portable kernel: per block, an accumulator row updated by one
    /// plain multiply-add loop per input, which the compiler vectorises
    /// for whatever the target offers.
    fn apply_portable(&self, x: &[f32], y: &mut [f32], relu: bool) {
        let width = self.k * LANES;
        let x = &x[..self.inputs];
        let block_len = width * self.inputs;
        for (b, bias) in self.bias.chunks_exact(width).enumerate() {
            let weights = &self.packed[b * block_len..(b + 1) * block_len];
            let mut acc = [0.0f32; 4 * LANES];
            let acc = &mut acc[..width];
            acc.copy_from_slice(bias);
            for (xj, w) in x.iter().zip(weights.chunks_exact(width)) {
                for (a, w) in acc.iter_mut().zip(w) {
                    *a += w * xj;
                }
            }
            let end = ((b + 1) * width).min(self.outputs);
            for (o, v) in y[b * width..end].iter_mut().zip(acc.iter()) {
                *o = if relu { v.max(0.0) } else { *v };
            }
        }
    }

    /// Whether every weight and bias is finite.
    pub(crate) fn is_finite(&self) -> (bool, bool) {
        (self.packed.iter().all(|x| x.is_finite()), self.bias.iter().all(|x| x.is_finite()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every variant this CPU has equals the plain triple loop, for widths
    /// around the block sizes, and packing round-trips.
    #[test]
    fn every_variant_matches_the_plain_product() {
        for (inputs, outputs) in [(1, 1), (3, 8), (5, 9), (7, 16), (17, 17), (40, 128), (128, 129), (0, 3)] {
            let w: Vec<f32> = (0..inputs * outputs).map(|i| ((i * 7919 % 113) as f32 - 56.0) / 37.0).collect();
            let bias: Vec<f32> = (0..outputs).map(|o| (o as f32 * 0.3).sin()).collect();
            let x: Vec<f32> = (0..inputs).map(|j| (j as f32 * 0.71).cos()).collect();
            let mut layer = DenseLayer::from_row_major(inputs, outputs, &w, bias.clone());
            assert_eq!(layer.row_major(), (w.clone(), bias.clone()));
            for relu in [false, true] {
                let expected: Vec<f32> = (0..outputs)
                    .map(|o| {
                        let v = bias[o] + (0..inputs).map(|j| w[o * inputs + j] * x[j]).sum::<f32>();
                        if relu { v.max(0.0) } else { v }
                    })
                    .collect();
                for level in SimdLevel::available() {
                    assert_eq!(layer.set_simd(level), level);
                    let mut y = vec![f32::NAN; outputs + 3];
                    layer.apply(&x, &mut y, relu);
                    for (o, (got, want)) in y.iter().zip(&expected).enumerate() {
                        assert!((got - want).abs() <= 1e-5 * (1.0 + want.abs()), "{level:?} {inputs}x{outputs} {o}");
                    }
                    assert!(y[outputs..].iter().all(|v| v.is_nan()), "wrote past the outputs");
                }
            }
        }
    }
}
