//! `atmosim uvspec` as a user runs it: uvspec-style and CSV output of a small
//! input, and bad inputs (unknown keyword, missing value, umu out of range:
//! exit code 2 with the line number).

use assert_cmd::Command;

fn atmosim() -> Command {
    Command::cargo_bin("atmosim").unwrap()
}

const SMALL: &str = "\
atmosphere_file afglus
source solar
wavelength 550
sza 30
phi0 0
umu -0.5 1
phi 0 90
zout 0 5
albedo 0.3
crs_model o3 Bogumil
output_quantity transmittance
rte_solver disort
number_of_streams 16
quiet
";

fn run(input: &str, args: &[&str]) -> std::process::Output {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("in.inp");
    std::fs::write(&path, input).unwrap();
    atmosim().arg("uvspec").arg(&path).args(args).output().unwrap()
}

#[test]
fn csv_has_one_row_per_zout_umu_and_phi() {
    let out = run(SMALL, &["--format", "csv", "--samples", "2000"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("zout_km,umu,phi_deg,wavelength_nm,I,Q,U,V,I_se,Q_se,U_se,V_se")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2 * 2 * 2);
    assert_eq!(rows[0][..4], ["0", "-0.5", "0", "550"]);
    assert_eq!(rows[7][..4], ["5", "1", "90", "550"]);
    for r in &rows {
        assert_eq!(r.len(), 12);
        // Scalar run: Q, U, V and their errors empty.
        assert!(r[5].is_empty() && r[6].is_empty() && r[7].is_empty() && r[11].is_empty());
        let (i, se): (f64, f64) = (r[4].parse().unwrap(), r[8].parse().unwrap());
        assert!(i > 0.0 && se > 0.0 && se < 0.2 * i, "{r:?}");
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("number_of_streams"), "{stderr}");
}

#[test]
fn uvspec_output_has_the_flux_line_and_the_radiance_block() {
    let out = run(SMALL, &["--samples", "2000"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // Per zout: flux line, phi line, one row per umu.
    assert_eq!(lines.len(), 2 * (1 + 1 + 2), "{text}");
    let flux: Vec<f64> = lines[0].split_whitespace().map(|v| v.parse().unwrap()).collect();
    assert_eq!(flux.len(), 7);
    assert_eq!(flux[0], 550.0);
    // edir = μ0·exp(−τ/μ0) in plane-parallel geometry, τ the column optical depth.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("in.inp");
    std::fs::write(&path, SMALL).unwrap();
    let job = atmosim::compat::uvspec::UvspecInput::from_file(&path)
        .unwrap()
        .job(10, 1, false)
        .unwrap();
    let c = job.atmosphere.column(0);
    let tau = c.tau_rayleigh + c.tau_absorption + c.tau_aerosol_ext;
    let mu0 = 30f64.to_radians().cos();
    let edir = mu0 * (-tau / mu0).exp();
    assert!((flux[1] / edir - 1.0).abs() < 2e-6, "{} vs {edir}", flux[1]);
    // uavgdir = T/(4π).
    assert!((flux[4] / (edir / mu0 / (4.0 * std::f64::consts::PI)) - 1.0).abs() < 2e-6);
    let phis: Vec<f64> = lines[1].split_whitespace().map(|v| v.parse().unwrap()).collect();
    assert_eq!(phis, vec![0.0, 90.0]);
    let row: Vec<f64> = lines[2].split_whitespace().map(|v| v.parse().unwrap()).collect();
    assert_eq!(row.len(), 4);
    assert_eq!(row[0], -0.5);
}

#[test]
fn polarised_runs_print_four_rows_per_umu() {
    let input = SMALL.replace("rte_solver disort", "rte_solver polradtran\npolradtran nstokes 3");
    let out = run(&input, &["--samples", "1000"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 2 * (1 + 1 + 2 * 4), "{text}");
    let csv = run(&input, &["--samples", "1000", "--format", "csv"]);
    let text = String::from_utf8(csv.stdout).unwrap();
    let row: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    assert!(!row[5].is_empty() && !row[9].is_empty(), "{row:?}");
}

fn assert_bad(input: &str, needle: &str) {
    let out = run(input, &["--samples", "10"]);
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(needle), "`{stderr}` lacks `{needle}`");
    assert!(out.stdout.is_empty());
}

#[test]
fn unknown_keyword_exits_2_with_its_line() {
    assert_bad(
        &SMALL.replace("quiet", "quiet\nmystery_option 3"),
        "in.inp:15: unknown keyword `mystery_option`",
    );
}

#[test]
fn missing_value_exits_2_with_its_line() {
    assert_bad(&SMALL.replace("sza 30", "sza"), "in.inp:4: `sza`: missing value");
}

#[test]
fn umu_out_of_range_exits_2_with_its_line() {
    assert_bad(
        &SMALL.replace("umu -0.5 1", "umu -0.5 1.5"),
        "in.inp:6: `umu` = 1.5: out of range (valid: -1 to 1)",
    );
}

#[test]
fn missing_input_file_exits_2() {
    let out = atmosim().args(["uvspec", "no/such/file.inp"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}
