//! The checks a dataset passes before it is written or after it is read:
//! counts, ascending axes and breaks, table lengths.

use std::f64::consts::PI;

use super::tables::*;

/// How far (rad) a break may stray outside [0, π] by rounding.
pub(super) const BREAK_TOLERANCE: f64 = 1e-6;

pub(super) fn check_shape(d: &Dataset) -> Result<(), String> {
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
pub(super) fn check_axis(what: &str, values: &[f64]) -> Result<(), String> {
    if let Some(x) = values.iter().find(|x| !x.is_finite()) {
        return Err(format!("{what}: {x} is not finite"));
    }
    match values.windows(2).find(|w| w[1] <= w[0]) {
        Some(w) => Err(format!("{what}: {} then {} is not strictly ascending", w[0], w[1])),
        None => Ok(()),
    }
}

/// Checks a break list: at least two, strictly ascending, within [0, π].
pub(super) fn check_breaks(what: &str, breaks: &[f64]) -> Result<(), String> {
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
pub(super) fn check_axes(a: &Axes) -> Result<(), String> {
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
pub(super) fn check_count(what: &str, n: usize, min: usize) -> Result<(), String> {
    match (min..=i32::MAX as usize).contains(&n) {
        true => Ok(()),
        false => Err(format!("{what}: {n}, must be in [{min}, {}]", i32::MAX)),
    }
}

/// The product of a table's dimensions (saturated: no table is that long).
pub(super) fn product(dims: [usize; 4]) -> usize {
    dims.iter()
        .try_fold(1usize, |p, &d| p.checked_mul(d))
        .unwrap_or(usize::MAX)
}

/// Checks a table's length against its shape.
pub(super) fn check_len(what: &str, len: usize, expected: usize) -> Result<(), String> {
    match len == expected {
        true => Ok(()),
        false => Err(format!("{what}: {len} values, the shape calls for {expected}")),
    }
}

/// Checks that `configs` has one entry per configuration and that each
/// holds as many components as the first; returns that rank.
pub(super) fn check_configs<C>(
    what: &str,
    configs: &[C],
    components: impl Fn(&C) -> usize,
    axes: &Axes,
) -> Result<usize, String> {
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
pub(super) fn check_component(c: &ComponentFit, n_sun: usize, n_zenith: usize) -> Result<(), String> {
    if c.sun.len() != n_sun || c.zenith.len() != n_zenith {
        let (s, z) = (c.sun.len(), c.zenith.len());
        return Err(format!(
            "{s} sun and {z} zenith values for {n_sun} and {n_zenith} breaks"
        ));
    }
    Ok(())
}
