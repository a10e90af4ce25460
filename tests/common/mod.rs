//! Helpers shared by the validation tests: reading the project's reference
//! tables, building jobs, and the z statistics of the issue (z = difference
//! over the combined standard error, Šidák threshold for a 1 % family-wise
//! false-alarm rate), reading back the CSV outputs of a render, and
//! running the binary as a user does.
#![allow(dead_code)]

pub mod markdown;
pub mod synthetic_sky;

use std::path::Path;

use atmosim::compat::significance::sidak_threshold;
use atmosim::film::directions::render_directions;
use atmosim::film::tally::Tally;
use atmosim::job::Job;
use atmosim::physics::data::Table;
use atmosim::sampling::stream::Render;
use atmosim::sensor::direction::Direction;

/// Reads a table of the repository (validation/…).
pub fn table(rel: &str) -> Table {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Table::parse(rel, &text, 0).unwrap()
}

/// Parses a job from TOML text.
pub fn job(text: &str) -> Job {
    Job::parse(text, "test.toml", Path::new(".")).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// Samples per direction for CI, overridable with ATMOSIM_VALIDATION_SAMPLES.
pub fn samples(default: u64) -> u64 {
    std::env::var("ATMOSIM_VALIDATION_SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// Viewing directions from (view zenith, azimuth) pairs in degrees.
#[allow(dead_code)]
pub fn directions(pairs: &[(f64, f64)]) -> Vec<Direction> {
    pairs
        .iter()
        .map(|&(z, a)| Direction {
            view_zenith_deg: z,
            azimuth_deg: a,
        })
        .collect()
}

/// Renders `directions` of wavelength index 0 of `job` at `altitude_km`.
pub fn render(job: &Job, altitude_km: f64, directions: &[Direction], samples: u64) -> Vec<Tally> {
    render_directions(
        &job.scene(0),
        altitude_km,
        directions,
        samples,
        job.render.seed,
        Render::channel(0, 0),
    )
}

/// A family of comparisons with a reference.
#[derive(Default)]
pub struct Comparison {
    pub z: Vec<f64>,
    pub worst: String,
    pub max_abs_z: f64,
}

impl Comparison {
    /// Adds one value: atmosim's mean and standard error, the reference and
    /// its standard error (0 for exact references: a floor of `ref_floor`).
    pub fn add(&mut self, what: impl FnOnce() -> String, mean: f64, se: f64, reference: f64, ref_se: f64) {
        let combined = (se * se + ref_se * ref_se).sqrt();
        let z = if combined > 0.0 {
            (mean - reference) / combined
        } else if mean == reference {
            0.0
        } else {
            f64::INFINITY
        };
        if z.abs() > self.max_abs_z || !z.is_finite() {
            self.max_abs_z = z.abs();
            self.worst = format!(
                "{}: atmosim {mean:e} ± {se:e}, reference {reference:e} ± {ref_se:e}",
                what()
            );
        }
        self.z.push(z);
    }

    /// Adds I, Q and U of every direction: renders `a` against renders `b`
    /// of the same directions (independent streams), named by `label`.
    pub fn add_tallies(&mut self, label: &str, a: &[Tally], b: &[Tally]) {
        assert_eq!(a.len(), b.len(), "{label}: direction counts differ");
        for (d, (x, y)) in a.iter().zip(b).enumerate() {
            for s in 0..3 {
                self.add(
                    || format!("{label} direction {d} Stokes {s}"),
                    x.mean()[s],
                    x.standard_error()[s],
                    y.mean()[s],
                    y.standard_error()[s],
                );
            }
        }
    }

    /// Fraction of |z| below 1 (≈ 0.68 for honest errors).
    pub fn within_one_sigma(&self) -> f64 {
        self.z.iter().filter(|z| z.abs() < 1.0).count() as f64 / self.z.len() as f64
    }

    /// Asserts that no |z| exceeds the Šidák threshold; returns a summary.
    pub fn assert_no_outlier(&self, name: &str) -> String {
        let threshold = sidak_threshold(self.z.len(), 0.01);
        let summary = format!(
            "{name}: {} values, max |z| = {:.2} (threshold {threshold:.2}), {:.1} % within 1σ; worst: {}",
            self.z.len(),
            self.max_abs_z,
            100.0 * self.within_one_sigma(),
            self.worst
        );
        eprintln!("{summary}");
        assert!(self.max_abs_z <= threshold, "outlier in {summary}");
        summary
    }
}

/// TOML of a plane-parallel atmosphere of explicit layers.
pub fn layers_toml(layers: &[(f64, f64, f64, f64)], depol: f64) -> String {
    let mut s = String::from("[planet]\ngeometry = \"plane_parallel\"\n");
    for &(bottom, top, tau_r, tau_abs) in layers {
        s.push_str(&format!(
            "[[atmosphere.layers]]\nbottom_km = {bottom:?}\ntop_km = {top:?}\ntau_rayleigh = {tau_r:?}\n\
             rayleigh_depolarization = {depol:?}\ntau_absorption = {tau_abs:?}\n"
        ));
    }
    s
}

/// Every file under `dir` (recursively), sorted.
pub fn files_under(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    let mut dirs = vec![dir.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

/// All numbers of the CSV files of every task under `out`, by file.
pub fn csv_values(out: &Path) -> Vec<(String, Vec<f64>)> {
    files_under(out)
        .iter()
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .map(|p| {
            let text = std::fs::read_to_string(p).unwrap();
            let values = text
                .lines()
                .skip(1)
                .flat_map(|l| l.split(',').map(|x| x.parse::<f64>().unwrap()).collect::<Vec<_>>())
                .collect();
            (p.strip_prefix(out).unwrap().display().to_string(), values)
        })
        .collect()
}

/// The atmosim binary, run as a user runs it.
pub fn atmosim() -> assert_cmd::Command {
    assert_cmd::Command::cargo_bin("atmosim").unwrap()
}

/// Runs `atmosim ARGS` in `dir`; panics with its stderr unless it
/// succeeds. Returns its output.
pub fn run_ok(dir: &Path, args: &[&str]) -> std::process::Output {
    let out = atmosim().current_dir(dir).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Writes `job` as `job.toml` in a fresh directory and runs `atmosim ARGS`
/// there; panics unless it succeeds. Returns the directory.
pub fn run_job(job: &str, args: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    let out = atmosim().current_dir(dir.path()).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    dir
}

/// Sends SIGTERM to a running child process.
pub fn sigterm(child: &std::process::Child) {
    let ok = std::process::Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

/// `atmosim COMMAND job.toml` of `job`, in a fresh directory, exits with
/// code 2, its message names every one of `words`, and nothing is written.
pub fn assert_refused(command: &str, job: &str, words: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    let out = atmosim()
        .current_dir(dir.path())
        .args([command, "job.toml"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{job}: {err}");
    assert!(words.iter().all(|w| err.contains(w)), "{words:?} not named: {err}");
    assert!(!dir.path().join("out").exists(), "{job}: files written");
}

/// Renders of one job with several seeds: per seed the tallies of each
/// direction, the seconds they took and the paths they traced.
pub struct SeedRuns {
    pub tallies: Vec<Vec<Tally>>,
    pub seconds: f64,
    pub paths: u64,
}

impl SeedRuns {
    /// Mean of the seeds' estimates of component `s` in direction `d`, and
    /// its reported standard error (from each render's own errors).
    pub fn mean_and_se(&self, d: usize, s: usize) -> (f64, f64) {
        let n = self.tallies.len() as f64;
        let mean = self.tallies.iter().map(|t| t[d].mean()[s]).sum::<f64>() / n;
        let var = self
            .tallies
            .iter()
            .map(|t| t[d].standard_error()[s].powi(2))
            .sum::<f64>()
            / (n * n);
        (mean, var.sqrt())
    }

    /// The spread of the seeds' estimates of component `s` in direction
    /// `d` (sample variance) over their mean reported variance.
    pub fn spread_over_reported(&self, d: usize, s: usize) -> f64 {
        let n = self.tallies.len() as f64;
        let mean = self.tallies.iter().map(|t| t[d].mean()[s]).sum::<f64>() / n;
        let spread = self
            .tallies
            .iter()
            .map(|t| (t[d].mean()[s] - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        let reported = self
            .tallies
            .iter()
            .map(|t| t[d].standard_error()[s].powi(2))
            .sum::<f64>()
            / n;
        spread / reported
    }

    /// The square root of the spread over the reported variance of
    /// component `s`, averaged over the directions where it has noise (Q
    /// of the depolarising ground seen from the ground has none): about 1
    /// where the reported standard errors are honest.
    pub fn pooled_spread(&self, s: usize) -> f64 {
        let ratios: Vec<f64> = self
            .noisy_directions(s)
            .map(|d| self.spread_over_reported(d, s))
            .collect();
        (ratios.iter().sum::<f64>() / ratios.len() as f64).sqrt()
    }

    /// The directions where component `s` has noise.
    fn noisy_directions(&self, s: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.tallies[0].len()).filter(move |&d| self.mean_and_se(d, s).1 > 0.0)
    }

    /// The interval that [`SeedRuns::pooled_spread`] of component `s`
    /// falls in where the reported errors are honest, at a family-wise
    /// false-alarm rate of 1 % over `family` such checks (Šidák). With n
    /// seeds of Gaussian estimates, a direction's sample variance over its
    /// variance is χ²(n − 1)/(n − 1), and the mean of D directions'
    /// χ²(ν)/ν with ν = D·(n − 1) (the directions trace paths of their
    /// own); its quantiles by Wilson–Hilferty, (1 − 2/(9ν) ± z·√(2/(9ν)))³,
    /// and the pooled spread is the square root. The reported variance is
    /// taken as exact: it is the mean of n renders' own estimates, each
    /// from thousands of paths.
    pub fn spread_window(&self, s: usize, family: usize) -> (f64, f64) {
        let seeds = self.tallies.len() as f64;
        spread_window(self.noisy_directions(s).count() as f64 * (seeds - 1.0), family)
    }

    /// Variance of I per path times seconds per path, direction `d`.
    pub fn cost(&self, d: usize) -> f64 {
        let (mean, se) = self.mean_and_se(d, 0);
        let per_path_var = (se / mean).powi(2) * self.paths as f64;
        per_path_var * self.seconds / self.paths as f64
    }
}

/// The square roots of the bounds of χ²(ν)/ν at a two-sided 1 % level
/// Šidák-corrected over `family` checks, by Wilson–Hilferty:
/// (1 − 2/(9ν) ± z·√(2/(9ν)))³ ([`SeedRuns::spread_window`]).
pub fn spread_window(nu: f64, family: usize) -> (f64, f64) {
    let z = sidak_threshold(family, 0.01);
    let a = 2.0 / (9.0 * nu);
    let bound = |sign: f64| (1.0 - a + sign * z * a.sqrt()).max(0.0).powi(3).sqrt();
    (bound(-1.0), bound(1.0))
}
