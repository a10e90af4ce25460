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

#[cfg(test)]
mod tests {
    use super::*;

    use crate::film::tally::of_intensities as tally;

    const TARGET: NoiseTarget = NoiseTarget {
        relative_se: 0.1,
        pilot: 4,
        max_samples: 1000,
        albedos: crate::job::TargetAlbedos::All,
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
}
