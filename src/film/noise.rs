//! The noise a render reached: per channel and albedo, the median, 99th
//! percentile and largest relative standard error of I over the pixels or
//! directions (those with a non-zero mean), how many miss a target, and
//! the samples they took.

use crate::film::quantile::quantile;
use crate::film::tally::Tally;

/// The noise of one channel and albedo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// Pixels or directions with a non-zero mean I (the others have no
    /// relative error).
    pub counted: usize,
    pub median: f64,
    pub p99: f64,
    pub max: f64,
    /// Of those counted, how many have a relative error above the target.
    pub above: usize,
    /// Samples per pixel or direction (traced ones): least, median, most.
    pub samples: [u64; 3],
    /// An image's noise as a whole, √(Σ Ω·se² / Σ Ω·I²) over its pixels
    /// (solid angle Ω): what `render.noise_target_per = "image"` targets;
    /// `None` for directions.
    pub image_rel_noise: Option<f64>,
}

impl Noise {
    /// The noise of `tallies` (one per pixel or direction; untraced pixels
    /// have no samples and are left out) against `target`.
    pub fn of(tallies: &[Tally], target: f64) -> Noise {
        let mut rel: Vec<f64> = tallies
            .iter()
            .filter(|t| t.samples > 0 && t.mean()[0] != 0.0)
            .map(|t| t.standard_error()[0] / t.mean()[0].abs())
            .collect();
        let mut samples: Vec<f64> = tallies
            .iter()
            .filter(|t| t.samples > 0)
            .map(|t| t.samples as f64)
            .collect();
        let counted = rel.len();
        let above = rel.iter().filter(|&&r| r > target).count();
        let (median, p99, max) = if rel.is_empty() {
            (0.0, 0.0, 0.0)
        } else {
            (
                quantile(&mut rel, 0.5),
                quantile(&mut rel, 0.99),
                quantile(&mut rel, 1.0),
            )
        };
        let samples = if samples.is_empty() {
            [0; 3]
        } else {
            [0.0, 0.5, 1.0].map(|q| quantile(&mut samples, q) as u64)
        };
        Noise {
            counted,
            median,
            p99,
            max,
            above,
            samples,
            image_rel_noise: None,
        }
    }

    /// The same, with the image's noise as a whole: `tallies` are an
    /// image's pixels and `solid_angle(p)` the solid angle of pixel `p`.
    pub fn of_image(tallies: &[Tally], target: f64, solid_angle: impl Fn(usize) -> f64) -> Noise {
        let (mut noise, mut signal) = (0.0, 0.0);
        for (p, t) in tallies.iter().enumerate().filter(|(_, t)| t.samples > 0) {
            let w = solid_angle(p);
            noise += w * t.standard_error()[0].powi(2);
            signal += w * t.mean()[0].powi(2);
        }
        Noise {
            image_rel_noise: (signal > 0.0).then(|| (noise / signal).sqrt()),
            ..Noise::of(tallies, target)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::film::tally::of_intensities as tally;

    #[test]
    fn relative_errors_of_the_traced_pixels_with_a_mean() {
        // Relative errors: (1/√2)/1 ... from values (0, 2): mean 1, se 1.
        let a = tally(&[0.0, 2.0]);
        let b = tally(&[1.0, 1.0, 1.0, 1.0]);
        let zero = tally(&[0.0, 0.0, 0.0]);
        let n = Noise::of(&[a, b, zero, Tally::default()], 0.5);
        assert_eq!(n.counted, 2);
        assert_eq!((n.median, n.max), (1.0, 1.0));
        assert_eq!(n.above, 1);
        // As an image with solid angles 1, 3, 1, 1: √((1·1 + 3·0) / (1·1 + 3·1)).
        let image = Noise::of_image(&[a, b, zero, Tally::default()], 0.5, |p| [1.0, 3.0, 1.0, 1.0][p]);
        assert_eq!(image.image_rel_noise, Some(0.5));
        assert_eq!(n.image_rel_noise, None);
        assert_eq!(n.samples, [2, 3, 4]);
    }
}
