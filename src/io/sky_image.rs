//! A task of an image job: every (albedo, wavelength) layer of a camera,
//! and its files: the EXR of Stokes images with their standard errors and
//! the task's metadata, PNG previews (sRGB of I, degree of linear
//! polarisation), and optionally the transmitted direct sun.

use std::path::Path;

use crate::atmosphere::report::gases_text;
use crate::error::Result;
use crate::film::ground_view::{GROUND_VIEW_SAMPLES, traced_rows};
use crate::film::image::{ImageLayer, SkyImage};
use crate::io::atomic::write_atomic;
use crate::io::exr::{Channel, wavelength_label, write_exr};
use crate::io::preview::write_png;
use crate::io::srgb::srgb_pixels;
use crate::io::sun_table::{SUN_FILE, sun_csv};
use crate::job::{AtmosphereSource, Job, RadianceUnits, Task};
use crate::physics::aerosol::AerosolPhase;
use crate::sensor::camera::{Camera, PixelFilter};

/// The file an image task writes its Stokes images to.
pub const IMAGE_FILE: &str = "image.exr";

/// The EXR layer name of a wavelength and albedo: `540nm_a030`.
pub fn layer_name(wavelength_nm: f64, albedo: f64) -> String {
    format!("{}_a{:03.0}", wavelength_label(wavelength_nm), albedo * 100.0)
}

/// Writes the task's files into `dir`; returns the preview exposure used.
pub fn write(dir: &Path, job: &Job, task: &Task, camera: &Camera, image: &SkyImage) -> Result<Option<f64>> {
    let spec = &job.render;
    let scale = |lambda: f64| job.unit_scale(lambda);
    let mut channels = Vec::new();
    for layer in &image.layers {
        let name = layer_name(layer.wavelength_nm, layer.albedo);
        let k = scale(layer.wavelength_nm);
        for (c, stokes) in ["I", "Q", "U", "V"].iter().enumerate() {
            channels.push(Channel {
                name: format!("{name}.{stokes}"),
                samples: layer.mean[c].iter().map(|v| (v * k) as f32).collect(),
            });
            channels.push(Channel {
                name: format!("{name}.{stokes}_se"),
                samples: layer.se[c].iter().map(|v| (v * k) as f32).collect(),
            });
        }
    }
    // A noise target's samples per pixel (exact in f32: the cap is 2²⁴).
    for (wavelength, counts) in &image.samples {
        channels.push(Channel {
            name: wavelength.map_or("samples".into(), |w| format!("{}.samples", wavelength_label(w))),
            samples: counts.iter().map(|&n| n as f32).collect(),
        });
    }
    let non_finite: u64 = image.layers.iter().map(|l| l.non_finite).sum();
    write_exr(
        &dir.join(IMAGE_FILE),
        image.width,
        image.height,
        channels,
        &attributes(job, task, camera, non_finite),
    )?;

    if spec.output_sun {
        write_atomic(&dir.join(SUN_FILE), sun_csv(job, task, Some(camera)).as_bytes())?;
    }
    if !spec.preview {
        return Ok(None);
    }
    // Previews from the first albedo.
    let first: Vec<&ImageLayer> = image.layers.iter().filter(|l| l.albedo == spec.albedos[0]).collect();
    let wavelengths: Vec<f64> = first.iter().map(|l| l.wavelength_nm).collect();
    let spectra: Vec<&[f64]> = first.iter().map(|l| l.mean[0].as_slice()).collect();
    let (rgb, exposure) = srgb_pixels(&wavelengths, &spectra, spec.exposure);
    // The layers hold the tracer's radiance: per unit E0, or absolute
    // where the tracer weighted by E0 (bands, see `Job::unit_scale`).
    let units = if job.tracer_weights_by_solar() {
        "absolute radiance (W m-2 sr-1 nm-1)"
    } else {
        "radiance per unit E0"
    };
    let note = format!(
        "sRGB of CIE 1931 XYZ from the I images (albedo {}), {units} × exposure {exposure:.6e}",
        spec.albedos[0]
    );
    write_png(
        &dir.join("preview.png"),
        image.width,
        image.height,
        3,
        &rgb,
        &[("exposure", format!("{exposure:.6e}")), ("Description", note)],
    )?;
    let reference = first
        .iter()
        .min_by(|a, b| {
            (a.wavelength_nm - 550.0)
                .abs()
                .total_cmp(&(b.wavelength_nm - 550.0).abs())
        })
        .expect("a job has at least one wavelength");
    let dolp: Vec<u8> = (0..image.width * image.height)
        .map(|p| {
            let (i, q, u) = (reference.mean[0][p], reference.mean[1][p], reference.mean[2][p]);
            let d = if i > 0.0 { (q * q + u * u).sqrt() / i } else { 0.0 };
            (d.clamp(0.0, 1.0) * 255.0).round() as u8
        })
        .collect();
    let note = format!(
        "degree of linear polarisation sqrt(Q²+U²)/I at {} nm, 0 black to 1 white",
        reference.wavelength_nm
    );
    write_png(
        &dir.join("dolp.png"),
        image.width,
        image.height,
        1,
        &dolp,
        &[("Description", note)],
    )?;
    Ok(Some(exposure))
}

fn attributes(job: &Job, task: &Task, camera: &Camera, non_finite: u64) -> Vec<(String, String)> {
    let spec = &job.render;
    let list = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ");
    let camera_text = match *camera {
        Camera::Fisheye {
            resolution,
            hemisphere,
            projection,
        } => format!(
            "fisheye {resolution}x{resolution}, hemisphere {hemisphere:?}, projection {projection:?}; image up = the sun's azimuth; \
             up: image right = azimuth +90 deg (counter-clockwise from above), down: image right = azimuth -90 deg; outside the circle 0"
        ),
        Camera::Panorama { width, height } => format!(
            "panorama {width}x{height}: x from azimuth +90 (left) to -90 deg (right) around the sun's azimuth, y from elevation +90 (top) to -90 deg"
        ),
        Camera::Sphere { width, height } => format!(
            "sphere (equirectangular) {width}x{height}: x from azimuth +180 to -180 deg, the sun's azimuth at the centre, y from elevation +90 to -90 deg"
        ),
    };
    let (profile, aerosol, aerosol_phase) = match &job.source {
        AtmosphereSource::Profile {
            profile,
            aerosol,
            aerosol_phase,
            ..
        } => (
            profile.clone(),
            aerosol.clone().unwrap_or_else(|| "none".into()),
            match (aerosol, aerosol_phase) {
                (None, _) => "none",
                (Some(_), AerosolPhase::Mie) => "mie: the OPAC components' Mie phase matrices",
                (Some(_), AerosolPhase::HenyeyGreenstein) => "hg: Henyey-Greenstein with the mixture's g, unpolarised",
            },
        ),
        AtmosphereSource::Layers => (
            "explicit layers".into(),
            "explicit layers".into(),
            "hg: Henyey-Greenstein, unpolarised",
        ),
    };
    let units = match spec.units {
        RadianceUnits::Normalized => "radiance per unit solar irradiance, 1/sr",
        RadianceUnits::Absolute => "W m-2 sr-1 nm-1 (radiance per unit E0 x Kurucz 1992 extraterrestrial irradiance)",
    };
    vec![
        ("atmosim_version".into(), env!("CARGO_PKG_VERSION").into()),
        ("job_hash".into(), job.hash.clone()),
        ("job_file".into(), job.file.clone()),
        ("task".into(), task.name.clone()),
        ("task_index".into(), format!("{}", task.index)),
        ("sensor".into(), camera_text),
        ("pixel_filter".into(), match spec.pixel_filter {
            PixelFilter::Box => "box: mean radiance over the pixel's solid angle (stratified jitter)".into(),
            PixelFilter::Center => "center: radiance of the pixel centre's direction".into(),
        }),
        ("symmetry".into(), spec
            .symmetry
            .resolve(camera, task.sun.zenith_deg)
            .describe(camera.size().0)),
        ("layers".into(), "<wavelength>nm_a<albedo x 100>, e.g. 540nm_a030; channels I Q U V and I_se Q_se U_se V_se (standard errors of the mean)".into()),
        ("units".into(), units.into()),
        ("stokes_frame".into(), format!(
            "{}; each pixel in the frame of its centre direction, carried to every sample direction of the pixel by \
             the rotation that takes the centre to it; Q = I(e1) - I(e2), U = I((e1+e2)/sqrt2) - I((e1-e2)/sqrt2) \
             (IPRT / libRadtran-MYSTIC)",
            spec.stokes_frame.describe()
        )),
        ("direct_sun".into(), "not included (diffuse sky radiance only)".into()),
        ("wavelengths_nm".into(), list(&job.wavelengths_nm)),
        ("albedos".into(), list(&spec.albedos)),
        ("sun_zenith_deg".into(), format!("{}", task.sun.zenith_deg)),
        ("sun_elevation_deg".into(), format!("{}", 90.0 - task.sun.zenith_deg)),
        ("sun_angular_radius_deg".into(), format!("{}", spec.sun_angular_radius_deg)),
        ("observer_altitude_km".into(), format!("{}", task.observer_altitude_km)),
        ("visibility_km".into(), task.atmosphere.visibility.map_or("none".into(), |v| format!("{}", v.ground_km))),
        ("profile".into(), profile),
        ("aerosol".into(), aerosol),
        ("aerosol_phase".into(), aerosol_phase.into()),
        ("gases".into(), gases_text(&task.atmosphere)),
        ("planet_radius_km".into(), format!("{}", job.planet.radius_km)),
        ("top_km".into(), format!("{}", job.planet.top_km)),
        ("geometry".into(), format!("{:?}", job.planet.geometry)),
        ("medium".into(), format!("{:?}", spec.medium)),
        ("polarized".into(), format!("{}", spec.settings.polarized)),
        ("max_scattering_order".into(), format!("{}", spec.settings.max_scattering_order)),
        ("samples_per_pixel".into(), match spec.target {
            None => format!("{}", spec.samples),
            Some(t) => format!(
                "noise target: relative standard error of I {} {} in every channel and {}, per pixel the samples of \
                 channel 'samples' (or '<wavelength>nm.samples'), {} to {}, allocated by a pilot of {} samples \
                 (not in the means)",
                t.relative_se,
                t.per.describe(),
                t.albedos.describe(),
                t.pilot,
                t.max_samples,
                t.pilot
            ),
        }),
        ("ground_view".into(), {
            let (first, height) = (traced_rows(camera, task), camera.size().1);
            if first < height {
                format!(
                    "rows {first} to {} (below the horizon of an observer on the ground) share one estimate of the \
                     ground's radiance, traced straight down with {GROUND_VIEW_SAMPLES}x a pixel's samples (a noise \
                     target: a quarter of its relative error)",
                    height - 1
                )
            } else {
                "none: every pixel traced".into()
            }
        }),
        ("seed".into(), format!("{}", spec.seed)),
        ("non_finite_samples".into(), format!("{non_finite}")),
    ]
}
