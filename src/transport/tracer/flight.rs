//! Free flights of a shared path: where the hero's flight ends (analog,
//! forced, delta-tracked), each channel's density of that end, and the
//! optical depths to where a ray leaves.

use std::ops::ControlFlow;

use crate::geometry::ray::{Ray, Segment, WalkEnd};
use crate::geometry::shell::Geometry;
use crate::sampling::sampler::Sampler;
use crate::transport::free_flight::FlightEnd;

use super::path::{Depths, Outcome, Path, ViewKey};
use super::scene::Scene;
use super::spectra::ChannelSpectra;

impl Scene {
    /// [`Scene::exit_depths`] of a path's flight along `ray` into
    /// `path.ray`. The sensor's own flight of a view ray that repeats
    /// ([`Path::view_repeats`]) computes what depends on the ray alone
    /// (the half chords, the basis vectors' depths, how it leaves) once
    /// and keeps it on the thread ([`Path::view_depths`]); every sample
    /// combines its own spectra's depths from it: the same numbers bit
    /// for bit, without the square roots of every level.
    pub(super) fn flight_depths(&self, path: &mut Path, spectra: &ChannelSpectra, ray: &Ray) -> Option<WalkEnd> {
        if path.order != 0 || !path.view_repeats {
            return self.exit_depths(&mut path.ray, spectra, &self.geometry, ray);
        }
        let key = ViewKey::new(self.id, ray, 0);
        if path.view_depths_key != Some(key) {
            let end = self.exit_depths(&mut path.ray, spectra, &self.geometry, ray);
            path.view_depths.clone_from(&path.ray);
            path.view_end = end;
            path.view_depths_key = Some(key);
            return end;
        }
        let (kept, d) = (&path.view_depths, &mut path.ray);
        d.chords.clone_from(&kept.chords);
        d.tau_basis.clone_from(&kept.tau_basis);
        d.exit.clone_from(&kept.exit);
        Self::combine(spectra, &d.tau_basis, &mut d.tau);
        path.view_end
    }

    /// Every channel's optical depth from the ray's origin to where it
    /// leaves (top or ground) into `d.tau`, through `geometry`, and how it
    /// leaves; `None` for an endless (horizontal plane-parallel) ray.
    pub(super) fn exit_depths(
        &self,
        d: &mut Depths,
        spectra: &ChannelSpectra,
        geometry: &Geometry,
        ray: &Ray,
    ) -> Option<WalkEnd> {
        let levels = &self.track.levels_km;
        let b = self.basis_len;
        let tau = &mut d.tau_basis;
        tau.fill(0.0);
        let end = match *geometry {
            // Closed form through concentric shells where σ is constant in
            // each layer.
            Geometry::Spherical { radius_km } if self.shapes.is_none() => {
                let exit = crate::geometry::shell_exit::shell_exit(radius_km, levels, ray);
                let range = exit.levels();
                let c = &mut d.chords[..range.len()];
                crate::geometry::chord_kernels::half_chords_into(radius_km, &levels[range], exit.h, c);
                let base = &self.track.sigma[ray.layer * b..(ray.layer + 1) * b];
                let stride = levels.len();
                for (j, (t, s)) in tau.iter_mut().zip(base).enumerate() {
                    *t = exit.depth(*s, &self.track.steps[j * stride..(j + 1) * stride], c);
                }
                let end = exit.end(radius_km, levels, ray);
                d.exit = Some(exit);
                Some(end)
            }
            _ => {
                d.exit = None;
                let mut endless = false;
                let end = crate::geometry::ray::walk(geometry, levels, ray, |seg| {
                    if seg.t1.is_finite() {
                        self.accumulate_along(tau, geometry, ray, seg.layer, seg.t0, seg.t1);
                    } else {
                        endless = true;
                    }
                    ControlFlow::Continue(())
                });
                (!endless).then_some(end)
            }
        };
        Self::combine(spectra, &d.tau_basis, &mut d.tau);
        end
    }

    /// Every channel's optical depth along a shadow ray to the top into
    /// `d.tau`; false (and nothing computed) when it meets the ground
    /// first. Through spherical shells of the layered medium in closed
    /// form, the half chords summed with the steps directly for a single
    /// basis vector (no chords kept: nothing is located along a shadow ray).
    pub(super) fn shadow_depths(
        &self,
        d: &mut Depths,
        spectra: &ChannelSpectra,
        geometry: &Geometry,
        ray: &Ray,
    ) -> bool {
        let Geometry::Spherical { radius_km } = *geometry else {
            return matches!(self.exit_depths(d, spectra, geometry, ray), Some(WalkEnd::Top { .. }));
        };
        if self.shapes.is_some() || self.basis_len != 1 {
            return matches!(self.exit_depths(d, spectra, geometry, ray), Some(WalkEnd::Top { .. }));
        }
        let levels = &self.track.levels_km;
        let exit = crate::geometry::shell_exit::shell_exit(radius_km, levels, ray);
        if exit.ground {
            return false;
        }
        let steps = &self.track.steps;
        let sum = |r: &std::ops::Range<usize>| {
            crate::geometry::chord_kernels::weighted_half_chords(
                radius_km,
                &levels[r.clone()],
                &steps[r.clone()],
                exit.h,
            )
        };
        d.tau_basis[0] = -exit.b * self.track.sigma[ray.layer] + 2.0 * sum(&exit.twice) + sum(&exit.once);
        Self::combine(spectra, &d.tau_basis, &mut d.tau);
        true
    }

    /// Samples the flight's outcome with the path's hero wavelength; every
    /// wavelength's integrand and density go in over the hero's density.
    /// `path.ray` holds the depths to the flight's `end`.
    ///
    /// One free-flight routine: tentative collisions against the hero's
    /// majorant, each real with probability σ_t/σ_maj (delta tracking; with
    /// the majorant σ_t itself, every one is real and this is the analog
    /// free path, drawn by inversion). A `forced` flight (majorant σ_t)
    /// draws its one tentative collision from the exponential truncated to
    /// the flight, probability 1 − e^(−τ) per wavelength; otherwise the
    /// flight may end on the ground or escape. A real collision at x has
    /// the density σ_t(x)·e^(−τ(x)) at every wavelength (over the forcing
    /// probability for a forced flight), whatever the majorant. At a
    /// collision, `path.mixtures` gets every channel's phase mixture there.
    pub(super) fn flight(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        ray: &Ray,
        end: WalkEnd,
        forced: bool,
        sampler: &mut Sampler,
    ) -> Outcome {
        let n = self.channels.len();
        let hero = path.hero;
        let exact = self.exact_majorant();
        // The collision: by inverting the hero's optical depth where σ_t
        // is the majorant (the first tentative collision is real; rounding
        // may leave a forced one beyond the end: the end), else by delta
        // tracking. `hero_depth` is the hero's depth to it (exact majorant).
        let (hit, hero_depth) = if exact {
            let target = if forced {
                for (p, t) in path.forced.iter_mut().zip(&path.ray.tau) {
                    *p = -(-t).exp_m1();
                }
                if path.forced[hero] <= 0.0 {
                    return Outcome::Escaped;
                }
                crate::transport::free_flight::forced_distance(sampler.next_f64(), path.forced[hero])
            } else {
                -(1.0 - sampler.next_f64()).ln()
            };
            let inside = forced || target < path.ray.tau[hero];
            (inside.then(|| self.locate(path, spectra, ray, target)), target)
        } else {
            (self.delta_track(path, spectra, ray, sampler), f64::NAN)
        };
        let Some((t, layer)) = hit else {
            let WalkEnd::Ground { t } = end else {
                return Outcome::Escaped;
            };
            // The ground, reached with probability e^(−τ) at every λ (and
            // through merged layers, the residual's factor on the way).
            let tau_hero = path.ray.tau[hero];
            for w in 0..n {
                let k = if w == hero {
                    1.0
                } else {
                    (tau_hero - path.ray.tau[w]).exp()
                };
                path.throughput[w] = path.throughput[w] * (k * path.residual_to(f64::INFINITY, w));
                path.scale_density(w, k);
            }
            path.densities_changed();
            return Outcome::Ground { t };
        };
        // Every channel's depth to the collision (from the basis, walked
        // again where σ_t is the majorant and there are other channels).
        if exact && n == 1 {
            path.tau_hit[hero] = hero_depth;
        } else {
            if exact {
                self.basis_depths_to(path, ray, t);
            }
            Self::combine(spectra, &path.ray.tau_basis, &mut path.tau_hit);
        }
        let geometry = &self.geometry;
        // The collision's density per wavelength, over the hero's: the
        // hero's e^(−τ) cancels, so each channel's transmittance comes in
        // relative to the hero's (none to compute for the hero). Through
        // merged layers, the densities are theirs, while σ_s, the phase
        // matrices and the residual's factor make the integrand the
        // profile's (`tracking`).
        let x = ray.origin + t * ray.dir;
        let f = self.fraction(geometry, layer, x);
        let merged = self.track.merged;
        let profile_layer = self.profile_layer(layer, x);
        let density = |sigma_t: f64, p: f64| {
            if !forced {
                sigma_t
            } else if p > 0.0 {
                sigma_t / p
            } else {
                0.0
            }
        };
        let inv_hero = 1.0 / density(self.sigma_t_point(spectra, layer, hero, f), path.forced[hero]);
        let tau_hero = path.tau_hit[hero];
        path.mixtures.clear();
        let mut scatters = false;
        for w in 0..n {
            let c = self.coefficients(spectra, profile_layer, w, f);
            path.mixtures.push(self.phase_mixture(spectra, profile_layer, w, &c));
            let transmittance = if w == hero {
                1.0
            } else {
                (tau_hero - path.tau_hit[w]).exp()
            };
            let sigma_t = if merged {
                self.sigma_t_point(spectra, layer, w, f)
            } else {
                c.sigma_t
            };
            let k = density(sigma_t, path.forced[w]) * transmittance * inv_hero;
            let integrand = c.sigma_s() * transmittance * path.residual_to(t, w);
            scatters |= integrand > 0.0;
            path.throughput[w] = path.throughput[w] * (integrand * inv_hero);
            path.scale_density(w, k);
        }
        // Where no channel scatters (a medium that only absorbs there) the
        // path ends: it carries nothing further, and its phase mixture,
        // with no component, has no direction to draw.
        if !scatters {
            return Outcome::Absorbed;
        }
        path.densities_changed();
        Outcome::Collided { t, layer }
    }

    /// The point at the hero's optical depth `target` along the flight
    /// (σ_t exact per layer): from the half chords `exit_depths` left, or
    /// walked; the end if rounding leaves the target beyond it.
    pub(super) fn locate(&self, path: &Path, spectra: &ChannelSpectra, ray: &Ray, target: f64) -> (f64, usize) {
        let layers = self.track.layers();
        let sigma = match spectra.sigma.get(path.hero * layers..(path.hero + 1) * layers) {
            Some(shared) => shared,
            None => &path.hero_sigma,
        };
        let c = match &path.ray.exit {
            Some(exit) => exit.locate(sigma, &path.ray.chords, target),
            None => {
                crate::transport::free_flight::locate_with(sigma, &self.geometry, &self.track.levels_km, ray, target)
            }
        };
        (c.t, c.layer)
    }

    /// Every basis vector's depth along the flight to distance `t` into
    /// `path.ray.tau_basis`.
    pub(super) fn basis_depths_to(&self, path: &mut Path, ray: &Ray, t: f64) {
        let geometry = &self.geometry;
        let Depths {
            tau_basis: tau,
            chords,
            exit,
            ..
        } = &mut path.ray;
        tau.fill(0.0);
        let visit = |s: Segment| {
            self.accumulate_along(tau, geometry, ray, s.layer, s.t0, s.t1.min(t));
            if s.t1 >= t {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        };
        match exit {
            Some(exit) => {
                let _ = exit.try_for_each_segment(chords, visit);
            }
            None => {
                crate::geometry::ray::walk(geometry, &self.track.levels_km, ray, visit);
            }
        }
    }

    /// Delta tracking of the hero against its majorant (the smooth medium,
    /// or inflated majorants; [`crate::transport::free_flight::sample_t_maj`]): the first real
    /// collision, with every basis vector's depth to it in
    /// `path.ray.tau_basis`, or `None` past the end.
    pub(super) fn delta_track(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        ray: &Ray,
        sampler: &mut Sampler,
    ) -> Option<(f64, usize)> {
        let hero = path.hero;
        let geometry = &self.geometry;
        let majorant = |layer| self.majorant(spectra, layer, hero);
        let end = crate::transport::free_flight::sample_t_maj(
            majorant,
            geometry,
            &self.track.levels_km,
            ray,
            sampler,
            |c, s| {
                let f = self.fraction(geometry, c.layer, ray.origin + c.t * ray.dir);
                s.next_f64() * c.sigma_maj >= self.sigma_t_point(spectra, c.layer, hero, f)
            },
        );
        let FlightEnd::Collided(c) = end else {
            return None;
        };
        self.basis_depths_to(path, ray, c.t);
        Some((c.t, c.layer))
    }

    /// The current flight's segments into `path.segments` (`path.ray`
    /// holds its exit; σ constant per layer); false for an endless flight.
    /// The depths to a point along them are summed when a point is
    /// connected (`sun_at_point`): a flight connects one point or a few,
    /// and keeping every segment's depths cost about 7 % of a twilight
    /// path's time (docs/design-sun.md, "Sun connections along shared paths").
    pub(super) fn flight_segments(&self, path: &mut Path, ray: &Ray) -> bool {
        let Path {
            segments, ray: depths, ..
        } = path;
        segments.clear();
        let push = |seg: Segment| {
            segments.push(seg);
            ControlFlow::<()>::Continue(())
        };
        match &depths.exit {
            Some(exit) => {
                let _ = exit.try_for_each_segment(&depths.chords, push);
            }
            None => {
                crate::geometry::ray::walk(&self.geometry, &self.track.levels_km, ray, push);
            }
        }
        segments.iter().all(|seg| seg.t1.is_finite())
    }
}
