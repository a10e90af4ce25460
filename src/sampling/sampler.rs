//! Random streams. Every sample's stream is derived from its keys (job
//! seed, wavelength, direction or pixel, sample index), never from thread
//! identity or timing, so the same job gives bit-identical output for any
//! number of threads (CONVENTIONS.md, "Randomness and determinism").

use rand::Rng;
use rand_pcg::Pcg64Mcg;

/// The splitmix64 finaliser (Steele, Lea & Flood 2014): a bijective mix of
/// 64 bits, used to turn stream keys into generator states.
fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A stream of uniform variates in [0, 1) for one sample.
pub struct Sampler {
    rng: Pcg64Mcg,
    /// The last key (the sample index at every call site) and a hash of
    /// the others (the estimate the sample belongs to): for sequences
    /// stratified over an estimate's samples.
    index: u64,
    estimate: u64,
}

impl Sampler {
    /// The stream of sample `keys` (any fixed-length tuple of identifiers).
    pub fn new(keys: &[u64]) -> Sampler {
        let (mut a, mut b) = (0x243F_6A88_85A3_08D3_u64, 0x1319_8A2E_0370_7344_u64);
        let mut estimate = 0;
        for &k in keys {
            estimate = a;
            a = mix64(a ^ k);
            b = mix64(b.wrapping_add(k).rotate_left(17));
        }
        let state = ((a as u128) << 64) | (b as u128);
        Sampler {
            rng: Pcg64Mcg::new(state),
            index: keys.last().copied().unwrap_or(0),
            estimate,
        }
    }

    /// Coordinate `dimension` of a randomised quasi-random sequence over
    /// the samples of one estimate: the base-2 radical inverse of the
    /// sample index (van der Corput), shifted modulo 1 by a uniform offset
    /// drawn from the estimate's keys and `dimension` (Cranley–Patterson
    /// rotation). Each sample's value is uniform on [0, 1) over the
    /// offsets, and the first n samples of an estimate are stratified
    /// (one in each interval of 1/2ᵏ for n = 2ᵏ).
    pub fn stratified(&self, dimension: u64) -> f64 {
        let radical_inverse = self.index.reverse_bits() as f64 * (1.0 / 18_446_744_073_709_551_616.0);
        let offset = (mix64(self.estimate ^ mix64(dimension)) >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        let u = radical_inverse + offset;
        if u >= 1.0 { u - 1.0 } else { u }
    }

    /// A uniform variate in [0, 1) with 53 random bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Two uniform variates.
    #[inline]
    pub fn next2(&mut self) -> [f64; 2] {
        [self.next_f64(), self.next_f64()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let draw = |keys: &[u64]| {
            let mut s = Sampler::new(keys);
            (0..4).map(|_| s.next_f64()).collect::<Vec<f64>>()
        };
        assert_eq!(draw(&[1, 2, 3]), draw(&[1, 2, 3]));
        assert_ne!(draw(&[1, 2, 3]), draw(&[1, 2, 4]));
        assert_ne!(Sampler::new(&[0, 1]).next_f64(), Sampler::new(&[1, 0]).next_f64());
    }

    #[test]
    fn stratified_coordinates_fill_every_stratum_once() {
        // 64 samples of one estimate: exactly one in each 1/64 (the offset
        // only rotates the strata), for any estimate and dimension.
        for (estimate, dimension) in [(3_u64, 0_u64), (9, 5)] {
            let mut hits = [0; 64];
            for i in 0..64 {
                let u = Sampler::new(&[estimate, i]).stratified(dimension);
                assert!((0.0..1.0).contains(&u));
                hits[(u * 64.0) as usize] += 1;
            }
            assert!(hits.iter().all(|&h| h == 1), "{hits:?}");
        }
        // Different estimates and dimensions are rotated differently.
        let u = |e: u64, d: u64| Sampler::new(&[e, 0]).stratified(d);
        assert_ne!(u(1, 0), u(2, 0));
        assert_ne!(u(1, 0), u(1, 1));
    }

    #[test]
    fn variates_are_uniform() {
        // Mean 1/2 and variance 1/12 within 4 standard errors.
        let n = 200_000;
        let mut s = Sampler::new(&[7]);
        let xs: Vec<f64> = (0..n).map(|_| s.next_f64()).collect();
        assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
        let mean = xs.iter().sum::<f64>() / n as f64;
        let se = (1.0f64 / 12.0 / n as f64).sqrt();
        assert!((mean - 0.5).abs() < 4.0 * se, "{mean}");
        let m2 = xs.iter().map(|x| (x - 0.5).powi(2)).sum::<f64>() / n as f64;
        // Var of (x − 1/2)² for uniform x is 1/80 − 1/144.
        let se2 = ((1.0 / 80.0 - 1.0 / 144.0) / n as f64).sqrt();
        assert!((m2 - 1.0 / 12.0).abs() < 4.0 * se2, "{m2}");
    }
}
