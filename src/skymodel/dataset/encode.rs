//! Fitted `f64` values to the file's precisions (halves for the
//! radiance, `f32` for the rest) and back as the runtime decodes them.

use half::f16;

use super::checks::*;
use super::tables::*;

/// Below this largest |value| a zenith component is written with scale 1
/// (its values are then half zeros): a larger scale would decode to `f32`
/// subnormals that cannot be stored again exactly.
pub(super) const SMALLEST_SCALED_ZENITH: f64 = 1.0 / (1u128 << 102) as f64;

/// How the radiance's values are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Rounding {
    /// IEEE halves, as the file holds them (zenith values scaled first).
    Halves,
    /// `f32`, for comparison only.
    Single,
}

/// The half nearest `x`, or why there is none.
pub(super) fn to_half(x: f64) -> Result<f16, String> {
    match nearest_half(x) {
        h if h.is_finite() => Ok(h),
        _ if x.is_finite() => Err(format!("{x} is beyond the half range (±{})", f16::MAX)),
        _ => Err(format!("{x} is not finite")),
    }
}

/// The `f32` nearest `x`, or why there is none.
pub(super) fn to_f32(x: f64) -> Result<f32, String> {
    match x as f32 {
        y if y.is_finite() => Ok(y),
        _ => Err(format!("{x} is not finite in f32")),
    }
}

/// The zenithScale of a component: 1/max|value| (1 for values all below
/// [`SMALLEST_SCALED_ZENITH`]).
pub(super) fn zenith_scale(zenith: &[f64]) -> Result<f64, String> {
    let mut max = 0.0f64;
    for &z in zenith {
        to_f32(z).map_err(|e| format!("zenith value {e}"))?;
        max = max.max(z.abs());
    }
    Ok(if max >= SMALLEST_SCALED_ZENITH { 1.0 / max } else { 1.0 })
}

pub(super) fn encode_radiance(fit: &RadianceFit, axes: &Axes, rounding: Rounding) -> Result<Radiance, String> {
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

pub(super) fn encode_transmittance(fit: &TransmittanceFit) -> Result<Transmittance, String> {
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

pub(super) fn encode_polarisation(fit: &PolarisationFit, axes: &Axes) -> Result<Polarisation, String> {
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
pub(super) fn pow2(k: i32) -> f64 {
    f64::from_bits(((1023 + k) as u64) << 52)
}

/// A sun or emphasis half as the runtime decodes it.
pub(super) fn decode_half(h: f16) -> Result<f32, String> {
    if h.is_finite() {
        Ok(h.to_f32())
    } else {
        Err(format!("{h} is not finite"))
    }
}

/// A zenith half as the runtime decodes it, f32(half / zenithScale),
/// refused unless finite and written back by [`Dataset::to_bytes`] as the
/// same half.
pub(super) fn decode_zenith(h: f16, scale: f64) -> Result<f32, String> {
    let z = (h.to_f64() / scale) as f32;
    if !z.is_finite() || nearest_half(z as f64 * scale).to_bits() != h.to_bits() {
        return Err(format!(
            "{h} / zenithScale {scale:e} = {z:e} is not finite or not stored again as the same half"
        ));
    }
    Ok(z)
}
