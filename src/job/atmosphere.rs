//! Resolving the `[atmosphere]` section: a gas profile with its
//! constituents, or explicit layers.

use std::path::Path;

use super::context::Ctx;
use super::raw::{RawAerosolLayer, RawAerosolPhase, RawAtmosphere, RawGases, RawLayer, RawOzone, RawRayleigh};
use crate::atmosphere::gas_terms::GasSpec;
use crate::atmosphere::{AerosolLayer, BuildError, ExplicitLayer, ProfileSpec};
use crate::error::{Error, Result};
use crate::physics::aerosol::{Aerosol, AerosolPhase};
use crate::physics::data;
use crate::physics::kdistribution::Gas;
use crate::physics::ozone::OzoneModel;
use crate::physics::profile::GasProfile;
use crate::physics::rayleigh::RayleighModel;

/// The profile spec (without visibility) and the requested visibilities
/// (`[None]` when not given).
pub(super) fn resolve_profile_spec(
    ctx: &Ctx,
    atm: &RawAtmosphere,
    dir: &Path,
) -> Result<(ProfileSpec, String, Vec<Option<f64>>)> {
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
        Some(du) => Some(ctx.range("atmosphere.ozone_column_du", du, 0.0, 2000.0, false, "0 to 2000 DU")?),
    };
    let aerosol_layers = match &atm.aerosol_layers {
        None => None,
        Some(_) if atm.aerosol.as_deref().is_some_and(|a| a != "none") => {
            return Err(ctx.invalid(
                "atmosphere.aerosol_layers",
                "(given)",
                "cannot be combined with an aerosol mixture (atmosphere.aerosol)",
                "either [[atmosphere.aerosol_layers]] or atmosphere.aerosol",
            ));
        }
        Some(layers) => Some(resolve_aerosol_layers(ctx, layers)?),
    };
    let aerosol_name = match (&atm.aerosol, &aerosol_layers) {
        (Some(name), _) => name.as_str(),
        (None, Some(_)) => "none",
        (None, None) => "continental_average",
    };
    let aerosol = if aerosol_name == "none" {
        None
    } else {
        let a = Aerosol::builtin(aerosol_name).ok_or_else(|| {
            ctx.invalid(
                "atmosphere.aerosol",
                format!("\"{aerosol_name}\""),
                "unknown aerosol mixture",
                &format!("\"none\" or an OPAC mixture: {}", data::names(data::OPAC_MIXTURES)),
            )
        })?;
        Some(a.map_err(|e| {
            ctx.invalid(
                "atmosphere.aerosol",
                format!("\"{aerosol_name}\""),
                &e.to_string(),
                "an OPAC mixture of spherical particles (every one but desert_spheroids), or \"none\"",
            )
        })?)
    };
    let aerosol_phase = match atm.aerosol_phase {
        None | Some(RawAerosolPhase::Mie) if aerosol.is_some() => AerosolPhase::Mie,
        None => AerosolPhase::HenyeyGreenstein,
        Some(RawAerosolPhase::Hg) => AerosolPhase::HenyeyGreenstein,
        Some(RawAerosolPhase::Mie) => {
            return Err(ctx.invalid(
                "atmosphere.aerosol_phase",
                "\"mie\"",
                "needs an OPAC aerosol mixture (atmosphere.aerosol): explicit aerosol layers and \"none\" have no Mie tables",
                "\"hg\", or leave it out",
            ));
        }
    };
    let visibilities = match &atm.visibility_km {
        None => vec![None],
        Some(_) if aerosol.is_none() => {
            return Err(ctx.invalid(
                "atmosphere.visibility_km",
                "(given)",
                "scales an OPAC aerosol mixture, but there is none (atmosphere.aerosol = \"none\" or aerosol_layers)",
                "leave it out, or name an aerosol mixture",
            ));
        }
        Some(list) => {
            let values = list.values();
            if values.is_empty() {
                return Err(ctx.invalid(
                    "atmosphere.visibility_km",
                    "[]",
                    "empty list",
                    "a number or a non-empty list of km",
                ));
            }
            values
                .into_iter()
                .map(|v| {
                    ctx.range(
                        "atmosphere.visibility_km",
                        v,
                        0.0,
                        f64::MAX,
                        true,
                        "a positive number of km",
                    )
                    .map(Some)
                })
                .collect::<Result<Vec<_>>>()?
        }
    };
    Ok((
        ProfileSpec {
            profile,
            rayleigh,
            ozone,
            ozone_column_du,
            aerosol,
            aerosol_phase,
            visibility_km: None,
            aerosol_layers,
            gases: resolve_gases(ctx, atm)?,
        },
        name,
        visibilities,
    ))
}

/// The wide range's gases (`atmosphere.gases`, none by default) and their
/// column scalings.
fn resolve_gases(ctx: &Ctx, atm: &RawAtmosphere) -> Result<GasSpec> {
    const KEY: &str = "atmosphere.gases";
    let valid = || {
        format!(
            "\"all\", \"none\" or a list of: {}",
            Gas::ALL
                .iter()
                .map(|g| format!("\"{}\"", g.name()))
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    let gases = match &atm.gases {
        None => Vec::new(),
        Some(RawGases::One(s)) if s == "none" => Vec::new(),
        Some(RawGases::One(s)) if s == "all" => Gas::ALL.to_vec(),
        Some(RawGases::One(s)) => return Err(ctx.invalid(KEY, format!("\"{s}\""), "unknown value", &valid())),
        Some(RawGases::Many(list)) => {
            let mut out = Vec::new();
            for s in list {
                let g = Gas::parse(s).ok_or_else(|| ctx.invalid(KEY, format!("\"{s}\""), "unknown gas", &valid()))?;
                if out.contains(&g) {
                    return Err(ctx.invalid(KEY, format!("\"{s}\""), "listed twice", "each gas once"));
                }
                out.push(g);
            }
            out.sort();
            out
        }
    };
    let needs = |key: &str, gas: Gas| {
        ctx.invalid(
            key,
            "(given)",
            &format!(
                "scales the {} column, but atmosphere.gases does not include \"{}\"",
                gas.name(),
                gas.name()
            ),
            &format!(
                "leave it out, or add \"{}\" to atmosphere.gases (or gases = \"all\")",
                gas.name()
            ),
        )
    };
    let precipitable_water_cm = match atm.precipitable_water_cm {
        None => None,
        Some(_) if !gases.contains(&Gas::H2o) => return Err(needs("atmosphere.precipitable_water_cm", Gas::H2o)),
        Some(v) => Some(ctx.range("atmosphere.precipitable_water_cm", v, 0.0, 10.0, false, "0 to 10 cm")?),
    };
    let co2_ppm = match atm.co2_ppm {
        None => None,
        Some(_) if !gases.contains(&Gas::Co2) => return Err(needs("atmosphere.co2_ppm", Gas::Co2)),
        Some(v) => Some(ctx.range("atmosphere.co2_ppm", v, 0.0, 10000.0, false, "0 to 10000 ppm")?),
    };
    Ok(GasSpec {
        gases,
        precipitable_water_cm,
        co2_ppm,
        range_nm: (0.0, 0.0),
    })
}

/// Explicit aerosol layers: non-overlapping intervals, τ ≥ 0, ω in [0, 1],
/// g in (−1, 1).
fn resolve_aerosol_layers(ctx: &Ctx, raw: &[RawAerosolLayer]) -> Result<Vec<AerosolLayer>> {
    let mut layers = raw
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let key = |k: &str| format!("atmosphere.aerosol_layers[{i}].{k}");
            let bottom_km = ctx.range(
                &key("bottom_km"),
                l.bottom_km,
                0.0,
                f64::MAX,
                false,
                "a finite number ≥ 0",
            )?;
            Ok(AerosolLayer {
                bottom_km,
                top_km: ctx.range(&key("top_km"), l.top_km, bottom_km, f64::MAX, true, "above bottom_km")?,
                tau: ctx.range(&key("tau"), l.tau, 0.0, f64::MAX, false, "a finite number ≥ 0")?,
                ssa: ctx.range(&key("ssa"), l.ssa, 0.0, 1.0, false, "0 to 1")?,
                g: ctx.range(&key("g"), l.g, -1.0, 0.999_999, true, "greater than -1, less than 1")?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    layers.sort_by(|a, b| a.bottom_km.total_cmp(&b.bottom_km));
    if let Some(w) = layers.windows(2).find(|w| w[1].bottom_km < w[0].top_km) {
        return Err(ctx.invalid(
            "atmosphere.aerosol_layers",
            format!(
                "[{}, {}] km and [{}, {}] km",
                w[0].bottom_km, w[0].top_km, w[1].bottom_km, w[1].top_km
            ),
            "layers overlap",
            "non-overlapping altitude intervals",
        ));
    }
    Ok(layers)
}

pub(super) fn resolve_layers(ctx: &Ctx, raw: &[RawLayer]) -> Result<Vec<ExplicitLayer>> {
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
            let nonneg = |k: &str, v: f64| ctx.range(&key(k), v, 0.0, f64::MAX, false, "a finite number ≥ 0");
            let bottom_km = nonneg("bottom_km", l.bottom_km)?;
            let top_km = ctx.range(&key("top_km"), l.top_km, bottom_km, f64::MAX, true, "above bottom_km")?;
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
                aerosol_ssa: ctx.range(&key("aerosol_ssa"), l.aerosol_ssa, 0.0, 1.0, false, "0 to 1")?,
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

pub(super) fn build_error(ctx: &Ctx, atm: &RawAtmosphere, e: BuildError) -> Error {
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
