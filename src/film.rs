//! Rendering an image sensor: per pixel, `samples` paths through points of
//! the pixel (stratified jitter, box filter) or through its centre, each
//! sample's radiance weighted by dΩ/dA over the pixel's mean, so the pixel
//! holds the mean radiance over its solid angle. Each sample's Stokes
//! vector is referred to the pixel's frame (that of its centre direction,
//! carried to the sample's direction: [`crate::stokes_frame`]), so the frame
//! is continuous over the pixel, the zenith and nadir pixels included.
//! Pixels are rendered in parallel; each pixel's sums run in sample order,
//! so the image is bit-identical for any number of threads.

use rayon::prelude::*;

use crate::camera::{Camera, PixelFilter};
use crate::integrator::Scene;
use crate::render::SampleValues;
use crate::render::Tally;
use crate::sampler::Sampler;
use crate::stokes::Stokes;
use crate::stokes_frame::{StokesFrame, carry};

/// One image layer: a wavelength and an albedo, mean and standard error of
/// I, Q, U, V per pixel (row-major, row 0 at the top).
#[derive(Debug, Clone)]
pub struct ImageLayer {
    pub wavelength_nm: f64,
    pub albedo: f64,
    pub mean: [Vec<f64>; 4],
    pub se: [Vec<f64>; 4],
    /// Samples that gave a non-finite value (left out of the sums).
    pub non_finite: u64,
}

impl ImageLayer {
    /// A layer from its pixels' tallies.
    pub fn from_tallies(wavelength_nm: f64, albedo: f64, pixels: &[Tally], non_finite: u64) -> ImageLayer {
        let mut mean: [Vec<f64>; 4] = Default::default();
        let mut se: [Vec<f64>; 4] = Default::default();
        for t in pixels {
            let (m, e) = (t.mean(), t.standard_error());
            for k in 0..4 {
                mean[k].push(m[k]);
                se[k].push(e[k]);
            }
        }
        ImageLayer {
            wavelength_nm,
            albedo,
            mean,
            se,
            non_finite,
        }
    }
}

/// Mean dΩ/dA of every pixel of a camera (0 for pixels outside a fisheye's
/// circle); computed once per image.
pub fn pixel_weights(camera: &Camera) -> Vec<f64> {
    let (w, h) = camera.size();
    (0..w * h)
        .into_par_iter()
        .map(|k| camera.mean_jacobian(k % w, k / w))
        .collect()
}

/// How pixels are sampled: the camera, the pixels' mean dΩ/dA, the filter,
/// the Stokes frame (and the sun's direction, which the sun–view frame
/// needs), samples per pixel and the stream keys (seed, key).
#[derive(Clone, Copy)]
pub struct PixelSampling<'a> {
    pub camera: &'a Camera,
    pub weights: &'a [f64],
    pub filter: PixelFilter,
    pub frame: StokesFrame,
    pub sun: glam::DVec3,
    pub samples: u64,
    pub seed: u64,
    pub key: u64,
}

/// Renders every pixel: `radiance(direction, e1, sampler)` gives a sample's
/// `count` values referred to the axis `e1`; returns tallies `[value][pixel]` and the count
/// of non-finite samples. `progress` is called as pixels finish (from
/// worker threads).
pub fn render_pixels<R: SampleValues>(
    sampling: &PixelSampling,
    count: usize,
    progress: &(dyn Fn(u64) + Sync),
    radiance: impl Fn(glam::DVec3, glam::DVec3, &mut Sampler) -> R + Sync,
) -> (Vec<Vec<Tally>>, u64) {
    let mut per_pixel = vec![Tally::default(); sampling.weights.len() * count];
    render_pixels_into(sampling, 0..sampling.samples, &mut per_pixel, count, progress, radiance);
    split_values(&per_pixel, count)
}

/// Adds the samples `range` (sample indices, the same for every pixel) of
/// every pixel to `per_pixel` (pixel-major: `count` tallies per pixel).
/// Each pixel's tallies run in sample order, so adding 0..a and then a..b
/// gives bit for bit what adding 0..b at once gives. `progress` gets the
/// paths traced, as pixels finish.
pub fn render_pixels_into<R: SampleValues>(
    sampling: &PixelSampling,
    range: std::ops::Range<u64>,
    per_pixel: &mut [Tally],
    count: usize,
    progress: &(dyn Fn(u64) + Sync),
    radiance: impl Fn(glam::DVec3, glam::DVec3, &mut Sampler) -> R + Sync,
) {
    let (w, _) = sampling.camera.size();
    per_pixel
        .par_chunks_mut(count)
        .with_min_len(4)
        .enumerate()
        .for_each(|(k, tallies)| {
            if render_pixel(sampling, (k % w, k / w), k, range.clone(), tallies, &radiance) {
                progress(range.end - range.start);
            }
        });
}

/// Pixel-major tallies (`count` per pixel) as `[value][pixel]`, and the
/// count of non-finite samples (those of the first value: every value of a
/// sample shares its path).
pub fn split_values(per_pixel: &[Tally], count: usize) -> (Vec<Vec<Tally>>, u64) {
    let non_finite = per_pixel.iter().step_by(count.max(1)).map(|t| t.non_finite).sum();
    let tallies = (0..count)
        .map(|v| per_pixel.iter().skip(v).step_by(count).copied().collect())
        .collect();
    (tallies, non_finite)
}

/// Pixels that are traced (inside a fisheye's circle).
pub fn active_pixels(weights: &[f64]) -> u64 {
    weights.iter().filter(|w| **w > 0.0).count() as u64
}

/// One wavelength for every albedo of `scene` seen from `altitude_km`:
/// tallies `[albedo][pixel]` and the count of non-finite samples.
pub fn render_layers(
    scene: &Scene,
    sampling: &PixelSampling,
    altitude_km: f64,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Vec<Tally>>, u64) {
    render_pixels(sampling, scene.albedos.len(), progress, |v, e1, s| {
        scene.radiance_sample(altitude_km, v, e1, s)
    })
}

/// [`render_layers`] for the scene's first albedo.
pub fn render_layer(
    scene: &Scene,
    sampling: &PixelSampling,
    altitude_km: f64,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Tally>, u64) {
    let (mut t, n) = render_layers(scene, sampling, altitude_km, progress);
    (t.swap_remove(0), n)
}

/// Strata per side for `samples` per pixel (at most 16 × 16).
fn strata(samples: u64) -> u64 {
    ((samples as f64).sqrt() as u64).clamp(1, 16)
}

/// Adds samples `range` of one pixel to its `tallies`; false for a pixel
/// entirely outside the image's circle (zero, no samples).
fn render_pixel<R: SampleValues>(
    sampling: &PixelSampling,
    (i, j): (usize, usize),
    index: usize,
    range: std::ops::Range<u64>,
    tallies: &mut [Tally],
    radiance: &impl Fn(glam::DVec3, glam::DVec3, &mut Sampler) -> R,
) -> bool {
    let weight = sampling.weights[index];
    if weight <= 0.0 {
        return false;
    }
    // The pixel's frame: its centre's, carried to each sample's direction.
    let Some(centre) = sampling.camera.centre_ray(i, j) else {
        return false;
    };
    let centre_e1 = sampling.frame.axis(centre.direction, centre.azimuth, sampling.sun);
    let samples = sampling.samples;
    let m = strata(samples);
    let stratified = samples / (m * m) * (m * m);
    for s in range {
        let mut sampler = Sampler::new(&[sampling.seed, sampling.key, index as u64, s]);
        let (x, y) = match sampling.filter {
            PixelFilter::Center => (i as f64 + 0.5, j as f64 + 0.5),
            PixelFilter::Box => {
                let [u, v] = sampler.next2();
                if s < stratified {
                    // Full rounds of m × m strata, then plain jitter.
                    let cell = s % (m * m);
                    (
                        i as f64 + ((cell % m) as f64 + u) / m as f64,
                        j as f64 + ((cell / m) as f64 + v) / m as f64,
                    )
                } else {
                    (i as f64 + u, j as f64 + v)
                }
            }
        };
        match sampling.camera.ray_at(x, y) {
            None => tallies.iter_mut().for_each(|t| t.add(&Stokes::zero())),
            Some(ray) => {
                let e1 = carry(centre_e1, centre.direction, ray.direction);
                let l = radiance(ray.direction, e1, &mut sampler);
                let scale = match sampling.filter {
                    PixelFilter::Center => 1.0,
                    PixelFilter::Box => ray.jacobian / weight,
                };
                for (t, v) in tallies.iter_mut().zip(l.values()) {
                    t.add(&(*v * scale));
                }
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_grow_with_samples() {
        assert_eq!(strata(1), 1);
        assert_eq!(strata(15), 3);
        assert_eq!(strata(100_000), 16);
    }
}
