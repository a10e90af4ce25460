//! Next-event estimation toward the sun: at a vertex, at K stratified points
//! of a flight, or at one point of the sun-aware density; shadow rays'
//! transmittance for every channel.

use glam::DVec3;

use crate::geometry::ray::{Ray, Segment, WalkEnd};
use crate::geometry::shell::Geometry;
use crate::job::options::SunTransmittance;
use crate::polarization::phase::PhaseFunction;
use crate::polarization::stokes::{Mueller, Stokes};
use crate::sampling::sampler::Sampler;
use crate::transport::flight_density::{FlightDensity, Point};
use crate::transport::free_flight::FlightEnd;

use super::path::{PIECE_SEGMENTS, Path, Shape, SunFollow, ViewKey};
use super::scene::Scene;
use super::spectra::ChannelSpectra;
use super::vertex::{INV_4PI, SUN_AWARE_SHARE, scattering_frame, sun_ray};

impl Scene {
    /// A sun connection from the point at distance `t` in segment `i` of
    /// the flight (`path.segments`), drawn with density `q` (the same for
    /// every channel, so the path's spectral MIS weight applies to it
    /// unchanged): channel w scores e^(−τ_w)·σ_s,w·[R·M_w/(4π)]·T_sun,w/q.
    pub(super) fn sun_at_point(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        ray: &Ray,
        (i, t): (usize, f64),
        q: f64,
        sampler: &mut Sampler,
    ) {
        let x = ray.origin + t * ray.dir;
        if self.hidden_from_sun(x) {
            // In the planet's shadow: it scores nothing.
            return;
        }
        let seg = path.segments[i];
        // Every channel's depth along the flight to the point: the
        // segments before it in order, then its own part.
        path.point_basis.clear();
        path.point_basis.resize(self.basis_len, 0.0);
        for s in &path.segments[..i] {
            self.accumulate(&mut path.point_basis, s.layer, s.t1 - s.t0);
        }
        self.accumulate(&mut path.point_basis, seg.layer, (t - seg.t0).max(0.0));
        Self::combine(spectra, &path.point_basis, &mut path.tau_hit);
        path.mixtures.clear();
        path.factors.clear();
        // The optics of the profile's layer there, and the residual's
        // factor on the way, through merged layers (`tracking`).
        let l = self.profile_layer(seg.layer, x);
        for w in 0..self.channels.len() {
            let c = self.coefficients(spectra, l, w, 0.0);
            path.mixtures.push(self.phase_mixture(spectra, l, w, &c));
            path.factors
                .push((-path.tau_hit[w]).exp() * path.residual_to(t, w) / q * c.sigma_s());
        }
        self.sun_from(path, spectra, x, seg.layer, -ray.dir, sampler, true);
    }

    /// Stratified sun connections along a forced flight
    /// ([`Settings::sun_samples_per_flight`] = K points): point k at the
    /// hero's forced distance for the variate (k + u_k)/K, connected with
    /// 1/K of its weight (`sun_at_point`, density K·σ_t,h·e^(−τ_h)/(1 −
    /// e^(−τ_h,end)) at the point). The path goes on from its own
    /// collision. Returns false (nothing done) for an endless flight.
    pub(super) fn sun_stratified(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        ray: &Ray,
        sampler: &mut Sampler,
    ) -> bool {
        if !self.flight_segments(path, ray) {
            return false;
        }
        let hero = path.hero;
        let p = -(-path.ray.tau[hero]).exp_m1();
        if p <= 0.0 {
            return true;
        }
        let k = self.settings.sun_samples_per_flight;
        for i in 0..k {
            let target = crate::transport::free_flight::forced_distance((i as f64 + sampler.next_f64()) / k as f64, p);
            let mut acc = 0.0;
            let mut point = None;
            for (j, seg) in path.segments.iter().enumerate() {
                let sigma = self.sigma_t(spectra, seg.layer, hero);
                let d = sigma * (seg.t1 - seg.t0);
                if sigma > 0.0 {
                    point = Some((j, (seg.t0 + (target - acc) / sigma).min(seg.t1), sigma));
                    if acc + d >= target {
                        break;
                    }
                }
                acc += d;
            }
            if let Some((j, t, sigma)) = point {
                let q = k as f64 * sigma * (-target).exp() / p;
                self.sun_at_point(path, spectra, ray, (j, t), q, sampler);
            }
        }
        true
    }

    /// Next-event estimation along a whole flight (`path.ray` holds its
    /// depths), every channel from one point. The point is drawn from the
    /// mixture q = Σ_k s_k·q_k over the K ≤ 2 followed channels (the
    /// least and the most extinct, with their centre wavelengths' optics,
    /// [`SunFollow`]; shares s = 0.3 and 0.7 for two,
    /// [`MOST_EXTINCT_SHARE`](crate::transport::flight_density::MOST_EXTINCT_SHARE)), each q_k a defensive mixture,
    /// α·q_sun,k + (1 − α)·q_flight,k with
    /// q_sun,k ∝ c̄·e^(−τ_k)·e^(−τ̃_sun,k) and q_flight,k ∝ c̄·e^(−τ_k),
    /// c̄ the mean σ_s·P11 at the sun's centre, piecewise exponential over
    /// runs of the flight's segments ([`FlightDensity`]; α = 0.8). Channel w scores
    /// e^(−τ_w)·σ_s,w·[R·M_w/(4π)]·T_sun,w/q: unbiased for its
    /// single-scattering integral along the flight whatever the hero, since
    /// q > 0 wherever σ_s > 0. Following the least extinct channel bounds
    /// the weight of every channel more extinct than it in every layer by
    /// 1/(s_0·(1 − α)) times their ratio of σ_s (its e^(−τ) and T_sun are the
    /// smaller); ozone's bands, and a band's own wavelengths, can break that
    /// order in places. The point's density is the same for every channel,
    /// so the path's spectral MIS weight (over the densities of the vertices
    /// before) applies unchanged. Returns false (nothing done) without
    /// sun-aware connections or for an endless flight.
    pub(super) fn sun_along_flight(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        ray: &Ray,
        sampler: &mut Sampler,
    ) -> bool {
        let Some(follow) = &self.sun_follow else {
            return false;
        };
        if follow.view_only && !(path.order == 0 && path.view_sun_aware) {
            return false;
        }
        // The sensor's own flight with a density exact per segment and
        // little defence, kept with the flight's segments from sample to
        // sample while the view ray stays the same (every sample of a
        // direction, or of a pixel's centre); the scattered flights'
        // coarser and more defensive.
        let point = if path.order == 0 {
            let (share, pieces) = follow.view_density;
            let key = ViewKey::new(follow.id, ray, pieces);
            let drawable = match path.view_key {
                Some((k, drawable)) if k == key => {
                    path.segments.clone_from(&path.view_segments);
                    drawable
                }
                _ => {
                    if !self.flight_segments(path, ray) {
                        return false;
                    }
                    if path.segments.is_empty() {
                        return true;
                    }
                    let drawable = self.build_sun_density(
                        follow,
                        &path.segments,
                        &mut path.view_density,
                        ray,
                        pieces,
                        Shape::Sunlit,
                    );
                    path.view_polarized = drawable && self.settings.polarized && path.view_repeats;
                    path.view_control_e1 = None;
                    if path.view_polarized {
                        self.build_sun_density(
                            follow,
                            &path.segments,
                            &mut path.view_polarization,
                            ray,
                            pieces,
                            Shape::Rayleigh,
                        );
                        path.view_polarization.keep_normalisers();
                    }
                    if path.view_repeats {
                        path.view_density.keep_normalisers();
                    }
                    path.view_segments.clone_from(&path.segments);
                    path.view_key = Some((key, drawable));
                    drawable
                }
            };
            if !drawable {
                return true;
            }
            let point = path.view_density.sample(&path.segments, share, sampler);
            if path.view_polarized {
                self.polarization_control(path, follow, ray, point);
            }
            point
        } else {
            if !self.flight_segments(path, ray) {
                return false;
            }
            if path.segments.is_empty() {
                return true;
            }
            if !self.build_sun_density(
                follow,
                &path.segments,
                &mut path.density,
                ray,
                PIECE_SEGMENTS,
                Shape::Sunlit,
            ) {
                return true;
            }
            path.density.sample(&path.segments, SUN_AWARE_SHARE, sampler)
        };
        let Some(point) = point else {
            return true;
        };
        self.sun_at_point(path, spectra, ray, (point.segment, point.t), point.pdf, sampler);
        true
    }

    /// The sun-following density along the flight along `ray` over its
    /// `segments` into `density`, in pieces of at most `pieces` segments,
    /// following `shape`; whether any followed channel can be drawn from.
    /// It depends on the ray and the scene alone (the followed channels'
    /// optics at their centre wavelengths, the sun's centre), not on the
    /// path.
    pub(super) fn build_sun_density(
        &self,
        follow: &SunFollow,
        segments: &[Segment],
        density: &mut FlightDensity,
        ray: &Ray,
        pieces: usize,
        shape: Shape,
    ) -> bool {
        let depth = &follow.depth;
        let nk = follow.channels.len();
        let s0 = self.sun.direction;
        let cos0 = (-s0).dot(-ray.dir);
        // Rayleigh's and the aerosol's P11 at the sun's centre per followed
        // channel: Rayleigh's recomputed only when its depolarisation
        // changes; the aerosol's from its tables where it has them
        // (`SunFollow::aerosol_p11`), else by Henyey–Greenstein with its g,
        // recomputed when g changes. This only shapes the density the point
        // is drawn from, which the contributions are divided by. (Until
        // 2026-11-27 Henyey–Greenstein stood in for the tables too: its
        // forward peak is several times lower, and twilight paths that
        // scatter sunlight forward toward the sensor were drawn too rarely;
        // docs/design-sun.md, "Sun connections along shared paths".)
        let mut rayleigh = [(f64::NAN, 0.0); 2];
        let mut aerosol = [(f64::NAN, 0.0); 2];
        let tabulated = !follow.aerosol_p11.is_empty();
        let angle = SunFollow::aerosol_angle(cos0);
        let optics = |_: usize, seg: &Segment| {
            let len = seg.t1 - seg.t0;
            let mut o = [(0.0, 0.0); 2];
            for (k, ok) in o.iter_mut().enumerate().take(nk) {
                let c = follow.coefficients[seg.layer * nk + k];
                if rayleigh[k].0 != c.rayleigh_depolarization {
                    let depolarization = c.rayleigh_depolarization;
                    rayleigh[k] = (depolarization, PhaseFunction::Rayleigh { depolarization }.p11(cos0));
                }
                if shape == Shape::Rayleigh {
                    // Its phase matrix at the sun's centre is the same
                    // all along the flight.
                    *ok = (c.sigma_t * len, c.sigma_rayleigh);
                    continue;
                }
                let mut sca = c.sigma_rayleigh * rayleigh[k].1;
                if c.sigma_aerosol_sca > 0.0 && tabulated {
                    sca += c.sigma_aerosol_sca * follow.aerosol_p11_at(seg.layer, k, nk, angle);
                } else if c.sigma_aerosol_sca > 0.0 {
                    if aerosol[k].0 != c.aerosol_g {
                        let g = c.aerosol_g;
                        aerosol[k] = (g, PhaseFunction::HenyeyGreenstein { g }.p11(cos0));
                    }
                    sca += c.sigma_aerosol_sca * aerosol[k].1;
                }
                *ok = (c.sigma_t * len, sca);
            }
            o
        };
        density.build(ray, segments, nk, pieces, optics, depth, s0)
    }

    /// A control variate for Q and U of the view flight's single
    /// scattering, for each followed channel w (k-th followed).
    ///
    /// Its point, at distance t with density q(t) (`point`; `None` when
    /// none was drawn), estimates w's single scattering along the flight,
    /// and q follows I's: near the sun that is the aerosol's forward peak,
    /// while Q and U come from Rayleigh scattering, spread higher up the
    /// column. The Rayleigh part of Q and U along the flight is about
    /// g(t) = Z·q_R(t)·v: q_R the density that follows σ_R·e^(−τ)·e^(−τ̃_sun)
    /// (`view_polarization`, normalised), Z its integral, v the Stokes
    /// column of Rayleigh's matrix at the sun's centre with I left out
    /// (the same at every point of the flight), over 4π. Adding
    /// Z·v·(1 − q_R(t)/q(t)) has expectation zero, whatever Z and v, since
    /// q > 0 wherever q_R > 0 (its flight part) and q_R integrates to 1:
    /// Q and U stay unbiased and lose the variance of their Rayleigh
    /// single scattering's shape; I is untouched.
    fn polarization_control(&self, path: &mut Path, follow: &SunFollow, ray: &Ray, point: Option<Point>) {
        // Z·v per followed channel depends on the view alone: computed
        // once per view ray and frame.
        if path.view_control_e1 != Some(path.frame_e1) {
            let nk = follow.channels.len();
            let k_in = -self.sun.direction;
            let k_out = -ray.dir;
            let (rotation, _) = scattering_frame(path.frame_e1, k_in, k_out);
            let layer = path.view_segments.first().map_or(ray.layer, |s| s.layer);
            for k in 0..nk {
                let z = path.view_polarization.sun_integral_of(k);
                path.view_control[k] = if z > 0.0 && z.is_finite() {
                    let depolarization = follow.coefficients[layer * nk + k].rayleigh_depolarization;
                    let m = PhaseFunction::Rayleigh { depolarization }.matrix(k_in.dot(k_out));
                    rotation.column_of(&Mueller::identity(), &m) * (z * INV_4PI)
                } else {
                    Stokes::default()
                };
            }
            path.view_control_e1 = Some(path.frame_e1);
        }
        for (k, &w) in follow.channels.iter().enumerate() {
            let control = path.view_control[k];
            if control.0[0] == 0.0 {
                continue;
            }
            let ratio = point.map_or(0.0, |p| path.view_polarization.sun_pdf_of(k, p.t, p.piece) / p.pdf);
            let mut v = path.throughput[w] * control;
            v.0[0] = 0.0;
            path.add(w, v * (1.0 - ratio));
        }
    }

    /// Whether a sun-aware connection along the flight along `ray` to `end`
    /// would score nothing because the planet hides a point sun from all of
    /// it (both ends in its shadow, [`Sun::hidden_by_planet`]): no point of
    /// it sees the sun, and neither does its collision. Saves the flight's
    /// density and connection at twilight; false without sun-aware
    /// connections (their absence keeps the day's random streams as they
    /// were).
    ///
    /// [`Sun::hidden_by_planet`]: crate::geometry::sun::Sun::hidden_by_planet
    pub(super) fn flight_hidden_from_sun(&self, ray: &Ray, end: WalkEnd) -> bool {
        if self.sun_follow.is_none() {
            return false;
        }
        let t = match end {
            WalkEnd::Ground { t } | WalkEnd::Top { t } => t,
            WalkEnd::Endless | WalkEnd::Stopped => return false,
        };
        self.hidden_from_sun(ray.origin) && self.hidden_from_sun(ray.origin + t * ray.dir)
    }

    /// Whether the planet hides a point sun from `x` (spherical geometry).
    fn hidden_from_sun(&self, x: DVec3) -> bool {
        match self.geometry {
            Geometry::Spherical { radius_km } => self.sun.hidden_by_planet(radius_km, x),
            Geometry::PlaneParallel => false,
        }
    }

    /// Every channel's transmittance toward the sun from `x` (in `layer`)
    /// into `path.shadow_tr`, along the direct beam's path (`sun_ray`):
    /// exact, or ratio-tracked against the largest of the channels'
    /// majorants ([`SunTransmittance`]); false when the shadow ray hits the
    /// planet or carries nothing.
    pub(super) fn sun_transmittances(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        x: DVec3,
        dir: DVec3,
        layer: usize,
        sampler: &mut Sampler,
    ) -> bool {
        let (geometry, ray) = sun_ray(
            self.geometry,
            self.pseudo_spherical_radius_km,
            Ray { origin: x, dir, layer },
        );
        match self.settings.sun_transmittance {
            SunTransmittance::Analytic => {
                // Through the tracking layers; where they are merged, the
                // residual's estimate too (`tracking`).
                if !self.shadow_depths(&mut path.shadow, spectra, &geometry, &ray) {
                    return false;
                }
                for (tr, tau) in path.shadow_tr.iter_mut().zip(&path.shadow.tau) {
                    *tr = (-tau).exp();
                }
                if let (true, Geometry::Spherical { radius_km }) = (self.track.merged, geometry) {
                    self.shadow_residual(path, spectra, radius_km, &ray, sampler);
                }
                true
            }
            SunTransmittance::RatioTracking => {
                // A horizontal ray of a slab never leaves it.
                if geometry == Geometry::PlaneParallel && ray.dir.z == 0.0 {
                    return false;
                }
                let n = self.channels.len();
                let tr = &mut path.shadow_tr;
                tr.fill(1.0);
                let majorant = |layer| (0..n).map(|w| self.majorant(spectra, layer, w)).fold(0.0, f64::max);
                let end = crate::transport::free_flight::sample_t_maj(
                    majorant,
                    &geometry,
                    &self.track.levels_km,
                    &ray,
                    sampler,
                    |c, _| {
                        let f = self.fraction(&geometry, c.layer, ray.origin + c.t * ray.dir);
                        let mut alive = false;
                        for (w, tr) in tr.iter_mut().enumerate() {
                            *tr *= 1.0 - self.sigma_t_point(spectra, c.layer, w, f) / c.sigma_maj;
                            alive |= *tr != 0.0;
                        }
                        alive
                    },
                );
                matches!(end, FlightEnd::Top { .. })
            }
        }
    }

    /// One shadow ray toward the sun from a scattering at `x` for every
    /// channel, each with its phase mixture in `path.mixtures` and, when
    /// `weighted`, times `path.factors[w]`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn sun_from(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        x: DVec3,
        layer: usize,
        k_out: DVec3,
        sampler: &mut Sampler,
        weighted: bool,
    ) {
        let s = self.sun.sample_direction(sampler.next2());
        if !self.sun_transmittances(path, spectra, x, s, layer, sampler) {
            return;
        }
        let k_in = -s;
        let at = self.phase_tables().locate(k_in.dot(k_out));
        let (rotation, _) = scattering_frame(path.frame_e1, k_in, k_out);
        for w in 0..self.channels.len() {
            let tr = path.shadow_tr[w];
            if tr == 0.0 {
                continue;
            }
            let m = path.mixtures[w].matrix(&at);
            let column = if self.settings.polarized {
                rotation.column_of(&path.throughput[w], &m)
            } else {
                path.throughput[w] * Stokes::new(m.p11, 0.0, 0.0, 0.0)
            };
            let factor = if weighted { path.factors[w] } else { 1.0 };
            path.add(w, column * (factor * tr * INV_4PI));
        }
    }
}
