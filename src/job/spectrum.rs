//! The job's channels: wavelengths, and bands around them.

use super::context::Ctx;
use super::raw::OneOrMany;
use crate::atmosphere::BuildError;
use crate::error::{Error, Result};

/// Each channel's band width (nm) from `spectrum.band_width_nm`: one value
/// for every channel or one per channel; 0 (monochromatic) by default. A
/// band is centred on its wavelength and must stay above 0 nm.
pub(super) fn band_widths(ctx: &Ctx, wavelengths_nm: &[f64], raw: Option<OneOrMany>) -> Result<Vec<f64>> {
    const KEY: &str = "spectrum.band_width_nm";
    let widths = match raw {
        None => vec![0.0; wavelengths_nm.len()],
        Some(OneOrMany::One(w)) => vec![w; wavelengths_nm.len()],
        Some(OneOrMany::Many(list)) => {
            if list.len() != wavelengths_nm.len() {
                return Err(ctx.invalid(
                    KEY,
                    format!("{} values", list.len()),
                    &format!("the list has one width per channel; there are {}", wavelengths_nm.len()),
                    "one number for every channel, or one per entry of spectrum.wavelengths_nm",
                ));
            }
            list
        }
    };
    for (&w, &l) in widths.iter().zip(wavelengths_nm) {
        ctx.range(
            KEY,
            w,
            0.0,
            2.0 * l,
            false,
            &format!("0 (one wavelength) or a full width in nm below twice the channel's wavelength ({l} nm)"),
        )?;
        if w == 2.0 * l {
            return Err(ctx.invalid(KEY, w, "the band would reach 0 nm", "less than twice the wavelength"));
        }
    }
    Ok(widths)
}

/// The error for a band edge outside a constituent's data.
pub(super) fn band_error(ctx: &Ctx, wavelengths_nm: &[f64], widths_nm: &[f64], e: BuildError) -> Error {
    match e {
        BuildError::Wavelength {
            lambda_nm,
            what,
            range_nm: (lo, hi),
        } => {
            let channel = wavelengths_nm
                .iter()
                .zip(widths_nm)
                .find(|(l, w)| (*l - 0.5 * *w - lambda_nm).abs() < 1e-9 || (*l + 0.5 * *w - lambda_nm).abs() < 1e-9);
            let (l, w) = channel.map_or((lambda_nm, 0.0), |(l, w)| (*l, *w));
            ctx.invalid(
                "spectrum.band_width_nm",
                w,
                &format!(
                    "the band {} to {} nm of the channel at {l} nm leaves the data of {what}",
                    l - 0.5 * w,
                    l + 0.5 * w
                ),
                &format!("bands inside {lo} to {hi} nm"),
            )
        }
        other => Error::data("built-in data", format!("{other:?}")),
    }
}

/// One output channel: a wavelength, or a band around it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Channel {
    pub lambda_nm: f64,
    /// Full width of the band centred on `lambda_nm`; 0 for one wavelength.
    pub band_width_nm: f64,
}

impl Channel {
    /// The channel's wavelength for a uniform variate `u` (its centre for a
    /// monochromatic channel).
    pub fn wavelength(&self, u: f64) -> f64 {
        self.lambda_nm + self.band_width_nm * (u - 0.5)
    }

    /// The band's edges (nm): every wavelength [`Channel::wavelength`]
    /// gives lies within them (both for one wavelength).
    pub fn band_nm(&self) -> (f64, f64) {
        let half = 0.5 * self.band_width_nm;
        (self.lambda_nm - half, self.lambda_nm + half)
    }
}
