//! The sensor's own flight's sun connection (docs/design-sun.md, "The
//! view's own flight"):
//!
//! - By day, a view whose ray repeats from sample to sample (every
//!   direction of a `directions` sensor) connects along its whole view
//!   ray wherever it looks; renders with `sun_sampling = "auto"` agree
//!   with renders whose every connection is at a collision
//!   (`"collision"`), I, Q and U of views near the sun and far from it,
//!   under HG aerosol layers and under Mie aerosol (no value beyond the
//!   Šidák 1 % threshold), and the single scattering of views far from
//!   the sun comes out almost exactly. (Jittered pixels do so only within
//!   18° of the sun: a unit test of `Scene`.)
//! - With the sun low (sun-aware connections on every flight), the view's
//!   density is exact per segment with a defence of 0.01: single
//!   scattering seen 8° from a sun 2° up has a per-path relative standard
//!   deviation below 0.05 (0.72 with the scattered flights' density of
//!   pieces of four and a defence of 0.2, the view's until 2026-11-29), and
//!   agrees with connections at collisions.

mod common;

use atmosim::film::tally::Tally;
use common::{Comparison, directions, job, render, samples};

const HG_LAYERS: &str = "[[atmosphere.aerosol_layers]]\nbottom_km = 0.0\ntop_km = 2.0\ntau = 0.2\nssa = 0.95\n\
                         g = 0.7\n[[atmosphere.aerosol_layers]]\nbottom_km = 2.0\ntop_km = 8.0\ntau = 0.05\n\
                         ssa = 0.95\ng = 0.65\n";

fn job_text(aerosol: &str, sun_zenith_deg: f64, sampling: &str, extra: &str, seed: u64) -> String {
    format!(
        "[planet]\nradius_km = 6378.0\ntop_km = 100.0\n[atmosphere]\nprofile = \"us_standard\"\n\
         ozone = \"bogumil\"\n{aerosol}[spectrum]\nwavelengths_nm = [540.0]\n[sun]\n\
         zenith_deg = {sun_zenith_deg:?}\n[ground]\nalbedo = 0.2\n[render]\nseed = {seed}\n\
         sun_sampling = \"{sampling}\"\n{extra}"
    )
}

#[test]
fn near_sun_views_by_day_agree_with_connections_at_collisions() {
    let n = samples(6000);
    let mut agreement = Comparison::default();
    for (name, aerosol, sun) in [
        ("HG layers", HG_LAYERS, 45.0),
        ("Mie", "aerosol = \"continental_average\"\n", 60.0),
    ] {
        // At the sun, 3°, 15° (both sides of the zenith) and 40° from it,
        // and far from it.
        let dirs = directions(&[
            (sun, 0.0),
            (sun - 3.0, 0.0),
            (sun - 15.0, 0.0),
            (sun + 15.0, 0.0),
            (sun, 40.0),
            (60.0, 180.0),
        ]);
        let auto = job(&job_text(aerosol, sun, "auto", "", 1));
        let collision = job(&job_text(aerosol, sun, "collision", "", 2));
        let a = render(&auto, 0.0, &dirs, n);
        let b = render(&collision, 0.0, &dirs, n);
        agreement.add_tallies(name, &a, &b);
        // Near the sun the view's connection along its flight is the far
        // better estimate of I (a test that it is used at all).
        let rel = |t: &Tally| t.standard_error()[0] / t.mean()[0];
        assert!(
            rel(&a[1]) < 0.5 * rel(&b[1]),
            "{name}: 3° from the sun, relative errors {} (auto) and {} (collision)",
            rel(&a[1]),
            rel(&b[1])
        );
    }
    agreement.assert_no_outlier("views by day, auto against collision");
}

#[test]
fn by_day_directions_far_from_the_sun_estimate_single_scattering_almost_exactly() {
    // Single scattering alone, the sun 45° up: 45°, 105° and 62° from the
    // sun, and 40° across it. Measured at 4000 paths (seed 3): a per-path
    // relative standard deviation of I of 0.0014-0.0036 along the flight
    // against 0.21-0.52 at collisions.
    let n = samples(4000);
    let dirs = [(0.0, 0.0), (60.0, 180.0), (80.0, 90.0), (45.0, 40.0)];
    let (a, b) = single_scattering_against_collisions(45.0, "auto", &dirs, (n, n), "sun 45° up");
    for (d, (a, b)) in a.iter().zip(&b).enumerate() {
        assert!(
            per_path_relative_sd(a, n) < 0.05 && per_path_relative_sd(b, n) > 0.1,
            "direction {d}: per-path relative standard deviations {} (auto), {} (collision)",
            per_path_relative_sd(a, n),
            per_path_relative_sd(b, n)
        );
    }
}

/// Single scattering alone (HG layers, 540 nm) seen from the ground in
/// `dirs` with `sampling` (`n` paths) and with connections at collisions
/// (`n_collision` paths), other seeds; asserts that they agree (Šidák
/// 1 %) and returns both.
fn single_scattering_against_collisions(
    sun_zenith_deg: f64,
    sampling: &str,
    dirs: &[(f64, f64)],
    (n, n_collision): (u64, u64),
    name: &str,
) -> (Vec<Tally>, Vec<Tally>) {
    let dirs = directions(dirs);
    let order1 = "max_scattering_order = 1\n";
    let a = render(
        &job(&job_text(HG_LAYERS, sun_zenith_deg, sampling, order1, 3)),
        0.0,
        &dirs,
        n,
    );
    let b = render(
        &job(&job_text(HG_LAYERS, sun_zenith_deg, "collision", order1, 4)),
        0.0,
        &dirs,
        n_collision,
    );
    let mut agreement = Comparison::default();
    agreement.add_tallies(&format!("single scattering, {name}"), &a, &b);
    agreement.assert_no_outlier(&format!("single scattering, {name}: {sampling} against collisions"));
    (a, b)
}

/// The relative standard deviation of I per path of a tally of `n` paths.
fn per_path_relative_sd(t: &Tally, n: u64) -> f64 {
    t.standard_error()[0] / t.mean()[0] * (n as f64).sqrt()
}

#[test]
fn the_view_flight_estimates_single_scattering_almost_exactly_with_the_sun_low() {
    let n = samples(4000);
    let dirs = [(80.0, 0.0), (60.0, 90.0), (0.0, 0.0)];
    let (a, _) = single_scattering_against_collisions(88.0, "sun_aware", &dirs, (n, n), "sun 2° up");
    for (d, t) in a.iter().enumerate() {
        let per_path = per_path_relative_sd(t, n);
        assert!(
            per_path < 0.05,
            "direction {d}: per-path relative standard deviation {per_path}"
        );
    }
}

#[test]
fn the_view_flights_polarisation_control_variate_is_unbiased_and_leaves_rayleigh_q_almost_exact() {
    // Single scattering alone under HG layers (whose P12 is 0: Q and U
    // are Rayleigh's), the sun 45° up, views 45°-105° from it. Along the
    // view's flight Q and U carry a control variate that follows
    // Rayleigh's single scattering (docs/design-sun.md, "Q and U along
    // the view's flight"); without it (commit 982573d) their per-path
    // relative standard deviation was 0.68-1.65 and at collisions it is
    // 1.0-1.2; with it, 1.0e-5 to 1.7e-5 (measured at 4000 paths, seed
    // 3). Against 50 times as many paths connected at collisions, every
    // value agrees (Šidák 1 %): a bias of the variate would show at the
    // collisions' standard error, 0.23-0.27 % of (Q, U).
    let n = samples(4000);
    let dirs = [(0.0, 0.0), (30.0, 180.0), (60.0, 90.0), (45.0, 40.0), (80.0, 0.0)];
    let (a, b) = single_scattering_against_collisions(45.0, "auto", &dirs, (n, 50 * n), "polarisation, sun 45° up");
    for (d, (a, b)) in a.iter().zip(&b).enumerate() {
        let linear = |t: &Tally| {
            let (m, se) = (t.mean(), t.standard_error());
            (m[1].hypot(m[2]), se[1].hypot(se[2]))
        };
        let ((qa, sa), (qb, sb)) = (linear(a), linear(b));
        let (per_path_a, per_path_b) = (sa / qa * (n as f64).sqrt(), sb / qb * ((50 * n) as f64).sqrt());
        assert!(
            per_path_a < 1e-3 && per_path_b > 0.1,
            "direction {d}: per-path relative standard deviations of (Q, U) {per_path_a} (auto), {per_path_b} (collision)"
        );
    }
}
