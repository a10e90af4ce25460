//! The two sun connections at twilight, against each other: renders of the
//! same jobs with `sun_sampling = "sun_aware"` and `"collision"` (spherical
//! geometry, US-standard gases with ozone, albedo 0.2; sun at −2°, −4.2°
//! and +2°; 420 and 620 nm; observers on the ground and at 10 km, looking
//! up and down), 16 seeds each.
//!
//! - Both estimate the same radiance: no I, Q or U differs beyond the
//!   Šidák 1 % threshold of the combined standard error.
//! - The standard errors they report are honest: over the 16 seeds, the
//!   spread of each direction's estimate matches the reported standard
//!   error (pooled over a job's directions, within the interval that
//!   honest errors give with 16 seeds, `SeedRuns::spread_window`). An
//!   estimator whose rare large weights are missed by most renders reports
//!   errors far below its spread.
//! - The efficiency of each (1/(variance × time) per path) is printed, with
//!   what `auto` picks for each job.
//!
//! `ATMOSIM_VALIDATION_SAMPLES` sets the paths per direction and seed
//! (default 1500, sized for CI; the figures of docs/design-sun.md are at 50,000) and
//! `ATMOSIM_TWILIGHT_SUN` the sun elevations.

mod common;

use std::time::Instant;

use atmosim::job::options::SunSampling;
use common::{Comparison, SeedRuns, directions, job, render, samples};

const SEEDS: u64 = 16;
const UP: [(f64, f64); 6] = [
    (0.0, 0.0),
    (60.0, 0.0),
    (80.0, 0.0),
    (80.0, 180.0),
    (88.0, 0.0),
    (88.0, 180.0),
];
const DOWN: [(f64, f64); 4] = [(92.0, 0.0), (100.0, 180.0), (120.0, 0.0), (180.0, 0.0)];

fn job_text(elevation_deg: f64, wavelength_nm: f64, sampling: &str, seed: u64) -> String {
    format!(
        "[planet]\nradius_km = 6370.0\ntop_km = 120.0\n[atmosphere]\nprofile = \"us_standard\"\n\
         ozone = \"bogumil\"\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [{wavelength_nm:?}]\n\
         [sun]\nelevation_deg = {elevation_deg:?}\n[ground]\nalbedo = 0.2\n[render]\nseed = {seed}\n\
         sun_sampling = \"{sampling}\"\n"
    )
}

/// The sun elevations: −2°, −4.2° and +2°, or those listed in
/// `ATMOSIM_TWILIGHT_SUN` (e.g. "5,10,20", to see where `auto` should
/// switch).
fn elevations() -> Vec<f64> {
    match std::env::var("ATMOSIM_TWILIGHT_SUN") {
        Ok(list) => list
            .split(',')
            .map(|e| {
                e.trim()
                    .parse()
                    .unwrap_or_else(|_| panic!("ATMOSIM_TWILIGHT_SUN: {list}"))
            })
            .collect(),
        Err(_) => vec![-2.0, -4.2, 2.0],
    }
}

#[test]
fn sun_aware_and_collision_agree_at_twilight_with_honest_errors() {
    let n = samples(1500);
    let mut agreement = Comparison::default();
    let mut ratios = Vec::new();
    eprintln!("paths per direction and seed: {n}, {SEEDS} seeds");
    eprintln!(
        "{:>6} {:>5} {:>5} | {:>22} | {:>22} | {:>9} {:>9} | auto",
        "sun", "nm", "zout", "spread/se I: sun-aware", "collision", "time s/c", "eff s/c"
    );
    // Per elevation, wavelength and observer both connections: the
    // family of spread checks.
    let family = elevations().len() * 2 * 2 * 2;
    for elevation in elevations() {
        for wavelength in [420.0, 620.0] {
            for zout in [0.0, 10.0] {
                let pairs: Vec<(f64, f64)> = if zout > 0.0 {
                    UP.iter().chain(&DOWN).copied().collect()
                } else {
                    UP.iter().copied().chain([(120.0, 0.0)]).collect()
                };
                let dirs = directions(&pairs);
                // Seeds 100–115 and 200–215: independent renders.
                let mut runs = [("sun_aware", 100, Vec::new(), 0.0), ("collision", 200, Vec::new(), 0.0)];
                // Seeds interleaved, so that a busy machine slows both alike.
                for seed in 0..SEEDS {
                    for (sampling, first_seed, tallies, seconds) in runs.iter_mut() {
                        let j = job(&job_text(elevation, wavelength, sampling, *first_seed + seed));
                        let start = Instant::now();
                        tallies.push(render(&j, zout, &dirs, n));
                        *seconds += start.elapsed().as_secs_f64();
                    }
                }
                let [a, b] = runs.map(|(_, _, tallies, seconds)| SeedRuns {
                    tallies,
                    seconds,
                    paths: SEEDS * n * dirs.len() as u64,
                });
                let label = format!("sun {elevation}°, {wavelength} nm, zout {zout} km");
                for (d, (z, az)) in pairs.iter().enumerate() {
                    for s in 0..3 {
                        let (ma, sa) = a.mean_and_se(d, s);
                        let (mb, sb) = b.mean_and_se(d, s);
                        agreement.add(|| format!("{label}, θ {z} φ {az}, Stokes {s}"), ma, sa, mb, sb);
                    }
                }
                let pooled = |r: &SeedRuns, s: usize| r.pooled_spread(s);
                let (ra, rb) = (pooled(&a, 0), pooled(&b, 0));
                ratios.push((format!("{label}, sun_aware"), ra, a.spread_window(0, family)));
                ratios.push((format!("{label}, collision"), rb, b.spread_window(0, family)));
                // Median over directions of the efficiency ratio.
                let mut eff: Vec<f64> = (0..dirs.len()).map(|d| b.cost(d) / a.cost(d)).collect();
                eff.sort_by(f64::total_cmp);
                let auto = if SunSampling::Auto.is_sun_aware(90.0 - elevation, false) {
                    "sun_aware"
                } else {
                    "collision"
                };
                eprintln!(
                    "{elevation:>6} {wavelength:>5} {zout:>5} | {ra:>9.3} (Q {:>5.3}) | {rb:>9.3} (Q {:>5.3}) | {:>9.2} {:>9.2} | {auto} \
                     (efficiency ratio over directions {:.2}–{:.2})",
                    pooled(&a, 1),
                    pooled(&b, 1),
                    a.seconds / b.seconds,
                    eff[eff.len() / 2],
                    eff[0],
                    eff[eff.len() - 1],
                );
            }
        }
    }
    agreement.assert_no_outlier("sun-aware against collision at twilight");
    assert_eq!(ratios.len(), family);
    for (label, r, (lo, hi)) in &ratios {
        assert!(
            (lo..=hi).contains(&r),
            "{label}: spread over reported standard error {r:.3}, outside {lo:.3}–{hi:.3}"
        );
    }
}
