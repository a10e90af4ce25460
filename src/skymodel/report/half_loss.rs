//! What storing the radiance in halves costs: per image, the SNR of the
//! dataset as written against the same fit kept in `f32`
//! ([`Dataset::unrounded`](crate::skymodel::dataset::Dataset::unrounded)),
//! both evaluated with the runtime's semantics at the pixel centres of a
//! sphere image, with solid-angle weights. Infinite where the two agree
//! exactly.

use rayon::prelude::*;

use super::score::parameters_at;
use crate::skymodel::fit::SphereImage;
use crate::skymodel::fit::renders::RenderGrid;
use crate::skymodel::runtime::Model;

/// 10·log10(Σ w·L² / Σ w·(L_half − L)²) per image of `grid`, in the
/// dataset's order (visibility, albedo, altitude, elevation, channel), at
/// the pixels of a `width` × `width/2` sphere.
pub fn half_float_snr_db(halves: &Model, unrounded: &Model, grid: &RenderGrid, width: usize) -> Vec<f64> {
    let like = SphereImage::zeros(width, (width / 2).max(1));
    let (n_alt, n_elev) = (grid.altitudes_km.len(), grid.elevations_deg.len());
    let mut images = Vec::new();
    for v in 0..grid.visibilities_km.len() {
        for &albedo in &grid.albedos {
            for h in 0..n_alt {
                for e in 0..n_elev {
                    for &lambda in &grid.wavelengths_nm {
                        images.push((grid.config(v, h, e), albedo, lambda));
                    }
                }
            }
        }
    }
    images
        .par_iter()
        .map(|&(config, albedo, lambda)| {
            let (mut signal, mut error) = (0.0, 0.0);
            for j in 0..like.height {
                let w = like.solid_angle(j);
                for i in 0..like.width {
                    let p = parameters_at(like.direction(i, j), config, albedo);
                    let (l, l_half) = (unrounded.sky_radiance(&p, lambda), halves.sky_radiance(&p, lambda));
                    signal += w * l * l;
                    error += w * (l_half - l) * (l_half - l);
                }
            }
            if error > 0.0 {
                10.0 * (signal / error).log10()
            } else {
                f64::INFINITY
            }
        })
        .collect()
}
