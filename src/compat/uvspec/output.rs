//! Running a uvspec input and printing uvspec-style results: per output
//! altitude the flux line (uvspec's `lambda edir edn eup uavgdir uavgdn
//! uavgup`, or the `output_user` columns), then, with `umu` and `phi`, the
//! radiance block: a line of the phi values, then per umu the row
//! `umu u0u uu(phi_1) … uu(phi_n)` (u0u the azimuthal mean); polarised runs
//! print four rows per umu, I, Q, U and V.

use std::f64::consts::PI;

use glam::DVec3;

use super::input::{DEFAULT_FLUX_COLUMNS, FLUX_COLUMNS, UvspecInput};
use crate::film::directions::render_directions_all;
use crate::film::fluxes::{Fluxes, render_fluxes_all};
use crate::film::tally::{Tally, tally};
use crate::job::Job;
use crate::polarization::stokes::{Stokes, meridian_frame};
use crate::sampling::stream::{Estimate, Render, StreamKey};
use crate::sensor::direction::Direction;
use crate::transport::tracer::ViewRay;

/// The results at one output altitude.
#[derive(Debug, Clone)]
pub struct ZoutResult {
    pub zout_km: f64,
    pub fluxes: Fluxes,
    /// Diffuse mean intensity (1/4π)∫L dΩ over the downward- and upward-
    /// travelling hemispheres, with standard errors.
    pub uavg_down: (f64, f64),
    pub uavg_up: (f64, f64),
    /// Transmittance of the direct beam to the altitude.
    pub direct_transmittance: f64,
    /// Per umu: the azimuthal mean (random azimuth per path).
    pub u0u: Vec<Tally>,
    /// Per umu (outer) and phi (inner).
    pub uu: Vec<Tally>,
}

/// The results of a uvspec input.
#[derive(Debug, Clone)]
pub struct UvspecResult {
    pub wavelength_nm: f64,
    pub sza_deg: f64,
    /// Multiplies every radiance and irradiance: 1 for `output_quantity
    /// transmittance`, else the Kurucz irradiance in mW m⁻² nm⁻¹.
    pub scale: f64,
    pub polarized: bool,
    pub zout: Vec<ZoutResult>,
}

/// Renders every output altitude of `input` (its job from
/// [`UvspecInput::job`]) in the current rayon pool.
pub fn run(input: &UvspecInput, job: &Job) -> crate::Result<UvspecResult> {
    let samples = job.render.samples;
    let seed = job.render.seed;
    let directions: Vec<Direction> = input.directions().iter().map(|(_, _, d)| *d).collect();
    let scale = if input.transmittance {
        1.0
    } else {
        let solar = crate::physics::solar::SolarSpectrum::kurucz()?;
        1000.0
            * solar.irradiance(input.wavelength_nm).ok_or_else(|| {
                crate::Error::data(
                    "solar_kurucz_1nm",
                    format!("no irradiance at {} nm (absolute output)", input.wavelength_nm),
                )
            })?
    };
    let mut zout = Vec::with_capacity(job.tasks.len());
    for task in &job.tasks {
        let scene = job.scene_for(task, 0);
        let z = task.observer_altitude_km;
        let render = Render::channel(task.index, 0);
        let uu = if directions.is_empty() {
            Vec::new()
        } else {
            render_directions_all(&scene, z, &directions, samples, seed, render)
                .swap_remove(0)
                .swap_remove(0)
        };
        let u0u: Vec<Tally> = input
            .umu
            .iter()
            .enumerate()
            .map(|(k, &umu)| {
                let theta = input.direction(umu, 0.0).view_zenith_deg;
                tally(
                    samples,
                    StreamKey::new(seed, render, Estimate::AzimuthalAverage(k)),
                    scene.value_count(),
                    |s, out| {
                        let phi = 360.0 * s.next_f64();
                        let d = Direction {
                            view_zenith_deg: theta,
                            azimuth_deg: phi,
                        };
                        scene.radiance_sample(z, d.vector(), d.meridian_axis(), ViewRay::Changing, s, out)
                    },
                )[0]
            })
            .collect();
        let mut fluxes = render_fluxes_all(&scene, z, samples, seed, render).swap_remove(0);
        let direct_transmittance = scene.direct_normal(z, 0, false);
        fluxes.e_dir = direct_transmittance * task.sun.direction.z.max(0.0);
        // Mean intensity: uniform directions over each hemisphere, (1/4π)·2π·⟨L⟩.
        let uavg = |estimate: Estimate, sign: f64| {
            let t = tally(
                samples,
                StreamKey::new(seed, render, estimate),
                scene.value_count(),
                |s, out| {
                    let u: [f64; 2] = s.next2();
                    let cos_t = sign * u[0];
                    let sin_t = (1.0 - u[0] * u[0]).max(0.0).sqrt();
                    let phi = 2.0 * PI * u[1];
                    let v = DVec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
                    scene.radiance_sample(z, v, meridian_frame(v, phi).0, ViewRay::Changing, s, out);
                    for x in out.iter_mut() {
                        *x = Stokes::new(0.5 * x.0[0], 0.0, 0.0, 0.0);
                    }
                },
            )[0];
            (t.mean()[0], t.standard_error()[0])
        };
        // Light travelling down is seen looking up.
        let uavg_down = uavg(Estimate::MeanIntensityDown, 1.0);
        let uavg_up = uavg(Estimate::MeanIntensityUp, -1.0);
        zout.push(ZoutResult {
            zout_km: z,
            fluxes,
            uavg_down,
            uavg_up,
            direct_transmittance,
            u0u,
            uu,
        });
    }
    Ok(UvspecResult {
        wavelength_nm: input.wavelength_nm,
        sza_deg: input.sza_deg,
        scale,
        polarized: input.polarized,
        zout,
    })
}

/// One flux-line column.
fn flux_value(col: &str, r: &UvspecResult, z: &ZoutResult) -> f64 {
    let f = &z.fluxes;
    let s = r.scale;
    let uavgdir = z.direct_transmittance / (4.0 * PI);
    match col {
        "lambda" | "wavelength" => r.wavelength_nm,
        "zout" => z.zout_km,
        "sza" => r.sza_deg,
        "edir" => s * f.e_dir,
        "edn" => s * f.e_down,
        "eup" => s * f.e_up,
        "eglo" => s * (f.e_dir + f.e_down),
        "enet" => s * (f.e_dir + f.e_down - f.e_up),
        "esum" => s * (f.e_dir + f.e_down + f.e_up),
        "uavgdir" => s * uavgdir,
        "uavgdn" => s * z.uavg_down.0,
        "uavgup" => s * z.uavg_up.0,
        "uavg" => s * (uavgdir + z.uavg_down.0 + z.uavg_up.0),
        _ => f64::NAN,
    }
}

/// uvspec-style text output.
pub fn format_uvspec(input: &UvspecInput, r: &UvspecResult) -> String {
    let default: Vec<String> = DEFAULT_FLUX_COLUMNS.iter().map(|c| c.to_string()).collect();
    let columns: Vec<&String> = input
        .output_user
        .as_ref()
        .unwrap_or(&default)
        .iter()
        .filter(|c| FLUX_COLUMNS.contains(&c.as_str()))
        .collect();
    let components = if r.polarized { 4 } else { 1 };
    let mut s = String::new();
    for z in &r.zout {
        let line: Vec<String> = columns
            .iter()
            .map(|c| match c.as_str() {
                "lambda" | "wavelength" | "zout" | "sza" => format!("{:10.3}", flux_value(c, r, z)),
                _ => format!("{:13.6e}", flux_value(c, r, z)),
            })
            .collect();
        s.push_str(&line.join(" "));
        s.push('\n');
        if input.umu.is_empty() {
            continue;
        }
        s.push_str(&format!("{:>22}", ""));
        for p in &input.phi_deg {
            s.push_str(&format!(" {p:13.6}"));
        }
        s.push('\n');
        let n_phi = input.phi_deg.len();
        for (k, umu) in input.umu.iter().enumerate() {
            for c in 0..components {
                s.push_str(&format!("{umu:8.4} {:13.6e}", r.scale * z.u0u[k].mean()[c]));
                for t in &z.uu[k * n_phi..(k + 1) * n_phi] {
                    s.push_str(&format!(" {:13.6e}", r.scale * t.mean()[c]));
                }
                s.push('\n');
            }
        }
    }
    s
}

/// Header of the CSV output (uvspec's coordinates).
pub const CSV_HEADER: &str = "zout_km,umu,phi_deg,wavelength_nm,I,Q,U,V,I_se,Q_se,U_se,V_se";

/// One row per output altitude, umu and phi; Q, U, V (and their errors)
/// empty in scalar runs.
pub fn format_csv(input: &UvspecInput, r: &UvspecResult) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for z in &r.zout {
        for ((umu, phi, _), t) in input.directions().iter().zip(&z.uu) {
            let (m, se) = (t.mean(), t.standard_error());
            s.push_str(&format!("{},{umu},{phi},{}", z.zout_km, r.wavelength_nm));
            for (values, digits) in [(m, 9), (se, 4)] {
                for (c, v) in values.iter().enumerate() {
                    if r.polarized || c == 0 {
                        s.push_str(&format!(",{:.*e}", digits, r.scale * v));
                    } else {
                        s.push(',');
                    }
                }
            }
            s.push('\n');
        }
    }
    s
}
