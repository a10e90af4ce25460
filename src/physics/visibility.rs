//! Meteorological visibility (Koschmieder 1924): V = 3.912/β with β the
//! total extinction coefficient at 550 nm at the ground. A requested
//! visibility is met by scaling the aerosol of the boundary (mixing) layer:
//!
//!   β_ground(s) = β_Rayleigh + β_aerosol,free + s·β_aerosol,boundary,
//!   s = (3.912/V − β_Rayleigh − β_aerosol,free) / β_aerosol,boundary.
//!
//! Any visibility below the aerosol-free limit 3.912/(β_Rayleigh +
//! β_aerosol,free) is reachable (s ≥ 0); larger ones are not.

use crate::physics::constants::KOSCHMIEDER_CONSTANT;

/// Koschmieder visibility (km) for an extinction coefficient β (km⁻¹).
pub fn koschmieder_km(beta_per_km: f64) -> f64 {
    KOSCHMIEDER_CONSTANT / beta_per_km
}

/// Extinction at the ground at 550 nm, split as the scaling needs it (km⁻¹).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundExtinction {
    pub rayleigh: f64,
    /// Aerosol from rows that visibility scaling leaves alone.
    pub aerosol_free: f64,
    /// Aerosol of the boundary layer, which scaling multiplies.
    pub aerosol_boundary: f64,
}

impl GroundExtinction {
    /// Visibility (km) with the boundary layer scaled by `s`.
    pub fn visibility_km(&self, s: f64) -> f64 {
        koschmieder_km(self.rayleigh + self.aerosol_free + s * self.aerosol_boundary)
    }

    /// The largest reachable visibility (boundary layer free of aerosol).
    pub fn max_visibility_km(&self) -> f64 {
        self.visibility_km(0.0)
    }

    /// The boundary-layer scale for visibility `v_km`, or `None` when no
    /// non-negative scale reaches it.
    pub fn scale_for(&self, v_km: f64) -> Option<f64> {
        if !v_km.is_finite() || v_km <= 0.0 || self.aerosol_boundary <= 0.0 {
            return None;
        }
        let s = (KOSCHMIEDER_CONSTANT / v_km - self.rayleigh - self.aerosol_free) / self.aerosol_boundary;
        (s >= 0.0 && v_km < self.max_visibility_km()).then_some(s)
    }
}

/// How the ground visibility of an atmosphere came about.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Visibility {
    /// Ground visibility of the atmosphere as built (km).
    pub ground_km: f64,
    /// Ground visibility of the mixture as tabulated, unscaled (km).
    pub unscaled_km: f64,
    /// The boundary-layer scale applied (1 when unscaled).
    pub boundary_scale: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaling_reaches_the_request_exactly() {
        let g = GroundExtinction {
            rayleigh: 0.0115,
            aerosol_free: 0.001,
            aerosol_boundary: 0.0537,
        };
        for v in [5.0, 20.0, 59.4, 131.8, 250.0] {
            let s = g.scale_for(v).unwrap();
            assert!((g.visibility_km(s) / v - 1.0).abs() < 1e-12);
        }
        // 3.912 / 0.0125
        assert!((g.max_visibility_km() - 312.96).abs() < 1e-9);
        assert_eq!(g.scale_for(400.0), None);
        assert_eq!(g.scale_for(0.0), None);
        assert_eq!(g.scale_for(f64::NAN), None);
    }

    #[test]
    fn koschmieder_constant_is_the_two_percent_contrast_threshold() {
        assert!((koschmieder_km(1.0) - (1.0f64 / 0.02).ln()).abs() < 1e-3);
    }
}
