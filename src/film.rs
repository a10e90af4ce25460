//! Rendering an image sensor: per pixel, `samples` paths through points of
//! the pixel (stratified jitter, box filter) or through its centre, each
//! sample's radiance weighted by dΩ/dA over the pixel's mean, so the pixel
//! holds the mean radiance over its solid angle. Pixels are rendered in
//! parallel; each pixel's sums run in sample order, so the image is
//! bit-identical for any number of threads.

use rayon::prelude::*;

use crate::camera::{Camera, PixelFilter};
use crate::integrator::Scene;
use crate::render::Tally;
use crate::sampler::Sampler;

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

/// Renders one wavelength for every albedo of the scene: `scene` seen by
/// `camera` from `altitude_km`, with streams keyed by (seed, key, pixel,
/// sample); tallies `[albedo][pixel]` and the count of non-finite samples.
/// `progress` is called with the number of pixels finished (from worker
/// threads).
#[allow(clippy::too_many_arguments)]
pub fn render_layers(
    scene: &Scene,
    camera: &Camera,
    weights: &[f64],
    filter: PixelFilter,
    altitude_km: f64,
    samples: u64,
    seed: u64,
    key: u64,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Vec<Tally>>, u64) {
    let (w, _) = camera.size();
    let per_pixel: Vec<Vec<Tally>> = (0..weights.len())
        .into_par_iter()
        .with_min_len(4)
        .map(|k| {
            let t = render_pixel(
                scene,
                camera,
                weights[k],
                filter,
                altitude_km,
                (k % w, k / w),
                samples,
                [seed, key, k as u64],
            );
            progress(1);
            t
        })
        .collect();
    let non_finite = per_pixel.iter().flatten().map(|t| t.non_finite).sum();
    let tallies = (0..scene.albedos.len())
        .map(|a| per_pixel.iter().map(|t| t[a]).collect())
        .collect();
    (tallies, non_finite)
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
    let (mut t, n) = render_layers(
        scene,
        camera,
        weights,
        filter,
        altitude_km,
        samples,
        seed,
        key,
        progress,
    );
    (t.swap_remove(0), n)
}

/// Strata per side for `samples` per pixel (at most 16 × 16).
fn strata(samples: u64) -> u64 {
    ((samples as f64).sqrt() as u64).clamp(1, 16)
}

#[allow(clippy::too_many_arguments)]
fn render_pixel(
    scene: &Scene,
    camera: &Camera,
    weight: f64,
    filter: PixelFilter,
    altitude_km: f64,
    (i, j): (usize, usize),
    samples: u64,
    keys: [u64; 3],
) -> Vec<Tally> {
    let mut tallies = vec![Tally::default(); scene.albedos.len()];
    if weight <= 0.0 {
        // Entirely outside the image's circle: zero, no samples.
        return tallies;
    }
    let m = strata(samples);
    let stratified = samples / (m * m) * (m * m);
    for s in 0..samples {
        let mut sampler = Sampler::new(&[keys[0], keys[1], keys[2], s]);
        let (x, y) = match filter {
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
        match camera.ray_at(x, y) {
            None => tallies.iter_mut().for_each(|t| t.add(&crate::stokes::Stokes::zero())),
            Some(ray) => {
                let l = scene.radiance_sample(altitude_km, ray.direction, ray.azimuth, &mut sampler);
                let scale = match filter {
                    PixelFilter::Center => 1.0,
                    PixelFilter::Box => ray.jacobian / weight,
                };
                for (t, v) in tallies.iter_mut().zip(l.as_slice()) {
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
