//! The estimates of a task, in a fixed order (per viewing direction, per
//! flux hemisphere, or every pixel of an image; for all channels along
//! shared paths or one channel alone), their stream keys and sample ranges
//! per shard, and the state of a unit's sums ([`UnitState`]).
//!
//! With a noise target every estimate comes twice: first its pilot
//! ([`Stage::Pilot`], the same in every shard), then the estimate itself
//! ([`Stage::Targeted`]), whose samples per direction or pixel the pilot's
//! sums decide ([`crate::run::allocation`]) once the pilot is done.

use crate::film::ground_view::{self, GROUND_VIEW_SAMPLES};
use crate::film::image::ActivePixels;
use crate::film::pixel_counts::PixelCounts;
use crate::film::tally::{self, BLOCK, Tally};
use crate::job::{Job, NoiseTarget, Sensor, TargetScope, Task};
use crate::run::allocation::{self, Allocation};
use crate::run::shard::Shard;
use crate::sampling::stream::{self, Channels, Render, StreamKey};
use crate::sensor::symmetry::Symmetry;

/// What an estimate measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EstimateKind {
    /// The radiance of viewing direction `direction` (index).
    Direction { channels: Channels, direction: usize },
    /// The downward (`up` false) or upward irradiance: at one
    /// wavelength, or at every channel along shared paths (bands, whose
    /// wavelengths vary per path).
    Flux { channels: Channels, up: bool },
    /// Every pixel of the image.
    Pixels { channels: Channels },
    /// The ground seen by an observer standing on it, which every pixel of
    /// the image's rows below the horizon ([`Layout::traced_rows`] and
    /// below) shares ([`crate::film::ground_view`]).
    GroundView { channels: Channels },
}

impl EstimateKind {
    /// The wavelengths the estimate's paths carry.
    pub fn channels(&self) -> Channels {
        match *self {
            EstimateKind::Direction { channels, .. }
            | EstimateKind::Flux { channels, .. }
            | EstimateKind::Pixels { channels }
            | EstimateKind::GroundView { channels } => channels,
        }
    }
}

/// Where an estimate's sample count comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// The job's `samples` per direction or pixel.
    Fixed,
    /// A noise target's pilot: `pilot_samples` per direction or pixel,
    /// traced whole by every shard; it sets the allocation and is not part
    /// of the results.
    Pilot,
    /// The samples the pilot at estimate index `pilot` allocates.
    Targeted { pilot: usize },
}

/// One estimate of a task: its kind, its stream key, the number of values
/// each sample gives and where its sample count comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub kind: EstimateKind,
    pub key: StreamKey,
    pub values: usize,
    pub stage: Stage,
}

/// The estimates of a task, in a fixed order.
#[derive(Debug, Clone)]
pub struct Layout {
    pub estimates: Vec<Estimate>,
    /// Samples per direction or pixel of the whole task.
    pub samples: u64,
    /// Pixels of an image sensor (0 for directions).
    pub pixels: usize,
    /// The pixels that are traced (image sensors): how many paths a range
    /// of items holds (see [`ActivePixels`]).
    pub active: Option<ActivePixels>,
    /// The image rows that are traced, from the top (all of them, unless the
    /// observer stands on the ground: then the rows below the horizon share
    /// the ground view, [`EstimateKind::GroundView`]).
    pub traced_rows: usize,
    /// The image columns that are traced, from the left (all of them, the
    /// half whose mirror images are the rest, or the first, whose rotations
    /// are the rest: [`crate::sensor::symmetry`]).
    pub traced_columns: usize,
    /// The sky's symmetry an image uses (`Symmetry::None` for directions).
    pub symmetry: Symmetry,
    /// True when the wavelengths share their paths.
    pub shared: bool,
    /// The spectral groups of shared paths (channel indices; one group of
    /// all the channels when they are not split; empty without shared
    /// paths).
    pub groups: Vec<Vec<usize>>,
    /// Paths of the first wave (a wave: blocks of one direction, or the
    /// same number of samples for every pixel); checkpoints and stop
    /// requests are honoured between waves.
    pub wave_paths: u64,
    /// Resize waves to last about [`WAVE_SECONDS`](crate::run::work_unit::WAVE_SECONDS) from the measured rate
    /// (the partition into waves never changes the sums).
    pub adaptive_waves: bool,
    /// The noise target, if samples are allocated.
    pub target: Option<NoiseTarget>,
    /// Per estimate: the samples a noise target allocated (targeted
    /// estimates whose pilot is done), else `None`.
    pub allocation: Vec<Option<Allocation>>,
    /// Image width (pixels a row; 0 for directions): the allocation's
    /// neighbourhoods.
    width: usize,
    /// Per albedo, whether the noise target counts it.
    counted_albedos: Vec<bool>,
    /// Per pixel of an image held to a target as a whole: its solid angle
    /// and that of the pixels that copy it (0 where untraced); empty
    /// otherwise.
    pixel_weights: Vec<f64>,
    /// The solid angle of the rows that show the ground view (an observer
    /// on the ground), for such an image.
    ground_solid_angle: f64,
}

impl Layout {
    /// The estimates of `task`; `spectral` tells whether the job's
    /// wavelengths share paths for this task (`job.spectral_scene(task)`).
    pub fn new(job: &Job, task: &Task, shared: bool) -> Layout {
        let spec = &job.render;
        let (nw, na) = (job.wavelengths_nm.len(), spec.albedos.len());
        let seed = spec.seed;
        let mut estimates = Vec::new();
        let (mut pixels, mut active, mut traced_rows, mut traced_columns) = (0, None, 0, 0);
        let mut symmetry = Symmetry::None;
        // The channel sets with paths of their own: every channel alone,
        // all of them along shared paths, or each spectral group.
        let groups = if shared { job.spectral_groups(task) } else { Vec::new() };
        let shared_sets: Vec<Channels> = match groups.len() {
            0 => Vec::new(),
            1 => vec![Channels::Shared],
            g => (0..g).map(Channels::Group).collect(),
        };
        let values_of = |channels: Channels| match channels {
            Channels::Shared => nw * na,
            Channels::One(_) => na,
            Channels::Group(g) => groups[g].len() * na,
        };
        let render_of = |channels: Channels| Render::Task {
            task: task.index,
            channels,
        };
        match &spec.sensor {
            Sensor::Directions(directions) => {
                for &channels in &shared_sets {
                    for d in 0..directions.len() {
                        estimates.push(Estimate {
                            kind: EstimateKind::Direction { channels, direction: d },
                            key: StreamKey::new(seed, render_of(channels), stream::Estimate::Direction(d)),
                            values: values_of(channels),
                            stage: Stage::Fixed,
                        });
                    }
                }
                let shared_fluxes = shared && job.banded();
                if spec.fluxes && shared_fluxes {
                    for &channels in &shared_sets {
                        for up in [false, true] {
                            estimates.push(Estimate {
                                kind: EstimateKind::Flux { channels, up },
                                key: StreamKey::new(seed, render_of(channels), stream::Estimate::flux(up)),
                                values: values_of(channels),
                                stage: Stage::Fixed,
                            });
                        }
                    }
                }
                for w in 0..nw {
                    if !shared {
                        for d in 0..directions.len() {
                            estimates.push(Estimate {
                                kind: EstimateKind::Direction {
                                    channels: Channels::One(w),
                                    direction: d,
                                },
                                key: StreamKey::new(
                                    seed,
                                    Render::channel(task.index, w),
                                    stream::Estimate::Direction(d),
                                ),
                                values: na,
                                stage: Stage::Fixed,
                            });
                        }
                    }
                    if spec.fluxes && !shared_fluxes {
                        for up in [false, true] {
                            estimates.push(Estimate {
                                kind: EstimateKind::Flux {
                                    channels: Channels::One(w),
                                    up,
                                },
                                key: StreamKey::new(seed, Render::channel(task.index, w), stream::Estimate::flux(up)),
                                values: na,
                                stage: Stage::Fixed,
                            });
                        }
                    }
                }
            }
            Sensor::Image(camera) => {
                traced_rows = ground_view::traced_rows(camera, task);
                symmetry = spec.symmetry.resolve(camera, task.sun.zenith_deg);
                traced_columns = symmetry.traced_columns(camera.size().0);
                let traced = ActivePixels::new(camera, traced_rows, traced_columns);
                pixels = traced.pixels() as usize;
                active = Some(traced);
                let channel_sets: Vec<Channels> = match shared {
                    true => shared_sets,
                    false => (0..nw).map(Channels::One).collect(),
                };
                for channels in channel_sets {
                    let render = render_of(channels);
                    let values = values_of(channels);
                    // Each pixel draws from its own stream (`Estimate::Pixel`
                    // with its index, in `film::image`); the key holds the
                    // render they share.
                    estimates.push(Estimate {
                        kind: EstimateKind::Pixels { channels },
                        key: StreamKey::new(seed, render, stream::Estimate::Pixel(0)),
                        values,
                        stage: Stage::Fixed,
                    });
                    if traced_rows < camera.size().1 {
                        estimates.push(Estimate {
                            kind: EstimateKind::GroundView { channels },
                            key: StreamKey::new(seed, render, stream::Estimate::GroundView),
                            values,
                            stage: Stage::Fixed,
                        });
                    }
                }
            }
        }
        if spec.target.is_some() {
            // Every estimate's pilot first, then the estimates themselves.
            let pilots: Vec<Estimate> = estimates
                .iter()
                .map(|e| Estimate {
                    key: e.key.with(e.key.estimate.pilot()),
                    stage: Stage::Pilot,
                    ..*e
                })
                .collect();
            let n = pilots.len();
            estimates = pilots
                .into_iter()
                .chain(estimates.into_iter().enumerate().map(|(k, e)| Estimate {
                    stage: Stage::Targeted { pilot: k },
                    ..e
                }))
                .collect();
            debug_assert_eq!(estimates.len(), 2 * n);
        }
        let width = match &spec.sensor {
            Sensor::Image(camera) => camera.size().0,
            Sensor::Directions(_) => 0,
        };
        let (pixel_weights, ground_solid_angle) = match (&spec.sensor, spec.target) {
            (Sensor::Image(camera), Some(t)) if t.per == TargetScope::Image => {
                let (w, h) = camera.size();
                let mut weights = vec![0.0; w * h];
                for j in 0..traced_rows.min(h) {
                    for i in camera.active_columns(j) {
                        weights[j * w + symmetry.traced_column(w, i)] += camera.pixel_solid_angle(i, j);
                    }
                }
                let ground: f64 = (traced_rows..h)
                    .flat_map(|j| camera.active_columns(j).map(move |i| (i, j)))
                    .map(|(i, j)| camera.pixel_solid_angle(i, j))
                    .sum();
                (weights, ground)
            }
            _ => (Vec::new(), 0.0),
        };
        Layout {
            allocation: vec![None; estimates.len()],
            estimates,
            samples: spec.samples,
            pixels,
            active,
            traced_rows,
            traced_columns,
            symmetry,
            shared,
            groups,
            wave_paths: 1 << 15,
            adaptive_waves: true,
            target: spec.target,
            width,
            pixel_weights,
            ground_solid_angle,
            counted_albedos: spec
                .albedos
                .iter()
                .map(|&a| spec.target.is_none_or(|t| t.albedos.counts(a)))
                .collect(),
        }
    }

    /// Allocates the samples of every targeted estimate whose pilot `state`
    /// has finished (and that has none yet); a no-op without a noise
    /// target, or for a state of another shape.
    pub fn allocate(&mut self, state: &UnitState) {
        let Some(target) = self.target else { return };
        if state.tallies.len() != self.estimates.len() || state.done.len() != self.estimates.len() {
            return;
        }
        for e in 0..self.estimates.len() {
            let Stage::Targeted { pilot } = self.estimates[e].stage else {
                continue;
            };
            if self.allocation[e].is_some() || state.done[pilot] != self.len(pilot, state.shard) {
                continue;
            }
            let tallies = &state.tallies[pilot];
            if tallies.len() != self.tallies(pilot) {
                continue;
            }
            if target.per == TargetScope::Image {
                self.allocate_image(e, pilot, state, &target);
                continue;
            }
            self.allocation[e] = Some(match self.estimates[e].kind {
                EstimateKind::Pixels { .. } => Allocation::Pixels(allocation::pixels(
                    tallies,
                    self.estimates[e].values,
                    self.width,
                    self.symmetry,
                    &target,
                    &self.counted_albedos,
                )),
                EstimateKind::GroundView { .. } => Allocation::Single(allocation::single(
                    tallies,
                    &allocation::ground_view(&target),
                    &self.counted_albedos,
                )),
                _ => Allocation::Single(allocation::single(tallies, &target, &self.counted_albedos)),
            });
        }
    }

    /// An image held to a target as a whole: the pixels of targeted
    /// estimate `e` (pilot `pilot`) and the ground view of the same
    /// channels, allocated together once both pilots are done (a ground
    /// view waits for its pixels).
    fn allocate_image(&mut self, e: usize, pilot: usize, state: &UnitState, target: &NoiseTarget) {
        let EstimateKind::Pixels { channels } = self.estimates[e].kind else {
            return;
        };
        let ground = (0..self.estimates.len()).find(|&g| {
            self.estimates[g].kind == EstimateKind::GroundView { channels }
                && matches!(self.estimates[g].stage, Stage::Targeted { .. })
        });
        let ground_pilot = ground.and_then(|g| match self.estimates[g].stage {
            Stage::Targeted { pilot } => Some(pilot),
            _ => None,
        });
        if let Some(gp) = ground_pilot
            && (state.done[gp] != self.len(gp, state.shard) || state.tallies[gp].len() != self.tallies(gp))
        {
            return;
        }
        let image = allocation::ImagePilot {
            tallies: &state.tallies[pilot],
            values: self.estimates[e].values,
            width: self.width,
            symmetry: self.symmetry,
            weights: &self.pixel_weights,
            ground: ground_pilot.map(|gp| (state.tallies[gp].as_slice(), self.ground_solid_angle)),
        };
        let (pixels, view) = allocation::image_pixels(&image, target, &self.counted_albedos);
        self.allocation[e] = Some(Allocation::Pixels(pixels));
        if let Some(g) = ground {
            self.allocation[g] = Some(Allocation::Single(view));
        }
    }

    /// Samples per direction or flux of estimate `e` in the whole task (0
    /// for a targeted estimate not yet allocated; images: see
    /// [`Layout::pixel_counts`]).
    pub fn samples_of(&self, e: usize) -> u64 {
        match (self.estimates[e].stage, &self.allocation[e]) {
            (Stage::Fixed, _) if matches!(self.estimates[e].kind, EstimateKind::GroundView { .. }) => {
                self.samples.saturating_mul(GROUND_VIEW_SAMPLES)
            }
            (Stage::Fixed, _) => self.samples,
            (Stage::Pilot, _) => self.target.map_or(0, |t| t.pilot),
            (Stage::Targeted { .. }, Some(Allocation::Single(n))) => *n,
            (Stage::Targeted { .. }, _) => 0,
        }
    }

    /// The samples of every pixel of targeted image estimate `e` in
    /// `shard`, once allocated.
    pub fn pixel_counts(&self, e: usize, shard: Shard) -> Option<PixelCounts> {
        let Some(Allocation::Pixels(n)) = &self.allocation[e] else {
            return None;
        };
        let ranges: Vec<std::ops::Range<u64>> = n.iter().map(|&n| shard.range(n)).collect();
        Some(PixelCounts::new(&ranges, n))
    }

    /// The work of estimate `e` in `shard`: sample blocks of a direction or
    /// flux; the items of an image (its samples per pixel × its pixels, see
    /// [`ActivePixels`], or for a targeted image the sum of its pixels'
    /// samples, see [`PixelCounts`]). A pilot is the same whole range in
    /// every shard; a targeted estimate not yet allocated has none.
    pub fn range(&self, e: usize, shard: Shard) -> std::ops::Range<u64> {
        let est = &self.estimates[e];
        let shard = if est.stage == Stage::Pilot { Shard::WHOLE } else { shard };
        match (est.kind, &self.allocation[e]) {
            (EstimateKind::Pixels { .. }, Some(Allocation::Pixels(n))) => {
                0..n.iter()
                    .map(|&n| shard.range(n).end - shard.range(n).start)
                    .sum::<u64>()
            }
            (EstimateKind::Pixels { .. }, _) => {
                let samples = shard.range(self.samples_of(e));
                let p = self.pixels as u64;
                samples.start * p..samples.end * p
            }
            _ => shard.range(self.samples_of(e).div_ceil(BLOCK)),
        }
    }

    /// The length of [`Layout::range`].
    fn len(&self, e: usize, shard: Shard) -> u64 {
        let r = self.range(e, shard);
        r.end - r.start
    }

    /// The estimates that make the results (all but a noise target's
    /// pilots), with their sums in `state`.
    pub fn results<'a>(&'a self, state: &'a UnitState) -> impl Iterator<Item = (&'a Estimate, &'a Vec<Tally>)> {
        self.estimates
            .iter()
            .zip(&state.tallies)
            .filter(|(est, _)| est.stage != Stage::Pilot)
    }

    /// True when two states hold the same pilots bit for bit (always true
    /// without a noise target).
    pub fn same_pilot(&self, a: &UnitState, b: &UnitState) -> bool {
        self.estimates
            .iter()
            .enumerate()
            .filter(|(_, est)| est.stage == Stage::Pilot)
            .all(|(e, _)| a.tallies.get(e) == b.tallies.get(e) && a.done.get(e) == b.done.get(e))
    }

    /// True when every targeted estimate has its allocation (always true
    /// without a noise target).
    pub fn is_allocated(&self) -> bool {
        self.estimates
            .iter()
            .zip(&self.allocation)
            .all(|(e, a)| !matches!(e.stage, Stage::Targeted { .. }) || a.is_some())
    }

    /// Tallies an estimate keeps: one per value (per pixel for images).
    pub fn tallies(&self, e: usize) -> usize {
        let est = &self.estimates[e];
        match est.kind {
            EstimateKind::Pixels { .. } => est.values * self.pixels,
            _ => est.values,
        }
    }

    /// The job's channel indices an estimate of `channels` holds, in the
    /// order of its values (shared paths have one group, of every channel).
    pub fn channel_indices(&self, channels: Channels) -> Vec<usize> {
        match channels {
            Channels::One(w) => vec![w],
            Channels::Shared => self.groups[0].clone(),
            Channels::Group(g) => self.groups[g].clone(),
        }
    }

    /// Paths a shard traces along shared spectral paths (every channel at
    /// once) and at single wavelengths, in that order: the two cost
    /// differently per path (`plan`).
    pub fn paths_by_channels(&self, shard: Shard) -> (u64, u64) {
        let mut paths = (0, 0);
        for (e, estimate) in self.estimates.iter().enumerate() {
            let n = self.paths_of(e, &self.range(e, shard));
            match estimate.kind.channels() {
                Channels::Shared | Channels::Group(_) => paths.0 += n,
                Channels::One(_) => paths.1 += n,
            }
        }
        paths
    }

    /// Paths a shard traces in a noise target's pilots and in the rest.
    pub fn paths_by_stage(&self, shard: Shard) -> (u64, u64) {
        let mut paths = (0, 0);
        for e in 0..self.estimates.len() {
            let n = self.paths_of(e, &self.range(e, shard));
            match self.estimates[e].stage {
                Stage::Pilot => paths.0 += n,
                _ => paths.1 += n,
            }
        }
        paths
    }

    /// Paths a shard traces in all.
    pub fn paths(&self, shard: Shard) -> u64 {
        (0..self.estimates.len())
            .map(|e| self.paths_of(e, &self.range(e, shard)))
            .sum()
    }

    /// Paths `state` has traced so far.
    pub fn done_paths(&self, state: &UnitState) -> u64 {
        (0..self.estimates.len())
            .map(|e| {
                let start = self.range(e, state.shard).start;
                self.paths_of(e, &(start..start + state.done[e]))
            })
            .sum()
    }

    /// Paths of `work` (a part of [`Layout::range`]) of estimate `e`.
    pub(crate) fn paths_of(&self, e: usize, work: &std::ops::Range<u64>) -> u64 {
        match (self.estimates[e].kind, &self.allocation[e]) {
            // Every item of a targeted image is a traced path.
            (EstimateKind::Pixels { .. }, Some(_)) => work.end - work.start,
            (EstimateKind::Pixels { .. }, None) => self.active.as_ref().map_or(0, |a| a.paths(work)),
            _ => tally::block_samples(work, self.samples_of(e)),
        }
    }

    /// An empty state for `shard` of `task`.
    pub fn empty_state(&self, job: &Job, task: &Task, shard: Shard) -> UnitState {
        UnitState {
            job_hash: job.hash.clone(),
            task: task.index,
            shard,
            done: vec![0; self.estimates.len()],
            tallies: (0..self.estimates.len())
                .map(|e| vec![Tally::default(); self.tallies(e)])
                .collect(),
        }
    }

    /// True when `state` has the shape of this layout (allocate first:
    /// a targeted estimate not yet allocated has no work done).
    pub fn fits(&self, state: &UnitState) -> bool {
        state.done.len() == self.estimates.len()
            && state.tallies.len() == self.estimates.len()
            && state
                .tallies
                .iter()
                .enumerate()
                .all(|(e, t)| t.len() == self.tallies(e))
            && state
                .done
                .iter()
                .enumerate()
                .all(|(e, &d)| d <= self.range(e, state.shard).end - self.range(e, state.shard).start)
    }
}

/// The sums of a unit so far.
#[derive(Debug, Clone, PartialEq)]
pub struct UnitState {
    pub job_hash: String,
    pub task: usize,
    pub shard: Shard,
    /// Per estimate: blocks (directions, fluxes) or items (images: samples
    /// × pixels, see [`ActivePixels`]) done, counted from the start of the
    /// shard's range.
    pub done: Vec<u64>,
    /// Per estimate: the running sums, one per value (pixel-major for
    /// images: the values of pixel 0, then of pixel 1, …).
    pub tallies: Vec<Vec<Tally>>,
}

impl UnitState {
    /// True when every estimate has done its whole range (and a noise
    /// target's estimates have their allocation).
    pub fn is_complete(&self, layout: &Layout) -> bool {
        layout.is_allocated()
            && self
                .done
                .iter()
                .enumerate()
                .all(|(e, &d)| d == layout.range(e, self.shard).end - layout.range(e, self.shard).start)
    }

    /// Samples of the results that gave a non-finite value (counted once
    /// per path; a noise target's pilot is not part of the results).
    pub fn non_finite(&self, layout: &Layout) -> u64 {
        self.tallies
            .iter()
            .zip(&layout.estimates)
            .filter(|(_, est)| est.stage != Stage::Pilot)
            .map(|(t, est)| t.iter().step_by(est.values.max(1)).map(|x| x.non_finite).sum::<u64>())
            .sum()
    }

    /// A warning when some paths gave a non-finite value: they are left
    /// out of the sums, so the estimate is biased by them (a defect of the
    /// tracer, never expected).
    pub fn non_finite_warning(&self, layout: &Layout, task: &str) -> Option<String> {
        let n = self.non_finite(layout);
        (n > 0).then(|| {
            format!(
                "warning: {task}: {n} paths gave a non-finite value and are left out of the sums; \
                 the estimate is biased by them (please report the job file)"
            )
        })
    }

    /// Adds another shard's sums (same task and layout) to these; a pilot,
    /// which every shard traces whole, is kept once.
    pub fn add(&mut self, other: &UnitState, layout: &Layout) {
        for ((a, b), est) in self.tallies.iter_mut().zip(&other.tallies).zip(&layout.estimates) {
            if est.stage == Stage::Pilot {
                continue;
            }
            for (x, y) in a.iter_mut().zip(b) {
                x.merge(y);
            }
        }
    }
}
