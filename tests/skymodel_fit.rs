//! The fitter end to end on synthetic inputs: a separable sky and
//! separable transmittance tables written as atmosim's own files, through
//! `atmosim fit` → dataset file → the runtime's evaluation.
//!
//! - The file holds the fit to half-float precision: the dataset evaluated
//!   at each pixel equals the fit's double-precision reconstruction to the
//!   rounding of halves (≤ 2⁻¹¹ relative per stored value, so a few 10⁻³
//!   of the image's peak for a rank-1 product and its emphasis).
//! - The fit holds the sky: a rank-1 sky F(γ)·G(θ′), smooth across the
//!   horizon, comes back to the bilinear resolution of the image.
//! - Transmittance tables of rank ≤ 2 come back at the nodes to f32.
//! - A truncated or a longer file is refused with exit 2.

mod common;

use std::path::Path;

use atmosim::job::transmittance::Grid;
use atmosim::physics::solar::SolarSpectrum;
use atmosim::sensor::camera::{Camera, Hemisphere, Projection};
use atmosim::skymodel::angles::ViewAngles;
use atmosim::skymodel::dataset::Dataset;
use atmosim::skymodel::fit::breaks::{emph_breaks, eval_piecewise, sun_breaks, zenith_breaks};
use atmosim::skymodel::fit::image_fit::{fit_prepared, prepare_layer};
use atmosim::skymodel::fit::settings::FitSettings;
use atmosim::skymodel::fit::{render_layers, renders};
use atmosim::skymodel::runtime::{Model, Parameters};
use common::synthetic_sky::{
    SyntheticSky, ground_query, sqrt_t, write_render as write_synthetic, write_transmittance_table,
};
use common::{atmosim, run_ok};

const WAVELENGTHS: [f64; 2] = [500.0, 600.0];
const ELEVATIONS: [f64; 2] = [10.0, 30.0];
const ALBEDO: f64 = 0.3;
const WIDTH: usize = 256;
const HEIGHT: usize = 128;

/// The synthetic sky: F(γ)·G(θ) per channel, G smooth over the horizon.
fn sky(gamma: f64, theta: f64, channel: usize) -> f64 {
    // Smooth at the sun (no cusp that bilinear sampling would cut).
    let f = 1.0 + 2.0 * (-gamma * gamma / 0.1).exp();
    let g = 1.2 + theta.cos();
    (1.0 + channel as f64) * 0.1 * f * g
}

/// A signed degree of polarisation in the sun–view frame.
fn dolp(gamma: f64) -> f64 {
    0.6 * gamma.sin().powi(2) / (1.0 + gamma.cos().powi(2))
}

fn write_render(dir: &Path, elevation: f64) {
    write_camera_render(
        dir,
        elevation,
        Camera::Sphere {
            width: WIDTH,
            height: HEIGHT,
        },
    );
}

/// The synthetic sky as one camera sees it (pixel centres; 0 outside a
/// fisheye's circle).
fn write_camera_render(dir: &Path, elevation: f64, camera: Camera) {
    let value = |a: &ViewAngles, c: usize| {
        let value = sky(a.gamma, a.theta, c);
        (value, value * dolp(a.gamma))
    };
    let synthetic = SyntheticSky {
        wavelengths_nm: &WAVELENGTHS,
        band_width_nm: 100.0,
        albedo: ALBEDO,
        value: &value,
        noise: None,
    };
    write_synthetic(dir, elevation, camera, &synthetic);
}

fn write_table(dir: &Path) {
    write_transmittance_table(dir, &WAVELENGTHS);
}

#[test]
fn a_separable_sky_goes_through_fit_file_and_eval() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    for e in ELEVATIONS {
        write_render(&root.join("renders").join(format!("elev{e}")), e);
    }
    write_table(&root.join("tables"));
    let fit_toml = "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"sky.dat\"\nblur_sigma = 0.0\n\
                    transmittance_rank = 2\n";
    std::fs::write(root.join("fit.toml"), fit_toml).unwrap();
    run_ok(root, &["fit", "fit.toml", "-q"]);
    assert!(root.join("sky.dat.toml").is_file() && root.join("sky.dat.fit.csv").is_file());

    let dataset = Dataset::read(&root.join("sky.dat")).unwrap();
    assert_eq!(dataset.axes.channel_start_nm, 450.0);
    assert_eq!(dataset.axes.channel_width_nm, 100.0);
    assert_eq!(dataset.axes.elevations_deg, ELEVATIONS.to_vec());
    let model = Model::new("sky.dat", dataset, SolarSpectrum::kurucz().unwrap()).unwrap();

    // The fit again in double precision, to see what the halves cost.
    let settings = FitSettings::parse(fit_toml, "fit.toml").unwrap();
    let grid = renders::scan(&[root.join("renders")]).unwrap();
    let (sb, zb, eb) = (sun_breaks(275), zenith_breaks(205), emph_breaks(118));
    let (mut worst_half, mut worst_truth, mut worst_pol) = (0.0f64, 0.0f64, 0.0f64);
    // Each elevation's tables borrow from the other's, as in the fit.
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
            ls.iter()
                .map(|l| prepare_layer(l, config.elevation_deg, 0.0, &settings, true))
                .collect()
        })
        .collect();
    for (e, config) in grid.configs.iter().enumerate() {
        for (c, layer) in layers[e].iter().enumerate() {
            let own = fit_prepared(&prepared[e][c], &[&prepared[1 - e][c]], &settings);
            let img = &layer.radiance;
            let peak = img.values.iter().fold(0.0f64, |m, &v| m.max(v));
            let elevation = config.elevation_deg.to_radians();
            for j in 0..img.height {
                for i in 0..img.width {
                    let v = img.direction(i, j);
                    let (a, p) = ground_query(v, elevation, 50.0, ALBEDO);
                    let lambda = WAVELENGTHS[c];
                    let from_file = model.sky_radiance(&p, lambda);
                    let double: f64 = own
                        .radiance
                        .components
                        .iter()
                        .map(|k| eval_piecewise(&sb, &k.sun, a.gamma) * eval_piecewise(&zb, &k.zenith, a.zero))
                        .sum::<f64>()
                        * eval_piecewise(&eb, &own.radiance.emph, a.zero);
                    worst_half = worst_half.max((from_file - double.max(0.0)).abs() / peak);
                    let e = (from_file - sky(a.gamma, a.theta, c)).abs() / peak;
                    worst_truth = worst_truth.max(e);
                    let pol = model.polarisation(&p, lambda).unwrap();
                    worst_pol = worst_pol.max((pol - dolp(a.gamma)).abs());
                }
            }
        }
    }
    // Halves: 11 significant bits per factor; with the breaks' resampling
    // identical on both sides only the rounding differs.
    assert!(
        worst_half < 3.0 * 2f64.powi(-11),
        "half-float loss {worst_half:e} of the peak"
    );
    // The fit's own figure of that loss, per image in the figures file: an
    // error below 3·2⁻¹¹ of the peak everywhere is an SNR above
    // 20·log10(2¹¹/3) = 56.7 dB against the peak, and this sky's rms is
    // above a fifth of its peak (G ≥ 0.2, F ≥ 1), so at least 42.7 dB;
    // and halves are not exact, so it is finite.
    let figures = std::fs::read_to_string(root.join("sky.dat.fit.csv")).unwrap();
    let header: Vec<&str> = figures.lines().next().unwrap().split(',').collect();
    let at = header
        .iter()
        .position(|&c| c == "half_float_snr_db")
        .expect("a half_float_snr_db column");
    for row in figures.lines().skip(1) {
        let snr: f64 = row.split(',').nth(at).unwrap().parse().unwrap();
        assert!(snr > 42.7 && snr.is_finite(), "half-float SNR {snr} dB");
    }
    // fit-report with a node's own render as the "between-node" render:
    // the interpolation is the identity there, so the ratio compares the
    // dataset's fit (whose cells outside the 10° sky are the 30° sky's
    // data) with the render's fit alone (a harmonic fill there): the data
    // must not fit worse than the fill (measured 0.773: the rank is spent
    // on sky, not on the fill's shape).
    let out = atmosim()
        .current_dir(root)
        .args(["fit-report", "fit.toml", "--mid", "renders/elev10"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report = std::fs::read_to_string(root.join("sky.dat.report").join("report.md")).unwrap();
    assert!(report.contains("loss from half floats"), "{report}");
    let line = report
        .lines()
        .find(|l| l.contains("interpolation ratio"))
        .expect("an interpolation row");
    let ratio: f64 = line
        .rsplit('|')
        .nth(1)
        .unwrap()
        .split('/')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!(ratio > 0.0 && ratio <= 1.0, "{line}");
    // The interpolated dataset's own SNR: at a node it is the dataset, so
    // its mean and minimum are those of the node's images in the report's
    // per-image table (printed to 0.01 dB).
    let numbers = |line: &str| -> Vec<f64> {
        line.rsplit('|')
            .nth(1)
            .unwrap()
            .trim()
            .trim_end_matches("dB")
            .split('/')
            .map(|v| v.trim().parse().unwrap())
            .collect()
    };
    let line = report
        .lines()
        .find(|l| l.contains("SNR of the interpolated dataset"))
        .expect("a row of the interpolated dataset's SNR");
    let (mean, min) = (numbers(line)[0], numbers(line)[1]);
    let at_node: Vec<f64> = report
        .split("## Per image")
        .nth(1)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            (cells.len() > 6 && cells[4] == "10").then(|| cells[6].parse().unwrap())
        })
        .collect();
    assert!(!at_node.is_empty(), "{report}");
    let node_mean = at_node.iter().sum::<f64>() / at_node.len() as f64;
    let node_min = at_node.iter().fold(f64::INFINITY, |m: f64, &v| m.min(v));
    assert!(
        (mean - node_mean).abs() < 0.011 && (min - node_min).abs() < 0.011,
        "{line}: the node's images {node_mean} / {node_min}"
    );
    // The sky: not exact, because half the (γ, α) table has no data and
    // the rank truncation spends some of its rank on the fill there. The
    // error is largest next to the sun at the edge of the valid region;
    // measured 2.5 % of the peak with the harmonic fill alone, 1.34 % after
    // 20 rounds of hard imputation, 0.7 % after 200, 0.35 % with the
    // weighted decomposition (the fill weighing 10⁻⁶, 2026-11-29; the
    // bilinear sampling of this smooth 1.4°-pixel image adds 0.2 % at most).
    assert!(
        worst_truth < 0.02,
        "fit vs the synthetic sky: {worst_truth:e} of the peak"
    );
    // The degree of polarisation, a function of γ alone (rank 1): the same
    // cause at rank 5, measured 1.49e-2 in absolute degree of polarisation
    // with hard imputation, 9.6e-3 with the weighted decomposition.
    assert!(worst_pol < 0.02, "polarisation: {worst_pol:e}");

    // Transmittance at the nodes (rank 2 of a rank-2 table: f32 exact).
    let grid_t = Grid::sky_model_runtime(8, 12);
    for (c, lambda) in WAVELENGTHS.iter().enumerate() {
        for &a in &grid_t.altitudes_km[1..] {
            // Straight up from the ground to altitude a: d = 0.
            let p = Parameters::new(glam::DVec3::ZERO, glam::DVec3::Z, 0.3, 0.0, 50.0, ALBEDO);
            // The runtime's viewpoint is 50 m up: ask for a − 0.05 km.
            let t = model.transmittance(&p, *lambda, a * 1000.0 - 50.0);
            let expected = sqrt_t(a, 0.0, c).powi(2);
            assert!(
                (t - expected).abs() < 1e-5,
                "T up to {a} km at {lambda} nm: {t} vs {expected}"
            );
        }
    }
}

/// A directory with the synthetic sky at 10° fitted coarsely into `sky.dat`.
fn fit_one_configuration() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    write_render(&root.join("renders").join("elev10"), 10.0);
    write_table(&root.join("tables"));
    std::fs::write(
        root.join("fit.toml"),
        "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"sky.dat\"\ntransmittance_rank = 2\nresolution = 91\n",
    )
    .unwrap();
    let out = atmosim()
        .current_dir(root)
        .args(["fit", "fit.toml", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    dir
}

#[test]
fn damaged_datasets_are_refused_with_exit_2() {
    let dir = fit_one_configuration();
    let root = dir.path();
    let bytes = std::fs::read(root.join("sky.dat")).unwrap();
    for (name, data) in [
        ("short.dat", &bytes[..bytes.len() - 3]),
        ("long.dat", &[bytes.as_slice(), &[0u8]].concat()[..]),
    ] {
        std::fs::write(root.join(name), data).unwrap();
        let out = atmosim()
            .current_dir(root)
            .args(["eval", name, "--info"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(name) && (err.contains("truncated") || err.contains("after")),
            "{name}: {err}"
        );
    }
    // A fit without its required keys names them.
    std::fs::write(root.join("bad.toml"), "renders = \"renders\"\n").unwrap();
    let out = atmosim().current_dir(root).args(["fit", "bad.toml"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("`out`"));
}

/// An up and a down fisheye of each configuration fit like a sphere: the
/// fit resamples them onto a sphere twice as wide as they are high.
#[test]
fn up_and_down_fisheyes_fit_like_a_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    for (name, hemisphere) in [("up", Hemisphere::Up), ("down", Hemisphere::Down)] {
        let camera = Camera::Fisheye {
            resolution: 128,
            hemisphere,
            projection: Projection::Equisolid,
        };
        write_camera_render(&root.join("renders").join(name), 20.0, camera);
    }
    write_table(&root.join("tables"));
    std::fs::write(
        root.join("fit.toml"),
        "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"sky.dat\"\ntransmittance_rank = 2\n",
    )
    .unwrap();
    let out = atmosim()
        .current_dir(root)
        .args(["fit", "fit.toml", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let model = Model::new(
        "sky.dat",
        Dataset::read(&root.join("sky.dat")).unwrap(),
        SolarSpectrum::kurucz().unwrap(),
    )
    .unwrap();
    let elevation = 20f64.to_radians();
    let mut worst = 0.0f64;
    let peak = sky(0.0, std::f64::consts::FRAC_PI_2 - elevation, 0);
    for e in (-80..=80).step_by(10) {
        for az in (0..360).step_by(15) {
            let (e, az) = ((e as f64).to_radians(), (az as f64).to_radians());
            let v = glam::DVec3::new(e.cos() * az.cos(), e.cos() * az.sin(), e.sin());
            let (a, p) = ground_query(v, elevation, 50.0, ALBEDO);
            worst = worst.max((model.sky_radiance(&p, 500.0) - sky(a.gamma, a.theta, 0)).abs() / peak);
        }
    }
    // The sphere's bound (2 % of the peak, see above) holds through the
    // fisheyes' resampling too.
    assert!(worst < 0.02, "fisheye fit vs the synthetic sky: {worst:e} of the peak");
}

/// `atmosim eval DATASET --queries Q.csv`: the rows come back with the
/// runtime's four answers appended, equal to the library's; bad rows are
/// refused with exit 2 before any answer.
#[test]
fn queries_are_answered_as_the_runtime_takes_them() {
    let dir = fit_one_configuration();
    let root = dir.path();
    let header = "view_x_m,view_y_m,view_z_m,dir_x,dir_y,dir_z,sun_elevation_deg,sun_azimuth_deg,visibility_km,albedo,wavelength_nm,distance_m";
    let rows = [
        "0,0,0,0.5,0.2,0.6,10,0,50,0.3,520,inf",
        "100,-50,20,-0.3,0.1,0.2,10,30,50,0.3,590,2000",
    ];
    std::fs::write(root.join("q.csv"), format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    let out = atmosim()
        .current_dir(root)
        .args(["eval", "sky.dat", "--queries", "q.csv"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        format!("{header},sky_radiance,sun_radiance,polarisation,transmittance")
    );
    let model = Model::new(
        "sky.dat",
        Dataset::read(&root.join("sky.dat")).unwrap(),
        SolarSpectrum::kurucz().unwrap(),
    )
    .unwrap();
    for (row, line) in rows.iter().zip(lines) {
        let v: Vec<f64> = row.split(',').map(|x| x.parse().unwrap()).collect();
        let answers: Vec<f64> = line.split(',').skip(12).map(|x| x.parse().unwrap()).collect();
        let p = Parameters::new(
            glam::DVec3::new(v[0], v[1], v[2]),
            glam::DVec3::new(v[3], v[4], v[5]),
            v[6].to_radians(),
            v[7].to_radians(),
            v[8],
            v[9],
        );
        let distance = if v[11].is_infinite() { f64::MAX } else { v[11] };
        let expected = [
            model.sky_radiance(&p, v[10]),
            model.sun_radiance(&p, v[10]),
            model.polarisation(&p, v[10]).unwrap(),
            model.transmittance(&p, v[10], distance),
        ];
        for (a, e) in answers.iter().zip(expected) {
            assert!(
                (a - e).abs() <= 1e-8 * e.abs().max(1e-30),
                "{row}: {answers:?} vs {expected:?}"
            );
        }
        assert!(
            answers[0] > 0.0 && answers[3] > 0.0 && answers[3] <= 1.0,
            "{row}: {answers:?}"
        );
    }
    std::fs::write(
        root.join("bad.csv"),
        format!("{header}\n0,0,-5,0,0,1,10,0,50,0.3,520,inf\n"),
    )
    .unwrap();
    let out = atmosim()
        .current_dir(root)
        .args(["eval", "sky.dat", "--queries", "bad.csv"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("view_z_m"));
    assert!(out.stdout.is_empty());
}

/// A smooth sky, brighter with the sun, with an aureole a hundred times
/// the zenith whose width changes with the zenith angle (no rank-9 table
/// holds it exactly), and a horizon that brightens slowly.
fn zenith_sky(gamma: f64, theta: f64, elevation: f64) -> f64 {
    let c = theta.cos();
    let sky = (1.2 + c) * (1.0 + 0.5 * (-gamma / 0.5).exp()) + 100.0 * (-gamma * (2.0 + c) / 0.1).exp();
    (0.1 + elevation.sin()) * sky + 0.5 * (1.0 - c * c)
}

/// The zenith (issue 61): near it a sun elevation's (γ, α) table has one
/// to a few cells per row with data among 361, the rest filled; a
/// decomposition that lets the fill weigh there sets the zenith from the
/// fill. The synthetic sky is smooth at the zenith (64 × 32 pixels, the
/// first row 2.8° from it, where the sky's curvature moves the row's mean
/// by 0.3 % from the zenith's value), so the dataset's relative error at
/// the zenith, and half a degree from it, may be no larger than its
/// largest relative error over the rest of the sky away from the sun (10°
/// to 80° from the zenith, 30° or more from the sun): the fit's own error
/// on the same dataset through the same runtime. Measured on 2026-11-29:
/// the zenith 5.3 % off against 2.6 % elsewhere with the sun 5° up when
/// the fill weighed alike and was imputed 20 rounds (before the weighted
/// decomposition), 0.50 % against 0.82 % now.
#[test]
fn the_zenith_is_held_as_the_rest_of_the_sky() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let elevations = [5.0, 30.0];
    for e in elevations {
        let value = |a: &ViewAngles, _c: usize| (zenith_sky(a.gamma, a.theta, f64::to_radians(e)), 0.0);
        let synthetic = SyntheticSky {
            wavelengths_nm: &WAVELENGTHS[..1],
            band_width_nm: 100.0,
            albedo: ALBEDO,
            value: &value,
            noise: None,
        };
        let camera = Camera::Sphere { width: 64, height: 32 };
        write_synthetic(&root.join("renders").join(format!("elev{e}")), e, camera, &synthetic);
    }
    write_transmittance_table(&root.join("tables"), &WAVELENGTHS[..1]);
    std::fs::write(
        root.join("fit.toml"),
        "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"sky.dat\"\ntransmittance_rank = 2\n\
         polarisation_rank = 0\n",
    )
    .unwrap();
    run_ok(root, &["fit", "fit.toml", "-q"]);
    let model = Model::new(
        "sky.dat",
        Dataset::read(&root.join("sky.dat")).unwrap(),
        SolarSpectrum::kurucz().unwrap(),
    )
    .unwrap();
    let lambda = WAVELENGTHS[0];
    for e in elevations {
        let elevation = f64::to_radians(e);
        let relative_error = |v: glam::DVec3| {
            let (a, p) = ground_query(v, elevation, 50.0, ALBEDO);
            let truth = zenith_sky(a.gamma, a.theta, elevation);
            (model.sky_radiance(&p, lambda) - truth).abs() / truth
        };
        let mut rest = 0.0f64;
        for z in (10..=80).step_by(2) {
            for az in (0..360).step_by(5) {
                let (z, az) = (f64::from(z).to_radians(), f64::from(az).to_radians());
                let v = glam::DVec3::new(z.sin() * az.cos(), z.sin() * az.sin(), z.cos());
                if ground_query(v, elevation, 50.0, ALBEDO).0.gamma >= 30f64.to_radians() {
                    rest = rest.max(relative_error(v));
                }
            }
        }
        let zenith = relative_error(glam::DVec3::Z);
        let half = 0.5f64.to_radians();
        let near = [1.0, -1.0].map(|s| relative_error(glam::DVec3::new(s * half.sin(), 0.0, half.cos())));
        println!("sun {e}°: zenith {zenith:.4}, 0.5° from it {near:.4?}, the rest of the sky at most {rest:.4}");
        assert!(
            zenith <= rest,
            "sun {e}°: zenith error {zenith:.4} vs the rest's {rest:.4}"
        );
        for n in near {
            assert!(
                n <= rest,
                "sun {e}°: 0.5° from the zenith {n:.4} vs the rest's {rest:.4}"
            );
        }
    }
}
