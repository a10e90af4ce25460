//! Resolving the `[sun]`, `[ground]`, `[sensor]`, `[render]` and `[output]`
//! sections into what a render needs.

use std::path::PathBuf;

use super::context::Ctx;
use super::raw::{
    OneOrMany, RawGround, RawHemisphere, RawMedium, RawOutput, RawPixelFilter, RawProjection, RawRender, RawResolution,
    RawSensor, RawSensorKind, RawSpectralGroups, RawStokesFrame, RawSun, RawSunSampling, RawSunTransmittance,
    RawSymmetry, RawTargetAlbedos, RawTargetScope, RawTrackingLayers, RawUnits,
};
use crate::error::Result;
use crate::job::options::MediumModel;
use crate::job::options::{
    DEFAULT_ROULETTE_THRESHOLD, GivenSettings, MAX_ALBEDOS, Settings, SpectralGroups, SunSampling, SunTransmittance,
    TrackingLayers,
};
use crate::polarization::stokes_frame::StokesFrame;
use crate::sensor::camera::{Camera, Hemisphere, PixelFilter, Projection};
use crate::sensor::direction::Direction;
use crate::sensor::symmetry::SymmetryChoice;

/// Default samples per direction or pixel.
pub const DEFAULT_SAMPLES: u64 = 100_000;
/// Default sun zenith angle (degrees).
pub const DEFAULT_SUN_ZENITH_DEG: f64 = 45.0;
/// Default view zenith angles (degrees) of the `directions` sensor.
pub const DEFAULT_VIEW_ZENITH_DEG: [f64; 4] = [0.0, 30.0, 60.0, 78.46];
/// Default azimuths (degrees) of the `directions` sensor.
pub const DEFAULT_AZIMUTH_DEG: [f64; 3] = [0.0, 90.0, 180.0];
/// Largest image side (pixels).
pub const MAX_RESOLUTION: i64 = 16384;

/// Default pilot samples per direction or pixel of a noise target.
pub const DEFAULT_PILOT_SAMPLES: u64 = 32;
/// Default cap on a noise target's samples per direction or pixel.
pub const DEFAULT_MAX_SAMPLES: u64 = 1_000_000;
/// Largest cap of a noise target.
pub const MAX_TARGET_SAMPLES: u64 = 1 << 24;

/// A noise target (`render.noise_target`): each direction or pixel gets the
/// samples its pilot says it needs for a relative standard error of I of
/// `relative_se` in every channel and every albedo it counts, between `pilot` and
/// `max_samples`. The pilot's own samples only set the allocation; the
/// result is the mean of the allocated samples alone, so it stays
/// unbiased (`crate::run::allocation`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseTarget {
    pub relative_se: f64,
    /// Pilot samples per direction or pixel (also the fewest allocated).
    pub pilot: u64,
    /// Most samples allocated per direction or pixel.
    pub max_samples: u64,
    /// The albedos whose noise sets the allocation.
    pub albedos: TargetAlbedos,
    /// What the relative error is of: each direction or pixel, or each
    /// image as a whole.
    pub per: TargetScope,
}

/// What a noise target's relative standard error is of
/// (`render.noise_target_per`; closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TargetScope {
    /// Each direction or pixel: its standard error of I over its I (the
    /// default).
    Pixel,
    /// Each image (every channel and counted albedo) as a whole: the
    /// root-mean-square standard error of I over the root-mean-square I,
    /// solid-angle weighted, √(Σ Ω·se² / Σ Ω·I²): the noise floor that
    /// `fit-report` shows, −20·log10(t) dB. Samples go where they lower it
    /// most per path: to each pixel in proportion to its standard
    /// deviation of I times the square root of its solid angle
    /// (`crate::run::allocation::image_pixels`). Images only.
    Image,
}

impl TargetScope {
    /// The value of `render.noise_target_per`.
    pub fn key_value(self) -> &'static str {
        match self {
            TargetScope::Pixel => "pixel",
            TargetScope::Image => "image",
        }
    }

    /// What the relative error is of, in words (outputs' metadata).
    pub fn describe(self) -> &'static str {
        match self {
            TargetScope::Pixel => "per direction or pixel",
            TargetScope::Image => "per image (rms standard error over rms I, solid-angle weighted)",
        }
    }
}

/// Which albedos a noise target counts (`render.noise_target_albedos`;
/// closed set). The others are rendered from the same paths, and their
/// noise is reported, but it allocates no samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TargetAlbedos {
    /// Every albedo (the default).
    All,
    /// The albedos above 0: the path radiance over a black ground, often
    /// the noisiest value seen from above at twilight, only rides along.
    AboveZero,
}

impl TargetAlbedos {
    /// Whether the target counts albedo `albedo`.
    pub fn counts(self, albedo: f64) -> bool {
        match self {
            TargetAlbedos::All => true,
            TargetAlbedos::AboveZero => albedo > 0.0,
        }
    }

    /// The albedos counted, in words (outputs' metadata).
    pub fn describe(self) -> &'static str {
        match self {
            TargetAlbedos::All => "every albedo",
            TargetAlbedos::AboveZero => "every albedo above 0",
        }
    }

    /// The value of `render.noise_target_albedos`.
    pub fn key_value(self) -> &'static str {
        match self {
            TargetAlbedos::All => "all",
            TargetAlbedos::AboveZero => "above_zero",
        }
    }
}

/// What the sensor records.
#[derive(Debug, Clone, PartialEq)]
pub enum Sensor {
    /// Radiance in a list of viewing directions (a CSV).
    Directions(Vec<Direction>),
    /// An image (an EXR).
    Image(Camera),
}

/// Output radiance units (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RadianceUnits {
    /// Per unit extraterrestrial solar irradiance (E0 = 1), sr⁻¹.
    Normalized,
    /// × the Kurucz solar irradiance: W m⁻² sr⁻¹ nm⁻¹.
    Absolute,
}

/// What a render needs besides the atmosphere.
#[derive(Debug, Clone)]
pub struct RenderSpec {
    /// Sun zenith angles (degrees): a grid axis.
    pub sun_zeniths_deg: Vec<f64>,
    pub sun_angular_radius_deg: f64,
    /// Ground albedos; each is rendered.
    pub albedos: Vec<f64>,
    pub sensor: Sensor,
    pub pixel_filter: PixelFilter,
    /// The frame of the output Stokes vectors (per pixel: the frame of its
    /// centre, carried over the pixel).
    pub stokes_frame: StokesFrame,
    /// Which of the sky's symmetries an image may use to trace fewer
    /// columns (resolved per task: [`SymmetryChoice::resolve`]).
    pub symmetry: SymmetryChoice,
    /// Also estimate the fluxes at the observer level (`directions`).
    pub fluxes: bool,
    /// Samples per direction or pixel (with a noise target: the most any
    /// gets, `target.max_samples`).
    pub samples: u64,
    /// Allocate samples to a noise target instead of a fixed count.
    pub target: Option<NoiseTarget>,
    /// Render all wavelengths along shared paths where the media allow.
    pub shared_wavelengths: bool,
    /// How the channels along shared paths are grouped.
    pub spectral_groups: SpectralGroups,
    pub seed: u64,
    pub settings: Settings,
    /// Which of the settings the job gave, and which are the defaults a
    /// scene may choose by its regime (`transport::scene_build`).
    pub given: GivenSettings,
    pub medium: MediumModel,
    pub majorant_scale: f64,
    pub output_directory: PathBuf,
    /// Write the transmitted direct sun per wavelength.
    pub output_sun: bool,
    pub units: RadianceUnits,
    /// Write PNG previews of images.
    pub preview: bool,
    /// Preview exposure (multiplier before the sRGB curve); `None`: auto.
    pub exposure: Option<f64>,
}

impl RenderSpec {
    /// The `directions` sensor's list, empty for images.
    pub fn directions(&self) -> &[Direction] {
        match &self.sensor {
            Sensor::Directions(d) => d,
            Sensor::Image(_) => &[],
        }
    }
}

fn axis(ctx: &Ctx, key: &str, v: &OneOrMany, lo: f64, hi: f64, valid: &str) -> Result<Vec<f64>> {
    let values = v.values();
    if values.is_empty() {
        return Err(ctx.invalid(
            key,
            "[]",
            "empty list",
            &format!("a number or a non-empty list, {valid}"),
        ));
    }
    values
        .into_iter()
        .map(|x| ctx.range(key, x, lo, hi, false, valid))
        .collect()
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
    let sun_zeniths_deg = match (&sun.zenith_deg, &sun.elevation_deg) {
        (Some(_), Some(_)) => {
            return Err(ctx.invalid(
                "sun.elevation_deg",
                "(given)",
                "sun.zenith_deg is given too",
                "one of sun.zenith_deg or sun.elevation_deg",
            ));
        }
        (Some(z), None) => axis(ctx, "sun.zenith_deg", z, 0.0, 180.0, "0 to 180 degrees")?,
        (None, Some(e)) => axis(ctx, "sun.elevation_deg", e, -90.0, 90.0, "-90 to 90 degrees")?
            .into_iter()
            .map(|e| 90.0 - e)
            .collect(),
        (None, None) => vec![DEFAULT_SUN_ZENITH_DEG],
    };
    let sun_angular_radius_deg = ctx.range(
        "sun.angular_radius_deg",
        sun.angular_radius_deg.unwrap_or(0.0),
        0.0,
        5.0,
        false,
        "0 (point sun) to 5 degrees; the sun's is 0.2666",
    )?;

    let albedos = match ground.unwrap_or_default().albedo {
        None => vec![0.0],
        Some(a) => axis(ctx, "ground.albedo", &a, 0.0, 1.0, "0 to 1")?,
    };
    if albedos.len() > MAX_ALBEDOS {
        return Err(ctx.invalid(
            "ground.albedo",
            format!("{} values", albedos.len()),
            "too many albedos for one render",
            &format!("at most {MAX_ALBEDOS} (they share the paths)"),
        ));
    }

    let sensor_raw = sensor.unwrap_or_default();
    let kind = sensor_raw.kind.unwrap_or(RawSensorKind::Directions);
    check_sensor_keys(ctx, kind, &sensor_raw)?;
    let sensor = match kind {
        RawSensorKind::Directions => Sensor::Directions(resolve_directions(ctx, &sensor_raw)?),
        image => Sensor::Image(resolve_camera(ctx, image, &sensor_raw)?),
    };
    let pixel_filter = match sensor_raw.pixel_filter.unwrap_or(RawPixelFilter::Box) {
        RawPixelFilter::Box => PixelFilter::Box,
        RawPixelFilter::Center => PixelFilter::Center,
    };

    let stokes_frame = match sensor_raw.stokes_frame {
        None | Some(RawStokesFrame::Meridian) => StokesFrame::Meridian,
        Some(RawStokesFrame::SunView) => StokesFrame::SunView,
    };

    let symmetry = match sensor_raw.symmetry {
        None | Some(RawSymmetry::Auto) => SymmetryChoice::Auto,
        Some(RawSymmetry::Mirror) => SymmetryChoice::Mirror,
        Some(RawSymmetry::None) => SymmetryChoice::None,
    };

    let render = render.unwrap_or_default();
    let target = resolve_target(ctx, &render, &albedos, matches!(sensor, Sensor::Image(_)))?;
    let samples = match target {
        Some(t) => t.max_samples,
        None => render.samples.unwrap_or(DEFAULT_SAMPLES),
    };
    if samples == 0 {
        return Err(ctx.invalid("render.samples", 0, "no samples", "at least 1"));
    }
    if let Sensor::Image(camera) = &sensor {
        // An image's work is counted in samples × pixels (u64).
        let (w, h) = camera.size();
        let pixels = (w * h) as u64;
        if samples.checked_mul(pixels).is_none_or(|n| n > 1 << 62) {
            return Err(ctx.invalid(
                if target.is_some() {
                    "render.max_samples"
                } else {
                    "render.samples"
                },
                samples,
                &format!("too many samples for an image of {pixels} pixels"),
                &format!("at most {} per pixel at this resolution", (1u64 << 62) / pixels),
            ));
        }
    }
    let majorant_scale = ctx.range(
        "render.majorant_scale",
        render.majorant_scale.unwrap_or(1.0),
        1.0,
        1.0e6,
        false,
        "1 (tight) or more",
    )?;
    let sun_samples_per_flight = match render.sun_samples_per_flight.unwrap_or(1) {
        0 => return Err(ctx.invalid("render.sun_samples_per_flight", 0, "no sun connections", "1 or more")),
        k => k,
    };
    let roulette_threshold = ctx.range(
        "render.roulette_threshold",
        render.roulette_threshold.unwrap_or(DEFAULT_ROULETTE_THRESHOLD),
        0.0,
        1.0,
        true,
        "above 0 and at most 1 (default 0.03)",
    )?;
    let sun_transmittance = match render.sun_transmittance.unwrap_or(RawSunTransmittance::Analytic) {
        RawSunTransmittance::Analytic => SunTransmittance::Analytic,
        RawSunTransmittance::RatioTracking => SunTransmittance::RatioTracking,
    };
    let tracking_layers = match render.tracking_layers.unwrap_or(RawTrackingLayers::Auto) {
        RawTrackingLayers::Auto => TrackingLayers::Auto,
        RawTrackingLayers::Profile => TrackingLayers::Profile,
        RawTrackingLayers::Merged => TrackingLayers::Merged,
    };
    if tracking_layers == TrackingLayers::Merged {
        let smooth = matches!(render.medium, Some(RawMedium::Smooth));
        if smooth || sun_transmittance == SunTransmittance::RatioTracking {
            return Err(ctx.invalid(
                "render.tracking_layers",
                "merged",
                if smooth {
                    "merging needs the layered medium, and medium = \"smooth\""
                } else {
                    "merged layers need analytic shadow rays, and sun_transmittance = \"ratio_tracking\""
                },
                "\"auto\" or \"profile\" here (\"merged\" with medium = \"layered\" and sun_transmittance = \"analytic\")",
            ));
        }
    }
    let output = output.unwrap_or_default();
    let exposure = match output.exposure {
        None => None,
        Some(e) => Some(ctx.range("output.exposure", e, 0.0, f64::MAX, true, "a positive multiplier")?),
    };
    Ok(RenderSpec {
        sun_zeniths_deg,
        sun_angular_radius_deg,
        albedos,
        sensor,
        pixel_filter,
        stokes_frame,
        symmetry,
        fluxes: sensor_raw.fluxes.unwrap_or(true),
        samples,
        target,
        shared_wavelengths: render.shared_wavelengths.unwrap_or(true),
        spectral_groups: spectral_groups(ctx, render.spectral_groups.as_ref())?,
        seed: render.seed.unwrap_or(1),
        given: GivenSettings {
            roulette_threshold: render.roulette_threshold.is_some(),
        },
        settings: Settings {
            polarized: render.polarized.unwrap_or(true),
            max_scattering_order: render.max_scattering_order.unwrap_or(0),
            sun_transmittance,
            tracking_layers,
            forced_collisions: render.forced_collisions.unwrap_or(true),
            sun_samples_per_flight,
            sun_sampling: match render.sun_sampling.unwrap_or(RawSunSampling::Auto) {
                RawSunSampling::Auto => SunSampling::Auto,
                RawSunSampling::SunAware => SunSampling::SunAware,
                RawSunSampling::Collision => SunSampling::Collision,
            },
            first_vertex_splitting: render.first_vertex_splitting.unwrap_or(true),
            // Given, the key rules both; absent, a noise target (of I)
            // leaves the first scattering unsplit.
            split_first_scattering: render.first_vertex_splitting.unwrap_or(target.is_none()),
            roulette_threshold,
        },
        medium: match render.medium.unwrap_or(RawMedium::Layered) {
            RawMedium::Layered => MediumModel::Layered,
            RawMedium::Smooth => MediumModel::Smooth,
        },
        majorant_scale,
        output_directory: output.directory.unwrap_or_else(|| PathBuf::from("out")),
        output_sun: output.sun.unwrap_or(false),
        units: match output.units.unwrap_or(RawUnits::Normalized) {
            RawUnits::Normalized => RadianceUnits::Normalized,
            RawUnits::Absolute => RadianceUnits::Absolute,
        },
        preview: output.preview.unwrap_or(true),
        exposure,
    })
}

/// The noise target of `[render]`, if any: `noise_target` with its
/// `pilot_samples` and `max_samples`, which mean nothing without it, as
/// `samples` means nothing with it.
fn resolve_target(ctx: &Ctx, render: &RawRender, albedos: &[f64], image: bool) -> Result<Option<NoiseTarget>> {
    let counted = render.noise_target_albedos.map(|a| match a {
        RawTargetAlbedos::All => TargetAlbedos::All,
        RawTargetAlbedos::AboveZero => TargetAlbedos::AboveZero,
    });
    let per = render.noise_target_per.map(|p| match p {
        RawTargetScope::Pixel => TargetScope::Pixel,
        RawTargetScope::Image => TargetScope::Image,
    });
    let Some(relative_se) = render.noise_target else {
        for (key, given) in [
            ("render.pilot_samples", render.pilot_samples.map(|v| v.to_string())),
            ("render.max_samples", render.max_samples.map(|v| v.to_string())),
            (
                "render.noise_target_albedos",
                counted.map(|a| a.key_value().to_string()),
            ),
            ("render.noise_target_per", per.map(|p| p.key_value().to_string())),
        ] {
            if let Some(v) = given {
                return Err(ctx.invalid(
                    key,
                    v,
                    "only a noise target has pilot and maximum samples and albedos it counts",
                    "set render.noise_target too, or leave the key out (render.samples is the fixed count)",
                ));
            }
        }
        return Ok(None);
    };
    if let Some(n) = render.samples {
        return Err(ctx.invalid(
            "render.samples",
            n,
            "render.noise_target is given too",
            "one of render.samples (a fixed count) or render.noise_target (with render.max_samples as the cap)",
        ));
    }
    let relative_se = ctx.range(
        "render.noise_target",
        relative_se,
        0.0,
        1.0,
        true,
        "a relative standard error of I above 0 and at most 1 (0.005: 0.5 %)",
    )?;
    let pilot = render.pilot_samples.unwrap_or(DEFAULT_PILOT_SAMPLES);
    if pilot < 2 {
        return Err(ctx.invalid(
            "render.pilot_samples",
            pilot,
            "a pilot needs two samples for a variance",
            "at least 2 (default 32)",
        ));
    }
    let max_samples = render.max_samples.unwrap_or(DEFAULT_MAX_SAMPLES.max(pilot));
    if pilot > MAX_TARGET_SAMPLES || max_samples > MAX_TARGET_SAMPLES {
        let (key, v) = if pilot > MAX_TARGET_SAMPLES {
            ("render.pilot_samples", pilot)
        } else {
            ("render.max_samples", max_samples)
        };
        return Err(ctx.invalid(
            key,
            v,
            "too many samples per direction or pixel for a noise target",
            &format!("at most {MAX_TARGET_SAMPLES} (2^24: the image's per-pixel counts are exact 32-bit floats)"),
        ));
    }
    if max_samples < pilot {
        return Err(ctx.invalid(
            "render.max_samples",
            max_samples,
            &format!("below render.pilot_samples ({pilot}), the fewest any direction or pixel gets"),
            &format!("at least {pilot}"),
        ));
    }
    let counted = counted.unwrap_or(TargetAlbedos::All);
    if !albedos.iter().any(|&a| counted.counts(a)) {
        return Err(ctx.invalid(
            "render.noise_target_albedos",
            counted.key_value(),
            "ground.albedo has no albedo above 0, so the target would count nothing",
            "\"all\" (the default), or an albedo above 0 in ground.albedo",
        ));
    }
    let per = per.unwrap_or(TargetScope::Pixel);
    if per == TargetScope::Image && !image {
        return Err(ctx.invalid(
            "render.noise_target_per",
            "\"image\"",
            "a directions sensor has no image to hold to a target as a whole",
            "\"pixel\" (the default: each direction's own relative error), or an image sensor",
        ));
    }
    Ok(Some(NoiseTarget {
        relative_se,
        pilot,
        max_samples,
        albedos: counted,
        per,
    }))
}

/// Refuses the keys of one kind of sensor given to the other, which it
/// would ignore (a directions sensor has no pixels; an image no list of
/// directions and no flux estimates).
fn check_sensor_keys(ctx: &Ctx, kind: RawSensorKind, sensor: &RawSensor) -> Result<()> {
    let image = !matches!(kind, RawSensorKind::Directions);
    let keys: [(&str, bool, bool); 9] = [
        ("sensor.resolution", sensor.resolution.is_some(), true),
        ("sensor.hemisphere", sensor.hemisphere.is_some(), true),
        ("sensor.projection", sensor.projection.is_some(), true),
        ("sensor.pixel_filter", sensor.pixel_filter.is_some(), true),
        ("sensor.symmetry", sensor.symmetry.is_some(), true),
        ("sensor.view_zenith_deg", sensor.view_zenith_deg.is_some(), false),
        ("sensor.azimuth_deg", sensor.azimuth_deg.is_some(), false),
        ("sensor.directions", sensor.directions.is_some(), false),
        ("sensor.fluxes", sensor.fluxes.is_some(), false),
    ];
    let fisheye_only = ["sensor.hemisphere", "sensor.projection"];
    for (key, given, for_images) in keys {
        let fits = if for_images {
            image && (!fisheye_only.contains(&key) || matches!(kind, RawSensorKind::Fisheye))
        } else {
            !image
        };
        if given && !fits {
            let (reason, valid) = if for_images && image {
                (
                    "applies to the fisheye sensor only",
                    "leave it out, or sensor.type = \"fisheye\"",
                )
            } else if for_images {
                (
                    "applies to image sensors only; a directions sensor would ignore it",
                    "leave it out, or sensor.type = \"fisheye\", \"panorama\" or \"sphere\"",
                )
            } else {
                (
                    "applies to the directions sensor only; an image sensor would ignore it",
                    "leave it out, or sensor.type = \"directions\"",
                )
            };
            return Err(ctx.invalid(key, "(given)", reason, valid));
        }
    }
    Ok(())
}

fn resolve_directions(ctx: &Ctx, sensor: &RawSensor) -> Result<Vec<Direction>> {
    let directions = match (&sensor.directions, &sensor.view_zenith_deg, &sensor.azimuth_deg) {
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
            zs.iter().flat_map(|&z| azs.iter().map(move |&a| (z, a))).collect()
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
    directions
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
        .collect()
}

fn resolve_camera(ctx: &Ctx, kind: RawSensorKind, sensor: &RawSensor) -> Result<Camera> {
    let side = |key: &str, v: i64| -> Result<usize> {
        if (1..=MAX_RESOLUTION).contains(&v) {
            Ok(v as usize)
        } else {
            Err(ctx.invalid(
                key,
                v,
                "not a usable image size",
                &format!("1 to {MAX_RESOLUTION} pixels"),
            ))
        }
    };
    let (width, height) = match sensor.resolution {
        None => match kind {
            RawSensorKind::Fisheye => (128, 128),
            RawSensorKind::Panorama => (180, 180),
            _ => (360, 180),
        },
        Some(RawResolution::Square(n)) => {
            let n = side("sensor.resolution", n)?;
            match kind {
                RawSensorKind::Sphere => (2 * n, n),
                _ => (n, n),
            }
        }
        Some(RawResolution::Rect([w, h])) => (side("sensor.resolution", w)?, side("sensor.resolution", h)?),
    };
    Ok(match kind {
        RawSensorKind::Fisheye => {
            if width != height {
                return Err(ctx.invalid(
                    "sensor.resolution",
                    format!("[{width}, {height}]"),
                    "a fisheye image is square",
                    "one number, e.g. resolution = 256",
                ));
            }
            Camera::Fisheye {
                resolution: width,
                hemisphere: match sensor.hemisphere.unwrap_or(RawHemisphere::Up) {
                    RawHemisphere::Up => Hemisphere::Up,
                    RawHemisphere::Down => Hemisphere::Down,
                },
                projection: match sensor.projection.unwrap_or(RawProjection::Equidistant) {
                    RawProjection::Equidistant => Projection::Equidistant,
                    RawProjection::Equisolid => Projection::Equisolid,
                    RawProjection::Stereographic => Projection::Stereographic,
                },
            }
        }
        RawSensorKind::Panorama => Camera::Panorama { width, height },
        RawSensorKind::Sphere => Camera::Sphere { width, height },
        RawSensorKind::Directions => unreachable!("handled by the caller"),
    })
}

/// `render.spectral_groups`: "auto" (the default) or a whole number ≥ 1.
fn spectral_groups(ctx: &Ctx, raw: Option<&RawSpectralGroups>) -> Result<SpectralGroups> {
    let valid = "\"auto\" or a whole number of groups from 1 (every channel along the same paths)";
    match raw {
        None => Ok(SpectralGroups::Auto),
        Some(RawSpectralGroups::Name(name)) if name == "auto" => Ok(SpectralGroups::Auto),
        Some(RawSpectralGroups::Name(name)) => {
            Err(ctx.invalid("render.spectral_groups", format!("\"{name}\""), "not a grouping", valid))
        }
        Some(RawSpectralGroups::Count(n)) if *n >= 1 => Ok(SpectralGroups::Count(*n as usize)),
        Some(RawSpectralGroups::Count(n)) => Err(ctx.invalid("render.spectral_groups", n, "out of range", valid)),
    }
}
