//! The strict reader of a dataset file's bytes.

use std::fmt;

use half::f16;

use super::checks::*;
use super::encode::*;
use super::tables::*;
use crate::error::{Error, Result};

/// What a read is for; formatted only when an error needs it: a named
/// field, or a field of a configuration (and of a rank component).
#[derive(Clone, Copy)]
pub(super) enum Field<'a> {
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
pub(super) struct Reader<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) pos: usize,
    pub(super) name: &'a str,
}

/// Little-endian bytes as an array (`b` is exactly `N` long).
pub(super) fn le<const N: usize>(b: &[u8]) -> [u8; N] {
    let mut a = [0; N];
    a.copy_from_slice(b);
    a
}

impl<'a> Reader<'a> {
    pub(super) fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    pub(super) fn error(&self, message: String) -> Error {
        Error::data(self.name, message)
    }

    /// The next `count` values of `size` bytes each.
    pub(super) fn take(&mut self, count: usize, size: usize, what: Field) -> Result<&'a [u8]> {
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

    pub(super) fn f64(&mut self, what: Field) -> Result<f64> {
        Ok(f64::from_le_bytes(le(self.take(1, 8, what)?)))
    }

    /// A count of at least `min`; with `size` > 0 its values, `size` bytes
    /// each and read next, must fit in the bytes left (checked before
    /// anything is allocated for them).
    pub(super) fn count(&mut self, what: &'static str, min: i32, size: usize) -> Result<usize> {
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
    pub(super) fn list(&mut self, count: &'static str, what: &'static str, min: i32) -> Result<Vec<f64>> {
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

    pub(super) fn halves(
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

    pub(super) fn f32s(&mut self, n: usize, what: Field, out: &mut Vec<f32>) -> Result<()> {
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

    pub(super) fn axes(&mut self) -> Result<Axes> {
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

    pub(super) fn radiance(&mut self, axes: &Axes) -> Result<Radiance> {
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

    pub(super) fn transmittance(&mut self, channels: usize) -> Result<Transmittance> {
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

    pub(super) fn polarisation(&mut self, axes: &Axes) -> Result<Polarisation> {
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
