//! Scattering directions drawn in part around the sun's direction, with
//! the sun low but up (10° to 25° above the horizon, where `auto` connects
//! to the sun at collisions; to 50° seen from within 1 km of the ground).
//!
//! A path's next vertex connects to the sun with the phase matrix there at
//! the angle between the flight and the sun. The aerosol's forward peak
//! makes that connection tens of times stronger for a flight heading within
//! a few degrees of the sun than for one across the sky, and the phase
//! function at the vertex before, which drew the flight's direction, knows
//! nothing of the sun: such flights come rarely and weigh much. Where the
//! sun is low, much of the light reaching the lower air has been scattered
//! near the sun's direction (the aureole and the bright horizon under the
//! sun), so this part of the noise is large: with the sun 10° up (the sky
//! model grid's atmosphere, 20 km visibility, ground observer, 40 nm
//! bands) single scattering carries 3–43 % of the radiance, and a path's
//! variance of I over I² grows from 0.02–0.13 for single scattering to
//! 0.2–0.5 with the second order (docs/design-sun.md, "Scattering around the sun").
//!
//! So a scattering direction comes with probability [`SUN_PEAK_SHARE`]
//! from a Henyey–Greenstein lobe of [`SUN_PEAK_G`] about the direction
//! toward the sun, and otherwise from the channels' phase functions; every
//! channel weighs it by its matrix over the mixture of both densities
//! (one-sample MIS, balance heuristic), as for the lobe toward the sunlit
//! air (`sun_lobe`), so the estimate stays unbiased and no weight exceeds
//! 1/(1 − share) times that of the phase functions alone. The lobe depends
//! on the sun's direction alone: renders stay bit-identical across threads,
//! resumes and shards.
//!
//! Chosen by measurement (directions jobs of docs/design.md "Transport": the cost
//! to a noise target, the two spectral groups' time × their worst band's
//! median variance per path): with the sun at 10°, 15° and 20° it cost
//! 0.78, 0.82 and 0.76 times as much seen from the ground and 0.87, 0.88
//! and 0.95 from 15 km; at 25° 0.92 and 1.01, at 45° 0.91 and 1.11, so it
//! stops at [`SUN_PEAK_MAX_ELEVATION_DEG`], except seen from within
//! [`SUN_PEAK_LOW_OBSERVER_KM`] of the ground, where it goes on to
//! [`SUN_PEAK_LOW_OBSERVER_MAX_ELEVATION_DEG`]: the figure of merit of I
//! on the `bench --suite` day sky (540 nm, HG aerosol τ 0.25) with the
//! lobe against without, ground observer, was 1.33, 1.19, 1.13, 1.08, 1.02,
//! 1.00 and 1.00 (median over 16 directions) with the sun 30°, 40°, 45°,
//! 50°, 60°, 70° and 90° up, and from 1 km 1.15 at 30° and 1.03 at 45°,
//! but from 2, 5 and 15 km 1.06, 1.03 and 0.96 at 30° and 0.96, 0.97 and
//! 0.94 at 45°; Q's 0.94–1.03 (docs/design-sun.md, 2026-11-29). The 480–760 nm group gains
//! (its worst band 0.66 against 1.01 times at 15°), the 320–480 nm group
//! hardly moves (the low sun's light reaches the lower air scattered, not
//! direct). Shares 0.05, 0.15, 0.2 and 0.35 and g of 0.6, 0.85 and 0.9
//! were no better (docs/design-sun.md).

use glam::DVec3;

use crate::polarization::phase::PhaseFunction;
use crate::sampling::sampler::Sampler;

/// The share of scattering directions drawn from the lobe about the sun.
pub const SUN_PEAK_SHARE: f64 = 0.1;

/// The lobe's asymmetry parameter.
pub const SUN_PEAK_G: f64 = 0.75;

/// The lobe serves a sun at least this high above the observer's horizon
/// (°): below it `auto` makes sun connections sun-aware, with the lobe
/// toward the sunlit air (`sun_lobe`) where that serves.
pub const SUN_PEAK_MIN_ELEVATION_DEG: f64 = 10.0;

/// ... and lower than this (°), ...
pub const SUN_PEAK_MAX_ELEVATION_DEG: f64 = 25.0;

/// ... or than this (°) for an observer within
/// [`SUN_PEAK_LOW_OBSERVER_KM`] of the ground, below most of the aerosol,
/// where the light scattered more than once about the sun is a larger part
/// of the sky's noise.
pub const SUN_PEAK_LOW_OBSERVER_MAX_ELEVATION_DEG: f64 = 50.0;

/// The height above the ground (km) up to which an observer is low.
pub const SUN_PEAK_LOW_OBSERVER_KM: f64 = 1.0;

/// Whether the lobe serves a sun at `zenith_deg` (at the observer) seen
/// from `height_km` above the ground.
pub fn sun_peak_serves(zenith_deg: f64, height_km: f64) -> bool {
    let elevation = 90.0 - zenith_deg;
    let max = if height_km <= SUN_PEAK_LOW_OBSERVER_KM {
        SUN_PEAK_LOW_OBSERVER_MAX_ELEVATION_DEG
    } else {
        SUN_PEAK_MAX_ELEVATION_DEG
    };
    (SUN_PEAK_MIN_ELEVATION_DEG..max).contains(&elevation)
}

/// The lobe about the direction toward the sun.
#[derive(Debug, Clone, Copy)]
pub(super) struct SunPeak {
    sun: DVec3,
}

impl SunPeak {
    /// The lobe about `sun` (unit, toward the sun).
    pub(super) fn new(sun: DVec3) -> SunPeak {
        SunPeak { sun }
    }

    fn phase() -> PhaseFunction {
        PhaseFunction::HenyeyGreenstein { g: SUN_PEAK_G }
    }

    /// A propagation direction drawn from the lobe (two uniform variates).
    pub(super) fn sample(&self, sampler: &mut Sampler) -> DVec3 {
        SunPeak::phase().sample_direction(self.sun, sampler.next2()).0
    }

    /// 4π times the lobe's density per steradian of propagation direction
    /// `d` (the scale of the phase functions' P11).
    pub(super) fn density_4pi(&self, d: DVec3) -> f64 {
        SunPeak::phase().p11(d.dot(self.sun).clamp(-1.0, 1.0))
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    #[test]
    fn the_peak_draws_what_its_density_says_around_the_sun() {
        // Histogram of 200,000 draws in 20 bins of the cosine of the angle
        // to the sun against the density integrated over each bin (HG's
        // closed-form CDF), within 4.5 binomial standard errors; every draw
        // a unit vector; the density is 4π·HG and integrates to 4π.
        let sun = DVec3::new(0.3, -0.2, 0.93).normalize();
        let peak = SunPeak::new(sun);
        let g = SUN_PEAK_G;
        let cdf = |mu: f64| (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 + g * g - 2.0 * g * mu).sqrt() - 1.0 / (1.0 + g));
        assert!((cdf(1.0) - 1.0).abs() < 1e-12 && cdf(-1.0).abs() < 1e-12);
        let bins = 20;
        let n = 200_000;
        let mut counts = vec![0u64; bins];
        let mut s = Sampler::new(&[51, 7]);
        for _ in 0..n {
            let d = peak.sample(&mut s);
            assert!((d.length() - 1.0).abs() < 1e-12);
            let mu = d.dot(sun).clamp(-1.0, 1.0);
            counts[(((mu + 1.0) / 2.0 * bins as f64) as usize).min(bins - 1)] += 1;
        }
        for (b, &k) in counts.iter().enumerate() {
            let (lo, hi) = (
                -1.0 + 2.0 * b as f64 / bins as f64,
                -1.0 + 2.0 * (b + 1) as f64 / bins as f64,
            );
            let p = cdf(hi) - cdf(lo);
            let (mean, se) = (n as f64 * p, (n as f64 * p * (1.0 - p)).sqrt());
            assert!(
                (k as f64 - mean).abs() < 4.5 * se,
                "bin {b}: {k} against {mean:.1} ± {se:.1}"
            );
        }
        // The density: midpoint rule over the cosine (azimuth uniform).
        let m = 200_000;
        let total: f64 = (0..m)
            .map(|i| {
                let mu = -1.0 + (i as f64 + 0.5) * 2.0 / m as f64;
                let s = (1.0 - mu * mu).sqrt();
                let e = sun.any_orthonormal_vector();
                peak.density_4pi(mu * sun + s * e) * 2.0 * PI * 2.0 / m as f64
            })
            .sum();
        assert!((total / (4.0 * PI) - 1.0).abs() < 1e-6, "{total}");
    }

    #[test]
    fn the_peak_serves_from_10_to_25_degrees_or_to_50_seen_from_low() {
        for (elevation, height, serves) in [
            (-4.2, 0.0, false),
            (2.0, 0.0, false),
            (9.9, 0.0, false),
            (10.0, 0.0, true),
            (10.0, 15.0, true),
            (20.0, 5.0, true),
            (24.9, 15.0, true),
            (25.0, 1.01, false),
            (45.0, 2.0, false),
            (25.0, 1.0, true),
            (45.0, 0.0, true),
            (49.9, 0.5, true),
            (50.0, 0.0, false),
            (90.0, 0.0, false),
        ] {
            assert_eq!(
                sun_peak_serves(90.0 - elevation, height),
                serves,
                "sun {elevation}°, {height} km"
            );
        }
    }
}
