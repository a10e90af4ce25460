//! The raw job-file schema: serde structs that refuse unknown keys. The
//! resolved, validated job is in the parent module.

use std::path::PathBuf;

use serde::Deserialize;

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawJob {
    pub(super) planet: Option<RawPlanet>,
    pub(super) atmosphere: Option<RawAtmosphere>,
    pub(super) spectrum: Option<RawSpectrum>,
    pub(super) observer: Option<RawObserver>,
    pub(super) sun: Option<RawSun>,
    pub(super) ground: Option<RawGround>,
    pub(super) sensor: Option<RawSensor>,
    pub(super) render: Option<RawRender>,
    pub(super) output: Option<RawOutput>,
    pub(super) transmittance: Option<RawTransmittance>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPlanet {
    pub(super) radius_km: Option<f64>,
    pub(super) top_km: Option<f64>,
    pub(super) geometry: Option<GeometryKind>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawAtmosphere {
    pub(super) profile: Option<String>,
    pub(super) profile_file: Option<PathBuf>,
    pub(super) ozone: Option<RawOzone>,
    pub(super) ozone_column_du: Option<f64>,
    pub(super) rayleigh: Option<RawRayleigh>,
    pub(super) aerosol: Option<String>,
    pub(super) aerosol_phase: Option<RawAerosolPhase>,
    pub(super) visibility_km: Option<OneOrMany>,
    pub(super) layers: Option<Vec<RawLayer>>,
    pub(super) aerosol_layers: Option<Vec<RawAerosolLayer>>,
    pub(super) gases: Option<RawGases>,
    pub(super) precipitable_water_cm: Option<f64>,
    pub(super) co2_ppm: Option<f64>,
}

/// `atmosphere.gases`: `"all"`, `"none"` or a list of gas names.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub(super) enum RawGases {
    One(String),
    Many(Vec<String>),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawAerosolLayer {
    pub(super) bottom_km: f64,
    pub(super) top_km: f64,
    pub(super) tau: f64,
    #[serde(default = "one")]
    pub(super) ssa: f64,
    #[serde(default)]
    pub(super) g: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLayer {
    pub(super) bottom_km: f64,
    pub(super) top_km: f64,
    #[serde(default)]
    pub(super) tau_rayleigh: f64,
    #[serde(default)]
    pub(super) rayleigh_depolarization: f64,
    #[serde(default)]
    pub(super) tau_absorption: f64,
    #[serde(default)]
    pub(super) tau_aerosol: f64,
    #[serde(default = "one")]
    pub(super) aerosol_ssa: f64,
    #[serde(default)]
    pub(super) aerosol_g: f64,
}

pub(super) fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawAerosolPhase {
    Mie,
    Hg,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawOzone {
    Bogumil,
    Molina,
    None,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawRayleigh {
    Bodhaine,
    None,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSpectrum {
    pub(super) wavelengths_nm: Option<Vec<f64>>,
    pub(super) band_width_nm: Option<OneOrMany>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawObserver {
    pub(super) altitude_km: Option<OneOrMany>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSun {
    pub(super) zenith_deg: Option<OneOrMany>,
    pub(super) elevation_deg: Option<OneOrMany>,
    pub(super) angular_radius_deg: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGround {
    pub(super) albedo: Option<OneOrMany>,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawSensorKind {
    Directions,
    Fisheye,
    Panorama,
    Sphere,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawHemisphere {
    Up,
    Down,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawProjection {
    Equidistant,
    Equisolid,
    Stereographic,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawPixelFilter {
    Box,
    Center,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawStokesFrame {
    Meridian,
    SunView,
}

/// Planet geometry (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GeometryKind {
    Spherical,
    PlaneParallel,
    /// Plane-parallel transport with the direct solar beam attenuated along
    /// its path through spherical shells (DISORT's and uvspec's
    /// `pseudospherical`): reproduces those runs, not the real sky.
    PseudoSpherical,
}

/// `resolution = 256` or `resolution = [512, 256]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(
    untagged,
    expecting = "a whole number or a list of two whole numbers [width, height]"
)]
pub(super) enum RawResolution {
    Square(i64),
    Rect([i64; 2]),
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSensor {
    #[serde(rename = "type")]
    pub(super) kind: Option<RawSensorKind>,
    pub(super) view_zenith_deg: Option<Vec<f64>>,
    pub(super) azimuth_deg: Option<Vec<f64>>,
    pub(super) directions: Option<Vec<[f64; 2]>>,
    pub(super) fluxes: Option<bool>,
    pub(super) resolution: Option<RawResolution>,
    pub(super) hemisphere: Option<RawHemisphere>,
    pub(super) projection: Option<RawProjection>,
    pub(super) pixel_filter: Option<RawPixelFilter>,
    pub(super) stokes_frame: Option<RawStokesFrame>,
    pub(super) symmetry: Option<RawSymmetry>,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawSymmetry {
    Auto,
    Mirror,
    None,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawMedium {
    Layered,
    Smooth,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawSunTransmittance {
    Analytic,
    RatioTracking,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRender {
    pub(super) samples: Option<u64>,
    pub(super) noise_target: Option<f64>,
    pub(super) pilot_samples: Option<u64>,
    pub(super) max_samples: Option<u64>,
    pub(super) noise_target_albedos: Option<RawTargetAlbedos>,
    pub(super) noise_target_per: Option<RawTargetScope>,
    pub(super) seed: Option<u64>,
    pub(super) polarized: Option<bool>,
    pub(super) max_scattering_order: Option<u32>,
    pub(super) medium: Option<RawMedium>,
    pub(super) sun_transmittance: Option<RawSunTransmittance>,
    pub(super) tracking_layers: Option<RawTrackingLayers>,
    pub(super) majorant_scale: Option<f64>,
    pub(super) forced_collisions: Option<bool>,
    pub(super) sun_samples_per_flight: Option<u32>,
    pub(super) roulette_threshold: Option<f64>,
    pub(super) sun_sampling: Option<RawSunSampling>,
    pub(super) first_vertex_splitting: Option<bool>,
    pub(super) shared_wavelengths: Option<bool>,
    pub(super) spectral_groups: Option<RawSpectralGroups>,
}

/// `noise_target_per`: what a noise target's relative error is of.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawTargetScope {
    Pixel,
    Image,
}

/// `noise_target_albedos`: which albedos a noise target counts.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawTargetAlbedos {
    All,
    AboveZero,
}

/// `spectral_groups = "auto"` or a whole number of groups.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged, expecting = "\"auto\" or a whole number of groups")]
pub(super) enum RawSpectralGroups {
    Count(i64),
    Name(String),
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawTrackingLayers {
    Auto,
    Profile,
    Merged,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawSunSampling {
    Auto,
    SunAware,
    Collision,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOutput {
    pub(super) directory: Option<PathBuf>,
    pub(super) sun: Option<bool>,
    pub(super) units: Option<RawUnits>,
    pub(super) preview: Option<bool>,
    pub(super) exposure: Option<f64>,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawUnits {
    Normalized,
    Absolute,
}

/// A number or a list of numbers (a grid axis).
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged, expecting = "a number or a list of numbers")]
pub(super) enum OneOrMany {
    One(f64),
    Many(Vec<f64>),
}

impl OneOrMany {
    pub(super) fn values(&self) -> Vec<f64> {
        match self {
            OneOrMany::One(v) => vec![*v],
            OneOrMany::Many(v) => v.clone(),
        }
    }
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawEstimator {
    RatioTracking,
    ResidualRatioTracking,
    Analytic,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RawTableLayout {
    Closed,
    SkyModel,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTransmittance {
    pub(super) layout: Option<RawTableLayout>,
    pub(super) altitude_nodes: Option<i64>,
    pub(super) distance_nodes: Option<i64>,
    pub(super) max_distance_km: Option<f64>,
    pub(super) altitudes_km: Option<Vec<f64>>,
    pub(super) distances_km: Option<Vec<f64>>,
    pub(super) estimator: Option<RawEstimator>,
    pub(super) samples: Option<u64>,
    pub(super) export_sqrt: Option<bool>,
}
