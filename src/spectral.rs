//! Shared spectral paths: one path carries every wavelength of a task.
//!
//! Choice: hero-wavelength sampling with spectral multiple importance
//! sampling over whole paths (Wilkie et al. 2014, "Hero wavelength spectral
//! sampling"). One wavelength picked uniformly per path (the hero) makes
//! every sampling decision (free flights, phase-function directions); each
//! wavelength λ scores its path integrand over the *mixture* of the N
//! wavelengths' path densities, f_λ(path) / ((1/N)·Σ_j p_j(path)) — the
//! balance heuristic. The path densities are carried as ratios to the
//! hero's (as pbrt-v4 does), so nothing under- or overflows. Every weight is
//! bounded: the mixture contains p_λ/N, so the weight is at most N times the
//! single-wavelength estimator's f_λ/p_λ, itself at most 1 per flight
//! (σ_s/σ_t, forcing probability) and per scattering (|M_ij|/P11 ≤ 1).
//! (Mixing per decision instead multiplies per-decision mixtures along the
//! path and was measured 2.4× noisier at 320 nm with 760 nm beside it.) Spectral tracking against a majorant over the
//! wavelengths was the alternative; with Rayleigh's λ⁻⁴ spread (σ differs
//! ×4 between 320 and 760 nm in the thin upper layers, ×20 in extinction)
//! its null-collision weights need history-aware probabilities to stay
//! bounded, while the hero scheme is bounded by construction and reuses
//! the forced-collision flights of the single-wavelength tracer.
//!
//! Geometry (the shell walk, shadow-ray walks) is computed once per path;
//! optical depths per wavelength are σ_λ × chord on the shared segments.
//! Requires piecewise-constant media (the `layered` model) and forced
//! collisions; sun connections are made at the collision points.

use std::f64::consts::FRAC_1_PI;

use glam::DVec3;

use std::cell::RefCell;
use std::ops::ControlFlow;

use crate::integrator::{
    INV_4PI, MAX_ALBEDOS, ROULETTE_THRESHOLD, Settings, cosine_hemisphere, phase_mixture, pick_component,
    reference_albedo, scattering_frame,
};
use crate::medium::{Medium, PointCoefficients, density_steps};
use crate::phase::PhaseMixture;
use crate::sampler::Sampler;
use crate::shell::Geometry;
use crate::stokes::{Mueller, PhaseMatrix, Stokes, meridian_frame};
use crate::sun::Sun;
use crate::tracking::{self, Ray, WalkEnd};

/// Everything a shared-wavelength path needs.
#[derive(Debug, Clone)]
pub struct SpectralScene {
    pub geometry: Geometry,
    /// One medium per wavelength, on the same levels.
    pub media: Vec<Medium>,
    pub sun: Sun,
    pub albedos: Vec<f64>,
    pub settings: Settings,
    /// σ_t per layer and wavelength, layer-major (`[layer·N + λ]`), so the
    /// per-segment optical depths of all wavelengths are one contiguous loop.
    sigma_t: Vec<f64>,
    /// σ_t's steps per wavelength and level (`[λ·(layers + 1) + level]`,
    /// see `Medium::steps`).
    steps: Vec<f64>,
    /// σ_s and the phase mixture per layer and wavelength (`[layer·N + λ]`).
    sigma_s: Vec<f64>,
    mixtures: Vec<PhaseMixture>,
}

/// One sample's radiances: `values[λ·albedos + albedo]`.
#[derive(Debug, Clone)]
pub struct SpectralRadiances {
    pub values: Vec<Stokes>,
    pub wavelengths: usize,
    pub albedos: usize,
}

impl SpectralRadiances {
    /// The radiance of wavelength `w` and albedo `a`.
    pub fn get(&self, w: usize, a: usize) -> Stokes {
        self.values[w * self.albedos + a]
    }
}

/// A path's state; its per-wavelength vectors are reused from sample to
/// sample on each thread ([`WORK`]).
#[derive(Default)]
struct Path {
    /// Per wavelength: its path integrand over the hero's path density.
    throughput: Vec<Mueller>,
    /// Per wavelength: its path density over the hero's.
    density_ratio: Vec<f64>,
    /// 1 / mean of `density_ratio` (the balance heuristic's denominator).
    inv_mean_density: f64,
    hero: usize,
    frame_e1: DVec3,
    order: u32,
    albedo_weights: [f64; MAX_ALBEDOS],
    /// `[λ·albedos + albedo]`.
    radiance: Vec<Stokes>,
    albedos: usize,
    /// Scratch per wavelength: optical depths to the exit and to the
    /// collision, forcing probabilities, phase matrices.
    tau_exit: Vec<f64>,
    tau_hit: Vec<f64>,
    forced: Vec<f64>,
    matrices: Vec<PhaseMatrix>,
    /// Scratch per level: the weighted half chords of a ray.
    chords: Vec<f64>,
}

thread_local! {
    static WORK: RefCell<Path> = RefCell::new(Path::default());
}

impl Path {
    fn reset(&mut self, n: usize, levels: usize, albedos: usize, frame_e1: DVec3, hero: usize) {
        self.throughput.clear();
        self.throughput.resize(n, Mueller::identity());
        self.density_ratio.clear();
        self.density_ratio.resize(n, 1.0);
        self.inv_mean_density = 1.0;
        self.hero = hero;
        self.frame_e1 = frame_e1;
        self.order = 0;
        self.albedo_weights = [1.0; MAX_ALBEDOS];
        self.radiance.clear();
        self.radiance.resize(n * albedos, Stokes::zero());
        self.albedos = albedos;
        for v in [&mut self.tau_exit, &mut self.tau_hit, &mut self.forced] {
            v.resize(n, 0.0);
        }
        self.chords.resize(levels, 0.0);
    }

    /// Multiplies wavelength `w`'s density ratio by `k`.
    fn scale_density(&mut self, w: usize, k: f64) {
        self.density_ratio[w] *= k;
    }

    /// Refreshes the balance heuristic's denominator after density changes.
    fn densities_changed(&mut self) {
        let mean = self.density_ratio.iter().sum::<f64>() / self.density_ratio.len() as f64;
        self.inv_mean_density = 1.0 / mean;
    }

    /// Adds wavelength `w`'s contribution `s` (throughput already in it),
    /// with the balance heuristic over the wavelengths' path densities.
    fn add(&mut self, w: usize, s: Stokes) {
        let s = s * self.inv_mean_density;
        let base = w * self.albedos;
        for a in 0..self.albedos {
            self.radiance[base + a] += s * self.albedo_weights[a];
        }
    }

    /// Russian roulette on the mean effective T₀₀ over the wavelengths (the
    /// largest kept paths alive as long as 320 nm needed: 1.5× the cost
    /// for a larger error at 320 nm at equal time).
    fn roulette(&mut self, sampler: &mut Sampler) -> bool {
        let mean = self.throughput.iter().map(|t| t.0[0][0]).sum::<f64>() / self.throughput.len() as f64;
        let w = mean * self.inv_mean_density;
        if self.order < 2 || w >= ROULETTE_THRESHOLD {
            return w > 0.0;
        }
        let q = w / ROULETTE_THRESHOLD;
        if sampler.next_f64() >= q {
            return false;
        }
        for t in self.throughput.iter_mut() {
            *t = *t * (1.0 / q);
        }
        true
    }
}

/// How a shared flight ended.
enum Outcome {
    /// Collision at distance `t` in `layer`.
    Collided {
        t: f64,
        layer: usize,
    },
    Ground {
        t: f64,
    },
    Escaped,
}

impl SpectralScene {
    /// A scene over `media` (one per wavelength, same levels).
    pub fn new(
        geometry: Geometry,
        media: Vec<Medium>,
        sun: Sun,
        albedos: Vec<f64>,
        settings: Settings,
    ) -> SpectralScene {
        let layers = media[0].levels_km().len() - 1;
        let sigma_t = (0..layers)
            .flat_map(|l| media.iter().map(move |m| m.sigma_maj(l)))
            .collect();
        let steps = media
            .iter()
            .flat_map(|m| density_steps(&(0..layers).map(|l| m.sigma_maj(l)).collect::<Vec<_>>()))
            .collect();
        // Constant per layer (the media are piecewise constant).
        let coeffs: Vec<PointCoefficients> = (0..layers)
            .flat_map(|l| {
                let mid = 0.5 * (media[0].levels_km()[l] + media[0].levels_km()[l + 1]);
                media.iter().map(move |m| m.at(l, mid))
            })
            .collect();
        SpectralScene {
            geometry,
            media,
            sun,
            albedos,
            settings,
            sigma_t,
            steps,
            sigma_s: coeffs.iter().map(PointCoefficients::sigma_s).collect(),
            mixtures: coeffs.iter().map(phase_mixture).collect(),
        }
    }

    /// Adds σ_t(λ)·`len` of `layer` to every wavelength's `tau`.
    #[inline]
    fn accumulate(&self, tau: &mut [f64], layer: usize, len: f64) {
        let n = tau.len();
        for (t, s) in tau.iter_mut().zip(&self.sigma_t[layer * n..(layer + 1) * n]) {
            *t += s * len;
        }
    }

    /// Whether shared paths can render these media: piecewise-constant
    /// coefficients and forced collisions.
    pub fn supported(media: &[Medium], settings: &Settings) -> bool {
        settings.forced_collisions && media.iter().all(Medium::is_piecewise_constant)
    }

    fn observer_position(&self, altitude_km: f64) -> DVec3 {
        match self.geometry {
            Geometry::Spherical { radius_km } => DVec3::new(0.0, 0.0, radius_km + altitude_km),
            Geometry::PlaneParallel => DVec3::new(0.0, 0.0, altitude_km),
        }
    }

    fn reflects(&self) -> bool {
        self.albedos.iter().any(|&a| a > 0.0)
    }

    fn order_done(&self, order: u32) -> bool {
        self.settings.max_scattering_order != 0 && order >= self.settings.max_scattering_order
    }

    /// One sample of the diffuse Stokes radiance at every wavelength and
    /// albedo, arriving from `view` (see `integrator::Scene::radiance_sample`).
    pub fn radiance_sample(
        &self,
        altitude_km: f64,
        view: DVec3,
        phi_fallback: f64,
        sampler: &mut Sampler,
    ) -> SpectralRadiances {
        WORK.with_borrow_mut(|path| {
            let n = self.media.len();
            let albedos = self.albedos.len().min(MAX_ALBEDOS);
            let (e1, _) = meridian_frame(view, phi_fallback);
            let hero = ((sampler.next_f64() * n as f64) as usize).min(n - 1);
            let levels = self.media[0].levels_km();
            path.reset(n, levels.len(), albedos, e1, hero);
            let origin = self.observer_position(altitude_km);
            let up = self.geometry.up(origin);
            match tracking::layer_at(levels, altitude_km, view.dot(up)) {
                Some(layer) => self.trace(
                    path,
                    Ray {
                        origin,
                        dir: view,
                        layer,
                    },
                    sampler,
                ),
                None => {
                    if altitude_km <= levels[0] && view.dot(up) < 0.0 && self.ground(path, origin, sampler) {
                        let dir = cosine_hemisphere(up, sampler.next2());
                        self.trace(path, Ray { origin, dir, layer: 0 }, sampler);
                    }
                }
            }
            SpectralRadiances {
                values: path.radiance.clone(),
                wavelengths: n,
                albedos,
            }
        })
    }

    fn trace(&self, path: &mut Path, mut ray: Ray, sampler: &mut Sampler) {
        let n = self.media.len();
        loop {
            let mut tau_exit = std::mem::take(&mut path.tau_exit);
            let end = self.exit_depths(&ray, &mut path.chords, &mut tau_exit);
            path.tau_exit = tau_exit;
            let Some(end) = end else { return };
            let analog = matches!(end, WalkEnd::Ground { .. }) && self.reflects();
            match self.flight(path, &ray, end, analog, sampler) {
                Outcome::Escaped => return,
                Outcome::Ground { t } => {
                    let x = ray.origin + t * ray.dir;
                    if !self.ground(path, x, sampler) {
                        return;
                    }
                    let dir = cosine_hemisphere(self.geometry.up(x), sampler.next2());
                    ray = Ray {
                        origin: x,
                        dir,
                        layer: 0,
                    };
                }
                Outcome::Collided { t, layer } => {
                    let x = ray.origin + t * ray.dir;
                    let mixtures = &self.mixtures[layer * n..(layer + 1) * n];
                    let k_out = -ray.dir;
                    path.order += 1;
                    self.sun_from_scattering(path, x, layer, k_out, sampler);
                    if self.order_done(path.order) {
                        return;
                    }
                    // Direction from one wavelength's phase function, picked
                    // uniformly, weighted by the mixture of all wavelengths'
                    // densities.
                    let pick = ((sampler.next_f64() * n as f64) as usize).min(n - 1);
                    let coeffs = self.media[pick].at(layer, self.geometry.altitude(x));
                    let component = pick_component(&coeffs, sampler.next_f64());
                    let (k_in, _) = component.sample_direction(k_out, sampler.next2());
                    let cos = k_in.dot(k_out);
                    path.matrices.clear();
                    path.matrices.extend(mixtures.iter().map(|m| m.matrix(cos)));
                    let inv_mean_p11 = n as f64 / path.matrices.iter().map(|m| m.p11).sum::<f64>();
                    let (rotation, e1_in) = scattering_frame(path.frame_e1, k_in, k_out);
                    for (t, m) in path.throughput.iter_mut().zip(&path.matrices) {
                        *t = if self.settings.polarized {
                            rotation.right_of_then(t, &m.scaled(inv_mean_p11))
                        } else {
                            *t * Mueller::depolarizer(m.p11 * inv_mean_p11)
                        };
                    }
                    path.frame_e1 = e1_in;
                    if !path.roulette(sampler) {
                        return;
                    }
                    ray = Ray {
                        origin: x,
                        dir: -k_in,
                        layer,
                    };
                }
            }
        }
    }

    /// Every wavelength's optical depth from the ray's origin to where it
    /// leaves (top or ground) into `tau`, and how it leaves; `None` for an
    /// endless (horizontal plane-parallel) ray. `chords` is scratch.
    fn exit_depths(&self, ray: &Ray, chords: &mut [f64], tau: &mut [f64]) -> Option<WalkEnd> {
        let n = tau.len();
        let levels = self.media[0].levels_km();
        tau.fill(0.0);
        match self.geometry {
            Geometry::Spherical { radius_km } => {
                let exit = tracking::shell_exit(radius_km, levels, ray);
                // The levels crossed, in one run: twice (a dip), then once.
                let start = if exit.twice.is_empty() {
                    exit.once.start
                } else {
                    exit.twice.start
                };
                let range = start..exit.once.end;
                let c = &mut chords[range.clone()];
                tracking::half_chords_into(radius_km, &levels[range.clone()], exit.h, c);
                c[..exit.twice.len()].iter_mut().for_each(|x| *x *= 2.0);
                let base = &self.sigma_t[ray.layer * n..(ray.layer + 1) * n];
                let stride = levels.len();
                for (w, (t, s)) in tau.iter_mut().zip(base).enumerate() {
                    let steps = &self.steps[w * stride + range.start..w * stride + range.end];
                    *t = (tracking::dot(c, steps) - exit.b * s).max(0.0);
                }
                Some(exit.end(radius_km, levels, ray))
            }
            Geometry::PlaneParallel => {
                let mut endless = false;
                let end = tracking::walk(&self.geometry, levels, ray, |seg| {
                    if seg.t1.is_finite() {
                        self.accumulate(tau, seg.layer, seg.t1 - seg.t0);
                    } else {
                        endless = true;
                    }
                    ControlFlow::Continue(())
                });
                (!endless).then_some(end)
            }
        }
    }

    /// Samples the flight's outcome with the path's hero wavelength; every
    /// wavelength's integrand and density go in over the hero's density.
    /// `path.tau_exit` holds the depths to the flight's `end`.
    fn flight(&self, path: &mut Path, ray: &Ray, end: WalkEnd, analog: bool, sampler: &mut Sampler) -> Outcome {
        let hero = path.hero;
        let u = sampler.next_f64();
        let target = if analog {
            let tau = -(1.0 - u).ln();
            if tau >= path.tau_exit[hero] {
                // The ground, reached with probability e^(−τ) at every λ.
                let hero_p = (-path.tau_exit[hero]).exp();
                for w in 0..self.media.len() {
                    let k = (-path.tau_exit[w]).exp() / hero_p;
                    path.throughput[w] = path.throughput[w] * k;
                    path.scale_density(w, k);
                }
                path.densities_changed();
                let WalkEnd::Ground { t } = end else {
                    unreachable!("analog flights end on the ground")
                };
                return Outcome::Ground { t };
            }
            tau
        } else {
            // Forcing probabilities 1 − e^(−τ).
            for (p, t) in path.forced.iter_mut().zip(&path.tau_exit) {
                *p = -(-t).exp_m1();
            }
            if path.forced[hero] <= 0.0 {
                return Outcome::Escaped;
            }
            tracking::forced_distance(u, path.forced[hero])
        };
        // Locate the collision along the hero's optical depth, with every
        // wavelength's depth to it accumulated on the way.
        let hero_medium = &self.media[hero];
        let mut acc = 0.0;
        let mut hit = None;
        let mut last = None;
        path.tau_hit.fill(0.0);
        tracking::walk(&self.geometry, hero_medium.levels_km(), ray, |s| {
            let sigma = hero_medium.sigma_maj(s.layer);
            let d = sigma * (s.t1 - s.t0);
            if sigma > 0.0 && acc + d >= target {
                let t = (s.t0 + (target - acc) / sigma).min(s.t1);
                self.accumulate(&mut path.tau_hit, s.layer, t - s.t0);
                hit = Some((t, s.layer));
                return ControlFlow::Break(());
            }
            self.accumulate(&mut path.tau_hit, s.layer, s.t1 - s.t0);
            acc += d;
            last = Some((s.t1, s.layer));
            ControlFlow::Continue(())
        });
        let Some((t, layer)) = hit.or(last) else {
            return Outcome::Escaped;
        };
        // The collision's density per wavelength (σ_t·e^(−τ), over the
        // forcing probability for a forced flight), over the hero's.
        let n = self.media.len();
        let sigma_t = &self.sigma_t[layer * n..(layer + 1) * n];
        let sigma_s = &self.sigma_s[layer * n..(layer + 1) * n];
        let density = |w: usize, transmittance: f64, path: &Path| {
            let q = sigma_t[w] * transmittance;
            if analog {
                q
            } else if path.forced[w] > 0.0 {
                q / path.forced[w]
            } else {
                0.0
            }
        };
        let inv_hero = 1.0 / density(hero, (-path.tau_hit[hero]).exp(), path);
        for (w, sigma_s) in sigma_s.iter().enumerate() {
            let transmittance = (-path.tau_hit[w]).exp();
            let k = density(w, transmittance, path) * inv_hero;
            path.throughput[w] = path.throughput[w] * (sigma_s * transmittance * inv_hero);
            path.scale_density(w, k);
        }
        path.densities_changed();
        Outcome::Collided { t, layer }
    }

    /// Every wavelength's optical depth toward the sun from `x` into
    /// `path.tau_exit`; false when the shadow ray hits the planet.
    fn sun_depths(&self, path: &mut Path, x: DVec3, dir: DVec3, layer: usize) -> bool {
        let mut tau = std::mem::take(&mut path.tau_exit);
        let end = self.exit_depths(&Ray { origin: x, dir, layer }, &mut path.chords, &mut tau);
        path.tau_exit = tau;
        matches!(end, Some(WalkEnd::Top { .. }))
    }

    fn sun_from_scattering(&self, path: &mut Path, x: DVec3, layer: usize, k_out: DVec3, sampler: &mut Sampler) {
        let n = self.media.len();
        let mixtures = &self.mixtures[layer * n..(layer + 1) * n];
        let s = self.sun.sample_direction(sampler.next2());
        if !self.sun_depths(path, x, s, layer) {
            return;
        }
        let k_in = -s;
        let cos = k_in.dot(k_out);
        let (rotation, _) = scattering_frame(path.frame_e1, k_in, k_out);
        for (w, mixture) in mixtures.iter().enumerate() {
            let tr = (-path.tau_exit[w]).exp();
            if tr <= 0.0 {
                continue;
            }
            let m = mixture.matrix(cos);
            let column = if self.settings.polarized {
                rotation.column_of(&path.throughput[w], &m)
            } else {
                path.throughput[w] * Stokes::new(m.p11, 0.0, 0.0, 0.0)
            };
            path.add(w, column * (tr * INV_4PI));
        }
    }

    /// A ground vertex: NEE to the sun for every wavelength, then the
    /// Lambertian weight. Returns whether the path goes on.
    fn ground(&self, path: &mut Path, x: DVec3, sampler: &mut Sampler) -> bool {
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
        if mu_s > 0.0 && self.sun_depths(path, x, s, 0) {
            for w in 0..self.media.len() {
                let f = FRAC_1_PI * mu_s * (-path.tau_exit[w]).exp();
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
