//! The pseudo-spherical geometry (plane-parallel transport, direct beam
//! through spherical shells) and explicit aerosol layers on a profile
//! atmosphere, as jobs state them.

use std::path::Path;

use atmosim::job::Job;

fn job(text: &str) -> Job {
    Job::parse(text, "test.toml", Path::new(".")).unwrap_or_else(|e| panic!("{e}"))
}

const ATMOSPHERE: &str = "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [540.0]\n\
                          [sun]\nzenith_deg = 80.0\n";

#[test]
fn pseudo_spherical_direct_beam_is_the_spherical_one() {
    let text = |g: &str| format!("[planet]\nradius_km = 6370.0\ntop_km = 120.0\ngeometry = \"{g}\"\n{ATMOSPHERE}");
    let (pp, ps, sph) = (
        job(&text("plane_parallel")),
        job(&text("pseudo_spherical")),
        job(&text("spherical")),
    );
    assert_eq!(ps.pseudo_spherical_radius_km(), Some(6370.0));
    assert!(ps.plane_parallel_transport() && pp.plane_parallel_transport() && !sph.plane_parallel_transport());
    for z in [0.0, 3.7, 10.0] {
        let t_ps = ps.scene(0).direct_normal(z, 0, false);
        let t_sph = sph.scene(0).direct_normal(z, 0, false);
        let t_pp = pp.scene(0).direct_normal(z, 0, false);
        assert!((t_ps / t_sph - 1.0).abs() < 1e-12, "{z}: {t_ps} vs {t_sph}");
        // Plane-parallel: exp(−τ(z)/μ0) exactly.
        let atm = &pp.atmosphere;
        let tau_above: f64 = (0..atm.layer_count())
            .map(|i| {
                let (z0, z1) = (atm.levels_km[i].max(z), atm.levels_km[i + 1]);
                let o = atm.optics[0][i];
                (z1 - z0).max(0.0) * o.sigma_t()
            })
            .sum();
        let mu0 = 80f64.to_radians().cos();
        assert!((t_pp / (-tau_above / mu0).exp() - 1.0).abs() < 1e-12);
        // At 80° the spherical air mass is smaller: more direct light.
        assert!(t_ps > t_pp * 1.01, "{z}: {t_ps} vs {t_pp}");
    }
    // Shared spectral paths see the same pseudo-spherical beam.
    let two = job(&text("pseudo_spherical").replace("[540.0]", "[540.0, 600.0]"));
    let shared = two.spectral_scene(&two.tasks[0]).expect("shared paths");
    for z in [0.0, 3.7, 10.0] {
        let t_ps = ps.scene(0).direct_normal(z, 0, false);
        let t_shared = shared.direct_normal(z, 0, false);
        assert!((t_shared / t_ps - 1.0).abs() < 1e-12, "{z}: {t_shared} vs {t_ps}");
    }
}

#[test]
fn aerosol_layers_split_over_the_profile_layers() {
    // One aerosol layer 0.5–2.5 km over the 1 km AFGL layers: halves at the
    // ends, ω and g as given, nothing elsewhere.
    let text = "[planet]\ntop_km = 120.0\n[atmosphere]\n[[atmosphere.aerosol_layers]]\nbottom_km = 0.5\ntop_km = 2.5\n\
                tau = 0.2\nssa = 0.8\ng = 0.6\n[spectrum]\nwavelengths_nm = [540.0]\n";
    let j = job(text);
    let atm = &j.atmosphere;
    let tau = |i: usize| atm.optics[0][i].sigma_aerosol_ext * atm.thickness_km(i);
    assert_eq!(&atm.levels_km[..4], &[0.0, 1.0, 2.0, 3.0]);
    assert!((tau(0) - 0.05).abs() < 1e-12 && (tau(1) - 0.1).abs() < 1e-12 && (tau(2) - 0.05).abs() < 1e-12);
    assert_eq!(tau(3), 0.0);
    assert!((atm.optics[0][1].sigma_aerosol_sca / atm.optics[0][1].sigma_aerosol_ext - 0.8).abs() < 1e-12);
    assert_eq!(atm.optics[0][2].aerosol_g, 0.6);
    assert!(atm.visibility.is_none());
}

#[test]
fn aerosol_layers_refuse_a_mixture_overlaps_and_bad_values() {
    let base = "[atmosphere]\n";
    let layer = |b: f64, t: f64, extra: &str| {
        format!("[[atmosphere.aerosol_layers]]\nbottom_km = {b:?}\ntop_km = {t:?}\ntau = 0.1\n{extra}")
    };
    let err = |text: String| Job::parse(&text, "t.toml", Path::new(".")).unwrap_err().to_string();
    let e = err(format!("[atmosphere]\naerosol = \"urban\"\n{}", layer(0.0, 1.0, "")));
    assert!(
        e.contains("atmosphere.aerosol_layers") && e.contains("aerosol mixture"),
        "{e}"
    );
    let e = err(format!("{base}{}{}", layer(0.0, 2.0, ""), layer(1.0, 3.0, "")));
    assert!(e.contains("overlap"), "{e}");
    let e = err(format!("{base}{}", layer(0.0, 1.0, "ssa = 1.5\n")));
    assert!(e.contains("aerosol_layers[0].ssa"), "{e}");
    let e = err(format!("{base}visibility_km = 20.0\n{}", layer(0.0, 1.0, "")));
    assert!(e.contains("visibility_km"), "{e}");
}
