//! Scattering directions drawn in part about the sun (`sun_peak`, what
//! `sun_sampling = "auto"` does with the sun 10° to 25° up, to 50° seen
//! from near the ground) against the
//! phase functions alone (`"collision"`, the same sun connections): renders
//! of the same jobs (spherical geometry, US-standard gases with ozone,
//! continental aerosol at 20 km visibility, whose forward peak the lobe
//! is for; albedo 0.3; 550 nm; sun at 12° and 22° with observers on the
//! ground and at 10 km, and at 40° on the ground (the lobe serves higher
//! suns seen from within 1 km of it), looking up, at the sun's aureole and
//! the horizon under it, and down), 16 seeds each.
//!
//! - Both estimate the same radiance: no I, Q or U differs beyond the
//!   Šidák 1 % threshold of the combined standard error.
//! - The lobe's standard errors are honest: over the 16 seeds the spread
//!   of each direction's estimate matches the reported standard error
//!   (pooled over a job's directions, within the interval that honest
//!   errors give with 16 seeds, `SeedRuns::spread_window`: about
//!   0.78–1.23 for 6 directions, 0.82–1.19 for 9).
//! - The variance of I per path with the lobe over that without is
//!   printed per job (the measured gains are in docs/design-sun.md, "Scattering around
//!   the sun").
//!
//! `ATMOSIM_VALIDATION_SAMPLES` sets the paths per direction and seed
//! (default 1500, sized for CI).

mod common;

use common::{Comparison, SeedRuns, directions, job, render, samples};

const SEEDS: u64 = 16;
const UP: [(f64, f64); 6] = [
    (0.0, 0.0),
    (50.0, 90.0),
    (72.0, 0.0),
    (80.0, 8.0),
    (88.0, 0.0),
    (85.0, 180.0),
];
const DOWN: [(f64, f64); 3] = [(95.0, 0.0), (120.0, 90.0), (180.0, 0.0)];

fn job_text(elevation_deg: f64, sampling: &str, seed: u64) -> String {
    format!(
        "[planet]\nradius_km = 6370.0\ntop_km = 100.0\n[atmosphere]\nprofile = \"us_standard\"\n\
         ozone = \"bogumil\"\naerosol = \"continental_average\"\nvisibility_km = 20.0\n[spectrum]\n\
         wavelengths_nm = [550.0]\n[sun]\nelevation_deg = {elevation_deg:?}\n[ground]\nalbedo = 0.3\n\
         [render]\nseed = {seed}\nsun_sampling = \"{sampling}\"\n"
    )
}

#[test]
fn drawing_around_the_sun_keeps_the_radiance_and_honest_errors() {
    let n = samples(1500);
    let mut agreement = Comparison::default();
    let mut ratios = Vec::new();
    eprintln!("paths per direction and seed: {n}, {SEEDS} seeds");
    // Two elevations × two observers, and a higher sun seen from the
    // ground (where the lobe serves up to 50°): the family of spread checks.
    let cases: [(f64, &[f64]); 3] = [(12.0, &[0.0, 10.0]), (22.0, &[0.0, 10.0]), (40.0, &[0.0])];
    let family = 5;
    for (elevation, observers) in cases {
        for &zout in observers {
            assert!(atmosim::transport::tracer::sun_peak_serves(90.0 - elevation, zout));
            let pairs: Vec<(f64, f64)> = if zout > 0.0 {
                UP.iter().chain(&DOWN).copied().collect()
            } else {
                UP.to_vec()
            };
            let dirs = directions(&pairs);
            // Seeds 300–315 and 400–415: independent renders.
            let [a, b] = [("auto", 300), ("collision", 400)].map(|(sampling, first_seed)| SeedRuns {
                tallies: (0..SEEDS)
                    .map(|seed| render(&job(&job_text(elevation, sampling, first_seed + seed)), zout, &dirs, n))
                    .collect(),
                seconds: 0.0,
                paths: SEEDS * n * dirs.len() as u64,
            });
            let label = format!("sun {elevation}°, zout {zout} km");
            let mut variance_ratios = Vec::new();
            for (d, (z, az)) in pairs.iter().enumerate() {
                for s in 0..3 {
                    let (ma, sa) = a.mean_and_se(d, s);
                    let (mb, sb) = b.mean_and_se(d, s);
                    agreement.add(|| format!("{label}, θ {z} φ {az}, Stokes {s}"), ma, sa, mb, sb);
                    if s == 0 {
                        variance_ratios.push(format!("{:.2}", (sa / sb).powi(2)));
                    }
                }
            }
            let spread = a.pooled_spread(0);
            eprintln!(
                "{label}: spread/se of I {spread:.3} (Q {:.3}); variance of I per path, lobe over none, per direction: {}",
                a.pooled_spread(1),
                variance_ratios.join(" ")
            );
            ratios.push((label, spread, a.spread_window(0, family)));
        }
    }
    agreement.assert_no_outlier("drawing about the sun against the phase functions alone");
    assert_eq!(ratios.len(), family);
    for (label, r, (lo, hi)) in &ratios {
        assert!(
            (lo..=hi).contains(&r),
            "{label}: spread over reported standard error {r:.3}, outside {lo:.3}–{hi:.3}"
        );
    }
}

/// The spread window's quantiles against published χ² tables: for 90
/// degrees of freedom the 0.005 and 0.995 quantiles are 59.196 and 128.299
/// (a single check at 1 %, two-sided).
#[test]
fn the_spread_window_matches_chi_square_tables() {
    let (lo, hi) = common::spread_window(90.0, 1);
    assert!((lo * lo * 90.0 - 59.196).abs() < 0.1, "{}", lo * lo * 90.0);
    assert!((hi * hi * 90.0 - 128.299).abs() < 0.1, "{}", hi * hi * 90.0);
    // More checks widen it.
    let (lo4, hi4) = common::spread_window(90.0, 4);
    assert!(lo4 < lo && hi4 > hi);
}
