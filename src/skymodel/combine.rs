//! Datasets fitted from shards of one grid, joined into the grid's
//! dataset. `atmosim fit --shard K/N` fits a contiguous range of the
//! grid's visibilities, the outermost axis of the radiance and polarisation
//! tables, so joining is concatenation in visibility order; everything else
//! (the other axes, breaks, ranks and the transmittance part, which every
//! shard fits from the whole set of tables) must be identical, and is
//! checked to be.

use std::path::Path;

use super::dataset::{Axes, Dataset};
use super::fit_files::{find_shards, sidecars};
use crate::error::{Error, Result};

/// A grid's dataset joined from its shard files, with its sidecars' text.
pub struct Joined {
    pub dataset: Dataset,
    /// The number of shards joined.
    pub shards: u64,
    /// The first shard's provenance with the summed counts (`<out>.toml`).
    pub provenance: String,
    /// The shards' per-image figures in visibility order (`<out>.fit.csv`).
    pub figures: String,
}

/// The shards of `out` (`<out>.shard-K-of-N.dat` with their sidecars, every
/// K of one N) read and joined. Nothing is written: the caller writes the
/// dataset and [`sidecars`] of `out`.
pub fn combine_files(out: &Path) -> Result<Joined> {
    let found = find_shards(out)?;
    let count = found.first().map_or(0, |(s, _)| s.count);
    let mut shards = Vec::new();
    for (_, path) in &found {
        shards.push((path.display().to_string(), Dataset::read(path)?));
    }
    let dataset = combine(&shards)?;
    let mut order: Vec<usize> = (0..shards.len()).collect();
    order.sort_by(|&a, &b| shards[a].1.axes.visibilities_km[0].total_cmp(&shards[b].1.axes.visibilities_km[0]));
    let read = |p: &Path| std::fs::read_to_string(p).map_err(|e| Error::io(p, e));
    let mut figures = String::new();
    let mut provenances = Vec::new();
    for &i in &order {
        let (toml, csv) = sidecars(&found[i].1);
        let text = read(&csv)?;
        let mut lines = text.lines();
        let header = lines.next().unwrap_or_default();
        if figures.is_empty() {
            figures.push_str(header);
            figures.push('\n');
        }
        for l in lines {
            figures.push_str(l);
            figures.push('\n');
        }
        provenances.push(read(&toml)?);
    }
    let provenance = joined_provenance(&provenances, out, count);
    Ok(Joined {
        dataset,
        shards: count,
        provenance,
        figures,
    })
}

/// The first shard's provenance (`texts`, one per shard) with `images` and
/// `image_core_seconds` summed over all of them, `shards = count` added,
/// and `dataset` naming `out`.
fn joined_provenance(texts: &[String], out: &Path, count: u64) -> String {
    let value = |text: &str, key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key).and_then(|r| r.trim_start().strip_prefix('=')))
            .and_then(|v| v.trim().parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    let images: u64 = texts.iter().map(|t| value(t, "images") as u64).sum();
    let core_seconds: f64 = texts.iter().map(|t| value(t, "image_core_seconds")).sum();
    let first = texts.first().map_or("", |t| t.as_str());
    first
        .lines()
        .map(|l| {
            if l.starts_with("images =") {
                format!("images = {images}\nshards = {count}")
            } else if l.starts_with("image_core_seconds =") {
                format!("image_core_seconds = {core_seconds:.3}")
            } else if l.starts_with("dataset =") {
                format!("dataset = {:?}", out.display().to_string())
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn provenance_sums_the_shards_counts() {
        let shard = |images: u32, secs: f64| {
            format!(
                "# header\ndataset = \"g.dat.shard-1\"\nimages = {images}\nimage_core_seconds = {secs:.3}\n\n[settings]\nrank = 9\n"
            )
        };
        let text = joined_provenance(&[shard(66, 90.5), shard(44, 60.25)], Path::new("out/g.dat"), 2);
        let value: toml::Value = toml::from_str(&text).expect("the joined provenance is TOML");
        assert_eq!(value["images"].as_integer(), Some(110));
        assert_eq!(value["shards"].as_integer(), Some(2));
        assert_eq!(value["image_core_seconds"].as_float(), Some(150.75));
        assert_eq!(value["dataset"].as_str(), Some("out/g.dat"));
        assert_eq!(value["settings"]["rank"].as_integer(), Some(9));
    }
}
