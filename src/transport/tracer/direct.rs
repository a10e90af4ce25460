//! The direct solar beam: its transmittance to the observer normal to the
//! beam and on a horizontal plane, per wavelength or averaged over a band's
//! cells from the columns of the extinction terms.

use std::ops::ControlFlow;

use crate::atmosphere::spectral_terms::TermOptics;
use crate::geometry::ray::{Ray, WalkEnd};
use crate::geometry::shell::Geometry;
use crate::transport::medium::shape_integrals;

use super::scene::{DIRECT_CELL_NM, Scene};
use super::vertex::sun_ray;

impl Scene {
    /// The direct solar irradiance on a horizontal plane at the observer
    /// in channel `w`: μ0·T(λ) (times E0 at λ, when radiances are
    /// weighted by one), averaged over the band by the composite midpoint
    /// rule on cells of at most [`DIRECT_CELL_NM`] (the ozone data's
    /// spacing is 0.1 nm); a monochromatic channel's value at its
    /// wavelength. Optical depths are exact: one column per extinction
    /// term along the sun's direction, Σ_t response_t(λ)·τ_t.
    #[inline]
    pub fn direct_horizontal(&self, altitude_km: f64, w: usize) -> f64 {
        let origin = self.geometry.observer_position(altitude_km);
        let mu0 = self.sun.direction.dot(self.geometry.up(origin));
        if mu0 <= 0.0 {
            return 0.0;
        }
        mu0 * self.direct_normal(altitude_km, w, true)
    }

    /// The direct beam at the observer in channel `w`, normal to it: the
    /// band average of T(λ), times E0 at λ with `weighted` and a
    /// solar spectrum (as [`Scene::direct_horizontal`]); 0 for a
    /// sun below the observer's horizon or behind the planet.
    #[inline]
    pub fn direct_normal(&self, altitude_km: f64, w: usize, weighted: bool) -> f64 {
        let origin = self.geometry.observer_position(altitude_km);
        let dir = self.sun.direction;
        let mu0 = dir.dot(self.geometry.up(origin));
        if mu0 <= 0.0 {
            return 0.0;
        }
        let columns = match crate::geometry::ray::layer_at(&self.levels_km, altitude_km, mu0) {
            Some(layer) => match self.term_columns_in(
                sun_ray(
                    self.geometry,
                    self.pseudo_spherical_radius_km,
                    Ray { origin, dir, layer },
                ),
                f64::INFINITY,
            ) {
                Some(c) => c,
                None => return 0.0,
            },
            None => vec![0.0; self.terms.terms.len()],
        };
        self.band_average(w, &columns, weighted)
    }

    /// Each term's amount integrated along `ray` over at most `length` (km),
    /// or `None` when the ray meets the ground first.
    #[inline]
    pub fn term_columns(&self, ray: &Ray, length: f64) -> Option<Vec<f64>> {
        self.term_columns_in((self.geometry, *ray), length)
    }

    /// [`Scene::term_columns`] along a ray of a given geometry.
    #[inline]
    pub(super) fn term_columns_in(&self, (geometry, ray): (Geometry, Ray), length: f64) -> Option<Vec<f64>> {
        let terms = &self.terms.terms;
        let mut columns = vec![0.0; terms.len()];
        let end = crate::geometry::ray::walk(&geometry, &self.levels_km, &ray, |seg| {
            let t1 = seg.t1.min(length);
            if t1 > seg.t0 {
                let integrals = match &self.shapes {
                    None => [t1 - seg.t0; 3],
                    Some(shapes) => {
                        let bounds = (self.levels_km[seg.layer], self.levels_km[seg.layer + 1]);
                        shape_integrals(&shapes[seg.layer], bounds, &geometry, ray.origin, ray.dir, seg.t0, t1)
                    }
                };
                for ((c, t), shape) in columns.iter_mut().zip(terms).zip(&self.term_shapes) {
                    *c += t.amount[seg.layer] * integrals[shape.index()];
                }
            }
            if seg.t1 >= length {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        // A ray ending on the ground within a millimetre of `length` (a
        // point on the ground) reaches it.
        match end {
            WalkEnd::Ground { t } if t < length - 1e-6 => None,
            _ => Some(columns),
        }
    }

    /// The band average over channel `w` of e^(−Σ_t response_t(λ)·column_t)
    /// (times E0 at λ with `weighted` and a solar spectrum), by
    /// the composite midpoint rule on cells of at most [`DIRECT_CELL_NM`]
    /// (the ozone data's spacing is 0.1 nm); a monochromatic channel's
    /// value at its wavelength.
    #[inline]
    pub fn band_average(&self, w: usize, columns: &[f64], weighted: bool) -> f64 {
        let solar = self.solar.as_ref().filter(|_| weighted).map(|solar| {
            self.cell_wavelengths(w)
                .map(|lambda| solar.irradiance(lambda).unwrap_or(0.0))
                .collect::<Vec<f64>>()
        });
        Scene::band_average_of(&self.band_cells(w), columns, solar.as_deref())
    }

    /// The midpoints of channel `w`'s cells (its wavelength alone for a
    /// monochromatic channel).
    #[inline]
    pub(super) fn cell_wavelengths(&self, w: usize) -> impl Iterator<Item = f64> {
        let channel = self.channels[w];
        let cells = (channel.band_width_nm / DIRECT_CELL_NM).ceil().max(1.0) as usize;
        (0..cells).map(move |k| channel.wavelength((k as f64 + 0.5) / cells as f64))
    }

    /// The extinction responses of every term at the midpoints of channel
    /// `w`'s cells (`[cell·terms + term]`), for [`Scene::band_average_of`].
    #[inline]
    pub fn band_cells(&self, w: usize) -> Vec<f64> {
        let mut responses = vec![TermOptics::default(); self.terms.terms.len()];
        let mut out = Vec::new();
        for lambda in self.cell_wavelengths(w) {
            self.terms.responses_into(lambda, &mut responses);
            out.extend(responses.iter().map(|r| r.ext));
        }
        out
    }

    /// The mean over a band's cells (responses from
    /// [`Scene::band_cells`]) of e^(−Σ response·column), each cell
    /// times its `solar` factor when given.
    #[inline]
    pub fn band_average_of(cells: &[f64], columns: &[f64], solar: Option<&[f64]>) -> f64 {
        let t = columns.len().max(1);
        let n = (cells.len() / t).max(1);
        let sum: f64 = cells
            .chunks_exact(t)
            .enumerate()
            .map(|(k, r)| {
                let tau = r.iter().zip(columns).map(|(a, c)| a * c).sum::<f64>().max(0.0);
                (-tau).exp() * solar.map_or(1.0, |s| s[k])
            })
            .sum();
        sum / n as f64
    }
}
