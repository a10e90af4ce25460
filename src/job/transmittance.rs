//! Resolving the `[transmittance]` section.

use super::context::Ctx;
use super::raw::{RawEstimator, RawTableLayout, RawTransmittance};
use crate::error::Result;

/// The sky model's maximum distance to the edge of the atmosphere (km).
pub const SKY_MODEL_MAX_DISTANCE_KM: f64 = 1571.524;
/// The sky-model runtime's height of the atmosphere for its node layout (km).
pub const SKY_MODEL_TOP_KM: f64 = 100.0;

/// Which estimator fills the table (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Estimator {
    RatioTracking,
    /// Ratio tracking of the residual σ_t − σ̄_layer against the exact
    /// transmittance of the layer means (the control).
    ResidualRatioTracking,
    Analytic,
}

impl Estimator {
    /// The job-file spelling.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::RatioTracking => "ratio_tracking",
            Estimator::ResidualRatioTracking => "residual_ratio_tracking",
            Estimator::Analytic => "analytic",
        }
    }
}

/// The grid: altitudes (rows) × ground distances (columns).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub altitudes_km: Vec<f64>,
    pub distances_km: Vec<f64>,
    /// How the nodes were made, for metadata.
    pub definition: String,
}

impl Grid {
    /// The sky-model runtime's own nodes, `n_a` altitudes and `n_d`
    /// distances: a_i = 100 km·(i/n_a)³ and d_j = 1571.524 km·(j/n_d)⁴ for
    /// i, j from 0 (i/N, not i/(N − 1): the runtime's last node lies below
    /// 100 km and 1571.524 km, and it clamps beyond it). A dataset's
    /// transmittance part is fitted on exactly these.
    pub fn sky_model_runtime(n_a: usize, n_d: usize) -> Grid {
        let node = |i: usize, n: usize, p: i32| (i as f64 / n as f64).powi(p);
        Grid {
            altitudes_km: (0..n_a).map(|i| SKY_MODEL_TOP_KM * node(i, n_a, 3)).collect(),
            distances_km: (0..n_d).map(|j| SKY_MODEL_MAX_DISTANCE_KM * node(j, n_d, 4)).collect(),
            definition: format!(
                "sky_model: a_i = {SKY_MODEL_TOP_KM}*(i/{n_a})^3 km, i = 0..{}; d_j = {SKY_MODEL_MAX_DISTANCE_KM}*(j/{n_d})^4 km, j = 0..{} (the sky-model runtime's nodes)",
                n_a - 1,
                n_d - 1
            ),
        }
    }

    /// Power-law nodes with both ends included (layout `closed`):
    /// a_i = top·(i/(n_a − 1))³ and d_j = max_distance·(j/(n_d − 1))⁴.
    pub fn closed(top_km: f64, n_a: usize, n_d: usize, max_distance_km: f64) -> Grid {
        let node = |i: usize, n: usize, p: i32| (i as f64 / (n - 1) as f64).powi(p);
        Grid {
            altitudes_km: (0..n_a).map(|i| top_km * node(i, n_a, 3)).collect(),
            distances_km: (0..n_d).map(|j| max_distance_km * node(j, n_d, 4)).collect(),
            definition: format!(
                "a_i = {top_km}*(i/{})^3 km, i = 0..{}; d_j = {max_distance_km}*(j/{})^4 km, j = 0..{}",
                n_a - 1,
                n_a - 1,
                n_d - 1,
                n_d - 1
            ),
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.altitudes_km.len() * self.distances_km.len()
    }

    /// True for a grid without points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Settings of a transmittance computation.
#[derive(Debug, Clone, PartialEq)]
pub struct TransmittanceSpec {
    pub grid: Grid,
    pub estimator: Estimator,
    pub samples: u64,
    pub export_sqrt: bool,
}

/// Default altitude nodes of the sky-model layout.
pub const DEFAULT_ALTITUDE_NODES: usize = 32;
/// Default distance nodes of the sky-model layout.
pub const DEFAULT_DISTANCE_NODES: usize = 64;
/// Default ratio-tracking samples per point.
pub const DEFAULT_SAMPLES: u64 = 1000;
/// Most nodes per axis: the grid's node lists are built when the job is
/// read, so a mistyped count (say 10¹²) must be refused, not allocated.
pub const MAX_NODES: i64 = 100_000;

pub(super) fn resolve(
    ctx: &Ctx,
    raw: Option<RawTransmittance>,
    top_km: f64,
    radius_km: Option<f64>,
    banded: bool,
) -> Result<TransmittanceSpec> {
    let raw = raw.unwrap_or_default();
    let nodes = |key: &str, v: Option<i64>, default: usize| -> Result<usize> {
        match v {
            None => Ok(default),
            Some(n) if (2..=MAX_NODES).contains(&n) => Ok(n as usize),
            Some(n) if n < 2 => Err(ctx.invalid(key, n, "fewer than 2 nodes", &format!("2 to {MAX_NODES}"))),
            Some(n) => Err(ctx.invalid(key, n, "too many nodes", &format!("2 to {MAX_NODES}"))),
        }
    };
    let n_a = nodes(
        "transmittance.altitude_nodes",
        raw.altitude_nodes,
        DEFAULT_ALTITUDE_NODES,
    )?;
    let n_d = nodes(
        "transmittance.distance_nodes",
        raw.distance_nodes,
        DEFAULT_DISTANCE_NODES,
    )?;
    // A point beyond half the planet's circumference is the same as a nearer one.
    let max_d = radius_km.map_or(f64::MAX, |r| std::f64::consts::PI * r);
    let max_d_text = radius_km.map_or("≥ 0 km".to_string(), |_| {
        format!("0 to {max_d:.1} km (half the circumference)")
    });
    let d_max = ctx.range(
        "transmittance.max_distance_km",
        raw.max_distance_km.unwrap_or(SKY_MODEL_MAX_DISTANCE_KM),
        0.0,
        max_d,
        true,
        &max_d_text,
    )?;
    let layout = raw.layout.unwrap_or(RawTableLayout::Closed);
    if let RawTableLayout::SkyModel = layout {
        for (key, given) in [
            ("transmittance.max_distance_km", raw.max_distance_km.is_some()),
            ("transmittance.altitudes_km", raw.altitudes_km.is_some()),
            ("transmittance.distances_km", raw.distances_km.is_some()),
        ] {
            if given {
                return Err(ctx.invalid(
                    key,
                    "given",
                    "layout = \"sky_model\" fixes the nodes to the runtime's",
                    "absent with layout = \"sky_model\" (or layout = \"closed\")",
                ));
            }
        }
        let grid = Grid::sky_model_runtime(n_a, n_d);
        let highest = grid.altitudes_km[n_a - 1];
        if highest > top_km {
            return Err(ctx.invalid(
                "transmittance.altitude_nodes",
                n_a,
                &format!("the highest sky_model node ({highest:.3} km) lies above planet.top_km ({top_km} km)"),
                "fewer nodes, or an atmosphere up to 100 km",
            ));
        }
        if let Some(r) = radius_km
            && grid.distances_km[n_d - 1] > std::f64::consts::PI * r
        {
            return Err(ctx.invalid(
                "transmittance.distance_nodes",
                n_d,
                "the farthest sky_model node lies beyond half the planet's circumference",
                "a planet of radius ≥ 500.3 km",
            ));
        }
    }
    let mut grid = match layout {
        RawTableLayout::SkyModel => Grid::sky_model_runtime(n_a, n_d),
        RawTableLayout::Closed => Grid::closed(top_km, n_a, n_d, d_max),
    };
    let list = |key: &str, values: &[f64], hi: f64, valid: &str| -> Result<Vec<f64>> {
        if values.len() < 2 {
            return Err(ctx.invalid(key, format!("{values:?}"), "fewer than 2 nodes", "a list of 2 or more"));
        }
        values
            .iter()
            .map(|&v| ctx.range(key, v, 0.0, hi, false, valid))
            .collect()
    };
    if let Some(a) = &raw.altitudes_km {
        grid.altitudes_km = list(
            "transmittance.altitudes_km",
            a,
            top_km,
            &format!("0 to planet.top_km ({top_km} km)"),
        )?;
        grid.definition = format!("altitudes_km = {:?}; {}", grid.altitudes_km, grid.definition);
    }
    if let Some(d) = &raw.distances_km {
        grid.distances_km = list("transmittance.distances_km", d, max_d, &max_d_text)?;
        grid.definition = format!("distances_km = {:?}; {}", grid.distances_km, grid.definition);
    }
    if raw.altitudes_km.is_some() && raw.distances_km.is_some() {
        grid.definition = format!(
            "altitudes_km = {:?}; distances_km = {:?}",
            grid.altitudes_km, grid.distances_km
        );
    }
    let samples = raw.samples.unwrap_or(DEFAULT_SAMPLES);
    if samples == 0 {
        return Err(ctx.invalid("transmittance.samples", 0, "no samples", "at least 1"));
    }
    Ok(TransmittanceSpec {
        grid,
        estimator: {
            let asked = raw.estimator.map(|e| match e {
                RawEstimator::RatioTracking => Estimator::RatioTracking,
                RawEstimator::ResidualRatioTracking => Estimator::ResidualRatioTracking,
                RawEstimator::Analytic => Estimator::Analytic,
            });
            match (asked, banded) {
                // Bands average T over each band exactly (they use the
                // layered medium, where the optical depth is a sum).
                (None | Some(Estimator::Analytic), true) => Estimator::Analytic,
                (Some(other), true) => {
                    return Err(ctx.invalid(
                        "transmittance.estimator",
                        format!("\"{}\"", other.name()),
                        "spectrum.band_width_nm > 0: bands average the transmittance over each band exactly",
                        "\"analytic\" (the default with bands)",
                    ));
                }
                (asked, false) => asked.unwrap_or(Estimator::RatioTracking),
            }
        },
        samples,
        export_sqrt: raw.export_sqrt.unwrap_or(false),
    })
}
