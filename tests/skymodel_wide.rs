//! The wide range as a sky model: 55 bands of 40 nm from 280 to 2480 nm
//! (the Prague sky model's newest channels) with every gas on, rendered,
//! fitted by `atmosim fit` and evaluated as the runtime does, on a tiny
//! grid (two sun elevations, one albedo, 32 × 16 spheres, fixed seed).
//!
//! - The dataset has the runtime's 55 channels: start 280 nm, width 40 nm.
//! - The file holds the fit: at every pixel of the first, the 940 nm
//!   (water vapour), the 1380 nm (water vapour, nearly black) and the last
//!   channel, the dataset evaluated at the node equals the fit's own
//!   double-precision reconstruction to within a bound derived from the
//!   file's precisions alone (halves: relative 2⁻¹¹, absolute 2⁻²⁵ below
//!   the normal range; zenith values scaled by 1/max before rounding and
//!   decoded through `f32`), carried through the rank's sum of products
//!   and the emphasis. A channel mix-up would be off by far more.
//! - The transmittance at the tables' nodes (straight up from the ground)
//!   equals the tables' within the largest error the fit reports for them.
//! - `atmosim eval --queries` gives finite, positive radiance in the first,
//!   a middle (940 nm) and the last channel, and the runtime's documented
//!   0 outside the channels (below 280 nm, at 2480 nm and above).
//! - Renders whose gases differ are not one grid: the fit refuses them.

mod common;

use std::path::Path;

use atmosim::io::exr::read_exr;
use atmosim::physics::solar::SolarSpectrum;
use atmosim::skymodel::dataset::Dataset;
use atmosim::skymodel::fit::breaks::{emph_breaks, eval_piecewise, sun_breaks, zenith_breaks};
use atmosim::skymodel::fit::image_fit::{fit_prepared, prepare_layer};
use atmosim::skymodel::fit::settings::FitSettings;
use atmosim::skymodel::fit::{render_layers, renders};
use atmosim::skymodel::runtime::{Model, Parameters};
use common::synthetic_sky::ground_query;
use common::{atmosim, run_ok};

/// The 55 band centres, 300 to 2460 nm.
fn wide_bands() -> Vec<f64> {
    (0..55).map(|k| 300.0 + 40.0 * k as f64).collect()
}

fn atmosphere(gases: &str, wavelengths_nm: &[f64]) -> String {
    let list: Vec<String> = wavelengths_nm.iter().map(|w| format!("{w:.1}")).collect();
    format!(
        "[planet]\nradius_km = 6378.0\ntop_km = 100.0\n\
         [atmosphere]\nprofile = \"us_standard\"\ngases = \"{gases}\"\naerosol = \"continental_average\"\n\
         visibility_km = 40.0\n\
         [spectrum]\nwavelengths_nm = [{}]\nband_width_nm = 40.0\n\
         [observer]\naltitude_km = 0.0\n",
        list.join(", ")
    )
}

fn render_job(
    gases: &str,
    wavelengths_nm: &[f64],
    elevations: &str,
    resolution: &str,
    samples: u32,
    out: &str,
) -> String {
    format!(
        "{}[sun]\nelevation_deg = {elevations}\n[ground]\nalbedo = [0.2]\n\
         [sensor]\ntype = \"sphere\"\nresolution = {resolution}\nstokes_frame = \"sun_view\"\n\
         [render]\nsamples = {samples}\npolarized = true\nseed = 1\n\
         [output]\ndirectory = \"{out}\"\nunits = \"absolute\"\npreview = false\n",
        atmosphere(gases, wavelengths_nm)
    )
}

const ALBEDO: f64 = 0.2;
const ELEVATIONS: [f64; 2] = [0.0, 30.0];
const FIT: &str = "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"sky.dat\"\nresolution = 91\n";
/// Half floats: the unit roundoff of the normal range and half the
/// spacing of the subnormals.
const HALF_RELATIVE: f64 = 1.0 / 2048.0;
const HALF_ABSOLUTE: f64 = 1.0 / (1u64 << 25) as f64;
/// The `f32` decoding of a zenith value (half / zenithScale).
const F32_RELATIVE: f64 = 1.0 / (1u64 << 24) as f64;

/// Renders, tabulates and fits the tiny 55-band grid in `root`.
fn fitted(root: &Path) {
    let bands = wide_bands();
    std::fs::write(
        root.join("render.toml"),
        render_job("all", &bands, "[0.0, 30.0]", "[32, 16]", 16, "renders"),
    )
    .unwrap();
    std::fs::write(
        root.join("tables.toml"),
        format!(
            "{}[transmittance]\nlayout = \"sky_model\"\naltitude_nodes = 8\ndistance_nodes = 12\n\
             estimator = \"analytic\"\n[output]\ndirectory = \"tables\"\n",
            atmosphere("all", &bands)
        ),
    )
    .unwrap();
    std::fs::write(root.join("fit.toml"), FIT).unwrap();
    run_ok(root, &["render", "render.toml", "-q"]);
    run_ok(root, &["transmittance", "tables.toml", "-q"]);
    run_ok(root, &["fit", "fit.toml", "-q"]);
}

#[test]
fn a_55_band_grid_is_rendered_fitted_and_evaluated() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    fitted(root);

    // The runtime's channels.
    let dataset = Dataset::read(&root.join("sky.dat")).unwrap();
    let axes = &dataset.axes;
    assert_eq!(axes.channels, 55);
    assert_eq!(axes.channel_start_nm, 280.0);
    assert_eq!(axes.channel_width_nm, 40.0);
    assert_eq!(axes.channel_end_nm(), 2480.0);
    assert_eq!(axes.elevations_deg, ELEVATIONS.to_vec());
    assert_eq!(axes.albedos, vec![ALBEDO]);
    let model = Model::new("sky.dat", dataset.clone(), SolarSpectrum::kurucz().unwrap()).unwrap();

    // The fit again in double precision, for the channels checked: each
    // elevation's tables borrow from the other's, as in the fit.
    let settings = FitSettings::parse(FIT, "fit.toml").unwrap();
    let grid = renders::scan(&[root.join("renders")]).unwrap();
    let bands = wide_bands();
    let checked: Vec<usize> = [300.0, 940.0, 1380.0, 2460.0]
        .iter()
        .map(|l| bands.iter().position(|b| b == l).unwrap())
        .collect();
    let layers: Vec<_> = grid
        .configs
        .iter()
        .map(|c| render_layers::load(&grid, c).unwrap())
        .collect();
    let prepared: Vec<Vec<_>> = grid
        .configs
        .iter()
        .zip(&layers)
        .map(|(config, ls)| {
            checked
                .iter()
                .map(|&c| prepare_layer(&ls[c], config.elevation_deg, 0.0, &settings, true))
                .collect()
        })
        .collect();
    let (sb, zb, eb) = (
        sun_breaks(settings.sun_breaks),
        zenith_breaks(settings.zenith_breaks),
        emph_breaks(settings.emph_breaks),
    );
    let abs = |v: &[f64]| v.iter().map(|x| x.abs()).collect::<Vec<f64>>();
    for (e, config) in grid.configs.iter().enumerate() {
        let elevation = config.elevation_deg.to_radians();
        for (k, &c) in checked.iter().enumerate() {
            let own = fit_prepared(&prepared[e][k], &[&prepared[1 - e][k]], &settings);
            let components = &own.radiance.components;
            // What the file's precisions allow each stored value to move.
            let zenith_absolute: Vec<f64> = components
                .iter()
                .map(|comp| {
                    let max = comp.zenith.iter().fold(0.0f64, |m, z| m.max(z.abs()));
                    // Scaled by 1/max before rounding: a half's absolute
                    // step is max times as large unscaled.
                    HALF_ABSOLUTE * if max >= 2f64.powi(-102) { max } else { 1.0 }
                })
                .collect();
            let sun_abs: Vec<Vec<f64>> = components.iter().map(|comp| abs(&comp.sun)).collect();
            let zenith_abs: Vec<Vec<f64>> = components.iter().map(|comp| abs(&comp.zenith)).collect();
            let emph_abs = abs(&own.radiance.emph);
            let image = &layers[e][c].radiance;
            let (mut worst_ratio, mut worst_error, mut peak) = (0.0f64, 0.0f64, 0.0f64);
            for j in 0..image.height {
                for i in 0..image.width {
                    let (a, p) = ground_query(image.direction(i, j), elevation, 40.0, ALBEDO);
                    let from_file = model.sky_radiance(&p, bands[c]);
                    let emph = eval_piecewise(&eb, &own.radiance.emph, a.zero);
                    let sum: f64 = components
                        .iter()
                        .map(|k| eval_piecewise(&sb, &k.sun, a.gamma) * eval_piecewise(&zb, &k.zenith, a.zero))
                        .sum();
                    let double = (sum * emph).max(0.0);
                    // |S′Z′ − SZ| ≤ (|S| + ΔS)(|Z| + ΔZ) − |S||Z| per
                    // component, with ΔX = ε|X| + η at either break of the
                    // piecewise-linear lookup; then the emphasis likewise.
                    let mut sum_bound = 0.0;
                    let mut sum_abs = 0.0;
                    for r in 0..components.len() {
                        let s = eval_piecewise(&sb, &sun_abs[r], a.gamma);
                        let z = eval_piecewise(&zb, &zenith_abs[r], a.zero);
                        let ds = HALF_RELATIVE * s + HALF_ABSOLUTE;
                        let dz = (HALF_RELATIVE + F32_RELATIVE) * (1.0 + HALF_RELATIVE) * z + zenith_absolute[r];
                        sum_bound += (s + ds) * (z + dz) - s * z;
                        sum_abs += s * z;
                    }
                    let e_abs = eval_piecewise(&eb, &emph_abs, a.zero);
                    let de = HALF_RELATIVE * e_abs + HALF_ABSOLUTE;
                    // The runtime's sums in f64 of f32 values: 10⁻¹² of the
                    // magnitudes covers them.
                    let bound = sum_bound * (e_abs + de) + sum_abs * de + 1e-12 * sum_abs * e_abs;
                    let error = (from_file - double).abs();
                    assert!(
                        error <= bound,
                        "{} nm, sun {}°, pixel ({i}, {j}): file {from_file:e}, fit {double:e}, bound {bound:e}",
                        bands[c],
                        config.elevation_deg
                    );
                    if bound > 0.0 {
                        worst_ratio = worst_ratio.max(error / bound);
                    }
                    worst_error = worst_error.max(error);
                    peak = peak.max(double);
                }
            }
            eprintln!(
                "{} nm, sun {}°: file against fit {worst_error:.3e} at most ({:.2e} of the peak {peak:.3e}), \
                 {worst_ratio:.3} of the halves' bound",
                bands[c],
                config.elevation_deg,
                worst_error / peak.max(f64::MIN_POSITIVE)
            );
            assert!(
                peak > 0.0,
                "{} nm, sun {}°: a black fit",
                bands[c],
                config.elevation_deg
            );
        }
    }

    // Transmittance at the nodes straight up from the ground (distance
    // node 0), against the tables, within the fit's own figure for them.
    let provenance = std::fs::read_to_string(root.join("sky.dat.toml")).unwrap();
    let reported: f64 = provenance
        .lines()
        .find_map(|l| l.strip_prefix("transmittance_max_abs_error = "))
        .expect("the fit reports its transmittance error")
        .trim()
        .parse()
        .unwrap();
    // The figure is printed to 7 significant digits.
    let allowed = reported * (1.0 + 1e-6);
    let table = read_exr(&root.join("tables").join("transmittance.exr")).unwrap();
    let attribute = |k: &str| -> Vec<f64> {
        let (_, v) = table.attributes.iter().find(|(a, _)| a == k).unwrap();
        v.split_whitespace().map(|x| x.parse().unwrap()).collect()
    };
    let altitudes_km = attribute("altitudes_km");
    for &c in &checked {
        let name = format!("{}nm.T", bands[c]);
        let channel = table.channels.iter().find(|ch| ch.name == name).unwrap();
        for (i, &a_km) in altitudes_km.iter().enumerate().skip(1) {
            let expected = channel.samples[i * table.width] as f64;
            // The runtime's viewpoint is 50 m up: its path ends at a.
            let p = Parameters::new(glam::DVec3::ZERO, glam::DVec3::Z, 0.3, 0.0, 40.0, ALBEDO);
            let t = model.transmittance(&p, bands[c], a_km * 1000.0 - 50.0);
            assert!(
                (t - expected).abs() <= allowed,
                "T up to {a_km} km at {} nm: {t} vs the table's {expected} (the fit reports {reported:e})",
                bands[c]
            );
        }
    }

    // `atmosim eval --queries`: the first, a middle and the last channel
    // answer; outside the channels the runtime gives 0.
    let header = "view_x_m,view_y_m,view_z_m,dir_x,dir_y,dir_z,sun_elevation_deg,sun_azimuth_deg,visibility_km,albedo,wavelength_nm,distance_m";
    let inside = [280.0, 300.0, 940.0, 2479.9];
    let outside = [279.9, 2480.0, 2500.0];
    let rows: Vec<String> = inside
        .iter()
        .chain(&outside)
        .map(|l| format!("0,0,0,0.3,0.2,0.5,20,0,40,{ALBEDO},{l},inf"))
        .collect();
    std::fs::write(root.join("q.csv"), format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    let out = run_ok(root, &["eval", "sky.dat", "--queries", "q.csv"]);
    let text = String::from_utf8(out.stdout).unwrap();
    for (line, lambda) in text.lines().skip(1).zip(inside.iter().chain(&outside)) {
        let answers: Vec<f64> = line.split(',').skip(12).map(|x| x.parse().unwrap()).collect();
        let (sky, pol, t) = (answers[0], answers[2], answers[3]);
        if inside.contains(lambda) {
            assert!(
                sky.is_finite() && sky > 0.0 && pol.is_finite() && t > 0.0 && t <= 1.0,
                "{lambda} nm: {answers:?}"
            );
        } else {
            assert_eq!([sky, pol, t], [0.0, 0.0, 0.0], "{lambda} nm, outside the channels");
        }
    }
    // The channel rule: 280 nm is the first channel's, 2479.9 nm the last's.
    let first: Vec<&str> = text
        .lines()
        .skip(1)
        .take(2)
        .map(|l| l.rsplit(',').nth(3).unwrap())
        .collect();
    assert_eq!(first[0], first[1], "280 and 300 nm share the first channel");
}

/// Renders with gases and without are two atmospheres, not one grid.
#[test]
fn renders_with_other_gases_are_not_one_grid() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    for (gases, elevation) in [("all", "[10.0]"), ("none", "[30.0]")] {
        std::fs::write(
            root.join(format!("{gases}.toml")),
            render_job(
                gases,
                &[940.0, 980.0],
                elevation,
                "[8, 4]",
                2,
                &format!("renders/{gases}"),
            ),
        )
        .unwrap();
        run_ok(root, &["render", &format!("{gases}.toml"), "-q"]);
    }
    std::fs::write(
        root.join("fit.toml"),
        "renders = [\"renders/all\", \"renders/none\"]\nout = \"sky.dat\"\n",
    )
    .unwrap();
    let out = atmosim()
        .current_dir(root)
        .args(["fit", "fit.toml", "-q"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("atmosphere") && err.contains("gases none"), "{err}");
    assert!(!root.join("sky.dat").exists());
}
