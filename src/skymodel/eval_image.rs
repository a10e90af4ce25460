//! Images of a fitted sky: a dataset evaluated through the runtime's
//! semantics at every pixel centre of a sphere or fisheye camera, written
//! as an EXR (per channel centre: sky radiance `I`, the runtime's signed
//! degree of polarisation `P`, and the transmittance to the end of the
//! view `T`) and an sRGB PNG of the sky radiance.
//!
//! The image frame is the renders': z up, x toward the sun's azimuth (the
//! runtime is asked with sun azimuth 0), the viewpoint on the z axis at
//! `viewpoint_z_m` above the ground (the runtime adds its 50 m).

use std::path::Path;

use glam::DVec3;

use super::runtime::{Model, Parameters};
use crate::error::Result;
use crate::io::exr::{Channel, wavelength_label, write_exr};
use crate::io::preview::write_png;
use crate::io::srgb::srgb_pixels;
use crate::sensor::camera::Camera;

/// What to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalView {
    /// The viewpoint's height above the ground (m).
    pub viewpoint_z_m: f64,
    pub sun_elevation_deg: f64,
    pub visibility_km: f64,
    pub albedo: f64,
    pub wavelengths_nm: Vec<f64>,
}

/// An evaluated image: per wavelength, per pixel (row-major).
#[derive(Debug, Clone, PartialEq)]
pub struct EvalImage {
    pub width: usize,
    pub height: usize,
    pub radiance: Vec<Vec<f64>>,
    /// `None` for a dataset without polarisation.
    pub polarisation: Option<Vec<Vec<f64>>>,
    pub transmittance: Vec<Vec<f64>>,
}

/// Evaluates `model` at every pixel centre of `camera` (0 outside a
/// fisheye's circle).
pub fn evaluate(model: &Model, camera: &Camera, view: &EvalView) -> EvalImage {
    let (width, height) = camera.size();
    let n = width * height;
    let channels = view.wavelengths_nm.len();
    let has_pol = model.dataset().polarisation.is_some();
    let mut image = EvalImage {
        width,
        height,
        radiance: vec![vec![0.0; n]; channels],
        polarisation: has_pol.then(|| vec![vec![0.0; n]; channels]),
        transmittance: vec![vec![0.0; n]; channels],
    };
    let viewpoint = DVec3::new(0.0, 0.0, view.viewpoint_z_m);
    for j in 0..height {
        for i in 0..width {
            if !camera.active_columns(j).contains(&i) {
                continue;
            }
            let Some(ray) = camera.centre_ray(i, j) else { continue };
            let p = Parameters::new(
                viewpoint,
                ray.direction,
                view.sun_elevation_deg.to_radians(),
                0.0,
                view.visibility_km,
                view.albedo,
            );
            let k = j * width + i;
            for (c, &lambda) in view.wavelengths_nm.iter().enumerate() {
                image.radiance[c][k] = model.sky_radiance(&p, lambda);
                image.transmittance[c][k] = model.transmittance(&p, lambda, f64::MAX);
                if let Some(pol) = image.polarisation.as_mut() {
                    pol[c][k] = model.polarisation(&p, lambda).unwrap_or(0.0);
                }
            }
        }
    }
    image
}

/// Writes `image` as `<stem>.exr` and `<stem>.png` in `dir`.
pub fn write(
    dir: &Path,
    stem: &str,
    image: &EvalImage,
    view: &EvalView,
    attributes: &[(String, String)],
) -> Result<()> {
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let mut channels = Vec::new();
    for (c, &lambda) in view.wavelengths_nm.iter().enumerate() {
        let label = wavelength_label(lambda);
        channels.push(Channel {
            name: format!("{label}.I"),
            samples: f32s(&image.radiance[c]),
        });
        if let Some(p) = &image.polarisation {
            channels.push(Channel {
                name: format!("{label}.P"),
                samples: f32s(&p[c]),
            });
        }
        channels.push(Channel {
            name: format!("{label}.T"),
            samples: f32s(&image.transmittance[c]),
        });
    }
    let mut attrs = attributes.to_vec();
    attrs.push((
        "layers".into(),
        "<wavelength>nm.I: sky radiance (the dataset's units, W m-2 sr-1 nm-1 for atmosim fits); \
         .P: the runtime's degree of polarisation (sun-view frame, + for Rayleigh); \
         .T: transmittance to the end of the view (ground or top of the atmosphere)"
            .into(),
    ));
    write_exr(
        &dir.join(format!("{stem}.exr")),
        image.width,
        image.height,
        channels,
        &attrs,
    )?;
    let spectra: Vec<&[f64]> = image.radiance.iter().map(|v| v.as_slice()).collect();
    let (rgb, exposure) = srgb_pixels(&view.wavelengths_nm, &spectra, None);
    write_png(
        &dir.join(format!("{stem}.png")),
        image.width,
        image.height,
        3,
        &rgb,
        &[
            ("exposure", format!("{exposure:.6e}")),
            (
                "Description",
                format!("sRGB of the fitted sky radiance × exposure {exposure:.6e}"),
            ),
        ],
    )
}
