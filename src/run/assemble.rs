//! A task's results from its sums: radiance and flux rows of a
//! `directions` sensor, the layers of an image.

use crate::film::fluxes::Fluxes;
use crate::film::image::SkyImage;
use crate::film::image::{self, ImageLayer};
use crate::film::noise::Noise;
use crate::film::results::RenderResult;
use crate::film::results::{FluxRow, RadianceRow};
use crate::film::tally::Tally;
use crate::job::{Job, Sensor, Task};
use crate::run::layout::{EstimateKind, Layout, UnitState};
use crate::sampling::stream::Channels;
use crate::sensor::camera::Camera;

/// A task's sums as a `directions` result: radiance rows (wavelength,
/// albedo, direction) and flux rows (wavelength, albedo).
pub fn directions_result(job: &Job, task: &Task, layout: &Layout, state: &UnitState) -> RenderResult {
    let spec = &job.render;
    let Sensor::Directions(directions) = &spec.sensor else {
        return RenderResult::default();
    };
    let na = spec.albedos.len();
    let mut radiance: Vec<Vec<Vec<Tally>>> = vec![vec![Vec::new(); na]; job.wavelengths_nm.len()];
    let mut flux: Vec<[Vec<Tally>; 2]> = vec![Default::default(); job.wavelengths_nm.len()];
    // A noise target's pilot only set the allocation: not a result.
    for (est, tallies) in layout.results(state) {
        match est.kind {
            EstimateKind::Direction { channels, .. } => {
                for (k, w) in layout.channel_indices(channels).into_iter().enumerate() {
                    for (a, list) in radiance[w].iter_mut().enumerate() {
                        list.push(tallies[k * na + a]);
                    }
                }
            }
            EstimateKind::Flux { channels, up } => {
                for (k, w) in layout.channel_indices(channels).into_iter().enumerate() {
                    flux[w][up as usize] = tallies[k * na..(k + 1) * na].to_vec();
                }
            }
            EstimateKind::Pixels { .. } | EstimateKind::GroundView { .. } => {}
        }
    }
    let mut result = RenderResult::default();
    let band_scene = (spec.fluxes && job.banded())
        .then(|| job.spectral_scene(task))
        .flatten();
    for (w, &wavelength_nm) in job.wavelengths_nm.iter().enumerate() {
        let k = job.unit_scale(wavelength_nm);
        let altitude_km = task.observer_altitude_km;
        let e_dir = spec.fluxes.then(|| {
            k * match &band_scene {
                // A band's direct irradiance is its band average.
                Some(scene) => scene.direct_horizontal(altitude_km, w),
                None => job.scene_for(task, w).direct_horizontal(altitude_km, 0),
            }
        });
        for (a, &albedo) in spec.albedos.iter().enumerate() {
            for (direction, tally) in directions.iter().zip(&radiance[w][a]) {
                result.radiance.push(RadianceRow {
                    wavelength_nm,
                    albedo,
                    direction: *direction,
                    tally: tally.scaled(k),
                });
            }
            if let Some(e_dir) = e_dir {
                result.fluxes.push(FluxRow {
                    wavelength_nm,
                    albedo,
                    altitude_km: task.observer_altitude_km,
                    fluxes: Fluxes::new(e_dir, &flux[w][0][a].scaled(k), &flux[w][1][a].scaled(k)),
                });
            }
        }
    }
    result
}

/// A noise target's samples per pixel: for one channel (its wavelength),
/// or for all of them along shared paths (`None`).
type SampleMap = (Option<f64>, Vec<u64>);

/// A task's sums as an image: one layer per (wavelength, albedo).
pub fn image_result(job: &Job, camera: &Camera, layout: &Layout, state: &UnitState) -> SkyImage {
    let (width, height) = camera.size();
    let spec = &job.render;
    let na = spec.albedos.len();
    // Layers and sample maps keyed by channel index, so that they come in
    // the job's channel order whatever the channel sets.
    let mut layers: Vec<(usize, ImageLayer)> = Vec::new();
    let mut samples: Vec<(usize, SampleMap)> = Vec::new();
    for (channels, per_value, non_finite) in pixel_tallies(camera, layout, state) {
        let wavelengths = layout.channel_indices(channels);
        if layout.target.is_some() {
            // A noise target's samples per pixel: one map for all the
            // channels along shared paths, else one per channel (each
            // channel of a spectral group has its group's).
            let map: Vec<u64> = per_value[0].iter().map(|t| t.samples).collect();
            match channels {
                Channels::Shared => samples.push((0, (None, map))),
                _ => samples.extend(
                    wavelengths
                        .iter()
                        .map(|&w| (w, (Some(job.wavelengths_nm[w]), map.clone()))),
                ),
            }
        }
        for (k, &w) in wavelengths.iter().enumerate() {
            for (a, &albedo) in spec.albedos.iter().enumerate() {
                let layer = ImageLayer::from_tallies(
                    job.wavelengths_nm[w],
                    albedo,
                    &per_value[k * na + a],
                    if k == 0 && a == 0 { non_finite } else { 0 },
                );
                layers.push((w, layer));
            }
        }
    }
    // Stable: a channel's albedos keep their order.
    layers.sort_by_key(|(w, _)| *w);
    samples.sort_by_key(|(w, _)| *w);
    SkyImage {
        width,
        height,
        layers: layers.into_iter().map(|(_, l)| l).collect(),
        samples: samples.into_iter().map(|(_, s)| s).collect(),
    }
}

/// Per image estimate (its channels), the tallies `[value][pixel]` of
/// every pixel and the count of non-finite samples; the pixels of the
/// columns that are not traced hold the mirror images of their partners'
/// or their rotations' ([`crate::sensor::symmetry`]), those of the rows
/// that are not traced (below the horizon of an observer on the ground)
/// the ground view's, those outside a fisheye's circle none.
fn pixel_tallies(camera: &Camera, layout: &Layout, state: &UnitState) -> Vec<(Channels, Vec<Vec<Tally>>, u64)> {
    let (width, height) = camera.size();
    let ground: Vec<(Channels, &Vec<Tally>)> = layout
        .results(state)
        .filter_map(|(est, t)| match est.kind {
            EstimateKind::GroundView { channels } => Some((channels, t)),
            _ => None,
        })
        .collect();
    let mut out = Vec::new();
    for (est, tallies) in layout.results(state) {
        let EstimateKind::Pixels { channels } = est.kind else {
            continue;
        };
        let (mut per_value, mut non_finite) = image::split_values(tallies, est.values);
        for j in 0..layout.traced_rows.min(height) {
            for i in camera.active_columns(j) {
                if let Some(source) = layout.symmetry.source_column(width, i) {
                    for list in per_value.iter_mut() {
                        let t = list[j * width + source];
                        list[j * width + i] = if layout.symmetry.negates_u_v() { t.mirrored() } else { t };
                    }
                }
            }
        }
        if let Some((_, view)) = ground.iter().find(|(c, _)| *c == channels) {
            for j in layout.traced_rows..height {
                for i in camera.active_columns(j) {
                    for (v, list) in per_value.iter_mut().enumerate() {
                        list[j * width + i] = view[v];
                    }
                }
            }
            non_finite += view.first().map_or(0, |t| t.non_finite);
        }
        out.push((channels, per_value, non_finite));
    }
    out
}

/// The noise a task's sums reached (against its noise target, or 0): per
/// (wavelength, albedo), over the pixels or the viewing directions, with
/// whether the target counts that albedo.
pub fn noise(job: &Job, layout: &Layout, state: &UnitState) -> Vec<(f64, f64, bool, Noise)> {
    let target = layout.target.map_or(0.0, |t| t.relative_se);
    let na = job.render.albedos.len();
    let nw = job.wavelengths_nm.len();
    // Per (wavelength, albedo), the tallies of its pixels or directions.
    let mut per_value: Vec<Vec<Tally>> = vec![Vec::new(); nw * na];
    // Value v of an estimate is albedo v % na of its channel v / na.
    let slot = |indices: &[usize], v: usize| indices[v / na] * na + v % na;
    for (est, tallies) in layout.results(state) {
        if let EstimateKind::Direction { channels, .. } = est.kind {
            let indices = layout.channel_indices(channels);
            for (v, t) in tallies.iter().enumerate() {
                per_value[slot(&indices, v)].push(*t);
            }
        }
    }
    if let Sensor::Image(camera) = &job.render.sensor {
        for (channels, values, _) in pixel_tallies(camera, layout, state) {
            let indices = layout.channel_indices(channels);
            for (v, list) in values.into_iter().enumerate() {
                per_value[slot(&indices, v)] = list;
            }
        }
    }
    let camera = match &job.render.sensor {
        Sensor::Image(camera) => Some(camera),
        Sensor::Directions(_) => None,
    };
    per_value
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let albedo = job.render.albedos[k % na];
            let noise = match camera {
                Some(c) => {
                    let width = c.size().0.max(1);
                    Noise::of_image(t, target, |p| c.pixel_solid_angle(p % width, p / width))
                }
                None => Noise::of(t, target),
            };
            (
                job.wavelengths_nm[k / na],
                albedo,
                layout.target.is_none_or(|t| t.albedos.counts(albedo)),
                noise,
            )
        })
        .collect()
}
