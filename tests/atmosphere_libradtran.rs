//! The atmosphere against libRadtran 2.0.3 (uvspec) for the same inputs:
//! column optical depths (shared/data/README.md) and every layer of the
//! 540 nm verbose runs (validation/libradtran, derived by
//! scripts/derive_data.py). Bounds from the foundation issue: Rayleigh
//! 0.05 %, ozone 0.5 %, aerosol extinction 0.5 %, single-scattering albedo
//! 0.2 %.

use std::path::Path;

use atmosim::atmosphere::Atmosphere;
use atmosim::job::Job;
use atmosim::physics::data::Table;

const RAYLEIGH_REL: f64 = 5e-4;
const OZONE_REL: f64 = 5e-3;
const AEROSOL_REL: f64 = 5e-3;
const SSA_REL: f64 = 2e-3;

/// afglus + Bogumil + continental_average to 120 km, as the reference runs.
fn reference_atmosphere(wavelengths: &str) -> Atmosphere {
    let text = format!(
        "[planet]\nradius_km = 6370.0\ntop_km = 120.0\n\
         [atmosphere]\nprofile = \"us_standard\"\nozone = \"bogumil\"\naerosol = \"continental_average\"\n\
         [spectrum]\nwavelengths_nm = {wavelengths}\n"
    );
    Job::parse(&text, "reference.toml", Path::new(".")).unwrap().atmosphere
}

fn table(name: &str, text: &str) -> Table {
    Table::parse(name, text, 0).unwrap()
}

fn close(what: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got / want - 1.0).abs() <= rel,
        "{what}: atmosim {got:e}, libRadtran {want:e}, relative difference {:e} > {rel:e}",
        got / want - 1.0
    );
}

#[test]
fn column_optical_depths_match_libradtran_at_420_540_620_nm() {
    let atm = reference_atmosphere("[420.0, 540.0, 620.0]");
    let refs = table("columns", include_str!("../validation/libradtran/columns.txt"));
    for (w, row) in refs.rows.iter().enumerate() {
        assert_eq!(atm.wavelengths_nm[w], row[0]);
        let c = atm.column(w);
        let at = |q: &str| format!("{q} at {} nm", row[0]);
        close(&at("tau_rayleigh"), c.tau_rayleigh, row[1], RAYLEIGH_REL);
        close(&at("tau_ozone"), c.tau_absorption, row[2], OZONE_REL);
        close(&at("tau_aerosol_ext"), c.tau_aerosol_ext, row[3], AEROSOL_REL);
        close(&at("aerosol ssa"), c.aerosol_ssa(), row[4], SSA_REL);
    }
}

#[test]
fn every_gas_layer_at_540_nm_matches_libradtran() {
    let atm = reference_atmosphere("[540.0]");
    for (name, text) in [
        ("A", include_str!("../validation/libradtran/A_540nm_layers.txt")),
        ("B", include_str!("../validation/libradtran/B_540nm_layers.txt")),
    ] {
        let refs = table(name, text);
        assert_eq!(refs.rows.len(), atm.layer_count(), "{name}: layer count");
        for (i, row) in refs.rows.iter().enumerate() {
            assert_eq!((atm.levels_km[i], atm.levels_km[i + 1]), (row[0], row[1]));
            let o = atm.optics[0][i];
            let dz = atm.thickness_km(i);
            let at = |q: &str| format!("{name} layer {}-{} km {q}", row[0], row[1]);
            close(&at("tau_rayleigh"), o.sigma_rayleigh * dz, row[2], RAYLEIGH_REL);
            close(&at("tau_ozone"), o.sigma_absorption * dz, row[6], OZONE_REL);
        }
    }
}

#[test]
fn every_aerosol_layer_at_540_nm_matches_libradtran() {
    let atm = reference_atmosphere("[540.0]");
    let refs = table(
        "fullprec",
        include_str!("../validation/libradtran/B_540nm_aerosol_fullprec.txt"),
    );
    for row in &refs.rows {
        // A reference layer may span several gas layers (12-35 km).
        let (mut ext, mut sca, mut g_sca) = (0.0, 0.0, 0.0);
        for (i, o) in atm.optics[0].iter().enumerate() {
            if atm.levels_km[i] >= row[0] && atm.levels_km[i + 1] <= row[1] {
                let dz = atm.thickness_km(i);
                ext += o.sigma_aerosol_ext * dz;
                sca += o.sigma_aerosol_sca * dz;
                g_sca += o.aerosol_g * o.sigma_aerosol_sca * dz;
            }
        }
        let at = |q: &str| format!("aerosol layer {}-{} km {q}", row[0], row[1]);
        close(&at("tau_ext"), ext, row[3], AEROSOL_REL);
        close(&at("ssa"), sca / ext, row[5], SSA_REL);
        assert!(
            (g_sca / sca - row[6]).abs() < 1e-5,
            "{}: g {} vs {}",
            at("g"),
            g_sca / sca,
            row[6]
        );
    }
}

#[test]
fn unscaled_continental_average_visibility_is_59_km() {
    // shared/data/README.md: 0.0547 km⁻¹ aerosol + 0.0115 km⁻¹ Rayleigh at
    // 550 nm at the ground, 3.912/β ≈ 59 km.
    let atm = reference_atmosphere("[550.0]");
    let v = atm.visibility.unwrap();
    let expect = 3.912 / (0.054667 + 0.011483);
    close("unscaled visibility", v.unscaled_km, expect, 1e-3);
    assert_eq!(v.boundary_scale, 1.0);
}

#[test]
fn requested_visibility_is_reached_and_scales_only_the_boundary_layer() {
    let base = reference_atmosphere("[550.0]");
    let text = "[planet]\ntop_km = 120.0\n[atmosphere]\nvisibility_km = 20.0\n[spectrum]\nwavelengths_nm = [550.0]\n";
    let atm = Job::parse(text, "vis.toml", Path::new(".")).unwrap().atmosphere;
    let v = atm.visibility.unwrap();
    close("ground visibility", v.ground_km, 20.0, 1e-12);
    // Ground extinction from the layers themselves: Koschmieder with the
    // lowest layer's aerosol and the ground-level Rayleigh coefficient
    // (the 0-1 km layer's Rayleigh mean is below the ground value).
    let beta_aer = atm.optics[0][0].sigma_aerosol_ext;
    let beta_aer_base = base.optics[0][0].sigma_aerosol_ext;
    close("boundary scale", beta_aer / beta_aer_base, v.boundary_scale, 1e-12);
    for i in 0..atm.layer_count() {
        let (a, b) = (atm.optics[0][i], base.optics[0][i]);
        if atm.levels_km[i] >= 2.0 {
            assert_eq!(
                a.sigma_aerosol_ext, b.sigma_aerosol_ext,
                "layer {i} above the boundary layer changed"
            );
        }
        assert_eq!(a.sigma_rayleigh, b.sigma_rayleigh);
    }
}

#[test]
fn ozone_column_scaling_hits_the_requested_dobson_units() {
    let text = "[atmosphere]\nozone_column_du = 300.0\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [540.0]\n";
    let scaled = Job::parse(text, "o3.toml", Path::new(".")).unwrap().atmosphere;
    close("ozone column", scaled.ozone_column_du.unwrap(), 300.0, 1e-12);
    let text = "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [540.0]\n";
    let base = Job::parse(text, "o3.toml", Path::new(".")).unwrap().atmosphere;
    let ratio = scaled.column(0).tau_absorption / base.column(0).tau_absorption;
    close(
        "ozone optical depth ratio",
        ratio,
        300.0 / base.ozone_column_du.unwrap(),
        1e-12,
    );
}

#[test]
fn explicit_layers_replace_the_profile() {
    let text = "\
[[atmosphere.layers]]
bottom_km = 0.0
top_km = 1.0
tau_rayleigh = 0.1
rayleigh_depolarization = 0.03
tau_aerosol = 0.2
aerosol_ssa = 0.9
aerosol_g = 0.7
[[atmosphere.layers]]
bottom_km = 1.0
top_km = 30.0
tau_rayleigh = 0.4
tau_absorption = 0.05
";
    let job = Job::parse(text, "layers.toml", Path::new(".")).unwrap();
    let atm = &job.atmosphere;
    assert_eq!(atm.levels_km, vec![0.0, 1.0, 30.0]);
    assert_eq!(job.planet.top_km, 30.0);
    let c = atm.column(0);
    close("tau_rayleigh", c.tau_rayleigh, 0.5, 1e-12);
    close("tau_absorption", c.tau_absorption, 0.05, 1e-12);
    close("tau_aerosol_sca", c.tau_aerosol_sca, 0.18, 1e-12);
    assert_eq!(atm.optics[0][0].aerosol_g, 0.7);
    assert_eq!(atm.optics[0][0].rayleigh_depolarization, 0.03);
    close(
        "sigma_rayleigh km-1",
        atm.optics[0][1].sigma_rayleigh,
        0.4 / 29.0,
        1e-12,
    );
}
