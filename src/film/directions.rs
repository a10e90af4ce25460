//! Radiances along a list of viewing directions: per direction, the sums of
//! a scene's radiance samples for every channel and albedo.

use crate::film::tally::{Tally, tally};
use crate::sampling::stream::{Estimate, Render, StreamKey};
use crate::sensor::direction::Direction;
use crate::transport::tracer::{Scene, ViewRay};

/// Renders each direction with `samples` paths for every channel and
/// albedo of the scene: `[channel][albedo][direction]`. `seed` and
/// `render` key the streams ([`crate::sampling::stream`]).
pub fn render_directions_all(
    scene: &Scene,
    altitude_km: f64,
    directions: &[Direction],
    samples: u64,
    seed: u64,
    render: Render,
) -> Vec<Vec<Vec<Tally>>> {
    let (nw, na) = (scene.channel_count(), scene.albedos.len());
    let per_direction: Vec<Vec<Tally>> = directions
        .iter()
        .enumerate()
        .map(|(d, dir)| {
            let (v, e1) = (dir.vector(), dir.meridian_axis());
            tally(
                samples,
                StreamKey::new(seed, render, Estimate::Direction(d)),
                scene.value_count(),
                |s, out| scene.radiance_sample(altitude_km, v, e1, ViewRay::Repeated, s, out),
            )
        })
        .collect();
    (0..nw)
        .map(|w| {
            (0..na)
                .map(|a| per_direction.iter().map(|t| t[w * na + a]).collect())
                .collect()
        })
        .collect()
}

/// [`render_directions_all`] for the scene's first channel and albedo.
pub fn render_directions(
    scene: &Scene,
    altitude_km: f64,
    directions: &[Direction],
    samples: u64,
    seed: u64,
    render: Render,
) -> Vec<Tally> {
    render_directions_all(scene, altitude_km, directions, samples, seed, render)
        .swap_remove(0)
        .swap_remove(0)
}
