//! The transport core against published plane-parallel benchmarks (the
//! project's copies in validation/published, derived by
//! scripts/derive_validation.py): Natraj et al. 2009 (subset), IPRT phase A
//! A1, A2, B1, B2 (MYSTIC), Korkin's single scattering for B2, DISORT test 3.
//! Criterion: no |z| beyond the Šidák threshold for a 1 % family-wise false
//! alarm over the values compared. Sample counts are sized for CI; set
//! ATMOSIM_VALIDATION_SAMPLES to run more.

mod common;

use atmosim::render::Direction;
use common::{Comparison, job, layers_toml, render, samples, table};

fn directions(rows: &[&Vec<f64>], zen: usize, az: usize) -> Vec<Direction> {
    rows.iter()
        .map(|r| Direction {
            view_zenith_deg: r[zen],
            azimuth_deg: r[az],
        })
        .collect()
}

#[test]
fn natraj_2009_subset() {
    let t = table("validation/published/natraj2009.txt");
    let n = samples(100_000);
    let mut cmp = Comparison::default();
    let mus = [0.1, 0.52, 1.0];
    for tau in [0.1, 1.0] {
        for albedo in [0.0, 0.8] {
            for mu0 in [0.2, 0.8] {
                for level in [0.0, 1.0] {
                    let rows: Vec<&Vec<f64>> = t
                        .rows
                        .iter()
                        .filter(|r| r[0] == tau && r[1] == albedo && r[2] == mu0 && r[3] == level)
                        .filter(|r| mus.iter().any(|m| (r[4].to_radians().cos().abs() - m).abs() < 1e-6))
                        .filter(|r| [0.0, 90.0, 180.0].contains(&r[5]))
                        .collect();
                    assert!(!rows.is_empty());
                    let text = format!(
                        "{}[ground]\nalbedo = {albedo:?}\n[sun]\nzenith_deg = {:?}\n[observer]\naltitude_km = {level:?}\n[render]\nseed = 7\nsun_samples_per_flight = {}\n",
                        layers_toml(&[(0.0, 1.0, tau, 0.0)], 0.0),
                        mu0.acos().to_degrees(),
                        // Both the single and the stratified sun connections.
                        if tau == 1.0 { 3 } else { 1 }
                    );
                    let j = job(&text);
                    let tallies = render(&j, level, &directions(&rows, 4, 5), n);
                    for (r, tl) in rows.iter().zip(&tallies) {
                        let (m, se) = (tl.mean(), tl.standard_error());
                        for (k, name) in [(0, "I"), (1, "Q"), (2, "U")] {
                            // Reference: 8 decimals in π units.
                            let what = || {
                                format!(
                                    "{name} tau {tau} A {albedo} mu0 {mu0} level {level} θ {} φ {}",
                                    r[4], r[5]
                                )
                            };
                            cmp.add(what, m[k], se[k], r[6 + k], 0.5e-8 / std::f64::consts::PI);
                        }
                    }
                }
            }
        }
    }
    cmp.assert_no_outlier("Natraj 2009 subset");
}

/// Compares an IPRT MYSTIC file (columns zout_km θ φ I Q U V and their
/// standard errors) with atmosim: `job_for(zout)` is the job text for the
/// observer at each output level; every `stride`-th direction is rendered.
fn iprt_compare(file: &str, stride: usize, job_for: impl Fn(f64) -> String) -> Comparison {
    let t = table(file);
    let n = samples(10_000);
    let mut levels: Vec<f64> = t.column(0);
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let mut cmp = Comparison::default();
    for zout in levels {
        let rows: Vec<&Vec<f64>> = t.rows.iter().filter(|r| r[0] == zout).step_by(stride).collect();
        let tallies = render(&job(&job_for(zout)), zout, &directions(&rows, 1, 2), n);
        for (r, tl) in rows.iter().zip(&tallies) {
            let (m, se) = (tl.mean(), tl.standard_error());
            for k in 0..3 {
                let what = || format!("{file} {} zout {zout} θ {} φ {}", ["I", "Q", "U"][k], r[1], r[2]);
                cmp.add(what, m[k], se[k], r[3 + k], r[7 + k]);
            }
        }
    }
    cmp
}

/// An IPRT A case: one Rayleigh layer 0–1 km, outputs at 0 and 1 km.
fn iprt_a(file: &str, tau: f64, depol: f64, albedo: f64, stride: usize) -> Comparison {
    let sza: f64 = table(file).header("sza_deg").unwrap().parse().unwrap();
    iprt_compare(file, stride, |zout| {
        format!(
            "{}[ground]\nalbedo = {albedo:?}\n[sun]\nzenith_deg = {sza:?}\n[observer]\naltitude_km = {zout:?}\n[render]\nseed = 3\n",
            layers_toml(&[(0.0, 1.0, tau, 0.0)], depol)
        )
    })
}

#[test]
fn iprt_a1_three_depolarisations() {
    for (depol, file) in [
        (0.0, "validation/published/iprt_a1_depol0.00.txt"),
        (0.03, "validation/published/iprt_a1_depol0.03.txt"),
        (0.1, "validation/published/iprt_a1_depol0.10.txt"),
    ] {
        iprt_a(file, 0.5, depol, 0.0, 3).assert_no_outlier(file);
    }
}

#[test]
fn iprt_a2_lambertian_ground() {
    iprt_a("validation/published/iprt_a2.txt", 0.1, 0.03, 0.3, 1).assert_no_outlier("IPRT A2");
}

/// The IPRT B atmosphere at 450 nm (B1) or 325 nm with ozone (B2).
fn iprt_b_toml(b2: bool, depol: f64) -> String {
    let t = table("validation/published/iprt_b_layers.txt");
    let layers: Vec<(f64, f64, f64, f64)> = t
        .rows
        .iter()
        .map(|r| {
            if b2 {
                (r[0], r[1], r[3], r[4])
            } else {
                (r[0], r[1], r[2], 0.0)
            }
        })
        .collect();
    layers_toml(&layers, depol)
}

fn iprt_b(b2: bool, depol: f64, stride: usize) -> Comparison {
    let file = if b2 {
        "validation/published/iprt_b2.txt"
    } else {
        "validation/published/iprt_b1.txt"
    };
    iprt_compare(file, stride, |zout| {
        format!(
            "{}[sun]\nzenith_deg = 60.0\n[observer]\naltitude_km = {zout:?}\n[render]\nseed = 5\n",
            iprt_b_toml(b2, depol)
        )
    })
}

#[test]
fn iprt_b1_layered_rayleigh() {
    iprt_b(false, 0.03, 4).assert_no_outlier("IPRT B1");
}

#[test]
fn iprt_b2_rayleigh_with_ozone_matches_depolarisation_0_03() {
    // The MYSTIC file is labelled depolarisation 0.00 but the case uses
    // 0.03: the data decide (see the closing note of the issue).
    let with = iprt_b(true, 0.03, 4);
    let without = iprt_b(true, 0.0, 4);
    eprintln!(
        "B2 with depolarisation 0.03: max |z| {:.2}; with 0: {:.2}",
        with.max_abs_z, without.max_abs_z
    );
    with.assert_no_outlier("IPRT B2 (depolarisation 0.03)");
    assert!(without.max_abs_z > with.max_abs_z);
}

#[test]
fn korkin_single_scattering_of_b2() {
    // Both sun connections: at the collision (a Monte Carlo estimate) and
    // sun-aware (exact for plane-parallel single scattering).
    // ATMOSIM_SUN_SAMPLING picks one.
    match std::env::var("ATMOSIM_SUN_SAMPLING") {
        Ok(mode) => korkin(&mode),
        Err(_) => {
            korkin("collision");
            korkin("sun_aware");
        }
    }
}

fn korkin(sun_sampling: &str) {
    let t = table("validation/published/korkin_b2_single_scatter.txt");
    let n = samples(10_000);
    let mut cmp = Comparison::default();
    let mut rel_se = Vec::new();
    let mut szas: Vec<f64> = t.column(0);
    szas.dedup();
    for sza in szas {
        // Every third direction in CI; ATMOSIM_KORKIN_STRIDE=1 for all.
        let stride = std::env::var("ATMOSIM_KORKIN_STRIDE")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(3);
        let rows: Vec<&Vec<f64>> = t.rows.iter().filter(|r| r[0] == sza).step_by(stride).collect();
        let text = format!(
            "{}[sun]\nzenith_deg = {sza:?}\n[observer]\naltitude_km = 30.0\n[render]\nmax_scattering_order = 1\nseed = 9\n\
             sun_sampling = \"{sun_sampling}\"\n",
            iprt_b_toml(true, 0.03)
        );
        let tallies = render(&job(&text), 30.0, &directions(&rows, 1, 2), n);
        for (r, tl) in rows.iter().zip(&tallies) {
            let (m, se) = (tl.mean(), tl.standard_error());
            rel_se.push(se[0] / m[0]);
            for k in 0..3 {
                // Exact to 5e-6 relative of I.
                let what = || format!("Korkin {} sza {sza} θ {} φ {}", ["I", "Q", "U"][k], r[1], r[2]);
                cmp.add(what, m[k], se[k], r[3 + k], 5e-6 * r[3]);
            }
        }
    }
    rel_se.sort_by(f64::total_cmp);
    eprintln!(
        "Korkin ({sun_sampling}): relative standard error of I at {n} paths: median {:.2e}, max {:.2e}",
        rel_se[rel_se.len() / 2],
        rel_se[rel_se.len() - 1]
    );
    cmp.assert_no_outlier(&format!("Korkin single scattering ({sun_sampling})"));
}

#[test]
fn disort_test_3_henyey_greenstein_scalar() {
    // Reference: DISORT at 128 streams (validation/disort/
    // disort_test3_128streams.txt, scripts/disort_converged.py). The
    // published "correct answers" (16 streams) agree with it within 0.5 %
    // except the nadir radiance at the top of test 3a, 1.2 % high: a
    // 16-stream truncation of the g = 0.75 backscatter, pinned below.
    let conv = table("validation/disort/disort_test3_128streams.txt");
    let published = table("validation/published/disort_tests_radiance.txt");
    for c in conv.rows.iter().filter(|r| r[9] > 0.0) {
        let p = published
            .rows
            .iter()
            .find(|r| r[0] == 3.0 && r[1] == c[0] && r[7] == c[6] && (r[8] - c[7]).abs() < 1e-6)
            .expect("the same direction in the published table");
        let rel = p[10] / c[9] - 1.0;
        let nadir_3a = c[0] == 0.0 && c[6] == 1.0 && c[7] == 180.0;
        if nadir_3a {
            assert!((rel - 0.0116).abs() < 0.0005, "16-stream nadir error {rel}");
        } else {
            assert!(rel.abs() < 0.005, "published vs converged at {c:?}: {rel}");
        }
    }
    let n = samples(200_000);
    for case in [0.0, 1.0] {
        let rows: Vec<&Vec<f64>> = conv.rows.iter().filter(|r| r[0] == case && r[9] > 0.0).collect();
        let (g, tau, ssa, mu0) = (rows[0][1], rows[0][2], rows[0][3], rows[0][4]);
        for level in [0.0, 1.0] {
            let rows: Vec<&Vec<f64>> = rows.iter().copied().filter(|r| r[6] == level).collect();
            let altitude = if level == 1.0 { 1.0 } else { 0.0 };
            let text = format!(
                "[planet]\ngeometry = \"plane_parallel\"\n[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\n\
                 tau_aerosol = {tau:?}\naerosol_ssa = {ssa:?}\naerosol_g = {g:?}\n\
                 [sun]\nzenith_deg = {:?}\n[observer]\naltitude_km = {altitude:?}\n[render]\npolarized = false\nseed = 11\n",
                mu0.acos().to_degrees()
            );
            let tallies = render(&job(&text), altitude, &directions(&rows, 7, 8), n);
            for (r, tl) in rows.iter().zip(&tallies) {
                let (m, se) = (tl.mean()[0], tl.standard_error()[0]);
                let tol = (0.005 * r[9]).max(4.0 * se);
                eprintln!(
                    "DISORT 3{} level {level} θ {:.2}: atmosim {m:.6} ± {se:.1e}, DISORT (128 streams) {:.6}",
                    ["a", "b"][case as usize],
                    r[7],
                    r[9]
                );
                assert!(
                    (m - r[9]).abs() <= tol,
                    "DISORT test 3 case {case} θ {}: {m} vs {}",
                    r[7],
                    r[9]
                );
            }
        }
    }
}

#[test]
fn pydisort_128_streams_rayleigh_and_henyey_greenstein_scalar() {
    // validation/disort/pydisort.txt: scalar DISORT with 128 streams (5e-6
    // relative), one Rayleigh layer, Rayleigh above an HG aerosol layer, and
    // both mixed; albedo 0 and 0.3, sun zenith 30° and 60°, top and bottom.
    let t = table("validation/disort/pydisort.txt");
    let n = samples(20_000);
    let mut keys: Vec<[f64; 8]> = t
        .rows
        .iter()
        .map(|r| [r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]])
        .collect();
    keys.sort_by(|a, b| a.partial_cmp(b).unwrap());
    keys.dedup();
    let mut cmp = Comparison::default();
    for [case, tau_r, tau_a, ssa, g, albedo, sza, level] in keys {
        let rows: Vec<&Vec<f64>> = t
            .rows
            .iter()
            .filter(|r| r[..8] == [case, tau_r, tau_a, ssa, g, albedo, sza, level])
            .collect();
        let layers = match case as u32 {
            0 => format!("[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\ntau_rayleigh = {tau_r:?}\n"),
            // Rayleigh on top of the aerosol layer.
            1 => format!(
                "[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\ntau_aerosol = {tau_a:?}\naerosol_ssa = {ssa:?}\naerosol_g = {g:?}\n\
                 [[atmosphere.layers]]\nbottom_km = 1.0\ntop_km = 2.0\ntau_rayleigh = {tau_r:?}\n"
            ),
            _ => format!(
                "[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\ntau_rayleigh = {tau_r:?}\n\
                 tau_aerosol = {tau_a:?}\naerosol_ssa = {ssa:?}\naerosol_g = {g:?}\n"
            ),
        };
        let top = if case as u32 == 1 { 2.0 } else { 1.0 };
        let altitude = if level == 1.0 { top } else { 0.0 };
        let text = format!(
            "[planet]\ngeometry = \"plane_parallel\"\n{layers}[ground]\nalbedo = {albedo:?}\n[sun]\nzenith_deg = {sza:?}\n\
             [observer]\naltitude_km = {altitude:?}\n[render]\npolarized = false\nseed = 13\n"
        );
        let tallies = render(&job(&text), altitude, &directions(&rows, 8, 9), n);
        for (r, tl) in rows.iter().zip(&tallies) {
            let what = || {
                format!(
                    "case {case} τR {tau_r} τa {tau_a} A {albedo} sza {sza} level {level} θ {} φ {}",
                    r[8], r[9]
                )
            };
            cmp.add(what, tl.mean()[0], tl.standard_error()[0], r[10], 5e-6 * r[10]);
        }
    }
    cmp.assert_no_outlier("pydisort 128 streams");
}
