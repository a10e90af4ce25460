//! Synthetic renders for the fitter's tests: a sky given as a function of
//! the runtime's angles, written as atmosim writes an image task
//! (`image.exr` with its attributes and `task.toml`), optionally with
//! Gaussian noise of a known standard error recorded in `I_se`.

use std::path::Path;

use atmosim::io::exr::{Channel, write_exr};
use atmosim::io::sky_image::layer_name;
use atmosim::job::transmittance::Grid;
use atmosim::sensor::camera::Camera;
use atmosim::skymodel::angles::{SunPosition, ViewAngles};
use atmosim::skymodel::runtime::Parameters;
use glam::DVec3;
use rand::{Rng, SeedableRng};

/// What a synthetic render holds.
pub struct SyntheticSky<'a> {
    pub wavelengths_nm: &'a [f64],
    pub band_width_nm: f64,
    pub albedo: f64,
    /// (I, Q in the sun–view frame) of a view with angles `a` in channel c.
    pub value: &'a dyn Fn(&ViewAngles, usize) -> (f64, f64),
    /// Noise: each pixel's I gets a Gaussian deviate of standard deviation
    /// `relative · I` (recorded as its `I_se`), drawn from `seed`.
    pub noise: Option<(f64, u64)>,
}

/// Writes `sky` seen by `camera` with the sun at `elevation` (deg) into the
/// task directory `dir` (pixel centres; 0 outside a fisheye's circle).
pub fn write_render(dir: &Path, elevation: f64, camera: Camera, sky: &SyntheticSky) {
    std::fs::create_dir_all(dir).unwrap();
    let (width, height) = camera.size();
    let sun = SunPosition {
        elevation: elevation.to_radians(),
        azimuth: 0.0,
    };
    let mut rng = rand_pcg::Pcg64::seed_from_u64(sky.noise.map_or(0, |n| n.1));
    let mut uniform = move || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    let mut gaussian = move || {
        // Box–Muller.
        let (u1, u2) = (uniform(), uniform());
        (-2.0 * (1.0 - u1).ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    };
    let mut channels = Vec::new();
    for (c, lambda) in sky.wavelengths_nm.iter().enumerate() {
        let mut i = vec![0f32; width * height];
        let mut se = vec![0f32; width * height];
        let mut q = vec![0f32; width * height];
        for j in 0..height {
            for k in camera.active_columns(j) {
                let Some(ray) = camera.centre_ray(k, j) else { continue };
                let a = ViewAngles::of(ray.direction, sun, 0.0);
                let (value, q_value) = (sky.value)(&a, c);
                let p = j * width + k;
                let sigma = sky.noise.map_or(0.0, |n| n.0 * value);
                i[p] = (value + sigma * gaussian()) as f32;
                se[p] = sigma as f32;
                q[p] = q_value as f32;
            }
        }
        let name = layer_name(*lambda, sky.albedo);
        let zeros = vec![0f32; width * height];
        for (s, v) in [("I", i), ("I_se", se), ("Q", q), ("U", zeros)] {
            channels.push(Channel {
                name: format!("{name}.{s}"),
                samples: v,
            });
        }
    }
    let list = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ");
    let attrs: Vec<(String, String)> = [
        (
            "sensor",
            match camera {
                Camera::Fisheye {
                    resolution,
                    hemisphere,
                    projection,
                } => format!("fisheye {resolution}x{resolution}, hemisphere {hemisphere:?}, projection {projection:?}"),
                _ => format!("sphere (equirectangular) {width}x{height}: synthetic"),
            },
        ),
        ("visibility_km", "50".into()),
        ("planet_radius_km", "6378".into()),
        ("geometry", "Spherical".into()),
        ("stokes_frame", "sun_view: synthetic".into()),
        ("observer_altitude_km", "0".into()),
        ("sun_elevation_deg", format!("{elevation}")),
        ("wavelengths_nm", list(sky.wavelengths_nm)),
        ("albedos", format!("{}", sky.albedo)),
        ("units", "W m-2 sr-1 nm-1 (synthetic)".into()),
        ("polarized", "true".into()),
        ("samples_per_pixel", "1".into()),
        ("job_hash", "0123456789abcdef".into()),
        ("job_file", "synthetic.toml".into()),
        ("profile", "synthetic".into()),
        ("aerosol", "synthetic".into()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect();
    write_exr(&dir.join("image.exr"), width, height, channels, &attrs).unwrap();
    let widths = vec![format!("{:?}", sky.band_width_nm); sky.wavelengths_nm.len()];
    std::fs::write(
        dir.join("task.toml"),
        format!("band_width_nm = [{}]\n", widths.join(", ")),
    )
    .unwrap();
}

/// √T of the synthetic transmittance tables: rank 2 over (node) × (channel).
pub fn sqrt_t(a_km: f64, d_km: f64, channel: usize) -> f64 {
    let x = (-a_km / 8.0).exp() * (d_km / 400.0);
    (-(0.2 + 0.1 * channel as f64) * x).exp().min(1.0) * 0.5 + 0.5 * (-x).exp()
}

/// Writes the synthetic transmittance tables of `wavelengths_nm` on the
/// runtime's nodes (8 × 12) as `atmosim transmittance` writes them.
pub fn write_transmittance_table(dir: &Path, wavelengths_nm: &[f64]) {
    std::fs::create_dir_all(dir).unwrap();
    let grid = Grid::sky_model_runtime(8, 12);
    let (n_a, n_d) = (grid.altitudes_km.len(), grid.distances_km.len());
    let mut channels = Vec::new();
    for (c, lambda) in wavelengths_nm.iter().enumerate() {
        let mut t = Vec::new();
        for &a in &grid.altitudes_km {
            for &d in &grid.distances_km {
                t.push(sqrt_t(a, d, c).powi(2) as f32);
            }
        }
        channels.push(Channel {
            name: format!("{lambda:.0}nm.T"),
            samples: t,
        });
    }
    channels.push(Channel {
        name: "blocked".into(),
        samples: vec![0.0; n_a * n_d],
    });
    let list = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ");
    let attrs = vec![
        ("altitudes_km".to_string(), list(&grid.altitudes_km)),
        ("distances_km".to_string(), list(&grid.distances_km)),
        ("wavelengths_nm".to_string(), list(wavelengths_nm)),
        ("planet_radius_km".to_string(), "6378".to_string()),
        ("visibility_km".to_string(), "50".to_string()),
        ("observer_altitude_km".to_string(), "0".to_string()),
    ];
    write_exr(&dir.join("transmittance.exr"), n_d, n_a, channels, &attrs).unwrap();
}

/// The runtime's query for view direction `v` from the ground with the sun
/// `elevation` (rad) up at azimuth 0: the view's angles and the
/// parameters at `visibility_km` and `albedo`.
pub fn ground_query(v: DVec3, elevation: f64, visibility_km: f64, albedo: f64) -> (ViewAngles, Parameters) {
    let a = ViewAngles::of(
        v,
        SunPosition {
            elevation,
            azimuth: 0.0,
        },
        0.0,
    );
    let p = Parameters {
        theta: a.theta,
        gamma: a.gamma,
        shadow: a.shadow,
        zero: a.zero,
        elevation,
        altitude_m: 0.0,
        visibility_km,
        albedo,
    };
    (a, p)
}
