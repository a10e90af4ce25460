//! Rendering an image sensor: per pixel, `samples` paths through points of
//! the pixel (stratified jitter, box filter) or through its centre, each
//! sample's radiance weighted by dΩ/dA over the pixel's mean, so the pixel
//! holds the mean radiance over its solid angle. Pixels are rendered in
//! parallel; each pixel's sums run in sample order, so the image is
//! bit-identical for any number of threads.

use rayon::prelude::*;

use crate::camera::{Camera, PixelFilter};
use crate::integrator::Scene;
use crate::render::SampleValues;
use crate::render::Tally;
use crate::sampler::Sampler;
use crate::spectral::SpectralScene;
use crate::stokes::Stokes;

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
/// samples per pixel and the stream keys (seed, key).
#[derive(Clone, Copy)]
pub struct PixelSampling<'a> {
    pub camera: &'a Camera,
    pub weights: &'a [f64],
    pub filter: PixelFilter,
    pub samples: u64,
    pub seed: u64,
    pub key: u64,
}

/// Renders every pixel: `radiance(direction, azimuth, sampler)` gives a
/// sample's `count` values; returns tallies `[value][pixel]` and the count
/// of non-finite samples. `progress` is called as pixels finish (from
/// worker threads).
pub fn render_pixels<R: SampleValues>(
    sampling: &PixelSampling,
    count: usize,
    progress: &(dyn Fn(u64) + Sync),
    radiance: impl Fn(glam::DVec3, f64, &mut Sampler) -> R + Sync,
) -> (Vec<Vec<Tally>>, u64) {
    let (w, _) = sampling.camera.size();
    let per_pixel: Vec<Vec<Tally>> = (0..sampling.weights.len())
        .into_par_iter()
        .with_min_len(4)
        .map(|k| {
            let t = render_pixel(sampling, (k % w, k / w), k, count, &radiance);
            progress(1);
            t
        })
        .collect();
    let non_finite = per_pixel.iter().map(|t| t.first().map_or(0, |x| x.non_finite)).sum();
    let tallies = (0..count).map(|v| per_pixel.iter().map(|t| t[v]).collect()).collect();
    (tallies, non_finite)
}

/// One wavelength for every albedo of `scene` seen from `altitude_km`:
/// tallies `[albedo][pixel]` and the count of non-finite samples.
pub fn render_layers(
    scene: &Scene,
    sampling: &PixelSampling,
    altitude_km: f64,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Vec<Tally>>, u64) {
    render_pixels(sampling, scene.albedos.len(), progress, |v, phi, s| {
        scene.radiance_sample(altitude_km, v, phi, s)
    })
}

/// Every wavelength and albedo of `scene` along shared spectral paths:
/// tallies `[wavelength·albedos + albedo][pixel]`.
pub fn render_layers_spectral(
    scene: &SpectralScene,
    sampling: &PixelSampling,
    altitude_km: f64,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Vec<Tally>>, u64) {
    let count = scene.media.len() * scene.albedos.len();
    render_pixels(sampling, count, progress, |v, phi, s| {
        scene.radiance_sample(altitude_km, v, phi, s)
    })
}

/// [`render_layers`] for the scene's first albedo.
#[allow(clippy::too_many_arguments)]
pub fn render_layer(
    scene: &Scene,
    camera: &Camera,
    weights: &[f64],
    filter: PixelFilter,
    altitude_km: f64,
    samples: u64,
    seed: u64,
    key: u64,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Tally>, u64) {
    let sampling = PixelSampling {
        camera,
        weights,
        filter,
        samples,
        seed,
        key,
    };
    let (mut t, n) = render_layers(scene, &sampling, altitude_km, progress);
    (t.swap_remove(0), n)
}

/// Strata per side for `samples` per pixel (at most 16 × 16).
fn strata(samples: u64) -> u64 {
    ((samples as f64).sqrt() as u64).clamp(1, 16)
}

fn render_pixel<R: SampleValues>(
    sampling: &PixelSampling,
    (i, j): (usize, usize),
    index: usize,
    count: usize,
    radiance: &impl Fn(glam::DVec3, f64, &mut Sampler) -> R,
) -> Vec<Tally> {
    let mut tallies = vec![Tally::default(); count];
    let weight = sampling.weights[index];
    if weight <= 0.0 {
        // Entirely outside the image's circle: zero, no samples.
        return tallies;
    }
    let samples = sampling.samples;
    let m = strata(samples);
    let stratified = samples / (m * m) * (m * m);
    for s in 0..samples {
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
                let l = radiance(ray.direction, ray.azimuth, &mut sampler);
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
    tallies
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
