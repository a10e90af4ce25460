//! Sums of samples: per value of an estimate, Σx and Σx² of each Stokes
//! component, added in fixed blocks (in parallel, reduced in block order) so
//! a sum is bit-identical for any number of threads and any split into
//! shards or checkpoints.

use rayon::prelude::*;

use crate::polarization::stokes::Stokes;
use crate::sampling::sampler::Sampler;
use crate::sampling::stream::StreamKey;

/// Samples per block: the unit of parallel work and of the summation order.
pub const BLOCK: u64 = 1024;

/// Sums of a sample set: Σx and Σx² per Stokes component.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Tally {
    pub sum: [f64; 4],
    pub sum_sq: [f64; 4],
    pub samples: u64,
    /// Samples with a non-finite component: counted, never summed.
    pub non_finite: u64,
}

impl Tally {
    /// Adds one sample (a non-finite one only to the count of such).
    pub fn add(&mut self, s: &Stokes) {
        if s.0.iter().any(|x| !x.is_finite()) {
            self.non_finite += 1;
            self.samples += 1;
            return;
        }
        for k in 0..4 {
            self.sum[k] += s.0[k];
            self.sum_sq[k] += s.0[k] * s.0[k];
        }
        self.samples += 1;
    }

    /// Adds another tally's sums and counts.
    pub fn merge(&mut self, o: &Tally) {
        for k in 0..4 {
            self.sum[k] += o.sum[k];
            self.sum_sq[k] += o.sum_sq[k];
        }
        self.samples += o.samples;
        self.non_finite += o.non_finite;
    }

    /// The tally of the samples times `k` (a change of units).
    pub fn scaled(&self, k: f64) -> Tally {
        Tally {
            sum: self.sum.map(|s| s * k),
            sum_sq: self.sum_sq.map(|s| s * k * k),
            ..*self
        }
    }

    /// The tally of the same samples seen in a mirror: U and V negated
    /// (their sums; the sums of squares and counts unchanged), as the sky's
    /// reflection about the sun's vertical plane turns them
    /// ([`crate::sensor::symmetry`]).
    pub fn mirrored(&self) -> Tally {
        let mut t = *self;
        t.sum[2] = -t.sum[2];
        t.sum[3] = -t.sum[3];
        t
    }

    /// Mean per component (0 without samples).
    pub fn mean(&self) -> [f64; 4] {
        if self.samples == 0 {
            return [0.0; 4];
        }
        self.sum.map(|s| s / self.samples as f64)
    }

    /// Standard error of the mean per component.
    pub fn standard_error(&self) -> [f64; 4] {
        if self.samples < 2 {
            return [0.0; 4];
        }
        let n = self.samples as f64;
        std::array::from_fn(|k| {
            let m = self.sum[k] / n;
            let var = (self.sum_sq[k] / n - m * m).max(0.0) * n / (n - 1.0).max(1.0);
            (var / n).sqrt()
        })
    }
}

/// Tallies (one per value of a sample) of one estimate per sample index `i`
/// of `f(sampler, values)` (which writes the sample's `count` values),
/// summed in blocks (fixed order: bit-identical for any thread count).
pub fn tally(samples: u64, key: StreamKey, count: usize, f: impl Fn(&mut Sampler, &mut [Stokes]) + Sync) -> Vec<Tally> {
    let mut total = vec![Tally::default(); count];
    tally_blocks(0..samples.div_ceil(BLOCK), samples, key, &mut total, f);
    total
}

/// Adds the samples of `blocks` (block indices of an estimate of `samples`
/// samples) to `total`, one tally per value: blocks in parallel, their sums
/// added to `total` in block order. Adding blocks 0..a and then a..b gives
/// bit for bit what adding 0..b at once gives, which is what makes shards
/// and checkpoints exact.
pub fn tally_blocks(
    blocks: std::ops::Range<u64>,
    samples: u64,
    key: StreamKey,
    total: &mut [Tally],
    f: impl Fn(&mut Sampler, &mut [Stokes]) + Sync,
) {
    let count = total.len();
    let partial: Vec<Vec<Tally>> = blocks
        .into_par_iter()
        .map(|b| {
            let mut t = vec![Tally::default(); count];
            let mut values = vec![Stokes::zero(); count];
            for i in b * BLOCK..((b + 1) * BLOCK).min(samples) {
                let mut s = key.sampler(i);
                f(&mut s, &mut values);
                for (ta, v) in t.iter_mut().zip(&values) {
                    ta.add(v);
                }
            }
            t
        })
        .collect();
    for p in &partial {
        for (t, q) in total.iter_mut().zip(p) {
            t.merge(q);
        }
    }
}

/// The tally of samples whose I are `values` (Q, U, V zero): for tests.
#[cfg(test)]
pub(crate) fn of_intensities(values: &[f64]) -> Tally {
    let mut t = Tally::default();
    for &v in values {
        t.add(&Stokes::new(v, 0.0, 0.0, 0.0));
    }
    t
}

/// The samples of `blocks`.
pub fn block_samples(blocks: &std::ops::Range<u64>, samples: u64) -> u64 {
    (blocks.end * BLOCK).min(samples) - (blocks.start * BLOCK).min(samples)
}
