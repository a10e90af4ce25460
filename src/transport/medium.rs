//! One wavelength's medium: per-layer coefficients, the density model
//! inside a layer and the majorant; what transmittance tables track
//! through (the path tracer, `spectral`, holds the same models for any
//! number of channels, on the atmosphere's terms).
//!
//! - `layered` (default, libRadtran-compatible): coefficients constant in
//!   each layer; the majorant is σ_t itself, so every tentative collision is
//!   real and optical depth along a ray is exact (Σ σ_t × chord).
//! - `smooth`: inside a layer the air density varies exponentially between
//!   the levels and the ozone mixing ratio linearly (the profile's own
//!   interpolation, see `atmosphere::LayerShape`), aerosol constant. Each
//!   layer's optical depth per unit thickness is the same as `layered`; the
//!   tracer uses per-layer majorants (the bound of σ_t over the layer).
//!   Explicit layers have no inner structure: `smooth` equals `layered`.
//!
//! `majorant_scale` ≥ 1 inflates every majorant (for testing the trackers).

use crate::job::options::MediumModel;
use glam::DVec3;

use crate::atmosphere::Atmosphere;
use crate::atmosphere::layer_shape::LayerShape;
use crate::atmosphere::optics::{Optics, PointOptics};
use crate::geometry::shell::Geometry;

/// The medium at one wavelength.
#[derive(Debug, Clone)]
pub struct Medium {
    levels_km: Vec<f64>,
    layers: Vec<Optics>,
    shapes: Option<Vec<LayerShape>>,
    sigma_maj: Vec<f64>,
    /// σ_t of each layer (its mean for `smooth`).
    sigma_t_layer: Vec<f64>,
    /// σ_maj's step at each level k, σ_maj(k − 1) − σ_maj(k), with zero
    /// below the ground and above the top (`levels_km.len()` entries): the
    /// coefficients of the closed-form optical depth through shells.
    steps: Vec<f64>,
}

/// Gauss–Legendre nodes and weights on [0, 1] (8 points, exact for
/// polynomials of degree 15) for optical depth in the smooth medium.
const GAUSS_8: [(f64, f64); 8] = [
    (0.019_855_071_751_231_86, 0.050_614_268_145_188_13),
    (0.101_666_761_293_186_6, 0.111_190_517_226_687_2),
    (0.237_233_795_041_835_5, 0.156_853_322_938_943_6),
    (0.408_282_678_752_175, 0.181_341_891_689_181),
    (0.591_717_321_247_825, 0.181_341_891_689_181),
    (0.762_766_204_958_164_5, 0.156_853_322_938_943_6),
    (0.898_333_238_706_813_4, 0.111_190_517_226_687_2),
    (0.980_144_928_248_768_2, 0.050_614_268_145_188_13),
];

impl Medium {
    /// The medium of wavelength index `w` of `atm`.
    pub fn new(atm: &Atmosphere, w: usize, model: MediumModel, majorant_scale: f64) -> Medium {
        let layers = atm.optics[w].clone();
        let shapes = match model {
            MediumModel::Layered => None,
            MediumModel::Smooth => atm.layer_shapes.clone(),
        };
        let sigma_maj = layers
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let bound = match &shapes {
                    None => o.sigma_t(),
                    Some(s) => {
                        let (fr, fo) = s[i].max_factors();
                        o.sigma_rayleigh * fr + o.sigma_absorption * fo + o.sigma_aerosol_ext
                    }
                };
                bound * majorant_scale
            })
            .collect();
        Medium::assemble(
            atm.levels_km.clone(),
            layers.iter().map(Optics::sigma_t).collect(),
            layers,
            shapes,
            sigma_maj,
        )
    }

    /// The medium with its derived fields (steps).
    fn assemble(
        levels_km: Vec<f64>,
        sigma_t_layer: Vec<f64>,
        layers: Vec<Optics>,
        shapes: Option<Vec<LayerShape>>,
        sigma_maj: Vec<f64>,
    ) -> Medium {
        let steps = density_steps(&sigma_maj);
        Medium {
            levels_km,
            layers,
            shapes,
            sigma_maj,
            sigma_t_layer,
            steps,
        }
    }

    /// The same medium tracked against other majorants (each at least this
    /// medium's own): for sharing tentative collisions between wavelengths.
    pub fn with_majorants(&self, sigma_maj: Vec<f64>) -> Medium {
        debug_assert!(sigma_maj.iter().zip(&self.sigma_maj).all(|(a, b)| a >= b));
        self.with_sigma_maj(sigma_maj)
    }

    fn with_sigma_maj(&self, sigma_maj: Vec<f64>) -> Medium {
        Medium::assemble(
            self.levels_km.clone(),
            self.sigma_t_layer.clone(),
            self.layers.clone(),
            self.shapes.clone(),
            sigma_maj,
        )
    }

    /// The layer's mean σ_t (km⁻¹): the control of residual ratio tracking.
    pub fn layer_sigma_t(&self, i: usize) -> f64 {
        self.sigma_t_layer[i]
    }

    /// A bound on |σ_t(z) − mean σ_t| over layer `i` (0 for `layered`).
    pub fn residual_bound(&self, i: usize) -> f64 {
        match &self.shapes {
            None => 0.0,
            Some(s) => {
                let o = &self.layers[i];
                let (hr, ho) = s[i].max_factors();
                let (lr, lo) = s[i].min_factors();
                let hi = o.sigma_rayleigh * hr + o.sigma_absorption * ho + o.sigma_aerosol_ext;
                let lo = o.sigma_rayleigh * lr + o.sigma_absorption * lo + o.sigma_aerosol_ext;
                let mean = self.sigma_t_layer[i];
                (hi - mean).max(mean - lo).max(0.0)
            }
        }
    }

    /// The same medium with majorants for the residual σ_t − σ̄ (see
    /// [`Medium::residual_bound`]), for residual ratio tracking.
    pub fn with_residual_majorants(&self, bounds: Vec<f64>) -> Medium {
        self.with_sigma_maj(bounds)
    }

    /// Layer boundaries (km), ascending from the ground.
    pub fn levels_km(&self) -> &[f64] {
        &self.levels_km
    }

    /// The majorant of layer `i` (km⁻¹).
    #[inline]
    pub fn sigma_maj(&self, i: usize) -> f64 {
        self.sigma_maj[i]
    }

    /// The majorant's step at each level, σ_maj(k − 1) − σ_maj(k) (zero
    /// outside the atmosphere): see [`crate::geometry::shell_exit::shell_exit`].
    #[inline]
    pub fn steps(&self) -> &[f64] {
        &self.steps
    }

    /// Coefficients in layer `i` at altitude `z_km`.
    #[inline]
    pub fn at(&self, i: usize, z_km: f64) -> PointOptics {
        self.at_altitude_of(i, || z_km)
    }

    /// Coefficients in layer `i` at the altitude `z_km()`, called only for a
    /// `smooth` medium (a layered one is constant in the layer; the
    /// altitude of a point in spherical shells costs a square root).
    #[inline]
    pub fn at_altitude_of(&self, i: usize, z_km: impl FnOnce() -> f64) -> PointOptics {
        let o = &self.layers[i];
        let (fr, fo) = match &self.shapes {
            None => (1.0, 1.0),
            Some(s) => {
                let f = ((z_km() - self.levels_km[i]) / (self.levels_km[i + 1] - self.levels_km[i])).clamp(0.0, 1.0);
                (s[i].rayleigh_factor(f), s[i].ozone_factor(f))
            }
        };
        let sigma_rayleigh = o.sigma_rayleigh * fr;
        PointOptics {
            sigma_t: sigma_rayleigh + o.sigma_absorption * fo + o.sigma_aerosol_ext,
            sigma_rayleigh,
            sigma_aerosol_sca: o.sigma_aerosol_sca,
            rayleigh_depolarization: o.rayleigh_depolarization,
            aerosol_g: o.aerosol_g,
        }
    }

    /// Optical depth of the straight segment `origin + t·dir`, t ∈ [t0, t1],
    /// inside layer `i`: exact for `layered`; for `smooth`, the layer's
    /// coefficients times [`shape_integrals`].
    pub fn segment_optical_depth(
        &self,
        geometry: &Geometry,
        origin: DVec3,
        dir: DVec3,
        i: usize,
        t0: f64,
        t1: f64,
    ) -> f64 {
        let Some(shapes) = &self.shapes else {
            return self.sigma_t_layer[i] * (t1 - t0);
        };
        let o = &self.layers[i];
        let layer = (self.levels_km[i], self.levels_km[i + 1]);
        let [air, ozone, length] = shape_integrals(&shapes[i], layer, geometry, origin, dir, t0, t1);
        o.sigma_rayleigh * air + o.sigma_absorption * ozone + o.sigma_aerosol_ext * length
    }
}

/// The integrals of a smooth layer's shape factors along the straight
/// segment `origin + t·dir`, t ∈ [t0, t1], inside the layer between the
/// altitudes `layer` (km): [∫ air factor, ∫ ozone factor, length] (see
/// [`LayerShape`]). 8-point Gauss–Legendre on pieces of at most 0.1 of
/// the layer's thickness in altitude change (relative error below 1e-10
/// for AFGL layers).
pub fn shape_integrals(
    shape: &LayerShape,
    layer: (f64, f64),
    geometry: &Geometry,
    origin: DVec3,
    dir: DVec3,
    t0: f64,
    t1: f64,
) -> [f64; 3] {
    let dz = layer.1 - layer.0;
    let z0 = geometry.altitude(origin + t0 * dir);
    let z1 = geometry.altitude(origin + t1 * dir);
    // Altitude is not monotonic along a limb chord; split finely enough.
    let pieces =
        (((z1 - z0).abs() / (0.1 * dz)).ceil() as usize).clamp(1, 64) * if (t1 - t0) > 4.0 * dz { 4 } else { 1 };
    let h = (t1 - t0) / pieces as f64;
    let (mut air, mut ozone) = (0.0, 0.0);
    for k in 0..pieces {
        let a = t0 + k as f64 * h;
        for (x, w) in GAUSS_8 {
            let z = geometry.altitude(origin + (a + x * h) * dir);
            let f = ((z - layer.0) / dz).clamp(0.0, 1.0);
            air += w * h * shape.rayleigh_factor(f);
            ozone += w * h * shape.ozone_factor(f);
        }
    }
    [air, ozone, t1 - t0]
}

/// σ(k − 1) − σ(k) at each level k = 0..=n of n layers, σ zero outside.
pub(crate) fn density_steps(sigma: &[f64]) -> Vec<f64> {
    let at = |k: usize| sigma.get(k).copied().unwrap_or(0.0);
    (0..=sigma.len())
        .map(|k| if k == 0 { -at(0) } else { at(k - 1) - at(k) })
        .collect()
}

/// The medium of the built-in profile atmosphere with OPAC
/// continental_average at 340 nm (the tests' medium with aerosol and ozone).
#[cfg(test)]
pub(crate) fn test_medium(model: MediumModel, scale: f64) -> Medium {
    let text = "[atmosphere]\naerosol = \"continental_average\"\n[spectrum]\nwavelengths_nm = [340.0]\n";
    let job = crate::job::Job::parse(text, "t", std::path::Path::new(".")).expect("a valid job");
    Medium::new(&job.atmosphere, 0, model, scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::Job;
    use std::path::Path;

    fn atmosphere() -> Atmosphere {
        let text = "[atmosphere]\naerosol = \"continental_average\"\n[spectrum]\nwavelengths_nm = [320.0]\n";
        Job::parse(text, "t", Path::new(".")).unwrap().atmosphere
    }

    #[test]
    fn smooth_layers_keep_the_layered_optical_depth() {
        let atm = atmosphere();
        let layered = Medium::new(&atm, 0, MediumModel::Layered, 1.0);
        let smooth = Medium::new(&atm, 0, MediumModel::Smooth, 1.0);
        let g = Geometry::PlaneParallel;
        for i in 0..atm.layer_count() {
            let (z0, z1) = (atm.levels_km[i], atm.levels_km[i + 1]);
            let o = DVec3::new(0.0, 0.0, z0);
            let a = layered.segment_optical_depth(&g, o, DVec3::Z, i, 0.0, z1 - z0);
            let b = smooth.segment_optical_depth(&g, o, DVec3::Z, i, 0.0, z1 - z0);
            assert!((a / b - 1.0).abs() < 1e-10, "layer {i}: {a} vs {b}");
        }
    }

    #[test]
    fn smooth_majorant_bounds_sigma_t_and_density_falls_with_height() {
        let atm = atmosphere();
        let m = Medium::new(&atm, 0, MediumModel::Smooth, 1.0);
        for i in 0..atm.layer_count() {
            let (z0, z1) = (atm.levels_km[i], atm.levels_km[i + 1]);
            for k in 0..=100 {
                let z = z0 + (z1 - z0) * k as f64 / 100.0;
                assert!(m.at(i, z).sigma_t <= m.sigma_maj(i) * (1.0 + 1e-12));
            }
            assert!(m.at(i, z0).sigma_rayleigh > m.at(i, z1).sigma_rayleigh);
        }
    }

    #[test]
    fn smooth_quadrature_matches_a_fine_midpoint_sum_on_a_limb_chord() {
        let atm = atmosphere();
        let m = Medium::new(&atm, 0, MediumModel::Smooth, 1.0);
        let r = 6378.0;
        let g = Geometry::Spherical { radius_km: r };
        // Horizontal ray at 3.5 km: inside layer 3 (3–4 km) until it leaves
        // through the 4 km shell.
        let o = DVec3::new(0.0, 0.0, r + 3.5);
        let t1 = ((r + 4.0f64).powi(2) - (r + 3.5f64).powi(2)).sqrt();
        let quad = m.segment_optical_depth(&g, o, DVec3::X, 3, 0.0, t1);
        let n = 200_000;
        let h = t1 / n as f64;
        let mid: f64 = (0..n)
            .map(|k| m.at(3, g.altitude(o + (k as f64 + 0.5) * h * DVec3::X)).sigma_t * h)
            .sum();
        assert!((quad / mid - 1.0).abs() < 1e-8, "{quad} vs {mid}");
    }
}
