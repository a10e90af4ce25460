//! Layer optics as a short sum of terms, each a wavelength-independent
//! amount per layer times a per-unit-amount spectral response:
//!
//! optics(layer, λ) = Σ_t amount_t(layer) · response_t(λ)
//!
//! The profile atmospheres separate this way exactly: Rayleigh is the air
//! number density times one cross section; ozone is its number density
//! times a cross section quadratic in T − T₀, i.e. three terms with amounts
//! n_O₃·(T − T₀)ᵏ; an OPAC aerosol is each component's mass density times
//! its mass coefficients at the layer's tabulated humidity (one term per
//! component and humidity). Explicit layers and explicit aerosol layers do
//! not depend on λ: constant responses.
//!
//! This is what lets a path draw its own wavelengths inside bands: the
//! per-path work is one response per term and channel, and the optical
//! depth of a ray for every channel is Σ_t response_t·τ_t, with one column
//! τ_t per extinction term, whatever the number of channels.

use std::sync::Arc;

use crate::atmosphere::layer_shape::LayerShape;
use crate::atmosphere::optics::PointOptics;
use crate::physics::aerosol::Component;
use crate::physics::kdistribution::{CollisionPairs, Gas, KDistributions, Scaling};
use crate::physics::mie::tables::PhaseTables;
use crate::physics::ozone::CrossSection;
use crate::physics::rayleigh;

/// A term's optics per unit amount at one wavelength (km⁻¹ per unit).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TermOptics {
    /// Extinction.
    pub ext: f64,
    /// Rayleigh scattering.
    pub rayleigh: f64,
    /// Rayleigh depolarisation factor × Rayleigh scattering.
    pub rho_rayleigh: f64,
    /// Aerosol scattering.
    pub aerosol_sca: f64,
    /// Aerosol asymmetry parameter g × aerosol scattering.
    pub g_aerosol_sca: f64,
}

impl TermOptics {
    fn add_scaled(&mut self, r: &TermOptics, k: f64) {
        self.ext += k * r.ext;
        self.rayleigh += k * r.rayleigh;
        self.rho_rayleigh += k * r.rho_rayleigh;
        self.aerosol_sca += k * r.aerosol_sca;
        self.g_aerosol_sca += k * r.g_aerosol_sca;
    }

    /// The point coefficients these sums stand for.
    pub fn coefficients(&self) -> PointOptics {
        let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
        PointOptics {
            sigma_t: self.ext,
            sigma_rayleigh: self.rayleigh,
            sigma_aerosol_sca: self.aerosol_sca,
            rayleigh_depolarization: ratio(self.rho_rayleigh, self.rayleigh),
            aerosol_g: ratio(self.g_aerosol_sca, self.aerosol_sca),
        }
    }
}

/// One part of the optics, for terms that add to it alone (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    Extinction,
    Rayleigh,
    RhoRayleigh,
    AerosolScattering,
    GAerosolScattering,
}

impl TermOptics {
    /// One unit of `part`, nothing else.
    pub fn unit(part: Part) -> TermOptics {
        let mut r = TermOptics::default();
        *match part {
            Part::Extinction => &mut r.ext,
            Part::Rayleigh => &mut r.rayleigh,
            Part::RhoRayleigh => &mut r.rho_rayleigh,
            Part::AerosolScattering => &mut r.aerosol_sca,
            Part::GAerosolScattering => &mut r.g_aerosol_sca,
        } = 1.0;
        r
    }
}

/// How far (nm) [`Spectrum::may_respond_in`] looks past a band's edges.
pub const BAND_EDGE_MARGIN_NM: f64 = 1e-6;

/// How a term's response depends on λ (closed set).
#[derive(Debug, Clone)]
pub enum Spectrum {
    /// The same at every wavelength.
    Constant(TermOptics),
    /// Air: Bodhaine's cross section (cm²) and depolarisation, for a CO₂
    /// mixing ratio.
    Air { co2_ratio: f64 },
    /// Ozone absorption: coefficient `power` of the cross section's
    /// quadratic in T − T₀ (cm² K⁻ᵖᵒʷᵉʳ).
    Ozone { table: Arc<CrossSection>, power: usize },
    /// An OPAC component's mass coefficients at humidity index `rh`, and
    /// its phase matrices there (`None`: it scatters by Henyey–Greenstein
    /// with its g).
    Aerosol {
        component: Arc<Component>,
        rh: usize,
        phase: Option<Arc<PhaseTables>>,
    },
    /// A molecular absorber of the wide range (`gas_terms`).
    Gas { gas: Gas, response: GasResponse },
}

/// How a gas term's absorption per unit amount depends on λ (closed set).
#[derive(Debug, Clone)]
pub enum GasResponse {
    /// A k-distribution gas's pseudo-spectrum (cm²) in its bands of one
    /// amount scaling (0 in its other bands and outside them).
    Bands {
        table: &'static KDistributions,
        scaling: Scaling,
    },
    /// The O₂–O₂ collision-induced cross section (cm⁵).
    Pairs(&'static CollisionPairs),
    /// Coefficient `power` of a cross section quadratic in T − T₀ (NO₂).
    CrossSection { table: Arc<CrossSection>, power: usize },
}

impl GasResponse {
    /// The absorption per unit amount of `gas` at λ.
    pub fn at(&self, gas: Gas, lambda_nm: f64) -> f64 {
        match self {
            GasResponse::Bands { table, scaling } => table
                .band_at(gas, lambda_nm)
                .filter(|b| b.scaling == *scaling)
                .map_or(0.0, |b| b.k_cm2(lambda_nm)),
            GasResponse::Pairs(table) => table.sigma_cm5(lambda_nm),
            GasResponse::CrossSection { table, power } => table.coefficient_cm2(lambda_nm, *power).unwrap_or(0.0),
        }
    }
}

impl Spectrum {
    /// Whether the response may be other than zero somewhere in [lo, hi]
    /// nm: false only for a k-distribution gas's term of one amount
    /// scaling when no band of that scaling overlaps the interval widened
    /// by [`BAND_EDGE_MARGIN_NM`] (a wavelength drawn at a band's edge may
    /// round onto the next band's), so skipping it changes no response.
    pub fn may_respond_in(&self, (lo_nm, hi_nm): (f64, f64)) -> bool {
        match self {
            Spectrum::Gas {
                gas,
                response: GasResponse::Bands { table, scaling },
            } => table
                .scalings(*gas, (lo_nm - BAND_EDGE_MARGIN_NM, hi_nm + BAND_EDGE_MARGIN_NM))
                .contains(scaling),
            _ => true,
        }
    }

    /// Whether the term adds to extinction (at some wavelength).
    pub fn has_extinction(&self) -> bool {
        match self {
            Spectrum::Constant(r) => r.ext != 0.0,
            Spectrum::Air { .. } | Spectrum::Ozone { .. } | Spectrum::Aerosol { .. } | Spectrum::Gas { .. } => true,
        }
    }

    /// The response at λ (nm); zero outside the data (the atmosphere checks
    /// every requested wavelength and band against the data's range).
    pub fn response(&self, lambda_nm: f64) -> TermOptics {
        match self {
            Spectrum::Constant(r) => *r,
            Spectrum::Air { co2_ratio } => {
                let s = rayleigh::cross_section_cm2(lambda_nm, *co2_ratio);
                TermOptics {
                    ext: s,
                    rayleigh: s,
                    rho_rayleigh: s * rayleigh::depolarization(lambda_nm, *co2_ratio),
                    ..TermOptics::default()
                }
            }
            Spectrum::Ozone { table, power } => TermOptics {
                ext: table.coefficient_cm2(lambda_nm, *power).unwrap_or(0.0),
                ..TermOptics::default()
            },
            Spectrum::Aerosol { component, rh, .. } => match component.optics(lambda_nm, *rh) {
                Some(o) => TermOptics {
                    ext: o.k_ext,
                    aerosol_sca: o.k_sca,
                    g_aerosol_sca: o.g * o.k_sca,
                    ..TermOptics::default()
                },
                None => TermOptics::default(),
            },
            Spectrum::Gas { gas, response } => TermOptics {
                ext: response.at(*gas, lambda_nm),
                ..TermOptics::default()
            },
        }
    }
}

/// One term: its amount in each layer and its spectrum.
#[derive(Debug, Clone)]
pub struct Term {
    pub amount: Vec<f64>,
    pub spectrum: Spectrum,
}

/// How a term's amount varies inside a layer of the smooth medium
/// (closed set; see `medium` and [`crate::atmosphere::layer_shape::LayerShape`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TermShape {
    /// Constant (aerosols, explicit layers).
    Flat,
    /// As the air density (Rayleigh).
    Air,
    /// As the ozone density (ozone absorption).
    Ozone,
}

impl TermShape {
    /// The index of this shape's factor in [`crate::transport::medium::shape_integrals`].
    pub fn index(self) -> usize {
        match self {
            TermShape::Air => 0,
            TermShape::Ozone => 1,
            TermShape::Flat => 2,
        }
    }

    /// The factor at fraction `f` of a layer of `shape` (1 without one).
    pub fn factor(self, shape: Option<&LayerShape>, f: f64) -> f64 {
        match (self, shape) {
            (TermShape::Air, Some(s)) => s.rayleigh_factor(f),
            (TermShape::Ozone, Some(s)) => s.ozone_factor(f),
            _ => 1.0,
        }
    }

    /// The largest factor over a layer of `shape`.
    pub fn max_factor(self, shape: Option<&LayerShape>) -> f64 {
        match (self, shape) {
            (TermShape::Air, Some(s)) => s.max_factors().0,
            (TermShape::Ozone, Some(s)) => s.max_factors().1,
            _ => 1.0,
        }
    }
}

impl Term {
    /// How the term varies inside a smooth layer.
    pub fn shape(&self) -> TermShape {
        match self.spectrum {
            // The wide range's gases vary as the air inside a layer: exact
            // for the well-mixed ones, an approximation for water vapour
            // (the layer's column is kept either way).
            Spectrum::Air { .. } | Spectrum::Gas { .. } => TermShape::Air,
            Spectrum::Ozone { .. } => TermShape::Ozone,
            Spectrum::Constant(_) | Spectrum::Aerosol { .. } => TermShape::Flat,
        }
    }
}

/// An atmosphere's layer optics as terms (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct SpectralTerms {
    pub terms: Vec<Term>,
}

impl SpectralTerms {
    /// Adds a term unless its amount is zero everywhere.
    pub fn push(&mut self, amount: Vec<f64>, spectrum: Spectrum) {
        if amount.iter().any(|&a| a != 0.0) {
            self.terms.push(Term { amount, spectrum });
        }
    }

    /// Adds a wavelength-independent term: `amount` of one `part`.
    pub fn push_constant(&mut self, amount: Vec<f64>, part: Part) {
        self.push(amount, Spectrum::Constant(TermOptics::unit(part)));
    }

    /// Every term's response at λ, in term order, into `out`.
    pub fn responses_into(&self, lambda_nm: f64, out: &mut [TermOptics]) {
        for (o, t) in out.iter_mut().zip(&self.terms) {
            *o = t.spectrum.response(lambda_nm);
        }
    }

    /// [`SpectralTerms::responses_into`] for the terms where `active` is
    /// true; zero for the others (terms known to respond nothing at λ,
    /// [`Spectrum::may_respond_in`]).
    pub fn active_responses_into(&self, lambda_nm: f64, active: &[bool], out: &mut [TermOptics]) {
        for ((o, t), &on) in out.iter_mut().zip(&self.terms).zip(active) {
            *o = if on {
                t.spectrum.response(lambda_nm)
            } else {
                TermOptics::default()
            };
        }
    }

    /// The summed responses of `layer` for one channel's `responses`.
    pub fn layer_sum(&self, layer: usize, responses: &[TermOptics]) -> TermOptics {
        self.point_sum(layer, responses, |_| 1.0)
    }

    /// The summed responses at a point of `layer`, each term's amount times
    /// `factor(term index)` (its shape factor there).
    pub fn point_sum(&self, layer: usize, responses: &[TermOptics], factor: impl Fn(usize) -> f64) -> TermOptics {
        let mut sum = TermOptics::default();
        for (k, (t, r)) in self.terms.iter().zip(responses).enumerate() {
            let a = t.amount[layer];
            if a != 0.0 {
                sum.add_scaled(r, a * factor(k));
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::job::Job;

    /// The terms give back the optics the atmosphere computes directly, at
    /// every layer and wavelength, for every kind of atmosphere.
    #[test]
    fn terms_reproduce_the_layer_optics() {
        let wavelengths = "[spectrum]\nwavelengths_nm = [320.0, 333.3, 404.7, 550.0, 687.1, 760.0]\n";
        let atmospheres = [
            "[atmosphere]\nozone = \"bogumil\"\naerosol = \"continental_average\"\nvisibility_km = 40.0\n",
            "[atmosphere]\nozone = \"molina\"\naerosol = \"continental_clean\"\n",
            "[atmosphere]\nozone = \"bogumil\"\naerosol = \"urban\"\nvisibility_km = 20.0\n",
            "[atmosphere]\naerosol = \"none\"\nozone = \"none\"\n",
            "[atmosphere]\nrayleigh = \"none\"\naerosol = \"continental_polluted\"\n",
            "[atmosphere]\n[[atmosphere.aerosol_layers]]\nbottom_km = 0.5\ntop_km = 2.5\ntau = 0.2\nssa = 0.8\ng = 0.6\n",
            "[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\ntau_rayleigh = 0.1\nrayleigh_depolarization = 0.03\n\
             tau_aerosol = 0.2\naerosol_ssa = 0.9\naerosol_g = 0.7\n[[atmosphere.layers]]\nbottom_km = 1.0\n\
             top_km = 30.0\ntau_rayleigh = 0.4\ntau_absorption = 0.05\n",
        ];
        for atm_text in atmospheres {
            let job = Job::parse(&format!("{atm_text}{wavelengths}"), "terms.toml", Path::new(".")).unwrap();
            let atm = &job.atmosphere;
            let terms = &atm.terms;
            let mut responses = vec![Default::default(); terms.terms.len()];
            for (w, &lambda) in atm.wavelengths_nm.iter().enumerate() {
                terms.responses_into(lambda, &mut responses);
                for (i, o) in atm.optics[w].iter().enumerate() {
                    let c = terms.layer_sum(i, &responses).coefficients();
                    let close = |a: f64, b: f64, what: &str| {
                        assert!(
                            (a - b).abs() <= 1e-12 * b.abs().max(1e-300),
                            "{atm_text}: {what} at {lambda} nm, layer {i}: {a:e} vs {b:e}"
                        )
                    };
                    close(c.sigma_t, o.sigma_t(), "sigma_t");
                    close(c.sigma_rayleigh, o.sigma_rayleigh, "sigma_rayleigh");
                    close(c.sigma_aerosol_sca, o.sigma_aerosol_sca, "sigma_aerosol_sca");
                    if o.sigma_rayleigh > 0.0 {
                        close(c.rayleigh_depolarization, o.rayleigh_depolarization, "depolarisation");
                    }
                    if o.sigma_aerosol_sca > 0.0 {
                        close(c.aerosol_g, o.aerosol_g, "g");
                    }
                }
            }
        }
    }

    /// A term that [`Spectrum::may_respond_in`] leaves out of a band
    /// responds nothing anywhere in it: every term of the wide range's 55
    /// bands and of bands straddling two of its 40 nm bands, at 2001
    /// wavelengths across each band, its edges included. And the gas terms
    /// are left out somewhere (the point of it).
    #[test]
    fn terms_left_out_of_a_band_respond_nothing_in_it() {
        let centres: Vec<String> = (0..55)
            .map(|i| format!("{:.1}", 300.0 + 40.0 * i as f64))
            .chain(["330.0", "945.5", "1379.99", "2455.0"].map(String::from))
            .collect();
        let text = format!(
            "[atmosphere]\naerosol = \"none\"\ngases = \"all\"\n[spectrum]\nwavelengths_nm = [{}]\nband_width_nm = 40.0\n",
            centres.join(", ")
        );
        let job = Job::parse(&text, "wide.toml", Path::new(".")).unwrap();
        let terms = &job.atmosphere.terms.terms;
        let mut left_out = 0;
        for c in &centres {
            let centre: f64 = c.parse().unwrap();
            let band = (centre - 20.0, centre + 20.0);
            for t in terms {
                if t.spectrum.may_respond_in(band) {
                    continue;
                }
                left_out += 1;
                for i in 0..=2000 {
                    let lambda = band.0 + 40.0 * i as f64 / 2000.0;
                    let r = t.spectrum.response(lambda);
                    assert_eq!(r, super::TermOptics::default(), "{c} nm band at {lambda} nm");
                }
            }
        }
        assert!(left_out > 100, "{left_out}");
    }
}
