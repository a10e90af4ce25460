//! The transmittance part of a dataset (the supplement's section 2): √T at
//! the runtime's nodes, for each observer altitude a matrix of nodes ×
//! (visibility, channel), decomposed by a truncated SVD.
//!
//! The tables are those of `atmosim transmittance` with
//! `layout = "sky_model"` ([`read`]): one task per (visibility, observer
//! altitude), `<λ>nm.T` per channel and `blocked` for nodes whose line of
//! sight passes below the ground; or, when the fit names no table
//! directory, the same tables computed from the render jobs themselves
//! ([`compute`], on the default 32 × 64 nodes). A blocked node has no transmittance; it is filled by
//! harmonic continuation of its visible neighbours' √T over the
//! (distance, altitude) node grid, so that the runtime, which interpolates
//! between nodes and observer altitudes, reads a smooth surface there and
//! not a cliff to 0.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::decompose::truncated_svd;
use super::laplace;
use super::settings::{AUTO_MAX_ERROR, AUTO_RANK_START, AUTO_RANK_STEP, TransmittanceRank};
use crate::error::{Error, Result};
use crate::io::exr::{read_exr, wavelength_label};
use crate::job::transmittance::Grid;
use crate::skymodel::dataset::TransmittanceFit;

/// The file `atmosim transmittance` writes per task.
pub const TABLE_FILE: &str = "transmittance.exr";

/// A fitted transmittance part and how well it holds the tables.
#[derive(Debug, Clone)]
pub struct TransmittanceResult {
    pub part: TransmittanceFit,
    /// The largest |T_fit − T_table| over visible nodes (after f32).
    pub max_abs_error: f64,
    /// Explained variance of √T by rank, per observer altitude.
    pub explained: Vec<Vec<f64>>,
    /// Blocked nodes filled, of all nodes.
    pub filled: (usize, usize),
    /// Where the tables came from: their directory, or the render jobs.
    pub source: String,
}

/// One table: (visibility, observer altitude) → per channel √T over the
/// nodes (index d·n_a + a), and the blocked flags.
struct Table {
    sqrt_t: Vec<Vec<f64>>,
    t: Vec<Vec<f64>>,
    blocked: Vec<bool>,
}

/// The tables of a grid, keyed by (visibility km, observer altitude m) as
/// bits, on `n_a` × `n_d` runtime nodes; `source` names where they came
/// from, for errors.
pub struct Tables {
    by_key: BTreeMap<(u64, u64), Table>,
    n_a: usize,
    n_d: usize,
    source: String,
}

/// The EXR's or table's pixel (row i = altitude, column j = distance) to
/// node d·n_a + a, the runtime's order.
fn to_node_order(v: &[f64], n_a: usize, n_d: usize) -> Vec<f64> {
    let mut out = vec![0.0; n_a * n_d];
    for i in 0..n_a {
        for j in 0..n_d {
            out[j * n_a + i] = v[i * n_d + j];
        }
    }
    out
}

impl Table {
    fn new(t: Vec<Vec<f64>>, blocked: Vec<bool>) -> Table {
        let sqrt_t = t
            .iter()
            .map(|c| c.iter().map(|&x| x.max(0.0).sqrt()).collect())
            .collect();
        Table { sqrt_t, t, blocked }
    }
}

/// Computes the transmittance tables of every (visibility, observer
/// altitude) of the render jobs `jobs` ((hash, file) as the renders record
/// them) on the runtime's default 32 × 64 nodes, for the channels
/// `wavelengths_nm`. A job file that is gone or has changed since the
/// renders is refused: the tables must be of the rendered atmosphere.
pub fn compute(jobs: &[(String, String)], wavelengths_nm: &[f64]) -> Result<Tables> {
    use crate::job::Job;
    use crate::job::transmittance::{
        DEFAULT_ALTITUDE_NODES, DEFAULT_DISTANCE_NODES, DEFAULT_SAMPLES, Estimator, Grid, TransmittanceSpec,
    };
    let (n_a, n_d) = (DEFAULT_ALTITUDE_NODES, DEFAULT_DISTANCE_NODES);
    let mut by_key = BTreeMap::new();
    for (hash, file) in jobs {
        let advice = "or render the tables with `atmosim transmittance` (layout = \"sky_model\") and name \
                      their directory as `transmittance` in the fit settings";
        let mut job = Job::from_file(Path::new(file)).map_err(|e| {
            Error::data(
                file.clone(),
                format!("the renders' job file, needed for the transmittance tables, cannot be read ({e}); run the fit where the renders were made, {advice}"),
            )
        })?;
        if &job.hash != hash {
            return Err(Error::data(
                file.clone(),
                format!(
                    "has changed since the renders (job hash {} now, {hash} in the renders); {advice}",
                    job.hash
                ),
            ));
        }
        if (job.wavelengths_nm.len() != wavelengths_nm.len())
            || job
                .wavelengths_nm
                .iter()
                .zip(wavelengths_nm)
                .any(|(a, b)| (a - b).abs() > 1e-9)
        {
            return Err(Error::data(
                file.clone(),
                format!(
                    "wavelengths {:?}, the renders' channels are {wavelengths_nm:?}",
                    job.wavelengths_nm
                ),
            ));
        }
        job.transmittance = TransmittanceSpec {
            grid: Grid::sky_model_runtime(n_a, n_d),
            estimator: Estimator::Analytic,
            samples: DEFAULT_SAMPLES,
            export_sqrt: false,
        };
        for (task, _) in job.transmittance_tasks() {
            let visibility = task.atmosphere.visibility.map_or(0.0, |v| v.ground_km);
            let key = (visibility.to_bits(), (task.observer_altitude_km * 1000.0).to_bits());
            if by_key.contains_key(&key) {
                continue;
            }
            let table = crate::transport::table_build::transmittance_table(&job, task);
            let t = table.t.iter().map(|c| to_node_order(c, n_a, n_d)).collect();
            let blocked: Vec<f64> = table.blocked.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
            let blocked = to_node_order(&blocked, n_a, n_d).iter().map(|&b| b > 0.5).collect();
            by_key.insert(key, Table::new(t, blocked));
        }
    }
    Ok(Tables {
        by_key,
        n_a,
        n_d,
        source: format!("computed from the render jobs (layout sky_model, {n_a} x {n_d} nodes, analytic)"),
    })
}

/// Reads every table under `dir`; `wavelengths_nm` are the radiance
/// part's channel centres, which the tables must have.
pub fn read(dir: &Path, wavelengths_nm: &[f64]) -> Result<Tables> {
    let mut paths: Vec<PathBuf> = if dir.join(TABLE_FILE).is_file() {
        vec![dir.join(TABLE_FILE)]
    } else {
        std::fs::read_dir(dir)
            .map_err(|e| Error::io(dir, e))?
            .filter_map(|e| e.ok().map(|e| e.path().join(TABLE_FILE)))
            .filter(|p| p.is_file())
            .collect()
    };
    paths.sort();
    if paths.is_empty() {
        return Err(Error::data(
            dir.display().to_string(),
            format!("no {TABLE_FILE} (run `atmosim transmittance` with layout = \"sky_model\")"),
        ));
    }
    let mut tables: BTreeMap<(u64, u64), Table> = BTreeMap::new();
    let mut layout: Option<(usize, usize)> = None;
    for path in &paths {
        let name = path.display().to_string();
        let exr = read_exr(path)?;
        let attr = |k: &str| -> Result<String> {
            exr.attributes
                .iter()
                .find(|(a, _)| a == k)
                .map(|(_, v)| v.clone())
                .ok_or_else(|| Error::data(&name, format!("no `{k}` attribute: not an atmosim transmittance table")))
        };
        let numbers = |k: &str| -> Result<Vec<f64>> {
            attr(k)?
                .split_whitespace()
                .map(|v| v.parse().map_err(|_| Error::data(&name, format!("`{k}` holds {v:?}"))))
                .collect()
        };
        let (n_a, n_d) = (exr.height, exr.width);
        let runtime = Grid::sky_model_runtime(n_a, n_d);
        let close = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9 * y.max(1.0))
        };
        if !close(&numbers("altitudes_km")?, &runtime.altitudes_km)
            || !close(&numbers("distances_km")?, &runtime.distances_km)
        {
            return Err(Error::data(
                &name,
                "not on the sky-model runtime's nodes: render the tables with `layout = \"sky_model\"` in [transmittance]",
            ));
        }
        match layout {
            None => layout = Some((n_a, n_d)),
            Some(l) if l != (n_a, n_d) => {
                return Err(Error::data(
                    &name,
                    format!("{n_a} × {n_d} nodes, another table has {} × {}", l.0, l.1),
                ));
            }
            Some(_) => {}
        }
        let table_wavelengths = numbers("wavelengths_nm")?;
        if !close(&table_wavelengths, wavelengths_nm) {
            return Err(Error::data(
                &name,
                format!("wavelengths {table_wavelengths:?}, the renders' channels are {wavelengths_nm:?}"),
            ));
        }
        let radius = attr("planet_radius_km")?;
        if radius.trim() != "6378" {
            return Err(Error::data(
                &name,
                format!("planet radius {radius} km; the runtime assumes 6378 km"),
            ));
        }
        // "none": no aerosol, as the renders' visibility 0 stands for.
        let visibility_text = attr("visibility_km")?;
        let visibility: f64 = if visibility_text.trim() == "none" {
            0.0
        } else {
            visibility_text
                .trim()
                .parse()
                .map_err(|_| Error::data(&name, format!("`visibility_km` = {visibility_text:?} is not a number")))?
        };
        let altitude_km: f64 = attr("observer_altitude_km")?
            .trim()
            .parse()
            .map_err(|_| Error::data(&name, "`observer_altitude_km` is not a number"))?;
        let channel = |n: &str| -> Result<&Vec<f32>> {
            exr.channels
                .iter()
                .find(|c| c.name == n)
                .map(|c| &c.samples)
                .ok_or_else(|| Error::data(&name, format!("no channel `{n}`")))
        };
        let reorder = |v: &[f32]| to_node_order(&v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>(), n_a, n_d);
        let blocked: Vec<bool> = reorder(channel("blocked")?).iter().map(|&b| b > 0.5).collect();
        let mut t = Vec::new();
        for &lambda in wavelengths_nm {
            t.push(reorder(channel(&format!("{}.T", wavelength_label(lambda)))?));
        }
        let key = (visibility.to_bits(), (altitude_km * 1000.0).to_bits());
        if tables.insert(key, Table::new(t, blocked)).is_some() {
            return Err(Error::data(
                &name,
                format!("a second table of visibility {visibility} km, observer {altitude_km} km"),
            ));
        }
    }
    let (n_a, n_d) = layout.expect("at least one table");
    Ok(Tables {
        by_key: tables,
        n_a,
        n_d,
        source: dir.display().to_string(),
    })
}

/// Fits `tables` for the channels `wavelengths_nm` at `rank` per
/// observer altitude, fixed or chosen ([`TransmittanceRank::Auto`]).
pub fn fit_rank(tables: &Tables, wavelengths_nm: &[f64], rank: TransmittanceRank) -> Result<TransmittanceResult> {
    match rank {
        TransmittanceRank::Fixed(rank) => fit(tables, wavelengths_nm, rank),
        TransmittanceRank::Auto => {
            // Exact at as many ranks as (visibility, channel) columns.
            let visibilities = {
                let mut v: Vec<u64> = tables.by_key.keys().map(|k| k.0).collect();
                v.sort_unstable();
                v.dedup();
                v.len()
            };
            let columns = (visibilities * wavelengths_nm.len()).max(1);
            let mut rank = AUTO_RANK_START.min(columns);
            loop {
                let result = fit(tables, wavelengths_nm, rank)?;
                if result.max_abs_error <= AUTO_MAX_ERROR || rank >= columns {
                    return Ok(result);
                }
                rank = (rank + AUTO_RANK_STEP).min(columns);
            }
        }
    }
}

/// Fits the tables at a fixed `rank` per observer altitude.
pub fn fit(tables: &Tables, wavelengths_nm: &[f64], rank: usize) -> Result<TransmittanceResult> {
    let (n_a, n_d) = (tables.n_a, tables.n_d);
    let mut visibilities: Vec<f64> = tables.by_key.keys().map(|k| f64::from_bits(k.0)).collect();
    let mut altitudes_m: Vec<f64> = tables.by_key.keys().map(|k| f64::from_bits(k.1)).collect();
    for v in [&mut visibilities, &mut altitudes_m] {
        v.sort_by(f64::total_cmp);
        v.dedup();
    }
    let channels = wavelengths_nm.len();
    let nodes = n_a * n_d;
    let configs = visibilities.len() * channels;
    let mut u = vec![0f64; altitudes_m.len() * nodes * rank];
    let mut v = vec![0f64; visibilities.len() * altitudes_m.len() * channels * rank];
    let mut explained = Vec::new();
    let mut filled = (0, 0);
    let mut max_abs_error: f64 = 0.0;
    for (ai, &alt) in altitudes_m.iter().enumerate() {
        // Columns: (visibility, channel); rows: nodes.
        let mut m = vec![0.0; nodes * configs];
        for (vi, &vis) in visibilities.iter().enumerate() {
            let table = tables.by_key.get(&(vis.to_bits(), alt.to_bits())).ok_or_else(|| {
                Error::data(
                    tables.source.clone(),
                    format!(
                        "no table of visibility {vis} km for observer {} km: the tables must cover every pair",
                        alt / 1000.0
                    ),
                )
            })?;
            let known: Vec<bool> = table.blocked.iter().map(|b| !b).collect();
            filled.0 += table.blocked.iter().filter(|&&b| b).count() * channels;
            filled.1 += nodes * channels;
            for (c, values) in table.sqrt_t.iter().enumerate() {
                let mut column = values.clone();
                laplace::fill(&mut column, &known, n_a, n_d, false);
                for (node, x) in column.iter().enumerate() {
                    m[node * configs + vi * channels + c] = *x;
                }
            }
        }
        let low = truncated_svd(&m, nodes, configs, rank);
        explained.push(low.explained_variance());
        for node in 0..nodes {
            for r in 0..rank {
                u[(ai * nodes + node) * rank + r] = low.zenith[r][node];
            }
        }
        for vi in 0..visibilities.len() {
            for c in 0..channels {
                for r in 0..rank {
                    v[((vi * altitudes_m.len() + ai) * channels + c) * rank + r] = low.sun[r][vi * channels + c];
                }
            }
        }
        // The error at the nodes, as the runtime reconstructs them from
        // the file's f32 values.
        for (vi, &vis) in visibilities.iter().enumerate() {
            let table = &tables.by_key[&(vis.to_bits(), alt.to_bits())];
            for c in 0..channels {
                for node in (0..nodes).filter(|&k| !table.blocked[k]) {
                    let s: f64 = (0..rank)
                        .map(|r| {
                            (u[(ai * nodes + node) * rank + r] as f32) as f64
                                * (v[((vi * altitudes_m.len() + ai) * channels + c) * rank + r] as f32) as f64
                        })
                        .sum();
                    let fitted = s.max(0.0).powi(2);
                    max_abs_error = max_abs_error.max((fitted - table.t[c][node]).abs());
                }
            }
        }
    }
    Ok(TransmittanceResult {
        part: TransmittanceFit {
            d_dim: n_d,
            a_dim: n_a,
            altitudes_m,
            visibilities_km: visibilities,
            rank,
            u,
            v,
        },
        max_abs_error,
        explained,
        filled,
        source: tables.source.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One visibility and observer altitude, 8 × 16 nodes and `channels`
    /// channels whose √T is a sum of `terms` separable patterns with
    /// amplitudes falling by 0.6 per term (so each rank leaves the next
    /// terms' error), scaled into (0, 1).
    fn tables(channels: usize, terms: usize) -> Tables {
        let (n_a, n_d) = (8, 16);
        let nodes = n_a * n_d;
        let mut sqrt_t = vec![vec![0.0; nodes]; channels];
        for (c, column) in sqrt_t.iter_mut().enumerate() {
            for (node, x) in column.iter_mut().enumerate() {
                let s: f64 = (0..terms)
                    .map(|k| {
                        let f = ((k + 1) as f64 * (node as f64 * 0.37 + 0.5)).sin();
                        let g = ((k + 2) as f64 * (c as f64 * 0.71 + 0.3)).cos();
                        0.6f64.powi(k as i32) * f * g
                    })
                    .sum();
                *x = 0.5 + 0.2 * s;
            }
        }
        let t = sqrt_t.iter().map(|c| c.iter().map(|x| x * x).collect()).collect();
        let mut by_key = BTreeMap::new();
        by_key.insert(
            (40f64.to_bits(), 0f64.to_bits()),
            Table {
                sqrt_t,
                t,
                blocked: vec![false; nodes],
            },
        );
        Tables {
            by_key,
            n_a,
            n_d,
            source: "test".into(),
        }
    }

    #[test]
    fn auto_takes_the_first_rank_from_twelve_that_holds_the_nodes() {
        // Twenty-four patterns over thirty channels: rank 12 leaves more
        // than the target.
        let t = tables(30, 24);
        let wavelengths: Vec<f64> = (0..30).map(|c| 300.0 + 40.0 * c as f64).collect();
        let at = |r: usize| fit(&t, &wavelengths, r).unwrap().max_abs_error;
        assert!(at(AUTO_RANK_START) > AUTO_MAX_ERROR, "{}", at(AUTO_RANK_START));
        let expected = (AUTO_RANK_START..=30)
            .step_by(AUTO_RANK_STEP)
            .find(|&r| at(r) <= AUTO_MAX_ERROR)
            .expect("a rank that holds the nodes");
        let auto = fit_rank(&t, &wavelengths, TransmittanceRank::Auto).unwrap();
        assert_eq!(auto.part.rank, expected);
        assert!(auto.part.rank > AUTO_RANK_START && auto.max_abs_error <= AUTO_MAX_ERROR);
        // A fixed rank is taken as it is.
        assert_eq!(
            fit_rank(&t, &wavelengths, TransmittanceRank::Fixed(12))
                .unwrap()
                .part
                .rank,
            12
        );
        // Few patterns: the supplement's 12.
        let easy = tables(30, 6);
        assert_eq!(
            fit_rank(&easy, &wavelengths, TransmittanceRank::Auto)
                .unwrap()
                .part
                .rank,
            12
        );
        // Fewer columns than 12: as many as there are (exact).
        let few = tables(5, 24);
        let r = fit_rank(&few, &wavelengths[..5], TransmittanceRank::Auto).unwrap();
        assert_eq!(r.part.rank, 5);
        assert!(r.max_abs_error < 1e-6, "{}", r.max_abs_error);
    }
}
