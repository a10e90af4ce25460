//! A measurement, not a feature: does a bidirectional estimator carry
//! twilight light more cheaply than the tracer's sun-aware connections?
//! (docs/lab-notes/2026-11-28.md, "Measured on 2026-11-28 and not kept", items 13 and 14.)
//!
//! For one wavelength, scalar (I only), a point sun, a black ground and
//! the layered medium of a directions job's first task (spherical
//! geometry, `aerosol_phase = "hg"`), it estimates the radiance at the
//! observer along given directions with bidirectional path tracing:
//! - a sensor subpath from the eye along the direction (free flights,
//!   phase-sampled directions, with `--lobe` some from a lobe toward the
//!   sunlit air), connected to the sun at every collision,
//!   or with `--sun along` from one point drawn along every flight, as
//!   the tracer's sun-aware connections are (here from a cruder density);
//!   with `--forced`, its flights collide before they leave, with Russian
//!   roulette, as the tracer's do;
//! - `--lights` light subpaths per sample, each entering the atmosphere
//!   along the sun's beam through a disc across it (centred on the
//!   observer's line, half the draws within `--disc` A km of it, half
//!   within B km), then free flights and phase-sampled directions;
//! - every sensor vertex connected to every light vertex (`point`),
//!   and/or every sensor flight to every light vertex at a point drawn
//!   along the flight by equiangular sampling toward it (`equiangular`);
//! - the balance heuristic over every way the path could have been made
//!   (each split between the two subpaths with at least one sensor
//!   vertex, and each way of drawing the last sensor vertex), so the
//!   estimate is unbiased whatever the subpaths' densities.
//!
//! With `--extra N` (and no light subpaths) each collision also gets N
//! directions that are not followed, only connected to the sun along
//! their flights (docs/lab-notes/2026-11-28.md, item 14).
//!
//! With `--sun along --forced --lobe 0.3` its sensor side is about as
//! noisy as the tracer's (a fixed lobe, cruder densities, no Mie phase
//! functions); what it measures is what light subpaths add to it.
//!
//! It prints per direction the mean, its standard error, a path's variance
//! of I over I², the time per sample and each part's share and variance:
//! compare with `atmosim render` of the same job (its `radiance.csv`:
//! `I_se` over I, squared, times `samples`).
//!
//! ```text
//! cargo run --release --example bidirectional_probe -- \
//!     examples/twilight_bidirectional.toml --paths 1000000 --seed 21 0:0 60:180 85:0
//! ```

// Built as a test too (Cargo.toml), where `main` and what only it uses
// are not called.
#![cfg_attr(test, allow(dead_code))]

use std::f64::consts::PI;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use atmosim::geometry::basis::orthonormal_basis;
use atmosim::geometry::ray::{Ray, WalkEnd, layer_at, walk};
use atmosim::geometry::shell::Geometry;
use atmosim::job::Job;
use atmosim::job::options::MediumModel;
use atmosim::polarization::phase::PhaseFunction;
use atmosim::sampling::sampler::Sampler;
use atmosim::transport::free_flight::{FlightEnd, forced_distance, locate_with, sample_t_maj};
use atmosim::transport::medium::Medium;
use atmosim::transport::optical_depth::{optical_depth, optical_depth_to};
use clap::Parser;
use glam::DVec3;

/// The most vertices of either subpath (a bound far above what a path
/// reaches in the atmosphere; a longer one would be left out).
const MAX_VERTICES: usize = 200;

#[derive(Parser)]
#[command(about = "Bidirectional twilight probe (a measurement; docs/lab-notes/2026-11-28.md, item 13 of 2026-11-28)")]
struct Args {
    /// A directions job (spherical, one wavelength; its first task).
    job: PathBuf,
    /// Directions as view_zenith_deg:azimuth_deg (azimuth from the sun's).
    #[arg(required = true)]
    directions: Vec<String>,
    /// Samples per direction.
    #[arg(long, default_value_t = 200_000)]
    paths: u64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Light subpaths per sample (0: the sensor subpath and its sun
    /// connections alone).
    #[arg(long, default_value_t = 1)]
    lights: u32,
    /// The two disc radii (km) the light subpaths enter through.
    #[arg(long, value_delimiter = ',', default_values_t = [300.0, 1500.0])]
    disc: Vec<f64>,
    /// Connections: "point", "equiangular" or "both".
    #[arg(long, default_value = "both")]
    connections: String,
    /// How sensor subpaths reach the sun: "collision" (a shadow ray from
    /// every collision) or "along" (from one point drawn along every
    /// flight, as the tracer's sun-aware connections; here from a
    /// piecewise-constant density over pieces of at most `--piece-km`, mixed 0.8 :
    /// 0.2 with the flight's own).
    #[arg(long, default_value = "collision")]
    sun: String,
    /// Sensor subpaths collide before they leave (each flight's weight
    /// times its chance of a collision), with Russian roulette below a
    /// throughput of 0.03, as the tracer's do; the densities in the
    /// weights stay those of free flights (any weights that sum to 1 over
    /// the ways of making a path keep the estimate unbiased).
    #[arg(long)]
    forced: bool,
    /// The share of the sensor subpath's scattering directions drawn from
    /// a lobe toward the sunlit air (Henyey–Greenstein, g 0.8, about an
    /// axis 5° above the horizon toward the sun: the tracer's lobe before
    /// it was tabulated), each weighed by the phase function over the
    /// mixture. 0: none.
    #[arg(long, default_value_t = 0.0)]
    lobe: f64,
    /// With `--sun along` and no light subpaths: at every collision, this
    /// many more directions drawn as the path's own (not followed), each
    /// with its point along the flight toward the sun; the path's own
    /// flight and these share the estimate of that vertex's in-scattered
    /// sunlit single scattering equally.
    #[arg(long, default_value_t = 0)]
    extra: u32,
    /// Where `--extra` applies: "all" collisions or the "first" only.
    #[arg(long, default_value = "all")]
    extra_at: String,
    /// The longest piece (km) of the `--sun along` density.
    #[arg(long, default_value_t = 2.0)]
    piece_km: f64,
}

const LOBE: PhaseFunction = PhaseFunction::HenyeyGreenstein { g: 0.8 };

/// A density along a ray for the point a sun connection is made from:
/// share [`SUN_SHARE`] piecewise constant in proportion to the sunlit
/// single scattering at each piece's middle, the rest the flight's own
/// (σ_t·e^(−τ), truncated at the exit).
struct SunDensity {
    /// Per piece: start, end, σ_t, optical depth at its start, value per km.
    pieces: Vec<(f64, f64, f64, f64, f64)>,
    /// Σ value × length.
    total: f64,
    /// Optical depth to the exit.
    tau_exit: f64,
}

const SUN_SHARE: f64 = 0.8;

impl SunDensity {
    fn piece_at(&self, t: f64) -> usize {
        self.pieces.partition_point(|p| p.1 < t).min(self.pieces.len() - 1)
    }
    fn tau_at(&self, t: f64) -> f64 {
        let p = self.pieces[self.piece_at(t)];
        p.3 + p.2 * (t - p.0)
    }
    fn share(&self) -> f64 {
        if self.total > 0.0 { SUN_SHARE } else { 0.0 }
    }
    fn pdf(&self, t: f64) -> f64 {
        let p = self.pieces[self.piece_at(t)];
        let flight = p.2 * (-(p.3 + p.2 * (t - p.0))).exp() / (1.0 - (-self.tau_exit).exp());
        let sun = if self.total > 0.0 { p.4 / self.total } else { 0.0 };
        self.share() * sun + (1.0 - self.share()) * flight
    }
    fn sample(&self, sampler: &mut Sampler) -> f64 {
        let [u0, u1] = sampler.next2();
        if sampler.next_f64() < self.share() {
            let target = u0 * self.total;
            let mut acc = 0.0;
            for p in &self.pieces {
                let w = p.4 * (p.1 - p.0);
                if acc + w >= target && w > 0.0 {
                    return p.0 + u1 * (p.1 - p.0);
                }
                acc += w;
            }
            let p = self.pieces[self.pieces.len() - 1];
            p.0 + u1 * (p.1 - p.0)
        } else {
            let tau = -(1.0 - u0 * (1.0 - (-self.tau_exit).exp())).ln();
            let i = self
                .pieces
                .partition_point(|p| p.3 + p.2 * (p.1 - p.0) < tau)
                .min(self.pieces.len() - 1);
            let p = self.pieces[i];
            if p.2 > 0.0 {
                (p.0 + (tau - p.3) / p.2).clamp(p.0, p.1)
            } else {
                p.0
            }
        }
    }
}

/// A vertex: its position and its layer's optics.
#[derive(Clone, Copy)]
struct Vertex {
    x: DVec3,
    sigma_t: f64,
    sigma_s: f64,
    rayleigh: f64,
    aerosol: f64,
    depolarization: f64,
    g: f64,
}

/// One flight of the sensor subpath: origin, direction and the distance
/// to where it leaves the atmosphere or meets the ground.
struct Flight {
    origin: DVec3,
    dir: DVec3,
    exit: f64,
    /// The factor of forced collisions and roulette on the path before it.
    factor: f64,
}

/// A whole path, eye side first.
#[derive(Default)]
struct FullPath {
    v: Vec<Vertex>,
    /// `t[i]`: transmittance between `v[i]` and `v[i + 1]`.
    t: Vec<f64>,
    /// Transmittance from the eye to `v[0]`.
    t_eye: f64,
    /// `exit[i]`: the exit distance of the ray from `v[i − 1]` (the eye
    /// for `i = 0`) through `v[i]`.
    exit: Vec<f64>,
}

/// How often each way of making a path is drawn per sample.
struct Counts {
    point: f64,
    equiangular: f64,
}

struct World {
    medium: Medium,
    /// Each layer's σ_t, for locating forced collisions.
    sigma_t: Vec<f64>,
    geometry: Geometry,
    radius: f64,
    top_radius: f64,
    sun: DVec3,
    eye: DVec3,
    disc: [f64; 2],
    /// The sensor side's lobe share (`--lobe`).
    lobe: f64,
    /// The longest piece of the sun-connection density (`--piece-km`).
    piece_km: f64,
}

impl World {
    fn vertex(&self, x: DVec3, layer: usize) -> Vertex {
        let o = self.medium.at(layer, self.geometry.altitude(x));
        Vertex {
            x,
            sigma_t: o.sigma_t,
            sigma_s: o.sigma_s(),
            rayleigh: o.sigma_rayleigh,
            aerosol: o.sigma_aerosol_sca,
            depolarization: o.rayleigh_depolarization,
            g: o.aerosol_g,
        }
    }

    /// A direction from `v` for a sensor subpath arriving along `d_in`:
    /// from the phase function or, with share `lobe`, the lobe; and its
    /// weight, the phase function over the mixture.
    fn scatter(&self, v: &Vertex, d_in: DVec3, sampler: &mut Sampler) -> (DVec3, f64) {
        if self.lobe <= 0.0 {
            return (self.sample_direction(v, d_in, sampler), 1.0);
        }
        let next = if sampler.next_f64() < self.lobe {
            LOBE.sample_direction(self.lobe_axis(v.x), sampler.next2()).0
        } else {
            self.sample_direction(v, d_in, sampler)
        };
        let phase = self.phase(v, d_in.dot(next));
        let lobe = LOBE.pdf(self.lobe_axis(v.x).dot(next));
        (next, phase / ((1.0 - self.lobe) * phase + self.lobe * lobe))
    }

    /// The axis of the lobe toward the sunlit air at `x`: 5° above the
    /// local horizon toward the sun's azimuth.
    fn lobe_axis(&self, x: DVec3) -> DVec3 {
        let up = self.geometry.up(x);
        let toward = (self.sun - self.sun.dot(up) * up).normalize();
        let (s, c) = 5f64.to_radians().sin_cos();
        c * toward + s * up
    }

    /// The vertex at `x`, if inside the atmosphere.
    fn vertex_at(&self, x: DVec3) -> Option<Vertex> {
        let levels = self.medium.levels_km();
        let layer = layer_at(levels, self.geometry.altitude(x).max(levels[0]), 0.0)?;
        Some(self.vertex(x, layer))
    }

    /// The phase function over 4π at `v`: also the density per steradian
    /// of a direction drawn there.
    fn phase(&self, v: &Vertex, cos: f64) -> f64 {
        let r = PhaseFunction::Rayleigh {
            depolarization: v.depolarization,
        }
        .p11(cos);
        let a = if v.aerosol > 0.0 {
            PhaseFunction::HenyeyGreenstein { g: v.g }.p11(cos)
        } else {
            0.0
        };
        (v.rayleigh * r + v.aerosol * a) / (v.sigma_s * 4.0 * PI)
    }

    fn sample_direction(&self, v: &Vertex, k_in: DVec3, sampler: &mut Sampler) -> DVec3 {
        let u = sampler.next2();
        let phase = if sampler.next_f64() * v.sigma_s < v.rayleigh {
            PhaseFunction::Rayleigh {
                depolarization: v.depolarization,
            }
        } else {
            PhaseFunction::HenyeyGreenstein { g: v.g }
        };
        phase.sample_direction(k_in, u).0
    }

    fn ray(&self, origin: DVec3, dir: DVec3) -> Option<Ray> {
        let levels = self.medium.levels_km();
        let z = self.geometry.altitude(origin).max(levels[0]);
        let layer = layer_at(levels, z, self.geometry.up(origin).dot(dir))?;
        Some(Ray { origin, dir, layer })
    }

    /// A free flight: the collision and the transmittance to it.
    fn flight(&self, origin: DVec3, dir: DVec3, sampler: &mut Sampler) -> Option<(Vertex, f64)> {
        let ray = self.ray(origin, dir)?;
        let levels = self.medium.levels_km();
        let end = sample_t_maj(
            |l| self.medium.sigma_maj(l),
            &self.geometry,
            levels,
            &ray,
            sampler,
            |_, _| false,
        );
        let FlightEnd::Collided(c) = end else { return None };
        let tau = optical_depth_to(&self.medium, &self.geometry, &ray, c.t);
        Some((self.vertex(origin + c.t * dir, c.layer), (-tau).exp()))
    }

    /// A forced free flight: a collision before the ray leaves, drawn in
    /// proportion to σ_t·e^(−τ) over the ray, its transmittance, and the
    /// chance of a collision at all (the flight's weight).
    fn forced_flight(&self, origin: DVec3, dir: DVec3, sampler: &mut Sampler) -> Option<(Vertex, f64, f64)> {
        let ray = self.ray(origin, dir)?;
        let levels = self.medium.levels_km();
        let (tau_exit, _) = optical_depth(&self.medium, &self.geometry, &ray);
        let chance = -(-tau_exit).exp_m1();
        if chance <= 0.0 {
            return None;
        }
        let tau = forced_distance(sampler.next_f64(), chance);
        let c = locate_with(&self.sigma_t, &self.geometry, levels, &ray, tau);
        Some((self.vertex(origin + c.t * dir, c.layer), (-tau).exp(), chance))
    }

    fn exit(&self, origin: DVec3, dir: DVec3) -> f64 {
        let Some(ray) = self.ray(origin, dir) else { return 0.0 };
        match walk(&self.geometry, self.medium.levels_km(), &ray, |_| {
            ControlFlow::Continue(())
        }) {
            WalkEnd::Ground { t } | WalkEnd::Top { t } => t,
            WalkEnd::Endless | WalkEnd::Stopped => f64::INFINITY,
        }
    }

    /// Transmittance between two points (0 where the planet is between).
    fn transmittance(&self, a: DVec3, b: DVec3) -> f64 {
        let d = b - a;
        let len = d.length();
        let dir = d / len;
        let closest = (-a.dot(dir)).clamp(0.0, len);
        if (a + closest * dir).length() < self.radius * (1.0 - 1e-12) {
            return 0.0;
        }
        let Some(ray) = self.ray(a, dir) else { return 0.0 };
        (-optical_depth_to(&self.medium, &self.geometry, &ray, len)).exp()
    }

    /// Transmittance toward the sun (0 where the planet hides it).
    fn sun_transmittance(&self, x: DVec3) -> f64 {
        let Some(ray) = self.ray(x, self.sun) else { return 0.0 };
        match optical_depth(&self.medium, &self.geometry, &ray) {
            (_, WalkEnd::Ground { .. }) => 0.0,
            (tau, _) => (-tau).exp(),
        }
    }

    /// The sun-connection density along the ray from `origin` along `dir`.
    fn sun_density(&self, origin: DVec3, dir: DVec3) -> Option<SunDensity> {
        let ray = self.ray(origin, dir)?;
        let cos = self.sun.dot(dir);
        let mut d = SunDensity {
            pieces: Vec::new(),
            total: 0.0,
            tau_exit: 0.0,
        };
        let mut tau = 0.0;
        walk(&self.geometry, self.medium.levels_km(), &ray, |seg| {
            if !seg.t1.is_finite() {
                return ControlFlow::Break(());
            }
            let sigma = self.medium.layer_sigma_t(seg.layer);
            let n = ((seg.t1 - seg.t0) / self.piece_km).ceil().max(1.0) as usize;
            let len = (seg.t1 - seg.t0) / n as f64;
            for i in 0..n {
                let t0 = seg.t0 + i as f64 * len;
                let mid = origin + (t0 + 0.5 * len) * dir;
                let v = self.vertex(mid, seg.layer);
                let value = if v.sigma_s > 0.0 {
                    v.sigma_s * self.phase(&v, cos) * (-(tau + 0.5 * sigma * len)).exp() * self.sun_transmittance(mid)
                } else {
                    0.0
                };
                d.pieces.push((t0, t0 + len, sigma, tau, value));
                d.total += value * len;
                tau += sigma * len;
            }
            ControlFlow::Continue(())
        });
        d.tau_exit = tau;
        (!d.pieces.is_empty() && tau > 0.0).then_some(d)
    }

    /// The density (per km² across the beam) of the disc point whose
    /// line along the beam passes through `x`.
    fn disc_density(&self, x: DVec3) -> f64 {
        let d = x - self.eye;
        let r = (d - d.dot(self.sun) * self.sun).length();
        self.disc.iter().filter(|&&a| r < a).map(|&a| 0.5 / (PI * a * a)).sum()
    }

    /// A light subpath's first vertex and the sun's transmittance to it.
    fn light_start(&self, sampler: &mut Sampler) -> Option<(Vertex, f64)> {
        let [u0, u1] = sampler.next2();
        let radius = if sampler.next_f64() < 0.5 {
            self.disc[0]
        } else {
            self.disc[1]
        };
        let (r, phi) = (radius * u0.sqrt(), 2.0 * PI * u1);
        let (b1, b2) = orthonormal_basis(self.sun);
        let c = self.eye + r * (phi.cos() * b1 + phi.sin() * b2);
        let cs = c.dot(self.sun);
        let disc = cs * cs - (c.length_squared() - self.top_radius * self.top_radius);
        if disc <= 0.0 {
            return None;
        }
        let entry = c + (disc.sqrt() - cs - 1e-7) * self.sun;
        let (v, t) = self.flight(entry, -self.sun, sampler)?;
        Some((v, t))
    }

    /// f over the sum of count × density of every way of making `p` with
    /// its first `k` vertices from the sensor side (`sun_tr`: the sun's
    /// transmittance to its last vertex).
    fn contribution(
        &self,
        p: &FullPath,
        k: usize,
        sun_tr: f64,
        counts: &Counts,
        phase: &mut Vec<f64>,
        last: f64,
    ) -> f64 {
        let n = p.v.len();
        phase.clear();
        for i in 0..n {
            let prev = if i == 0 { self.eye } else { p.v[i - 1].x };
            let out = (prev - p.v[i].x).normalize();
            let inc = if i + 1 == n {
                -self.sun
            } else {
                (p.v[i].x - p.v[i + 1].x).normalize()
            };
            phase.push(self.phase(&p.v[i], inc.dot(out)));
        }
        let g = |i: usize| p.t[i] / (p.v[i + 1].x - p.v[i].x).length_squared();
        let disc = self.disc_density(p.v[n - 1].x);
        // The sensor side's density of the direction from v[i] to v[i + 1]:
        // the phase function, mixed with the lobe where there is one.
        let sensor_direction = |i: usize| {
            if self.lobe > 0.0 {
                let dir = (p.v[i + 1].x - p.v[i].x).normalize();
                (1.0 - self.lobe) * phase[i] + self.lobe * LOBE.pdf(self.lobe_axis(p.v[i].x).dot(dir))
            } else {
                phase[i]
            }
        };
        // f over the density of drawing the path split at k with x_k at a
        // collision: the albedos, the phase at the ends of the connection
        // and the connection itself.
        let mut weight: f64 = p.v.iter().map(|v| v.sigma_s / v.sigma_t).product();
        weight *= phase[k - 1];
        if k < n {
            weight *= g(k - 1) * phase[k] / disc;
        } else {
            weight *= sun_tr;
        }
        if weight == 0.0 || !weight.is_finite() {
            return 0.0;
        }
        // The density of the split at m + 1 over that at m (1-based).
        let ratio = |m: usize| {
            if m + 1 < n {
                sensor_direction(m - 1) * g(m - 1) / (phase[m + 1] * g(m))
            } else {
                sensor_direction(m - 1) * g(m - 1) / (sun_tr * disc)
            }
        };
        // x_m drawn by equiangular sampling over drawn at a collision.
        let equiangular = |m: usize| {
            let o = if m == 1 { self.eye } else { p.v[m - 2].x };
            let d = p.v[m - 1].x - o;
            let t = d.length();
            let q = equiangular_density(o, d / t, p.exit[m - 1], p.v[m].x, t);
            let tm = if m == 1 { p.t_eye } else { p.t[m - 2] };
            q / (p.v[m - 1].sigma_t * tm)
        };
        let count = |m: usize| {
            if m == n {
                last
            } else if counts.equiangular > 0.0 {
                counts.point + counts.equiangular * equiangular(m)
            } else {
                counts.point
            }
        };
        let mut sum = count(k);
        let mut r = 1.0;
        for m in k..n {
            r *= ratio(m);
            sum += count(m + 1) * r;
        }
        let mut r = 1.0;
        for m in (1..k).rev() {
            r /= ratio(m);
            sum += count(m) * r;
        }
        weight / sum
    }
}

/// The equiangular density (per km) at distance `t` along the ray
/// (`o`, `u`) over [0, `t_max`] toward `c`.
fn equiangular_density(o: DVec3, u: DVec3, t_max: f64, c: DVec3, t: f64) -> f64 {
    let (delta, h, a, b) = equiangular_frame(o, u, t_max, c);
    h / ((b - a) * (h * h + (t - delta) * (t - delta)))
}

fn equiangular_frame(o: DVec3, u: DVec3, t_max: f64, c: DVec3) -> (f64, f64, f64, f64) {
    let delta = (c - o).dot(u);
    let h = (c - o - delta * u).length().max(1e-9);
    (delta, h, (-delta / h).atan(), ((t_max - delta) / h).atan())
}

fn equiangular_sample(o: DVec3, u: DVec3, t_max: f64, c: DVec3, xi: f64) -> f64 {
    let (delta, h, a, b) = equiangular_frame(o, u, t_max, c);
    (delta + h * (a + xi * (b - a)).tan()).clamp(0.0, t_max)
}

/// Running sums of a value and its square.
#[derive(Default, Clone, Copy)]
struct Moments {
    sum: f64,
    sum2: f64,
}

impl Moments {
    fn add(&mut self, x: f64) {
        self.sum += x;
        self.sum2 += x * x;
    }
    fn variance(&self, n: f64) -> f64 {
        (self.sum2 / n - (self.sum / n).powi(2)) * n / (n - 1.0)
    }
}

fn parse_direction(text: &str) -> Result<DVec3> {
    let (z, a) = text
        .split_once(':')
        .with_context(|| format!("direction {text:?}: expected view_zenith_deg:azimuth_deg"))?;
    let z: f64 = z.parse().with_context(|| format!("direction {text:?}: view zenith"))?;
    let a: f64 = a.parse().with_context(|| format!("direction {text:?}: azimuth"))?;
    let (z, a) = (z.to_radians(), a.to_radians());
    Ok(DVec3::new(z.sin() * a.cos(), z.sin() * a.sin(), z.cos()))
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(2);
    }
}

fn run(args: Args) -> Result<()> {
    let (point, equiangular) = match args.connections.as_str() {
        "point" => (true, false),
        "equiangular" => (false, true),
        "both" => (true, true),
        other => bail!("--connections {other:?}: expected point, equiangular or both"),
    };
    let sun_along = match args.sun.as_str() {
        "collision" => false,
        "along" => true,
        other => bail!("--sun {other:?}: expected collision or along"),
    };
    if args.disc.len() != 2 || args.disc.iter().any(|&r| r <= 0.0 || !r.is_finite()) {
        bail!("--disc: expected two radii in km above 0, e.g. 300,1500");
    }
    if !(args.piece_km > 0.0 && args.piece_km.is_finite()) {
        bail!("--piece-km {}: expected a length in km above 0", args.piece_km);
    }
    if !(0.0..1.0).contains(&args.lobe) {
        bail!("--lobe {}: expected a share in [0, 1)", args.lobe);
    }
    let extra_first = match args.extra_at.as_str() {
        "all" => false,
        "first" => true,
        other => bail!("--extra-at {other:?}: expected all or first"),
    };
    if args.extra > 0 && (args.lights > 0 || args.sun != "along") {
        bail!("--extra: only with --sun along and --lights 0");
    }
    if args.paths < 2 {
        bail!("--paths: at least 2");
    }
    let lights = args.lights as f64;
    let counts = Counts {
        point: if point { lights } else { 0.0 },
        equiangular: if equiangular { lights } else { 0.0 },
    };
    let job = Job::from_file(&args.job)?;
    let Geometry::Spherical { radius_km } = job.geometry() else {
        bail!("{}: the probe is for spherical geometry", args.job.display());
    };
    let task = &job.tasks[0];
    let medium = Medium::new(&task.atmosphere, 0, MediumModel::Layered, 1.0);
    let top = medium.levels_km()[medium.levels_km().len() - 1];
    let world = World {
        sigma_t: (0..medium.levels_km().len() - 1)
            .map(|l| medium.layer_sigma_t(l))
            .collect(),
        medium,
        geometry: job.geometry(),
        radius: radius_km,
        top_radius: radius_km + top,
        sun: task.sun.direction,
        eye: job.geometry().observer_position(task.observer_altitude_km),
        disc: [args.disc[0], args.disc[1]],
        lobe: args.lobe,
        piece_km: args.piece_km,
    };
    println!(
        "{} ({}), {} paths per direction, seed {}, {} light subpaths per sample through discs of {} and {} km, connections {}, sun {}, forced {}, lobe {}",
        args.job.display(),
        task.name,
        args.paths,
        args.seed,
        args.lights,
        args.disc[0],
        args.disc[1],
        args.connections,
        args.sun,
        args.forced,
        args.lobe,
    );
    for (index, text) in args.directions.iter().enumerate() {
        let dir = parse_direction(text)?;
        let mut sensor: Vec<(Vertex, f64, f64)> = Vec::new();
        let mut flights: Vec<Flight> = Vec::new();
        let mut light: Vec<(Vertex, f64)> = Vec::new();
        let mut back_exit: Vec<f64> = Vec::new();
        let mut path = FullPath::default();
        let mut phase = Vec::new();
        let (mut total, mut sun, mut points, mut along) = (
            Moments::default(),
            Moments::default(),
            Moments::default(),
            Moments::default(),
        );
        let start = Instant::now();
        for sample in 0..args.paths {
            let mut sampler = Sampler::new(&[args.seed, index as u64, sample]);
            sensor.clear();
            flights.clear();
            let (mut x, mut d) = (world.eye, dir);
            let (mut factor, mut throughput) = (1.0, 1.0);
            while sensor.len() < MAX_VERTICES && world.ray(x, d).is_some() {
                let exit = if equiangular { world.exit(x, d) } else { 0.0 };
                flights.push(Flight {
                    origin: x,
                    dir: d,
                    exit,
                    factor,
                });
                let next = if args.forced {
                    world.forced_flight(x, d, &mut sampler)
                } else {
                    world.flight(x, d, &mut sampler).map(|(v, t)| (v, t, 1.0))
                };
                let Some((v, t, chance)) = next else {
                    break;
                };
                factor *= chance;
                sensor.push((v, t, factor));
                throughput *= chance * v.sigma_s / v.sigma_t;
                if args.forced {
                    let q = (throughput / 0.03).min(1.0);
                    if sampler.next_f64() >= q {
                        break;
                    }
                    factor /= q;
                    throughput /= q;
                }
                let (next, weight) = world.scatter(&v, d, &mut sampler);
                factor *= weight;
                throughput *= weight;
                d = next;
                x = v.x;
            }
            // The first k sensor vertices of the path, with their flights.
            let sensor_part = |path: &mut FullPath, k: usize| {
                path.v.clear();
                path.t.clear();
                path.exit.clear();
                path.t_eye = sensor.first().map_or(0.0, |s| s.1);
                for i in 0..k {
                    path.v.push(sensor[i].0);
                    path.exit.push(flights[i].exit);
                    if i + 1 < k {
                        path.t.push(sensor[i + 1].1);
                    }
                }
            };
            // The first k − 1 sensor vertices and a point `vz` drawn along
            // flight k, `t_in` beyond its start.
            let flight_part = |path: &mut FullPath, k: usize, vz: Vertex, t_in: f64| {
                sensor_part(path, k - 1);
                if k == 1 {
                    path.t_eye = t_in;
                } else {
                    path.t.push(t_in);
                }
                path.v.push(vz);
                path.exit.push(flights[k - 1].exit);
            };
            let (mut s, mut pc, mut ec) = (0.0, 0.0, 0.0);
            if sun_along {
                // The share of a flight's estimate past the first (`--extra`).
                let share = 1.0 / (1.0 + f64::from(args.extra));
                // Flight k leaves collision k − 1: its estimate is shared
                // where that collision has extra directions.
                let split_upto = if extra_first { 1.min(sensor.len()) } else { sensor.len() };
                for (k, f) in flights.iter().enumerate().map(|(i, f)| (i + 1, f)) {
                    let share = if k >= 2 && k - 1 <= split_upto { share } else { 1.0 };
                    let Some(density) = world.sun_density(f.origin, f.dir) else {
                        continue;
                    };
                    let t = density.sample(&mut sampler);
                    let z = f.origin + t * f.dir;
                    let Some(vz) = world.vertex_at(z) else { continue };
                    let (t_in, tr) = ((-density.tau_at(t)).exp(), world.sun_transmittance(z));
                    if tr == 0.0 || vz.sigma_s == 0.0 || t_in == 0.0 {
                        continue;
                    }
                    flight_part(&mut path, k, vz, t_in);
                    let last = density.pdf(t) / (vz.sigma_t * t_in);
                    s += share * f.factor * world.contribution(&path, k, tr, &counts, &mut phase, last);
                }
                for j in 1..=split_upto {
                    for _ in 0..args.extra {
                        let (v, d_in) = (sensor[j - 1].0, flights[j - 1].dir);
                        let (dir, weight) = world.scatter(&v, d_in, &mut sampler);
                        let Some(density) = world.sun_density(v.x, dir) else {
                            continue;
                        };
                        let t = density.sample(&mut sampler);
                        let z = v.x + t * dir;
                        let Some(vz) = world.vertex_at(z) else { continue };
                        let (t_in, tr) = ((-density.tau_at(t)).exp(), world.sun_transmittance(z));
                        if tr == 0.0 || vz.sigma_s == 0.0 || t_in == 0.0 {
                            continue;
                        }
                        sensor_part(&mut path, j);
                        path.t.push(t_in);
                        path.v.push(vz);
                        path.exit.push(0.0);
                        let last = density.pdf(t) / (vz.sigma_t * t_in);
                        let c = world.contribution(&path, j + 1, tr, &counts, &mut phase, last);
                        s += share * sensor[j - 1].2 * weight * c;
                    }
                }
            } else {
                for k in 1..=sensor.len() {
                    let tr = world.sun_transmittance(sensor[k - 1].0.x);
                    if tr > 0.0 {
                        sensor_part(&mut path, k);
                        s += sensor[k - 1].2 * world.contribution(&path, k, tr, &counts, &mut phase, 1.0);
                    }
                }
            }
            for _ in 0..args.lights {
                light.clear();
                back_exit.clear();
                if let Some((mut v, t)) = world.light_start(&mut sampler) {
                    light.push((v, t));
                    let mut d = -world.sun;
                    while light.len() < MAX_VERTICES {
                        d = world.sample_direction(&v, d, &mut sampler);
                        let Some((next, t)) = world.flight(v.x, d, &mut sampler) else {
                            break;
                        };
                        if equiangular {
                            back_exit.push(world.exit(next.x, (v.x - next.x).normalize()));
                        }
                        light.push((next, t));
                        v = next;
                    }
                }
                // The light part of a path ending (sun side) in y_j .. y_1.
                let light_part = |path: &mut FullPath, j: usize| {
                    for i in (0..j).rev() {
                        path.v.push(light[i].0);
                        if i > 0 {
                            path.t.push(light[i].1);
                        }
                    }
                    if equiangular {
                        path.exit.extend((1..j).rev().map(|a| back_exit[a - 1]));
                    }
                };
                let sun_tr = light.first().map_or(0.0, |l| l.1);
                // With sun connections along flights: the density of the
                // first light vertex as a point drawn along the flight from
                // `from` toward it, over its density at a collision there.
                let along_last = |from: DVec3, t_from: f64| {
                    let y1 = light[0].0;
                    let d = y1.x - from;
                    let t = d.length();
                    world
                        .sun_density(from, d / t)
                        .map_or(0.0, |density| density.pdf(t) / (y1.sigma_t * t_from))
                };
                let second_last = if sun_along && light.len() >= 2 {
                    along_last(light[1].0.x, light[1].1)
                } else {
                    0.0
                };
                // Joins the path's sensor part, ending at `from` (its k-th
                // vertex), to light vertex j over a transmittance `tc`.
                let mut connect = |path: &mut FullPath, k: usize, from: DVec3, j: usize, tc: f64| {
                    path.t.push(tc);
                    if equiangular {
                        let yj = light[j - 1].0.x;
                        path.exit.push(if j >= 2 {
                            world.exit(from, (yj - from).normalize())
                        } else {
                            0.0
                        });
                    }
                    light_part(path, j);
                    let last = match (sun_along, j) {
                        (false, _) => 1.0,
                        (true, 1) => along_last(from, tc),
                        (true, _) => second_last,
                    };
                    world.contribution(path, k, sun_tr, &counts, &mut phase, last)
                };
                if point {
                    for k in 1..=sensor.len() {
                        let xk = sensor[k - 1].0.x;
                        for j in 1..=light.len() {
                            let yj = light[j - 1].0.x;
                            let tc = world.transmittance(xk, yj);
                            if tc == 0.0 {
                                continue;
                            }
                            sensor_part(&mut path, k);
                            pc += sensor[k - 1].2 * connect(&mut path, k, xk, j, tc);
                        }
                    }
                }
                if equiangular {
                    for (k, f) in flights.iter().enumerate().map(|(i, f)| (i + 1, f)) {
                        if f.exit <= 0.0 {
                            continue;
                        }
                        for j in 1..=light.len() {
                            let yj = light[j - 1].0.x;
                            let t = equiangular_sample(f.origin, f.dir, f.exit, yj, sampler.next_f64());
                            let z = f.origin + t * f.dir;
                            let Some(vz) = world.vertex_at(z) else { continue };
                            let (t_in, tc) = (world.transmittance(f.origin, z), world.transmittance(z, yj));
                            if tc == 0.0 || t_in == 0.0 || vz.sigma_s == 0.0 {
                                continue;
                            }
                            flight_part(&mut path, k, vz, t_in);
                            ec += f.factor * connect(&mut path, k, z, j, tc);
                        }
                    }
                }
            }
            total.add(s + pc + ec);
            sun.add(s);
            points.add(pc);
            along.add(ec);
        }
        let seconds = start.elapsed().as_secs_f64();
        let n = args.paths as f64;
        let mean = total.sum / n;
        let var = total.variance(n);
        let part = |m: &Moments| (m.sum / total.sum, m.variance(n) / (mean * mean));
        let (ss, sv) = part(&sun);
        let (ps, pv) = part(&points);
        let (es, ev) = part(&along);
        println!(
            "{text}: I {mean:.5e} se {:.3e} (relative {:.4}); a path's variance of I over I^2 {:.2}; {:.2} us a path; \
             share and variance over I^2: sun from sensor vertices {ss:.3} {sv:.2}, point connections {ps:.3} {pv:.2}, \
             equiangular connections {es:.3} {ev:.2}",
            (var / n).sqrt(),
            (var / n).sqrt() / mean,
            var / (mean * mean),
            seconds / n * 1e6,
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫₀ᵗ f by Simpson's rule on `n` intervals.
    fn integral(f: impl Fn(f64) -> f64, t: f64, n: usize) -> f64 {
        let h = t / n as f64;
        let inner: f64 = (1..n)
            .map(|i| f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
            .sum();
        (f(0.0) + inner + f(t)) * h / 3.0
    }

    #[test]
    fn equiangular_draws_invert_their_density() {
        // A ray from the origin along x over [0, 80] km and a point 3 km
        // off it at 25 km: the density integrates to 1, and the distance
        // drawn from ξ has ξ of the density below it (Simpson's rule on
        // 20,000 intervals: errors near 1e-9 for these smooth integrands).
        let (o, u, c, t_max) = (DVec3::ZERO, DVec3::X, DVec3::new(25.0, 3.0, 0.0), 80.0);
        let density = |t: f64| equiangular_density(o, u, t_max, c, t);
        assert!((integral(density, t_max, 20_000) - 1.0).abs() < 1e-7);
        for xi in [0.01, 0.2, 0.5, 0.77, 0.99] {
            let t = equiangular_sample(o, u, t_max, c, xi);
            let below = integral(density, t, 20_000);
            assert!((below - xi).abs() < 1e-7, "ξ {xi}: t {t}, ∫ {below}");
        }
    }

    /// Three pieces: a shadowed one (no sunlit value), a sunlit one and a
    /// thin one.
    fn three_pieces() -> SunDensity {
        let pieces = vec![
            (0.0, 2.0, 0.3, 0.0, 0.0),
            (2.0, 4.0, 0.2, 0.6, 0.5),
            (4.0, 10.0, 0.05, 1.0, 0.1),
        ];
        let total = pieces.iter().map(|p| p.4 * (p.1 - p.0)).sum();
        SunDensity {
            pieces,
            total,
            tau_exit: 1.3,
        }
    }

    #[test]
    fn the_sun_density_integrates_to_one_and_draws_what_it_says() {
        let d = three_pieces();
        // Its depth is continuous at the pieces' ends and reaches tau_exit.
        assert!((d.tau_at(10.0) - d.tau_exit).abs() < 1e-12);
        assert!((integral(|t| d.pdf(t), 10.0, 200_000) - 1.0).abs() < 1e-4);
        // 400,000 draws in 20 bins of 0.5 km against each bin's
        // probability p (by quadrature): every count within 4.5 binomial
        // standard errors √(n p (1 − p)) (Šidák over 20 bins at 1e-3 asks
        // for about 4.1).
        let n = 400_000;
        let mut counts = [0usize; 20];
        let mut sampler = Sampler::new(&[7]);
        for _ in 0..n {
            let t = d.sample(&mut sampler);
            counts[((t / 0.5) as usize).min(19)] += 1;
        }
        for (b, &count) in counts.iter().enumerate() {
            let lo = b as f64 * 0.5;
            let p = integral(|t| d.pdf(lo + t), 0.5, 2_000);
            let (expected, se) = (n as f64 * p, (n as f64 * p * (1.0 - p)).sqrt());
            assert!(
                (count as f64 - expected).abs() < 4.5 * se,
                "bin {b}: {count} against {expected:.1} ± {se:.1}"
            );
        }
    }
}
