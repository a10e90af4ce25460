//! Image pixels against the exact single-scattering Rayleigh sky, every
//! pixel, the zenith and nadir pixels included: the pixel's Stokes frame must
//! stay continuous over the pixel, or the average over a pixel that holds the
//! pole (where the meridian frame turns through a full circle) loses its
//! polarisation.
//!
//! The reference is independent of the tracer: a plane-parallel Rayleigh
//! slab (no depolarisation, black ground, single scattering only) has the
//! closed-form radiance
//! I(v) = (1/4π)·(3/4)(1 + cos²Θ)·μ0·f(μ), with f the slab's single-
//! scattering path integral (below), polarised with degree
//! sin²Θ/(1 + cos²Θ) perpendicular to the plane of the sun and the view.
//! Its Q and U are taken in each direction's frame (the frame of the pixel's
//! centre carried to it, written here with Rodrigues' axis–angle formula)
//! and averaged over the pixel's solid angle by quadrature.

mod common;

use std::f64::consts::PI;

use atmosim::job::Sensor;
use atmosim::sensor::camera::Camera;
use common::{Comparison, job, layers_toml};
use glam::DVec3;

/// Slab optical depth and the sun's elevation.
const TAU: f64 = 0.1;
const SUN_ELEVATION_DEG: f64 = 30.0;

/// The exact single-scattering Stokes vector (I, Q, U) of view direction `d`
/// in the frame with axis `e1` (⟂ d), seen from the ground below the slab
/// (`above` false) or from above it: looking up from the ground or down from
/// above, the slab; else the black ground or empty space (0).
fn exact(d: DVec3, e1: DVec3, sun: DVec3, above: bool) -> [f64; 3] {
    let mu0 = sun.z;
    let mu = d.z.abs();
    if (d.z > 0.0) == above || d.z == 0.0 {
        return [0.0; 3];
    }
    let path = if d.z > 0.0 {
        // Seen from below: ∫ e^{−t/μ0} e^{−(τ−t)/μ} dt/μ.
        if (mu - mu0).abs() < 1e-9 {
            TAU / mu0 * (-TAU / mu0).exp()
        } else {
            mu0 / (mu0 - mu) * ((-TAU / mu0).exp() - (-TAU / mu).exp())
        }
    } else {
        // Seen from above: ∫ e^{−t/μ0} e^{−t/μ} dt/μ.
        mu0 / (mu0 + mu) * (1.0 - (-TAU * (1.0 / mu0 + 1.0 / mu)).exp())
    } / mu0;
    let cos_theta = sun.dot(d);
    let i = mu0 * path * 3.0 / (16.0 * PI) * (1.0 + cos_theta * cos_theta);
    let ip = mu0 * path * 3.0 / (16.0 * PI) * (1.0 - cos_theta * cos_theta);
    // The polarised part's E-vector is perpendicular to the scattering plane.
    let n = d.cross(sun);
    let p = if n.length() > 0.0 { n.normalize() } else { e1 };
    let e2 = (-d).cross(e1);
    let (a, b) = (p.dot(e1), p.dot(e2));
    [i, ip * (a * a - b * b), ip * 2.0 * a * b]
}

/// `e1` at `c` carried to `d` by the rotation about c × d through the angle
/// between them (Rodrigues' axis–angle form).
fn carried(e1: DVec3, c: DVec3, d: DVec3) -> DVec3 {
    let axis = c.cross(d);
    let s = axis.length();
    if s < 1e-15 {
        return e1;
    }
    let k = axis / s;
    let angle = s.atan2(c.dot(d));
    let (sa, ca) = angle.sin_cos();
    e1 * ca + k.cross(e1) * sa + k * k.dot(e1) * (1.0 - ca)
}

/// The pixel's reference axis at its centre direction `c` (azimuth `phi`):
/// meridian (e1 = ∂v/∂θ) or perpendicular to the sun–view plane.
fn centre_axis(frame: &str, c: DVec3, phi: f64, sun: DVec3) -> DVec3 {
    match frame {
        "meridian" => {
            let theta = c.z.clamp(-1.0, 1.0).acos();
            let phi = if c.x.hypot(c.y) > 0.0 { c.y.atan2(c.x) } else { phi };
            DVec3::new(theta.cos() * phi.cos(), theta.cos() * phi.sin(), -theta.sin())
        }
        _ => sun.cross(c).normalize(),
    }
}

/// The exact mean of every pixel over its solid angle (K × K midpoints,
/// each in the pixel centre's frame carried to it), and whether the pixel
/// holds a pole; `None` outside a fisheye's circle.
fn pixel_references<const K: usize>(
    camera: &Camera,
    frame: &str,
    sun: DVec3,
    above: bool,
) -> Vec<Option<([f64; 3], bool)>> {
    let (w, h) = camera.size();
    (0..w * h)
        .map(|p| {
            let (px, py) = (p % w, p / w);
            // The pixel's centre direction (the rim point for a fisheye pixel
            // whose centre is outside the circle, as the camera defines it).
            let centre = camera.centre_ray(px, py)?;
            let e1c = centre_axis(frame, centre.direction, centre.azimuth, sun);
            let (mut sum, mut weight) = ([0.0; 3], 0.0);
            let mut holds_pole = false;
            for a in 0..K {
                for b in 0..K {
                    let x = px as f64 + (a as f64 + 0.5) / K as f64;
                    let y = py as f64 + (b as f64 + 0.5) / K as f64;
                    let Some(ray) = camera.ray_at(x, y) else { continue };
                    let d = ray.direction;
                    holds_pole |= d.z.abs() > (0.5f64).to_radians().cos();
                    let s = exact(d, carried(e1c, centre.direction, d), sun, above);
                    for k in 0..3 {
                        sum[k] += s[k] * ray.jacobian;
                    }
                    weight += ray.jacobian;
                }
            }
            (weight > 0.0).then(|| (sum.map(|s| s / weight), holds_pole))
        })
        .collect()
}

/// The slab job with `sensor`, `frame`, observer altitude and the
/// `[render]` keys of its sample count.
fn slab_job(sensor: &str, frame: &str, observer_km: f64, samples: &str, seed: u64) -> atmosim::job::Job {
    job(&format!(
        "{}[sun]\nelevation_deg = {SUN_ELEVATION_DEG}\n[observer]\naltitude_km = {observer_km}\n\
         [render]\n{samples}\nseed = {seed}\nmax_scattering_order = 1\n\
         [sensor]\n{sensor}\nstokes_frame = \"{frame}\"\n[output]\npreview = false\n",
        layers_toml(&[(0.0, 10.0, TAU, 0.0), (10.0, 20.0, 0.0, 0.0)], 0.0)
    ))
}

fn check(sensor: &str, frame: &str, observer_km: f64, samples: u64) {
    let j = slab_job(sensor, frame, observer_km, &format!("samples = {samples}"), 11);
    let Sensor::Image(camera) = j.render.sensor.clone() else {
        panic!("not an image")
    };
    let task = &j.tasks[0];
    let sun = task.sun.direction;
    let image = atmosim::run::task::render_image(&j, task, &camera, &|_| {}, &|_| {}).unwrap();
    let layer = &image.layers[0];
    let mut cmp = Comparison::default();
    let mut dolp = Comparison::default();
    let (mut pole_pixels, mut pixels) = (0, 0);
    let (w, _) = camera.size();
    for (p, r) in pixel_references::<48>(&camera, frame, sun, observer_km > 10.0)
        .iter()
        .enumerate()
    {
        let Some((reference, holds_pole)) = *r else { continue };
        let (px, py) = (p % w, p / w);
        pixels += 1;
        pole_pixels += holds_pole as usize;
        let mean = [layer.mean[0][p], layer.mean[1][p], layer.mean[2][p]];
        let se = [layer.se[0][p], layer.se[1][p], layer.se[2][p]];
        for k in 0..3 {
            cmp.add(
                || format!("{sensor} {frame} pixel ({px}, {py}) Stokes {k}"),
                mean[k],
                se[k],
                reference[k],
                0.0,
            );
        }
        if reference[0] == 0.0 {
            continue;
        }
        // The degree of linear polarisation, with its standard error from
        // the linearised ratio (the errors of I, Q and U taken as
        // independent: an upper bound here, where they are correlated).
        let lin = mean[1].hypot(mean[2]);
        let d = lin / mean[0];
        let d_se =
            ((mean[1] * se[1]).powi(2) / (lin * lin) + (mean[2] * se[2]).powi(2) / (lin * lin) + (d * se[0]).powi(2))
                .sqrt()
                / mean[0];
        let d_ref = reference[1].hypot(reference[2]) / reference[0];
        dolp.add(
            || format!("{sensor} {frame} pixel ({px}, {py}) DoLP {d:.4} (exact {d_ref:.4})"),
            d,
            d_se,
            d_ref,
            0.0,
        );
    }
    assert!(
        pole_pixels >= 1 && pixels > 40,
        "{sensor}: {pole_pixels} pole pixels of {pixels}"
    );
    cmp.assert_no_outlier(&format!("{sensor} {frame}: I, Q, U per pixel"));
    dolp.assert_no_outlier(&format!("{sensor} {frame}: DoLP per pixel"));
}

#[test]
fn noise_targeted_pixels_are_unbiased_over_many_seeds() {
    unbiased_over_seeds("noise_target = 0.03\npilot_samples = 8\nmax_samples = 4000");
}

#[test]
fn pixels_of_an_image_held_to_a_target_as_a_whole_are_unbiased_over_many_seeds() {
    // The image's noise as a whole at 3 %: its pixels' samples follow
    // their standard deviation times the square root of their solid angle.
    unbiased_over_seeds("noise_target = 0.03\nnoise_target_per = \"image\"\npilot_samples = 8\nmax_samples = 4000");
}

fn unbiased_over_seeds(target: &str) {
    // A noise target allocates each pixel's samples from a pilot; the mean
    // is of the allocated samples alone, so it stays unbiased. 150 seeds of
    // a small sphere image: per pixel, the mean over the seeds (its standard
    // error from their spread) against the exact pixel mean, and every
    // seed's pixel against it with its own standard error. A sphere image:
    // no pixel is cut by a fisheye's circle, whose midpoint quadrature
    // would not match the pooled precision (≈ 0.1 %).
    const SEEDS: u64 = 150;
    let sensor = "type = \"sphere\"\nresolution = 8";
    let first = slab_job(sensor, "meridian", 0.0, target, 0);
    let Sensor::Image(camera) = first.render.sensor.clone() else {
        panic!("not an image")
    };
    let sun = first.tasks[0].sun.direction;
    let references = pixel_references::<256>(&camera, "meridian", sun, false);
    let n = references.len();
    let (mut sum, mut sum_sq) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
    let mut each = Comparison::default();
    let mut counts = std::collections::BTreeSet::new();
    for seed in 0..SEEDS {
        let j = slab_job(sensor, "meridian", 0.0, target, seed);
        let task = &j.tasks[0];
        let image = atmosim::run::task::render_image(&j, task, &camera, &|_| {}, &|_| {}).unwrap();
        let layer = &image.layers[0];
        counts.extend(image.samples[0].1.iter().copied());
        for (p, r) in references.iter().enumerate() {
            let Some((reference, _)) = r else { continue };
            for k in 0..3 {
                let m = layer.mean[k][p];
                sum[p][k] += m;
                sum_sq[p][k] += m * m;
                each.add(
                    || format!("seed {seed} pixel {p} Stokes {k}"),
                    m,
                    layer.se[k][p],
                    reference[k],
                    0.0,
                );
            }
        }
    }
    // The allocation differs between pixels and seeds (it is not a fixed
    // count in disguise).
    assert!(counts.len() > 20, "{counts:?}");
    let mut pooled = Comparison::default();
    for (p, r) in references.iter().enumerate() {
        let Some((reference, _)) = r else { continue };
        for k in 0..3 {
            let s = SEEDS as f64;
            let mean = sum[p][k] / s;
            let var = (sum_sq[p][k] / s - mean * mean).max(0.0) * s / (s - 1.0);
            pooled.add(
                || format!("pixel {p} Stokes {k}, mean of {SEEDS} seeds"),
                mean,
                (var / s).sqrt(),
                reference[k],
                1e-12 * reference[0].abs(),
            );
        }
    }
    pooled.assert_no_outlier("noise target: per-pixel mean over seeds");
    each.assert_no_outlier("noise target: every seed's pixels");
}

#[test]
fn up_fisheye_pixels_hold_the_exact_single_scattering_polarisation_pole_included() {
    // Even: the zenith is the corner of the four central pixels.
    check("type = \"fisheye\"\nresolution = 8", "meridian", 0.0, 4000);
    // Odd: the zenith is the centre of the central pixel.
    check("type = \"fisheye\"\nresolution = 9", "meridian", 0.0, 4000);
}

#[test]
fn down_fisheye_pixels_hold_the_exact_single_scattering_polarisation_nadir_included() {
    check(
        "type = \"fisheye\"\nresolution = 8\nhemisphere = \"down\"\nprojection = \"equisolid\"",
        "meridian",
        15.0,
        4000,
    );
}

#[test]
fn sun_view_frame_pixels_hold_the_exact_single_scattering_polarisation() {
    check("type = \"fisheye\"\nresolution = 8", "sun_view", 0.0, 4000);
    check("type = \"sphere\"\nresolution = 8", "sun_view", 0.0, 2000);
}

#[test]
fn sphere_pixels_at_the_poles_hold_the_exact_single_scattering_polarisation() {
    check("type = \"sphere\"\nresolution = 8", "meridian", 0.0, 2000);
}

#[test]
fn directions_in_the_sun_view_frame_hold_the_exact_single_scattering_stokes_vector() {
    let text = format!(
        "{}[sun]\nelevation_deg = {SUN_ELEVATION_DEG}\n[render]\nsamples = 20000\nseed = 12\n\
         max_scattering_order = 1\n[spectrum]\nwavelengths_nm = [550.0]\n[sensor]\ndirections = [[0.0, 0.0], [40.0, 0.0], [60.0, 90.0], [75.0, 200.0]]\n\
         fluxes = false\nstokes_frame = \"sun_view\"\n",
        layers_toml(&[(0.0, 10.0, TAU, 0.0), (10.0, 20.0, 0.0, 0.0)], 0.0)
    );
    let j = job(&text);
    let task = &j.tasks[0];
    let sun = task.sun.direction;
    let rows = atmosim::run::task::render_directions(&j, task, &|_| {})
        .unwrap()
        .radiance;
    let mut cmp = Comparison::default();
    for row in &rows {
        let d = row.direction.vector();
        let reference = exact(d, sun.cross(d).normalize(), sun, false);
        // In this frame the light is polarised along e1: U = 0, Q = DoLP·I.
        assert!(reference[1] > 0.0 && reference[2].abs() < 1e-15 * reference[0]);
        let (mean, se) = (row.tally.mean(), row.tally.standard_error());
        for k in 0..3 {
            // Single scattering in a plane-parallel slab is estimated without
            // variance here (the flight's point follows the sunlit single
            // scattering exactly): the floor is the closed form's rounding.
            cmp.add(
                || format!("direction {:?} Stokes {k}", row.direction),
                mean[k],
                se[k],
                reference[k],
                1e-12 * reference[0],
            );
        }
    }
    assert_eq!(rows.len(), 4);
    cmp.assert_no_outlier("directions, sun_view frame");
}
