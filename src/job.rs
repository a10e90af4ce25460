//! Job files: the raw TOML schema (serde, unknown keys refused) and the
//! resolved, validated job with tables loaded and the atmosphere built.
//!
//! Every error names the file and the key, with the value and the valid
//! range; TOML syntax and schema errors carry TOML's line and column.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::aerosol::Aerosol;
use crate::atmosphere::{Atmosphere, BuildError, ExplicitLayer, ProfileSpec};
use crate::data;
use crate::error::{Error, Result};
use crate::ozone::OzoneModel;
use crate::profile::GasProfile;
use crate::rayleigh::RayleighModel;

/// Default planet radius (km): the sky model's (libRadtran uses 6370).
pub const DEFAULT_RADIUS_KM: f64 = 6378.0;
/// Default top of the atmosphere (km).
pub const DEFAULT_TOP_KM: f64 = 100.0;
/// Default wavelengths (nm): the seed's validation wavelengths.
pub const DEFAULT_WAVELENGTHS_NM: [f64; 3] = [420.0, 540.0, 620.0];

// ---------------------------------------------------------------------------
// Raw schema

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawJob {
    planet: Option<RawPlanet>,
    atmosphere: Option<RawAtmosphere>,
    spectrum: Option<RawSpectrum>,
    observer: Option<RawObserver>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlanet {
    radius_km: Option<f64>,
    top_km: Option<f64>,
    geometry: Option<GeometryKind>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAtmosphere {
    profile: Option<String>,
    profile_file: Option<PathBuf>,
    ozone: Option<RawOzone>,
    ozone_column_du: Option<f64>,
    rayleigh: Option<RawRayleigh>,
    aerosol: Option<String>,
    visibility_km: Option<f64>,
    layers: Option<Vec<RawLayer>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLayer {
    bottom_km: f64,
    top_km: f64,
    #[serde(default)]
    tau_rayleigh: f64,
    #[serde(default)]
    rayleigh_depolarization: f64,
    #[serde(default)]
    tau_absorption: f64,
    #[serde(default)]
    tau_aerosol: f64,
    #[serde(default = "one")]
    aerosol_ssa: f64,
    #[serde(default)]
    aerosol_g: f64,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
enum RawOzone {
    Bogumil,
    Molina,
    None,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case")]
enum RawRayleigh {
    Bodhaine,
    None,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpectrum {
    wavelengths_nm: Option<Vec<f64>>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObserver {
    altitude_km: Option<f64>,
}

// ---------------------------------------------------------------------------
// Resolved job

/// Planet geometry (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GeometryKind {
    Spherical,
    PlaneParallel,
}

/// The planet: radius, top of the atmosphere and geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planet {
    pub radius_km: f64,
    pub top_km: f64,
    pub geometry: GeometryKind,
}

/// What the atmosphere was built from, for reports.
#[derive(Debug, Clone, PartialEq)]
pub enum AtmosphereSource {
    Profile {
        profile: String,
        ozone: OzoneModel,
        rayleigh: RayleighModel,
        aerosol: Option<String>,
    },
    Layers,
}

/// A validated job.
#[derive(Debug, Clone)]
pub struct Job {
    /// The job file (or `<built-in default>`), for messages.
    pub file: String,
    pub planet: Planet,
    pub observer_altitude_km: f64,
    pub wavelengths_nm: Vec<f64>,
    pub source: AtmosphereSource,
    pub atmosphere: Atmosphere,
}

/// Validation context: the file name for every error.
struct Ctx<'a> {
    file: &'a str,
}

impl Ctx<'_> {
    fn invalid(
        &self,
        key: &str,
        value: impl std::fmt::Display,
        reason: &str,
        valid: &str,
    ) -> Error {
        Error::InvalidValue {
            file: self.file.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.to_string(),
            valid: valid.to_string(),
        }
    }

    /// A finite number within [lo, hi] (inclusive by the flags).
    fn range(
        &self,
        key: &str,
        v: f64,
        lo: f64,
        hi: f64,
        lo_open: bool,
        valid: &str,
    ) -> Result<f64> {
        let ok = v.is_finite() && (if lo_open { v > lo } else { v >= lo }) && v <= hi;
        if ok {
            Ok(v)
        } else if !v.is_finite() {
            Err(self.invalid(key, v, "not a finite number", valid))
        } else {
            Err(self.invalid(key, v, "out of range", valid))
        }
    }
}

impl Job {
    /// The built-in default job: US-standard atmosphere, Bogumil ozone,
    /// OPAC continental_average (unscaled, ≈ 59 km visibility), 420, 540
    /// and 620 nm, spherical planet of 6378 km with a 100 km top.
    pub fn builtin_default() -> Result<Job> {
        Self::parse("", "<built-in default>", Path::new("."))
    }

    /// Reads and resolves a job file.
    pub fn from_file(path: &Path) -> Result<Job> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        Self::parse(&text, &path.display().to_string(), dir)
    }

    /// Resolves job text; `file` names it in errors and relative paths in it
    /// are taken from `dir`.
    pub fn parse(text: &str, file: &str, dir: &Path) -> Result<Job> {
        let raw: RawJob = toml::from_str(text).map_err(|e| Error::JobSyntax {
            file: file.to_string(),
            message: e.to_string().trim_end().to_string(),
        })?;
        let ctx = Ctx { file };
        let planet_raw = raw.planet.unwrap_or_default();
        let atm = raw.atmosphere.unwrap_or_default();

        let radius_km = ctx.range(
            "planet.radius_km",
            planet_raw.radius_km.unwrap_or(DEFAULT_RADIUS_KM),
            0.0,
            1.0e6,
            true,
            "a positive number of km, e.g. 6378 (sky model) or 6370 (libRadtran)",
        )?;
        let geometry = planet_raw.geometry.unwrap_or(GeometryKind::Spherical);

        let wavelengths_nm = match raw.spectrum.and_then(|s| s.wavelengths_nm) {
            None => DEFAULT_WAVELENGTHS_NM.to_vec(),
            Some(w) if w.is_empty() => {
                return Err(ctx.invalid(
                    "spectrum.wavelengths_nm",
                    "[]",
                    "empty list",
                    "at least one wavelength in nm",
                ));
            }
            Some(w) => {
                for &l in &w {
                    ctx.range(
                        "spectrum.wavelengths_nm",
                        l,
                        0.0,
                        f64::MAX,
                        true,
                        "positive wavelengths in nm",
                    )?;
                }
                w
            }
        };

        let (source, atmosphere, top_km) = if let Some(layers) = &atm.layers {
            let given: Vec<&str> = [
                ("profile", atm.profile.is_some()),
                ("profile_file", atm.profile_file.is_some()),
                ("ozone", atm.ozone.is_some()),
                ("ozone_column_du", atm.ozone_column_du.is_some()),
                ("rayleigh", atm.rayleigh.is_some()),
                ("aerosol", atm.aerosol.is_some()),
                ("visibility_km", atm.visibility_km.is_some()),
            ]
            .iter()
            .filter(|(_, g)| *g)
            .map(|(k, _)| *k)
            .collect();
            if let Some(k) = given.first() {
                return Err(ctx.invalid(
                    &format!("atmosphere.{k}"),
                    "(given)",
                    "cannot be combined with atmosphere.layers, which replace the profile",
                    "either [[atmosphere.layers]] or the profile keys",
                ));
            }
            let layers = resolve_layers(&ctx, layers)?;
            let atmosphere = Atmosphere::from_layers(&layers, &wavelengths_nm)?;
            let top = atmosphere.top_km();
            if let Some(t) = planet_raw.top_km.filter(|&t| t != top) {
                return Err(ctx.invalid(
                    "planet.top_km",
                    t,
                    "differs from the top of the explicit layers",
                    &format!("{top} (or leave it out)"),
                ));
            }
            (AtmosphereSource::Layers, atmosphere, top)
        } else {
            let (spec, name) = resolve_profile_spec(&ctx, &atm, dir)?;
            let profile_top = spec.profile.top_km();
            let top_km = ctx.range(
                "planet.top_km",
                planet_raw.top_km.unwrap_or(DEFAULT_TOP_KM.min(profile_top)),
                spec.profile.ground_km(),
                profile_top,
                true,
                &format!("above the ground, at most the profile's top, {profile_top} km"),
            )?;
            let atmosphere = Atmosphere::from_profile(&spec, top_km, &wavelengths_nm)
                .map_err(|e| build_error(&ctx, &atm, e))?;
            let source = AtmosphereSource::Profile {
                profile: name,
                ozone: spec.ozone,
                rayleigh: spec.rayleigh,
                aerosol: spec.aerosol.as_ref().map(|a| a.mixture.name.clone()),
            };
            (source, atmosphere, top_km)
        };

        let observer_altitude_km = raw.observer.and_then(|o| o.altitude_km).unwrap_or(0.0);
        let ground = atmosphere.levels_km[0];
        if !observer_altitude_km.is_finite()
            || observer_altitude_km < ground
            || observer_altitude_km >= top_km
        {
            return Err(ctx.invalid(
                "observer.altitude_km",
                observer_altitude_km,
                if observer_altitude_km >= top_km {
                    "the observer is at or above the top of the atmosphere"
                } else {
                    "out of range"
                },
                &format!("from the ground ({ground} km) to below planet.top_km ({top_km} km)"),
            ));
        }

        Ok(Job {
            file: file.to_string(),
            planet: Planet {
                radius_km,
                top_km,
                geometry,
            },
            observer_altitude_km,
            wavelengths_nm,
            source,
            atmosphere,
        })
    }
}

fn resolve_profile_spec(
    ctx: &Ctx,
    atm: &RawAtmosphere,
    dir: &Path,
) -> Result<(ProfileSpec, String)> {
    let (profile, name) = match (&atm.profile, &atm.profile_file) {
        (Some(_), Some(_)) => {
            return Err(ctx.invalid(
                "atmosphere.profile_file",
                "(given)",
                "cannot be combined with atmosphere.profile",
                "one of profile (a built-in name) or profile_file (a path)",
            ));
        }
        (_, Some(path)) => {
            let full = dir.join(path);
            let text = std::fs::read_to_string(&full).map_err(|e| {
                ctx.invalid(
                    "atmosphere.profile_file",
                    full.display(),
                    &format!("cannot read the file: {e}"),
                    "a readable AFGL-format profile (9 columns: z_km p_hPa T_K n_air n_o3 n_o2 n_h2o n_co2 n_no2)",
                )
            })?;
            let p = GasProfile::parse(&full.display().to_string(), &text)?;
            (p, full.display().to_string())
        }
        (name, None) => {
            let name = name.as_deref().unwrap_or("us_standard");
            let p = GasProfile::builtin(name).ok_or_else(|| {
                ctx.invalid(
                    "atmosphere.profile",
                    format!("\"{name}\""),
                    "unknown profile",
                    &data::names(data::AFGL_PROFILES),
                )
            })??;
            (p, name.to_string())
        }
    };
    let ozone = match atm.ozone.unwrap_or(RawOzone::Bogumil) {
        RawOzone::Bogumil => OzoneModel::Bogumil,
        RawOzone::Molina => OzoneModel::Molina,
        RawOzone::None => OzoneModel::None,
    };
    let rayleigh = match atm.rayleigh.unwrap_or(RawRayleigh::Bodhaine) {
        RawRayleigh::Bodhaine => RayleighModel::Bodhaine,
        RawRayleigh::None => RayleighModel::None,
    };
    let ozone_column_du = match atm.ozone_column_du {
        None => None,
        Some(_) if ozone == OzoneModel::None => {
            return Err(ctx.invalid(
                "atmosphere.ozone_column_du",
                "(given)",
                "needs an ozone cross section, but atmosphere.ozone = \"none\"",
                "leave it out, or set ozone = \"bogumil\" or \"molina\"",
            ));
        }
        Some(du) => Some(ctx.range(
            "atmosphere.ozone_column_du",
            du,
            0.0,
            2000.0,
            false,
            "0 to 2000 DU",
        )?),
    };
    let aerosol_name = atm.aerosol.as_deref().unwrap_or("continental_average");
    let aerosol = if aerosol_name == "none" {
        None
    } else {
        let a = Aerosol::builtin(aerosol_name).ok_or_else(|| {
            ctx.invalid(
                "atmosphere.aerosol",
                format!("\"{aerosol_name}\""),
                "unknown aerosol mixture",
                &format!(
                    "\"none\" or an OPAC mixture: {}",
                    data::names(data::OPAC_MIXTURES)
                ),
            )
        })?;
        Some(a.map_err(|e| {
            ctx.invalid(
                "atmosphere.aerosol",
                format!("\"{aerosol_name}\""),
                &e.to_string(),
                "continental_average, continental_clean, continental_polluted, urban",
            )
        })?)
    };
    let visibility_km = match atm.visibility_km {
        None => None,
        Some(_) if aerosol.is_none() => {
            return Err(ctx.invalid(
                "atmosphere.visibility_km",
                "(given)",
                "scales the aerosol, but atmosphere.aerosol = \"none\"",
                "leave it out, or name an aerosol mixture",
            ));
        }
        Some(v) => Some(ctx.range(
            "atmosphere.visibility_km",
            v,
            0.0,
            f64::MAX,
            true,
            "a positive number of km",
        )?),
    };
    Ok((
        ProfileSpec {
            profile,
            rayleigh,
            ozone,
            ozone_column_du,
            aerosol,
            visibility_km,
        },
        name,
    ))
}

fn resolve_layers(ctx: &Ctx, raw: &[RawLayer]) -> Result<Vec<ExplicitLayer>> {
    if raw.is_empty() {
        return Err(ctx.invalid(
            "atmosphere.layers",
            "[]",
            "empty list",
            "at least one [[atmosphere.layers]] table",
        ));
    }
    raw.iter()
        .enumerate()
        .map(|(i, l)| {
            let key = |k: &str| format!("atmosphere.layers[{i}].{k}");
            let nonneg = |k: &str, v: f64| {
                ctx.range(&key(k), v, 0.0, f64::MAX, false, "a finite number ≥ 0")
            };
            let bottom_km = nonneg("bottom_km", l.bottom_km)?;
            let top_km = ctx.range(
                &key("top_km"),
                l.top_km,
                bottom_km,
                f64::MAX,
                true,
                "above bottom_km",
            )?;
            Ok(ExplicitLayer {
                bottom_km,
                top_km,
                tau_rayleigh: nonneg("tau_rayleigh", l.tau_rayleigh)?,
                rayleigh_depolarization: ctx.range(
                    &key("rayleigh_depolarization"),
                    l.rayleigh_depolarization,
                    0.0,
                    0.5,
                    false,
                    "0 to 0.5",
                )?,
                tau_absorption: nonneg("tau_absorption", l.tau_absorption)?,
                tau_aerosol: nonneg("tau_aerosol", l.tau_aerosol)?,
                aerosol_ssa: ctx.range(
                    &key("aerosol_ssa"),
                    l.aerosol_ssa,
                    0.0,
                    1.0,
                    false,
                    "0 to 1",
                )?,
                aerosol_g: ctx.range(
                    &key("aerosol_g"),
                    l.aerosol_g,
                    -1.0,
                    0.999_999,
                    true,
                    "greater than -1, less than 1",
                )?,
            })
        })
        .collect()
}

fn build_error(ctx: &Ctx, atm: &RawAtmosphere, e: BuildError) -> Error {
    match e {
        BuildError::Wavelength {
            lambda_nm,
            what,
            range_nm: (lo, hi),
        } => ctx.invalid(
            "spectrum.wavelengths_nm",
            lambda_nm,
            &format!("outside the data of {what}"),
            &format!("{lo} to {hi} nm"),
        ),
        BuildError::Visibility { requested_km, max_km } => ctx.invalid(
            "atmosphere.visibility_km",
            requested_km,
            &format!(
                "cannot be reached with aerosol `{}`: the largest reachable visibility is {max_km:.1} km (no boundary-layer aerosol)",
                atm.aerosol.as_deref().unwrap_or("continental_average")
            ),
            &format!("greater than 0 and less than {max_km:.1} km"),
        ),
        BuildError::OzoneColumn => ctx.invalid(
            "atmosphere.ozone_column_du",
            atm.ozone_column_du.unwrap_or(0.0),
            "the profile has no ozone to scale",
            "a profile with ozone",
        ),
        BuildError::Data(message) => Error::data("built-in data", message),
    }
}
