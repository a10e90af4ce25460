//! Scattering directions drawn in part toward the sunlit air, for a set
//! or low sun (below the observer's horizon, or less than 10° above it for
//! channels of little extinction; with sun-aware connections, in spherical
//! geometry).
//!
//! With the sun low or set, much of the light reaching a vertex arrives
//! from the sunlit air above the Earth's shadow, seen at small scattering
//! angles where the aerosol's forward peak (the stratospheric layer's too)
//! scatters strongly. The phase function at the vertex knows nothing of
//! that, so those directions are drawn rarely and weigh much: looking at
//! the zenith from the ground with the sun 4.2° down (500 nm, 100,000
//! paths), the top 0.1 % of the paths carried 64 % of the variance of I;
//! of the 25 largest, the half whose largest term could be traced back got
//! it at a sun-aware point at 15–33 km on a flight heading within a few
//! degrees of the horizon toward the sun, with a phase function of 2–11
//! there. Where that air lies depends on the vertex's altitude: steeply up
//! from deep in the shadow, near the horizon toward the sun from above it.
//!
//! So once per scene the lobe tabulates, per tracked layer, the sunlit
//! single scattering a flight from there would meet,
//! F(h, ω) = ∫ c̄·e^(−τ)·e^(−τ_sun) dt along ω from the layer's middle on
//! the observer's vertical (the integral of the sun-aware density,
//! [`FlightDensity::sunlit_integral`], at the followed channels' centre
//! wavelengths, averaged over them), on a grid of directions in the local
//! frame: [`SUN_LOBE_MU_BINS`] bins of the cosine of the zenith angle by
//! [`SUN_LOBE_PHI_BINS`] bins of the azimuth from the sun's (0 to π,
//! mirrored: the sky is symmetric about the sun's vertical plane), each
//! bin its centre's value plus [`SUN_LOBE_FLOOR`] of the layer's mean. A
//! vertex elsewhere reads its layer's row in its own local frame (its own
//! vertical and the sun's azimuth there). A direction is drawn by bin (in
//! proportion) and then uniformly in the bin's cosine and azimuth, so its
//! density is the bin's share over its solid angle.
//!
//! A reflecting ground has a row of its own, built the same way from the
//! ground itself for directions above the horizon only, holding √(F·μ):
//! a path reflected there goes on from the row with
//! [`GROUND_LOBE_SHARE`] and otherwise by the cosine, weighed by the
//! cosine's density over the mixture's (at most 1/(1 − share)).
//!
//! A scattering direction comes from the lobe with probability
//! [`SUN_LOBE_SHARE`], and otherwise from the channels' phase functions.
//! Every channel weighs the direction by its matrix over the mixture of
//! both densities (one-sample MIS, balance heuristic), so the table is a
//! density to draw from, not part of the integrand: the estimate stays
//! unbiased whatever its accuracy, and no weight exceeds 1/(1 − share)
//! times that of the phase functions alone. The table depends on the scene
//! alone, so renders stay bit-identical across threads, resumes and
//! shards. Where the sensor's first vertex is split, both branches come
//! from the lobe together (independently) or from the phase functions
//! together (the second a quarter turn of the first): each branch's
//! direction alone then has the mixture's density.
//!
//! It replaced a fixed Henyey–Greenstein lobe (g = 0.8, axis 5° above the
//! horizon toward the sun's azimuth, same share): on the grid benchmark's
//! twilight tasks (`bench --grid`) the variance side of the cost (paths ×
//! the factor to the target) came out 0.76–0.89 times at 20 km visibility,
//! 0.79–1.02 at 131.8 km, a path 1.08–1.16 times as dear (paths into the
//! sunlit air live longer); the dearest task (−4.2°, 15 km) 0.87 times in
//! all (docs/design-sun.md, "Scattering toward the sunlit air"). With the sun up it
//! serves only channels of little column extinction
//! ([`SUN_LOBE_SUN_UP_MAX_COLUMN`]) below
//! [`SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG`], limits chosen with the fixed
//! lobe (the tabulated one changed the variance side of the sun-at-2°
//! tasks by 0.95–1.00).
//!
//! [`FlightDensity::sunlit_integral`]: crate::transport::flight_density::FlightDensity::sunlit_integral

use std::f64::consts::PI;

use glam::DVec3;

use crate::sampling::sampler::Sampler;

/// The share of scattering directions drawn from the lobe.
pub const SUN_LOBE_SHARE: f64 = 0.3;

/// With the sun up, the lobe serves only a scene whose channels' column
/// extinctions (at their centre wavelengths) are all at most this, and
/// only below [`SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG`]. On directions jobs in
/// the sky model grid's atmosphere (20 km visibility, roulette from 0.03,
/// time × the worst band's variance per path, with the fixed lobe) the
/// group of 480–760 nm (column extinction 0.27–0.57) cost about half with
/// it at 2° (ground 8.6 against 16.8, 15 km 1.4 against 1.7), and the group
/// of 320–480 nm (up to 1.37, 320–360 nm) 1.8 times more from the ground
/// (24.2 against 13.7), its long horizontal paths opaque (docs/design-sun.md, "Sun
/// connections at twilight"). 0.7 lies between the largest column
/// extinction of the 480–760 nm group at 20 km visibility (0.57, 480–520
/// nm) and that of the 320–480 nm group at 131.8 km (0.81, 320–360 nm),
/// the grid's extremes.
pub const SUN_LOBE_SUN_UP_MAX_COLUMN: f64 = 0.7;

/// With the sun up, the lobe is used only below this elevation (°), where
/// sun-aware connections are (`SunSampling::Auto`): with the fixed lobe a
/// 500 nm band gained from it at 2° and 10° (variance per path 0.336 →
/// 0.278, 0.572 → 0.503) and lost at 45° (0.156 → 0.180).
pub const SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG: f64 = 10.0;

/// Bins of the cosine of the zenith angle, from −1 to 1.
pub const SUN_LOBE_MU_BINS: usize = 32;

/// Bins of the azimuth from the sun's, from 0 to π (mirrored to −π).
pub const SUN_LOBE_PHI_BINS: usize = 16;

/// Every bin's value is raised by this share of its layer's mean, so that
/// no direction's density is 0 within the table itself.
pub const SUN_LOBE_FLOOR: f64 = 0.05;

/// Bins per row of the table.
pub(super) const SUN_LOBE_BINS: usize = SUN_LOBE_MU_BINS * SUN_LOBE_PHI_BINS;

const BINS: usize = SUN_LOBE_BINS;

/// The share of directions up from a reflecting ground drawn from the
/// table's ground row ([`SunLobes::ground_at`]); the rest are drawn by
/// the cosine. The row holds √(F·μ) from the ground (F as for the layers,
/// μ the cosine a Lambertian ground weighs a direction by): the square
/// root tempers the row's peak toward the sun's horizon. Measured on
/// 2026-11-28 (docs/design-sun.md, "Scattering toward the sunlit air"): the paths
/// to the target 0.94-0.97 times as many (geometric means over the four
/// −4.2° tasks at three seeds, over the −1° and 2° tasks at one), the
/// 131.8 km −4.2° task from 15 km 0.82 times at every seed, a path
/// 1.00-1.01 times as dear; a row of F·μ itself 0.95 and 1.07 times
/// (heavier tails at 700-740 nm from the ground).
pub const GROUND_LOBE_SHARE: f64 = 0.3;
const D_MU: f64 = 2.0 / SUN_LOBE_MU_BINS as f64;
const D_PHI: f64 = PI / SUN_LOBE_PHI_BINS as f64;

/// The lobe's table: its rows, one per tracked layer, and the ground's.
#[derive(Debug, Clone)]
pub(super) struct SunLobes {
    /// Per layer, the cumulative shares of its bins (`BINS + 1` values
    /// from 0 to 1; bin b = μ bin · PHI_BINS + φ bin).
    cdf: Vec<f64>,
    /// The ground's row, for directions up from a reflecting ground: its
    /// bins below the horizon are empty.
    ground: Vec<f64>,
}

impl SunLobes {
    /// The values `value(layer, μ, φ)` at each bin's centre (μ the cosine
    /// of the zenith angle, φ the azimuth from the sun's, in [0, π]), for
    /// `layers` layers, row by row (non-finite or negative ones as 0).
    pub(super) fn values(layers: usize, mut value: impl FnMut(usize, f64, f64) -> f64) -> Vec<f64> {
        let mut out = Vec::with_capacity(layers * BINS);
        for layer in 0..layers {
            for b in 0..BINS {
                let (i, j) = (b / SUN_LOBE_PHI_BINS, b % SUN_LOBE_PHI_BINS);
                let mu = -1.0 + (i as f64 + 0.5) * D_MU;
                let phi = (j as f64 + 0.5) * D_PHI;
                let f = value(layer, mu, phi);
                out.push(if f.is_finite() && f > 0.0 { f } else { 0.0 });
            }
        }
        out
    }

    /// The table from the values of [`SunLobes::values`], one row per
    /// layer, and the ground's row `ground` (its bins below the horizon
    /// are left empty whatever their values).
    pub(super) fn from_values(layers: usize, values: &[f64], ground: &[f64]) -> SunLobes {
        let mut cdf = Vec::with_capacity(layers * (BINS + 1));
        for row in values.chunks(BINS).take(layers) {
            push_row(&mut cdf, row, 0);
        }
        let mut ground_cdf = Vec::with_capacity(BINS + 1);
        push_row(&mut ground_cdf, ground, UPPER_FIRST_BIN);
        SunLobes {
            cdf,
            ground: ground_cdf,
        }
    }

    /// The table from the values `value(layer, μ, φ)` at each bin's centre.
    #[cfg(test)]
    pub(super) fn new(layers: usize, mut value: impl FnMut(usize, f64, f64) -> f64) -> SunLobes {
        let values = SunLobes::values(layers + 1, &mut value);
        SunLobes::from_values(layers, &values[..layers * BINS], &values[layers * BINS..])
    }

    /// The lobe at a vertex in tracked layer `layer` whose local vertical
    /// is `up` (unit), for the direction toward the sun `sun` (unit).
    pub(super) fn at(&self, layer: usize, up: DVec3, sun: DVec3) -> SunLobe<'_> {
        let rows = self.cdf.len() / (BINS + 1);
        let layer = layer.min(rows - 1);
        SunLobe {
            cdf: &self.cdf[layer * (BINS + 1)..(layer + 1) * (BINS + 1)],
            frame: LocalFrame::new(up, sun),
        }
    }

    /// The lobe up from a ground vertex whose local vertical is `up`
    /// (unit), for the direction toward the sun `sun` (unit): it draws
    /// only above the horizon.
    pub(super) fn ground_at(&self, up: DVec3, sun: DVec3) -> SunLobe<'_> {
        SunLobe {
            cdf: &self.ground,
            frame: LocalFrame::new(up, sun),
        }
    }
}

/// The first bin above the horizon (μ > 0).
const UPPER_FIRST_BIN: usize = SUN_LOBE_MU_BINS / 2 * SUN_LOBE_PHI_BINS;

/// Appends the cumulative shares of `row`'s bins from bin `first` on
/// (those before it empty), each raised by [`SUN_LOBE_FLOOR`] of their
/// mean; a row with nothing in them draws uniformly over them.
fn push_row(cdf: &mut Vec<f64>, row: &[f64], first: usize) {
    let open = &row[first..BINS];
    let mean = open.iter().sum::<f64>() / open.len() as f64;
    let floor = if mean > 0.0 { SUN_LOBE_FLOOR * mean } else { 1.0 };
    let total = open.iter().map(|v| v + floor).sum::<f64>();
    cdf.extend(std::iter::repeat_n(0.0, first + 1));
    let mut acc = 0.0;
    for v in open {
        acc += (v + floor) / total;
        cdf.push(acc);
    }
    // Exactly 1 at the end whatever the rounding.
    *cdf.last_mut().expect("a row was pushed") = 1.0;
}

/// A vertex's frame: its vertical, the horizontal toward the sun's
/// azimuth (any where the sun is at the zenith or nadir), and a quarter
/// turn of that.
#[derive(Debug, Clone, Copy)]
pub(super) struct LocalFrame {
    up: DVec3,
    east: DVec3,
    north: DVec3,
}

impl LocalFrame {
    /// The frame at a vertex whose local vertical is `up` (unit), for the
    /// direction toward the sun `sun` (unit).
    pub(super) fn new(up: DVec3, sun: DVec3) -> LocalFrame {
        let horizontal = sun - sun.dot(up) * up;
        let len = horizontal.length();
        let east = if len > 1e-12 {
            horizontal / len
        } else {
            up.any_orthonormal_vector()
        };
        LocalFrame {
            up,
            east,
            north: up.cross(east),
        }
    }

    /// The direction of zenith-angle cosine `mu` and azimuth `side`·`phi`
    /// from the sun's (`side` ±1).
    pub(super) fn direction(&self, mu: f64, phi: f64, side: f64) -> DVec3 {
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        let (sp, cp) = phi.sin_cos();
        s * cp * self.east + side * s * sp * self.north + mu * self.up
    }
}

/// The lobe at one vertex: its layer's row, in its local frame.
#[derive(Debug, Clone, Copy)]
pub(super) struct SunLobe<'a> {
    cdf: &'a [f64],
    frame: LocalFrame,
}

impl SunLobe<'_> {
    /// A propagation direction drawn from the lobe (three uniform
    /// variates).
    pub(super) fn sample(&self, sampler: &mut Sampler) -> DVec3 {
        let [u0, u1] = sampler.next2();
        let u = [u0, u1, sampler.next_f64()];
        // The bin by its share; what is left of u[0] inside the bin picks
        // the mirror side.
        let b = (self.cdf.partition_point(|&c| c <= u[0]) - 1).min(BINS - 1);
        let (lo, hi) = (self.cdf[b], self.cdf[b + 1]);
        let side = if hi > lo && (u[0] - lo) / (hi - lo) >= 0.5 {
            -1.0
        } else {
            1.0
        };
        let (i, j) = (b / SUN_LOBE_PHI_BINS, b % SUN_LOBE_PHI_BINS);
        let mu = (-1.0 + (i as f64 + u[1]) * D_MU).clamp(-1.0, 1.0);
        self.frame.direction(mu, (j as f64 + u[2]) * D_PHI, side)
    }

    /// 4π times the lobe's density per steradian of propagation direction
    /// `d` (the scale of the phase functions' P11).
    pub(super) fn density_4pi(&self, d: DVec3) -> f64 {
        let f = &self.frame;
        let mu = d.dot(f.up).clamp(-1.0, 1.0);
        let phi = d.dot(f.north).abs().atan2(d.dot(f.east));
        let i = (((mu + 1.0) / D_MU) as usize).min(SUN_LOBE_MU_BINS - 1);
        let j = ((phi / D_PHI) as usize).min(SUN_LOBE_PHI_BINS - 1);
        let b = i * SUN_LOBE_PHI_BINS + j;
        // Both mirror halves: a solid angle of 2·Δμ·Δφ.
        4.0 * PI * (self.cdf[b + 1] - self.cdf[b]) / (2.0 * D_MU * D_PHI)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table peaked toward the sun's horizon and up, from the values of
    /// a smooth function, in its layer 0 and its ground row; layer 1 sees
    /// no sunlit air.
    fn table() -> SunLobes {
        SunLobes::new(2, |layer, mu, phi| {
            if layer != 1 {
                (1.0 + 4.0 * mu.max(0.0)) * (1.0 + 10.0 * (-phi).exp())
            } else {
                0.0
            }
        })
    }

    #[test]
    fn the_lobe_draws_what_its_density_says() {
        // Histogram of 400,000 draws over a coarse grid of cos(zenith) ×
        // signed azimuth against the density integrated over each cell
        // (on a fine grid whose cells lie inside both the table's bins and
        // the histogram's cells, so exactly), each within 4.5 binomial
        // standard errors; every draw is a unit vector; the density integrates to
        // 4π over the sphere. Row 2 is the ground's: it draws above the
        // horizon only, and its density is 0 below it.
        let up = DVec3::new(0.2, -0.1, 1.0).normalize();
        let sun = DVec3::new(0.7, 0.5, -0.1).normalize();
        let g = table();
        for layer in 0..3 {
            let at = if layer < 2 {
                g.at(layer, up, sun)
            } else {
                g.ground_at(up, sun)
            };
            let (nm, np) = (10usize, 12usize);
            let cell = |d: DVec3| {
                let mu = d.dot(at.frame.up).clamp(-1.0, 1.0);
                let phi = d.dot(at.frame.north).atan2(d.dot(at.frame.east));
                let i = (((mu + 1.0) / 2.0 * nm as f64) as usize).min(nm - 1);
                let j = (((phi + PI) / (2.0 * PI) * np as f64) as usize).min(np - 1);
                i * np + j
            };
            let n = 400_000;
            let mut counts = vec![0u64; nm * np];
            let mut s = Sampler::new(&[43, layer as u64]);
            for _ in 0..n {
                let d = at.sample(&mut s);
                assert!((d.length() - 1.0).abs() < 1e-12);
                assert!(
                    layer < 2 || d.dot(up) >= 0.0,
                    "the ground's row drew {d} below the horizon"
                );
                counts[cell(d)] += 1;
            }
            // The expected share of each cell, and the total, by a fine
            // grid of directions (solid angle dμ·dφ).
            let (fm, fp) = (320usize, 480usize);
            let mut expected = vec![0.0; nm * np];
            let mut total = 0.0;
            for a in 0..fm {
                for b in 0..fp {
                    let mu = -1.0 + (a as f64 + 0.5) * 2.0 / fm as f64;
                    let phi = -PI + (b as f64 + 0.5) * 2.0 * PI / fp as f64;
                    let s = (1.0 - mu * mu).sqrt();
                    let d = s * phi.cos() * at.frame.east + s * phi.sin() * at.frame.north + mu * at.frame.up;
                    let w = at.density_4pi(d) / (4.0 * PI) * (2.0 / fm as f64) * (2.0 * PI / fp as f64);
                    expected[cell(d)] += w;
                    total += w;
                }
            }
            assert!(
                (total - 1.0).abs() < 1e-9,
                "layer {layer}: the density integrates to {total}"
            );
            for (c, (&k, &p)) in counts.iter().zip(&expected).enumerate() {
                let mean = n as f64 * p;
                let se = (n as f64 * p * (1.0 - p)).sqrt();
                // (A cell the density leaves empty must get no draw.)
                assert!(
                    (k as f64 - mean).abs() <= 4.5 * se,
                    "layer {layer}, cell {c}: {k} draws against {mean:.1} ± {se:.1}"
                );
            }
        }
    }

    #[test]
    fn the_lobe_follows_its_table_and_mirrors_it() {
        let g = table();
        let up = DVec3::Z;
        let at = g.at(0, up, DVec3::new(1.0, 0.0, -0.07).normalize());
        let dir = |mu: f64, phi: f64| {
            let s = (1.0 - mu * mu).sqrt();
            DVec3::new(s * phi.cos(), s * phi.sin(), mu)
        };
        // Toward the sun's azimuth and up beats away and down, and the
        // mirror image has the same density.
        assert!(at.density_4pi(dir(0.5, 0.05)) > 5.0 * at.density_4pi(dir(-0.5, 3.0)));
        assert_eq!(at.density_4pi(dir(0.3, 1.0)), at.density_4pi(dir(0.3, -1.0)));
        // A layer with no sunlit air draws uniformly: 1 everywhere.
        let dark = g.at(1, up, DVec3::X);
        for d in [dir(0.9, 0.1), dir(-0.9, 2.0), dir(0.0, -3.0)] {
            assert!((dark.density_4pi(d) - 1.0).abs() < 1e-12);
        }
    }
}
