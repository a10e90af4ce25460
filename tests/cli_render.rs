//! `atmosim render` run as a user runs it: the CSV outputs, --stdout, and
//! bad render keys (exit code 2, nothing written).

mod common;

use common::atmosim;

const SMALL: &str = "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [550.0]\n\
                     [sun]\nzenith_deg = 30.0\n[ground]\nalbedo = 0.3\n\
                     [sensor]\ndirections = [[0.0, 0.0], [60.0, 90.0]]\n[render]\nsamples = 2000\n";

#[test]
fn render_writes_radiance_and_flux_csv() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job.toml");
    std::fs::write(&job, SMALL).unwrap();
    let out = dir.path().join("out");
    let status = atmosim()
        .arg("render")
        .arg(&job)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let radiance = std::fs::read_to_string(out.join("radiance.csv")).unwrap();
    let mut lines = radiance.lines();
    assert_eq!(
        lines.next(),
        Some("wavelength_nm,albedo,view_zenith_deg,azimuth_deg,I,Q,U,V,I_se,Q_se,U_se,V_se,samples")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 2);
    for r in &rows {
        assert_eq!(r.len(), 13);
        assert!(r[4] > 0.0 && r[8] > 0.0 && r[12] == 2000.0);
    }
    let fluxes = std::fs::read_to_string(out.join("fluxes.csv")).unwrap();
    assert!(fluxes.starts_with("wavelength_nm,albedo,altitude_km,e_dir,e_down,e_up,e_down_se,e_up_se,samples\n"));
    let f: Vec<f64> = fluxes
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // E_dir = μ0·exp(−τ/μ0) is between 0 and μ0 = cos 30°.
    assert!(f[3] > 0.0 && f[3] < 30f64.to_radians().cos());
}

#[test]
fn stdout_prints_the_radiance_csv_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job.toml");
    std::fs::write(&job, SMALL).unwrap();
    let out = atmosim()
        .current_dir(dir.path())
        .args(["render", "job.toml", "--stdout", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(
        String::from_utf8(out.stdout)
            .unwrap()
            .starts_with("wavelength_nm,albedo,")
    );
    assert!(!dir.path().join("out").exists());
}

#[test]
fn bad_render_keys_are_refused_before_anything_is_written() {
    for (extra, key) in [
        ("[sun]\nelevation_deg = 95.0\n", "sun.elevation_deg"),
        ("[ground]\nalbedo = 1.5\n", "ground.albedo"),
        ("[sensor]\nview_zenith_deg = [190.0]\n", "sensor.view_zenith_deg"),
        ("[render]\nsamples = 0\n", "render.samples"),
        ("[render]\nmedium = \"lumpy\"\n", "lumpy"),
    ] {
        common::assert_refused(
            "render",
            &format!("[spectrum]\nwavelengths_nm = [550.0]\n{extra}"),
            &[key],
        );
    }
}

#[test]
fn bench_ratios_report_every_ratio_before_the_throughput_line() {
    let out = atmosim().args(["bench", "--quick", "--ratios"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    for line in [
        "four albedos (0, 0.3, 0.6, 1) from the same paths:",
        "eleven wavelengths (320 to 760 nm by 44) along shared paths:",
        "320.0 nm: shared relative standard error",
        "760.0 nm: shared relative standard error",
        "eleven bands of 40 nm from 320 nm along shared paths:",
        "320–360 nm band:",
        "720–760 nm band:",
        "analog first vertex:",
        "analog flights (forced_collisions = false, first_vertex_splitting = false):",
        "fine profile (US standard every 100 m, 1000 layers) through its own layers:",
        "merged layers:",
        "threads vs 1: throughput ratio",
    ] {
        assert!(text.contains(line), "no {line:?} in\n{text}");
    }
    assert!(text.lines().last().unwrap().starts_with("paths_per_second_per_core: "));
}

#[test]
fn bench_grid_quick_reports_its_tasks_and_ends_with_the_core_hours_line() {
    let out = atmosim().args(["bench", "--grid", "--quick"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    // Priced at the grid job's own resolution.
    let tasks: Vec<&str> = text.lines().filter(|l| l.contains("core-hours at 512x256")).collect();
    assert_eq!(tasks.len(), 3, "{text}");
    for t in &tasks {
        assert!(t.contains("image noise by band 340: ") && t.contains("740: "), "{t}");
    }
    assert!(
        text.starts_with(
            "grid benchmark: 3 tasks, 64x32 full-sphere images to the grid job's noise target, 0.02 per image"
        ),
        "{text}"
    );
    let last = text.lines().last().unwrap();
    let figures: Vec<f64> = last
        .strip_prefix("grid_core_hours_per_task: ")
        .unwrap()
        .split(' ')
        .map(|x| x.parse().unwrap())
        .collect();
    assert!(
        figures.len() == 2 && figures[0] > 0.0 && figures[1] >= figures[0],
        "{last}"
    );
    let out = atmosim().args(["bench", "--grid", "--ratios"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    // Fixed samples instead of the noise target: the same report, no pilot.
    let out = atmosim()
        .args(["bench", "--grid", "--quick", "--samples", "4"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.starts_with("grid benchmark: 3 tasks, 64x32 full-sphere images to 4 samples per pixel"),
        "{text}"
    );
    let tasks: Vec<&str> = text.lines().filter(|l| l.contains("(0 % pilot)")).collect();
    assert_eq!(tasks.len(), 3, "{text}");
    assert!(text.lines().last().unwrap().starts_with("grid_core_hours_per_task: "));
    // A subset by name: the tasks containing a pattern, the last line over
    // them; a pattern that matches none is refused before any work.
    let out = atmosim()
        .args([
            "bench",
            "--grid",
            "--quick",
            "--samples",
            "4",
            "--task",
            "elev+90",
            "--task",
            "elev-01",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let tasks: Vec<&str> = text.lines().filter(|l| l.contains("core-hours at 512x256")).collect();
    assert_eq!(tasks.len(), 2, "{text}");
    assert!(
        tasks[0].starts_with("vis020.0_elev-01.0_alt00000m: ")
            && tasks[1].starts_with("vis020.0_elev+90.0_alt00000m: "),
        "{text}"
    );
    assert!(text.starts_with("grid benchmark: 2 tasks, "), "{text}");
    let out = atmosim()
        .args(["bench", "--grid", "--quick", "--task", "elev+45"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("`--task` = \"elev+45\"") && err.contains("vis020.0_elev+10.0_alt00000m"),
        "{err}"
    );
    // The seed: 1 by default, named in the header; another seed renders
    // other paths (the figures differ), the same seed the same ones.
    let noise_of = |seed: Option<&str>| {
        let mut args = vec!["bench", "--grid", "--quick", "--samples", "4", "--task", "elev-01"];
        if let Some(seed) = seed {
            args.extend(["--seed", seed]);
        }
        let out = atmosim().args(&args).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8(out.stdout).unwrap();
        let seed = seed.unwrap_or("1");
        assert!(
            text.lines().next().unwrap().contains(&format!(", seed {seed}, ")),
            "{text}"
        );
        // The task's noise figures, without its timings.
        let line = text.lines().find(|l| l.contains("core-hours at 512x256")).unwrap();
        let start = line.find("image noise by band").unwrap();
        line[start..line.rfind(": ").unwrap()].to_string()
    };
    let default = noise_of(None);
    assert_eq!(noise_of(Some("1")), default);
    assert_ne!(noise_of(Some("2")), default);
    // The former per-pixel yardstick, priced at 1024×512.
    let out = atmosim()
        .args(["bench", "--grid", "--quick", "--per-pixel", "--task", "elev+90"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("the per-pixel yardstick") && text.contains("median/p99 by band 340: "),
        "{text}"
    );
    assert!(text.lines().any(|l| l.contains("core-hours at 1024x512")), "{text}");
    // Only with --grid, at least 2 samples, a seed that is a u64.
    for args in [
        &["bench", "--samples", "4"][..],
        &["bench", "--grid", "--samples", "1"][..],
        &["bench", "--task", "elev+90"][..],
        &["bench", "--seed", "2"][..],
        &["bench", "--grid", "--seed", "-1"][..],
        &["bench", "--per-pixel"][..],
        &["bench", "--grid", "--per-pixel", "--samples", "4"][..],
    ] {
        let out = atmosim().args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}

#[test]
fn bench_ends_with_the_throughput_line() {
    let out = atmosim().args(["bench", "--quick", "--threads", "1"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let last = text.lines().last().unwrap();
    let rate: f64 = last
        .strip_prefix("paths_per_second_per_core: ")
        .unwrap()
        .parse()
        .unwrap();
    assert!(rate > 0.0);
    assert!(text.contains("threads: 1"));
    // 12 directions with their relative standard errors.
    assert_eq!(
        text.lines()
            .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()) && l.contains(','))
            .count(),
        12
    );
}

#[test]
fn bad_band_widths_are_refused_naming_the_key_and_range() {
    let base = "[atmosphere]\naerosol = \"none\"\n";
    for (extra, key, hint) in [
        (
            "[spectrum]\nwavelengths_nm = [550.0]\nband_width_nm = -5.0\n",
            "spectrum.band_width_nm",
            "twice",
        ),
        (
            "[spectrum]\nwavelengths_nm = [550.0]\nband_width_nm = 1200.0\n",
            "spectrum.band_width_nm",
            "twice",
        ),
        (
            "[spectrum]\nwavelengths_nm = [450.0, 550.0]\nband_width_nm = [10.0]\n",
            "spectrum.band_width_nm",
            "one per",
        ),
        // 240 ± 30 nm reaches below the Bodhaine formula's 230 nm.
        (
            "[spectrum]\nwavelengths_nm = [240.0]\nband_width_nm = 60.0\n",
            "spectrum.band_width_nm",
            "230",
        ),
        (
            "[spectrum]\nwavelengths_nm = [550.0]\nband_width_nm = 40.0\n[render]\nshared_wavelengths = false\n",
            "render.shared_wavelengths",
            "band_width_nm",
        ),
        (
            "[render]\nroulette_threshold = 0.0\n",
            "render.roulette_threshold",
            "above 0 and at most 1",
        ),
        (
            "[render]\nroulette_threshold = 1.5\n",
            "render.roulette_threshold",
            "above 0 and at most 1",
        ),
        (
            "[render]\nspectral_groups = 0\n",
            "render.spectral_groups",
            "whole number of groups from 1",
        ),
        (
            "[render]\nspectral_groups = \"two\"\n",
            "render.spectral_groups",
            "\"auto\"",
        ),
        // A type error: the reader shows the line, key and all.
        (
            "[render]\nspectral_groups = 1.5\n",
            "spectral_groups = 1.5",
            "whole number of groups",
        ),
        // Absolute units need the Kurucz irradiance (250–10000 nm) over
        // every channel, band edges included.
        (
            "[spectrum]\nwavelengths_nm = [240.0]\n[output]\nunits = \"absolute\"\n",
            "spectrum.wavelengths_nm",
            "250 to 10000 nm",
        ),
        (
            "[spectrum]\nwavelengths_nm = [270.0]\nband_width_nm = 50.0\n[output]\nunits = \"absolute\"\n",
            "spectrum.band_width_nm",
            "245 to 295 nm leaves",
        ),
    ] {
        common::assert_refused("render", &format!("{base}{extra}"), &[key, hint]);
    }
}

#[test]
fn band_channels_render_and_are_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let job = "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [340.0, 380.0]\nband_width_nm = 40.0\n\
               [sensor]\ndirections = [[0.0, 0.0]]\n[render]\nsamples = 2000\n";
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    let out = atmosim()
        .current_dir(dir.path())
        .args(["render", "job.toml", "--out", "out", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let radiance = std::fs::read_to_string(dir.path().join("out/radiance.csv")).unwrap();
    assert_eq!(radiance.lines().count(), 3, "{radiance}");
    // Band-averaged fluxes, one row per band.
    let fluxes = std::fs::read_to_string(dir.path().join("out/fluxes.csv")).unwrap();
    assert_eq!(fluxes.lines().count(), 3, "{fluxes}");
    assert!(fluxes.lines().nth(1).unwrap().starts_with("340"), "{fluxes}");
    let meta = std::fs::read_to_string(dir.path().join("out/task.toml")).unwrap();
    assert!(meta.contains("band_width_nm = [40.0, 40.0]"), "{meta}");
    assert!(meta.contains("wavelengths_nm = [340.0, 380.0]"), "{meta}");
    // Band-averaged transmittance tables (exact: the analytic estimator);
    // a Monte Carlo estimator is refused, naming the key, before anything
    // is written.
    let t = atmosim()
        .current_dir(dir.path())
        .args(["transmittance", "job.toml", "--out", "tr", "-q"])
        .output()
        .unwrap();
    assert!(t.status.success(), "{}", String::from_utf8_lossy(&t.stderr));
    let table = std::fs::read_to_string(dir.path().join("tr/transmittance.csv")).unwrap();
    for band in ["340,", "380,"] {
        assert!(table.lines().any(|l| l.starts_with(band)), "{table}");
    }
    let mc = job.replace("[render]", "[transmittance]\nestimator = \"ratio_tracking\"\n[render]");
    std::fs::write(dir.path().join("mc.toml"), mc).unwrap();
    let t = atmosim()
        .current_dir(dir.path())
        .args(["transmittance", "mc.toml", "--out", "tr_mc"])
        .output()
        .unwrap();
    assert_eq!(t.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&t.stderr).contains("transmittance.estimator"));
    assert!(!dir.path().join("tr_mc").exists());
}

/// The radiance.csv and fluxes.csv of `job` rendered into `out` under `dir`.
fn render_csvs(dir: &std::path::Path, job: &str, out: &str) -> (String, String, String) {
    std::fs::write(dir.join(format!("{out}.toml")), job).unwrap();
    let o = atmosim()
        .current_dir(dir)
        .args(["render", &format!("{out}.toml"), "--out", out, "-q"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read = |f: &str| std::fs::read_to_string(dir.join(out).join(f)).unwrap_or_default();
    (read("radiance.csv"), read("fluxes.csv"), read("task.toml"))
}

/// The numbers of a CSV's data lines.
fn numbers(csv: &str) -> Vec<Vec<f64>> {
    csv.lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn absolute_units_scale_the_directions_outputs_by_the_irradiance() {
    // The same paths in both units: absolute = normalised × E0(λ), E0 from
    // the Kurucz table (1.86 W m-2 nm-1 at 550 nm, 1.95 at 500).
    let dir = tempfile::tempdir().unwrap();
    let job = "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [500.0, 550.0]\n\
               [sensor]\ndirections = [[0.0, 0.0], [60.0, 90.0]]\n[render]\nsamples = 2000\n";
    let (rn, fnorm, meta_n) = render_csvs(dir.path(), job, "norm");
    let (ra, fabs, meta_a) = render_csvs(dir.path(), &format!("{job}[output]\nunits = \"absolute\"\n"), "abs");
    assert!(meta_n.contains("units = \"normalized"), "{meta_n}");
    assert!(meta_a.contains("units = \"absolute: W m-2 sr-1 nm-1"), "{meta_a}");
    let solar = atmosim::physics::solar::SolarSpectrum::kurucz().unwrap();
    // radiance.csv: I..V_se (columns 4–11) scale; fluxes.csv: every column
    // after wavelength, albedo and altitude.
    for (n, a, cols) in [
        (numbers(&rn), numbers(&ra), 4..12),
        (numbers(&fnorm), numbers(&fabs), 3..8),
    ] {
        assert!(!n.is_empty() && n.len() == a.len());
        for (x, y) in n.iter().zip(&a) {
            let e0 = solar.irradiance(x[0]).unwrap();
            for c in cols.clone() {
                // Standard errors are printed to 5 digits: 2e-4 relative.
                assert!((y[c] - x[c] * e0).abs() <= 2e-4 * (x[c] * e0).abs(), "{x:?} vs {y:?}");
            }
        }
    }
}

#[test]
fn bench_suite_reports_every_case_and_direction() {
    // Not timed: that the suite runs, and each direction of each case has
    // a positive, finite figure of merit for I and Q.
    let out = atmosim()
        .args(["bench", "--suite", "--quick", "--threads", "1"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().last(), Some("suite_cases: 7"));
    let cases: Vec<&str> = text.lines().filter(|l| l.starts_with("case ")).collect();
    assert_eq!(cases.len(), 7, "{text}");
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    // 16 + 15 + 14 + 12 + 12 + 12 + 14 directions.
    assert_eq!(rows.len(), 95);
    for r in &rows {
        assert!(
            r[2].is_finite() && r[2] > 0.0 && r[3].is_finite() && r[3] > 0.0,
            "{r:?}"
        );
    }
}

#[test]
fn bench_suite_writes_job_files_that_render() {
    let dir = tempfile::tempdir().unwrap();
    let out = atmosim()
        .args(["bench", "--suite", "--quick", "--write-jobs"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let job = dir.path().join("fine_profile.toml");
    let out = atmosim()
        .arg("render")
        .arg(&job)
        .args(["--stdout", "--threads", "1", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(String::from_utf8(out.stdout).unwrap().lines().count(), 13);
    let bad = atmosim()
        .args(["bench", "--suite", "--quick", "--case", "nope"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("fine_profile"));
}
