//! Datasets fitted from shards of one grid, joined into the grid's
//! dataset. `atmosim fit --shard K/N` fits a contiguous range of the
//! grid's visibilities, the outermost axis of the radiance and polarisation
//! tables, so joining is concatenation in visibility order; everything else
//! (the other axes, breaks, ranks and the transmittance part, which every
//! shard fits from the whole set of tables) must be identical, and is
//! checked to be.

use super::dataset::{Axes, Dataset};
use crate::error::{Error, Result};

/// Joins `shards` ((name, dataset), any order) into one dataset whose
/// visibilities are theirs in ascending order. Refused: an empty list,
/// shards whose fixed parts differ, or visibilities that two shards share.
pub fn combine(shards: &[(String, Dataset)]) -> Result<Dataset> {
    let Some((first_name, first)) = shards.first() else {
        return Err(Error::data("shards", "no shard to combine"));
    };
    let mut order: Vec<&(String, Dataset)> = shards.iter().collect();
    order.sort_by(|a, b| a.1.axes.visibilities_km[0].total_cmp(&b.1.axes.visibilities_km[0]));
    let differs = |name: &str, what: &str| {
        Error::data(
            name,
            format!("its {what} differs from {first_name}'s: not a shard of the same fit"),
        )
    };
    let fixed = |a: &Axes| {
        (
            a.albedos.clone(),
            a.altitudes_m.clone(),
            a.elevations_deg.clone(),
            a.channels,
            a.channel_start_nm.to_bits(),
            a.channel_width_nm.to_bits(),
        )
    };
    let mut out = first.clone();
    out.axes.visibilities_km.clear();
    out.radiance.coefs.clear();
    out.radiance.zenith_scales.clear();
    if let Some(p) = out.polarisation.as_mut() {
        p.coefs.clear();
    }
    for (name, d) in order {
        if fixed(&d.axes) != fixed(&first.axes) {
            return Err(differs(name, "grid (albedos, altitudes, elevations or channels)"));
        }
        let (r, r0) = (&d.radiance, &first.radiance);
        if (r.rank, &r.sun_breaks, &r.zenith_breaks, &r.emph_breaks)
            != (r0.rank, &r0.sun_breaks, &r0.zenith_breaks, &r0.emph_breaks)
        {
            return Err(differs(name, "radiance rank or breaks"));
        }
        if d.transmittance != first.transmittance {
            return Err(differs(name, "transmittance part"));
        }
        match (&d.polarisation, &first.polarisation, out.polarisation.as_mut()) {
            (None, None, _) => {}
            (Some(p), Some(p0), Some(joined))
                if (p.rank, &p.sun_breaks, &p.zenith_breaks) == (p0.rank, &p0.sun_breaks, &p0.zenith_breaks) =>
            {
                joined.coefs.extend_from_slice(&p.coefs);
            }
            _ => return Err(differs(name, "polarisation part")),
        }
        if let Some(&v) = out.axes.visibilities_km.last()
            && d.axes.visibilities_km[0] <= v
        {
            return Err(Error::data(
                name,
                format!("visibility {} km is also in another shard", d.axes.visibilities_km[0]),
            ));
        }
        out.axes.visibilities_km.extend_from_slice(&d.axes.visibilities_km);
        out.radiance.coefs.extend_from_slice(&r.coefs);
        out.radiance.zenith_scales.extend_from_slice(&r.zenith_scales);
    }
    out.check("the combined dataset")?;
    Ok(out)
}
