//! One radiance sample: a path from the sensor, vertex by vertex (scattering,
//! ground reflection, splitting at the first vertex), scoring every channel
//! and albedo.

use std::f64::consts::FRAC_1_PI;

use glam::DVec3;

use crate::geometry::ray::{Ray, WalkEnd};
use crate::job::options::MAX_ALBEDOS;
use crate::polarization::phase_mixture::PhaseMixture;
use crate::polarization::phase_table_set::PhaseTableSet;
use crate::polarization::stokes::{Mueller, PhaseMatrix, Stokes};
use crate::sampling::sampler::Sampler;

use super::direction_guide::DirectionGuide;
use super::path::{Outcome, Path, WORK, Work};
use super::scene::Scene;
use super::spectra::ChannelSpectra;
use super::sun_lobe::{GROUND_LOBE_SHARE, SunLobe};
use super::vertex::{cosine_hemisphere, quarter_turn, reference_albedo, scattering_frame};
use super::view_ray::ViewRay;

impl Scene {
    /// One sample of the diffuse Stokes radiance arriving at the observer at
    /// `altitude_km` from viewing direction `view` (unit, observer frame),
    /// referred to the axis `e1` (unit, ⟂ `view`; e.g. the meridian axis,
    /// see [`crate::polarization::stokes_frame`]), at every channel and albedo, into
    /// `out[channel·albedos + albedo]` ([`Scene::value_count`] values).
    /// `ray` says whether the caller asks for the same view sample after
    /// sample.
    pub fn radiance_sample(
        &self,
        altitude_km: f64,
        view: DVec3,
        e1: DVec3,
        ray: ViewRay,
        sampler: &mut Sampler,
        out: &mut [Stokes],
    ) {
        WORK.with_borrow_mut(|work| {
            let Work { path, spare, spectra } = work;
            let spectra = match &self.fixed {
                Some(fixed) => fixed,
                None => {
                    self.draw_spectra(spectra, sampler);
                    &*spectra
                }
            };
            let n = self.channels.len();
            let albedos = self.albedos.len().min(MAX_ALBEDOS);
            let hero = ((sampler.next_f64() * n as f64) as usize).min(n - 1);
            let levels = &self.track.levels_km;
            path.reset(n, levels.len(), self.basis_len, albedos, e1, hero);
            // A path that starts on the ground (looking down from it) keeps
            // the scene's threshold; one with a view flight scales it there.
            path.roulette_threshold = self.settings.roulette_threshold;
            path.view_sun_aware = view.dot(self.sun.direction) >= self.view_sun_aware_min_cos(ray);
            path.view_repeats = ray == ViewRay::Repeated;
            if spectra.sigma.is_empty() {
                path.hero_sigma.clear();
                path.hero_sigma
                    .extend((0..levels.len() - 1).map(|l| self.sigma_t(spectra, l, hero)));
            }
            let origin = self.geometry.observer_position(altitude_km);
            let up = self.geometry.up(origin);
            match crate::geometry::ray::layer_at(levels, altitude_km, view.dot(up)) {
                Some(layer) => self.trace(
                    path,
                    spectra,
                    Ray {
                        origin,
                        dir: view,
                        layer,
                    },
                    sampler,
                    Some(spare),
                ),
                None => {
                    if altitude_km <= levels[0] && view.dot(up) < 0.0 {
                        self.trace_on_from_ground(path, spectra, origin, sampler);
                    }
                }
            }
            out.copy_from_slice(&path.radiance);
            if self.solar.is_some() {
                for (w, per_albedo) in out.chunks_mut(albedos).enumerate() {
                    for s in per_albedo {
                        *s = *s * spectra.solar[w];
                    }
                }
            }
        })
    }

    /// Follows a path from `ray` to its end. With a `spare` path to split
    /// into and [`Settings::first_vertex_splitting`], the sensor's first
    /// vertex is split: a forced flight toward
    /// a reflecting ground follows both ends (the ground with weight
    /// e^(−τ_λ) at every λ, a decision taken for all wavelengths alike, so
    /// no density changes; the collision forced), and, with
    /// [`Settings::split_first_scattering`], the first scattering
    /// goes on in the sampled direction and its quarter turn, which every
    /// wavelength's phase function gives the same density.
    pub(super) fn trace(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        mut ray: Ray,
        sampler: &mut Sampler,
        mut spare: Option<&mut Path>,
    ) {
        let n = self.channels.len();
        if !self.settings.first_vertex_splitting {
            spare = None;
        }
        let forced = self.forced();
        loop {
            let Some(end) = self.flight_depths(path, spectra, &ray) else {
                return;
            };
            if self.track.merged {
                self.flight_residual(path, spectra, &ray, sampler);
            }
            // Thin views roulette later where sun connections are at
            // collisions (`view_roulette_scale`).
            if path.order == 0 && self.sun_follow.as_ref().is_none_or(|f| f.view_only) {
                path.set_view_roulette(self.settings.roulette_threshold);
            }
            // A forced flight toward a reflecting ground is split at the
            // sensor's first vertex, else analog.
            let to_ground = matches!(end, WalkEnd::Ground { .. }) && self.reflects();
            let split = forced && to_ground && path.order == 0 && spare.is_some();
            let forced_flight = forced && (split || !to_ground);
            // Sun connections along the whole flight (sun-aware, or
            // stratified on a forced flight), with the throughput and
            // densities before its collision.
            let sun_done = !self.order_done(path.order)
                && (self.flight_hidden_from_sun(&ray, end)
                    || self.sun_along_flight(path, spectra, &ray, sampler)
                    || (forced_flight
                        && self.settings.sun_samples_per_flight > 1
                        && self.sun_stratified(path, spectra, &ray, sampler)));
            if let (true, WalkEnd::Ground { t }, Some(branch)) = (split, end, spare.as_deref_mut()) {
                branch.branch_from(path);
                for (w, (m, tau)) in branch.throughput.iter_mut().zip(&path.ray.tau).enumerate() {
                    *m = *m * ((-tau).exp() * path.residual_to(f64::INFINITY, w));
                }
                self.trace_on_from_ground(branch, spectra, ray.origin + t * ray.dir, sampler);
                std::mem::swap(&mut path.radiance, &mut branch.radiance);
            }
            match self.flight(path, spectra, &ray, end, forced_flight, sampler) {
                Outcome::Escaped | Outcome::Absorbed => return,
                Outcome::Ground { t } => {
                    let x = ray.origin + t * ray.dir;
                    if !self.ground(path, spectra, x, sampler) {
                        return;
                    }
                    let dir = self.ground_direction(path, x, sampler);
                    ray = Ray {
                        origin: x,
                        dir,
                        layer: 0,
                    };
                }
                Outcome::Collided { t, layer } => {
                    let x = ray.origin + t * ray.dir;
                    let k_out = -ray.dir;
                    path.order += 1;
                    if !sun_done {
                        // At the collision, with every channel's phase mixture there.
                        self.sun_from(path, spectra, x, layer, k_out, sampler, false);
                    }
                    if self.order_done(path.order) {
                        return;
                    }
                    // Direction from one wavelength's phase function, picked
                    // uniformly, weighted by the mixture of all wavelengths'
                    // densities.
                    // (`path.mixtures` holds every channel's mixture at the
                    // collision.)
                    // With the sun low or set, in part from a guide instead
                    // (`direction_guide`).
                    let pick = ((sampler.next_f64() * n as f64) as usize).min(n - 1);
                    let tables = self.phase_tables();
                    let guide = self.direction_guide(x, layer);
                    let from_guide = guide.is_some_and(|g| sampler.next_f64() < g.share());
                    let k_in = match guide {
                        Some(guide) if from_guide => -guide.sample(sampler),
                        _ => path.mixtures[pick].sample_direction(k_out, sampler.next_f64(), sampler.next2(), tables),
                    };
                    matrices_at(&mut path.matrices, &path.mixtures, tables, k_in.dot(k_out));
                    let branch = match (path.order, self.settings.split_first_scattering) {
                        (1, true) => spare.as_deref_mut(),
                        _ => None,
                    };
                    if let Some(branch) = branch {
                        branch.branch_from(path);
                        branch.halve();
                        let k_branch = match guide {
                            Some(guide) if from_guide => {
                                let k = -guide.sample(sampler);
                                matrices_at(&mut branch.matrices, &path.mixtures, tables, k.dot(k_out));
                                k
                            }
                            _ => quarter_turn(k_out, k_in),
                        };
                        let inv_density = direction_weight(&branch.matrices, guide, -k_branch);
                        if let Some(next) = self.scattered(branch, k_branch, k_out, x, layer, inv_density, sampler) {
                            self.trace(branch, spectra, next, sampler, None);
                        }
                        std::mem::swap(&mut path.radiance, &mut branch.radiance);
                        path.halve();
                    }
                    let inv_density = direction_weight(&path.matrices, guide, -k_in);
                    match self.scattered(path, k_in, k_out, x, layer, inv_density, sampler) {
                        Some(next) => ray = next,
                        None => return,
                    }
                }
            }
        }
    }

    /// Scatters the path at `x` (in `layer`) from light along k_in into
    /// k_out with every wavelength's matrix at the last collision
    /// (`path.matrices`) over the direction's density (`inv_density`:
    /// 1/(4π × density), [`direction_weight`]); the ray it goes on along,
    /// or `None` when roulette ends it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn scattered(
        &self,
        path: &mut Path,
        k_in: DVec3,
        k_out: DVec3,
        x: DVec3,
        layer: usize,
        inv_density: f64,
        sampler: &mut Sampler,
    ) -> Option<Ray> {
        let (rotation, e1_in) = scattering_frame(path.frame_e1, k_in, k_out);
        for (t, m) in path.throughput.iter_mut().zip(&path.matrices) {
            *t = if self.settings.polarized {
                rotation.right_of_then(t, &m.scaled(inv_density))
            } else {
                *t * Mueller::depolarizer(m.p11 * inv_density)
            };
        }
        path.frame_e1 = e1_in;
        if !path.roulette(sampler) {
            return None;
        }
        Some(Ray {
            origin: x,
            dir: -k_in,
            layer,
        })
    }

    /// The guide at `x` in tracked layer `layer`, where one is used: the
    /// lobe toward the sunlit air, or the lobe about the sun.
    fn direction_guide(&self, x: DVec3, layer: usize) -> Option<DirectionGuide<'_>> {
        match (&self.sun_lobes, self.sun_peak) {
            (Some(lobes), _) => Some(DirectionGuide::SunLobe(lobes.at(
                layer,
                self.geometry.up(x),
                self.sun.direction,
            ))),
            (None, Some(peak)) => Some(DirectionGuide::SunPeak(peak)),
            (None, None) => None,
        }
    }

    /// A ground vertex at `x` and the rest of the path from it (unsplit).
    pub(super) fn trace_on_from_ground(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        x: DVec3,
        sampler: &mut Sampler,
    ) {
        if self.ground(path, spectra, x, sampler) {
            let dir = self.ground_direction(path, x, sampler);
            self.trace(
                path,
                spectra,
                Ray {
                    origin: x,
                    dir,
                    layer: 0,
                },
                sampler,
                None,
            );
        }
    }

    /// The direction a path goes on along from a ground vertex at `x`: by
    /// the cosine, or, where the lobe toward the sunlit air is used, with
    /// its share from the ground's row of it; every channel's throughput
    /// is weighed by the cosine's density over the mixture's.
    fn ground_direction(&self, path: &mut Path, x: DVec3, sampler: &mut Sampler) -> DVec3 {
        let up = self.geometry.up(x);
        let Some(lobes) = &self.sun_lobes else {
            return cosine_hemisphere(up, sampler.next2());
        };
        let (dir, weight) = guided_ground_direction(&lobes.ground_at(up, self.sun.direction), up, sampler);
        for t in path.throughput.iter_mut() {
            *t = *t * weight;
        }
        dir
    }

    /// A ground vertex: NEE to the sun for every wavelength, then the
    /// Lambertian weight. Returns whether the path goes on.
    pub(super) fn ground(&self, path: &mut Path, spectra: &ChannelSpectra, x: DVec3, sampler: &mut Sampler) -> bool {
        if !self.reflects() {
            return false;
        }
        path.order += 1;
        let a_ref = reference_albedo(&self.albedos);
        // Lambertian and depolarising: only the first column survives.
        for t in path.throughput.iter_mut() {
            for row in t.0.iter_mut() {
                *row = [row[0] * a_ref, 0.0, 0.0, 0.0];
            }
        }
        for (w, a) in path.albedo_weights.iter_mut().zip(&self.albedos) {
            *w *= a / a_ref;
        }
        let up = self.geometry.up(x);
        let s = self.sun.sample_direction(sampler.next2());
        let mu_s = s.dot(up);
        if mu_s > 0.0 && self.sun_transmittances(path, spectra, x, s, 0, sampler) {
            for w in 0..self.channels.len() {
                let f = FRAC_1_PI * mu_s * path.shadow_tr[w];
                let m = &path.throughput[w].0;
                let column = Stokes::new(m[0][0], m[1][0], m[2][0], m[3][0]);
                path.add(w, column * f);
            }
        }
        if self.order_done(path.order) {
            return false;
        }
        path.roulette(sampler)
    }
}

/// A direction up from a Lambertian ground whose vertical is `up`, drawn
/// from `lobe` (its ground row) with share [`GROUND_LOBE_SHARE`] and
/// otherwise by the cosine, and its weight: the cosine's density, μ/π,
/// over the mixture's (0 at or below the horizon).
fn guided_ground_direction(lobe: &SunLobe, up: DVec3, sampler: &mut Sampler) -> (DVec3, f64) {
    let share = GROUND_LOBE_SHARE;
    let dir = if sampler.next_f64() < share {
        lobe.sample(sampler)
    } else {
        cosine_hemisphere(up, sampler.next2())
    };
    let cosine_4pi = 4.0 * dir.dot(up).max(0.0);
    let mixture = (1.0 - share) * cosine_4pi + share * lobe.density_4pi(dir);
    let weight = if mixture > 0.0 { cosine_4pi / mixture } else { 0.0 };
    (dir, weight)
}

/// 1/(4π × the density) of the scattering direction whose propagation
/// direction is `d` and whose channels' matrices are `matrices`: the mean
/// of the channels' P11 (each channel's phase function picked alike), or
/// with a guide the mixture of that and the guide.
fn direction_weight(matrices: &[PhaseMatrix], guide: Option<DirectionGuide>, d: DVec3) -> f64 {
    let sum = matrices.iter().map(|m| m.p11).sum::<f64>();
    match guide {
        None => matrices.len() as f64 / sum,
        Some(guide) => guide.inverse_mixture(sum / matrices.len() as f64, d),
    }
}

/// Every channel's phase matrix at scattering-angle cosine `cos` from its
/// mixture, into `matrices`.
fn matrices_at(matrices: &mut Vec<PhaseMatrix>, mixtures: &[PhaseMixture], tables: &PhaseTableSet, cos: f64) {
    let at = tables.locate(cos);
    matrices.clear();
    matrices.extend(mixtures.iter().map(|m| m.matrix(&at)));
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use glam::DVec3;

    use super::super::sun_lobe::SunLobes;
    use super::*;

    #[test]
    fn guided_ground_directions_weigh_out_to_the_cosine() {
        // A ground row peaked near the horizon toward the sun. 400,000
        // guided draws, their weights summed per cell of cos(zenith) ×
        // azimuth, estimate each cell's share of the Lambertian ground's
        // cosine measure, ∫ μ/π dω, within 4.5 standard errors of the
        // cell's mean weight; no draw goes below the horizon.
        let lobes = SunLobes::new(1, |_, mu, phi| {
            (1.0 + 30.0 * (-10.0 * mu.abs()).exp()) * (1.0 + 10.0 * (-2.0 * phi).exp())
        });
        let up = DVec3::new(0.1, 0.2, 1.0).normalize();
        let sun = DVec3::new(0.8, -0.3, -0.07).normalize();
        let lobe = lobes.ground_at(up, sun);
        let east = up.any_orthonormal_vector();
        let north = up.cross(east);
        let (nm, np) = (8usize, 12usize);
        let n = 400_000;
        let (mut sum, mut sum2) = (vec![0.0; nm * np], vec![0.0; nm * np]);
        let mut s = Sampler::new(&[47]);
        for _ in 0..n {
            let (d, w) = guided_ground_direction(&lobe, up, &mut s);
            let mu = d.dot(up);
            assert!(mu > 0.0 && w.is_finite(), "draw {d} with weight {w}");
            let phi = d.dot(north).atan2(d.dot(east));
            let i = ((mu * nm as f64) as usize).min(nm - 1);
            let j = (((phi + PI) / (2.0 * PI) * np as f64) as usize).min(np - 1);
            sum[i * np + j] += w;
            sum2[i * np + j] += w * w;
        }
        for c in 0..nm * np {
            let (i, j) = (c / np, c % np);
            let (mu0, mu1) = (i as f64 / nm as f64, (i + 1) as f64 / nm as f64);
            let want = 0.5 * (mu1 * mu1 - mu0 * mu0) * (2.0 * PI / np as f64) / PI;
            let mean = sum[c] / n as f64;
            let se = ((sum2[c] / n as f64 - mean * mean) / n as f64).sqrt();
            assert!(
                (mean - want).abs() < 4.5 * se,
                "cell {i}, {j}: {mean:.6} ± {se:.6} against {want:.6}"
            );
        }
    }
}
