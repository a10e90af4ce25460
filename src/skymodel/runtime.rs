//! Evaluation of a sky-model [`Dataset`] with the semantics of the Prague
//! sky model's public runtime (`PragueSkyModel.cpp`; Wilkie et al. 2021,
//! Vévoda et al. 2022): sky radiance, polarisation, transmittance and the
//! sun's radiance for one view, in the runtime's frame (z up, metres, the
//! ground at z = 0 above the origin, the planet's centre at (0, 0, −R)).
//!
//! - Parameters ([`Parameters::new`]): the viewpoint is raised by the
//!   runtime's 50 m; the view angles are those of [`super::angles`] with
//!   the viewpoint's own zenith n in place of ẑ.
//! - Radiance: per configuration Σ_r sun_r(γ)·zenith_r(α) times the
//!   emphasis at θ′, clamped at 0, each factor piecewise linear over its
//!   breaks; then interpolated over visibility, albedo, altitude and
//!   elevation (a level is skipped when its factor is below 10⁻⁶). No
//!   interpolation across channels: a wavelength takes its channel's value.
//! - Polarisation: the same with the polarisation tables, α = θ′, no
//!   emphasis or clamp, the sum negated (as the runtime returns it).
//! - Transmittance: √T from the rank-reduced U·V tables at the end of the
//!   ray's path, bilinear over the (altitude³, distance⁴) nodes, then over
//!   observer altitude and visibility, squared.
//! - Sun: where the view meets the sun's disc, the disc's mean radiance
//!   times the transmittance toward it.
//!
//! Where this differs from the runtime:
//! - the sun's radiance comes from the project's one solar spectrum
//!   ([`SolarSpectrum`], Kurucz), spread evenly over the disc
//!   (E0 / Ω_sun), not from the runtime's own table, so that every part of
//!   atmosim uses the same sun;
//! - piecewise-linear lookups at a list's last break read that break (the
//!   runtime reads one past it, multiplied by a factor of 0);
//! - transmittance at a path end exactly on a distance node (factor 0, not
//!   the last node) between two altitude nodes interpolates between the
//!   two altitude nodes at that distance; the runtime there takes its
//!   second value, which is the next distance node's at the lower
//!   altitude (it happens for views exactly at the zenith);
//! - `acos` arguments are clamped to [−1, 1].

use std::f64::consts::FRAC_PI_2;

use glam::DVec3;

use super::angles::{PLANET_RADIUS_M, SAFETY_ALTITUDE_M, SunPosition};
use super::dataset::Dataset;
use crate::error::{Error, Result};
use crate::physics::solar::SolarSpectrum;

/// The sun's angular radius in the runtime (rad): 0.2667°.
pub const SUN_RADIUS: f64 = 0.004654793;
/// The top of the runtime's atmosphere above the ground (m).
const ATMOSPHERE_HEIGHT_M: f64 = 100_000.0;
/// The runtime's greatest distance parameter, a ground arc (m).
const MAX_DISTANCE_M: f64 = 1_571_524.413613;
/// An interpolation level whose factor is below this is skipped.
const SKIP_FACTOR: f64 = 1e-6;
/// Below this altitude (m) the runtime treats the observer as on the ground.
const GROUND_ALTITUDE_M: f64 = 0.3;

/// The runtime's parameters of one view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parameters {
    /// θ: zenith angle of the view at the viewpoint (rad).
    pub theta: f64,
    /// γ: angle between the view and the sun (rad).
    pub gamma: f64,
    /// σ: angle between the corrected view and the shadow point (rad).
    pub shadow: f64,
    /// θ′: zenith angle of the corrected view (rad).
    pub zero: f64,
    /// The sun's elevation at the viewpoint (rad).
    pub elevation: f64,
    /// The runtime's altitude (m): the viewpoint's, 50 m added, ≥ 0.
    pub altitude_m: f64,
    pub visibility_km: f64,
    pub albedo: f64,
}

impl Parameters {
    /// The parameters of a view from `viewpoint` (m) along `direction`
    /// (any length but zero) under a sun at `sun_elevation` and
    /// `sun_azimuth` (rad, as seen from the origin on the ground).
    pub fn new(
        viewpoint: DVec3,
        direction: DVec3,
        sun_elevation: f64,
        sun_azimuth: f64,
        visibility_km: f64,
        albedo: f64,
    ) -> Parameters {
        let to_view = viewpoint - DVec3::new(0.0, 0.0, -PLANET_RADIUS_M);
        let n = to_view.normalize();
        let d = to_view.length() + SAFETY_ALTITUDE_M;
        let v = direction.normalize();
        let sun = SunPosition {
            elevation: sun_elevation,
            azimuth: sun_azimuth,
        };
        let s = sun.direction();
        // The corrected view: the tangent to the planet becomes horizontal.
        let corrected = if d > PLANET_RADIUS_M {
            (v + n * ((d * d - PLANET_RADIUS_M * PLANET_RADIUS_M).sqrt() / d)).normalize()
        } else {
            v
        };
        Parameters {
            theta: acos(v.dot(n)),
            gamma: acos(v.dot(s)),
            shadow: acos(corrected.dot(sun.shadow_direction())),
            zero: acos(corrected.dot(n)),
            elevation: FRAC_PI_2 - acos(n.dot(s)),
            altitude_m: (d - PLANET_RADIUS_M).max(0.0),
            visibility_km,
            albedo,
        }
    }
}

fn acos(x: f64) -> f64 {
    x.clamp(-1.0, 1.0).acos()
}

/// A place on a list of nodes: the lower node and the fraction toward the
/// next (0 at the last node).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Position {
    index: usize,
    factor: f64,
}

/// The runtime's position of `x` on ascending `breaks` (at least one):
/// clamped to the ends; the lower break is the one before the first break
/// greater than `x`, searched from the second.
fn position(breaks: &[f64], x: f64) -> Position {
    let last = breaks.len() - 1;
    let x = x.clamp(breaks[0], breaks[last]);
    let above = 1 + breaks[1..].partition_point(|&b| b <= x);
    if above > last {
        return Position {
            index: last,
            factor: 0.0,
        };
    }
    let index = above - 1;
    Position {
        index,
        factor: (x - breaks[index]) / (breaks[above] - breaks[index]),
    }
}

/// The runtime's position of `p` ∈ [0, 1] on `n` transmittance nodes at
/// (i/n)^power, linear in p^power.
fn node_position(p: f64, n: usize, power: i32) -> Position {
    let index = ((p * n as f64).floor() as usize).min(n - 1);
    if index == n - 1 {
        return Position { index, factor: 0.0 };
    }
    let node = |i: usize| (i as f64 / n as f64).powi(power);
    let factor = (p.powi(power) - node(index)) / (node(index + 1) - node(index));
    Position {
        index,
        factor: factor.clamp(0.0, 1.0),
    }
}

/// The value at `at` of the piecewise-linear function with `values` at the
/// breaks.
#[inline]
fn lookup(values: &[f32], at: Position) -> f64 {
    let low = values[at.index] as f64;
    if at.factor == 0.0 {
        return low;
    }
    (values[at.index + 1] as f64 - low) * at.factor + low
}

#[inline]
fn lerp(from: f64, to: f64, factor: f64) -> f64 {
    (1.0 - factor) * from + factor * to
}

/// A dataset ready to evaluate, with the sun's spectrum.
#[derive(Debug, Clone)]
pub struct Model {
    name: String,
    dataset: Dataset,
    solar: SolarSpectrum,
    /// The sun's solid angle (sr).
    sun_solid_angle: f64,
}

impl Model {
    /// A model of `dataset` (named `name` in errors) whose sun shines with
    /// `solar`. The dataset is checked once here, so that evaluation
    /// cannot index outside it.
    pub fn new(name: impl Into<String>, dataset: Dataset, solar: SolarSpectrum) -> Result<Model> {
        let name = name.into();
        dataset.check(&name)?;
        // 2π(1 − cos r), written without the cancellation.
        let half_angle = (SUN_RADIUS / 2.0).sin();
        let sun_solid_angle = 4.0 * std::f64::consts::PI * half_angle * half_angle;
        Ok(Model {
            name,
            dataset,
            solar,
            sun_solid_angle,
        })
    }

    pub fn dataset(&self) -> &Dataset {
        &self.dataset
    }

    /// The channel of `wavelength_nm`, none outside the dataset's channels.
    fn channel(&self, wavelength_nm: f64) -> Option<usize> {
        let a = &self.dataset.axes;
        if !(wavelength_nm >= a.channel_start_nm && wavelength_nm < a.channel_end_nm()) {
            return None;
        }
        let channel = ((wavelength_nm - a.channel_start_nm) / a.channel_width_nm).floor() as usize;
        Some(channel.min(a.channels - 1))
    }

    /// The positions on the configuration axes: visibility, albedo,
    /// altitude and elevation (in degrees).
    fn configuration_positions(&self, p: &Parameters) -> [Position; 4] {
        let a = &self.dataset.axes;
        [
            position(&a.visibilities_km, p.visibility_km),
            position(&a.albedos, p.albedo),
            position(&a.altitudes_m, p.altitude_m),
            position(&a.elevations_deg, p.elevation.to_degrees()),
        ]
    }

    /// The runtime's interpolation over the configuration axes, from
    /// `level` on (0 visibility, 1 albedo, 2 altitude, 3 elevation);
    /// `offset` holds one bit per axis (visibility the highest) for
    /// taking the upper node.
    fn interpolate(
        &self,
        level: usize,
        offset: usize,
        at: &[Position; 4],
        channel: usize,
        value: &impl Fn(usize) -> f64,
    ) -> f64 {
        if level == 4 {
            let a = &self.dataset.axes;
            let lens = [&a.visibilities_km, &a.albedos, &a.altitudes_m, &a.elevations_deg].map(Vec::len);
            let index = |l: usize| (at[l].index + (offset >> (3 - l) & 1)).min(lens[l] - 1);
            return value(a.configuration([index(0), index(1), index(2), index(3), channel]));
        }
        let low = self.interpolate(level + 1, offset, at, channel, value);
        let factor = at[level].factor;
        if factor < SKIP_FACTOR {
            return low;
        }
        let high = self.interpolate(level + 1, offset + (1 << (3 - level)), at, channel, value);
        lerp(low, high, factor)
    }

    /// Sky radiance (the dataset's units) of the view at `wavelength_nm`;
    /// 0 outside the dataset's channels.
    pub fn sky_radiance(&self, p: &Parameters, wavelength_nm: f64) -> f64 {
        let Some(channel) = self.channel(wavelength_nm) else {
            return 0.0;
        };
        let r = &self.dataset.radiance;
        let alpha = if p.elevation < 0.0 { p.shadow } else { p.zero };
        let sun = position(&r.sun_breaks, p.gamma);
        let zenith = position(&r.zenith_breaks, alpha);
        let emph = position(&r.emph_breaks, p.zero);
        let (n_sun, component_len, config_len) = (r.sun_breaks.len(), r.component_len(), r.config_len());
        let reconstruct = |config: usize| {
            let coefs = &r.coefs[config * config_len..(config + 1) * config_len];
            let (components, emph_values) = coefs.split_at(r.rank * component_len);
            let sum: f64 = components
                .chunks_exact(component_len)
                .map(|c| lookup(&c[..n_sun], sun) * lookup(&c[n_sun..], zenith))
                .sum();
            (sum * lookup(emph_values, emph)).max(0.0)
        };
        let at = self.configuration_positions(p);
        self.interpolate(0, 0, &at, channel, &reconstruct)
    }

    /// The runtime's polarisation (degree of linear polarisation, as it
    /// returns it: negated) of the view at `wavelength_nm`; 0 outside the
    /// dataset's channels, an error for a dataset without polarisation.
    pub fn polarisation(&self, p: &Parameters, wavelength_nm: f64) -> Result<f64> {
        let Some(pol) = &self.dataset.polarisation else {
            return Err(Error::data(&self.name, "the dataset has no polarisation part"));
        };
        let Some(channel) = self.channel(wavelength_nm) else {
            return Ok(0.0);
        };
        let sun = position(&pol.sun_breaks, p.gamma);
        let zenith = position(&pol.zenith_breaks, p.zero);
        let (n_sun, component_len, config_len) = (pol.sun_breaks.len(), pol.component_len(), pol.config_len());
        let reconstruct = |config: usize| -> f64 {
            pol.coefs[config * config_len..(config + 1) * config_len]
                .chunks_exact(component_len)
                .map(|c| lookup(&c[..n_sun], sun) * lookup(&c[n_sun..], zenith))
                .sum()
        };
        let at = self.configuration_positions(p);
        Ok(-self.interpolate(0, 0, &at, channel, &reconstruct))
    }

    /// Transmittance at `wavelength_nm` along the view from the viewpoint
    /// over `distance_m` (or to the ground or the top of the atmosphere,
    /// whichever is nearer); 0 outside the dataset's channels.
    pub fn transmittance(&self, p: &Parameters, wavelength_nm: f64, distance_m: f64) -> f64 {
        let Some(channel) = self.channel(wavelength_nm) else {
            return 0.0;
        };
        let t = &self.dataset.transmittance;
        let visibility = position(&t.visibilities_km, p.visibility_km);
        let altitude = position(&t.altitudes_m, p.altitude_m);
        let (a, d) = self.path_end(p, distance_m);
        let at_visibility = |vis: usize| {
            let low = self.sqrt_transmittance(vis, altitude.index, a, d, channel);
            if altitude.factor > 0.0 {
                let high = self.sqrt_transmittance(vis, altitude.index + 1, a, d, channel);
                return lerp(low, high, altitude.factor);
            }
            low
        };
        let mut root = at_visibility(visibility.index);
        if visibility.factor > 0.0 {
            root = lerp(root, at_visibility(visibility.index + 1), visibility.factor);
        }
        root * root
    }

    /// The positions of the path's end on the altitude and distance
    /// nodes.
    fn path_end(&self, p: &Parameters, distance_m: f64) -> (Position, Position) {
        let t = &self.dataset.transmittance;
        let r0 = PLANET_RADIUS_M + p.altitude_m;
        let (sin_t, cos_t) = p.theta.sin_cos();
        let top = PLANET_RADIUS_M + ATMOSPHERE_HEIGHT_M;
        let to_end = if p.altitude_m < GROUND_ALTITUDE_M {
            if p.theta <= FRAC_PI_2 {
                ray_to_circle(r0, cos_t, top).unwrap_or(0.0)
            } else {
                0.0
            }
        } else {
            ray_to_circle(r0, cos_t, PLANET_RADIUS_M)
                .or_else(|| ray_to_circle(r0, cos_t, top))
                .unwrap_or(0.0)
        };
        let s = to_end.min(distance_m);
        let (x, y) = (s * sin_t, r0 + s * cos_t);
        let r = (x * x + y * y).sqrt();
        let height = (r - PLANET_RADIUS_M).clamp(0.0, ATMOSPHERE_HEIGHT_M) / ATMOSPHERE_HEIGHT_M;
        let a_param = height.powf(1.0 / 3.0);
        let d_param = (acos(y / r) * PLANET_RADIUS_M / MAX_DISTANCE_M).powf(0.25).min(1.0);
        (node_position(a_param, t.a_dim, 3), node_position(d_param, t.d_dim, 4))
    }

    /// √T at the path end (`a`, `d`) for the observer-altitude node `alt`
    /// and the visibility node `vis`: bilinear over the nodes, each
    /// altitude's value clamped at 0 before the altitude interpolation.
    fn sqrt_transmittance(&self, vis: usize, alt: usize, a: Position, d: Position, channel: usize) -> f64 {
        let t = &self.dataset.transmittance;
        let v_at = ((vis * t.altitudes_m.len() + alt) * self.dataset.axes.channels + channel) * t.rank;
        let v = &t.v[v_at..v_at + t.rank];
        let node = |a: usize, d: usize| -> f64 {
            let u_at = ((alt * t.d_dim + d) * t.a_dim + a) * t.rank;
            t.u[u_at..u_at + t.rank]
                .iter()
                .zip(v)
                .map(|(&u, &v)| u as f64 * v as f64)
                .sum()
        };
        let at_altitude = |a: usize| {
            let low = node(a, d.index);
            if d.factor > 0.0 {
                lerp(low, node(a, d.index + 1), d.factor)
            } else {
                low
            }
        };
        let low = at_altitude(a.index).max(0.0);
        if a.factor > 0.0 {
            return lerp(low, at_altitude(a.index + 1).max(0.0), a.factor);
        }
        low
    }

    /// The sun's radiance (W m⁻² sr⁻¹ nm⁻¹) seen along the view: 0 off the
    /// disc (γ > [`SUN_RADIUS`]) and outside the solar spectrum, else the
    /// disc's mean radiance E0(λ)/Ω_sun times the transmittance toward
    /// the sun.
    pub fn sun_radiance(&self, p: &Parameters, wavelength_nm: f64) -> f64 {
        if p.gamma > SUN_RADIUS {
            return 0.0;
        }
        let Some(irradiance) = self.solar.irradiance(wavelength_nm) else {
            return 0.0;
        };
        irradiance / self.sun_solid_angle * self.transmittance(p, wavelength_nm, f64::MAX)
    }
}

/// The runtime's distance along a ray from (0, `r0`) with direction
/// (sin θ, cos θ) to the circle of `radius` about the origin: the nearer
/// root when both are ahead, else the farther; none when the ray misses
/// or touches it, or the circle is behind.
fn ray_to_circle(r0: f64, cos_theta: f64, radius: f64) -> Option<f64> {
    let b = 2.0 * cos_theta * r0;
    let c = r0 * r0 - radius * radius;
    let discriminant = b * b - 4.0 * c;
    if discriminant <= 0.0 {
        return None;
    }
    let root = discriminant.sqrt();
    let (t1, t2) = ((-b - root) / 2.0, (-b + root) / 2.0);
    let t = if t1 > 0.0 && t2 > 0.0 { t1.min(t2) } else { t1.max(t2) };
    (t >= 0.0).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skymodel::angles::ViewAngles;

    #[test]
    fn rays_meet_the_ground_or_the_top() {
        let r0 = PLANET_RADIUS_M + 1000.0;
        assert!((ray_to_circle(r0, -1.0, PLANET_RADIUS_M).unwrap() - 1000.0).abs() < 1e-6);
        assert_eq!(ray_to_circle(r0, 1.0, PLANET_RADIUS_M), None);
        assert!((ray_to_circle(r0, 1.0, PLANET_RADIUS_M + 1e5).unwrap() - 99_000.0).abs() < 1e-6);
        assert_eq!(
            ray_to_circle(r0, 0.0, PLANET_RADIUS_M),
            None,
            "the horizontal ray passes above"
        );
    }

    #[test]
    fn node_and_break_positions() {
        assert_eq!(position(&[0.0, 1.0, 3.0], 2.0), Position { index: 1, factor: 0.5 });
        assert_eq!(position(&[0.0, 1.0, 3.0], 1.0), Position { index: 1, factor: 0.0 });
        assert_eq!(position(&[0.0, 1.0, 3.0], 7.0), Position { index: 2, factor: 0.0 });
        assert_eq!(position(&[0.0, 1.0, 3.0], -1.0), Position { index: 0, factor: 0.0 });
        assert_eq!(position(&[5.0], 1.0), Position { index: 0, factor: 0.0 });
        // Nodes at (i/4)³: p = 0.6 lies between i = 2 (0.125) and 3 (0.421875).
        let p = node_position(0.6, 4, 3);
        assert_eq!(p.index, 2);
        assert!((p.factor - (0.216 - 0.125) / (0.421875 - 0.125)).abs() < 1e-15);
        assert_eq!(node_position(1.0, 4, 3), Position { index: 3, factor: 0.0 });
        assert_eq!(node_position(0.99, 4, 4).factor, 0.0, "the last node");
    }

    #[test]
    fn parameters_raise_the_viewpoint_by_50_m() {
        let sun = SunPosition {
            elevation: 0.2,
            azimuth: 0.7,
        };
        for z in [0.0, 1234.0] {
            for v in [
                DVec3::new(0.3, -0.2, 0.93),
                DVec3::new(1.0, 0.0, -0.01),
                DVec3::new(-0.2, 0.5, -0.8),
            ] {
                let p = Parameters::new(DVec3::new(0.0, 0.0, z), v * 3.0, sun.elevation, sun.azimuth, 40.0, 0.5);
                assert!((p.altitude_m - (z + 50.0)).abs() < 1e-6);
                let a = ViewAngles::of(v.normalize(), sun, p.altitude_m);
                for (got, want) in [
                    (p.gamma, a.gamma),
                    (p.theta, a.theta),
                    (p.zero, a.zero),
                    (p.shadow, a.shadow),
                ] {
                    assert!((got - want).abs() < 1e-9, "{got} vs {want}");
                }
                assert!((p.elevation - 0.2).abs() < 1e-12);
            }
        }
        let at = |z: f64| Parameters::new(DVec3::new(0.0, 0.0, z), DVec3::Z, 0.2, 0.0, 40.0, 0.5).altitude_m;
        assert!(at(-50.0).abs() < 1e-6);
        assert_eq!(at(-80.0), 0.0);
    }

    #[test]
    fn elsewhere_on_the_planet_the_local_zenith_is_used() {
        // A viewpoint on the ground at angle β from the origin toward +x:
        // the sun in azimuth 0 stands β higher there.
        let beta: f64 = 0.1;
        let n = DVec3::new(beta.sin(), 0.0, beta.cos());
        let viewpoint = n * PLANET_RADIUS_M - DVec3::new(0.0, 0.0, PLANET_RADIUS_M);
        let p = Parameters::new(viewpoint, n, 0.3, 0.0, 40.0, 0.5);
        assert!((p.elevation - 0.4).abs() < 1e-9, "{}", p.elevation);
        assert!(p.theta.abs() < 1e-7 && p.zero.abs() < 1e-7);
        assert!((p.gamma - (FRAC_PI_2 - 0.4)).abs() < 1e-9);
    }
}
