use super::*;
use crate::error::{Error, Result};

fn no_files(name: &str) -> std::io::Result<String> {
    Err(std::io::Error::new(std::io::ErrorKind::NotFound, name.to_string()))
}

fn parse(text: &str) -> Result<UvspecInput> {
    UvspecInput::parse(text, "t.inp", &no_files)
}

/// The error message and line of a bad input.
fn error(text: &str) -> (usize, String) {
    match parse(text) {
        Err(Error::Uvspec { line, message, .. }) => (line, message),
        other => panic!("expected a uvspec error, got {other:?}"),
    }
}

const MINIMAL: &str = "atmosphere_file afglus\nwavelength 540\n";

#[test]
fn every_keyword_of_the_subset_is_read() {
    let layer = |name: &str| -> std::io::Result<String> {
        let v = match name {
            "tau.dat" => "0.1",
            "ssa.dat" => "0.9",
            "gg.dat" => "0.7",
            _ => return no_files(name),
        };
        Ok(format!("# z value\n2.0 0.0\n1.0 {v}\n0.0 {v}\n"))
    };
    // Every keyword of the subset (also a seed of tests/readers_fuzz.rs).
    let text = include_str!("../../../tests/data/every_keyword.inp");
    let u = UvspecInput::parse(text, "t.inp", &layer).unwrap();
    assert_eq!(u.profile, ProfileChoice::Builtin("midlatitude_summer".into()));
    assert_eq!(
        (u.wavelength_nm, u.sza_deg, u.phi0_deg, u.albedo),
        (550.0, 30.0, 40.0, 0.3)
    );
    assert_eq!(u.umu, vec![-1.0, -0.5, 0.5]);
    assert_eq!(u.phi_deg, vec![0.0, 90.0]);
    assert_eq!(u.zout, vec![Zout::Surface, Zout::Km(2.5), Zout::Top]);
    assert_eq!(u.radius_km, 6371.0);
    assert_eq!(u.ozone_model, "bogumil");
    assert_eq!(u.ozone_column_du, Some(300.0));
    assert!(u.transmittance && u.polarized);
    assert_eq!(u.geometry, UvspecGeometry::PseudoSpherical);
    assert_eq!(u.output_user.as_ref().map(Vec::len), Some(6));
    let layers = u.aerosol_layers();
    assert_eq!(layers.len(), 2);
    assert_eq!(
        (layers[0].bottom_km, layers[0].tau, layers[0].ssa, layers[0].g),
        (0.0, 0.1, 0.9, 0.7)
    );
    // number_of_streams and `polradtran src_code` warn; quiet, verbose and data_files_path are silent.
    assert_eq!(u.warnings.len(), 2, "{:?}", u.warnings);
    assert!(
        u.warnings
            .iter()
            .any(|w| w.contains("t.inp:28") && w.contains("number_of_streams"))
    );
    let toml = u.job_toml(1000, 1, false);
    assert!(toml.contains("geometry = \"pseudo_spherical\""), "{toml}");
    assert!(
        toml.contains("polarized = true") && toml.contains("ozone_column_du = 300.0"),
        "{toml}"
    );
    assert!(toml.contains("altitude_km = [0.0, 2.5, 120.0]"), "{toml}");
    assert!(toml.contains("top_km = 120.0"), "{toml}");
    let job = u.job(1000, 1, false).unwrap();
    assert_eq!(job.tasks.len(), 3);
    assert_eq!(job.planet.radius_km, 6371.0);
    // The explicit aerosol: 0.1 per km in 0–2 km, none above.
    let c = job.atmosphere.column(0);
    assert!((c.tau_aerosol_ext - 0.2).abs() < 1e-12, "{}", c.tau_aerosol_ext);
    assert!((c.tau_aerosol_sca - 0.18).abs() < 1e-12);
    assert_eq!(job.atmosphere.optics[0][0].aerosol_g, 0.7);
    assert!((job.atmosphere.ozone_column_du.unwrap() - 300.0).abs() < 1e-9);
    assert!(u.job(1000, 1, true).unwrap().pseudo_spherical_radius_km().is_none());
}

#[test]
fn defaults_follow_uvspec() {
    let u = parse(MINIMAL).unwrap();
    assert_eq!(u.profile, ProfileChoice::Builtin("us_standard".into()));
    assert_eq!(u.ozone_model, "molina");
    assert_eq!(u.zout, vec![Zout::Surface]);
    assert_eq!(u.geometry, UvspecGeometry::PlaneParallel);
    assert!(!u.polarized && !u.transmittance);
    assert_eq!(u.radius_km, 6370.0);
    assert!(u.job_toml(10, 1, false).contains("aerosol = \"none\""));
}

#[test]
fn solvers_set_polarisation_and_geometry() {
    let run = |extra: &str| parse(&format!("{MINIMAL}{extra}")).unwrap();
    assert!(run("rte_solver polradtran\n").polarized);
    assert!(!run("rte_solver polradtran\npolradtran nstokes 1\n").polarized);
    assert!(!run("rte_solver mystic\n").polarized);
    let mc = run("rte_solver mystic\nmc_polarisation\nmc_spherical 1D\n");
    assert!(mc.polarized);
    assert_eq!(mc.geometry, UvspecGeometry::Spherical);
    assert_eq!(run("rte_solver sdisort\n").geometry, UvspecGeometry::PseudoSpherical);
    assert!(!run("rte_solver disort\n").polarized);
    assert!(
        run("rte_solver mystic\nmc_spherical 1D\n")
            .job_toml(1, 1, false)
            .contains("\"spherical\"")
    );
}

#[test]
fn profile_and_mixture_names() {
    assert_eq!(profile_choice("afglt"), ProfileChoice::Builtin("tropical".into()));
    assert_eq!(
        profile_choice("afglsw.dat"),
        ProfileChoice::Builtin("subarctic_winter".into())
    );
    assert_eq!(profile_choice("my/atm.dat"), ProfileChoice::File("my/atm.dat".into()));
    assert_eq!(opac_name("continental_clean"), "continental_clean");
    assert_eq!(opac_name("data/aerosol/OPAC/standard_aerosol_files/urban.mix"), "urban");
    let u = parse(&format!(
        "{MINIMAL}aerosol_default\naerosol_species_file urban\naerosol_visibility 20\n"
    ))
    .unwrap();
    let toml = u.job_toml(1, 1, false);
    assert!(
        toml.contains("aerosol = \"urban\"") && toml.contains("visibility_km = 20.0"),
        "{toml}"
    );
}

#[test]
fn umu_and_phi_map_to_view_zenith_and_relative_azimuth() {
    let u = parse(&format!("{MINIMAL}phi0 30\numu -1 -0.2 0 0.5 1\nphi 30 120 0\n")).unwrap();
    let d = |umu: f64, phi: f64| u.direction(umu, phi);
    // umu < 0: downwelling light, the sensor looks up.
    assert_eq!(d(-1.0, 30.0).view_zenith_deg, 0.0);
    assert!((d(-0.2, 30.0).view_zenith_deg - 78.463_040_967).abs() < 1e-6);
    assert_eq!(d(0.0, 30.0).view_zenith_deg, 90.0);
    assert!((d(0.5, 30.0).view_zenith_deg - 120.0).abs() < 1e-12);
    assert_eq!(d(1.0, 30.0).view_zenith_deg, 180.0);
    // phi − phi0 = 0: looking toward the sun's azimuth.
    assert_eq!(d(-0.2, 30.0).azimuth_deg, 0.0);
    assert_eq!(d(-0.2, 120.0).azimuth_deg, 90.0);
    assert_eq!(d(-0.2, 0.0).azimuth_deg, 330.0);
    assert_eq!(u.directions().len(), 15);
    assert_eq!(u.directions()[1].1, 120.0);
}

#[test]
fn reference_inputs_land_on_the_reference_directions() {
    // Every (umu, phi) of the libRadtran inputs is a (view zenith, azimuth)
    // of the reference file, and every reference direction is covered.
    let reference = crate::physics::data::Table::parse(
        "uvspec_540nm_sza45.txt",
        include_str!("../../../validation/libradtran/uvspec_540nm_sza45.txt"),
        9,
    )
    .unwrap();
    for (inp, atmosphere, solver) in [("A_polrad.inp", 0.0, 2.0), ("H_disort_ps.inp", 2.0, 1.0)] {
        let u = crate::compat::validate::libradtran::input(inp).unwrap();
        let dirs = u.directions();
        for z in [0.0, 10.0] {
            let rows: Vec<&Vec<f64>> = reference
                .rows
                .iter()
                .filter(|r| r[0] == atmosphere && r[1] == solver && r[2] == z)
                .collect();
            assert_eq!(rows.len(), dirs.len());
            for r in &rows {
                assert!(
                    dirs.iter()
                        .any(|(_, _, d)| (d.view_zenith_deg - r[3]).abs() < 1e-3 && d.azimuth_deg == r[4]),
                    "{inp}: reference θ {} φ {} not produced",
                    r[3],
                    r[4]
                );
            }
        }
    }
}

#[test]
fn h_input_reproduces_the_layer_files() {
    let u = crate::compat::validate::libradtran::input("H_disort_pp.inp").unwrap();
    let files = u.aerosol_files.as_ref().unwrap();
    let total: f64 = files.tau.as_ref().unwrap().iter().map(|(_, v)| v).sum();
    let job = u.job(10, 1, false).unwrap();
    let c = job.atmosphere.column(0);
    assert!(
        (c.tau_aerosol_ext / total - 1.0).abs() < 1e-12,
        "{} vs {total}",
        c.tau_aerosol_ext
    );
    // The 0–1 km layer: τ, ω, g of the file's 0 km line.
    let o = job.atmosphere.optics[0][0];
    assert!((o.sigma_aerosol_ext - 0.05607528).abs() < 1e-12);
    assert!((o.sigma_aerosol_sca / o.sigma_aerosol_ext - 0.897644203).abs() < 1e-9);
    assert!((o.aerosol_g - 0.671991).abs() < 1e-12);
    assert_eq!(job.planet.top_km, 120.0);
}

#[test]
fn errors_name_the_line() {
    let cases: &[(&str, usize, &str)] = &[
        ("atmosphere_file afglus\nfoo 1\n", 2, "unknown keyword `foo`"),
        (
            "atmosphere_file afglus\nwavelength 540\nsza\n",
            3,
            "`sza`: missing value",
        ),
        (
            "atmosphere_file afglus\nwavelength 540\nsza 30 40\n",
            3,
            "too many values",
        ),
        (
            "atmosphere_file afglus\nwavelength 540\nalbedo x\n",
            3,
            "`x` is not a number",
        ),
        (
            "atmosphere_file afglus\nwavelength 540\nalbedo 1.5\n",
            3,
            "out of range",
        ),
        (
            "wavelength 540\n\numu -0.5 1.2\n",
            3,
            "`umu` = 1.2: out of range (valid: -1 to 1)",
        ),
        ("wavelength 540\numu\n", 2, "`umu`: missing value"),
        ("wavelength 540 560\n", 1, "one wavelength"),
        ("wavelength 540\nmol_modify NO2 0.3 DU\n", 2, "no absorption by NO2"),
        ("wavelength 540\nmol_modify O3 300 kg\n", 2, "unit `kg`"),
        ("wavelength 540\ncrs_model o3 Daumont\n", 2, "not available"),
        ("wavelength 540\nmol_abs_param reptran\n", 2, "cross sections only"),
        ("wavelength 540\noutput_quantity reflectivity\n", 2, "not supported"),
        ("wavelength 540\nrte_solver foo\n", 2, "unknown"),
        ("wavelength 540\nsource thermal\n", 2, "source solar"),
        ("wavelength 540\noutput_user lambda foo\n", 2, "column `foo`"),
        (
            "wavelength 540\naerosol_file tau missing.dat\n",
            2,
            "cannot read `missing.dat`",
        ),
        ("wavelength 540\npolradtran nstokes 2\n", 2, "valid: 1, 3, 4"),
        ("atmosphere_file afglus\n", 1, "no `wavelength`"),
        ("wavelength 540\n", 1, "no `atmosphere_file`"),
        (
            "atmosphere_file afglus\nwavelength 540\numu 0.5\n",
            3,
            "both `umu` and `phi`",
        ),
        (
            "atmosphere_file afglus\nwavelength 540\naerosol_default\nquiet\n",
            3,
            "Shettle",
        ),
        (
            "atmosphere_file afglus\nwavelength 540\naerosol_visibility 20\n",
            3,
            "needs `aerosol_species_file`",
        ),
    ];
    for (text, line, needle) in cases {
        let (l, message) = error(text);
        assert_eq!(l, *line, "{text:?}: {message}");
        assert!(message.contains(needle), "{text:?}: `{message}` lacks `{needle}`");
    }
    let e = parse("atmosphere_file afglus\nfoo 1\n").unwrap_err();
    assert!(e.is_user_error());
    assert_eq!(e.to_string(), "t.inp:2: unknown keyword `foo`");
}

#[test]
fn job_errors_point_at_the_keyword() {
    // 5000 nm is outside the Bodhaine range: reported at the wavelength line.
    let u = parse("atmosphere_file afglus\nquiet\nwavelength 5000\n").unwrap();
    match u.job(10, 1, false) {
        Err(Error::Uvspec { line, message, .. }) => {
            assert_eq!(line, 3, "{message}");
            assert!(message.contains("wavelength"), "{message}");
        }
        other => panic!("{other:?}"),
    }
}
