//! Physics of a fitted sky, from real renders through `atmosim fit` and
//! the runtime's evaluation: a Rayleigh-only sky (no aerosol) at two sun
//! elevations, small images.
//!
//! - The evaluated degree of polarisation is positive over the sky more
//!   than 20° from the sun and largest about 90° from it (single Rayleigh
//!   scattering peaks at 90°; multiple scattering and the ground move the
//!   peak a few degrees). Nearer the sun it is negative between the sun and
//!   the Babinet and Brewster neutral points: a 512-sample render of this
//!   sky at 550 nm has Q/I = −0.020 ± 0.002 at 35° elevation above the 30°
//!   sun, 0 near 42°.
//! - With the sun 3° below the horizon, the Earth's shadow lies on the
//!   horizon opposite the sun: the sky there is darker just above the
//!   horizon than 10° higher, and darker than just above the horizon
//!   toward the sun.

mod common;

use atmosim::physics::solar::SolarSpectrum;
use atmosim::skymodel::dataset::Dataset;
use atmosim::skymodel::runtime::{Model, Parameters};
use common::run_ok;
use glam::DVec3;

const ATMOSPHERE: &str = "[atmosphere]\nprofile = \"us_standard\"\naerosol = \"none\"\n\
                          [spectrum]\nwavelengths_nm = [450.0, 550.0]\n[observer]\naltitude_km = 0.0\n";

#[test]
fn a_fitted_rayleigh_sky_polarises_at_90_degrees_and_shows_the_earths_shadow() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::write(
        root.join("render.toml"),
        format!(
            "{ATMOSPHERE}[sun]\nelevation_deg = [-3.0, 30.0]\n[ground]\nalbedo = 0.0\n\
             [sensor]\ntype = \"sphere\"\nresolution = [64, 32]\nstokes_frame = \"sun_view\"\n\
             [render]\nsamples = 128\npolarized = true\nseed = 3\n[output]\ndirectory = \"renders\"\nunits = \"absolute\"\npreview = false\n"
        ),
    )
    .unwrap();
    std::fs::write(
        root.join("tables.toml"),
        format!(
            "{ATMOSPHERE}[transmittance]\nlayout = \"sky_model\"\naltitude_nodes = 8\ndistance_nodes = 12\n\
             estimator = \"analytic\"\n[output]\ndirectory = \"tables\"\n"
        ),
    )
    .unwrap();
    std::fs::write(
        root.join("fit.toml"),
        "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"sky.dat\"\nresolution = 181\n",
    )
    .unwrap();
    run_ok(root, &["render", "render.toml", "-q"]);
    run_ok(root, &["transmittance", "tables.toml", "-q"]);
    // This grid has no 0° node: the fit says what that costs.
    let out = run_ok(root, &["fit", "fit.toml", "-q"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("from -3° to 30° with no 0° node"), "{err}");
    let model = Model::new(
        "sky.dat",
        Dataset::read(&root.join("sky.dat")).unwrap(),
        SolarSpectrum::kurucz().unwrap(),
    )
    .unwrap();
    let view = |elevation_deg: f64, azimuth_deg: f64| {
        let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
        DVec3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin())
    };
    let params = |v: DVec3, sun_deg: f64| Parameters::new(DVec3::ZERO, v, sun_deg.to_radians(), 0.0, 0.0, 0.0);

    // Polarisation under a sun 30° high, over the sky above 5°.
    let mut by_gamma = [(0.0f64, 0usize); 18];
    for e in (5..90).step_by(5) {
        for a in (0..360).step_by(10) {
            let p = params(view(e as f64, a as f64), 30.0);
            let dop = model.polarisation(&p, 550.0).unwrap();
            assert!(
                dop > 0.0 || p.gamma < 20f64.to_radians(),
                "degree of polarisation {dop} at elevation {e}°, azimuth {a}°"
            );
            let bin = ((p.gamma.to_degrees() / 10.0) as usize).min(17);
            by_gamma[bin].0 += dop;
            by_gamma[bin].1 += 1;
        }
    }
    let means: Vec<f64> = by_gamma
        .iter()
        .map(|(s, n)| if *n > 0 { s / *n as f64 } else { 0.0 })
        .collect();
    let peak = (0..18).max_by(|&i, &j| means[i].total_cmp(&means[j])).unwrap();
    assert!(
        (7..=10).contains(&peak),
        "largest degree of polarisation at γ ≈ {}°: {means:?}",
        peak * 10 + 5
    );
    assert!(means[peak] > 2.0 * means[1], "{means:?}");

    // The Earth's shadow with the sun 3° below the horizon.
    let radiance = |e: f64, a: f64| model.sky_radiance(&params(view(e, a), -3.0), 450.0);
    let (anti_low, anti_high) = (radiance(1.0, 180.0), radiance(10.0, 180.0));
    let sun_low = radiance(1.0, 0.0);
    assert!(anti_low > 0.0);
    assert!(
        anti_low < anti_high,
        "opposite the sun: {anti_low} at 1° vs {anti_high} at 10°"
    );
    assert!(
        anti_low < sun_low,
        "at 1°: {anti_low} opposite the sun vs {sun_low} toward it"
    );
}
