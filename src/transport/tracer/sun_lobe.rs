//! Scattering directions drawn in part toward the sun's horizon, for a set
//! or low sun (below the observer's horizon, or less than 10° above it for
//! channels of little extinction; with sun-aware connections, in spherical
//! geometry).
//!
//! With the sun low or set, much of the light reaching a vertex arrives
//! along long, nearly horizontal paths toward the sun's azimuth: sunlit air
//! above the Earth's shadow seen at small scattering angles, where the
//! aerosol's forward peak (the stratospheric layer's too) scatters strongly.
//! The phase function at the vertex knows nothing of that, so those
//! directions are drawn rarely and weigh much: looking at the zenith from
//! the ground with the sun 4.2° down (500 nm, 100,000 paths), the top 0.1 %
//! of the paths carried 64 % of the variance of I; of the 25 largest, the
//! half whose largest term could be traced back (the rest came through the
//! split first vertex's second branch) got it at a sun-aware point at 15–33
//! km on a flight heading within a few degrees of the horizon toward the
//! sun, with a phase function of 2–11 there.
//!
//! A scattering direction therefore comes, with probability
//! [`SUN_LOBE_SHARE`], from a Henyey–Greenstein lobe ([`SUN_LOBE_G`])
//! about the axis [`SUN_LOBE_ELEVATION_DEG`] above the local horizon
//! toward the sun's azimuth (the sun itself where it has none), and
//! otherwise from the channels' phase functions as before. Every channel
//! weighs the direction by its matrix over the mixture of both densities
//! (one-sample MIS, balance heuristic), so no weight exceeds 1/(1 −
//! share) times that of the phase functions alone and the estimate stays
//! unbiased. With the sun up it serves only channels of little column
//! extinction ([`SUN_LOBE_SUN_UP_MAX_COLUMN`]) below
//! [`SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG`]: for all eleven bands of the sky
//! model grid it made the benchmark's sun-at-2° tasks (20 km visibility)
//! 1.23 (ground) and 0.94 (15 km) times as dear, their worst band then
//! (320–360 nm, whose long horizontal paths are opaque) gaining nothing,
//! while the 480–760 nm group alone gains (README, "Sun connections at
//! twilight"). Where the sensor's first vertex is split, both branches come
//! from the lobe together (independently) or from the phase functions
//! together (the second a quarter turn of the first): each branch's
//! direction alone then has the mixture's density.

use glam::DVec3;

use crate::polarization::phase::PhaseFunction;

/// The share of scattering directions drawn from the lobe.
pub const SUN_LOBE_SHARE: f64 = 0.3;

/// The lobe's Henyey–Greenstein asymmetry (about 11° of half-width).
pub const SUN_LOBE_G: f64 = 0.8;

/// The lobe axis's elevation above the local horizon (°).
pub const SUN_LOBE_ELEVATION_DEG: f64 = 5.0;

/// With the sun up, the lobe serves only a scene whose channels' column
/// extinctions (at their centre wavelengths) are all at most this, and
/// only below [`SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG`]. On directions jobs in
/// the sky model grid's atmosphere (20 km visibility, roulette from 0.03,
/// time × the worst band's variance per path) the group of 480–760 nm
/// (column extinction 0.27–0.57) cost about half with it at 2° (ground 8.6
/// against 16.8, 15 km 1.4 against 1.7), and the group of 320–480 nm (up
/// to 1.37, 320–360 nm) 1.8 times more from the ground (24.2 against
/// 13.7), its long horizontal paths opaque (README, "Sun connections at
/// twilight"). 0.7 lies between the largest column extinction of the
/// 480–760 nm group at 20 km visibility (0.57, 480–520 nm) and that of the
/// 320–480 nm group at 131.8 km (0.81, 320–360 nm), the grid's extremes.
pub const SUN_LOBE_SUN_UP_MAX_COLUMN: f64 = 0.7;

/// With the sun up, the lobe is used only below this elevation (°), where
/// sun-aware connections are (`SunSampling::Auto`): a 500 nm band gained
/// from it at 2° and 10° (variance per path 0.336 → 0.278, 0.572 → 0.503)
/// and lost at 45° (0.156 → 0.180).
pub const SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG: f64 = 10.0;

/// The lobe at one vertex.
#[derive(Debug, Clone, Copy)]
pub(super) struct SunLobe {
    axis: DVec3,
}

impl SunLobe {
    /// The lobe at a vertex whose local vertical is `up` (unit), for the
    /// direction toward the sun `sun` (unit).
    pub(super) fn new(up: DVec3, sun: DVec3) -> SunLobe {
        let horizontal = sun - sun.dot(up) * up;
        let len = horizontal.length();
        let axis = if len > 1e-9 {
            let (sin_e, cos_e) = SUN_LOBE_ELEVATION_DEG.to_radians().sin_cos();
            cos_e * (horizontal / len) + sin_e * up
        } else {
            sun
        };
        SunLobe { axis }
    }

    fn phase() -> PhaseFunction {
        PhaseFunction::HenyeyGreenstein { g: SUN_LOBE_G }
    }

    /// A propagation direction drawn from the lobe.
    pub(super) fn sample(&self, u: [f64; 2]) -> DVec3 {
        Self::phase().sample_direction(self.axis, u).0
    }

    /// 4π times the lobe's density per steradian of propagation direction
    /// `d` (the scale of the phase functions' P11).
    pub(super) fn density_4pi(&self, d: DVec3) -> f64 {
        Self::phase().p11(d.dot(self.axis).clamp(-1.0, 1.0))
    }

    /// The inverse of the mixture's density (times 4π) of a direction
    /// whose channels' mean P11 is `mean_p11`.
    pub(super) fn inverse_mixture(&self, mean_p11: f64, d: DVec3) -> f64 {
        1.0 / ((1.0 - SUN_LOBE_SHARE) * mean_p11 + SUN_LOBE_SHARE * self.density_4pi(d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::sampler::Sampler;

    #[test]
    fn the_lobe_draws_what_its_density_says() {
        // Histogram of 400,000 draws over 20 bands of cos(angle to the
        // axis) against the density integrated over each band (the
        // closed-form HG fraction), each within 4.5 binomial standard
        // errors; and the axis is 5° above the horizon toward the sun.
        let up = DVec3::Z;
        let sun = DVec3::new(0.3, 0.4, -0.05).normalize();
        let lobe = SunLobe::new(up, sun);
        let toward = DVec3::new(0.6, 0.8, 0.0);
        let e = SUN_LOBE_ELEVATION_DEG.to_radians();
        assert!((lobe.axis - (e.cos() * toward + e.sin() * up)).length() < 1e-12);
        let n = 400_000;
        let bands = 20;
        let mut counts = vec![0u64; bands];
        let mut s = Sampler::new(&[41]);
        for _ in 0..n {
            let d = lobe.sample(s.next2());
            assert!((d.length() - 1.0).abs() < 1e-12);
            let c = d.dot(lobe.axis);
            counts[(((c + 1.0) / 2.0 * bands as f64) as usize).min(bands - 1)] += 1;
        }
        // ∫ over cos from a to b of p11/2 (per unit cos, azimuth done).
        let g = SUN_LOBE_G;
        let cdf = |c: f64| (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 + g * g - 2.0 * g * c).sqrt() - 1.0 / (1.0 + g));
        for (i, &k) in counts.iter().enumerate() {
            let (a, b) = (
                -1.0 + 2.0 * i as f64 / bands as f64,
                -1.0 + 2.0 * (i + 1) as f64 / bands as f64,
            );
            let p = cdf(b) - cdf(a);
            let se = (n as f64 * p * (1.0 - p)).sqrt().max(1.0);
            assert!(
                (k as f64 - n as f64 * p).abs() < 4.5 * se,
                "band {i}: {k} vs {}",
                n as f64 * p
            );
        }
        // The density integrates to 4π over the sphere (midpoint in cos).
        let m = 200_000;
        let total: f64 = (0..m)
            .map(|i| {
                let c = -1.0 + (i as f64 + 0.5) * 2.0 / m as f64;
                let sin = (1.0 - c * c).sqrt();
                let d = c * lobe.axis + sin * lobe.axis.any_orthonormal_vector();
                lobe.density_4pi(d) * 2.0 / m as f64 * 2.0 * std::f64::consts::PI
            })
            .sum();
        assert!((total / (4.0 * std::f64::consts::PI) - 1.0).abs() < 1e-3, "{total}");
        // With the sun at the zenith the axis is the sun.
        assert!((SunLobe::new(up, up).axis - up).length() < 1e-15);
    }
}
