//! Rendering an image sensor: per pixel, `samples` paths through points of
//! the pixel (stratified jitter, box filter) or through its centre, each
//! sample's radiance weighted by dΩ/dA over the pixel's mean, so the pixel
//! holds the mean radiance over its solid angle. Each sample's Stokes
//! vector is referred to the pixel's frame (that of its centre direction,
//! carried to the sample's direction: [`crate::polarization::stokes_frame`]), so the frame
//! is continuous over the pixel, the zenith and nadir pixels included.
//! Pixels are rendered in parallel; each pixel's sums run in sample order,
//! so the image is bit-identical for any number of threads.

use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use crate::film::pixel_counts::PixelCounts;
use crate::film::tally::Tally;
use crate::polarization::stokes::Stokes;
use crate::polarization::stokes_frame::{StokesFrame, carry};
use crate::sampling::sampler::Sampler;
use crate::sampling::stream::{Estimate, Render, StreamKey};
use crate::sensor::camera::{Camera, PixelFilter};
use crate::transport::tracer::{Scene, ViewRay};

/// One image layer: a wavelength and an albedo, mean and standard error of
/// I, Q, U, V per pixel (row-major, row 0 at the top).
#[derive(Debug, Clone)]
pub struct ImageLayer {
    pub wavelength_nm: f64,
    pub albedo: f64,
    pub mean: [Vec<f64>; 4],
    pub se: [Vec<f64>; 4],
    /// Samples that gave a non-finite value (left out of the sums).
    pub non_finite: u64,
}

impl ImageLayer {
    /// A layer from its pixels' tallies.
    pub fn from_tallies(wavelength_nm: f64, albedo: f64, pixels: &[Tally], non_finite: u64) -> ImageLayer {
        let mut mean: [Vec<f64>; 4] = Default::default();
        let mut se: [Vec<f64>; 4] = Default::default();
        for t in pixels {
            let (m, e) = (t.mean(), t.standard_error());
            for k in 0..4 {
                mean[k].push(m[k]);
                se[k].push(e[k]);
            }
        }
        ImageLayer {
            wavelength_nm,
            albedo,
            mean,
            se,
            non_finite,
        }
    }
}

/// Mean dΩ/dA of every pixel of a camera, i.e. its solid angle (0 for
/// pixels outside a fisheye's circle); computed once per image.
pub fn pixel_weights(camera: &Camera) -> Vec<f64> {
    static NEVER: AtomicBool = AtomicBool::new(false);
    pixel_weights_until(camera, &NEVER).expect("never stopped")
}

/// [`pixel_weights`] in bands of rows, giving up (`None`) between two
/// bands once `stop` is set: a stop request is honoured within about a
/// band's time (≈ 0.1 s) at any image size.
pub fn pixel_weights_until(camera: &Camera, stop: &AtomicBool) -> Option<Vec<f64>> {
    let (w, h) = camera.size();
    let mut weights = vec![0.0; w * h];
    let band = (1 << 20) / w.max(1) + 1;
    for (b, rows) in weights.chunks_mut(band * w.max(1)).enumerate() {
        if stop.load(Ordering::SeqCst) {
            return None;
        }
        rows.par_iter_mut().enumerate().for_each(|(k, weight)| {
            let (i, j) = (k % w, b * band + k / w);
            *weight = camera.pixel_solid_angle(i, j);
        });
    }
    Some(weights)
}

/// The pixels that are traced (those of a fisheye inside its circle) and
/// how many of them lie in a range of a render's *items*: a render of `s`
/// samples per pixel is the items `0 .. s·P` (`P` pixels), item `n` being
/// sample `n / P` of pixel `n mod P`. A range of items is a wave of any
/// size, down to a few pixels of one sample each, and every pixel still
/// adds its samples in order.
#[derive(Debug, Clone, PartialEq)]
pub struct ActivePixels {
    width: usize,
    /// Per row, its first and one-past-last active column.
    columns: Vec<(usize, usize)>,
    /// Active pixels in the rows above each row (and in all, last).
    before_row: Vec<u64>,
}

impl ActivePixels {
    /// The active pixels of `camera` in its first `traced_rows` rows and
    /// first `traced_columns` columns, from its geometry (O(rows)); the rows
    /// below are not traced (they share the ground view, see
    /// [`crate::run::layout::EstimateKind::GroundView`]), nor are the
    /// columns to the right (copies of those traced: mirror images, or
    /// rotations under a sun at the zenith, [`crate::sensor::symmetry`]).
    pub fn new(camera: &Camera, traced_rows: usize, traced_columns: usize) -> ActivePixels {
        let (width, height) = camera.size();
        let columns: Vec<(usize, usize)> = (0..height)
            .map(|j| {
                let c = if j < traced_rows {
                    camera.active_columns(j)
                } else {
                    0..0
                };
                let end = c.end.min(traced_columns);
                (c.start.min(end), end)
            })
            .collect();
        let mut before_row = Vec::with_capacity(height + 1);
        let mut n = 0;
        for &(lo, hi) in &columns {
            before_row.push(n);
            n += (hi - lo) as u64;
        }
        before_row.push(n);
        ActivePixels {
            width,
            columns,
            before_row,
        }
    }

    /// All pixels, active or not.
    pub fn pixels(&self) -> u64 {
        (self.width * self.columns.len()) as u64
    }

    /// The active pixels.
    pub fn count(&self) -> u64 {
        *self.before_row.last().unwrap_or(&0)
    }

    /// Active pixels with an index below `p` (row-major).
    fn below(&self, p: u64) -> u64 {
        let (j, i) = ((p / self.width as u64) as usize, (p % self.width as u64) as usize);
        match self.columns.get(j) {
            None => self.count(),
            Some(&(lo, hi)) => self.before_row[j] + (i.clamp(lo, hi) - lo) as u64,
        }
    }

    /// Active items (traced paths) in the items `range`.
    pub fn paths(&self, range: &std::ops::Range<u64>) -> u64 {
        let p = self.pixels().max(1);
        let up_to = |x: u64| (x / p) * self.count() + self.below(x % p);
        up_to(range.end) - up_to(range.start)
    }
}

/// Samples of pixel `p` (of `pixels`) among the items `0 .. x`.
fn samples_below(p: u64, pixels: u64, x: u64) -> u64 {
    x / pixels + u64::from(x % pixels > p)
}

/// How pixels are sampled: the camera, the rows that are traced (from the
/// top; those below share the ground view) and the columns (from the left;
/// those to the right are copies of them), the pixels' mean dΩ/dA, the
/// filter, the Stokes frame (and the sun's direction, which the sun–view
/// frame needs), samples per pixel, the seed and render that key the
/// pixels' streams, and whether they are a noise target's pilot (streams
/// of their own).
#[derive(Clone, Copy)]
pub struct PixelSampling<'a> {
    pub camera: &'a Camera,
    pub traced_rows: usize,
    pub traced_columns: usize,
    pub weights: &'a [f64],
    pub filter: PixelFilter,
    pub frame: StokesFrame,
    pub sun: glam::DVec3,
    pub samples: u64,
    pub seed: u64,
    pub render: Render,
    pub pilot: bool,
}

impl PixelSampling<'_> {
    /// Whether a pixel's samples repeat one view ray (through its centre)
    /// or each take their own (jittered over the pixel).
    pub fn view_ray(&self) -> ViewRay {
        match self.filter {
            PixelFilter::Box => ViewRay::Changing,
            PixelFilter::Center => ViewRay::Repeated,
        }
    }
}

/// Renders every pixel: `radiance(direction, e1, sampler, values)` writes a sample's
/// `count` values referred to the axis `e1`; returns tallies `[value][pixel]` and the count
/// of non-finite samples. `progress` is called as pixels finish (from
/// worker threads).
pub fn render_pixels(
    sampling: &PixelSampling,
    count: usize,
    progress: &(dyn Fn(u64) + Sync),
    radiance: impl Fn(glam::DVec3, glam::DVec3, &mut Sampler, &mut [Stokes]) + Sync,
) -> (Vec<Vec<Tally>>, u64) {
    let pixels = sampling.weights.len();
    let mut per_pixel = vec![Tally::default(); pixels * count];
    let items = 0..sampling.samples * pixels as u64;
    render_pixels_into(sampling, items, &mut per_pixel, count, progress, radiance);
    split_values(&per_pixel, count)
}

/// Adds the items `items` (see [`ActivePixels`]: item `n` is sample `n / P`
/// of pixel `n mod P`) to `per_pixel` (pixel-major: `count` tallies per
/// pixel). Each pixel's tallies run in sample order, so adding 0..a and
/// then a..b gives bit for bit what adding 0..b at once gives. `progress`
/// gets the paths traced, as pixels finish.
pub fn render_pixels_into(
    sampling: &PixelSampling,
    items: std::ops::Range<u64>,
    per_pixel: &mut [Tally],
    count: usize,
    progress: &(dyn Fn(u64) + Sync),
    radiance: impl Fn(glam::DVec3, glam::DVec3, &mut Sampler, &mut [Stokes]) + Sync,
) {
    let (w, _) = sampling.camera.size();
    let pixels = sampling.weights.len() as u64;
    if items.is_empty() || pixels == 0 {
        return;
    }
    // The pixels the items touch: all, or one or two runs of indices.
    let (first, last) = (items.start % pixels, items.end % pixels);
    let runs: [std::ops::Range<u64>; 2] = if items.end - items.start >= pixels {
        [0..pixels, 0..0]
    } else if first < last {
        [first..last, 0..0]
    } else {
        [first..pixels, 0..last]
    };
    for run in runs.into_iter().filter(|r| !r.is_empty()) {
        let (a, b) = (run.start as usize, run.end as usize);
        per_pixel[a * count..b * count]
            .par_chunks_mut(count)
            .with_min_len(4)
            .enumerate()
            .for_each(|(k, tallies)| {
                let p = a + k;
                let samples = samples_below(p as u64, pixels, items.start)..samples_below(p as u64, pixels, items.end);
                let n = samples.end - samples.start;
                let total = sampling.samples;
                if n > 0 && render_pixel(sampling, (p % w, p / w), p, (samples, total), tallies, &radiance) {
                    progress(n);
                }
            });
    }
}

/// Adds the items `items` of pixels with samples of their own (`counts`,
/// see [`PixelCounts`]) to `per_pixel` (pixel-major, `count` tallies per
/// pixel); as [`render_pixels_into`], any cut of the items into waves gives
/// the same sums bit for bit.
pub fn render_counted_into(
    sampling: &PixelSampling,
    counts: &PixelCounts,
    items: std::ops::Range<u64>,
    per_pixel: &mut [Tally],
    count: usize,
    radiance: impl Fn(glam::DVec3, glam::DVec3, &mut Sampler, &mut [Stokes]) + Sync,
) {
    let (w, _) = sampling.camera.size();
    if items.is_empty() || counts.pixels() == 0 {
        return;
    }
    let samples = counts.samples_of(&items);
    per_pixel
        .par_chunks_mut(count)
        .zip(samples.par_iter())
        .enumerate()
        .with_min_len(16)
        .filter(|(_, (_, s))| !s.is_empty())
        .for_each(|(p, (tallies, s))| {
            render_pixel(
                sampling,
                (p % w, p / w),
                p,
                (s.clone(), counts.total(p)),
                tallies,
                &radiance,
            );
        });
}

/// Pixel-major tallies (`count` per pixel) as `[value][pixel]`, and the
/// count of non-finite samples (those of the first value: every value of a
/// sample shares its path).
pub fn split_values(per_pixel: &[Tally], count: usize) -> (Vec<Vec<Tally>>, u64) {
    let non_finite = per_pixel.iter().step_by(count.max(1)).map(|t| t.non_finite).sum();
    let tallies = (0..count)
        .map(|v| per_pixel.iter().skip(v).step_by(count).copied().collect())
        .collect();
    (tallies, non_finite)
}

/// Every channel and albedo of `scene` seen from `altitude_km`: tallies
/// `[channel·albedos + albedo][pixel]` and the count of non-finite samples.
pub fn render_layers(
    scene: &Scene,
    sampling: &PixelSampling,
    altitude_km: f64,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Vec<Tally>>, u64) {
    let ray = sampling.view_ray();
    render_pixels(sampling, scene.value_count(), progress, |v, e1, s, out| {
        scene.radiance_sample(altitude_km, v, e1, ray, s, out)
    })
}

/// [`render_layers`] for the scene's first channel and albedo.
pub fn render_layer(
    scene: &Scene,
    sampling: &PixelSampling,
    altitude_km: f64,
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Tally>, u64) {
    let (mut t, n) = render_layers(scene, sampling, altitude_km, progress);
    (t.swap_remove(0), n)
}

/// Strata per side for `samples` per pixel (at most 16 × 16).
fn strata(samples: u64) -> u64 {
    ((samples as f64).sqrt() as u64).clamp(1, 16)
}

/// Adds samples `range` (of the pixel's `total`, which set its strata) of
/// one pixel to its `tallies`; false for a pixel entirely outside the
/// image's circle (zero, no samples) or in a row or column that is not
/// traced.
fn render_pixel(
    sampling: &PixelSampling,
    (i, j): (usize, usize),
    index: usize,
    (range, samples): (std::ops::Range<u64>, u64),
    tallies: &mut [Tally],
    radiance: &impl Fn(glam::DVec3, glam::DVec3, &mut Sampler, &mut [Stokes]),
) -> bool {
    let weight = sampling.weights[index];
    if weight <= 0.0 || j >= sampling.traced_rows || i >= sampling.traced_columns {
        return false;
    }
    // The pixel's frame: its centre's, carried to each sample's direction.
    let Some(centre) = sampling.camera.centre_ray(i, j) else {
        return false;
    };
    let centre_e1 = sampling.frame.axis(centre.direction, centre.azimuth, sampling.sun);
    let m = strata(samples);
    let stratified = samples / (m * m) * (m * m);
    let mut values = vec![Stokes::zero(); tallies.len()];
    for s in range {
        let stream = if sampling.pilot {
            Estimate::Pilot(index)
        } else {
            Estimate::Pixel(index)
        };
        let mut sampler = StreamKey::new(sampling.seed, sampling.render, stream).sampler(s);
        let (x, y) = match sampling.filter {
            PixelFilter::Center => (i as f64 + 0.5, j as f64 + 0.5),
            PixelFilter::Box => {
                let [u, v] = sampler.next2();
                if s < stratified {
                    // Full rounds of m × m strata, then plain jitter.
                    let cell = s % (m * m);
                    (
                        i as f64 + ((cell % m) as f64 + u) / m as f64,
                        j as f64 + ((cell / m) as f64 + v) / m as f64,
                    )
                } else {
                    (i as f64 + u, j as f64 + v)
                }
            }
        };
        match sampling.camera.ray_at(x, y) {
            None => tallies.iter_mut().for_each(|t| t.add(&Stokes::zero())),
            Some(ray) => {
                let e1 = carry(centre_e1, centre.direction, ray.direction);
                radiance(ray.direction, e1, &mut sampler, &mut values);
                let scale = match sampling.filter {
                    PixelFilter::Center => 1.0,
                    PixelFilter::Box => ray.jacobian / weight,
                };
                for (t, v) in tallies.iter_mut().zip(&values) {
                    t.add(&(*v * scale));
                }
            }
        }
    }
    true
}

/// A rendered image task.
#[derive(Debug, Clone)]
pub struct SkyImage {
    pub width: usize,
    pub height: usize,
    pub layers: Vec<ImageLayer>,
    /// A noise target's samples per pixel: one map for all channels along
    /// shared paths (wavelength `None`), else one per channel.
    pub samples: Vec<(Option<f64>, Vec<u64>)>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_grow_with_samples() {
        assert_eq!(strata(1), 1);
        assert_eq!(strata(15), 3);
        assert_eq!(strata(100_000), 16);
    }

    #[test]
    fn items_give_every_pixel_its_samples_in_order() {
        // Any cut of the items into waves gives each pixel the samples
        // 0, 1, 2, … without gap or repeat.
        let pixels = 7u64;
        for cuts in [vec![0, 3, 10, 11, 21, 35], vec![0, 35], vec![0, 1, 2, 6, 7, 8, 34, 35]] {
            let mut next = vec![0u64; pixels as usize];
            for w in cuts.windows(2) {
                for p in 0..pixels {
                    let range = samples_below(p, pixels, w[0])..samples_below(p, pixels, w[1]);
                    assert_eq!(range.start, next[p as usize]);
                    next[p as usize] = range.end;
                }
            }
            assert!(next.iter().all(|&n| n == 5), "{next:?}");
        }
    }

    #[test]
    fn active_pixels_count_the_traced_items_of_a_range() {
        use crate::sensor::camera::{Hemisphere, Projection};
        let cam = Camera::Fisheye {
            resolution: 9,
            hemisphere: Hemisphere::Up,
            projection: Projection::Equidistant,
        };
        let weights = pixel_weights(&cam);
        // Every column, and the five a mirror traces.
        for columns in [9, 5] {
            let active = ActivePixels::new(&cam, 9, columns);
            let is_active: Vec<bool> = weights
                .iter()
                .enumerate()
                .map(|(k, w)| *w > 0.0 && k % 9 < columns)
                .collect();
            assert_eq!(active.count(), is_active.iter().filter(|a| **a).count() as u64);
            let p = active.pixels();
            for (a, b) in [(0, 1), (0, p), (5, 40), (40, 5 * p + 3), (p - 1, 3 * p + 1)] {
                let brute = (a..b).filter(|n| is_active[(n % p) as usize]).count() as u64;
                assert_eq!(active.paths(&(a..b)), brute, "{a}..{b}");
            }
        }
    }

    #[test]
    fn weights_stop_when_asked() {
        let cam = Camera::Sphere { width: 64, height: 32 };
        let stop = AtomicBool::new(true);
        assert!(pixel_weights_until(&cam, &stop).is_none());
        stop.store(false, Ordering::SeqCst);
        assert_eq!(pixel_weights_until(&cam, &stop).unwrap(), pixel_weights(&cam));
    }
}
