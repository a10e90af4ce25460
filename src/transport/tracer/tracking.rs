//! The medium paths are tracked through: the profile's own layers, or, in a
//! fine profile, merged layers with what they leave out ratio-tracked.
//!
//! Optical depths through concentric shells cost one square root per level a
//! ray crosses, so a 1000-level radiosonde or model profile makes every
//! flight and every sun connection ~20× dearer than a 45-level AFGL one.
//! With `tracking_layers = "merged"` (what "auto" picks for a layered,
//! spherical profile of more than [`AUTO_MIN_LAYERS`] layers with analytic
//! shadow rays), paths are tracked through merged layers instead: runs of adjacent layers
//! in which every basis vector's σ varies by at most [`MERGE_SPREAD`] of its
//! largest value, each with the column-preserving mean σ̄ of its layers.
//!
//! - Flights draw their collisions, and every density the path's MIS
//!   weights and sun-aware points use, from σ̄: a sampling technique like
//!   any other, so the estimator stays unbiased as long as the integrand
//!   is the true one.
//! - The integrand's optics at a point (σ_s, phase matrices) are the
//!   profile layer's at that altitude.
//! - Its transmittances, along a flight to any point and along shadow
//!   rays, are e^(−τ̄_w)·Π_i (1 − r_w(x_i)/μ): τ̄_w the merged layers'
//!   depth (closed form, one square root per merged level), r_w = σ_w −
//!   σ̄_w the residual at points x_i drawn along the ray at rate μ ≥ |r_w|
//!   in each merged layer (μ = [`RATE_SCALE`]·Σ_b max_w |W_wb|·max|σ_b − σ̄_b|,
//!   twice the most any channel's residual can be there). The product's
//!   expectation is e^(−∫r_w), so the estimate's is e^(−τ_w) exactly:
//!   residual ratio tracking (Novák et al. 2014; `residual`). A flight
//!   draws its points once and every point along it uses those before it.
//!
//! The expected number of points along a ray is ∫μ, a fraction of τ̄, so
//! most rays draw none (their integral of μ is in closed form too, and
//! only a ray that draws a point walks its merged layers); a point costs
//! one search of the profile's levels inside its merged layer.

use crate::transport::medium::density_steps;

/// The most a basis vector's σ may vary inside a merged layer, as a
/// fraction of its largest value there (chosen by measurement: docs/design.md,
/// "Fine profiles").
pub const MERGE_SPREAD: f64 = 0.25;

/// The residual's rate over the most |σ − σ̄| in a merged layer: the
/// relative variance of ratio tracking, e^(∫r²/μ) − 1, falls as 1/μ while
/// its points grow as μ (chosen by measurement: docs/design.md, "Fine profiles").
pub const RATE_SCALE: f64 = 2.0;

/// The profile's layer count above which `tracking_layers = "auto"`
/// tracks paths through merged layers.
pub const AUTO_MIN_LAYERS: usize = 100;

/// The layers paths are tracked through, with each basis vector's σ.
#[derive(Debug, Clone)]
pub(super) struct Tracking {
    /// The levels (the profile's, or a subset with both ends kept).
    pub(super) levels_km: Vec<f64>,
    /// σ per layer and basis vector (`[layer·basis + b]`).
    pub(super) sigma: Vec<f64>,
    /// Its steps per level (`[b·levels + level]`, see `Medium::steps`).
    pub(super) steps: Vec<f64>,
    /// Whether layers were merged (else nothing is left to ratio-track).
    pub(super) merged: bool,
    /// Each tracking level's index among the profile's levels.
    profile_level: Vec<usize>,
    /// [`RATE_SCALE`] × max |σ − σ̄| per merged layer and basis vector
    /// (the residual's rate, `residual`), and its steps.
    pub(super) residual: Vec<f64>,
    pub(super) residual_steps: Vec<f64>,
}

impl Tracking {
    /// Tracking through the profile's own layers.
    pub(super) fn exact(levels_km: &[f64], sigma: &[f64], steps: Vec<f64>) -> Tracking {
        Tracking {
            levels_km: levels_km.to_vec(),
            sigma: sigma.to_vec(),
            steps,
            merged: false,
            profile_level: (0..levels_km.len()).collect(),
            residual: Vec::new(),
            residual_steps: Vec::new(),
        }
    }

    /// Tracking through merged layers of a layered medium with `basis`
    /// vectors of σ per layer (`sigma[layer·basis + b]`) between
    /// `levels_km`.
    pub(super) fn merged(levels_km: &[f64], sigma: &[f64], basis: usize) -> Tracking {
        let layers = levels_km.len() - 1;
        let sigma_of = |l: usize| &sigma[l * basis..(l + 1) * basis];
        // Merge greedily from the ground: a layer joins the run while
        // every basis vector's spread stays within MERGE_SPREAD of its
        // largest value over the run.
        let mut profile_level = vec![0];
        let (mut lo, mut hi) = (sigma_of(0).to_vec(), sigma_of(0).to_vec());
        for l in 1..layers {
            let fits = sigma_of(l).iter().enumerate().all(|(b, &s)| {
                let (a, z) = (lo[b].min(s), hi[b].max(s));
                z - a <= MERGE_SPREAD * z
            });
            if fits {
                for (b, &s) in sigma_of(l).iter().enumerate() {
                    lo[b] = lo[b].min(s);
                    hi[b] = hi[b].max(s);
                }
            } else {
                profile_level.push(l);
                lo.copy_from_slice(sigma_of(l));
                hi.copy_from_slice(sigma_of(l));
            }
        }
        profile_level.push(layers);
        let merged = profile_level.len() - 1;
        let mut mean = vec![0.0; merged * basis];
        let mut residual = vec![0.0; merged * basis];
        for m in 0..merged {
            let run = profile_level[m]..profile_level[m + 1];
            let thickness = levels_km[run.end] - levels_km[run.start];
            for b in 0..basis {
                let column: f64 = run
                    .clone()
                    .map(|l| sigma_of(l)[b] * (levels_km[l + 1] - levels_km[l]))
                    .sum();
                let s = column / thickness;
                mean[m * basis + b] = s;
                residual[m * basis + b] =
                    RATE_SCALE * run.clone().map(|l| (sigma_of(l)[b] - s).abs()).fold(0.0, f64::max);
            }
        }
        let steps_of = |v: &[f64]| -> Vec<f64> {
            (0..basis)
                .flat_map(|b| density_steps(&(0..merged).map(|m| v[m * basis + b]).collect::<Vec<_>>()))
                .collect()
        };
        let (steps, residual_steps) = (steps_of(&mean), steps_of(&residual));
        Tracking {
            levels_km: profile_level.iter().map(|&k| levels_km[k]).collect(),
            sigma: mean,
            steps,
            merged: true,
            profile_level,
            residual,
            residual_steps,
        }
    }

    /// The number of tracking layers.
    pub(super) fn layers(&self) -> usize {
        self.levels_km.len() - 1
    }

    /// The profile's layer at altitude `z` (km) inside tracking layer `m`
    /// (`profile_km` the profile's levels).
    #[inline]
    pub(super) fn profile_layer(&self, profile_km: &[f64], m: usize, z: f64) -> usize {
        let (first, last) = (self.profile_level[m], self.profile_level[m + 1] - 1);
        (first + profile_km[first + 1..=last].partition_point(|&level| level <= z)).min(last)
    }

    /// The profile layer in the middle of tracking layer `m` (`m` itself
    /// where nothing is merged).
    pub(super) fn middle_layer(&self, m: usize) -> usize {
        (self.profile_level[m] + self.profile_level[m + 1] - 1) / 2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merged_layers_keep_each_column_and_bound_the_residual() {
        // An exponential profile over 100 m layers and a second vector
        // that is zero below 2 km: merged runs never mix zero and non-zero,
        // keep every column, and bound |σ − σ̄| by the spread.
        let levels: Vec<f64> = (0..=300).map(|i| 0.1 * i as f64).collect();
        let layers = levels.len() - 1;
        let mut sigma = Vec::new();
        for l in 0..layers {
            let z = 0.5 * (levels[l] + levels[l + 1]);
            sigma.push(0.012 * (-z / 8.0).exp());
            sigma.push(if z < 2.0 { 0.0 } else { 1e-3 * (-z / 1.5).exp() });
        }
        let c = Tracking::merged(&levels, &sigma, 2);
        assert!(c.layers() < layers / 5, "{} merged layers", c.layers());
        assert_eq!(c.levels_km.first(), levels.first());
        assert_eq!(c.levels_km.last(), levels.last());
        assert!(
            c.profile_level.contains(&20),
            "a merged level where the second vector starts"
        );
        for m in 0..c.layers() {
            let run = c.profile_level[m]..c.profile_level[m + 1];
            for b in 0..2 {
                let fine: f64 = run.clone().map(|l| sigma[l * 2 + b] * 0.1).sum();
                let merged = c.sigma[m * 2 + b] * (c.levels_km[m + 1] - c.levels_km[m]);
                assert!((fine - merged).abs() <= 1e-12 * fine.max(1e-300), "column of {m}/{b}");
                let top = run.clone().map(|l| sigma[l * 2 + b]).fold(0.0, f64::max);
                assert!(c.residual[m * 2 + b] <= RATE_SCALE * MERGE_SPREAD * top * (1.0 + 1e-12));
            }
            // Every altitude inside the merged layer finds its own layer.
            for l in run {
                let z = 0.5 * (levels[l] + levels[l + 1]);
                assert_eq!(c.profile_layer(&levels, m, z), l);
            }
        }
    }
}
