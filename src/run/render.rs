//! Rendering a `directions` sensor and the fluxes at the observer level:
//! samples in fixed blocks, blocks in parallel (rayon), sums reduced in
//! block order so the result is bit-identical for any number of threads.

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::polarization::stokes::{Stokes, meridian_frame};
use crate::polarization::stokes_frame::StokesFrame;
use crate::sampling::sampler::Sampler;
use crate::transport::spectral::Scene;

/// Samples per block: the unit of parallel work and of the summation order.
pub const BLOCK: u64 = 1024;

/// A viewing direction: view zenith (0 = zenith, 180 = nadir) and azimuth
/// relative to the sun's, counter-clockwise from above, in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Direction {
    pub view_zenith_deg: f64,
    pub azimuth_deg: f64,
}

impl Direction {
    /// The unit vector v = (sin θ cos φ, sin θ sin φ, cos θ).
    pub fn vector(&self) -> DVec3 {
        let (st, ct) = self.view_zenith_deg.to_radians().sin_cos();
        let (sp, cp) = self.azimuth_deg.to_radians().sin_cos();
        DVec3::new(st * cp, st * sp, ct)
    }

    /// The Stokes reference axis e1 of this direction in `frame`
    /// ([`crate::polarization::stokes_frame`]); `sun` is the unit vector toward the sun.
    pub fn axis(&self, frame: StokesFrame, sun: DVec3) -> DVec3 {
        frame.axis(self.vector(), self.azimuth_deg.to_radians(), sun)
    }

    /// The meridian axis e1 = ∂v/∂θ of this direction (at the zenith or
    /// nadir, that of its azimuth).
    pub fn meridian_axis(&self) -> DVec3 {
        meridian_frame(self.vector(), self.azimuth_deg.to_radians()).0
    }
}

/// Sums of a sample set: Σx and Σx² per Stokes component.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Tally {
    pub sum: [f64; 4],
    pub sum_sq: [f64; 4],
    pub samples: u64,
    /// Samples with a non-finite component: counted, never summed.
    pub non_finite: u64,
}

impl Tally {
    /// Adds one sample (a non-finite one only to the count of such).
    pub fn add(&mut self, s: &Stokes) {
        if s.0.iter().any(|x| !x.is_finite()) {
            self.non_finite += 1;
            self.samples += 1;
            return;
        }
        for k in 0..4 {
            self.sum[k] += s.0[k];
            self.sum_sq[k] += s.0[k] * s.0[k];
        }
        self.samples += 1;
    }

    /// Adds another tally's sums and counts.
    pub fn merge(&mut self, o: &Tally) {
        for k in 0..4 {
            self.sum[k] += o.sum[k];
            self.sum_sq[k] += o.sum_sq[k];
        }
        self.samples += o.samples;
        self.non_finite += o.non_finite;
    }

    /// The tally of the samples times `k` (a change of units).
    pub fn scaled(&self, k: f64) -> Tally {
        Tally {
            sum: self.sum.map(|s| s * k),
            sum_sq: self.sum_sq.map(|s| s * k * k),
            ..*self
        }
    }

    /// Mean per component (0 without samples).
    pub fn mean(&self) -> [f64; 4] {
        if self.samples == 0 {
            return [0.0; 4];
        }
        self.sum.map(|s| s / self.samples as f64)
    }

    /// Standard error of the mean per component.
    pub fn standard_error(&self) -> [f64; 4] {
        if self.samples < 2 {
            return [0.0; 4];
        }
        let n = self.samples as f64;
        std::array::from_fn(|k| {
            let m = self.sum[k] / n;
            let var = (self.sum_sq[k] / n - m * m).max(0.0) * n / (n - 1.0).max(1.0);
            (var / n).sqrt()
        })
    }
}

/// Stream key for the flux estimates (directions use their index).
const FLUX_DOWN_KEY: u64 = u64::MAX - 1;
const FLUX_UP_KEY: u64 = u64::MAX - 2;

/// Tallies (one per value of a sample) of one estimate per sample index `i`
/// of `f(sampler, values)` (which writes the sample's `count` values),
/// summed in blocks (fixed order: bit-identical for any thread count).
pub fn tally(samples: u64, keys: [u64; 3], count: usize, f: impl Fn(&mut Sampler, &mut [Stokes]) + Sync) -> Vec<Tally> {
    let mut total = vec![Tally::default(); count];
    tally_blocks(0..samples.div_ceil(BLOCK), samples, keys, &mut total, f);
    total
}

/// Adds the samples of `blocks` (block indices of an estimate of `samples`
/// samples) to `total`, one tally per value: blocks in parallel, their sums
/// added to `total` in block order. Adding blocks 0..a and then a..b gives
/// bit for bit what adding 0..b at once gives, which is what makes shards
/// and checkpoints exact.
pub fn tally_blocks(
    blocks: std::ops::Range<u64>,
    samples: u64,
    keys: [u64; 3],
    total: &mut [Tally],
    f: impl Fn(&mut Sampler, &mut [Stokes]) + Sync,
) {
    let count = total.len();
    let partial: Vec<Vec<Tally>> = blocks
        .into_par_iter()
        .map(|b| {
            let mut t = vec![Tally::default(); count];
            let mut values = vec![Stokes::zero(); count];
            for i in b * BLOCK..((b + 1) * BLOCK).min(samples) {
                let mut s = Sampler::new(&[keys[0], keys[1], keys[2], i]);
                f(&mut s, &mut values);
                for (ta, v) in t.iter_mut().zip(&values) {
                    ta.add(v);
                }
            }
            t
        })
        .collect();
    for p in &partial {
        for (t, q) in total.iter_mut().zip(p) {
            t.merge(q);
        }
    }
}

/// The samples of `blocks`.
pub fn block_samples(blocks: &std::ops::Range<u64>, samples: u64) -> u64 {
    (blocks.end * BLOCK).min(samples) - (blocks.start * BLOCK).min(samples)
}

/// Renders each direction with `samples` paths for every channel and
/// albedo of the scene: `[channel][albedo][direction]`. `keys` = (seed,
/// stream key) identify the streams.
pub fn render_directions_all(
    scene: &Scene,
    altitude_km: f64,
    directions: &[Direction],
    samples: u64,
    seed: u64,
    key: u64,
) -> Vec<Vec<Vec<Tally>>> {
    let (nw, na) = (scene.channel_count(), scene.albedos.len());
    let per_direction: Vec<Vec<Tally>> = directions
        .iter()
        .enumerate()
        .map(|(d, dir)| {
            let (v, e1) = (dir.vector(), dir.meridian_axis());
            tally(samples, [seed, key, d as u64], scene.value_count(), |s, out| {
                scene.radiance_sample(altitude_km, v, e1, s, out)
            })
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
    key: u64,
) -> Vec<Tally> {
    render_directions_all(scene, altitude_km, directions, samples, seed, key)
        .swap_remove(0)
        .swap_remove(0)
}

/// Fluxes at the observer level per unit E0 (libRadtran's edir, edn, eup).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fluxes {
    /// Direct solar irradiance on a horizontal plane, μ0·T_sun.
    pub e_dir: f64,
    /// Diffuse downward irradiance and its standard error.
    pub e_down: f64,
    pub e_down_se: f64,
    /// Upward irradiance and its standard error.
    pub e_up: f64,
    pub e_up_se: f64,
    pub samples: u64,
}

/// Irradiances at the observer for every albedo of the scene's first
/// channel: E = π·⟨I⟩ over cosine-distributed viewing directions in each
/// hemisphere; the direct beam from the exact transmittance along the
/// sun's direction.
pub fn render_fluxes_all(scene: &Scene, altitude_km: f64, samples: u64, seed: u64, key: u64) -> Vec<Fluxes> {
    let hemisphere = |stream: u64, up: bool| {
        tally(samples, [seed, key, stream], scene.value_count(), |s, out| {
            flux_sample(scene, altitude_km, up, s, out)
        })
    };
    let down = hemisphere(FLUX_DOWN_KEY, false);
    let up = hemisphere(FLUX_UP_KEY, true);
    let e_dir = scene.direct_horizontal(altitude_km, 0);
    down.iter()
        .zip(&up)
        .take(scene.albedos.len())
        .map(|(d, u)| Fluxes::new(e_dir, d, u))
        .collect()
}

/// The stream (third key) of the downward (`up` false) or upward flux.
pub fn flux_stream(up: bool) -> u64 {
    if up { FLUX_UP_KEY } else { FLUX_DOWN_KEY }
}

/// One sample of an irradiance estimate: π·I for a cosine-distributed
/// viewing direction in the upper (`up` false: light coming down) or lower
/// hemisphere, for every channel and albedo of the scene, into `out`.
pub fn flux_sample(scene: &Scene, altitude_km: f64, up: bool, s: &mut Sampler, out: &mut [Stokes]) {
    let (v, e1) = flux_direction(up, s);
    scene.radiance_sample(altitude_km, v, e1, s, out);
    to_irradiance(out);
}

/// A cosine-distributed viewing direction in the upper (`up` false) or
/// lower hemisphere, and its meridian axis.
fn flux_direction(up: bool, s: &mut Sampler) -> (DVec3, DVec3) {
    let sign = if up { -1.0 } else { 1.0 };
    let u = s.next2();
    let r = u[0].sqrt();
    let phi = 2.0 * PI * u[1];
    let z = sign * (1.0 - u[0]).max(0.0).sqrt();
    let v = DVec3::new(r * phi.cos(), r * phi.sin(), z);
    (v, meridian_frame(v, phi).0)
}

/// Radiances of cosine-distributed directions to irradiances: π·I.
fn to_irradiance(values: &mut [Stokes]) {
    for x in values.iter_mut() {
        *x = Stokes::new(PI * x.0[0], 0.0, 0.0, 0.0);
    }
}

impl Fluxes {
    /// The fluxes from the direct irradiance and the tallies of the
    /// downward and upward estimates.
    pub fn new(e_dir: f64, down: &Tally, up: &Tally) -> Fluxes {
        Fluxes {
            e_dir,
            e_down: down.mean()[0],
            e_down_se: down.standard_error()[0],
            e_up: up.mean()[0],
            e_up_se: up.standard_error()[0],
            samples: down.samples,
        }
    }
}

/// [`render_fluxes_all`] for the scene's first albedo.
pub fn render_fluxes(scene: &Scene, altitude_km: f64, samples: u64, seed: u64, key: u64) -> Fluxes {
    render_fluxes_all(scene, altitude_km, samples, seed, key).swap_remove(0)
}

/// Everything a `directions` render produces.
#[derive(Debug, Clone, Default)]
pub struct RenderResult {
    pub radiance: Vec<crate::io::output::RadianceRow>,
    pub fluxes: Vec<crate::io::output::FluxRow>,
}

/// The stream key of (task, wavelength): independent streams for every
/// render of a job (all albedos share their paths).
pub fn stream_key(task: usize, wavelength: usize) -> u64 {
    ((task as u64) << 32) | wavelength as u64
}

/// Renders a `directions` sensor for every albedo and wavelength of one
/// task in one go (in the current rayon pool; see [`crate::run::work_unit`] for runs
/// that checkpoint), calling `log` with a line at the end.
pub fn render_task(job: &crate::job::Job, task: &crate::job::Task, log: &dyn Fn(&str)) -> RenderResult {
    use crate::run::shard::Shard;
    use crate::run::work_unit::{self, Control, Layout};
    let start = std::time::Instant::now();
    let shared = job.spectral_scene(task);
    let layout = Layout::new(job, task, shared.is_some());
    let mut state = layout.empty_state(job, task, Shard::WHOLE);
    let quiet = |_| {};
    // Without a stop flag or checkpoints a run always completes.
    let _ = work_unit::run(job, task, &layout, shared, &mut state, &Control::none(&quiet));
    let paths = layout.paths(Shard::WHOLE);
    let secs = start.elapsed().as_secs_f64();
    log(&format!(
        "{}: {} wavelengths × {} albedos{}: {paths} paths in {secs:.2} s ({:.0} paths/s on {} threads)",
        task.name,
        job.wavelengths_nm.len(),
        job.render.albedos.len(),
        if layout.shared { " along shared paths" } else { "" },
        paths as f64 / secs,
        rayon::current_num_threads()
    ));
    work_unit::directions_result(job, task, &layout, &state)
}
