//! The published plane-parallel benchmarks: Natraj et al. 2009 (a subset),
//! IPRT phase A A1 (three depolarisations), A2, B1, B2 (MYSTIC), Korkin's
//! single scattering of B2 (both sun connections), DISORT test 3 and
//! pydisort (128 streams). Reference files: validation/published and
//! validation/disort, described in validation/README.md.

use std::path::Path;

use super::case::Case;
use super::stats::Value;
use crate::error::Result;
use crate::film::directions::render_directions;
use crate::film::tally::Tally;
use crate::job::Job;
use crate::physics::data::Table;
use crate::sampling::stream::Render;
use crate::sensor::direction::Direction;

macro_rules! reference {
    ($path:literal) => {
        (
            $path,
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/validation/", $path)),
        )
    };
}

const NATRAJ: (&str, &str) = reference!("published/natraj2009.txt");
const IPRT_A1_000: (&str, &str) = reference!("published/iprt_a1_depol0.00.txt");
const IPRT_A1_003: (&str, &str) = reference!("published/iprt_a1_depol0.03.txt");
const IPRT_A1_010: (&str, &str) = reference!("published/iprt_a1_depol0.10.txt");
const IPRT_A2: (&str, &str) = reference!("published/iprt_a2.txt");
const IPRT_B1: (&str, &str) = reference!("published/iprt_b1.txt");
const IPRT_B2: (&str, &str) = reference!("published/iprt_b2.txt");
const IPRT_B_LAYERS: (&str, &str) = reference!("published/iprt_b_layers.txt");
const KOKHANOVSKY: (&str, &str) = reference!("published/kokhanovsky2010.txt");
const KORKIN: (&str, &str) = reference!("published/korkin_b2_single_scatter.txt");
const DISORT3: (&str, &str) = reference!("disort/disort_test3_128streams.txt");
const PYDISORT: (&str, &str) = reference!("disort/pydisort.txt");
const MYSTIC_TWILIGHT: (&str, &str) = reference!("published/mystic_twilight_620nm.txt");

/// A reference table.
pub(super) fn table((name, text): (&str, &str)) -> Result<Table> {
    Table::parse(name, text, 0)
}

/// A job from TOML text written here.
pub(super) fn job(text: &str) -> Result<Job> {
    Job::parse(text, "<validation case>", Path::new("."))
}

/// Renders `directions` at wavelength index 0 of the job's first task.
pub(super) fn render(job: &Job, altitude_km: f64, directions: &[Direction], samples: u64) -> Vec<Tally> {
    render_directions(
        &job.scene(0),
        altitude_km,
        directions,
        samples,
        job.render.seed,
        Render::channel(0, 0),
    )
}

fn directions(rows: &[&Vec<f64>], zen: usize, az: usize) -> Vec<Direction> {
    rows.iter()
        .map(|r| Direction {
            view_zenith_deg: r[zen],
            azimuth_deg: r[az],
        })
        .collect()
}

/// Appends the Stokes components `components` of a direction: reference
/// values `reference[k]`, standard errors `reference_se[k]`, floor `floor`
/// (absolute, the same for every component).
#[allow(clippy::too_many_arguments)]
pub(super) fn push(
    values: &mut Vec<Value>,
    label: &str,
    d: Direction,
    t: &Tally,
    components: &[usize],
    reference: &[f64],
    reference_se: &[f64],
    floor: f64,
    in_stats: bool,
) {
    let (m, se) = (t.mean(), t.standard_error());
    for (i, &k) in components.iter().enumerate() {
        values.push(Value {
            group: label.to_string(),
            label: format!(
                "{label} θ {:.4} φ {:.1} {}",
                d.view_zenith_deg,
                d.azimuth_deg,
                ["I", "Q", "U", "V"][k]
            ),
            view_zenith_deg: d.view_zenith_deg,
            azimuth_deg: d.azimuth_deg,
            component: k,
            atmosim: m[k],
            atmosim_se: se[k],
            reference: reference[i],
            reference_se: reference_se.get(i).copied().unwrap_or(0.0),
            floor,
            in_stats,
        });
    }
}

/// TOML of a plane-parallel atmosphere of explicit layers
/// (bottom, top, τ_Rayleigh, τ_absorption).
pub(super) fn layers_toml(layers: &[(f64, f64, f64, f64)], depol: f64) -> String {
    let mut s = String::from("[planet]\ngeometry = \"plane_parallel\"\n");
    for &(bottom, top, tau_r, tau_abs) in layers {
        s.push_str(&format!(
            "[[atmosphere.layers]]\nbottom_km = {bottom:?}\ntop_km = {top:?}\ntau_rayleigh = {tau_r:?}\n\
             rayleigh_depolarization = {depol:?}\ntau_absorption = {tau_abs:?}\n"
        ));
    }
    s
}

fn natraj(samples: u64) -> Result<Vec<Value>> {
    let t = table(NATRAJ)?;
    let mut values = Vec::new();
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
                    let text = format!(
                        "{}[ground]\nalbedo = {albedo:?}\n[sun]\nzenith_deg = {:?}\n[observer]\naltitude_km = {level:?}\n\
                         [render]\nseed = 7\nsun_samples_per_flight = {}\n",
                        layers_toml(&[(0.0, 1.0, tau, 0.0)], 0.0),
                        mu0.acos().to_degrees(),
                        // Both the single and the stratified sun connections.
                        if tau == 1.0 { 3 } else { 1 }
                    );
                    let dirs = directions(&rows, 4, 5);
                    let tallies = render(&job(&text)?, level, &dirs, samples);
                    let label = format!("τ {tau} A {albedo} μ0 {mu0} level {level}");
                    for ((r, d), tl) in rows.iter().zip(&dirs).zip(&tallies) {
                        // 8 decimals in π units.
                        let floor = 0.5e-8 / std::f64::consts::PI;
                        push(&mut values, &label, *d, tl, &[0, 1, 2], &r[6..9], &[], floor, true);
                    }
                }
            }
        }
    }
    Ok(values)
}

/// An IPRT MYSTIC file (columns zout_km θ φ I Q U V and their standard
/// errors): `job_for(zout)` is the job text for the observer at each output
/// level; every `stride`-th direction is rendered.
fn iprt_compare(
    reference: (&str, &str),
    stride: usize,
    samples: u64,
    job_for: impl Fn(f64) -> String,
) -> Result<Vec<Value>> {
    mystic_compare(reference, stride, samples, 7, job_for)
}

/// A MYSTIC file (columns zout_km θ φ I Q U, then the standard errors of
/// I, Q and U from column `se_at`): `job_for(zout)` is the job text for the
/// observer at each output level; every `stride`-th direction is rendered.
fn mystic_compare(
    reference: (&str, &str),
    stride: usize,
    samples: u64,
    se_at: usize,
    job_for: impl Fn(f64) -> String,
) -> Result<Vec<Value>> {
    let t = table(reference)?;
    let mut levels: Vec<f64> = t.column(0);
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let mut values = Vec::new();
    for zout in levels {
        let rows: Vec<&Vec<f64>> = t.rows.iter().filter(|r| r[0] == zout).step_by(stride).collect();
        let dirs = directions(&rows, 1, 2);
        let tallies = render(&job(&job_for(zout))?, zout, &dirs, samples);
        let label = format!("zout {zout}");
        for ((r, d), tl) in rows.iter().zip(&dirs).zip(&tallies) {
            push(
                &mut values,
                &label,
                *d,
                tl,
                &[0, 1, 2],
                &r[3..6],
                &r[se_at..se_at + 3],
                0.0,
                true,
            );
        }
    }
    Ok(values)
}

/// An IPRT A case: one Rayleigh layer 0–1 km, outputs at 0 and 1 km.
fn iprt_a(
    reference: (&str, &str),
    tau: f64,
    depol: f64,
    albedo: f64,
    stride: usize,
    samples: u64,
) -> Result<Vec<Value>> {
    let t = table(reference)?;
    let sza: f64 = t
        .header("sza_deg")
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| crate::Error::data(reference.0, "no `sza_deg` header"))?;
    iprt_compare(reference, stride, samples, |zout| {
        format!(
            "{}[ground]\nalbedo = {albedo:?}\n[sun]\nzenith_deg = {sza:?}\n[observer]\naltitude_km = {zout:?}\n\
             [render]\nseed = 3\n",
            layers_toml(&[(0.0, 1.0, tau, 0.0)], depol)
        )
    })
}

/// The IPRT B atmosphere at 450 nm (B1) or 325 nm with ozone (B2).
pub(super) fn iprt_b_toml(b2: bool, depol: f64) -> Result<String> {
    let t = table(IPRT_B_LAYERS)?;
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
    Ok(layers_toml(&layers, depol))
}

/// IPRT B1 (`b2` false) or B2 with Rayleigh depolarisation `depol`.
pub fn iprt_b(b2: bool, depol: f64, samples: u64) -> Result<Vec<Value>> {
    let atmosphere = iprt_b_toml(b2, depol)?;
    iprt_compare(if b2 { IPRT_B2 } else { IPRT_B1 }, 4, samples, |zout| {
        format!("{atmosphere}[sun]\nzenith_deg = 60.0\n[observer]\naltitude_km = {zout:?}\n[render]\nseed = 5\n")
    })
}

/// Spherical MYSTIC at twilight: the gas-only US-standard atmosphere at
/// 620 nm (ozone's Chappuis band) with the sun 2° below the horizon, seen
/// from the ground and from 10 km, every direction.
fn mystic_twilight(samples: u64) -> Result<Vec<Value>> {
    mystic_compare(MYSTIC_TWILIGHT, 1, samples, 6, |zout| {
        format!(
            "[planet]\nradius_km = 6370.0\ntop_km = 120.0\n[atmosphere]\nprofile = \"us_standard\"\n\
             ozone = \"bogumil\"\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [620.0]\n\
             [sun]\nelevation_deg = -2.0\n[ground]\nalbedo = 0.2\n[observer]\naltitude_km = {zout:?}\n\
             [render]\nseed = 9\n"
        )
    })
}

fn kokhanovsky(samples: u64) -> Result<Vec<Value>> {
    let t = table(KOKHANOVSKY)?;
    let rows: Vec<&Vec<f64>> = t.rows.iter().step_by(2).collect();
    let text = format!(
        "{}[sun]\nzenith_deg = 60.0\n[observer]\naltitude_km = 1.0\n[render]\nseed = 19\n",
        layers_toml(&[(0.0, 1.0, 0.3262, 0.0)], 0.0)
    );
    let dirs = directions(&rows, 0, 1);
    let tallies = render(&job(&text)?, 1.0, &dirs, samples);
    let mut values = Vec::new();
    for ((r, d), tl) in rows.iter().zip(&dirs).zip(&tallies) {
        // 7 significant digits.
        push(&mut values, "top", *d, tl, &[0, 1, 2], &r[2..5], &[], 5e-7 * r[2], true);
    }
    Ok(values)
}

fn korkin(sun_sampling: &str, samples: u64) -> Result<Vec<Value>> {
    let t = table(KORKIN)?;
    let atmosphere = iprt_b_toml(true, 0.03)?;
    let mut values = Vec::new();
    let mut szas: Vec<f64> = t.column(0);
    szas.dedup();
    for sza in szas {
        // Every third direction.
        let rows: Vec<&Vec<f64>> = t.rows.iter().filter(|r| r[0] == sza).step_by(3).collect();
        let text = format!(
            "{atmosphere}[sun]\nzenith_deg = {sza:?}\n[observer]\naltitude_km = 30.0\n[render]\n\
             max_scattering_order = 1\nseed = 9\nsun_sampling = \"{sun_sampling}\"\n"
        );
        let dirs = directions(&rows, 1, 2);
        let tallies = render(&job(&text)?, 30.0, &dirs, samples);
        let label = format!("sza {sza}");
        for ((r, d), tl) in rows.iter().zip(&dirs).zip(&tallies) {
            // Exact to 5e-6 relative of I.
            push(
                &mut values,
                &label,
                *d,
                tl,
                &[0, 1, 2],
                &r[3..6],
                &[],
                5e-6 * r[3],
                true,
            );
        }
    }
    Ok(values)
}

fn disort3(samples: u64) -> Result<Vec<Value>> {
    let conv = table(DISORT3)?;
    let mut values = Vec::new();
    for case in [0.0, 1.0] {
        let rows: Vec<&Vec<f64>> = conv.rows.iter().filter(|r| r[0] == case && r[9] > 0.0).collect();
        let Some(first) = rows.first() else { continue };
        let (g, tau, ssa, mu0) = (first[1], first[2], first[3], first[4]);
        for level in [0.0, 1.0] {
            let rows: Vec<&Vec<f64>> = rows.iter().copied().filter(|r| r[6] == level).collect();
            let text = format!(
                "[planet]\ngeometry = \"plane_parallel\"\n[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\n\
                 tau_aerosol = {tau:?}\naerosol_ssa = {ssa:?}\naerosol_g = {g:?}\n\
                 [sun]\nzenith_deg = {:?}\n[observer]\naltitude_km = {level:?}\n[render]\npolarized = false\nseed = 11\n",
                mu0.acos().to_degrees()
            );
            let dirs = directions(&rows, 7, 8);
            let tallies = render(&job(&text)?, level, &dirs, samples);
            let label = format!("test 3{} level {level}", ["a", "b"][case as usize]);
            for ((r, d), tl) in rows.iter().zip(&dirs).zip(&tallies) {
                push(&mut values, &label, *d, tl, &[0], &r[9..10], &[], 2e-6 * r[9], true);
            }
        }
    }
    Ok(values)
}

fn pydisort(samples: u64) -> Result<Vec<Value>> {
    let t = table(PYDISORT)?;
    let mut keys: Vec<[f64; 8]> = t
        .rows
        .iter()
        .map(|r| [r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]])
        .collect();
    keys.sort_by(|a, b| {
        a.iter()
            .zip(b)
            .map(|(x, y)| x.total_cmp(y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    keys.dedup();
    let mut values = Vec::new();
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
                "[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\ntau_aerosol = {tau_a:?}\naerosol_ssa = {ssa:?}\n\
                 aerosol_g = {g:?}\n[[atmosphere.layers]]\nbottom_km = 1.0\ntop_km = 2.0\ntau_rayleigh = {tau_r:?}\n"
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
        let dirs = directions(&rows, 8, 9);
        let tallies = render(&job(&text)?, altitude, &dirs, samples);
        let label = format!("case {case} τR {tau_r} τa {tau_a} A {albedo} sza {sza} level {level}");
        for ((r, d), tl) in rows.iter().zip(&dirs).zip(&tallies) {
            push(&mut values, &label, *d, tl, &[0], &r[10..11], &[], 5e-6 * r[10], true);
        }
    }
    Ok(values)
}

const MYSTIC_FLOOR: &str = "none: the MYSTIC standard errors of the file enter the combined error";

/// The published cases.
pub(super) fn published() -> Vec<Case> {
    vec![
        Case {
            name: "natraj2009",
            title: "Natraj et al. 2009 Rayleigh slab (subset)",
            reference: "validation/published/natraj2009.txt (corrected Coulson–Dave–Sekera tables): τ 0.1 and 1, \
                        albedo 0 and 0.8, μ0 0.2 and 0.8, top and bottom, μ 0.1/0.52/1, φ 0/90/180; I, Q, U",
            setup: "plane-parallel, polarised, depolarisation 0; 3 stratified sun connections per flight for τ 1",
            floor: "half the last printed digit, 0.5e-8/π (absolute): the tables are exact to 8 decimals",
            default_samples: 100_000,
            informational: false,
            ratio_limit: None,
            run: natraj,
        },
        Case {
            name: "iprt_a1_depol0.00",
            title: "IPRT A1, Rayleigh τ 0.5, depolarisation 0",
            reference: "validation/published/iprt_a1_depol0.00.txt (MYSTIC), every third direction, zout 0 and 1 km",
            setup: "plane-parallel, polarised, black ground",
            floor: MYSTIC_FLOOR,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| iprt_a(IPRT_A1_000, 0.5, 0.0, 0.0, 3, n),
        },
        Case {
            name: "iprt_a1_depol0.03",
            title: "IPRT A1, Rayleigh τ 0.5, depolarisation 0.03",
            reference: "validation/published/iprt_a1_depol0.03.txt (MYSTIC), every third direction, zout 0 and 1 km",
            setup: "plane-parallel, polarised, black ground",
            floor: MYSTIC_FLOOR,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| iprt_a(IPRT_A1_003, 0.5, 0.03, 0.0, 3, n),
        },
        Case {
            name: "iprt_a1_depol0.10",
            title: "IPRT A1, Rayleigh τ 0.5, depolarisation 0.1",
            reference: "validation/published/iprt_a1_depol0.10.txt (MYSTIC), every third direction, zout 0 and 1 km",
            setup: "plane-parallel, polarised, black ground",
            floor: MYSTIC_FLOOR,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| iprt_a(IPRT_A1_010, 0.5, 0.1, 0.0, 3, n),
        },
        Case {
            name: "iprt_a2",
            title: "IPRT A2, Rayleigh τ 0.1 over a Lambertian ground (0.3)",
            reference: "validation/published/iprt_a2.txt (MYSTIC), every direction, zout 0 and 1 km",
            setup: "plane-parallel, polarised, depolarisation 0.03",
            floor: MYSTIC_FLOOR,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| iprt_a(IPRT_A2, 0.1, 0.03, 0.3, 1, n),
        },
        Case {
            name: "iprt_b1",
            title: "IPRT B1, 30 Rayleigh layers at 450 nm",
            reference: "validation/published/iprt_b1.txt (MYSTIC), every fourth direction, zout 0, 1 and 30 km",
            setup: "plane-parallel, polarised, depolarisation 0.03, sun zenith 60°",
            floor: MYSTIC_FLOOR,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| iprt_b(false, 0.03, n),
        },
        Case {
            name: "iprt_b2",
            title: "IPRT B2, Rayleigh and ozone absorption at 325 nm",
            reference: "validation/published/iprt_b2.txt (MYSTIC), every fourth direction, zout 0, 1 and 30 km",
            setup: "plane-parallel, polarised, depolarisation 0.03 (the file's label says 0.00; the data reject 0: \
                    tests/validation_published.rs)",
            floor: MYSTIC_FLOOR,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| iprt_b(true, 0.03, n),
        },
        Case {
            name: "kokhanovsky2010",
            title: "Kokhanovsky et al. 2010 Rayleigh benchmark, τ 0.3262, sza 60, reflection",
            reference: "validation/published/kokhanovsky2010.txt (SMART-G validation file), every second direction",
            setup: "plane-parallel, polarised, depolarisation 0, black ground, observer at the top",
            floor: "5e-7 × I: 7 significant digits",
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: kokhanovsky,
        },
        Case {
            name: "korkin_collision",
            title: "Korkin single scattering of the B2 atmosphere (sun connected at collisions)",
            reference: "validation/published/korkin_b2_single_scatter.txt, every third direction, sza 0–85, TOA",
            setup: "plane-parallel, polarised, single scattering only, sun_sampling = collision",
            floor: "5e-6 × I (the single-scattering values are reproduced to 5e-6 independently, validation/README.md)",
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| korkin("collision", n),
        },
        Case {
            name: "korkin_sun_aware",
            title: "Korkin single scattering of the B2 atmosphere (sun-aware connections)",
            reference: "validation/published/korkin_b2_single_scatter.txt, every third direction, sza 0–85, TOA",
            setup: "plane-parallel, polarised, single scattering only, sun_sampling = sun_aware",
            floor: "5e-6 × I (as korkin_collision)",
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| korkin("sun_aware", n),
        },
        Case {
            name: "mystic_twilight",
            title: "Spherical MYSTIC at twilight: sun −2°, 620 nm, ozone",
            reference: "validation/published/mystic_twilight_620nm.txt (libRadtran 2.0.3 MYSTIC, mc_spherical 1D, \
                        polarised), zout 0 and 10 km, every direction",
            setup: "spherical (6370 km, top 120 km), polarised, US standard, Bogumil ozone, no aerosol, albedo 0.2; \
                    sun-aware connections (auto below 10°)",
            floor: MYSTIC_FLOOR,
            default_samples: 40_000,
            informational: false,
            ratio_limit: Some(0.003),
            run: mystic_twilight,
        },
        Case {
            name: "disort_test3",
            title: "DISORT test 3: Henyey–Greenstein g 0.75, τ 1 and 8, scalar",
            reference: "validation/disort/disort_test3_128streams.txt (DISORT 2.1.3, 128 streams; the published \
                        16-stream answers are checked against it in tests/validation_published.rs)",
            setup: "plane-parallel, scalar",
            floor: "2e-6 × I: 64 and 128 streams agree to 2e-6 (file header)",
            default_samples: 200_000,
            informational: false,
            ratio_limit: None,
            run: disort3,
        },
        Case {
            name: "pydisort",
            title: "pydisort: Rayleigh, Rayleigh over HG aerosol, mixed; albedo 0/0.3, sza 30/60",
            reference: "validation/disort/pydisort.txt (DISORT 2.1.3, 128 streams)",
            setup: "plane-parallel, scalar",
            floor: "5e-6 × I: 32 and 128 streams agree to 5e-6 (file header)",
            default_samples: 20_000,
            informational: false,
            ratio_limit: None,
            run: pydisort,
        },
    ]
}
