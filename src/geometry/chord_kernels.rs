//! The inner loops of the half chords: √(r_k² − h²) per level, weighted sums
//! and dot products, with AVX2 kernels where the processor has them that give
//! the portable loops' results bit for bit.

/// Σ_k w_k·√((r_k − h)(r_k + h)) with r_k = `radius_km` + `levels_km[k]`
/// (a negative radicand counts as 0): the half chords of [`shell_exit`](crate::geometry::shell_exit)
/// weighted by σ steps. Four independent partial sums, so the square roots
/// pipeline (and vectorise: the same code compiled for AVX2 where the CPU
/// has it; the order of operations, hence the result, is the same either way).
#[inline]
pub fn weighted_half_chords(radius_km: f64, levels_km: &[f64], weights: &[f64], h: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { weighted_half_chords_avx2(radius_km, levels_km, weights, h) };
    }
    weighted_half_chords_portable(radius_km, levels_km, weights, h)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) fn weighted_half_chords_avx2(radius_km: f64, levels_km: &[f64], weights: &[f64], h: f64) -> f64 {
    weighted_half_chords_portable(radius_km, levels_km, weights, h)
}

#[inline(always)]
pub(crate) fn weighted_half_chords_portable(radius_km: f64, levels_km: &[f64], weights: &[f64], h: f64) -> f64 {
    let term = |z: f64, w: f64| {
        let r = radius_km + z;
        ((r - h) * (r + h)).max(0.0).sqrt() * w
    };
    let n = levels_km.len().min(weights.len());
    let (levels_km, weights) = (&levels_km[..n], &weights[..n]);
    let mut acc = [0.0; 4];
    let mut chunks = levels_km.chunks_exact(4).zip(weights.chunks_exact(4));
    for (z, w) in &mut chunks {
        for j in 0..4 {
            acc[j] += term(z[j], w[j]);
        }
    }
    let tail = n - n % 4;
    for j in tail..n {
        acc[j - tail] += term(levels_km[j], weights[j]);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Σ a_i·b_i in four independent partial sums (AVX2 where the CPU has it;
/// the same order of operations, hence the same result, either way): the
/// optical depths of many wavelengths from one ray's half chords.
#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { dot_avx2(a, b) };
    }
    dot_portable(a, b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) fn dot_avx2(a: &[f64], b: &[f64]) -> f64 {
    dot_portable(a, b)
}

#[inline(always)]
pub(crate) fn dot_portable(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 4];
    for (x, y) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        for j in 0..4 {
            acc[j] += x[j] * y[j];
        }
    }
    let tail = n - n % 4;
    for j in tail..n {
        acc[j - tail] += a[j] * b[j];
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// The half chords √((r_k − h)(r_k + h)) (0 for a negative radicand) of
/// `levels_km` into `out`, element by element (AVX2 where the CPU has it).
#[inline]
pub fn half_chords_into(radius_km: f64, levels_km: &[f64], h: f64, out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { half_chords_into_avx2(radius_km, levels_km, h, out) };
    }
    half_chords_into_portable(radius_km, levels_km, h, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) fn half_chords_into_avx2(radius_km: f64, levels_km: &[f64], h: f64, out: &mut [f64]) {
    half_chords_into_portable(radius_km, levels_km, h, out)
}

#[inline(always)]
pub(crate) fn half_chords_into_portable(radius_km: f64, levels_km: &[f64], h: f64, out: &mut [f64]) {
    for (o, &z) in out.iter_mut().zip(levels_km) {
        let r = radius_km + z;
        *o = ((r - h) * (r + h)).max(0.0).sqrt();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::sampling::sampler::Sampler;

    const R: f64 = 6378.0;

    #[test]
    fn vectorised_kernels_give_the_portable_results_bit_for_bit() {
        // Lengths around the 4-wide blocks, radicands of both signs.
        let mut s = Sampler::new(&[22]);
        for n in 0..13 {
            let levels: Vec<f64> = (0..n).map(|_| 100.0 * s.next_f64()).collect();
            let weights: Vec<f64> = (0..n).map(|_| s.next_f64() - 0.5).collect();
            let h = R + 50.0 * s.next_f64();
            assert_eq!(
                weighted_half_chords(R, &levels, &weights, h).to_bits(),
                weighted_half_chords_portable(R, &levels, &weights, h).to_bits()
            );
            assert_eq!(
                dot(&levels, &weights).to_bits(),
                dot_portable(&levels, &weights).to_bits()
            );
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            half_chords_into(R, &levels, h, &mut a);
            half_chords_into_portable(R, &levels, h, &mut b);
            assert_eq!(a, b);
            let plain: f64 = levels
                .iter()
                .zip(&weights)
                .map(|(z, w)| (((R + z) - h) * ((R + z) + h)).max(0.0).sqrt() * w)
                .sum();
            assert!((weighted_half_chords(R, &levels, &weights, h) - plain).abs() < 1e-9);
        }
    }
}
