//! `atmosim transmittance` as a user runs it: per-task CSV and EXR with
//! metadata, and bad grids refused with exit code 2.

mod common;

use atmosim::io::exr::read_exr;
use common::atmosim;

#[test]
fn writes_csv_and_exr_per_task_with_metadata() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("job.toml"),
        "[atmosphere]\nvisibility_km = [20.0, 60.0]\n[spectrum]\nwavelengths_nm = [400.0, 700.0]\n\
         [observer]\naltitude_km = 1.0\n[transmittance]\naltitude_nodes = 4\ndistance_nodes = 5\nsamples = 50\nexport_sqrt = true\n",
    )
    .unwrap();
    let out = atmosim()
        .current_dir(dir.path())
        .args(["transmittance", "job.toml", "--out", "tables", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for task in ["vis020.0_alt01000m", "vis060.0_alt01000m"] {
        let base = dir.path().join("tables").join(task);
        let csv = std::fs::read_to_string(base.join("transmittance.csv")).unwrap();
        let mut lines = csv.lines();
        assert_eq!(
            lines.next(),
            Some("wavelength_nm,altitude_km,distance_km,T,T_se,blocked,sqrt_T")
        );
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 2 * 4 * 5);
        for r in &rows {
            assert!((0.0..=1.0).contains(&r[3]) && r[4] >= 0.0);
            assert!((r[6] * r[6] - r[3]).abs() < 1e-8);
            if r[5] == 1.0 {
                assert_eq!(r[3], 0.0);
            }
        }
        // The default layout: a_i = 100·(i/3)³, d_j = 1571.524·(j/4)⁴.
        assert!(
            rows.iter()
                .any(|r| (r[1] - 100.0 / 27.0).abs() < 1e-12 && (r[2] - 1571.524 / 256.0).abs() < 1e-12)
        );
        let exr = read_exr(&base.join("transmittance.exr")).unwrap();
        assert_eq!((exr.width, exr.height), (5, 4));
        let attrs = &exr.attributes;
        let names: Vec<&str> = exr.channels.iter().map(|c| c.name.as_str()).collect();
        for n in ["400nm.T", "400nm.T_se", "400nm.sqrtT", "700nm.T", "blocked"] {
            assert!(names.contains(&n), "{n} missing: {names:?}");
        }
        let attr = |k: &str| {
            attrs
                .iter()
                .find(|(a, _)| a == k)
                .map(|(_, v)| v.clone())
                .unwrap_or_default()
        };
        assert_eq!(attr("estimator"), "ratio_tracking");
        assert_eq!(attr("samples"), "50");
        assert_eq!(attr("task"), task);
        assert_eq!(attr("job_hash").len(), 16);
        assert!(attr("grid").contains("^3") && attr("units").starts_with('1'));
    }
}

#[test]
fn bad_grids_are_refused() {
    for (section, key) in [
        ("altitude_nodes = 1\n", "transmittance.altitude_nodes"),
        ("distance_nodes = 0\n", "transmittance.distance_nodes"),
        ("distances_km = [0.0, -5.0]\n", "transmittance.distances_km"),
        ("altitudes_km = [0.0, 150.0]\n", "transmittance.altitudes_km"),
        ("altitudes_km = [1.0]\n", "transmittance.altitudes_km"),
        ("estimator = \"guess\"\n", "guess"),
        (
            "layout = \"sky_model\"\nmax_distance_km = 100.0\n",
            "transmittance.max_distance_km",
        ),
        (
            "layout = \"sky_model\"\naltitudes_km = [0.0, 1.0]\n",
            "transmittance.altitudes_km",
        ),
        ("layout = \"grid\"\n", "grid"),
    ] {
        common::assert_refused("transmittance", &format!("[transmittance]\n{section}"), &[key]);
    }
}

/// `layout = "sky_model"`: the sky-model runtime's nodes, a_i = 100 km·(i/N)³
/// and d_j = 1571.524 km·(j/N)⁴ from i, j = 0 (i/N, not i/(N − 1)).
#[test]
fn the_sky_model_layout_has_the_runtimes_nodes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("job.toml"),
        "[spectrum]\nwavelengths_nm = [550.0]\n[observer]\naltitude_km = 1.0\n\
         [transmittance]\nlayout = \"sky_model\"\naltitude_nodes = 4\ndistance_nodes = 5\nestimator = \"analytic\"\n",
    )
    .unwrap();
    let out = atmosim()
        .current_dir(dir.path())
        .args(["transmittance", "job.toml", "--out", "tables", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let exr = read_exr(&dir.path().join("tables").join("transmittance.exr")).unwrap();
    let attr = |k: &str| exr.attributes.iter().find(|(a, _)| a == k).unwrap().1.clone();
    let list = |k: &str| -> Vec<f64> { attr(k).split(' ').map(|v| v.parse().unwrap()).collect() };
    let a = list("altitudes_km");
    let d = list("distances_km");
    assert_eq!(a.len(), 4);
    assert_eq!(d.len(), 5);
    for (i, &x) in a.iter().enumerate() {
        assert!((x - 100.0 * (i as f64 / 4.0).powi(3)).abs() < 1e-12, "a_{i} = {x}");
    }
    for (j, &x) in d.iter().enumerate() {
        assert!((x - 1571.524 * (j as f64 / 5.0).powi(4)).abs() < 1e-9, "d_{j} = {x}");
    }
    assert!(attr("grid").starts_with("sky_model"));
}
