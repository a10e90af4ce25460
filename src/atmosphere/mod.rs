//! The atmosphere as the tracer sees it: layers between altitude levels,
//! each with piecewise-constant optical properties per wavelength.
//!
//! Built either from a gas profile (Rayleigh, ozone absorption, an OPAC
//! aerosol mixture scaled to a visibility: libRadtran's layering, see
//! `profile`, `rayleigh`, `ozone`, `aerosol`) or from explicit layers given
//! as optical depths (the published plane-parallel benchmarks).

pub mod gas_terms;
pub mod layer_shape;
pub mod optics;
pub mod report;
pub mod spectral_terms;

use crate::atmosphere::gas_terms::GasSpec;
use crate::atmosphere::layer_shape::LayerShape;
use crate::atmosphere::optics::{ColumnOptics, Optics};
use crate::atmosphere::spectral_terms::{Part, SpectralTerms, Spectrum};
use crate::error::{Error, Result};
use crate::physics::aerosol::{Aerosol, AerosolPhase};
use crate::physics::constants::{CM_PER_KM, VISIBILITY_WAVELENGTH_NM};
use crate::physics::mie::tables::PhaseTables;
use crate::physics::ozone::{CrossSection, OzoneModel};
use crate::physics::profile::GasProfile;
use crate::physics::rayleigh::{self, RayleighModel};
use crate::physics::visibility::{GroundExtinction, Visibility};
use crate::polarization::tabulated_phase::TabulatedPhaseMatrix;
use std::sync::Arc;

/// One explicit layer of a benchmark atmosphere (wavelength independent).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExplicitLayer {
    pub bottom_km: f64,
    pub top_km: f64,
    pub tau_rayleigh: f64,
    pub rayleigh_depolarization: f64,
    pub tau_absorption: f64,
    pub tau_aerosol: f64,
    pub aerosol_ssa: f64,
    pub aerosol_g: f64,
}

/// The constituents of a profile-based atmosphere.
#[derive(Debug, Clone)]
pub struct ProfileSpec {
    pub profile: GasProfile,
    pub rayleigh: RayleighModel,
    pub ozone: OzoneModel,
    /// Scale the ozone column (0 to top) to this many Dobson units.
    pub ozone_column_du: Option<f64>,
    pub aerosol: Option<Aerosol>,
    /// How the OPAC aerosol scatters (explicit aerosol layers always by
    /// Henyey–Greenstein).
    pub aerosol_phase: AerosolPhase,
    /// Scale the aerosol boundary layer to this ground visibility.
    pub visibility_km: Option<f64>,
    /// Explicit aerosol layers (optical depth, single-scattering albedo,
    /// Henyey–Greenstein g; the same at every wavelength) instead of an OPAC
    /// mixture: uvspec's `aerosol_file tau|ssa|gg`.
    pub aerosol_layers: Option<Vec<AerosolLayer>>,
    /// The wide range's molecular absorbers (none by default).
    pub gases: GasSpec,
}

/// One explicit aerosol layer on a profile atmosphere. A gas layer gets the
/// optical depth of the overlapping part of each aerosol layer (optical
/// depth uniform in altitude inside an aerosol layer); its single-scattering
/// albedo and g are the τ- and τ·ω-weighted means.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AerosolLayer {
    pub bottom_km: f64,
    pub top_km: f64,
    pub tau: f64,
    pub ssa: f64,
    pub g: f64,
}

/// The aerosol coefficients (ext, sca, g) of the slab [z0, z1] from explicit
/// aerosol layers.
fn explicit_aerosol(layers: &[AerosolLayer], z0: f64, z1: f64) -> (f64, f64, f64) {
    let (mut ext, mut sca, mut g_sca) = (0.0, 0.0, 0.0);
    for l in layers {
        let overlap = (z1.min(l.top_km) - z0.max(l.bottom_km)).max(0.0);
        if overlap > 0.0 {
            let tau = l.tau * overlap / (l.top_km - l.bottom_km);
            ext += tau;
            sca += tau * l.ssa;
            g_sca += tau * l.ssa * l.g;
        }
    }
    let dz = z1 - z0;
    let g = if sca > 0.0 { g_sca / sca } else { 0.0 };
    (ext / dz, sca / dz, g)
}

/// What failed while building a profile atmosphere, for the job layer to
/// name the key it came from.
#[derive(Debug, Clone, PartialEq)]
pub enum BuildError {
    /// A wavelength is outside what a constituent's data covers.
    Wavelength {
        lambda_nm: f64,
        what: String,
        range_nm: (f64, f64),
    },
    /// The requested visibility cannot be reached.
    Visibility { requested_km: f64, max_km: f64 },
    /// The ozone column cannot be scaled (no ozone in the profile).
    OzoneColumn,
    /// A built-in table failed to load.
    Data(String),
}

/// Layers with optical properties for each wavelength.
#[derive(Debug, Clone)]
pub struct Atmosphere {
    /// Layer boundaries, ascending; `levels_km[0]` is the ground.
    pub levels_km: Vec<f64>,
    pub wavelengths_nm: Vec<f64>,
    /// `optics[wavelength][layer]`.
    pub optics: Vec<Vec<Optics>>,
    /// Ground visibility at 550 nm, for profile atmospheres with aerosol.
    pub visibility: Option<Visibility>,
    /// Ozone column (DU) between the ground and the top, for profiles.
    pub ozone_column_du: Option<f64>,
    /// How density varies inside each layer, for the `smooth` medium;
    /// `None` for explicit layers (which are homogeneous by definition).
    pub layer_shapes: Option<Vec<LayerShape>>,
    /// The layer optics at any wavelength, as terms (for bands).
    pub terms: SpectralTerms,
    /// Precipitable water (cm) and column-mean CO₂ (ppm) of a profile
    /// with the wide range's gases on.
    pub gas_columns: Option<(f64, f64)>,
}

/// Checks every wavelength against the data of `spec`'s constituents, and
/// returns its ozone cross section.
pub fn check_wavelengths(
    spec: &ProfileSpec,
    wavelengths_nm: &[f64],
) -> std::result::Result<Option<CrossSection>, BuildError> {
    let ozone = CrossSection::builtin(spec.ozone)
        .transpose()
        .map_err(|e| BuildError::Data(e.to_string()))?;
    let check = |lambda_nm: f64, what: &str, (lo, hi): (f64, f64)| {
        if lambda_nm >= lo && lambda_nm <= hi {
            Ok(())
        } else {
            Err(BuildError::Wavelength {
                lambda_nm,
                what: what.to_string(),
                range_nm: (lo, hi),
            })
        }
    };
    for &l in wavelengths_nm {
        if spec.rayleigh == RayleighModel::Bodhaine {
            check(l, "the Bodhaine Rayleigh formula", rayleigh::WAVELENGTH_RANGE_NM)?;
        }
        if spec.gases.any() {
            let names: Vec<&str> = spec.gases.gases.iter().map(|g| g.name()).collect();
            check(
                l,
                &format!("the gas tables ({})", names.join(", ")),
                GasSpec::range_nm(),
            )?;
        }
        if let Some(x) = &ozone {
            // With the wide range's gases on, ozone absorbs nothing past its
            // table (LOWTRAN 7 lists no O₃ band between 1066 and 3070 nm).
            let (lo, hi) = x.range_nm();
            let hi = if spec.gases.any() {
                GasSpec::range_nm().1.max(hi)
            } else {
                hi
            };
            check(l, &format!("the {} ozone cross section", x.name), (lo, hi))?;
        }
        if let Some(a) = &spec.aerosol {
            let (range, comp) = a.range_nm();
            check(l, &format!("OPAC component `{comp}` of `{}`", a.mixture.name), range)?;
        }
    }

    Ok(ozone)
}

/// The terms of a profile atmosphere (see `spectral_terms`): what
/// [`Atmosphere::from_profile`] computes per wavelength, separated.
fn profile_terms(
    profile: &GasProfile,
    spec: &ProfileSpec,
    ozone: Option<Arc<CrossSection>>,
    aerosol: Option<&Aerosol>,
    co2_ratio: f64,
) -> std::result::Result<SpectralTerms, BuildError> {
    let layers = 0..profile.layer_count();
    // Columns are per cm², coefficients per km.
    let per_km = |i: usize| 1.0 / (profile.levels[i + 1].z_km - profile.levels[i].z_km);
    let mut terms = SpectralTerms::default();
    if spec.rayleigh == RayleighModel::Bodhaine {
        let air = layers.clone().map(|i| profile.air_column_cm2(i) * per_km(i)).collect();
        terms.push(air, Spectrum::Air { co2_ratio });
    }
    if let Some(table) = ozone {
        for power in 0..3 {
            let amount = layers
                .clone()
                .map(|i| {
                    let dt = profile.layer_temperature_k(i) - table.t0_k();
                    profile.o3_column_cm2(i) * per_km(i) * dt.powi(power as i32)
                })
                .collect();
            terms.push(
                amount,
                Spectrum::Ozone {
                    table: table.clone(),
                    power,
                },
            );
        }
    }
    if let Some(layers_spec) = &spec.aerosol_layers {
        let per_layer: Vec<(f64, f64, f64)> = layers
            .clone()
            .map(|i| explicit_aerosol(layers_spec, profile.levels[i].z_km, profile.levels[i + 1].z_km))
            .collect();
        terms.push_constant(per_layer.iter().map(|p| p.0).collect(), Part::Extinction);
        terms.push_constant(per_layer.iter().map(|p| p.1).collect(), Part::AerosolScattering);
        terms.push_constant(per_layer.iter().map(|p| p.1 * p.2).collect(), Part::GAerosolScattering);
    } else if let Some(a) = aerosol {
        // One term per (component, humidity index) present.
        let parts: Vec<Vec<(usize, usize, f64)>> = layers
            .clone()
            .map(|i| a.layer_parts(profile, i).unwrap_or_default())
            .collect();
        let mut first_tables = None;
        let mut keys: Vec<(usize, usize)> = parts.iter().flatten().map(|&(c, rh, _)| (c, rh)).collect();
        keys.sort_unstable();
        keys.dedup();
        for (c, rh) in keys {
            let Some(component) = a.component(c) else { continue };
            let amount = parts
                .iter()
                .map(|p| p.iter().filter(|q| q.0 == c && q.1 == rh).map(|q| q.2).sum())
                .collect();
            let phase = match spec.aerosol_phase {
                AerosolPhase::Mie => {
                    let tables = component
                        .phase_tables(rh)
                        .map_err(|e| BuildError::Data(e.to_string()))?;
                    check_phase_tables(&tables, &mut first_tables)?;
                    Some(Arc::new(tables))
                }
                AerosolPhase::HenyeyGreenstein => None,
            };
            let component = Arc::new(component.clone());
            terms.push(amount, Spectrum::Aerosol { component, rh, phase });
        }
    }
    spec.gases
        .push_terms(profile, &mut terms)
        .map_err(|e| BuildError::Data(e.to_string()))?;
    Ok(terms)
}

/// Adds the gas terms' absorption at each wavelength to `optics`.
fn add_gas_absorption(terms: &SpectralTerms, wavelengths_nm: &[f64], optics: &mut [Vec<Optics>]) {
    for (&lambda, per_layer) in wavelengths_nm.iter().zip(optics.iter_mut()) {
        for t in &terms.terms {
            if let Spectrum::Gas { .. } = t.spectrum {
                let k = t.spectrum.response(lambda).ext;
                for (o, a) in per_layer.iter_mut().zip(&t.amount) {
                    o.sigma_absorption += a * k;
                }
            }
        }
    }
}

/// Checks that a component's phase tables make samplers
/// ([`TabulatedPhaseMatrix`]) and share the scattering angles and
/// wavelengths of the first table checked (`first`), as a scene's tables
/// must (it combines the components' tables per layer and wavelength).
fn check_phase_tables(
    tables: &PhaseTables,
    first: &mut Option<(Vec<f64>, Vec<f64>)>,
) -> std::result::Result<(), BuildError> {
    let first = first.get_or_insert_with(|| {
        let angles = tables
            .matrices
            .first()
            .map(|m| m.angles_deg.clone())
            .unwrap_or_default();
        (angles, tables.wavelengths_nm.clone())
    });
    if first.1 != tables.wavelengths_nm {
        return Err(BuildError::Data(format!(
            "the phase tables of {} at RH {} % are not at the other aerosol tables' wavelengths",
            tables.component, tables.rh_pct
        )));
    }
    for (lambda, m) in tables.wavelengths_nm.iter().zip(&tables.matrices) {
        let name = format!("{} at RH {} % and {lambda} nm", tables.component, tables.rh_pct);
        TabulatedPhaseMatrix::from_mie(&name, m).map_err(|e| BuildError::Data(e.to_string()))?;
        if first.0 != m.angles_deg {
            return Err(BuildError::Data(format!(
                "phase table {name} is not on the scattering angles of the other aerosol tables"
            )));
        }
    }
    Ok(())
}

/// The terms of explicit layers: constant responses.
fn constant_terms(layers: &[Optics]) -> SpectralTerms {
    let column = |f: fn(&Optics) -> f64| layers.iter().map(f).collect::<Vec<_>>();
    let mut terms = SpectralTerms::default();
    terms.push_constant(column(Optics::sigma_t), Part::Extinction);
    terms.push_constant(column(|o| o.sigma_rayleigh), Part::Rayleigh);
    terms.push_constant(
        column(|o| o.rayleigh_depolarization * o.sigma_rayleigh),
        Part::RhoRayleigh,
    );
    terms.push_constant(column(|o| o.sigma_aerosol_sca), Part::AerosolScattering);
    terms.push_constant(column(|o| o.aerosol_g * o.sigma_aerosol_sca), Part::GAerosolScattering);
    terms
}

impl Atmosphere {
    /// Builds the layers of a gas profile cut at `top_km`.
    pub fn from_profile(
        spec: &ProfileSpec,
        top_km: f64,
        wavelengths_nm: &[f64],
    ) -> std::result::Result<Atmosphere, BuildError> {
        let mut profile = spec.profile.truncated(top_km);
        let ozone = check_wavelengths(spec, wavelengths_nm)?;

        // Ozone column scaling.
        let ozone_column_du = if spec.ozone == OzoneModel::None {
            None
        } else {
            let du = profile.o3_column_du();
            if let Some(target) = spec.ozone_column_du {
                if du <= 0.0 {
                    return Err(BuildError::OzoneColumn);
                }
                profile.scale_ozone(target / du);
            }
            Some(profile.o3_column_du())
        };
        let gas_columns = if spec.gases.any() {
            Some(
                spec.gases
                    .scale(&mut profile)
                    .map_err(|e| BuildError::Data(e.to_string()))?,
            )
        } else {
            None
        };

        // Visibility scaling of the aerosol boundary layer.
        let mut visibility = None;
        let aerosol = match &spec.aerosol {
            None => None,
            Some(a) => {
                let ground = ground_extinction(&profile, spec.rayleigh, a);
                let unscaled_km = ground.visibility_km(1.0);
                let (scaled, s) = match spec.visibility_km {
                    None => (a.clone(), 1.0),
                    Some(v) => {
                        let s = ground.scale_for(v).ok_or(BuildError::Visibility {
                            requested_km: v,
                            max_km: ground.max_visibility_km(),
                        })?;
                        (a.with_boundary_scale(s), s)
                    }
                };
                visibility = Some(Visibility {
                    ground_km: ground.visibility_km(s),
                    unscaled_km,
                    boundary_scale: s,
                });
                Some(scaled)
            }
        };

        let co2 = profile.surface_co2_ratio();
        let optics: Vec<Vec<Optics>> = wavelengths_nm
            .iter()
            .map(|&lambda| {
                let (sigma_r, rho) = match spec.rayleigh {
                    RayleighModel::Bodhaine => (
                        rayleigh::cross_section_cm2(lambda, co2),
                        rayleigh::depolarization(lambda, co2),
                    ),
                    RayleighModel::None => (0.0, 0.0),
                };
                (0..profile.layer_count())
                    .map(|i| {
                        let dz = profile.levels[i + 1].z_km - profile.levels[i].z_km;
                        // Columns are per cm², coefficients per km.
                        let per_km = 1.0 / dz;
                        let mut o = Optics {
                            sigma_rayleigh: sigma_r * profile.air_column_cm2(i) * per_km,
                            rayleigh_depolarization: rho,
                            ..Optics::default()
                        };
                        if let Some(x) = &ozone {
                            let t = profile.layer_temperature_k(i);
                            // Range was checked above.
                            let s = x.sigma_cm2(lambda, t).unwrap_or(0.0);
                            o.sigma_absorption = s * profile.o3_column_cm2(i) * per_km;
                        }
                        if let Some(a) = &aerosol {
                            let ao = a.layer_optics(&profile, i, lambda).unwrap_or_default();
                            o.sigma_aerosol_ext = ao.sigma_ext;
                            o.sigma_aerosol_sca = ao.sigma_sca;
                            o.aerosol_g = ao.g;
                        }
                        if let Some(layers) = &spec.aerosol_layers {
                            let (z0, z1) = (profile.levels[i].z_km, profile.levels[i + 1].z_km);
                            (o.sigma_aerosol_ext, o.sigma_aerosol_sca, o.aerosol_g) = explicit_aerosol(layers, z0, z1);
                        }
                        o
                    })
                    .collect()
            })
            .collect();

        let terms = profile_terms(&profile, spec, ozone.map(Arc::new), aerosol.as_ref(), co2)?;
        // The gases' absorption at each wavelength (a monochromatic
        // wavelength sees its slot of each band's pseudo-spectrum).
        let mut optics = optics;
        add_gas_absorption(&terms, wavelengths_nm, &mut optics);
        let layer_shapes = profile
            .levels
            .windows(2)
            .map(|w| LayerShape {
                air_ratio: w[1].n_air / w[0].n_air,
                o3_mixing: (w[0].n_o3 / w[0].n_air, w[1].n_o3 / w[1].n_air),
            })
            .collect();
        Ok(Atmosphere {
            levels_km: profile.levels.iter().map(|l| l.z_km).collect(),
            wavelengths_nm: wavelengths_nm.to_vec(),
            optics,
            visibility,
            ozone_column_du,
            layer_shapes: Some(layer_shapes),
            terms,
            gas_columns,
        })
    }

    /// Builds an atmosphere from explicit layers (contiguous, from the
    /// ground up); the same optics at every wavelength.
    pub fn from_layers(layers: &[ExplicitLayer], wavelengths_nm: &[f64]) -> Result<Atmosphere> {
        let mut sorted = layers.to_vec();
        sorted.sort_by(|a, b| a.bottom_km.total_cmp(&b.bottom_km));
        let Some(first) = sorted.first() else {
            return Err(Error::data("atmosphere.layers", "no layers"));
        };
        let mut levels_km = vec![first.bottom_km];
        for l in &sorted {
            let last = levels_km[levels_km.len() - 1];
            if l.bottom_km != last {
                return Err(Error::data(
                    "atmosphere.layers",
                    format!(
                        "layers must be contiguous: a layer ends at {last} km, the next starts at {} km",
                        l.bottom_km
                    ),
                ));
            }
            levels_km.push(l.top_km);
        }
        let per_layer: Vec<Optics> = sorted
            .iter()
            .map(|l| {
                let dz = l.top_km - l.bottom_km;
                Optics {
                    sigma_rayleigh: l.tau_rayleigh / dz,
                    rayleigh_depolarization: l.rayleigh_depolarization,
                    sigma_absorption: l.tau_absorption / dz,
                    sigma_aerosol_ext: l.tau_aerosol / dz,
                    sigma_aerosol_sca: l.tau_aerosol * l.aerosol_ssa / dz,
                    aerosol_g: l.aerosol_g,
                }
            })
            .collect();
        Ok(Atmosphere {
            levels_km,
            wavelengths_nm: wavelengths_nm.to_vec(),
            terms: constant_terms(&per_layer),
            optics: vec![per_layer; wavelengths_nm.len()],
            visibility: None,
            ozone_column_du: None,
            layer_shapes: None,
            gas_columns: None,
        })
    }

    /// Number of layers.
    pub fn layer_count(&self) -> usize {
        self.levels_km.len() - 1
    }

    /// Top of the atmosphere (km).
    pub fn top_km(&self) -> f64 {
        self.levels_km[self.levels_km.len() - 1]
    }

    /// Thickness of layer `i` (km).
    pub fn thickness_km(&self, i: usize) -> f64 {
        self.levels_km[i + 1] - self.levels_km[i]
    }

    /// The direct transmittance of the vertical column at cos(zenith) `mu`
    /// in plane-parallel geometry, e^(−τ(λ)/μ), averaged over [lo, hi] nm
    /// on cells of at most 0.05 nm (two per slot of the gases'
    /// pseudo-spectra, so exact for them), τ(λ) from the terms.
    pub fn band_transmittance(&self, lo_nm: f64, hi_nm: f64, mu: f64) -> f64 {
        let terms = &self.terms.terms;
        let columns: Vec<f64> = terms
            .iter()
            .map(|t| t.amount.iter().enumerate().map(|(i, a)| a * self.thickness_km(i)).sum())
            .collect();
        let cells = ((hi_nm - lo_nm) * 20.0).ceil().max(1.0) as usize;
        let mut responses = vec![spectral_terms::TermOptics::default(); terms.len()];
        let sum: f64 = (0..cells)
            .map(|k| {
                let lambda = lo_nm + (hi_nm - lo_nm) * (k as f64 + 0.5) / cells as f64;
                self.terms.responses_into(lambda, &mut responses);
                let tau: f64 = responses.iter().zip(&columns).map(|(r, c)| r.ext * c).sum();
                (-tau.max(0.0) / mu).exp()
            })
            .sum();
        sum / cells as f64
    }

    /// Column optical depths at wavelength index `w`.
    pub fn column(&self, w: usize) -> ColumnOptics {
        let mut c = ColumnOptics::default();
        for (i, o) in self.optics[w].iter().enumerate() {
            let dz = self.thickness_km(i);
            c.tau_rayleigh += o.sigma_rayleigh * dz;
            c.tau_absorption += o.sigma_absorption * dz;
            c.tau_aerosol_ext += o.sigma_aerosol_ext * dz;
            c.tau_aerosol_sca += o.sigma_aerosol_sca * dz;
        }
        c
    }
}

/// Ground extinction at 550 nm split into Rayleigh, free-tropospheric and
/// boundary-layer aerosol. "At the ground": Rayleigh from the air density of
/// the lowest level, aerosol of the lowest layer.
fn ground_extinction(profile: &GasProfile, model: RayleighModel, aerosol: &Aerosol) -> GroundExtinction {
    let lambda = VISIBILITY_WAVELENGTH_NM;
    let rayleigh = match model {
        RayleighModel::Bodhaine => {
            rayleigh::cross_section_cm2(lambda, profile.surface_co2_ratio()) * profile.levels[0].n_air * CM_PER_KM
        }
        RayleighModel::None => 0.0,
    };
    let total = aerosol.layer_optics(profile, 0, lambda).unwrap_or_default().sigma_ext;
    let boundary = aerosol
        .boundary_layer_only()
        .layer_optics(profile, 0, lambda)
        .unwrap_or_default()
        .sigma_ext;
    GroundExtinction {
        rayleigh,
        aerosol_free: total - boundary,
        aerosol_boundary: boundary,
    }
}
