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

use std::fmt;
use std::path::Path;

use crate::error::{Error, Result};

mod checks;
mod encode;
mod read;
mod tables;
mod write;

use checks::*;
pub use encode::nearest_half;
use encode::*;
use read::*;
pub use tables::*;
use write::*;

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

impl Dataset {
    /// Checks what reading and evaluating rely on: the counts, ascending
    /// axes and breaks, and tables as long as their shapes call for. (A
    /// dataset that [`Dataset::from_bytes`] or [`Dataset::encode`] made
    /// passes.)
    pub fn check(&self, name: &str) -> Result<()> {
        check_shape(self).map_err(|e| Error::data(name, e))
    }
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
