//! Band channels (`spectrum.band_width_nm`): a band's estimate is the
//! radiance averaged over the band, checked against Gauss–Legendre
//! quadrature of independent single-wavelength renders at nodes inside the
//! band (the radiance is smooth in λ where these bands lie: quadrature error
//! far below the Monte Carlo errors). Tolerances: the Šidák-corrected 1 %
//! threshold over every value compared (`common::Comparison`).

mod common;

use atmosim::film::directions::render_directions_all;
use atmosim::film::tally::Tally;
use atmosim::physics::solar::SolarSpectrum;
use atmosim::sampling::stream::Render;
use common::{Comparison, directions, job};

/// Six-point Gauss–Legendre nodes and weights on [−1, 1].
const GAUSS_6: [(f64, f64); 6] = [
    (-0.932_469_514_203_152, 0.171_324_492_379_170),
    (-0.661_209_386_466_265, 0.360_761_573_048_139),
    (-0.238_619_186_083_197, 0.467_913_934_572_691),
    (0.238_619_186_083_197, 0.467_913_934_572_691),
    (0.661_209_386_466_265, 0.360_761_573_048_139),
    (0.932_469_514_203_152, 0.171_324_492_379_170),
];

/// Σ_k c_k·L_k over independent renders `[k][albedo][direction]` of one
/// Stokes component, with its standard error √(Σ c_k²·se_k²).
fn combine(renders: &[Vec<Vec<Tally>>], weights: &[f64], a: usize, d: usize, s: usize) -> (f64, f64) {
    let (mut mean, mut var) = (0.0, 0.0);
    for (r, c) in renders.iter().zip(weights) {
        let t = &r[a][d];
        mean += c * t.mean()[s];
        var += (c * t.standard_error()[s]).powi(2);
    }
    (mean, var.sqrt())
}

/// The viewing directions of these tests.
const DIRECTIONS: [(f64, f64); 4] = [(0.0, 0.0), (60.0, 0.0), (80.0, 150.0), (120.0, 30.0)];

#[test]
fn band_channels_estimate_the_band_averaged_radiance() {
    // (atmosphere, channels (centre, width), sun elevation): a wide band
    // where Rayleigh varies ×3.6, a band with ozone beside a monochromatic
    // channel, and two bands with the sun set (sun-aware connections along
    // the shared paths, and for the single wavelengths).
    type Case<'a> = (&'a str, &'a [(f64, f64)], f64);
    let cases: [Case; 3] = [
        (
            "[atmosphere]\nozone = \"none\"\naerosol = \"continental_average\"\nvisibility_km = 30.0\n",
            &[(380.0, 120.0), (650.0, 100.0)],
            25.0,
        ),
        (
            "[atmosphere]\nozone = \"bogumil\"\naerosol = \"urban\"\n",
            &[(600.0, 40.0), (520.0, 0.0)],
            25.0,
        ),
        (
            "[atmosphere]\nozone = \"bogumil\"\naerosol = \"continental_average\"\n",
            &[(440.0, 40.0), (620.0, 40.0)],
            -2.0,
        ),
    ];
    let samples = common::samples(30_000);
    let dirs = directions(&DIRECTIONS);
    let mut cmp = Comparison::default();
    for (c, (atmosphere, channels, elevation)) in cases.iter().enumerate() {
        let list = |f: &dyn Fn(&(f64, f64)) -> f64| {
            channels
                .iter()
                .map(f)
                .map(|v| format!("{v}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let text = format!(
            "{atmosphere}[spectrum]\nwavelengths_nm = [{}]\nband_width_nm = [{}]\n[sun]\nelevation_deg = {elevation:?}\n\
             [observer]\naltitude_km = 0.2\n[ground]\nalbedo = [0.0, 0.4]\n",
            list(&|c| c.0),
            list(&|c| c.1)
        );
        let banded = job(&text);
        let scene = banded.spectral_scene(&banded.tasks[0]).expect("bands use shared paths");
        let h = banded.observer_altitude_km;
        let shared = render_directions_all(&scene, h, &dirs, samples, 3, Render::channel(0, 0));
        for (w, &(centre, width)) in channels.iter().enumerate() {
            // The reference: quadrature over single-wavelength renders.
            let nodes: Vec<(f64, f64)> = if width > 0.0 {
                GAUSS_6
                    .iter()
                    .map(|&(x, g)| (centre + 0.5 * width * x, 0.5 * g))
                    .collect()
            } else {
                vec![(centre, 1.0)]
            };
            let node_list = nodes.iter().map(|n| format!("{}", n.0)).collect::<Vec<_>>().join(", ");
            let mono = job(&format!(
                "{atmosphere}[spectrum]\nwavelengths_nm = [{node_list}]\n[sun]\nelevation_deg = {elevation:?}\n\
                 [observer]\naltitude_km = 0.2\n[ground]\nalbedo = [0.0, 0.4]\n"
            ));
            let renders: Vec<_> = (0..nodes.len())
                .map(|k| {
                    render_directions_all(&mono.scene(k), h, &dirs, samples, 100 + k as u64, Render::channel(0, 0))
                        .swap_remove(0)
                })
                .collect();
            for (a, per_albedo) in shared[w].iter().enumerate() {
                for (d, x) in per_albedo.iter().enumerate() {
                    for s in 0..3 {
                        let weights: Vec<f64> = nodes.iter().map(|n| n.1).collect();
                        let (mean, se) = combine(&renders, &weights, a, d, s);
                        cmp.add(
                            || {
                                format!(
                                    "case {c}: {centre} ± {} nm, albedo {a}, direction {d}, Stokes {s}",
                                    width / 2.0
                                )
                            },
                            x.mean()[s],
                            x.standard_error()[s],
                            mean,
                            se,
                        );
                    }
                }
            }
        }
    }
    println!(
        "{}",
        cmp.assert_no_outlier("band channels vs quadrature of single wavelengths")
    );
}

#[test]
fn a_wide_band_differs_from_its_centre_wavelength() {
    // The band estimate is not the centre's radiance: over 320–440 nm the
    // zenith sky differs from its 380 nm value by many standard errors.
    let base = "[atmosphere]\nozone = \"none\"\naerosol = \"none\"\n[sun]\nelevation_deg = 25.0\n";
    let band = job(&format!(
        "{base}[spectrum]\nwavelengths_nm = [380.0]\nband_width_nm = 120.0\n"
    ));
    let centre = job(&format!("{base}[spectrum]\nwavelengths_nm = [380.0]\n"));
    let dirs = &directions(&DIRECTIONS)[..1];
    let h = band.observer_altitude_km;
    let b = render_directions_all(
        &band.spectral_scene(&band.tasks[0]).unwrap(),
        h,
        dirs,
        100_000,
        1,
        Render::channel(0, 0),
    );
    let c = render_directions_all(&centre.scene(0), h, dirs, 100_000, 2, Render::channel(0, 0));
    let (x, y) = (&b[0][0][0], &c[0][0][0]);
    let z = (x.mean()[0] - y.mean()[0]) / x.standard_error()[0].hypot(y.standard_error()[0]);
    assert!(z.abs() > 5.0, "band {} vs centre {}: z = {z}", x.mean()[0], y.mean()[0]);
}

/// (1/w)·∫ E0(λ)·ℓ_i(λ) dλ over the band, ℓ_i the Lagrange basis
/// polynomials of the nodes: the weights that turn the radiances at the
/// nodes into the band average of E0·L, with L the polynomial through
/// them (trapezoids of 0.01 nm on a spectrum linear between 1 nm nodes).
fn source_weights(solar: &SolarSpectrum, nodes: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let steps = ((hi - lo) / 0.01).round() as usize;
    let h = (hi - lo) / steps as f64;
    (0..nodes.len())
        .map(|i| {
            let f = |x: f64| {
                let basis: f64 = (0..nodes.len())
                    .filter(|&j| j != i)
                    .map(|j| (x - nodes[j]) / (nodes[i] - nodes[j]))
                    .product();
                solar.irradiance(x).unwrap() * basis
            };
            let inner: f64 = (1..steps).map(|k| f(lo + k as f64 * h)).sum();
            (0.5 * (f(lo) + f(hi)) + inner) * h / (hi - lo)
        })
        .collect()
}

#[test]
fn absolute_bands_average_the_source_weighted_radiance() {
    // 370–430 nm: the Ca II H and K lines and the rise of E0 toward 430 nm
    // against Rayleigh's fall, so the band average of E0·L is well below
    // mean(E0)·mean(L); beside it a monochromatic channel, E0(520)·L(520).
    let base = "[atmosphere]\nozone = \"none\"\naerosol = \"none\"\n[sun]\nelevation_deg = 25.0\n\
                [observer]\naltitude_km = 0.2\n[ground]\nalbedo = [0.0, 0.4]\n";
    let (centre, width) = (400.0, 60.0);
    let banded = job(&format!(
        "{base}[spectrum]\nwavelengths_nm = [{centre}, 520.0]\nband_width_nm = [{width}, 0.0]\n[output]\nunits = \"absolute\"\n"
    ));
    let solar = banded.solar.clone().expect("absolute units load the spectrum");
    let samples = common::samples(30_000);
    let dirs = directions(&DIRECTIONS);
    let h = banded.observer_altitude_km;
    let shared = render_directions_all(
        &banded.spectral_scene(&banded.tasks[0]).unwrap(),
        h,
        &dirs,
        samples,
        5,
        Render::channel(0, 0),
    );
    let nodes: Vec<f64> = GAUSS_6.iter().map(|&(x, _)| centre + 0.5 * width * x).collect();
    let (lo, hi) = (centre - 0.5 * width, centre + 0.5 * width);
    let band = (source_weights(&solar, &nodes, lo, hi), nodes.clone());
    let mono = (vec![solar.irradiance(520.0).unwrap()], vec![520.0]);
    let mut cmp = Comparison::default();
    let mut naive_z = 0.0;
    for (w, (weights, nodes)) in [band, mono].iter().enumerate() {
        let list = nodes.iter().map(|n| format!("{n}")).collect::<Vec<_>>().join(", ");
        let single = job(&format!("{base}[spectrum]\nwavelengths_nm = [{list}]\n"));
        let renders: Vec<_> = (0..nodes.len())
            .map(|k| {
                render_directions_all(
                    &single.scene(k),
                    h,
                    &dirs,
                    samples,
                    200 + k as u64,
                    Render::channel(0, 0),
                )
                .swap_remove(0)
            })
            .collect();
        for (a, per_albedo) in shared[w].iter().enumerate() {
            for (d, x) in per_albedo.iter().enumerate() {
                for s in 0..3 {
                    let (mean, se) = combine(&renders, weights, a, d, s);
                    cmp.add(
                        || format!("channel {w}, albedo {a}, direction {d}, Stokes {s}"),
                        x.mean()[s],
                        x.standard_error()[s],
                        mean,
                        se,
                    );
                    if w == 0 && a == 0 && d == 0 && s == 0 {
                        // The product of the band means, from the same renders.
                        let gauss: Vec<f64> = GAUSS_6.iter().map(|&(_, g)| 0.5 * g).collect();
                        let (l, l_se) = combine(&renders, &gauss, a, d, 0);
                        let e0 = solar.band_mean(lo, hi).unwrap();
                        naive_z = (x.mean()[0] - e0 * l) / x.standard_error()[0].hypot(e0 * l_se);
                    }
                }
            }
        }
    }
    println!("{}", cmp.assert_no_outlier("absolute bands vs E0-weighted quadrature"));
    println!("zenith band against mean(E0)·mean(L): z = {naive_z:.1}");
    assert!(
        naive_z < -5.0,
        "the zenith band average should lie well below mean(E0)·mean(L): z = {naive_z}"
    );
}

/// The fluxes rows of `job`'s first task, `[channel][albedo]`.
fn task_fluxes(job: &atmosim::job::Job) -> Vec<Vec<atmosim::film::fluxes::Fluxes>> {
    let result = atmosim::run::task::render_directions(job, &job.tasks[0], &|_| {}).unwrap();
    let na = job.render.albedos.len();
    result
        .fluxes
        .chunks(na)
        .map(|c| c.iter().map(|r| r.fluxes).collect())
        .collect()
}

#[test]
fn band_fluxes_average_the_fluxes_over_the_band() {
    // 350–400 nm: Rayleigh falls ×0.59 and the OPAC optics are linear in
    // λ between these two table wavelengths (a table wavelength inside the
    // band would be a kink that six-point Gauss–Legendre quadrature does
    // not resolve to 1e-6), so quadrature of six single wavelengths is
    // exact far below the Monte Carlo errors; beside it a monochromatic
    // channel; normalised and absolute units. E_dir is deterministic on
    // both sides: the band's midpoint rule against the quadrature, to 1e-6.
    let base = "[atmosphere]\nozone = \"none\"\naerosol = \"continental_average\"\nvisibility_km = 40.0\n\
                [sun]\nelevation_deg = 25.0\n[observer]\naltitude_km = 0.2\n[ground]\nalbedo = [0.0, 0.4]\n\
                [sensor]\ndirections = [[0.0, 0.0]]\n";
    let (centre, width) = (375.0, 50.0);
    let samples = common::samples(40_000);
    let nodes: Vec<f64> = GAUSS_6.iter().map(|&(x, _)| centre + 0.5 * width * x).collect();
    let node_list = nodes.iter().map(|n| format!("{n}")).collect::<Vec<_>>().join(", ");
    let mono = job(&format!(
        "{base}[spectrum]\nwavelengths_nm = [{node_list}, 520.0]\n[render]\nsamples = {samples}\nseed = 11\n"
    ));
    let reference = task_fluxes(&mono);
    let solar = SolarSpectrum::kurucz().unwrap();
    let (lo, hi) = (centre - 0.5 * width, centre + 0.5 * width);
    let mut cmp = Comparison::default();
    for units in ["normalized", "absolute"] {
        let banded = job(&format!(
            "{base}[spectrum]\nwavelengths_nm = [{centre}, 520.0]\nband_width_nm = [{width}, 0.0]\n\
             [render]\nsamples = {samples}\nseed = 12\n[output]\nunits = \"{units}\"\n"
        ));
        let shared = task_fluxes(&banded);
        // Quadrature weights of the band (E0-weighted in absolute units)
        // and the factor of the monochromatic channel.
        let (band_weights, mono_factor) = if units == "absolute" {
            (source_weights(&solar, &nodes, lo, hi), solar.irradiance(520.0).unwrap())
        } else {
            (GAUSS_6.iter().map(|&(_, g)| 0.5 * g).collect(), 1.0)
        };
        for (a, albedo) in ["0", "0.4"].iter().enumerate() {
            let channels: [(&str, Vec<(usize, f64)>); 2] = [
                ("band", band_weights.iter().copied().enumerate().collect()),
                ("520 nm", vec![(nodes.len(), mono_factor)]),
            ];
            for (w, (name, parts)) in channels.iter().enumerate() {
                let got = shared[w][a];
                let sum = |f: &dyn Fn(&atmosim::film::fluxes::Fluxes) -> f64| {
                    parts.iter().map(|&(k, c)| c * f(&reference[k][a])).sum::<f64>()
                };
                let e_dir = sum(&|f| f.e_dir);
                assert!(
                    (got.e_dir - e_dir).abs() <= 1e-6 * e_dir,
                    "{units} {name} albedo {albedo}: E_dir {} vs quadrature {e_dir}",
                    got.e_dir
                );
                let var = |f: &dyn Fn(&atmosim::film::fluxes::Fluxes) -> f64| {
                    parts
                        .iter()
                        .map(|&(k, c)| (c * f(&reference[k][a])).powi(2))
                        .sum::<f64>()
                        .sqrt()
                };
                for (what, x, se, r, r_se) in [
                    (
                        "E_down",
                        got.e_down,
                        got.e_down_se,
                        sum(&|f| f.e_down),
                        var(&|f| f.e_down_se),
                    ),
                    ("E_up", got.e_up, got.e_up_se, sum(&|f| f.e_up), var(&|f| f.e_up_se)),
                ] {
                    cmp.add(|| format!("{units} {name} albedo {albedo} {what}"), x, se, r, r_se);
                }
            }
        }
    }
    println!(
        "{}",
        cmp.assert_no_outlier("band fluxes vs quadrature of single wavelengths")
    );
}

#[test]
fn band_sun_tables_average_the_direct_beam_over_the_band() {
    // sun.csv of a band job against the mean of the single-wavelength
    // direct beam over 400 wavelengths across each band (midpoints): the
    // transmittance, and the direct normal irradiance in both units. The
    // bands hold ozone's Huggins structure (320–360 nm) and the Chappuis
    // band (600–640 nm).
    for units in ["normalized", "absolute"] {
        let base = format!(
            "[atmosphere]\nozone = \"bogumil\"\naerosol = \"continental_average\"\n[sun]\nelevation_deg = 12.0\n\
             [observer]\naltitude_km = 0.5\n[output]\nunits = \"{units}\"\nsun = true\n"
        );
        let banded = job(&format!(
            "{base}[spectrum]\nwavelengths_nm = [340.0, 620.0]\nband_width_nm = 40.0\n"
        ));
        let table = atmosim::io::sun_table::sun_csv(&banded, &banded.tasks[0], None);
        let rows: Vec<Vec<f64>> = table
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 2, "{table}");
        for (row, centre) in rows.iter().zip([340.0, 620.0]) {
            assert_eq!(row[0], centre);
            let nodes: Vec<f64> = (0..400)
                .map(|k| centre - 20.0 + 40.0 * (k as f64 + 0.5) / 400.0)
                .collect();
            let list = nodes.iter().map(|l| format!("{l}")).collect::<Vec<_>>().join(", ");
            let mono = job(&format!("{base}[spectrum]\nwavelengths_nm = [{list}]\n"));
            let h = mono.observer_altitude_km;
            let t: Vec<f64> = (0..nodes.len())
                .map(|w| mono.scene(w).direct_normal(h, 0, false))
                .collect();
            let mean_t = t.iter().sum::<f64>() / t.len() as f64;
            let mean_e = t.iter().zip(&nodes).map(|(t, &l)| t * mono.unit_scale(l)).sum::<f64>() / t.len() as f64;
            assert!(
                (row[2] / mean_t - 1.0).abs() < 2e-4,
                "{units} {centre}: T {} vs {mean_t}",
                row[2]
            );
            assert!(
                (row[3] / mean_e - 1.0).abs() < 2e-4,
                "{units} {centre}: E {} vs {mean_e}",
                row[3]
            );
            if units == "normalized" {
                assert_eq!(row[2], row[3]);
            }
        }
    }
}

#[test]
fn spectral_groups_put_every_band_in_its_place() {
    // Bands listed out of wavelength order, split into two groups by
    // column extinction (each with paths of its own): every band's
    // radiances and fluxes, and every band's image, equal those of one
    // group of all the bands (independent seeds), and the groups are the
    // most extinct bands first.
    let base = "[atmosphere]\naerosol = \"continental_average\"\n[sun]\nelevation_deg = 15.0\n\
                [spectrum]\nwavelengths_nm = [740.0, 340.0, 580.0, 420.0]\nband_width_nm = 40.0\n\
                [ground]\nalbedo = [0.0, 0.3]\n";
    let dirs = "[sensor]\ntype = \"directions\"\nview_zenith_deg = [0.0, 60.0, 120.0]\nazimuth_deg = [0.0, 90.0]\n";
    let image = "[sensor]\ntype = \"sphere\"\nresolution = [8, 4]\n[observer]\naltitude_km = 2.0\n";
    for (sensor, samples) in [(dirs, 6000), (image, 600)] {
        let grouped = job(&format!(
            "{base}{sensor}[render]\nsamples = {samples}\nseed = 3\nspectral_groups = 2\n"
        ));
        let one = job(&format!(
            "{base}{sensor}[render]\nsamples = {samples}\nseed = 4\nspectral_groups = 1\n"
        ));
        let task = &grouped.tasks[0];
        assert_eq!(grouped.spectral_groups(task), vec![vec![1, 3], vec![0, 2]]);
        assert_eq!(one.spectral_groups(task), vec![vec![0, 1, 2, 3]]);
        // "auto": two groups over bands whose column extinctions span
        // more than 3 (here 0.93 at 340 nm to 0.11 at 740 nm), by day and
        // with the sun set alike, one over a narrow span (0.38 to 0.25 from
        // 450 to 550 nm).
        let auto = |text: &str| {
            let j = job(text);
            j.spectral_groups(&j.tasks[0])
        };
        assert_eq!(auto(base), vec![vec![1, 3], vec![0, 2]]);
        assert_eq!(
            auto(&base.replace("elevation_deg = 15.0", "elevation_deg = -4.2")),
            vec![vec![1, 3], vec![0, 2]]
        );
        assert_eq!(
            auto(&base.replace("[740.0, 340.0, 580.0, 420.0]", "[450.0, 550.0]")),
            vec![vec![0, 1]]
        );
        let run = |j: &atmosim::job::Job| atmosim::run::task::render_whole(j, &j.tasks[0], &|_| {}, &|_| {}).unwrap();
        let ((gl, gs), (ol, os)) = (run(&grouped), run(&one));
        assert_eq!(gl.groups.len(), 2);
        let mut cmp = Comparison::default();
        if sensor == dirs {
            let g = atmosim::run::assemble::directions_result(&grouped, task, &gl, &gs);
            let o = atmosim::run::assemble::directions_result(&one, task, &ol, &os);
            assert_eq!(g.radiance.len(), 4 * 2 * 6);
            for (a, b) in g.radiance.iter().zip(&o.radiance) {
                assert_eq!((a.wavelength_nm, a.albedo), (b.wavelength_nm, b.albedo));
                for s in 0..3 {
                    cmp.add(
                        || {
                            format!(
                                "{} nm albedo {} {:?} Stokes {s}",
                                a.wavelength_nm, a.albedo, a.direction
                            )
                        },
                        a.tally.mean()[s],
                        a.tally.standard_error()[s],
                        b.tally.mean()[s],
                        b.tally.standard_error()[s],
                    );
                }
            }
            assert_eq!(g.fluxes.len(), 8);
            for (a, b) in g.fluxes.iter().zip(&o.fluxes) {
                assert_eq!((a.wavelength_nm, a.albedo), (b.wavelength_nm, b.albedo));
                assert_eq!(a.fluxes.e_dir, b.fluxes.e_dir);
                cmp.add(
                    || format!("{} nm albedo {} e_down", a.wavelength_nm, a.albedo),
                    a.fluxes.e_down,
                    a.fluxes.e_down_se,
                    b.fluxes.e_down,
                    b.fluxes.e_down_se,
                );
            }
        } else {
            let atmosim::job::Sensor::Image(camera) = &grouped.render.sensor else {
                unreachable!()
            };
            let g = atmosim::run::assemble::image_result(&grouped, camera, &gl, &gs);
            let o = atmosim::run::assemble::image_result(&one, camera, &ol, &os);
            assert_eq!(g.layers.len(), 8);
            for (a, b) in g.layers.iter().zip(&o.layers) {
                assert_eq!((a.wavelength_nm, a.albedo), (b.wavelength_nm, b.albedo));
                for p in 0..32 {
                    cmp.add(
                        || format!("{} nm albedo {} pixel {p}", a.wavelength_nm, a.albedo),
                        a.mean[0][p],
                        a.se[0][p],
                        b.mean[0][p],
                        b.se[0][p],
                    );
                }
            }
        }
        cmp.assert_no_outlier("two spectral groups against one");
    }
}
