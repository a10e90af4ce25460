//! The dataset file of the Prague sky model's public runtime
//! (`PragueSkyModel.cpp`; Vévoda, Bashford-Rogers, Kolářová and Wilkie,
//! 2022), written and read field by field.
//!
//! The layout (little-endian `i32`, `f64`, `f32` and IEEE binary16 "half";
//! no magic number):
//!
//! ```text
//! radiance       i32 nVis, f64 visibilities[nVis] (km); i32 nAlb, f64 albedos[nAlb];
//!                i32 nAlt, f64 altitudes[nAlt] (m); i32 nElev, f64 elevations[nElev] (deg);
//!                i32 channels, f64 channelStart, f64 channelWidth (nm); i32 rank;
//!                i32 nSun, f64 sunBreaks[nSun]; i32 nZen, f64 zenithBreaks[nZen];
//!                i32 nEmph, f64 emphBreaks[nEmph] (rad);
//!                per configuration (visibility outermost, then albedo, altitude,
//!                elevation, channel innermost):
//!                  rank × (half sun[nSun], f64 zenithScale, half zenith[nZen]), half emph[nEmph]
//! transmittance  i32 dDim, aDim, nVisT, nAltT, rankT; f32 altitudes[nAltT] (m);
//!                f32 visibilities[nVisT] (km); f32 U[nAltT][dDim][aDim][rankT];
//!                f32 V[nVisT][nAltT][channels][rankT]
//! polarisation   (optional) i32 rankP; i32 nSunP, f64 sunBreaks[nSunP];
//!                i32 nZenP, f64 zenithBreaks[nZenP];
//!                per configuration: rankP × (f32 sun[nSunP], f32 zenith[nZenP])
//! ```
//!
//! A [`Dataset`] is what the runtime holds once it has read a file: the
//! coefficients as `f32`, decoded the runtime's way (a zenith value is
//! `f32(half / zenithScale)`), the axes as `f64`. Reading is stricter than
//! the runtime, which trusts its file: every count, axis and break list is
//! checked, a count whose values cannot fit in the bytes left is refused
//! before anything is allocated, and truncation or bytes after the last
//! part are errors naming the field and its byte offset.
//!
//! Writing starts from fitted `f64` values ([`DatasetFit`]):
//! [`Dataset::encode`] rounds them to the file's precisions (to nearest,
//! ties to even) and decodes them back, so that the `Dataset` it returns is
//! the one a reader of its bytes gets; [`Dataset::to_bytes`] and
//! [`Dataset::from_bytes`] round-trip it exactly.

use std::f64::consts::PI;
use std::fmt;
use std::path::Path;

use half::f16;

use crate::error::{Error, Result};

/// How far (rad) a break may stray outside [0, π] by rounding.
const BREAK_TOLERANCE: f64 = 1e-6;

/// Below this largest |value| a zenith component is written with scale 1
/// (its values are then half zeros): a larger scale would decode to `f32`
/// subnormals that cannot be stored again exactly.
const SMALLEST_SCALED_ZENITH: f64 = 1.0 / (1u128 << 102) as f64;

/// The configuration axes: one fitted configuration per (visibility,
/// albedo, altitude, elevation, channel), visibility outermost.
#[derive(Debug, Clone, PartialEq)]
pub struct Axes {
    pub visibilities_km: Vec<f64>,
    pub albedos: Vec<f64>,
    pub altitudes_m: Vec<f64>,
    pub elevations_deg: Vec<f64>,
    /// `channels` channels `channel_width_nm` wide from `channel_start_nm`.
    pub channels: usize,
    pub channel_start_nm: f64,
    pub channel_width_nm: f64,
}

impl Axes {
    /// The number of configurations.
    pub fn configurations(&self) -> usize {
        let [v, a, h, e] = [
            &self.visibilities_km,
            &self.albedos,
            &self.altitudes_m,
            &self.elevations_deg,
        ]
        .map(Vec::len);
        v * a * h * e * self.channels
    }

    /// The index of a configuration in file (and memory) order, from its
    /// indices [visibility, albedo, altitude, elevation, channel].
    pub fn configuration(&self, [v, a, h, e, c]: [usize; 5]) -> usize {
        (((v * self.albedos.len() + a) * self.altitudes_m.len() + h) * self.elevations_deg.len() + e) * self.channels
            + c
    }

    /// "configuration 5 (visibility 0, albedo 1, altitude 0, elevation 1,
    /// channel 0)", for errors.
    pub fn describe(&self, configuration: usize) -> String {
        let sizes = [&self.albedos, &self.altitudes_m, &self.elevations_deg].map(Vec::len);
        let c = configuration % self.channels.max(1);
        let mut rest = configuration / self.channels.max(1);
        let mut index = [0; 3];
        for k in (0..3).rev() {
            index[k] = rest % sizes[k].max(1);
            rest /= sizes[k].max(1);
        }
        let [a, h, e] = index;
        format!(
            "configuration {configuration} (visibility {rest}, albedo {a}, altitude {h}, elevation {e}, channel {c})"
        )
    }

    /// The end of the last channel (nm).
    pub fn channel_end_nm(&self) -> f64 {
        self.channel_start_nm + self.channels as f64 * self.channel_width_nm
    }
}

/// The sky-radiance tables. Per configuration, as the runtime lays them
/// out in memory: `rank` × (values at the sun breaks, then at the zenith
/// breaks), then values at the emphasis breaks.
#[derive(Debug, Clone, PartialEq)]
pub struct Radiance {
    pub rank: usize,
    /// Breaks (rad) of γ, of α and of θ′.
    pub sun_breaks: Vec<f64>,
    pub zenith_breaks: Vec<f64>,
    pub emph_breaks: Vec<f64>,
    /// The file's zenithScale per configuration and rank component, kept so
    /// that the file is written again bit for bit.
    pub zenith_scales: Vec<f64>,
    pub coefs: Vec<f32>,
}

impl Radiance {
    /// Values per rank component: sun then zenith.
    pub fn component_len(&self) -> usize {
        self.sun_breaks.len() + self.zenith_breaks.len()
    }

    /// Values per configuration.
    pub fn config_len(&self) -> usize {
        self.rank * self.component_len() + self.emph_breaks.len()
    }
}

/// The transmittance tables: √T at node (distance d, altitude a) for
/// observer altitude `alt`, visibility `vis` and a channel is
/// `Σ_r U[alt][d][a][r] · V[vis][alt][channel][r]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Transmittance<T = f32> {
    pub d_dim: usize,
    pub a_dim: usize,
    /// Observer altitudes (m) and visibilities (km), `f32` in the file.
    pub altitudes_m: Vec<f64>,
    pub visibilities_km: Vec<f64>,
    pub rank: usize,
    pub u: Vec<T>,
    pub v: Vec<T>,
}

/// The polarisation tables: per configuration `rank` × (values at the sun
/// breaks, then at the zenith breaks).
#[derive(Debug, Clone, PartialEq)]
pub struct Polarisation {
    pub rank: usize,
    pub sun_breaks: Vec<f64>,
    pub zenith_breaks: Vec<f64>,
    pub coefs: Vec<f32>,
}

impl Polarisation {
    /// Values per rank component: sun then zenith.
    pub fn component_len(&self) -> usize {
        self.sun_breaks.len() + self.zenith_breaks.len()
    }

    /// Values per configuration.
    pub fn config_len(&self) -> usize {
        self.rank * self.component_len()
    }
}

/// A dataset as the runtime holds it after reading.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    pub axes: Axes,
    pub radiance: Radiance,
    pub transmittance: Transmittance,
    pub polarisation: Option<Polarisation>,
}

/// A fitted dataset in double precision, for [`Dataset::encode`].
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetFit {
    pub axes: Axes,
    pub radiance: RadianceFit,
    pub transmittance: TransmittanceFit,
    pub polarisation: Option<PolarisationFit>,
}

/// Fitted radiance: the breaks and one entry per configuration, in file
/// order ([`Axes::configuration`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RadianceFit {
    pub sun_breaks: Vec<f64>,
    pub zenith_breaks: Vec<f64>,
    pub emph_breaks: Vec<f64>,
    pub configs: Vec<RadianceConfigFit>,
}

/// One configuration's rank components and emphasis values.
#[derive(Debug, Clone, PartialEq)]
pub struct RadianceConfigFit {
    pub components: Vec<ComponentFit>,
    pub emph: Vec<f64>,
}

/// One rank component: values at the sun breaks and at the zenith breaks.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentFit {
    pub sun: Vec<f64>,
    pub zenith: Vec<f64>,
}

/// A fitted transmittance part, laid out as the file's.
pub type TransmittanceFit = Transmittance<f64>;

/// Fitted polarisation: the breaks and, per configuration, its rank
/// components.
#[derive(Debug, Clone, PartialEq)]
pub struct PolarisationFit {
    pub sun_breaks: Vec<f64>,
    pub zenith_breaks: Vec<f64>,
    pub configs: Vec<Vec<ComponentFit>>,
}

impl Dataset {
    /// Reads a dataset file.
    pub fn read(path: &Path) -> Result<Dataset> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Dataset::from_bytes(&bytes, &path.display().to_string())
    }

    /// Writes the dataset file atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::io::atomic::write_atomic(path, &self.to_bytes())
    }

    /// Parses a dataset file's bytes; `name` names it in errors.
    pub fn from_bytes(bytes: &[u8], name: &str) -> Result<Dataset> {
        let mut r = Reader { bytes, pos: 0, name };
        let axes = r.axes()?;
        let radiance = r.radiance(&axes)?;
        let transmittance = r.transmittance(axes.channels)?;
        let polarisation = if r.remaining() == 0 {
            None
        } else {
            Some(r.polarisation(&axes)?)
        };
        if r.remaining() > 0 {
            return Err(r.error(format!(
                "{} bytes after the polarisation part (from byte {})",
                r.remaining(),
                r.pos
            )));
        }
        Ok(Dataset {
            axes,
            radiance,
            transmittance,
            polarisation,
        })
    }

    /// The file's bytes. A dataset that [`Dataset::encode`] or
    /// [`Dataset::from_bytes`] made is written back bit for bit.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.axes(&self.axes);
        w.radiance(&self.radiance);
        w.transmittance(&self.transmittance);
        if let Some(p) = &self.polarisation {
            w.polarisation(p);
        }
        w.0
    }

    /// Rounds a fit to the file's precisions: sun and emphasis values to
    /// half, zenith values to half after scaling each component by
    /// 1/max|value| (they use the half's range and never overflow it),
    /// transmittance and polarisation to `f32`; then decodes them as the
    /// runtime does. Non-finite values, values beyond their format's range
    /// and tables of the wrong shape are errors naming where they are.
    pub fn encode(fit: &DatasetFit, name: &str) -> Result<Dataset> {
        let err = |m: String| Error::data(name, m);
        let axes = &fit.axes;
        check_axes(axes).map_err(err)?;
        let polarisation = fit.polarisation.as_ref().map(|p| encode_polarisation(p, axes));
        let dataset = Dataset {
            axes: axes.clone(),
            radiance: encode_radiance(&fit.radiance, axes, Rounding::Halves).map_err(err)?,
            transmittance: encode_transmittance(&fit.transmittance).map_err(err)?,
            polarisation: polarisation.transpose().map_err(err)?,
        };
        // What is left to check: the transmittance's shape.
        dataset.check(name)?;
        Ok(dataset)
    }

    /// [`Dataset::encode`] with the radiance kept in `f32` instead of
    /// halves: not a dataset the format can hold, but the fit as the
    /// runtime would evaluate it without the halves' rounding, to measure
    /// what the rounding costs.
    pub fn unrounded(fit: &DatasetFit, name: &str) -> Result<Dataset> {
        let mut dataset = Self::encode(fit, name)?;
        dataset.radiance =
            encode_radiance(&fit.radiance, &fit.axes, Rounding::Single).map_err(|m| Error::data(name, m))?;
        Ok(dataset)
    }
}

/// How the radiance's values are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rounding {
    /// IEEE halves, as the file holds them (zenith values scaled first).
    Halves,
    /// `f32`, for comparison only.
    Single,
}

impl Dataset {
    /// Checks what reading and evaluating rely on: the counts, ascending
    /// axes and breaks, and tables as long as their shapes call for. (A
    /// dataset that [`Dataset::from_bytes`] or [`Dataset::encode`] made
    /// passes.)
    pub fn check(&self, name: &str) -> Result<()> {
        check_shape(self).map_err(|e| Error::data(name, e))
    }
}

fn check_shape(d: &Dataset) -> Result<(), String> {
    check_axes(&d.axes)?;
    let configs = d.axes.configurations();
    let r = &d.radiance;
    check_count("rank", r.rank, 1)?;
    check_breaks("sunBreaks", &r.sun_breaks)?;
    check_breaks("zenithBreaks", &r.zenith_breaks)?;
    check_breaks("emphBreaks", &r.emph_breaks)?;
    check_len("radiance", r.coefs.len(), configs.saturating_mul(r.config_len()))?;
    let t = &d.transmittance;
    for (what, n) in [("dDim", t.d_dim), ("aDim", t.a_dim), ("rankTrans", t.rank)] {
        check_count(what, n, 1)?;
    }
    for (what, values) in [
        ("altitudesTrans", &t.altitudes_m),
        ("visibilitiesTrans", &t.visibilities_km),
    ] {
        check_count(what, values.len(), 1)?;
        check_axis(what, values)?;
    }
    let (n_alt, n_vis) = (t.altitudes_m.len(), t.visibilities_km.len());
    check_len("transmittance U", t.u.len(), product([n_alt, t.d_dim, t.a_dim, t.rank]))?;
    check_len(
        "transmittance V",
        t.v.len(),
        product([n_vis, n_alt, d.axes.channels, t.rank]),
    )?;
    if let Some(p) = &d.polarisation {
        check_count("rankPol", p.rank, 1)?;
        check_breaks("sunBreaksPol", &p.sun_breaks)?;
        check_breaks("zenithBreaksPol", &p.zenith_breaks)?;
        check_len("polarisation", p.coefs.len(), configs.saturating_mul(p.config_len()))?;
    }
    Ok(())
}

/// Checks a configuration axis: finite and strictly ascending (the
/// runtime's interpolation searches it as sorted).
fn check_axis(what: &str, values: &[f64]) -> Result<(), String> {
    if let Some(x) = values.iter().find(|x| !x.is_finite()) {
        return Err(format!("{what}: {x} is not finite"));
    }
    match values.windows(2).find(|w| w[1] <= w[0]) {
        Some(w) => Err(format!("{what}: {} then {} is not strictly ascending", w[0], w[1])),
        None => Ok(()),
    }
}

/// Checks a break list: at least two, strictly ascending, within [0, π].
fn check_breaks(what: &str, breaks: &[f64]) -> Result<(), String> {
    check_count(what, breaks.len(), 2)?;
    check_axis(what, breaks)?;
    match breaks
        .iter()
        .find(|&&x| !(-BREAK_TOLERANCE..=PI + BREAK_TOLERANCE).contains(&x))
    {
        Some(x) => Err(format!("{what}: break {x} is outside [0, π]")),
        None => Ok(()),
    }
}

/// Checks the axes, the channels (start ≥ 0, width > 0, as the runtime
/// does) and that the configurations can be counted.
fn check_axes(a: &Axes) -> Result<(), String> {
    for (what, values) in [
        ("visibilities", &a.visibilities_km),
        ("albedos", &a.albedos),
        ("altitudes", &a.altitudes_m),
        ("elevations", &a.elevations_deg),
    ] {
        check_count(what, values.len(), 1)?;
        check_axis(what, values)?;
    }
    check_count("channels", a.channels, 1)?;
    let (start, width) = (a.channel_start_nm, a.channel_width_nm);
    if !(start.is_finite() && start >= 0.0 && width.is_finite() && width > 0.0) {
        return Err(format!(
            "channelStart {start} nm, channelWidth {width} nm: need start ≥ 0, width > 0"
        ));
    }
    let sizes = [&a.visibilities_km, &a.albedos, &a.altitudes_m, &a.elevations_deg].map(Vec::len);
    match sizes.iter().try_fold(a.channels, |p, &n| p.checked_mul(n)) {
        Some(_) => Ok(()),
        None => Err("the number of configurations overflows".to_string()),
    }
}

/// Checks a count against the runtime's minimum and the file's `i32`.
fn check_count(what: &str, n: usize, min: usize) -> Result<(), String> {
    match (min..=i32::MAX as usize).contains(&n) {
        true => Ok(()),
        false => Err(format!("{what}: {n}, must be in [{min}, {}]", i32::MAX)),
    }
}

/// The product of a table's dimensions (saturated: no table is that long).
fn product(dims: [usize; 4]) -> usize {
    dims.iter()
        .try_fold(1usize, |p, &d| p.checked_mul(d))
        .unwrap_or(usize::MAX)
}

/// Checks a table's length against its shape.
fn check_len(what: &str, len: usize, expected: usize) -> Result<(), String> {
    match len == expected {
        true => Ok(()),
        false => Err(format!("{what}: {len} values, the shape calls for {expected}")),
    }
}

/// The half nearest `x`, or why there is none.
fn to_half(x: f64) -> Result<f16, String> {
    match nearest_half(x) {
        h if h.is_finite() => Ok(h),
        _ if x.is_finite() => Err(format!("{x} is beyond the half range (±{})", f16::MAX)),
        _ => Err(format!("{x} is not finite")),
    }
}

/// The `f32` nearest `x`, or why there is none.
fn to_f32(x: f64) -> Result<f32, String> {
    match x as f32 {
        y if y.is_finite() => Ok(y),
        _ => Err(format!("{x} is not finite in f32")),
    }
}

/// The zenithScale of a component: 1/max|value| (1 for values all below
/// [`SMALLEST_SCALED_ZENITH`]).
fn zenith_scale(zenith: &[f64]) -> Result<f64, String> {
    let mut max = 0.0f64;
    for &z in zenith {
        to_f32(z).map_err(|e| format!("zenith value {e}"))?;
        max = max.max(z.abs());
    }
    Ok(if max >= SMALLEST_SCALED_ZENITH { 1.0 / max } else { 1.0 })
}

/// Checks that `configs` has one entry per configuration and that each
/// holds as many components as the first; returns that rank.
fn check_configs<C>(what: &str, configs: &[C], components: impl Fn(&C) -> usize, axes: &Axes) -> Result<usize, String> {
    if configs.len() != axes.configurations() {
        return Err(format!(
            "{what}: {} configurations, the axes call for {}",
            configs.len(),
            axes.configurations()
        ));
    }
    let rank = configs.first().map_or(0, &components);
    check_count(&format!("{what} rank"), rank, 1)?;
    match configs.iter().position(|c| components(c) != rank) {
        Some(config) => {
            let n = components(&configs[config]);
            Err(format!(
                "{what} of {}: {n} rank components, the first configuration has {rank}",
                axes.describe(config)
            ))
        }
        None => Ok(rank),
    }
}

/// Checks a component's lengths against the breaks.
fn check_component(c: &ComponentFit, n_sun: usize, n_zenith: usize) -> Result<(), String> {
    if c.sun.len() != n_sun || c.zenith.len() != n_zenith {
        let (s, z) = (c.sun.len(), c.zenith.len());
        return Err(format!(
            "{s} sun and {z} zenith values for {n_sun} and {n_zenith} breaks"
        ));
    }
    Ok(())
}

fn encode_radiance(fit: &RadianceFit, axes: &Axes, rounding: Rounding) -> Result<Radiance, String> {
    let store = |x: f64| -> Result<f32, String> {
        match rounding {
            Rounding::Halves => to_half(x).map(|h| h.to_f32()),
            Rounding::Single => to_f32(x),
        }
    };
    check_breaks("sunBreaks", &fit.sun_breaks)?;
    check_breaks("zenithBreaks", &fit.zenith_breaks)?;
    check_breaks("emphBreaks", &fit.emph_breaks)?;
    let rank = check_configs("radiance", &fit.configs, |c| c.components.len(), axes)?;
    let mut out = Radiance {
        rank,
        sun_breaks: fit.sun_breaks.clone(),
        zenith_breaks: fit.zenith_breaks.clone(),
        emph_breaks: fit.emph_breaks.clone(),
        zenith_scales: Vec::with_capacity(axes.configurations() * rank),
        coefs: Vec::new(),
    };
    out.coefs.reserve(axes.configurations() * out.config_len());
    for (config, c) in fit.configs.iter().enumerate() {
        for (k, comp) in c.components.iter().enumerate() {
            let at = |e: String| format!("radiance of {}, rank component {k}: {e}", axes.describe(config));
            check_component(comp, fit.sun_breaks.len(), fit.zenith_breaks.len()).map_err(at)?;
            for &x in &comp.sun {
                out.coefs.push(store(x).map_err(|e| at(format!("sun value {e}")))?);
            }
            let scale = zenith_scale(&comp.zenith).map_err(at)?;
            out.zenith_scales.push(scale);
            for &z in &comp.zenith {
                out.coefs.push(match rounding {
                    Rounding::Halves => {
                        let h = to_half(z * scale).map_err(|e| at(format!("scaled zenith value {e}")))?;
                        decode_zenith(h, scale).map_err(at)?
                    }
                    Rounding::Single => to_f32(z).map_err(|e| at(format!("zenith value {e}")))?,
                });
            }
        }
        let at = |e: String| format!("radiance of {}: {e}", axes.describe(config));
        if c.emph.len() != fit.emph_breaks.len() {
            return Err(at(format!(
                "{} emphasis values for {} breaks",
                c.emph.len(),
                fit.emph_breaks.len()
            )));
        }
        for &x in &c.emph {
            out.coefs.push(store(x).map_err(|e| at(format!("emphasis value {e}")))?);
        }
    }
    Ok(out)
}

fn encode_transmittance(fit: &TransmittanceFit) -> Result<Transmittance, String> {
    // Rounded to f32, an axis must still ascend.
    let axis = |what: &str, values: &[f64]| -> Result<Vec<f64>, String> {
        let rounded = values
            .iter()
            .map(|&x| to_f32(x).map(f64::from))
            .collect::<Result<Vec<_>, _>>();
        let rounded = rounded.map_err(|e| format!("{what}: {e}"))?;
        check_axis(what, &rounded).map(|_| rounded)
    };
    let table = |what: &str, values: &[f64]| -> Result<Vec<f32>, String> {
        let value = |(i, &x)| to_f32(x).map_err(|e| format!("transmittance {what}[{i}]: {e}"));
        values.iter().enumerate().map(value).collect()
    };
    Ok(Transmittance {
        d_dim: fit.d_dim,
        a_dim: fit.a_dim,
        altitudes_m: axis("altitudesTrans", &fit.altitudes_m)?,
        visibilities_km: axis("visibilitiesTrans", &fit.visibilities_km)?,
        rank: fit.rank,
        u: table("U", &fit.u)?,
        v: table("V", &fit.v)?,
    })
}

fn encode_polarisation(fit: &PolarisationFit, axes: &Axes) -> Result<Polarisation, String> {
    check_breaks("sunBreaksPol", &fit.sun_breaks)?;
    check_breaks("zenithBreaksPol", &fit.zenith_breaks)?;
    let rank = check_configs("polarisation", &fit.configs, Vec::len, axes)?;
    let mut coefs = Vec::with_capacity(axes.configurations() * rank * (fit.sun_breaks.len() + fit.zenith_breaks.len()));
    for (config, components) in fit.configs.iter().enumerate() {
        for (k, comp) in components.iter().enumerate() {
            let at = |e: String| format!("polarisation of {}, rank component {k}: {e}", axes.describe(config));
            check_component(comp, fit.sun_breaks.len(), fit.zenith_breaks.len()).map_err(at)?;
            for &x in comp.sun.iter().chain(&comp.zenith) {
                coefs.push(to_f32(x).map_err(at)?);
            }
        }
    }
    Ok(Polarisation {
        rank,
        sun_breaks: fit.sun_breaks.clone(),
        zenith_breaks: fit.zenith_breaks.clone(),
        coefs,
    })
}

impl fmt::Display for Dataset {
    /// A summary: the axes and the tables' sizes.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |v: &[f64]| match (v.first(), v.last()) {
            (Some(a), Some(b)) => format!("{} ({a} … {b})", v.len()),
            _ => "0".to_string(),
        };
        let (a, r, t) = (&self.axes, &self.radiance, &self.transmittance);
        let [s, z, e] = [&r.sun_breaks, &r.zenith_breaks, &r.emph_breaks].map(Vec::len);
        let lines = [
            ("visibilities (km)", list(&a.visibilities_km)),
            ("albedos", list(&a.albedos)),
            ("altitudes (m)", list(&a.altitudes_m)),
            ("elevations (deg)", list(&a.elevations_deg)),
            (
                "channels",
                format!(
                    "{} of {} nm from {} nm",
                    a.channels, a.channel_width_nm, a.channel_start_nm
                ),
            ),
            ("configurations", a.configurations().to_string()),
            (
                "radiance",
                format!("rank {}, breaks: sun {s}, zenith {z}, emphasis {e}", r.rank),
            ),
            (
                "transmittance",
                format!("rank {}, {} distances × {} altitudes", t.rank, t.d_dim, t.a_dim),
            ),
            ("  observer altitudes (m)", list(&t.altitudes_m)),
            ("  visibilities (km)", list(&t.visibilities_km)),
            (
                "polarisation",
                match &self.polarisation {
                    Some(p) => format!(
                        "rank {}, breaks: sun {}, zenith {}",
                        p.rank,
                        p.sun_breaks.len(),
                        p.zenith_breaks.len()
                    ),
                    None => "none".to_string(),
                },
            ),
        ];
        for (label, value) in lines {
            writeln!(f, "{:<24}{value}", format!("{label}:"))?;
        }
        Ok(())
    }
}

/// The half nearest `x`, ties to even (IEEE round-to-nearest); ±∞ past the
/// half range, NaN for NaN. `half`'s own `from_f64` rounds twice (through
/// `f32`, or after truncating the low mantissa bits), which misses the
/// nearest half by one unit just above a tie.
pub fn nearest_half(x: f64) -> f16 {
    if x.is_nan() {
        return f16::NAN;
    }
    let sign: u16 = if x.is_sign_negative() { 0x8000 } else { 0 };
    let a = x.abs();
    let bits = if a < pow2(-14) {
        // Subnormals: multiples of 2^-24; 1024 of them is the smallest normal.
        (a * pow2(24)).round_ties_even() as u32
    } else {
        let e = (a.to_bits() >> 52) as i32 - 1023;
        if e > 15 {
            0x7c00
        } else {
            // 1024 ≤ m ≤ 2048 units of 2^(e−10); 2048 carries into the exponent.
            let m = (a * pow2(10 - e)).round_ties_even() as u32;
            (((e + 15) as u32) << 10) + m - 1024
        }
    };
    f16::from_bits(sign | bits.min(0x7c00) as u16)
}

/// 2^k, exactly (|k| < 1000).
fn pow2(k: i32) -> f64 {
    f64::from_bits(((1023 + k) as u64) << 52)
}

/// A sun or emphasis half as the runtime decodes it.
fn decode_half(h: f16) -> Result<f32, String> {
    if h.is_finite() {
        Ok(h.to_f32())
    } else {
        Err(format!("{h} is not finite"))
    }
}

/// A zenith half as the runtime decodes it, f32(half / zenithScale),
/// refused unless finite and written back by [`Dataset::to_bytes`] as the
/// same half.
fn decode_zenith(h: f16, scale: f64) -> Result<f32, String> {
    let z = (h.to_f64() / scale) as f32;
    if !z.is_finite() || nearest_half(z as f64 * scale).to_bits() != h.to_bits() {
        return Err(format!(
            "{h} / zenithScale {scale:e} = {z:e} is not finite or not stored again as the same half"
        ));
    }
    Ok(z)
}

/// What a read is for; formatted only when an error needs it: a named
/// field, or a field of a configuration (and of a rank component).
#[derive(Clone, Copy)]
enum Field<'a> {
    Named(&'static str),
    Config(&'static str, &'a Axes, usize, Option<usize>),
}

impl fmt::Display for Field<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Field::Named(name) => f.write_str(name),
            Field::Config(name, axes, config, None) => write!(f, "{name} of {}", axes.describe(config)),
            Field::Config(name, axes, config, Some(k)) => {
                write!(f, "{name} of {}, rank component {k}", axes.describe(config))
            }
        }
    }
}

/// A strict reader: every field in order, errors naming field and offset.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    name: &'a str,
}

/// Little-endian bytes as an array (`b` is exactly `N` long).
fn le<const N: usize>(b: &[u8]) -> [u8; N] {
    let mut a = [0; N];
    a.copy_from_slice(b);
    a
}

impl<'a> Reader<'a> {
    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn error(&self, message: String) -> Error {
        Error::data(self.name, message)
    }

    /// The next `count` values of `size` bytes each.
    fn take(&mut self, count: usize, size: usize, what: Field) -> Result<&'a [u8]> {
        let Some(n) = count.checked_mul(size).filter(|&n| n <= self.remaining()) else {
            return Err(self.error(format!(
                "truncated at byte {}: reading {what} ({count} × {size} bytes) at byte {}",
                self.bytes.len(),
                self.pos
            )));
        };
        let slice = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(slice)
    }

    fn f64(&mut self, what: Field) -> Result<f64> {
        Ok(f64::from_le_bytes(le(self.take(1, 8, what)?)))
    }

    /// A count of at least `min`; with `size` > 0 its values, `size` bytes
    /// each and read next, must fit in the bytes left (checked before
    /// anything is allocated for them).
    fn count(&mut self, what: &'static str, min: i32, size: usize) -> Result<usize> {
        let at = self.pos;
        let n = i32::from_le_bytes(le(self.take(1, 4, Field::Named(what))?));
        if n < min {
            return Err(self.error(format!("{what} = {n} at byte {at}: must be at least {min}")));
        }
        let need = n as usize * size;
        if need > self.remaining() {
            return Err(self.error(format!(
                "truncated at byte {}: {what} = {n} at byte {at} calls for {need} bytes of values, {} are left \
                 (or the count is damaged)",
                self.bytes.len(),
                self.remaining()
            )));
        }
        Ok(n as usize)
    }

    /// A counted list of `f64`: an axis, or with `min` 2 a break list.
    fn list(&mut self, count: &'static str, what: &'static str, min: i32) -> Result<Vec<f64>> {
        let n = self.count(count, min, 8)?;
        let at = self.pos;
        let values: Vec<f64> = self
            .take(n, 8, Field::Named(what))?
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(le(b)))
            .collect();
        let check = if min >= 2 {
            check_breaks(what, &values)
        } else {
            check_axis(what, &values)
        };
        check.map_err(|e| self.error(format!("{e} (the list at byte {at})")))?;
        Ok(values)
    }

    fn halves(
        &mut self,
        n: usize,
        what: Field,
        out: &mut Vec<f32>,
        decode: impl Fn(f16) -> Result<f32, String>,
    ) -> Result<()> {
        let at = self.pos;
        for (i, b) in self.take(n, 2, what)?.chunks_exact(2).enumerate() {
            let value = decode(f16::from_le_bytes(le(b)));
            out.push(value.map_err(|e| self.error(format!("{what}: value {i} at byte {}: {e}", at + 2 * i)))?);
        }
        Ok(())
    }

    fn f32s(&mut self, n: usize, what: Field, out: &mut Vec<f32>) -> Result<()> {
        let at = self.pos;
        let bytes = self.take(n, 4, what)?;
        out.reserve(n);
        for (i, b) in bytes.chunks_exact(4).enumerate() {
            let x = f32::from_le_bytes(le(b));
            if !x.is_finite() {
                return Err(self.error(format!("{what}: value {i} at byte {} is {x}", at + 4 * i)));
            }
            out.push(x);
        }
        Ok(())
    }

    fn axes(&mut self) -> Result<Axes> {
        let visibilities_km = self.list("nVis", "visibilities", 1)?;
        let albedos = self.list("nAlb", "albedos", 1)?;
        let altitudes_m = self.list("nAlt", "altitudes", 1)?;
        let elevations_deg = self.list("nElev", "elevations", 1)?;
        let channels = self.count("channels", 1, 0)?;
        let at = self.pos;
        let channel_start_nm = self.f64(Field::Named("channelStart"))?;
        let channel_width_nm = self.f64(Field::Named("channelWidth"))?;
        let axes = Axes {
            visibilities_km,
            albedos,
            altitudes_m,
            elevations_deg,
            channels,
            channel_start_nm,
            channel_width_nm,
        };
        check_axes(&axes).map_err(|e| self.error(format!("{e} (at byte {at})")))?;
        Ok(axes)
    }

    fn radiance(&mut self, axes: &Axes) -> Result<Radiance> {
        let rank = self.count("rank", 1, 0)?;
        let mut rad = Radiance {
            rank,
            sun_breaks: self.list("nSunBreaks", "sunBreaks", 2)?,
            zenith_breaks: self.list("nZenithBreaks", "zenithBreaks", 2)?,
            emph_breaks: self.list("nEmphBreaks", "emphBreaks", 2)?,
            zenith_scales: Vec::new(),
            coefs: Vec::new(),
        };
        let (n_sun, n_zen, n_emph) = (rad.sun_breaks.len(), rad.zenith_breaks.len(), rad.emph_breaks.len());
        // Reserved no further than the bytes left could fill, so that a
        // damaged count cannot allocate more than the file holds.
        let configs = axes.configurations();
        rad.coefs
            .reserve(configs.saturating_mul(rad.config_len()).min(self.remaining() / 2));
        rad.zenith_scales
            .reserve(configs.saturating_mul(rank).min(self.remaining() / 8));
        for config in 0..configs {
            for k in 0..rank {
                let field = |name| Field::Config(name, axes, config, Some(k));
                self.halves(n_sun, field("sunCoefsRad"), &mut rad.coefs, decode_half)?;
                let at = self.pos;
                let scale = self.f64(field("zenithScale"))?;
                if !(scale.is_finite() && scale != 0.0) {
                    let what = field("zenithScale");
                    return Err(self.error(format!("{what} at byte {at}: {scale:e}, must be finite and non-zero")));
                }
                rad.zenith_scales.push(scale);
                self.halves(n_zen, field("zenithCoefsRad"), &mut rad.coefs, |h| {
                    decode_zenith(h, scale)
                })?;
            }
            let field = Field::Config("emphCoefsRad", axes, config, None);
            self.halves(n_emph, field, &mut rad.coefs, decode_half)?;
        }
        Ok(rad)
    }

    fn transmittance(&mut self, channels: usize) -> Result<Transmittance> {
        let d_dim = self.count("dDim", 1, 0)?;
        let a_dim = self.count("aDim", 1, 0)?;
        let n_vis = self.count("nVisTrans", 1, 0)?;
        let n_alt = self.count("nAltTrans", 1, 0)?;
        let rank = self.count("rankTrans", 1, 0)?;
        let mut axis = |n, what| -> Result<Vec<f64>> {
            let (at, mut values) = (self.pos, Vec::new());
            self.f32s(n, Field::Named(what), &mut values)?;
            let values: Vec<f64> = values.into_iter().map(f64::from).collect();
            check_axis(what, &values).map_err(|e| self.error(format!("{e} (the list at byte {at})")))?;
            Ok(values)
        };
        let altitudes_m = axis(n_alt, "altitudesTrans")?;
        let visibilities_km = axis(n_vis, "visibilitiesTrans")?;
        let (mut u, mut v) = (Vec::new(), Vec::new());
        self.f32s(product([n_alt, d_dim, a_dim, rank]), Field::Named("transU"), &mut u)?;
        self.f32s(product([n_vis, n_alt, channels, rank]), Field::Named("transV"), &mut v)?;
        Ok(Transmittance {
            d_dim,
            a_dim,
            altitudes_m,
            visibilities_km,
            rank,
            u,
            v,
        })
    }

    fn polarisation(&mut self, axes: &Axes) -> Result<Polarisation> {
        let mut pol = Polarisation {
            rank: self.count("rankPol", 1, 0)?,
            sun_breaks: self.list("nSunBreaksPol", "sunBreaksPol", 2)?,
            zenith_breaks: self.list("nZenithBreaksPol", "zenithBreaksPol", 2)?,
            coefs: Vec::new(),
        };
        let configs = axes.configurations();
        pol.coefs
            .reserve(configs.saturating_mul(pol.config_len()).min(self.remaining() / 4));
        for config in 0..configs {
            for k in 0..pol.rank {
                let field = |name| Field::Config(name, axes, config, Some(k));
                self.f32s(pol.sun_breaks.len(), field("sunCoefsPol"), &mut pol.coefs)?;
                self.f32s(pol.zenith_breaks.len(), field("zenithCoefsPol"), &mut pol.coefs)?;
            }
        }
        Ok(pol)
    }
}

/// The file's bytes, field by field.
#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn count(&mut self, n: usize) {
        self.0.extend_from_slice(&(n as i32).to_le_bytes());
    }

    fn f64(&mut self, x: f64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }

    fn list(&mut self, values: &[f64]) {
        self.count(values.len());
        values.iter().for_each(|&x| self.f64(x));
    }

    fn half(&mut self, x: f64) {
        self.0.extend_from_slice(&nearest_half(x).to_le_bytes());
    }

    fn f32s(&mut self, values: impl IntoIterator<Item = f32>) {
        values
            .into_iter()
            .for_each(|x| self.0.extend_from_slice(&x.to_le_bytes()));
    }

    fn axes(&mut self, a: &Axes) {
        for values in [&a.visibilities_km, &a.albedos, &a.altitudes_m, &a.elevations_deg] {
            self.list(values);
        }
        self.count(a.channels);
        self.f64(a.channel_start_nm);
        self.f64(a.channel_width_nm);
    }

    fn radiance(&mut self, r: &Radiance) {
        self.count(r.rank);
        for breaks in [&r.sun_breaks, &r.zenith_breaks, &r.emph_breaks] {
            self.list(breaks);
        }
        let n_sun = r.sun_breaks.len();
        for (config, c) in r.coefs.chunks_exact(r.config_len().max(1)).enumerate() {
            let (components, emph) = c.split_at(r.rank * r.component_len());
            for (k, comp) in components.chunks_exact(r.component_len().max(1)).enumerate() {
                let scale = r.zenith_scales.get(config * r.rank + k).copied().unwrap_or(1.0);
                comp[..n_sun].iter().for_each(|&x| self.half(x as f64));
                self.f64(scale);
                comp[n_sun..].iter().for_each(|&z| self.half(z as f64 * scale));
            }
            emph.iter().for_each(|&x| self.half(x as f64));
        }
    }

    fn transmittance(&mut self, t: &Transmittance) {
        for n in [t.d_dim, t.a_dim, t.visibilities_km.len(), t.altitudes_m.len(), t.rank] {
            self.count(n);
        }
        self.f32s(t.altitudes_m.iter().map(|&x| x as f32));
        self.f32s(t.visibilities_km.iter().map(|&x| x as f32));
        self.f32s(t.u.iter().copied());
        self.f32s(t.v.iter().copied());
    }

    fn polarisation(&mut self, p: &Polarisation) {
        self.count(p.rank);
        self.list(&p.sun_breaks);
        self.list(&p.zenith_breaks);
        self.f32s(p.coefs.iter().copied());
    }
}
