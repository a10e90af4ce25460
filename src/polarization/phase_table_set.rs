//! A set of tabulated phase matrices on one grid of μ = cos Θ: the tables a
//! scene's aerosol scatters with (one per component, humidity and
//! tabulated wavelength). Sharing the grid lets a scattering angle be
//! located once for every table and channel that evaluates it.

use crate::error::{Error, Result};
use crate::polarization::phase::PhaseSample;
use crate::polarization::stokes::PhaseMatrix;
use crate::polarization::tabulated_phase::TabulatedPhaseMatrix;

/// Tabulated phase matrices on one μ grid (possibly none).
#[derive(Debug, Clone, Default)]
pub struct PhaseTableSet {
    tables: Vec<TabulatedPhaseMatrix>,
}

/// A scattering angle located on a set's grid ([`PhaseTableSet::locate`]).
#[derive(Debug, Clone, Copy)]
pub struct Located<'a> {
    pub cos_theta: f64,
    set: &'a PhaseTableSet,
    segment: usize,
    weight: f64,
}

impl PhaseTableSet {
    /// The set without tables.
    pub const EMPTY: PhaseTableSet = PhaseTableSet { tables: Vec::new() };

    /// The set of `tables`, which must all have the same μ nodes.
    pub fn new(tables: Vec<TabulatedPhaseMatrix>) -> Result<PhaseTableSet> {
        if let Some(first) = tables.first()
            && let Some(i) = tables.iter().position(|t| t.mu_nodes() != first.mu_nodes())
        {
            return Err(Error::data(
                "aerosol phase tables",
                format!("table {i} is not on the scattering angles of table 0"),
            ));
        }
        Ok(PhaseTableSet { tables })
    }

    /// The number of tables.
    pub fn len(&self) -> usize {
        self.tables.len()
    }

    /// Whether the set has no table.
    pub fn is_empty(&self) -> bool {
        self.tables.is_empty()
    }

    /// Table `k`.
    pub fn table(&self, k: usize) -> &TabulatedPhaseMatrix {
        &self.tables[k]
    }

    /// `cos_theta` located on the set's grid, for every table at once.
    #[inline]
    pub fn locate(&self, cos_theta: f64) -> Located<'_> {
        let (segment, weight) = self.tables.first().map_or((0, 0.0), |t| t.locate(cos_theta));
        Located {
            cos_theta,
            set: self,
            segment,
            weight,
        }
    }

    /// Samples table `k` ([`TabulatedPhaseMatrix::sample`]).
    #[inline]
    pub fn sample(&self, k: usize, u: [f64; 2]) -> PhaseSample {
        self.tables[k].sample(u)
    }
}

impl Located<'_> {
    /// Table `k`'s phase matrix at this angle.
    #[inline]
    pub fn matrix(&self, k: usize) -> PhaseMatrix {
        self.set.tables[k].matrix_on(self.segment, self.weight)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(angles: &[f64], f: impl Fn(f64) -> f64) -> TabulatedPhaseMatrix {
        let p11: Vec<f64> = angles.iter().map(|a| f(*a)).collect();
        let p12: Vec<f64> = angles.iter().map(|a| -0.1 * f(*a) * a.to_radians().sin()).collect();
        let zero = vec![0.0; angles.len()];
        TabulatedPhaseMatrix::new("t", angles, &p11, &p12, &zero, &zero).unwrap()
    }

    #[test]
    fn a_located_angle_gives_each_tables_own_matrix() {
        let angles = [0.0, 1.0, 10.0, 45.0, 90.0, 135.0, 180.0];
        let set = PhaseTableSet::new(vec![
            table(&angles, |a| 10.0 / (1.0 + a)),
            table(&angles, |a| 1.0 + 0.01 * a),
        ])
        .unwrap();
        for k in 0..set.len() {
            for i in 0..=200 {
                let mu = -1.0 + i as f64 / 100.0;
                assert_eq!(set.locate(mu).matrix(k), set.table(k).matrix(mu), "{k} {mu}");
            }
        }
    }

    #[test]
    fn tables_on_different_grids_are_refused() {
        let a = table(&[0.0, 90.0, 180.0], |_| 1.0);
        let b = table(&[0.0, 45.0, 180.0], |_| 1.0);
        assert!(PhaseTableSet::new(vec![a.clone(), a.clone()]).is_ok());
        let e = PhaseTableSet::new(vec![a, b]).unwrap_err().to_string();
        assert!(e.contains("table 1"), "{e}");
    }
}
