//! Irradiances at the observer level (libRadtran's edir, edn, eup): the
//! diffuse ones as π·⟨I⟩ over cosine-distributed viewing directions of each
//! hemisphere, the direct one from the exact transmittance toward the sun.

use std::f64::consts::PI;

use glam::DVec3;

use crate::film::tally::{Tally, tally};
use crate::polarization::stokes::{Stokes, meridian_frame};
use crate::sampling::sampler::Sampler;
use crate::sampling::stream::{Estimate, Render, StreamKey};
use crate::transport::tracer::{Scene, ViewRay};

/// Fluxes at the observer level per unit E0 (libRadtran's edir, edn, eup).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fluxes {
    /// Direct solar irradiance on a horizontal plane, μ0·T_sun.
    pub e_dir: f64,
    /// Diffuse downward irradiance and its standard error.
    pub e_down: f64,
    pub e_down_se: f64,
    /// Upward irradiance and its standard error.
    pub e_up: f64,
    pub e_up_se: f64,
    pub samples: u64,
}

/// Irradiances at the observer for every albedo of the scene's first
/// channel: E = π·⟨I⟩ over cosine-distributed viewing directions in each
/// hemisphere; the direct beam from the exact transmittance along the
/// sun's direction.
pub fn render_fluxes_all(scene: &Scene, altitude_km: f64, samples: u64, seed: u64, render: Render) -> Vec<Fluxes> {
    let hemisphere = |up: bool| {
        tally(
            samples,
            StreamKey::new(seed, render, Estimate::flux(up)),
            scene.value_count(),
            |s, out| flux_sample(scene, altitude_km, up, s, out),
        )
    };
    let down = hemisphere(false);
    let up = hemisphere(true);
    let e_dir = scene.direct_horizontal(altitude_km, 0);
    down.iter()
        .zip(&up)
        .take(scene.albedos.len())
        .map(|(d, u)| Fluxes::new(e_dir, d, u))
        .collect()
}

/// One sample of an irradiance estimate: π·I for a cosine-distributed
/// viewing direction in the upper (`up` false: light coming down) or lower
/// hemisphere, for every channel and albedo of the scene, into `out`.
pub fn flux_sample(scene: &Scene, altitude_km: f64, up: bool, s: &mut Sampler, out: &mut [Stokes]) {
    let (v, e1) = flux_direction(up, s);
    scene.radiance_sample(altitude_km, v, e1, ViewRay::Changing, s, out);
    to_irradiance(out);
}

/// A cosine-distributed viewing direction in the upper (`up` false) or
/// lower hemisphere, and its meridian axis.
fn flux_direction(up: bool, s: &mut Sampler) -> (DVec3, DVec3) {
    let sign = if up { -1.0 } else { 1.0 };
    let u = s.next2();
    let r = u[0].sqrt();
    let phi = 2.0 * PI * u[1];
    let z = sign * (1.0 - u[0]).max(0.0).sqrt();
    let v = DVec3::new(r * phi.cos(), r * phi.sin(), z);
    (v, meridian_frame(v, phi).0)
}

/// Radiances of cosine-distributed directions to irradiances: π·I.
fn to_irradiance(values: &mut [Stokes]) {
    for x in values.iter_mut() {
        *x = Stokes::new(PI * x.0[0], 0.0, 0.0, 0.0);
    }
}

impl Fluxes {
    /// The fluxes from the direct irradiance and the tallies of the
    /// downward and upward estimates.
    pub fn new(e_dir: f64, down: &Tally, up: &Tally) -> Fluxes {
        Fluxes {
            e_dir,
            e_down: down.mean()[0],
            e_down_se: down.standard_error()[0],
            e_up: up.mean()[0],
            e_up_se: up.standard_error()[0],
            samples: down.samples,
        }
    }
}

/// [`render_fluxes_all`] for the scene's first albedo.
pub fn render_fluxes(scene: &Scene, altitude_km: f64, samples: u64, seed: u64, render: Render) -> Fluxes {
    render_fluxes_all(scene, altitude_km, samples, seed, render).swap_remove(0)
}
