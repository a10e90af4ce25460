//! `atmosim bench --suite`: the figure-of-merit suite, a fixed set of
//! single-direction jobs that span the tracer's work (docs/performance.md,
//! "The figure-of-merit suite").
//!
//! Every case is a `directions` job, rendered on the current pool and
//! timed; per direction the report gives the figure of merit of I and of Q,
//!
//! FOM_I = 1 / ((se_I / I)² × core-seconds), FOM_Q = 1 / ((se_Q / I)² × core-seconds)
//!
//! (Q's error relative to I, as Q crosses zero), the worst channel's where
//! a case has several channels or albedos. Paths per second are a
//! secondary figure: a path is one sample of a direction, whatever it
//! splits into at its first vertex. The same job files, written by
//! `--write-jobs DIR`, pair two builds with `scripts/bench_pair.py`: they
//! use only keys that builds since 2026-11-20 read.

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

use crate::error::{Error, Result};
use crate::job::Job;
use crate::physics::profile::GasProfile;

use super::bench::io;

/// One case of the suite: a name (the job file's stem), what it stands
/// for, and its job text.
pub struct SuiteCase {
    pub name: &'static str,
    pub what: &'static str,
    pub job: String,
}

/// The 1000-level profile's file name, beside the job files.
pub const FINE_PROFILE_FILE: &str = "us_standard_1000_levels.dat";

/// The Henyey–Greenstein aerosol layers of the single-wavelength cases
/// (uvspec-style `aerosol_layers`, which every build reads alike).
const HG_ATMOSPHERE: &str = r#"[planet]
radius_km = 6378.0
top_km = 100.0
[atmosphere]
PROFILE
ozone = "bogumil"
[[atmosphere.aerosol_layers]]
bottom_km = 0.0
top_km = 2.0
tau = 0.2
ssa = 0.95
g = 0.7
[[atmosphere.aerosol_layers]]
bottom_km = 2.0
top_km = 8.0
tau = 0.05
ssa = 0.95
g = 0.65
"#;

/// What varies between the cases.
struct Spec {
    sun_zenith_deg: f64,
    wavelengths_nm: Vec<f64>,
    band_width_nm: f64,
    observer_km: f64,
    albedos: &'static str,
    directions: Vec<(f64, f64)>,
    samples: u64,
}

/// The cross of view zeniths and azimuths.
fn cross(zeniths: &[f64], azimuths: &[f64]) -> Vec<(f64, f64)> {
    zeniths
        .iter()
        .flat_map(|&z| azimuths.iter().map(move |&a| (z, a)))
        .collect()
}

fn job_text(atmosphere: &str, spec: &Spec) -> String {
    let list = |v: &[f64]| v.iter().map(|x| format!("{x:.1}")).collect::<Vec<_>>().join(", ");
    let directions = spec
        .directions
        .iter()
        .map(|(z, a)| format!("[{z:.1}, {a:.1}]"))
        .collect::<Vec<_>>()
        .join(", ");
    let mut text = atmosphere.to_string();
    let _ = writeln!(text, "[spectrum]\nwavelengths_nm = [{}]", list(&spec.wavelengths_nm));
    if spec.band_width_nm > 0.0 {
        let _ = writeln!(text, "band_width_nm = {:.1}", spec.band_width_nm);
    }
    let _ = write!(
        text,
        "[observer]\naltitude_km = {:.1}\n[sun]\nzenith_deg = {:.1}\n[ground]\nalbedo = {}\n\
         [sensor]\ndirections = [{directions}]\nfluxes = false\n[render]\nsamples = {}\npolarized = true\n",
        spec.observer_km, spec.sun_zenith_deg, spec.albedos, spec.samples
    );
    text
}

/// The suite's cases; `quick` takes a tenth of the paths.
pub fn cases(quick: bool) -> Vec<SuiteCase> {
    let scale = if quick { 10 } else { 1 };
    let hg = HG_ATMOSPHERE.replace("PROFILE", "profile = \"us_standard\"");
    let fine = HG_ATMOSPHERE.replace("PROFILE", &format!("profile_file = \"{FINE_PROFILE_FILE}\""));
    let mie = "[planet]\nradius_km = 6378.0\ntop_km = 100.0\n[atmosphere]\nprofile = \"us_standard\"\n\
               ozone = \"bogumil\"\naerosol = \"continental_average\"\n";
    let ground = cross(&[0.0, 30.0, 60.0, 80.0], &[0.0, 90.0, 180.0]);
    let with = |extra: &[(f64, f64)]| ground.iter().chain(extra).copied().collect::<Vec<_>>();
    let spec = |sun: f64, wavelength: f64, directions: Vec<(f64, f64)>, samples: u64| Spec {
        sun_zenith_deg: sun,
        wavelengths_nm: vec![wavelength],
        band_width_nm: 0.0,
        observer_km: 0.0,
        albedos: "0.2",
        directions,
        samples: samples / scale,
    };
    let day = spec(
        45.0,
        540.0,
        cross(&[0.0, 30.0, 60.0, 80.0], &[0.0, 60.0, 120.0, 180.0]),
        40_000,
    );
    let low_sun = spec(88.0, 540.0, with(&[(86.0, 0.0), (87.0, 0.0), (88.0, 5.0)]), 40_000);
    let twilight = spec(92.0, 540.0, with(&[(88.0, 0.0), (89.0, 0.0)]), 20_000);
    let from_15km = Spec {
        observer_km: 15.0,
        ..spec(
            85.0,
            420.0,
            cross(&[0.0, 60.0, 95.0, 120.0, 150.0, 180.0], &[0.0, 180.0]),
            20_000,
        )
    };
    let bands = Spec {
        wavelengths_nm: (0..11).map(|i| 340.0 + 40.0 * i as f64).collect(),
        band_width_nm: 40.0,
        albedos: "[0.0, 0.3, 0.6, 1.0]",
        ..spec(70.0, 0.0, ground.clone(), 10_000)
    };
    let fine_profile = spec(30.0, 550.0, ground.clone(), 20_000);
    let mie_case = spec(60.0, 540.0, with(&[(55.0, 0.0), (58.0, 3.0)]), 20_000);
    vec![
        SuiteCase {
            name: "day",
            what: "sun 45°, ground, 540 nm, HG aerosol layers, 16 directions",
            job: job_text(&hg, &day),
        },
        SuiteCase {
            name: "low_sun",
            what: "sun 2° up, ground, 540 nm, with the aureole (view zenith 80–88° toward the sun)",
            job: job_text(&hg, &low_sun),
        },
        SuiteCase {
            name: "twilight",
            what: "sun 2° below the horizon, ground, 540 nm",
            job: job_text(&hg, &twilight),
        },
        SuiteCase {
            name: "from_15km",
            what: "sun zenith 85°, 420 nm, from 15 km, half the directions down",
            job: job_text(&hg, &from_15km),
        },
        SuiteCase {
            name: "bands_albedos",
            what: "11 bands of 40 nm from 320 nm × 4 albedos along shared paths, sun 20° up (worst band)",
            job: job_text(&hg, &bands),
        },
        SuiteCase {
            name: "fine_profile",
            what: "the day's atmosphere on a 1000-level profile (every 0.1 km), sun zenith 30°, 550 nm",
            job: job_text(&fine, &fine_profile),
        },
        SuiteCase {
            name: "mie",
            what: "OPAC continental_average with Mie phase matrices, sun zenith 60°, near-sun directions (builds before Mie read it as HG)",
            job: job_text(mie, &mie_case),
        },
    ]
}

/// Writes the suite's job files (and the fine profile) into `dir`.
pub fn write_jobs(dir: &Path, quick: bool) -> Result<Vec<SuiteCase>> {
    let write = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| Error::io(&path, e))
    };
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let fine = GasProfile::builtin("us_standard")
        .ok_or_else(|| Error::data("us_standard", "the built-in profile is missing"))??
        .resampled(0.1, 100.0);
    write(FINE_PROFILE_FILE, &fine.to_afgl_text())?;
    let cases = cases(quick);
    for case in &cases {
        write(&format!("{}.toml", case.name), &case.job)?;
    }
    Ok(cases)
}

/// Per direction of a case: view zenith, azimuth, FOM of I and of Q (the
/// worst channel's), and I of the worst channel for I.
pub struct DirectionFom {
    pub view_zenith_deg: f64,
    pub azimuth_deg: f64,
    pub fom_i: f64,
    pub fom_q: f64,
}

/// A case's figures.
pub struct CaseFigures {
    pub core_seconds: f64,
    pub paths: u64,
    pub directions: Vec<DirectionFom>,
}

/// Renders the case in `dir` (written by [`write_jobs`]) on the current
/// pool, timed.
pub fn run_case(dir: &Path, case: &SuiteCase) -> Result<CaseFigures> {
    let file = format!("{}.toml", case.name);
    let job = Job::parse(&case.job, &file, dir)?;
    let task = &job.tasks[0];
    let threads = rayon::current_num_threads() as f64;
    let start = Instant::now();
    let result = crate::run::task::render_directions(&job, task, &|_| {})?;
    let core_seconds = start.elapsed().as_secs_f64() * threads;
    let directions = job.render.directions();
    let paths = job.render.samples * directions.len() as u64;
    let figures = directions
        .iter()
        .map(|d| {
            let rows = result.radiance.iter().filter(|r| r.direction == *d);
            let (mut fom_i, mut fom_q) = (f64::INFINITY, f64::INFINITY);
            for row in rows {
                let (m, se) = (row.tally.mean(), row.tally.standard_error());
                if m[0] > 0.0 {
                    fom_i = fom_i.min(1.0 / ((se[0] / m[0]).powi(2) * core_seconds));
                    fom_q = fom_q.min(1.0 / ((se[1] / m[0]).powi(2) * core_seconds));
                }
            }
            DirectionFom {
                view_zenith_deg: d.view_zenith_deg,
                azimuth_deg: d.azimuth_deg,
                fom_i,
                fom_q,
            }
        })
        .collect();
    Ok(CaseFigures {
        core_seconds,
        paths,
        directions: figures,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Runs every case whose name is in `only` (all if empty) from the job
/// files in `dir`, writing a table per case and a summary line per case;
/// the last line is `suite_cases: <count>`.
pub fn run(dir: &Path, quick: bool, only: &[String], out: &mut dyn Write) -> Result<Vec<(String, CaseFigures)>> {
    let cases = write_jobs(dir, quick)?;
    if let Some(unknown) = only.iter().find(|o| !cases.iter().any(|c| c.name == o.as_str())) {
        return Err(Error::InvalidValue {
            file: "<bench --suite>".into(),
            key: "--case".into(),
            value: unknown.clone(),
            reason: "no such case".into(),
            valid: cases.iter().map(|c| c.name).collect::<Vec<_>>().join(", "),
        });
    }
    let threads = rayon::current_num_threads();
    writeln!(
        out,
        "# figure-of-merit suite: FOM = 1 / (relative variance × core-seconds) per direction; Q's error relative to I; worst channel; {threads} thread(s)"
    )
    .map_err(io)?;
    let mut all = Vec::new();
    for case in cases
        .iter()
        .filter(|c| only.is_empty() || only.iter().any(|o| o == c.name))
    {
        let figures = run_case(dir, case)?;
        writeln!(out, "## {}: {}", case.name, case.what).map_err(io)?;
        writeln!(out, "view_zenith_deg,azimuth_deg,fom_i,fom_q").map_err(io)?;
        for d in &figures.directions {
            writeln!(
                out,
                "{},{},{:.4e},{:.4e}",
                d.view_zenith_deg, d.azimuth_deg, d.fom_i, d.fom_q
            )
            .map_err(io)?;
        }
        let fi: Vec<f64> = figures.directions.iter().map(|d| d.fom_i).collect();
        let fq: Vec<f64> = figures.directions.iter().map(|d| d.fom_q).collect();
        writeln!(
            out,
            "case {}: {:.2} core-s, {:.0} paths/s per core (a path is one sample, its split first vertex included), FOM_I median {:.4e} min {:.4e}, FOM_Q median {:.4e} min {:.4e}",
            case.name,
            figures.core_seconds,
            figures.paths as f64 / figures.core_seconds,
            median(fi.clone()),
            fi.iter().copied().fold(f64::INFINITY, f64::min),
            median(fq.clone()),
            fq.iter().copied().fold(f64::INFINITY, f64::min),
        )
        .map_err(io)?;
        all.push((case.name.to_string(), figures));
    }
    writeln!(out, "suite_cases: {}", all.len()).map_err(io)?;
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_case_parses_with_its_profile() {
        let dir = tempfile::tempdir().unwrap();
        for case in write_jobs(dir.path(), true).unwrap() {
            let job = Job::parse(&case.job, case.name, dir.path()).unwrap_or_else(|e| panic!("{}: {e}", case.name));
            assert_eq!(job.tasks.len(), 1, "{}", case.name);
        }
        let text = std::fs::read_to_string(dir.path().join(FINE_PROFILE_FILE)).unwrap();
        let fine = GasProfile::parse("fine", &text).unwrap();
        assert_eq!(fine.levels.len(), 1001);
    }
}
