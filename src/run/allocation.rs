//! A noise target's allocation: from the pilot's sums of a direction, flux
//! or pixel, the samples it needs for the target relative standard error of
//! I in every channel and every albedo the target counts.
//!
//! Two stages keep the estimate unbiased. The pilot's samples (streams of
//! their own, [`crate::sampling::stream::Estimate::pilot`]) only decide how
//! many samples each direction or pixel gets; the result is the mean of
//! those allocated samples alone, which are independent of the pilot, so
//! its expectation given the allocation is the radiance whatever the
//! allocation is. (Folding the pilot's samples into the mean, or stopping
//! a pixel when its own running error looks small enough, would tie the
//! count to the values counted, and bias the mean.)
//!
//! The allocation of a value with per-sample variance σ² and mean μ is
//! σ²/(μ²t²) samples; a direction or pixel takes the most any of its
//! channels and counted albedos needs (values whose pilot mean is 0, such
//! as the ground at albedo 0 seen from the ground, are left out, and so
//! are albedos the target does not count: `render.noise_target_albedos`). An image pixel
//! takes the mean need of itself and its eight neighbours: a pilot of a few
//! dozen samples is a noisy estimate of σ² (it often misses the rare bright
//! paths of a pixel near the sun or the horizon that a neighbour catches),
//! and neighbours of a smooth sky need alike, so the mean over nine pilots
//! estimates a pixel's need from nine times the samples. (The most of the
//! nine, used before, overshot: the median pixel reached 0.65–0.85 of the
//! target, and the grid benchmark's tasks cost 15–30 % more for the same
//! median.) The count is then held between the pilot's count and the cap
//! (`render.max_samples`).
//!
//! A target for each image as a whole (`render.noise_target_per =
//! "image"`, [`image_pixels`]) asks instead that the image's noise power,
//! Σ Ω·se² over its pixels (solid angle Ω), be t² of its signal power
//! Σ Ω·I², in every channel and counted albedo. The allocation that meets
//! it with the fewest paths gives pixel k, of per-sample standard deviation
//! σ_k, n_k = λ·σ_k·√Ω_k samples (minimise Σ n_k subject to
//! Σ Ω_k·σ_k²/n_k = t²·S: a Lagrange multiplier), with
//! λ = Σ_j √Ω_j·σ_j / (t²·S). So bright pixels (the sun's aureole) and large
//! ones get more, dark ones fewer than a per-pixel target gives them. The
//! pilot estimates σ_k² (the mean over the pixel and its neighbours, as
//! above) and S; a mirrored pixel's Ω counts its mirror image too.

use crate::film::ground_view::GROUND_VIEW_SAMPLES;
use crate::film::tally::Tally;
use crate::job::NoiseTarget;
use crate::sensor::symmetry::Symmetry;

/// A targeted estimate's samples: per direction or flux, or per pixel (0
/// for a pixel that is not traced).
#[derive(Debug, Clone, PartialEq)]
pub enum Allocation {
    Single(u64),
    Pixels(Vec<u64>),
}

/// Samples a direction or pixel needs, from its pilot's tallies (one per
/// value, the albedos varying fastest): the most over the values of
/// σ²/(μ²t²) whose albedo `counted` holds (one flag per albedo), as a real
/// number; 0 when no such value has a mean.
pub fn needed(tallies: &[Tally], relative_se: f64, counted: &[bool]) -> f64 {
    let na = counted.len().max(1);
    tallies
        .iter()
        .enumerate()
        .filter(|(v, _)| counted.get(v % na).copied().unwrap_or(true))
        .map(|(_, t)| t)
        .filter(|t| t.samples > t.non_finite + 1)
        .filter_map(|t| {
            let n = (t.samples - t.non_finite) as f64;
            let mean = t.sum[0] / n;
            if mean.abs() <= 0.0 || !mean.is_finite() {
                return None;
            }
            let variance = ((t.sum_sq[0] - t.sum[0] * mean) / (n - 1.0)).max(0.0);
            Some(variance / (mean * mean * relative_se * relative_se))
        })
        .fold(0.0, f64::max)
}

/// The samples of a real-valued need, between the pilot's count and the cap.
fn clamp(need: f64, target: &NoiseTarget) -> u64 {
    let n = if need.is_finite() { need.ceil() } else { f64::MAX };
    (n.min(target.max_samples as f64) as u64).clamp(target.pilot, target.max_samples)
}

/// The target of the ground view (`run::layout::EstimateKind::GroundView`),
/// which many pixels share: a quarter of the pixels' relative error, up to
/// [`GROUND_VIEW_SAMPLES`] times their cap, from the same pilot.
pub fn ground_view(target: &NoiseTarget) -> NoiseTarget {
    let k = GROUND_VIEW_SAMPLES;
    NoiseTarget {
        relative_se: target.relative_se / (k as f64).sqrt(),
        max_samples: target.max_samples.saturating_mul(k),
        ..*target
    }
}

/// The allocation of a direction or flux from its pilot's tallies.
pub fn single(tallies: &[Tally], target: &NoiseTarget, counted: &[bool]) -> u64 {
    clamp(needed(tallies, target.relative_se, counted), target)
}

/// The allocation of an image of `width` pixels a row from its pilot's
/// tallies (`values` per pixel, pixel-major): each traced pixel takes the
/// mean of what it and its traced neighbours need, a neighbour in a column
/// that `symmetry` copies standing for its source; untraced pixels (no
/// pilot samples, or copied) get none.
pub fn pixels(
    tallies: &[Tally],
    values: usize,
    width: usize,
    symmetry: Symmetry,
    target: &NoiseTarget,
    counted: &[bool],
) -> Vec<u64> {
    let values = values.max(1);
    let count = tallies.len() / values;
    let width = width.max(1);
    let traced: Vec<bool> = (0..count)
        .map(|p| tallies[p * values].samples > 0 && symmetry.source_column(width, p % width).is_none())
        .collect();
    let need: Vec<f64> = (0..count)
        .map(|p| needed(&tallies[p * values..(p + 1) * values], target.relative_se, counted))
        .collect();
    let height = count / width;
    (0..count)
        .map(|p| {
            if !traced[p] {
                return 0;
            }
            let (i, j) = ((p % width) as i64, (p / width) as i64);
            let (mut sum, mut count) = (0.0, 0.0);
            for dj in -1..=1 {
                for di in -1..=1 {
                    let (x, y) = (i + di, j + dj);
                    if x < 0 || y < 0 || x >= width as i64 || y >= height as i64 {
                        continue;
                    }
                    let q = y as usize * width + symmetry.traced_column(width, x as usize);
                    if traced[q] {
                        sum += need[q];
                        count += 1.0;
                    }
                }
            }
            clamp(sum / count, target)
        })
        .collect()
}

/// An image's pilot, as [`image_pixels`] reads it.
#[derive(Debug, Clone, Copy)]
pub struct ImagePilot<'a> {
    /// `values` tallies per pixel, pixel-major, `width` pixels a row.
    pub tallies: &'a [Tally],
    pub values: usize,
    pub width: usize,
    pub symmetry: Symmetry,
    /// Per pixel its solid angle and that of the pixels copying it (0 for
    /// untraced pixels).
    pub weights: &'a [f64],
    /// The ground view's pilot and the solid angle of the rows showing it.
    pub ground: Option<(&'a [Tally], f64)>,
}

/// The allocation of an image held to a target as a whole (see the module
/// docs): from its pilot's tallies (`values` per pixel, pixel-major), each
/// pixel's weight (its solid angle and that of the pixels copying it; 0
/// for untraced pixels) and, for an observer on the ground, the pilot of
/// the ground view with the solid angle of the rows that show it (one
/// estimate, so one term of the sums): per pixel, and for the ground view,
/// the most any counted value needs.
pub fn image_pixels(pilot: &ImagePilot, target: &NoiseTarget, counted: &[bool]) -> (Vec<u64>, u64) {
    let ImagePilot {
        tallies,
        values,
        width,
        symmetry,
        weights,
        ground,
    } = *pilot;
    let values = values.max(1);
    let count = tallies.len() / values;
    let width = width.max(1);
    let height = count / width;
    let na = counted.len().max(1);
    let traced: Vec<bool> = (0..count)
        .map(|p| tallies[p * values].samples > 0 && weights.get(p).is_some_and(|&w| w > 0.0))
        .collect();
    // The pilot's mean and variance of I.
    let moments = |t: &Tally| -> Option<(f64, f64)> {
        if t.samples <= t.non_finite + 1 {
            return None;
        }
        let n = (t.samples - t.non_finite) as f64;
        let mean = t.sum[0] / n;
        let variance = ((t.sum_sq[0] - t.sum[0] * mean) / (n - 1.0)).max(0.0);
        (mean.is_finite() && variance.is_finite()).then_some((mean, variance))
    };
    let mut need = vec![0.0f64; count];
    let mut ground_need = 0.0f64;
    for v in (0..values).filter(|v| counted.get(v % na).copied().unwrap_or(true)) {
        let own: Vec<Option<(f64, f64)>> = (0..count)
            .map(|p| {
                if traced[p] {
                    moments(&tallies[p * values + v])
                } else {
                    None
                }
            })
            .collect();
        let view = ground.and_then(|(t, w)| Some((moments(t.get(v)?)?, w)));
        // S = Σ Ω·μ², and Σ √Ω·σ with each pixel's σ² the mean over its
        // traced neighbourhood.
        let mut signal: f64 = (0..count)
            .filter_map(|p| own[p].map(|(mean, _)| weights[p] * mean * mean))
            .sum();
        let mut sigma = vec![0.0; count];
        let mut spend = 0.0;
        for p in (0..count).filter(|&p| traced[p]) {
            let (i, j) = ((p % width) as i64, (p / width) as i64);
            let (mut sum, mut n) = (0.0, 0.0);
            for dj in -1..=1 {
                for di in -1..=1 {
                    let (x, y) = (i + di, j + dj);
                    if x < 0 || y < 0 || x >= width as i64 || y >= height as i64 {
                        continue;
                    }
                    let q = y as usize * width + symmetry.traced_column(width, x as usize);
                    if let Some((_, variance)) = own[q] {
                        sum += variance;
                        n += 1.0;
                    }
                }
            }
            if n > 0.0 {
                sigma[p] = (sum / n).sqrt();
                spend += weights[p].sqrt() * sigma[p];
            }
        }
        if let Some(((mean, variance), w)) = view {
            signal += w * mean * mean;
            spend += w.sqrt() * variance.sqrt();
        }
        if signal <= 0.0 {
            continue;
        }
        let lambda = spend / (target.relative_se * target.relative_se * signal);
        for p in (0..count).filter(|&p| traced[p]) {
            need[p] = need[p].max(lambda * sigma[p] * weights[p].sqrt());
        }
        if let Some(((_, variance), w)) = view {
            ground_need = ground_need.max(lambda * variance.sqrt() * w.sqrt());
        }
    }
    let pixels = (0..count)
        .map(|p| if traced[p] { clamp(need[p], target) } else { 0 })
        .collect();
    (pixels, clamp(ground_need, &ground_view(target)))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::film::tally::of_intensities as tally;

    const TARGET: NoiseTarget = NoiseTarget {
        relative_se: 0.1,
        pilot: 4,
        max_samples: 1000,
        albedos: crate::job::TargetAlbedos::All,
        per: crate::job::TargetScope::Pixel,
    };
    const ALL: &[bool] = &[true];

    #[test]
    fn the_need_is_the_relative_variance_over_the_target_squared() {
        // Mean 2, sample variance 16/3 (values 0, 4, 0, 4): (4/3) / 0.01.
        let t = tally(&[0.0, 4.0, 0.0, 4.0]);
        assert!((needed(&[t], 0.1, ALL) - 133.333_333_333_333_3).abs() < 1e-9);
        // The worst value sets the need; a zero mean is left out.
        let flat = tally(&[1.0, 1.0, 1.0, 1.0]);
        let zero = tally(&[0.0; 4]);
        assert!((needed(&[flat, t, zero], 0.1, ALL) - needed(&[t], 0.1, ALL)).abs() < 1e-12);
        assert_eq!(needed(&[zero], 0.1, ALL), 0.0);
        assert_eq!(single(&[t], &TARGET, ALL), 134);
        assert_eq!(single(&[flat], &TARGET, ALL), 4);
        // One bright sample in four: σ²/μ² = 4, to 1 %: 40,000, capped.
        let tight = NoiseTarget {
            relative_se: 0.01,
            ..TARGET
        };
        assert_eq!(single(&[tally(&[0.0, 0.0, 0.0, 1e6])], &tight, ALL), 1000);
    }

    #[test]
    fn a_pixel_takes_the_mean_need_of_its_neighbourhood() {
        // 4 × 3 pixels, one value each; pixel (1, 1) noisy (needs 400/3),
        // the others flat (need 0), (3, 2) untraced. A pixel whose
        // neighbourhood holds the noisy one takes 400/3 over the number of
        // traced pixels there: 4 at a corner (34), 6 on an edge (23), 9
        // around it (15, so the pilot's 16), 8 or 5 beside the untraced
        // one (17, 27); those out of its reach the pilot's count.
        let noisy = tally(&[0.0, 4.0, 0.0, 4.0]);
        let flat = tally(&[1.0, 1.0, 1.0, 1.0]);
        let mut t = vec![flat; 12];
        t[5] = noisy;
        t[11] = Tally::default();
        let target = NoiseTarget { pilot: 16, ..TARGET };
        let n = pixels(&t, 1, 4, Symmetry::None, &target, ALL);
        assert_eq!(n, vec![34, 23, 23, 16, 23, 16, 17, 16, 34, 23, 27, 0]);
    }

    #[test]
    fn a_mirrored_image_allocates_its_traced_half_as_the_whole_symmetric_one() {
        // 4 × 3 pixels whose pilot is mirror-symmetric (column i as column
        // 3 − i), one noisy pixel and its mirror image: traced alone, the
        // left half takes what the whole image gives it, the right none.
        let noisy = tally(&[0.0, 4.0, 0.0, 4.0]);
        let flat = tally(&[1.0, 1.0, 1.0, 1.0]);
        let mut whole = vec![flat; 12];
        whole[5] = noisy;
        whole[6] = noisy;
        let mut half = whole.clone();
        for row in half.chunks_mut(4) {
            row[2] = Tally::default();
            row[3] = Tally::default();
        }
        let target = NoiseTarget { pilot: 16, ..TARGET };
        let full = pixels(&whole, 1, 4, Symmetry::None, &target, ALL);
        let mirrored = pixels(&half, 1, 4, Symmetry::Mirror, &target, ALL);
        for p in 0..12 {
            assert_eq!(mirrored[p], if p % 4 < 2 { full[p] } else { 0 }, "pixel {p}");
        }
        // A pilot traced in every column allocates nothing to the mirrored ones.
        let again = pixels(&whole, 1, 4, Symmetry::Mirror, &target, ALL);
        assert_eq!(again, mirrored);
    }

    #[test]
    fn albedos_the_target_does_not_count_allocate_nothing() {
        // Two channels × two albedos, the albedo fastest: the first albedo's
        // values noisy (need 400/3 at 0.1), the second's flat. Counting
        // both, the noisy ones set the need; counting the second alone,
        // the flat ones do (0, so the pilot's count).
        let noisy = tally(&[0.0, 4.0, 0.0, 4.0]);
        let flat = tally(&[1.0, 1.0, 1.0, 1.0]);
        let values = [noisy, flat, noisy, flat];
        assert!((needed(&values, 0.1, &[true, true]) - 400.0 / 3.0).abs() < 1e-9);
        assert_eq!(needed(&values, 0.1, &[false, true]), 0.0);
        assert_eq!(single(&values, &TARGET, &[false, true]), TARGET.pilot);
        // A half-noisy second albedo alone sets it: (1/3) / 0.01.
        let half = tally(&[1.0, 3.0, 1.0, 3.0]);
        let values = [noisy, half, noisy, half];
        assert!((needed(&values, 0.1, &[false, true]) - 100.0 / 3.0).abs() < 1e-9);
        assert_eq!(pixels(&values, 4, 1, Symmetry::None, &TARGET, &[false, true]), vec![34]);
    }

    #[test]
    fn an_image_target_spends_by_deviation_times_root_solid_angle_and_meets_the_target_exactly() {
        // Three pixels in a row, the third untraced: the first two have
        // the same pilot (mean 2, σ² = 16/3), so the neighbourhood means
        // leave σ as it is; solid angles 1 and 4. The need is
        // n_k = λ·σ·√Ω_k with λ = Σ √Ω·σ / (t²·S), S = Σ Ω·μ².
        let a = tally(&[0.0, 4.0, 0.0, 4.0]);
        let b = tally(&[0.0, 4.0, 0.0, 4.0]);
        let weights = [1.0, 4.0, 0.0];
        let target = NoiseTarget {
            relative_se: 0.1,
            pilot: 2,
            max_samples: 1_000_000,
            per: crate::job::TargetScope::Image,
            ..TARGET
        };
        let tallies = [a, b, Tally::default()];
        let mut pilot = ImagePilot {
            tallies: &tallies,
            values: 1,
            width: 3,
            symmetry: Symmetry::None,
            weights: &weights,
            ground: None,
        };
        let (n, view) = image_pixels(&pilot, &target, ALL);
        let sigma = (16.0f64 / 3.0).sqrt();
        let signal = 1.0 * 4.0 + 4.0 * 4.0; // Σ Ω·μ²
        let lambda = (1.0 * sigma + 2.0 * sigma) / (0.01 * signal);
        assert_eq!(
            n,
            vec![(lambda * sigma).ceil() as u64, (lambda * sigma * 2.0).ceil() as u64, 0]
        );
        // The target met: Σ Ω·σ²/n = t²·S (to the rounding up of n).
        let noise: f64 = weights[..2]
            .iter()
            .zip(&n)
            .map(|(w, &k)| w * sigma * sigma / k as f64)
            .sum();
        assert!(noise <= 0.01 * signal && noise > 0.99 * 0.01 * signal, "{noise}");
        assert_eq!(view, target.pilot);
        // A ground view of solid angle 4 with the same pilot joins the sums
        // as one more term and takes its share.
        pilot.ground = Some((std::slice::from_ref(&a), 4.0));
        let (n2, view) = image_pixels(&pilot, &target, ALL);
        let lambda2 = (3.0 * sigma + 2.0 * sigma) / (0.01 * (signal + 16.0));
        assert_eq!(n2[0], (lambda2 * sigma).ceil() as u64);
        assert_eq!(view, (lambda2 * sigma * 2.0).ceil() as u64);
    }
}
