//! The resolved transport options of `[render]`: what the job asks of the
//! path tracer (polarisation, scattering orders, sun connections, flights,
//! the medium's model inside a layer). The tracer that honours them is
//! `transport`.

/// Density model inside a layer (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MediumModel {
    Layered,
    Smooth,
}

/// How shadow rays toward the sun get their transmittance (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SunTransmittance {
    Analytic,
    RatioTracking,
}

/// Which layers paths are tracked through (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackingLayers {
    /// Merged where the profile is fine (a layered, spherical atmosphere
    /// of more than [`AUTO_MIN_LAYERS`](crate::transport::tracer::AUTO_MIN_LAYERS)
    /// layers with analytic shadow rays), else the profile's own: resolved
    /// when a scene is made.
    Auto,
    /// The profile's own layers: every optical depth in closed form.
    Profile,
    /// Runs of similar layers merged, what they leave out ratio-tracked
    /// (`transport::tracer::tracking`).
    Merged,
}

/// Settings of the transport.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    pub polarized: bool,
    /// Highest scattering order counted (ground reflections included); 0 =
    /// unlimited.
    pub max_scattering_order: u32,
    pub sun_transmittance: SunTransmittance,
    pub tracking_layers: TrackingLayers,
    /// Force a collision on flights that would otherwise leave the
    /// atmosphere or die on a black ground (piecewise-constant media).
    pub forced_collisions: bool,
    /// Sun connections per forced flight: stratified points along the
    /// flight, each with 1/K of the weight (the path goes on from one of
    /// them, picked uniformly).
    pub sun_samples_per_flight: u32,
    /// How next-event points along a flight are chosen.
    pub sun_sampling: SunSampling,
    /// Split the sensor path at its first vertex: a forced flight toward a
    /// reflecting ground follows both of its ends,
    /// and the first scattering goes on in two directions a quarter turn
    /// apart about the line of sight (`quarter_turn`), half the weight
    /// each.
    pub first_vertex_splitting: bool,
    /// Of that split, the first scattering's two directions (with
    /// `first_vertex_splitting`). By default on for fixed-sample renders
    /// and off under a noise target, which counts I alone: the split cuts
    /// the noise of Q and U most and costs I more time than it saves it
    /// (docs/noise-targets.md, the first scattering unsplit).
    pub split_first_scattering: bool,
    /// Effective throughput (mean over the channels, with the balance
    /// heuristic's denominator) below which Russian roulette starts, from
    /// the second vertex on; a survivor carries this much. By day (sun
    /// connections at collisions) a path whose view is thin scales it down
    /// by the view's chance to scatter (docs/design.md, "Thin views roulette
    /// later").
    pub roulette_threshold: f64,
}

impl Settings {
    /// Whether a path that has reached scattering order `order` stops.
    pub fn order_done(&self, order: u32) -> bool {
        self.max_scattering_order != 0 && order >= self.max_scattering_order
    }
}

/// The default `render.roulette_threshold`. 0.03 rather than the 0.1 of
/// versions before 2026-11-26: on the sky model grid's bands (directions
/// jobs of 12 views, sun −4.2° to 45°, observers at 0 and 15 km) the
/// variance per path fell 1.2–2.8× (twilight paths climb to sunlit air,
/// and paths from 15 km leave its thin air, with throughputs of a few
/// hundredths) at about 1.3× the time per path (docs/design.md, "Transport").
pub const DEFAULT_ROULETTE_THRESHOLD: f64 = 0.03;

/// The settings a job gave itself; the others are defaults that a scene
/// chooses by its regime where measurements say so
/// (`transport::scene_build`, docs/performance.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GivenSettings {
    pub roulette_threshold: bool,
}

/// The roulette threshold by day: with the sun at least
/// [`DAY_ROULETTE_MIN_ELEVATION_DEG`] up and every channel's column
/// extinction at most [`DAY_ROULETTE_MAX_COLUMN`], a scene roulettes from
/// 0.1 (the threshold of versions before 2026-11-26) instead of the
/// default: single scattering dominates there, and the longer paths of
/// 0.03 cost more time than they save variance. Figure-of-merit suite
/// (`bench --suite`, both thresholds paired on one build, 2 rounds,
/// 2026-11-29): day 1.24× (median over its 16 directions, min 1.16),
/// the 1000-level profile 1.11×, Mie at sun zenith 60° 1.28×; but 11
/// bands at sun 45° 0.98× (its 340 nm column is 1.2), bands at 20° up
/// 0.80×, from 15 km at sun zenith 85° 0.84×, twilight 0.76×, sun 2° up
/// 0.97×: those keep 0.03. Calibration of the standard errors unchanged
/// (docs/lab-notes/2026-11-29.md, "The day roulette's failed test").
pub const DAY_ROULETTE_THRESHOLD: f64 = 0.1;

/// The least sun elevation (°) of [`DAY_ROULETTE_THRESHOLD`].
pub const DAY_ROULETTE_MIN_ELEVATION_DEG: f64 = 30.0;

/// The largest column extinction of any channel of
/// [`DAY_ROULETTE_THRESHOLD`] (the day case's 540 nm column with its
/// aerosol is 0.38; the bands' 340 nm 1.2).
pub const DAY_ROULETTE_MAX_COLUMN: f64 = 0.7;

/// How the channels that share spectral paths are grouped (closed set):
/// each group has paths of its own, its channels sharing them (hero
/// wavelengths and the balance heuristic inside the group).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpectralGroups {
    /// Two groups by column extinction where the channels' column
    /// extinctions span at least [`AUTO_GROUPS_MIN_SPREAD`], else one
    /// (where every channel gains from the others' paths):
    /// `transport::scene_build` states the measurements.
    Auto,
    /// This many groups (1: every channel along the same paths).
    Count(usize),
}

/// The least ratio of the largest to the smallest column extinction of the
/// channels at which `spectral_groups = "auto"` makes two groups: the
/// sky model grid's bands span 5 (20 km visibility) to 12 (131.8 km) and
/// gain from two; the quickstart's wavelengths span 2.2 and do not (13.8 M
/// paths against 8.5 M for the same noise target, docs/design.md "Spectral
/// groups").
pub const AUTO_GROUPS_MIN_SPREAD: f64 = 3.0;

/// Where on a flight the sun is connected to (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SunSampling {
    /// At the collision the path goes on from.
    Collision,
    /// At a point drawn from a density that follows the sunlit single
    /// scattering along the flight (piecewise-constant media): dearer per
    /// path than `Collision`, far less noise for a set sun.
    SunAware,
    /// `SunAware` in plane-parallel geometry (where it costs little) and
    /// for a sun lower than 10° above the horizon, else `Collision`: where
    /// the measured efficiencies of the two cross over (docs/design-sun.md, "Sun
    /// connections at twilight"); with the sun 10° to 25° up, scattering
    /// directions are also drawn in part about the sun (docs/design-sun.md,
    /// "Scattering around the sun").
    Auto,
}

impl SunSampling {
    /// Whether a sun at `zenith_deg` gets sun-aware sampling.
    pub fn is_sun_aware(self, zenith_deg: f64, plane_parallel: bool) -> bool {
        match self {
            SunSampling::Collision => false,
            SunSampling::SunAware => true,
            SunSampling::Auto => plane_parallel || zenith_deg > 80.0,
        }
    }
}

/// The most ground albedos one render estimates.
pub const MAX_ALBEDOS: usize = 8;
