//! `atmosim render` with image sensors, as a user runs it: the EXR read
//! back, previews, skipping completed tasks, `plan`, and bad image jobs.

mod common;

use atmosim::io::exr::read_exr;
use common::{atmosim, run_job};

const JOB: &str = "[atmosphere]\nvisibility_km = [30.0, 60.0]\n[spectrum]\nwavelengths_nm = [450.0, 550.0]\n\
                   [sun]\nelevation_deg = 20.0\n[ground]\nalbedo = [0.0, 0.5]\n\
                   [sensor]\ntype = \"fisheye\"\nresolution = 12\n[render]\nsamples = 16\n";

#[test]
fn fisheye_job_writes_stokes_layers_with_errors_and_metadata() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("job.toml"), JOB).unwrap();
    let out = atmosim()
        .current_dir(dir.path())
        .args(["render", "job.toml", "--out", "sky"])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{log}");
    for task in ["vis030.0_elev+20.0_alt00000m", "vis060.0_elev+20.0_alt00000m"] {
        let base = dir.path().join("sky").join(task);
        let exr = read_exr(&base.join("image.exr")).unwrap();
        assert_eq!((exr.width, exr.height), (12, 12));
        for layer in ["450nm_a000", "450nm_a050", "550nm_a000", "550nm_a050"] {
            for c in ["I", "Q", "U", "V", "I_se", "Q_se", "U_se", "V_se"] {
                let name = format!("{layer}.{c}");
                let ch = exr
                    .channels
                    .iter()
                    .find(|x| x.name == name)
                    .unwrap_or_else(|| panic!("{name} missing"));
                assert!(ch.samples.iter().all(|v| v.is_finite()), "{name}");
            }
            let i = &exr
                .channels
                .iter()
                .find(|x| x.name == format!("{layer}.I"))
                .unwrap()
                .samples;
            let se = &exr
                .channels
                .iter()
                .find(|x| x.name == format!("{layer}.I_se"))
                .unwrap()
                .samples;
            // Centre pixel: sky radiance with a positive standard error; corner: outside the circle.
            assert!(i[6 * 12 + 6] > 0.0 && se[6 * 12 + 6] > 0.0);
            assert_eq!(i[0], 0.0);
        }
        let attr = |k: &str| {
            exr.attributes
                .iter()
                .find(|(a, _)| a == k)
                .map(|(_, v)| v.clone())
                .unwrap_or_default()
        };
        assert_eq!(attr("task"), task);
        assert_eq!(attr("units"), "radiance per unit solar irradiance, 1/sr");
        assert!(attr("stokes_frame").starts_with("meridian: "));
        assert_eq!(
            attr("symmetry"),
            "mirror: columns 0 to 5 are traced; column i >= 6 is the mirror image of column 11 - i (the sky is \
             symmetric about the sun's vertical plane: I and Q the same, U and V negated)"
        );
        assert_eq!(attr("samples_per_pixel"), "16");
        assert_eq!(attr("sun_elevation_deg"), "20");
        assert_eq!(attr("albedos"), "0 0.5");
        assert_eq!(attr("job_hash").len(), 16);
        assert_eq!(attr("non_finite_samples"), "0");
        for png in ["preview.png", "dolp.png"] {
            let bytes = std::fs::read(base.join(png)).unwrap();
            assert_eq!(&bytes[1..4], b"PNG");
        }
    }
    // A rerun of the same job skips both tasks and changes nothing.
    let before = std::fs::read(dir.path().join("sky/vis030.0_elev+20.0_alt00000m/image.exr")).unwrap();
    let again = atmosim()
        .current_dir(dir.path())
        .args(["render", "job.toml", "--out", "sky"])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&again.stderr);
    assert!(again.status.success());
    assert_eq!(log.matches("skipped").count(), 2, "{log}");
    assert_eq!(
        before,
        std::fs::read(dir.path().join("sky/vis030.0_elev+20.0_alt00000m/image.exr")).unwrap()
    );
}

#[test]
fn absolute_units_and_the_direct_sun() {
    let dir = tempfile::tempdir().unwrap();
    let job = "[spectrum]\nwavelengths_nm = [550.0]\n[sun]\nelevation_deg = 40.0\nangular_radius_deg = 0.2666\n\
               [sensor]\ntype = \"panorama\"\nresolution = [8, 8]\n[render]\nsamples = 4\n\
               [output]\nunits = \"absolute\"\nsun = true\npreview = false\n";
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    let out = atmosim()
        .current_dir(dir.path())
        .args(["render", "job.toml", "--out", "o", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let exr = read_exr(&dir.path().join("o/image.exr")).unwrap();
    assert!(
        exr.attributes
            .iter()
            .any(|(k, v)| k == "units" && v.starts_with("W m-2 sr-1 nm-1"))
    );
    assert!(!dir.path().join("o/preview.png").exists());
    let sun = std::fs::read_to_string(dir.path().join("o/sun.csv")).unwrap();
    let row: Vec<f64> = sun
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // Kurucz at 550 nm ≈ 1.86 W m-2 nm-1; T at 50° zenith ≈ 0.7; the disc's
    // radiance is the irradiance over its 6.8e-5 sr.
    assert!(row[2] > 0.5 && row[2] < 0.9, "{sun}");
    assert!(row[3] > 0.9 && row[3] < 1.7, "{sun}");
    assert!((row[4] * 6.8e-5 / row[3] - 1.0).abs() < 0.01, "{sun}");
}

#[test]
fn plan_lists_every_task_with_its_cost() {
    let dir = tempfile::tempdir().unwrap();
    // `atmosim plan` of a job file's text: its standard output.
    let plan = |file: &str, job: &str| {
        std::fs::write(dir.path().join(file), job).unwrap();
        let out = atmosim().current_dir(dir.path()).args(["plan", file]).output().unwrap();
        assert!(out.status.success());
        String::from_utf8(out.stdout).unwrap()
    };
    let text = plan("job.toml", JOB);
    assert!(text.contains("task,name,visibility_km,sun_elevation_deg,observer_altitude_km,paths,core_hours"));
    assert!(text.contains("0,vis030.0_elev+20.0_alt00000m,30.0,20.000,0,"));
    assert!(text.contains("1,vis060.0_elev+20.0_alt00000m"));
    // 12×12 fisheye: the pixels of its traced left half (the right half
    // mirrors it) reaching into the circle × 16 samples (the 2 wavelengths
    // and the 2 albedos share the paths), costed at the rate of shared
    // spectral paths.
    let inside = (0..144)
        .filter(|k| k % 12 < 6)
        .filter(|k| {
            let (i, j) = ((k % 12) as f64, (k / 12) as f64);
            (0..256).any(|s| {
                let (x, y) = (
                    i + ((s % 16) as f64 + 0.5) / 16.0 - 6.0,
                    j + ((s / 16) as f64 + 0.5) / 16.0 - 6.0,
                );
                x * x + y * y <= 36.0
            })
        })
        .count();
    assert!(text.contains(&format!(",{},", inside * 16)), "{inside}: {text}");
    assert!(text.contains("shared spectral paths/s per core"), "{text}");
    assert!(
        text.contains("each 12x12 image (its left half traced, the mirror), 2 wavelengths"),
        "{text}"
    );
    // Without shared paths each wavelength has its own.
    let text = plan(
        "separate.toml",
        &JOB.replace("samples = 16\n", "samples = 16\nshared_wavelengths = false\n"),
    );
    assert!(text.contains(&format!(",{},", inside * 16 * 2)), "{inside}: {text}");
    assert!(!text.contains("shared spectral"), "{text}");
    // Each class of sun elevation is calibrated on its first task, and its
    // tasks are costed at its rates: the same paths, different hours.
    let text = plan(
        "classes.toml",
        &JOB.replace("elevation_deg = 20.0", "elevation_deg = [-2.0, 5.0, 30.0]")
            .replace("samples = 16\n", "samples = 400000\n"),
    );
    for (class, task) in [
        ("sun below the horizon (2 tasks): calibrated on task 0", 0),
        ("sun 0° to 10° (2 tasks): calibrated on task 1", 1),
        ("sun 10° and higher (2 tasks): calibrated on task 2", 2),
    ] {
        assert!(text.contains(class), "{class}: {text}");
        assert!(text.contains(&format!("\n{task},")), "{text}");
    }
    let hours: Vec<f64> = text
        .lines()
        .filter(|l| l.chars().next().is_some_and(|c| c.is_ascii_digit()))
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(hours.len(), 6, "{text}");
    let total: f64 = text
        .lines()
        .find(|l| l.starts_with("# total"))
        .and_then(|l| l.split(", ").nth(1))
        .and_then(|h| h.split(' ').next())
        .unwrap()
        .parse()
        .unwrap();
    // The total is printed to 0.1 core-hour, each task to 1e-4.
    assert!((total - hours.iter().sum::<f64>()).abs() <= 0.05 + 6.0 * 5e-5, "{text}");
    // Tasks 0–2 have visibility 30 km and the three suns, 3–5 60 km.
    assert!(hours[0] != hours[2] && hours[0] == hours[3], "{text}");
}

#[test]
fn bad_image_jobs_are_refused_before_anything_is_written() {
    for (text, key) in [
        ("[sensor]\ntype = \"fisheye\"\nresolution = 0\n", "sensor.resolution"),
        (
            "[sensor]\ntype = \"fisheye\"\nprojection = \"orthographic\"\n",
            "orthographic",
        ),
        ("[sensor]\ntype = \"camera\"\n", "camera"),
        (
            "[sensor]\ntype = \"fisheye\"\nresolution = [64, 32]\n",
            "sensor.resolution",
        ),
        ("[observer]\naltitude_km = 150.0\n", "observer.altitude_km"),
        ("[sun]\nelevation_deg = [10.0, 95.0]\n", "sun.elevation_deg"),
        ("[sun]\nelevation_deg = []\n", "sun.elevation_deg"),
        ("[atmosphere]\nvisibility_km = []\n", "atmosphere.visibility_km"),
        ("[observer]\naltitude_km = []\n", "observer.altitude_km"),
        ("[ground]\nalbedo = [0.1, 1.2]\n", "ground.albedo"),
        // Keys of one kind of sensor, which the other would ignore.
        (
            "[sensor]\ntype = \"directions\"\npixel_filter = \"center\"\n",
            "sensor.pixel_filter",
        ),
        ("[sensor]\nresolution = 32\n", "sensor.resolution"),
        (
            "[sensor]\ntype = \"directions\"\nsymmetry = \"none\"\n",
            "sensor.symmetry",
        ),
        ("[sensor]\ntype = \"sphere\"\nsymmetry = \"half\"\n", "symmetry"),
        (
            "[sensor]\ntype = \"sphere\"\nhemisphere = \"down\"\n",
            "sensor.hemisphere",
        ),
        (
            "[sensor]\ntype = \"panorama\"\nprojection = \"equisolid\"\n",
            "sensor.projection",
        ),
        (
            "[sensor]\ntype = \"fisheye\"\nview_zenith_deg = [10.0]\n",
            "sensor.view_zenith_deg",
        ),
        ("[sensor]\ntype = \"sphere\"\nfluxes = true\n", "sensor.fluxes"),
        (
            "[sensor]\ntype = \"fisheye\"\ndirections = [[0.0, 0.0]]\n",
            "sensor.directions",
        ),
    ] {
        common::assert_refused(
            "render",
            &format!("[spectrum]\nwavelengths_nm = [550.0]\n{text}"),
            &[key],
        );
    }
}

#[test]
fn the_quickstart_example_renders() {
    // The README's first command, into a temporary directory.
    let dir = tempfile::tempdir().unwrap();
    let job = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/quickstart.toml");
    let out = atmosim()
        .args(["render", job, "-q", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let exr = read_exr(&dir.path().join("image.exr")).unwrap();
    assert_eq!((exr.width, exr.height), (96, 96));
    assert!(dir.path().join("preview.png").exists());
}

#[test]
fn every_spherical_opac_mixture_renders_the_quickstart_sky() {
    // The quickstart job with each mixture in turn (fewer pixels and
    // paths): Mie aerosol by default, finite radiances, degree of linear
    // polarisation within [0, 1]; and the spheroidal dust refused by key.
    let quickstart = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/quickstart.toml")).unwrap();
    let small = quickstart
        .replace("resolution = 96", "resolution = 12")
        .replace("samples = 256", "samples = 8");
    for (mixture, _) in atmosim::physics::data::OPAC_MIXTURES {
        let job = small.replace("aerosol = \"continental_average\"", &format!("aerosol = \"{mixture}\""));
        assert!(job.contains(mixture));
        if *mixture == "desert_spheroids" {
            common::assert_refused("render", &job, &["atmosphere.aerosol", "desert_spheroids", "desert"]);
            continue;
        }
        let dir = run_job(&job, &["render", "job.toml", "--out", "o", "-q"]);
        let exr = read_exr(&dir.path().join("o/image.exr")).unwrap();
        let mut lit = 0;
        for channel in exr.channels.iter().filter(|c| c.name.ends_with(".I")) {
            let named = |n: String| &exr.channels.iter().find(|c| c.name == n).unwrap().samples;
            let (q, u) = (
                named(channel.name.replace(".I", ".Q")),
                named(channel.name.replace(".I", ".U")),
            );
            for ((i, q), u) in channel.samples.iter().zip(q).zip(u) {
                assert!(i.is_finite() && *i >= 0.0, "{mixture} {}: I = {i}", channel.name);
                if *i > 0.0 {
                    lit += 1;
                    assert!(q.hypot(*u) <= i * (1.0 + 1e-5), "{mixture}: DoLP above 1");
                }
            }
        }
        assert!(lit > 0, "{mixture}: an empty sky");
    }
    // aerosol_phase: only the OPAC mixtures have Mie tables; a value
    // outside the set is named.
    let none = small.replace(
        "aerosol = \"continental_average\"",
        "aerosol = \"none\"\naerosol_phase = \"mie\"",
    );
    common::assert_refused("render", &none, &["atmosphere.aerosol_phase", "\"hg\""]);
    let bad = small.replace("aerosol = \"continental_average\"", "aerosol_phase = \"rayleigh\"");
    common::assert_refused("render", &bad, &["aerosol_phase", "rayleigh"]);
}

#[test]
fn the_direct_sun_table_has_no_undefined_values_for_any_sensor() {
    // (sensor, sun, the header expected, whether the sun is in the image)
    let cases = [
        (
            "type = \"fisheye\"\nresolution = 8",
            "elevation_deg = 40.0",
            "wavelength_nm,sun_zenith_deg,transmittance,direct_normal_irradiance,image_x,image_y",
            true,
        ),
        (
            "type = \"fisheye\"\nresolution = 8",
            "elevation_deg = -2.0\nangular_radius_deg = 0.2666",
            "wavelength_nm,sun_zenith_deg,transmittance,direct_normal_irradiance,sun_radiance,image_x,image_y",
            false,
        ),
        (
            "type = \"directions\"\nview_zenith_deg = [0.0]\nazimuth_deg = [0.0]",
            "elevation_deg = 40.0",
            "wavelength_nm,sun_zenith_deg,transmittance,direct_normal_irradiance",
            false,
        ),
    ];
    for (sensor, sun, header, in_image) in cases {
        let job = format!(
            "[spectrum]\nwavelengths_nm = [450.0, 550.0]\n[sun]\n{sun}\n[sensor]\n{sensor}\n\
             [render]\nsamples = 4\n[output]\nsun = true\npreview = false\n"
        );
        let dir = run_job(&job, &["render", "job.toml", "--out", "o", "-q"]);
        let text = std::fs::read_to_string(dir.path().join("o/sun.csv")).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some(header), "{sensor} {sun}");
        let rows: Vec<&str> = lines.collect();
        assert_eq!(rows.len(), 2, "{text}");
        for row in rows {
            let fields: Vec<&str> = row.split(',').collect();
            assert_eq!(fields.len(), header.split(',').count(), "{row}");
            for (k, f) in fields.iter().enumerate() {
                let image_field = header.split(',').nth(k).unwrap().starts_with("image_");
                if image_field && !in_image {
                    assert_eq!(*f, "", "{sensor} {sun}: {row}");
                } else {
                    let v: f64 = f.parse().unwrap_or_else(|_| panic!("{row}"));
                    assert!(v.is_finite(), "{sensor} {sun}: {row}");
                }
            }
        }
    }
}
