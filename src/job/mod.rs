//! Job files: the raw TOML schema (serde, unknown keys refused) and the
//! resolved, validated job with tables loaded and the atmosphere built.
//!
//! Every error names the file and the key, with the value and the valid
//! range; TOML syntax and schema errors carry TOML's line and column.
//!
//! The job knows nothing of how it is rendered: the transport builds its
//! scenes from a job (`transport::scene_build`), and the resolved
//! transport options it holds (`options`) are plain values.

use std::path::Path;
use std::sync::Arc;

use crate::atmosphere::{Atmosphere, check_wavelengths};
use crate::error::{Error, Result};
use crate::geometry::shell::Geometry;
use crate::geometry::sun::Sun;
use crate::job::options::TrackingLayers;
use crate::job::spectrum::Channel;
use crate::job::transmittance::TransmittanceSpec;
use crate::physics::aerosol::AerosolPhase;
use crate::physics::ozone::OzoneModel;
use crate::physics::rayleigh::RayleighModel;
use crate::physics::solar::SolarSpectrum;
use atmosphere::{build_error, resolve_layers, resolve_profile_spec};
use context::Ctx;
use raw::RawJob;
use spectrum::{band_error, band_widths};

/// Default planet radius (km): the sky model's (libRadtran uses 6370).
pub const DEFAULT_RADIUS_KM: f64 = 6378.0;
/// Default top of the atmosphere (km).
pub const DEFAULT_TOP_KM: f64 = 100.0;
/// Default wavelengths (nm): the seed's validation wavelengths.
pub const DEFAULT_WAVELENGTHS_NM: [f64; 3] = [420.0, 540.0, 620.0];

mod atmosphere;
mod context;
pub mod input;
pub mod options;
mod raw;
mod render;
pub mod spectrum;
pub mod transmittance;

pub use raw::GeometryKind;
pub use render::{NoiseTarget, RadianceUnits, RenderSpec, Sensor, TargetAlbedos, TargetScope};

// Resolved job

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
        /// How the OPAC aerosol scatters.
        aerosol_phase: AerosolPhase,
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
    /// Full width of each channel's band, centred on its wavelength (0: one
    /// wavelength).
    pub band_widths_nm: Vec<f64>,
    pub source: AtmosphereSource,
    /// The atmosphere of the first task.
    pub atmosphere: Atmosphere,
    /// The job's grid: visibility × sun zenith × observer altitude, in that order.
    pub tasks: Vec<Task>,
    pub render: RenderSpec,
    pub transmittance: TransmittanceSpec,
    /// The extraterrestrial irradiance of absolute units (`None` for
    /// normalised ones).
    pub solar: Option<Arc<SolarSpectrum>>,
    /// FNV-1a hash of the job text (hex), identifying the job in outputs.
    pub hash: String,
    /// The job text and the directory its relative paths resolve from:
    /// shard and checkpoint files carry them, so `merge` can rebuild the job.
    pub text: String,
    pub dir: std::path::PathBuf,
}

/// One point of the job's grid.
#[derive(Debug, Clone)]
pub struct Task {
    /// Position in the job's task list (from 0).
    pub index: usize,
    /// Stable readable name, e.g. `vis059.4_elev+05.0_alt01000m`.
    pub name: String,
    /// The requested visibility, if any.
    pub visibility_km: Option<f64>,
    pub sun: Sun,
    pub observer_altitude_km: f64,
    pub atmosphere: Atmosphere,
}

impl Task {
    /// Whether the observer stands on the ground (at its lowest level):
    /// then every direction below the horizon sees the same radiance, the
    /// ground's right at the eye.
    pub fn observer_on_ground(&self) -> bool {
        self.observer_altitude_km <= self.atmosphere.levels_km[0]
    }
}

/// `vis059.4_elev+05.0_alt01000m`: the requested visibility, else the
/// atmosphere's own ground visibility (`novis` without aerosol), the sun's
/// elevation in degrees and the observer altitude in metres.
fn task_name(visibility_km: Option<f64>, atmosphere: &Atmosphere, sun_zenith_deg: f64, altitude_km: f64) -> String {
    let vis = match visibility_km.or(atmosphere.visibility.map(|v| v.ground_km)) {
        Some(v) => format!("vis{v:05.1}"),
        None => "novis".to_string(),
    };
    format!(
        "{vis}_elev{:+05.1}_alt{:05.0}m",
        90.0 - sun_zenith_deg,
        altitude_km * 1000.0
    )
}

impl Job {
    /// The planet's geometry for the tracer.
    pub fn geometry(&self) -> Geometry {
        match self.planet.geometry {
            GeometryKind::Spherical => Geometry::Spherical {
                radius_km: self.planet.radius_km,
            },
            GeometryKind::PlaneParallel | GeometryKind::PseudoSpherical => Geometry::PlaneParallel,
        }
    }

    /// Whether paths are traced between horizontally infinite slabs
    /// (plane-parallel and pseudo-spherical geometry).
    pub fn plane_parallel_transport(&self) -> bool {
        self.planet.geometry != GeometryKind::Spherical
    }

    /// The planet radius for the direct beam's spherical path in
    /// pseudo-spherical geometry, `None` otherwise.
    pub fn pseudo_spherical_radius_km(&self) -> Option<f64> {
        (self.planet.geometry == GeometryKind::PseudoSpherical).then_some(self.planet.radius_km)
    }

    /// The tasks of the transmittance tables: one per visibility and
    /// observer altitude (the sun does not matter), named like
    /// `vis059.4_alt01000m`.
    pub fn transmittance_tasks(&self) -> Vec<(&Task, String)> {
        let first_sun = self.render.sun_zeniths_deg[0];
        self.tasks
            .iter()
            .filter(|t| t.sun.zenith_deg == first_sun)
            .map(|t| {
                let vis = t.name.split('_').next().unwrap_or_default();
                (t, format!("{vis}_alt{:05.0}m", t.observer_altitude_km * 1000.0))
            })
            .collect()
    }

    /// Whether any channel is a band.
    pub fn banded(&self) -> bool {
        self.band_widths_nm.iter().any(|&w| w > 0.0)
    }

    /// The job's channels.
    pub fn channels(&self) -> Vec<Channel> {
        self.wavelengths_nm
            .iter()
            .zip(&self.band_widths_nm)
            .map(|(&lambda_nm, &band_width_nm)| Channel {
                lambda_nm,
                band_width_nm,
            })
            .collect()
    }

    /// Whether the tracer itself weights each path by E0 at the
    /// wavelengths it drew: bands in absolute units (the band average of
    /// E0·L is not the product of the averages).
    pub fn tracer_weights_by_solar(&self) -> bool {
        self.solar.is_some() && self.banded()
    }

    /// The factor from the tracer's radiance at `lambda_nm` to the output
    /// units: E0(λ) for absolute units, unless the tracer weighted by it
    /// already; 1 for normalised units.
    pub fn unit_scale(&self, lambda_nm: f64) -> f64 {
        match &self.solar {
            Some(solar) if !self.tracer_weights_by_solar() => solar.irradiance(lambda_nm).unwrap_or(0.0),
            _ => 1.0,
        }
    }

    /// Checks that absolute units have the irradiance at every channel's
    /// wavelengths (band edges included).
    fn check_solar_range(&self, ctx: &Ctx) -> Result<()> {
        let Some(solar) = &self.solar else { return Ok(()) };
        let (lo, hi) = solar.range_nm();
        for (&l, &w) in self.wavelengths_nm.iter().zip(&self.band_widths_nm) {
            let (a, b) = (l - 0.5 * w, l + 0.5 * w);
            if a < lo || b > hi {
                let (key, value, what) = if w > 0.0 {
                    (
                        "spectrum.band_width_nm",
                        w.to_string(),
                        format!("the band {a} to {b} nm leaves"),
                    )
                } else {
                    ("spectrum.wavelengths_nm", l.to_string(), format!("{l} nm lies outside"))
                };
                return Err(ctx.invalid(
                    key,
                    value,
                    &format!(
                        "output.units = \"absolute\" weights by the Kurucz extraterrestrial irradiance, and {what} its table"
                    ),
                    &format!("channels inside {lo} to {hi} nm, or output.units = \"normalized\""),
                ));
            }
        }
        Ok(())
    }

    /// Checks that a job with bands can render them: bands need shared
    /// paths, and their outputs are band averages of radiance only.
    fn check_bands(&self, ctx: &Ctx) -> Result<()> {
        if !self.banded() {
            return Ok(());
        }
        let why = "spectrum.band_width_nm > 0 renders bands along shared spectral paths";
        let r = &self.render;
        if !r.shared_wavelengths {
            return Err(ctx.invalid(
                "render.shared_wavelengths",
                "false",
                &format!("{why}; bands without shared paths are not available"),
                "leave it out (the default with bands)",
            ));
        }
        Ok(())
    }

    /// The built-in default job: US-standard atmosphere, Bogumil ozone,
    /// OPAC continental_average (unscaled, ≈ 59 km visibility), 420, 540
    /// and 620 nm, spherical planet of 6378 km with a 100 km top.
    pub fn builtin_default() -> Result<Job> {
        Self::parse("", "<built-in default>", Path::new("."))
    }

    /// Reads and resolves a job file.
    pub fn from_file(path: &Path) -> Result<Job> {
        let text = crate::job::input::read_text(path)?;
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

        let (wavelengths_raw, band_raw) = match raw.spectrum {
            Some(s) => (s.wavelengths_nm, s.band_width_nm),
            None => (None, None),
        };
        let wavelengths_nm = match wavelengths_raw {
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

        let band_widths_nm = band_widths(&ctx, &wavelengths_nm, band_raw)?;
        let band_edges_nm: Vec<f64> = wavelengths_nm
            .iter()
            .zip(&band_widths_nm)
            .filter(|(_, w)| **w > 0.0)
            .flat_map(|(l, w)| [l - 0.5 * w, l + 0.5 * w])
            .collect();

        let (source, atmospheres, top_km) = if let Some(layers) = &atm.layers {
            let given: Vec<&str> = [
                ("profile", atm.profile.is_some()),
                ("profile_file", atm.profile_file.is_some()),
                ("ozone", atm.ozone.is_some()),
                ("ozone_column_du", atm.ozone_column_du.is_some()),
                ("rayleigh", atm.rayleigh.is_some()),
                ("aerosol", atm.aerosol.is_some()),
                ("visibility_km", atm.visibility_km.is_some()),
                ("aerosol_layers", atm.aerosol_layers.is_some()),
                ("gases", atm.gases.is_some()),
                ("precipitable_water_cm", atm.precipitable_water_cm.is_some()),
                ("co2_ppm", atm.co2_ppm.is_some()),
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
            (AtmosphereSource::Layers, vec![(None, atmosphere)], top)
        } else {
            let (mut spec, name, visibilities) = resolve_profile_spec(&ctx, &atm, dir)?;
            let profile_top = spec.profile.top_km();
            let top_km = ctx.range(
                "planet.top_km",
                planet_raw.top_km.unwrap_or(DEFAULT_TOP_KM.min(profile_top)),
                spec.profile.ground_km(),
                profile_top,
                true,
                &format!("above the ground, at most the profile's top, {profile_top} km"),
            )?;
            if spec.gases.any() {
                if let Some(w) = band_widths_nm.iter().position(|&w| w == 0.0) {
                    return Err(ctx.invalid(
                        "spectrum.band_width_nm",
                        0,
                        &format!(
                            "the channel at {} nm is one wavelength, but atmosphere.gases absorb by k-distributions of 40 nm bands, which describe a band, not a wavelength",
                            wavelengths_nm[w]
                        ),
                        "a band width for every channel (40 nm: the gases' own bands, from 280 nm)",
                    ));
                }
                let lo = band_edges_nm.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = band_edges_nm.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                spec.gases.range_nm = (lo, hi);
            }
            check_wavelengths(&spec, &band_edges_nm)
                .map_err(|e| band_error(&ctx, &wavelengths_nm, &band_widths_nm, e))?;
            let mut atmospheres = Vec::with_capacity(visibilities.len());
            for v in visibilities {
                spec.visibility_km = v;
                let atmosphere =
                    Atmosphere::from_profile(&spec, top_km, &wavelengths_nm).map_err(|e| build_error(&ctx, &atm, e))?;
                atmospheres.push((v, atmosphere));
            }
            let source = AtmosphereSource::Profile {
                profile: name,
                ozone: spec.ozone,
                rayleigh: spec.rayleigh,
                aerosol: spec.aerosol.as_ref().map(|a| a.mixture.name.clone()),
                aerosol_phase: spec.aerosol_phase,
            };
            (source, atmospheres, top_km)
        };

        let altitudes = match raw.observer.and_then(|o| o.altitude_km) {
            None => vec![0.0],
            Some(list) => list.values(),
        };
        if altitudes.is_empty() {
            return Err(ctx.invalid(
                "observer.altitude_km",
                "[]",
                "empty list",
                "a number or a non-empty list of km",
            ));
        }
        let ground = atmospheres[0].1.levels_km[0];
        for &h in &altitudes {
            if !h.is_finite() || h < ground || h > top_km {
                return Err(ctx.invalid(
                    "observer.altitude_km",
                    h,
                    if h > top_km {
                        "the observer is above the top of the atmosphere"
                    } else if h.is_finite() {
                        "out of range"
                    } else {
                        "not a finite number"
                    },
                    &format!("from the ground ({ground} km) to planet.top_km ({top_km} km)"),
                ));
            }
        }
        let render = render::resolve(&ctx, raw.sun, raw.ground, raw.sensor, raw.render, raw.output)?;
        if render.settings.tracking_layers == TrackingLayers::Merged && geometry != GeometryKind::Spherical {
            return Err(ctx.invalid(
                "render.tracking_layers",
                "merged",
                "merged layers are tracked through spherical shells only",
                "\"auto\" or \"profile\" with planet.geometry other than \"spherical\"",
            ));
        }
        let mut tasks = Vec::with_capacity(atmospheres.len() * render.sun_zeniths_deg.len() * altitudes.len());
        for (v, atmosphere) in &atmospheres {
            for &z in &render.sun_zeniths_deg {
                for &h in &altitudes {
                    tasks.push(Task {
                        index: tasks.len(),
                        name: task_name(*v, atmosphere, z, h),
                        visibility_km: *v,
                        sun: Sun::new(z, render.sun_angular_radius_deg),
                        observer_altitude_km: h,
                        atmosphere: atmosphere.clone(),
                    });
                }
            }
        }
        let atmosphere = tasks[0].atmosphere.clone();
        let observer_altitude_km = tasks[0].observer_altitude_km;

        let solar = match render.units {
            RadianceUnits::Absolute => Some(Arc::new(SolarSpectrum::kurucz()?)),
            RadianceUnits::Normalized => None,
        };
        let transmittance = transmittance::resolve(
            &ctx,
            raw.transmittance,
            top_km,
            (geometry == GeometryKind::Spherical).then_some(radius_km),
            band_widths_nm.iter().any(|&w| w > 0.0),
        )?;

        let job = Job {
            file: file.to_string(),
            planet: Planet {
                radius_km,
                top_km,
                geometry,
            },
            observer_altitude_km,
            wavelengths_nm,
            band_widths_nm,
            source,
            atmosphere,
            tasks,
            render,
            transmittance,
            solar,
            hash: format!("{:016x}", crate::fnv::bytes(text.as_bytes())),
            text: text.to_string(),
            dir: dir.to_path_buf(),
        };
        job.check_bands(&ctx)?;
        job.check_solar_range(&ctx)?;
        Ok(job)
    }
}
