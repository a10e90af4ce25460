//! The `atmosim atmosphere` command run as a user runs it: output format,
//! and one test per kind of bad job file (clear error naming the file and
//! the key, exit code 2, nothing on stdout).

use assert_cmd::Command;
use std::path::PathBuf;

fn atmosim() -> Command {
    Command::cargo_bin("atmosim").unwrap()
}

/// Writes `text` as a job file in a fresh temp dir.
fn job(text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("job.toml");
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

/// Runs `atmosphere` on a bad job and returns stderr, after checking exit
/// code 2, an empty stdout, and that stderr names the file and every `needle`.
fn rejects(text: &str, needles: &[&str]) -> String {
    let (_dir, path) = job(text);
    let out = atmosim().arg("atmosphere").arg(&path).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(2), "exit code; stderr: {stderr}");
    assert!(
        out.stdout.is_empty(),
        "stdout not empty: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(stderr.contains("job.toml"), "file not named: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "`{n}` missing from: {stderr}");
    }
    stderr
}

#[test]
fn default_atmosphere_prints_the_csv_header_layers_totals_and_visibility() {
    let out = atmosim().args(["atmosphere", "--format", "csv"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some(
            "wavelength_nm,bottom_km,top_km,tau_rayleigh,tau_ozone,tau_aerosol_ext,tau_aerosol_sca,aerosol_g,rayleigh_depolarization"
        )
    );
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).skip(1).collect();
    // 3 default wavelengths × the AFGL layers up to 100 km: 25 of 1 km,
    // 10 of 2.5 km, 10 of 5 km.
    assert_eq!(rows.len(), 3 * 45);
    assert!(rows.iter().all(|r| r.split(',').count() == 9));
    assert!(text.contains("# column 540 nm: tau_rayleigh=0.10464"));
    assert!(text.contains("# ground visibility (550 nm, Koschmieder): 59.1"));
}

#[test]
fn table_format_is_aligned() {
    let out = atmosim().arg("atmosphere").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let widths: Vec<usize> = text.lines().filter(|l| !l.starts_with('#')).map(str::len).collect();
    assert!(widths.windows(2).all(|w| w[0] == w[1]), "rows of different width");
}

#[test]
fn a_job_file_selects_profile_wavelengths_and_visibility() {
    let (_d, path) = job(
        "[planet]\ntop_km = 50.0\n[atmosphere]\nprofile = \"tropical\"\nvisibility_km = 30.0\n\
         [spectrum]\nwavelengths_nm = [550.0]\n",
    );
    let out = atmosim()
        .arg("atmosphere")
        .arg(&path)
        .args(["--format", "csv"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("# ground visibility (550 nm, Koschmieder): 30.00 km"),
        "{text}"
    );
    assert!(text.lines().any(|l| l.starts_with("550,47.5,50,")));
}

#[test]
fn unknown_key_is_named_with_its_line() {
    let e = rejects("[planet]\nradius_km = 6378.0\nraduis = 1.0\n", &["raduis", "line 3"]);
    assert!(e.contains("radius_km"), "valid keys should be listed: {e}");
}

#[test]
fn unknown_section_is_refused() {
    rejects("[atmosfere]\nprofile = \"us_standard\"\n", &["atmosfere", "line 1"]);
}

#[test]
fn wrong_type_is_named_with_its_line() {
    rejects(
        "[planet]\nradius_km = \"big\"\n",
        &["radius_km", "line 2", "invalid type"],
    );
}

#[test]
fn malformed_toml_is_reported_with_its_line() {
    rejects("[planet\nradius_km = 1\n", &["line 1"]);
}

#[test]
fn unknown_profile_lists_the_valid_names() {
    rejects(
        "[atmosphere]\nprofile = \"martian\"\n",
        &["atmosphere.profile", "martian", "us_standard", "tropical"],
    );
}

#[test]
fn unknown_mixture_lists_the_valid_names() {
    rejects(
        "[atmosphere]\naerosol = \"volcanic\"\n",
        &["atmosphere.aerosol", "volcanic", "continental_average"],
    );
}

#[test]
fn the_spheroidal_dust_mixture_names_its_components_and_the_spherical_one() {
    rejects(
        "[atmosphere]\naerosol = \"desert_spheroids\"\n",
        &["atmosphere.aerosol", "minm_spheroids", "use `desert`"],
    );
}

#[test]
fn unknown_ozone_model_lists_the_variants() {
    rejects(
        "[atmosphere]\nozone = \"gorshelev\"\n",
        &["gorshelev", "bogumil", "molina"],
    );
}

#[test]
fn negative_radius_is_refused_with_the_valid_range() {
    rejects(
        "[planet]\nradius_km = -6378.0\n",
        &["planet.radius_km", "-6378", "valid:"],
    );
}

#[test]
fn non_finite_numbers_are_refused() {
    rejects("[planet]\ntop_km = inf\n", &["planet.top_km", "not a finite number"]);
    rejects(
        "[atmosphere]\nvisibility_km = nan\n",
        &["atmosphere.visibility_km", "not a finite number"],
    );
}

#[test]
fn negative_layer_optical_depth_names_the_layer() {
    rejects(
        "[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\ntau_rayleigh = -0.1\n",
        &["atmosphere.layers[0].tau_rayleigh", "≥ 0"],
    );
}

#[test]
fn wavelength_outside_the_data_names_the_range() {
    // The OPAC tables span 250–2500 nm: below them (where Rayleigh and
    // ozone still have data), and past them with ozone off.
    rejects(
        "[spectrum]\nwavelengths_nm = [540.0, 240.0]\n",
        &["spectrum.wavelengths_nm", "240", "OPAC component", "250 to 2500 nm"],
    );
    rejects(
        "[atmosphere]\nozone = \"none\"\n[spectrum]\nwavelengths_nm = [2600.0]\n",
        &["spectrum.wavelengths_nm", "2600", "OPAC component", "250 to 2500 nm"],
    );
    rejects(
        "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [200.0]\n",
        &["spectrum.wavelengths_nm", "230 to 4000 nm"],
    );
}

#[test]
fn unreachable_visibility_names_the_largest_reachable_value() {
    rejects(
        "[atmosphere]\nvisibility_km = 500.0\n",
        &["atmosphere.visibility_km", "largest reachable visibility is 3"],
    );
}

#[test]
fn visibility_without_aerosol_is_refused() {
    rejects(
        "[atmosphere]\naerosol = \"none\"\nvisibility_km = 50.0\n",
        &["atmosphere.visibility_km"],
    );
}

#[test]
fn top_below_the_observer_is_refused() {
    rejects(
        "[planet]\ntop_km = 40.0\n[observer]\naltitude_km = 50.0\n",
        &["observer.altitude_km", "above the top", "40"],
    );
}

#[test]
fn top_above_the_profile_is_refused() {
    rejects("[planet]\ntop_km = 150.0\n", &["planet.top_km", "120"]);
}

#[test]
fn missing_profile_file_is_named() {
    rejects(
        "[atmosphere]\nprofile_file = \"no_such_profile.dat\"\n",
        &["atmosphere.profile_file", "no_such_profile.dat"],
    );
}

#[test]
fn malformed_profile_file_is_named_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.dat"), "0 1013 288 2.5e19 1 2 3 4\n").unwrap();
    let path = dir.path().join("job.toml");
    std::fs::write(&path, "[atmosphere]\nprofile_file = \"bad.dat\"\n").unwrap();
    let out = atmosim().arg("atmosphere").arg(&path).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("bad.dat") && e.contains("line 1") && e.contains("expected 9"),
        "{e}"
    );
}

#[test]
fn a_profile_file_in_afgl_format_is_used() {
    let dir = tempfile::tempdir().unwrap();
    // Two levels of afglus.dat.
    std::fs::write(
        dir.path().join("two.dat"),
        "# z p T air o3 o2 h2o co2 no2\n\
         1.0 898.8 281.7 2.310936E+19 6.779402E+11 4.834170E+18 1.404222E+17 7.632900E+15 5.319900E+08\n\
         0.0 1013.0 288.2 2.545818E+19 6.777680E+11 5.325320E+18 1.973426E+17 8.408400E+15 5.860400E+08\n",
    )
    .unwrap();
    let path = dir.path().join("job.toml");
    std::fs::write(
        &path,
        "[atmosphere]\nprofile_file = \"two.dat\"\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [540.0]\n",
    )
    .unwrap();
    let out = atmosim()
        .arg("atmosphere")
        .arg(&path)
        .args(["--format", "csv"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    // uvspec's 0-1 km Rayleigh optical depth at 540 nm: 0.01179596.
    assert!(text.contains("540,0,1,1.179596e-2,"), "{text}");
}

#[test]
fn missing_job_file_is_a_user_error() {
    let out = atmosim().args(["atmosphere", "no/such/job.toml"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/job.toml"));
}

#[test]
fn the_example_job_runs() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/libradtran_reference.toml");
    let out = atmosim()
        .args(["atmosphere", path, "--format", "csv"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

const WIDE: &str = "[atmosphere]\naerosol = \"none\"\ngases = \"all\"\n[spectrum]\nwavelengths_nm = [940.0, 2300.0]\nband_width_nm = 40.0\n";

#[test]
fn gases_list_each_gas_per_layer_with_its_band_mean() {
    let (_dir, path) = job(WIDE);
    let out = atmosim()
        .args(["atmosphere", "--format", "csv"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let header = text.lines().next().unwrap();
    // NO2's table ends at 760 nm: it has no term in these bands.
    assert!(
        header.ends_with(",tau_h2o,tau_co2,tau_o2,tau_ch4,tau_n2o,tau_o4"),
        "{header}"
    );
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).skip(1).collect();
    assert!(rows.iter().all(|r| r.split(',').count() == 15));
    // Water absorbs at 940 nm, methane at 2300 nm, and not the other way.
    let gas_column = |lambda: &str, gas: &str| -> f64 {
        let line = text
            .lines()
            .find(|l| l.starts_with(&format!("# gas column {lambda} nm")))
            .unwrap();
        let field = line
            .split_whitespace()
            .find(|f| f.starts_with(&format!("tau_{gas}=")))
            .unwrap();
        field.split('=').nth(1).unwrap().parse().unwrap()
    };
    assert!(gas_column("940", "h2o") > 1.0);
    assert_eq!(gas_column("940", "ch4"), 0.0);
    assert!(gas_column("2300", "ch4") > 0.1);
    assert!(text.contains("# precipitable water: 1.417"), "{text}");
}

#[test]
fn gases_need_bands() {
    rejects(
        &WIDE.replace("band_width_nm = 40.0\n", ""),
        &["spectrum.band_width_nm", "one wavelength", "40 nm"],
    );
}

#[test]
fn gases_refuse_bands_outside_280_to_2480_nm() {
    rejects(
        &WIDE.replace("2300.0", "2480.0"),
        &["spectrum.band_width_nm", "gas tables", "280 to 2480"],
    );
}

#[test]
fn column_scalings_name_their_range_and_their_gas() {
    rejects(
        &WIDE.replace("gases = \"all\"\n", "gases = \"all\"\nprecipitable_water_cm = 12.0\n"),
        &["atmosphere.precipitable_water_cm", "0 to 10 cm"],
    );
    rejects(
        &WIDE.replace("gases = \"all\"\n", "gases = [\"h2o\"]\nco2_ppm = 400.0\n"),
        &["atmosphere.co2_ppm", "\"co2\""],
    );
    rejects(
        &WIDE.replace("\"all\"", "[\"h2o\", \"xenon\"]"),
        &["atmosphere.gases", "xenon", "\"no2\""],
    );
}
