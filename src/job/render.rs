//! Resolving the `[sun]`, `[ground]`, `[sensor]`, `[render]` and `[output]`
//! sections into what a render needs.

use std::path::PathBuf;

use super::Ctx;
use super::raw::{
    RawGround, RawMedium, RawOutput, RawRender, RawSensor, RawSensorKind, RawSun,
    RawSunTransmittance,
};
use crate::error::Result;
use crate::integrator::{Settings, SunTransmittance};
use crate::medium::MediumModel;
use crate::render::Direction;
use crate::sun::Sun;

/// Default samples per direction.
pub const DEFAULT_SAMPLES: u64 = 100_000;
/// Default sun zenith angle (degrees).
pub const DEFAULT_SUN_ZENITH_DEG: f64 = 45.0;
/// Default view zenith angles (degrees) of the `directions` sensor.
pub const DEFAULT_VIEW_ZENITH_DEG: [f64; 4] = [0.0, 30.0, 60.0, 78.46];
/// Default azimuths (degrees) of the `directions` sensor.
pub const DEFAULT_AZIMUTH_DEG: [f64; 3] = [0.0, 90.0, 180.0];

/// What a render needs besides the atmosphere.
#[derive(Debug, Clone)]
pub struct RenderSpec {
    pub sun: Sun,
    pub albedo: f64,
    pub directions: Vec<Direction>,
    /// Also estimate the fluxes at the observer level.
    pub fluxes: bool,
    pub samples: u64,
    pub seed: u64,
    pub settings: Settings,
    pub medium: MediumModel,
    pub majorant_scale: f64,
    pub output_directory: PathBuf,
}

pub(super) fn resolve(
    ctx: &Ctx,
    sun: Option<RawSun>,
    ground: Option<RawGround>,
    sensor: Option<RawSensor>,
    render: Option<RawRender>,
    output: Option<RawOutput>,
) -> Result<RenderSpec> {
    let sun = sun.unwrap_or_default();
    let zenith_deg = match (sun.zenith_deg, sun.elevation_deg) {
        (Some(_), Some(_)) => {
            return Err(ctx.invalid(
                "sun.elevation_deg",
                "(given)",
                "sun.zenith_deg is given too",
                "one of sun.zenith_deg or sun.elevation_deg",
            ));
        }
        (Some(z), None) => ctx.range("sun.zenith_deg", z, 0.0, 180.0, false, "0 to 180 degrees")?,
        (None, Some(e)) => {
            90.0 - ctx.range(
                "sun.elevation_deg",
                e,
                -90.0,
                90.0,
                false,
                "-90 to 90 degrees",
            )?
        }
        (None, None) => DEFAULT_SUN_ZENITH_DEG,
    };
    let radius = ctx.range(
        "sun.angular_radius_deg",
        sun.angular_radius_deg.unwrap_or(0.0),
        0.0,
        5.0,
        false,
        "0 (point sun) to 5 degrees; the sun's is 0.2666",
    )?;

    let albedo = ctx.range(
        "ground.albedo",
        ground.unwrap_or_default().albedo.unwrap_or(0.0),
        0.0,
        1.0,
        false,
        "0 to 1",
    )?;

    let sensor = sensor.unwrap_or_default();
    // The only sensor type so far; images come with their own types.
    match sensor.kind {
        None | Some(RawSensorKind::Directions) => {}
    }
    let directions = match (
        &sensor.directions,
        &sensor.view_zenith_deg,
        &sensor.azimuth_deg,
    ) {
        (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
            return Err(ctx.invalid(
                "sensor.directions",
                "(given)",
                "cannot be combined with sensor.view_zenith_deg / sensor.azimuth_deg",
                "either directions = [[zenith, azimuth], …] or the two lists",
            ));
        }
        (Some(list), None, None) => list.iter().map(|&[z, a]| (z, a)).collect::<Vec<_>>(),
        (None, zs, azs) => {
            let zs = zs.clone().unwrap_or(DEFAULT_VIEW_ZENITH_DEG.to_vec());
            let azs = azs.clone().unwrap_or(DEFAULT_AZIMUTH_DEG.to_vec());
            zs.iter()
                .flat_map(|&z| azs.iter().map(move |&a| (z, a)))
                .collect()
        }
    };
    if directions.is_empty() {
        return Err(ctx.invalid(
            "sensor.directions",
            "[]",
            "no viewing directions",
            "at least one direction",
        ));
    }
    let directions = directions
        .into_iter()
        .map(|(z, a)| {
            Ok(Direction {
                view_zenith_deg: ctx.range(
                    "sensor.view_zenith_deg",
                    z,
                    0.0,
                    180.0,
                    false,
                    "0 (zenith) to 180 (nadir) degrees",
                )?,
                azimuth_deg: ctx.range(
                    "sensor.azimuth_deg",
                    a,
                    -360.0,
                    360.0,
                    false,
                    "-360 to 360 degrees, 0 toward the sun",
                )?,
            })
        })
        .collect::<Result<Vec<_>>>()?;

    let render = render.unwrap_or_default();
    let samples = render.samples.unwrap_or(DEFAULT_SAMPLES);
    if samples == 0 {
        return Err(ctx.invalid("render.samples", 0, "no samples", "at least 1"));
    }
    let majorant_scale = ctx.range(
        "render.majorant_scale",
        render.majorant_scale.unwrap_or(1.0),
        1.0,
        1.0e6,
        false,
        "1 (tight) or more",
    )?;
    Ok(RenderSpec {
        sun: Sun::new(zenith_deg, radius),
        albedo,
        directions,
        fluxes: sensor.fluxes.unwrap_or(true),
        samples,
        seed: render.seed.unwrap_or(1),
        settings: Settings {
            polarized: render.polarized.unwrap_or(true),
            max_scattering_order: render.max_scattering_order.unwrap_or(0),
            sun_transmittance: match render
                .sun_transmittance
                .unwrap_or(RawSunTransmittance::Analytic)
            {
                RawSunTransmittance::Analytic => SunTransmittance::Analytic,
                RawSunTransmittance::RatioTracking => SunTransmittance::RatioTracking,
            },
            forced_collisions: render.forced_collisions.unwrap_or(true),
            sun_samples_per_flight: match render.sun_samples_per_flight.unwrap_or(1) {
                0 => {
                    return Err(ctx.invalid(
                        "render.sun_samples_per_flight",
                        0,
                        "no sun connections",
                        "1 or more",
                    ));
                }
                k => k,
            },
        },
        medium: match render.medium.unwrap_or(RawMedium::Layered) {
            RawMedium::Layered => MediumModel::Layered,
            RawMedium::Smooth => MediumModel::Smooth,
        },
        majorant_scale,
        output_directory: output
            .unwrap_or_default()
            .directory
            .unwrap_or_else(|| PathBuf::from("out")),
    })
}
