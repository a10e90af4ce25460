//! Fine profiles (`render.tracking_layers`): paths tracked through merged
//! layers give the radiances of the profile's own layers (by day, at
//! twilight with sun-aware connections, bands looking down on a reflecting
//! ground), bit for bit whatever the thread count; "auto" merges only where
//! it may; and the combinations it cannot serve are refused by name.

mod common;

use std::path::{Path, PathBuf};

use atmosim::film::directions::{render_directions, render_directions_all};
use atmosim::job::options::TrackingLayers;
use atmosim::physics::profile::GasProfile;
use atmosim::sampling::stream::Render;
use common::{Comparison, assert_refused, directions, job};

/// The US standard profile every `step_km` to 100 km, written into `dir`.
fn fine_profile(dir: &Path, step_km: f64) -> PathBuf {
    let profile = GasProfile::builtin("us_standard")
        .expect("built in")
        .expect("parses")
        .resampled(step_km, 100.0);
    let file = dir.join("fine.dat");
    std::fs::write(&file, profile.to_afgl_text()).expect("a temporary file");
    file
}

/// A job over the profile in `file` with continental aerosol, the keys of
/// `rest` and `[render]` keys `render`.
fn fine_job(file: &Path, rest: &str, render: &str) -> atmosim::job::Job {
    job(&format!(
        "[atmosphere]\nprofile_file = {:?}\naerosol = \"continental_average\"\n{rest}[render]\n{render}",
        file.display().to_string()
    ))
}

#[test]
fn merged_layers_give_the_radiances_of_the_profiles_own_layers() {
    // US standard every 250 m (400 layers): every channel, albedo and
    // Stokes component of four directions, merged (seed 1) against the
    // profile's own layers (seed 2), Šidák over all of them per case.
    // Merged first, on the same threads: any state a path kept from
    // merged layers would show in the render that follows.
    let dir = tempfile::tempdir().unwrap();
    let file = fine_profile(dir.path(), 0.25);
    let dirs = directions(&[(0.0, 0.0), (75.0, 10.0), (88.0, 180.0), (130.0, 60.0)]);
    for (what, rest, samples) in [
        (
            "by day, connections at collisions",
            "[spectrum]\nwavelengths_nm = [320.0, 550.0]\n[sun]\nelevation_deg = 30.0\n\
             [ground]\nalbedo = [0.0, 0.5]\n",
            20_000,
        ),
        (
            "sun 2° below the horizon, sun-aware connections along flights",
            "[spectrum]\nwavelengths_nm = [320.0, 550.0]\n[sun]\nelevation_deg = -2.0\n\
             [observer]\naltitude_km = 0.5\n[ground]\nalbedo = [0.0, 0.5]\n",
            20_000,
        ),
        (
            "bands seen from 5 km, the first vertex split toward the ground",
            "[spectrum]\nwavelengths_nm = [340.0, 500.0]\nband_width_nm = 40.0\n[sun]\nelevation_deg = 10.0\n\
             [observer]\naltitude_km = 5.0\n[ground]\nalbedo = [0.0, 0.5]\n",
            10_000,
        ),
    ] {
        let merged = fine_job(&file, rest, "tracking_layers = \"merged\"\nseed = 1\n");
        let own = fine_job(&file, rest, "tracking_layers = \"profile\"\nseed = 2\n");
        let render = |j: &atmosim::job::Job| {
            let scene = j.spectral_scene(&j.tasks[0]).expect("two channels share paths");
            render_directions_all(
                &scene,
                j.observer_altitude_km,
                &dirs,
                samples,
                j.render.seed,
                Render::channel(0, 0),
            )
        };
        let (a, b) = (render(&merged), render(&own));
        let mut cmp = Comparison::default();
        for w in 0..2 {
            for albedo in 0..2 {
                cmp.add_tallies(&format!("channel {w} albedo {albedo}"), &a[w][albedo], &b[w][albedo]);
            }
        }
        cmp.assert_no_outlier(&format!("merged vs own layers, {what}"));
    }
}

#[test]
fn merged_layers_are_bit_identical_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let file = fine_profile(dir.path(), 0.25);
    let j = fine_job(
        &file,
        "[spectrum]\nwavelengths_nm = [320.0]\n[sun]\nelevation_deg = 5.0\n[ground]\nalbedo = 0.3\n",
        "",
    );
    let scene = j.scene(0);
    assert_eq!(scene.settings.tracking_layers, TrackingLayers::Merged);
    let dirs = directions(&[(60.0, 30.0), (89.0, 170.0), (120.0, 10.0)]);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render_directions(&scene, 0.0, &dirs, 3_000, 42, Render::channel(0, 0)))
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}

#[test]
fn auto_merges_the_layers_of_fine_layered_spherical_profiles_only() {
    let dir = tempfile::tempdir().unwrap();
    let fine = fine_profile(dir.path(), 0.25);
    let layers = |j: atmosim::job::Job| j.scene(0).settings.tracking_layers;
    let spectrum = "[spectrum]\nwavelengths_nm = [550.0]\n";
    assert_eq!(layers(fine_job(&fine, spectrum, "")), TrackingLayers::Merged);
    // The built-in profile's 49 layers are tracked as they are.
    assert_eq!(layers(job(spectrum)), TrackingLayers::Profile);
    // Nor where merging does not apply: ratio-tracked shadow rays, the
    // smooth medium, plane-parallel slabs.
    for render in ["sun_transmittance = \"ratio_tracking\"\n", "medium = \"smooth\"\n"] {
        assert_eq!(
            layers(fine_job(&fine, spectrum, render)),
            TrackingLayers::Profile,
            "{render}"
        );
    }
    let slab = format!("[planet]\ngeometry = \"plane_parallel\"\n{spectrum}");
    assert_eq!(layers(fine_job(&fine, &slab, "")), TrackingLayers::Profile);
    // A coarse profile may be merged on request.
    let coarse = job(&format!("{spectrum}[render]\ntracking_layers = \"merged\"\n"));
    assert_eq!(layers(coarse), TrackingLayers::Merged);
}

#[test]
fn merged_layers_where_they_cannot_apply_are_refused_by_name() {
    for (keys, words) in [
        (
            "[render]\ntracking_layers = \"merged\"\nmedium = \"smooth\"\n",
            &["render.tracking_layers", "smooth"][..],
        ),
        (
            "[render]\ntracking_layers = \"merged\"\nsun_transmittance = \"ratio_tracking\"\n",
            &["render.tracking_layers", "ratio_tracking"][..],
        ),
        (
            "[planet]\ngeometry = \"plane_parallel\"\n[render]\ntracking_layers = \"merged\"\n",
            &["render.tracking_layers", "spherical"][..],
        ),
        (
            "[render]\ntracking_layers = \"fine\"\n",
            &["tracking_layers", "auto", "profile", "merged"][..],
        ),
    ] {
        let job = format!("[spectrum]\nwavelengths_nm = [550.0]\n[sensor]\nview_zenith_deg = [0.0]\n{keys}");
        assert_refused("render", &job, words);
    }
}
