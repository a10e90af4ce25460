//! Image sensors against the `directions` sensor and against symmetry.

mod common;

use atmosim::film::directions::render_directions;
use atmosim::film::image::{PixelSampling, pixel_weights, render_layer};
use atmosim::job::Sensor;
use atmosim::polarization::stokes_frame::StokesFrame;
use atmosim::sampling::stream::Render;
use atmosim::sensor::camera::{Camera, PixelFilter};
use atmosim::sensor::direction::Direction;
use common::{Comparison, job};

const SKY: &str = "[atmosphere]\naerosol = \"continental_average\"\n[spectrum]\nwavelengths_nm = [450.0]\n\
                   [sun]\nelevation_deg = 25.0\n[ground]\nalbedo = 0.2\n";

/// Meridian-frame sampling of `camera` with stream keys (seed, 0).
fn sampling<'a>(
    job: &atmosim::job::Job,
    camera: &'a Camera,
    weights: &'a [f64],
    filter: PixelFilter,
    samples: u64,
    seed: u64,
) -> PixelSampling<'a> {
    PixelSampling {
        camera,
        traced_rows: camera.size().1,
        traced_columns: camera.size().0,
        weights,
        filter,
        frame: StokesFrame::Meridian,
        sun: job.tasks[0].sun.direction,
        samples,
        seed,
        render: Render::channel(0, 0),
        pilot: false,
    }
}

fn camera_of(text: &str) -> (atmosim::job::Job, Camera) {
    let j = job(text);
    let Sensor::Image(c) = j.render.sensor.clone() else {
        panic!("not an image")
    };
    (j, c)
}

#[test]
fn fisheye_pixels_agree_with_directions_runs() {
    for projection in ["equidistant", "equisolid", "stereographic"] {
        let (j, cam) = camera_of(&format!(
            "{SKY}[sensor]\ntype = \"fisheye\"\nresolution = 16\nprojection = \"{projection}\"\npixel_filter = \"center\"\n"
        ));
        let scene = j.scene(0);
        let weights = pixel_weights(&cam);
        let (tallies, _) = render_layer(
            &scene,
            &sampling(&j, &cam, &weights, PixelFilter::Center, 4000, 1),
            0.0,
            &|_| {},
        );
        let mut cmp = Comparison::default();
        for (i, jj) in [(8usize, 8usize), (3, 8), (8, 2), (12, 11), (5, 13)] {
            let ray = cam.ray_at(i as f64 + 0.5, jj as f64 + 0.5).unwrap();
            let v = ray.direction;
            let d = Direction {
                view_zenith_deg: v.z.acos().to_degrees(),
                azimuth_deg: v.y.atan2(v.x).to_degrees(),
            };
            // Independent streams (another seed).
            let reference = &render_directions(&scene, 0.0, &[d], 4000, 99, Render::channel(0, 0))[0];
            let pixel = &tallies[jj * 16 + i];
            for k in 0..3 {
                cmp.add(
                    || format!("{projection} pixel ({i}, {jj}) Stokes {k}"),
                    pixel.mean()[k],
                    pixel.standard_error()[k],
                    reference.mean()[k],
                    reference.standard_error()[k],
                );
            }
        }
        assert!(cmp.max_abs_z < 4.0, "{projection}: {}", cmp.worst);
    }
}

#[test]
fn box_filtered_pixels_average_their_solid_angle() {
    // A coarse panorama's pixel holds the mean radiance over its solid
    // angle: compare with the mean of many centre-filtered sub-pixels of a
    // 4× finer panorama over the same area (solid-angle weighted).
    let (j, coarse) = camera_of(&format!("{SKY}[sensor]\ntype = \"panorama\"\nresolution = [6, 6]\n"));
    let scene = j.scene(0);
    let cw = pixel_weights(&coarse);
    let (c_tallies, _) = render_layer(
        &scene,
        &sampling(&j, &coarse, &cw, PixelFilter::Box, 20_000, 3),
        0.0,
        &|_| {},
    );
    let fine = Camera::Panorama { width: 24, height: 24 };
    let fw = pixel_weights(&fine);
    let (f_tallies, _) = render_layer(
        &scene,
        &sampling(&j, &fine, &fw, PixelFilter::Box, 1_500, 4),
        0.0,
        &|_| {},
    );
    let mut cmp = Comparison::default();
    for (ci, cj) in [(1usize, 1usize), (3, 2), (4, 4)] {
        let (mut num, mut var, mut den) = (0.0, 0.0, 0.0);
        for a in 0..4 {
            for b in 0..4 {
                let k = (cj * 4 + b) * 24 + ci * 4 + a;
                num += fw[k] * f_tallies[k].mean()[0];
                var += (fw[k] * f_tallies[k].standard_error()[0]).powi(2);
                den += fw[k];
            }
        }
        let c = &c_tallies[cj * 6 + ci];
        cmp.add(
            || format!("pixel ({ci}, {cj})"),
            c.mean()[0],
            c.standard_error()[0],
            num / den,
            var.sqrt() / den,
        );
    }
    assert!(cmp.max_abs_z < 4.0, "{}", cmp.worst);
}

#[test]
fn images_are_mirror_symmetric_about_the_sun_vertical() {
    // The sun lies in the x–z plane: I and Q are even and U odd in the
    // azimuth, i.e. across the image's vertical centre line.
    for sensor in [
        "type = \"fisheye\"\nresolution = 12\n",
        "type = \"fisheye\"\nresolution = 12\nhemisphere = \"down\"\nprojection = \"equisolid\"\n",
        "type = \"panorama\"\nresolution = [12, 10]\n",
    ] {
        let (j, cam) = camera_of(&format!("{SKY}[observer]\naltitude_km = 2.0\n[sensor]\n{sensor}"));
        let scene = j.scene(0);
        let weights = pixel_weights(&cam);
        let (t, _) = render_layer(
            &scene,
            &sampling(&j, &cam, &weights, PixelFilter::Box, 2_000, 5),
            2.0,
            &|_| {},
        );
        let (w, h) = cam.size();
        let mut cmp = Comparison::default();
        for y in 0..h {
            for x in 0..w / 2 {
                let (a, b) = (&t[y * w + x], &t[y * w + (w - 1 - x)]);
                if a.samples == 0 {
                    continue;
                }
                for (k, sign) in [(0, 1.0), (1, 1.0), (2, -1.0)] {
                    cmp.add(
                        || format!("{sensor} ({x}, {y}) Stokes {k}"),
                        a.mean()[k],
                        a.standard_error()[k],
                        sign * b.mean()[k],
                        b.standard_error()[k],
                    );
                }
            }
        }
        cmp.assert_no_outlier(&format!("mirror symmetry {sensor}"));
    }
}

#[test]
fn pixels_below_the_horizon_of_an_observer_on_the_ground_share_the_ground_view() {
    // A sphere image seen from the ground: its lower rows are not traced
    // but hold one estimate of the ground's radiance, traced straight down
    // with 16 times a pixel's samples. It must be what each of those
    // directions sees on its own (independent directions runs), with Q, U
    // and V exactly 0 (a Lambertian depolarising ground at the eye).
    let (j, cam) = camera_of(&format!(
        "{SKY}[sensor]\ntype = \"sphere\"\nresolution = [8, 4]\n[render]\nsamples = 400\nseed = 7\n"
    ));
    let task = &j.tasks[0];
    let (layout, state) = atmosim::run::task::render_whole(&j, task, &|_| {}, &|_| {}).unwrap();
    assert_eq!(layout.traced_rows, 2);
    let view = layout
        .results(&state)
        .find(|(e, _)| matches!(e.kind, atmosim::run::layout::EstimateKind::GroundView { .. }))
        .map(|(_, t)| t[0])
        .unwrap();
    assert_eq!(view.samples, 16 * 400);
    let image = atmosim::run::assemble::image_result(&j, &cam, &layout, &state);
    let layer = &image.layers[0];
    let ground = 2 * 8;
    let (i0, se0) = (layer.mean[0][ground], layer.se[0][ground]);
    assert!(i0 > 0.0 && se0 > 0.0);
    for p in ground..32 {
        assert_eq!((layer.mean[0][p], layer.se[0][p]), (i0, se0), "pixel {p}");
        for k in 1..4 {
            assert_eq!((layer.mean[k][p], layer.se[k][p]), (0.0, 0.0), "pixel {p} Stokes {k}");
        }
    }
    // The sky's pixels have their own values.
    assert!(layer.mean[0][..ground].iter().all(|&m| m > 0.0 && m != i0));
    let scene = j.scene(0);
    let downward = common::directions(&[(180.0, 0.0), (100.0, 30.0), (135.0, 200.0), (160.0, 90.0)]);
    let reference = render_directions(&scene, 0.0, &downward, 6400, 99, Render::channel(0, 0));
    let mut cmp = Comparison::default();
    for (d, r) in reference.iter().enumerate() {
        cmp.add(|| format!("direction {d}"), i0, se0, r.mean()[0], r.standard_error()[0]);
        assert!(r.mean()[1].abs() + r.mean()[2].abs() == 0.0);
    }
    cmp.assert_no_outlier("ground view against downward directions");
}

/// The camera, layout and image of the first task of the job `text`,
/// rendered whole.
fn whole_image(text: &str) -> (Camera, atmosim::run::layout::Layout, atmosim::film::image::SkyImage) {
    let (j, cam) = camera_of(text);
    let (layout, state) = atmosim::run::task::render_whole(&j, &j.tasks[0], &|_| {}, &|_| {}).unwrap();
    let image = atmosim::run::assemble::image_result(&j, &cam, &layout, &state);
    (cam, layout, image)
}

/// Adds I, Q and U of pixel `p` of layer `a` against the same pixel of
/// layer `b` (independent paths) to `cmp`.
fn add_pixel(
    cmp: &mut Comparison,
    label: &str,
    a: &atmosim::film::image::ImageLayer,
    b: &atmosim::film::image::ImageLayer,
    p: usize,
) {
    for k in 0..3 {
        cmp.add(
            || format!("{label} Stokes {k}"),
            a.mean[k][p],
            a.se[k][p],
            b.mean[k][p],
            b.se[k][p],
        );
    }
}

#[test]
fn mirrored_columns_are_the_traced_ones_seen_in_a_mirror() {
    // `sensor.symmetry = "mirror"` (the default) traces the left half of an
    // image and fills the right half with its mirror image: the traced half
    // bit for bit what a render of every column gives, each mirrored pixel
    // exactly its partner's I and Q with U and V negated, and that right
    // half in agreement with the same columns traced (independent paths),
    // with enough polarisation that a wrong sign of U would be caught.
    for (sensor, observer_km) in [
        ("type = \"sphere\"\nresolution = [16, 8]\n", 2.0),
        ("type = \"sphere\"\nresolution = [15, 6]\n", 0.0),
        (
            "type = \"panorama\"\nresolution = [12, 10]\nstokes_frame = \"sun_view\"\n",
            2.0,
        ),
        (
            "type = \"fisheye\"\nresolution = 12\nhemisphere = \"down\"\nprojection = \"equisolid\"\n",
            3.0,
        ),
        (
            "type = \"fisheye\"\nresolution = 11\nstokes_frame = \"sun_view\"\n",
            0.0,
        ),
    ] {
        let render = |symmetry: &str| {
            whole_image(&format!(
                "{SKY}[observer]\naltitude_km = {observer_km}\n[sensor]\n{sensor}symmetry = \"{symmetry}\"\n\
                 [render]\nsamples = 600\nseed = 3\n"
            ))
        };
        let (cam, all, every) = render("none");
        let (_, half, mirrored) = render("mirror");
        let (w, h) = cam.size();
        let traced = w.div_ceil(2);
        assert_eq!(half.traced_columns, traced);
        // Half the paths (an odd width traces its middle column as well).
        let whole = atmosim::run::shard::Shard::WHOLE;
        let active =
            |j: usize, cols: std::ops::Range<usize>| cols.filter(|i| cam.active_columns(j).contains(i)).count();
        let expected: usize = (0..all.traced_rows).map(|j| active(j, 0..traced)).sum();
        assert_eq!(
            half.paths(whole),
            600 * expected as u64 + all.paths(whole) - 600 * all.active.as_ref().unwrap().count()
        );
        let (a, b) = (&every.layers[0], &mirrored.layers[0]);
        let mut cmp = Comparison::default();
        let mut polarised = 0;
        for j in 0..h {
            for i in cam.active_columns(j) {
                let p = j * w + i;
                if i < traced || j >= all.traced_rows {
                    for k in 0..4 {
                        assert_eq!(
                            (a.mean[k][p], a.se[k][p]),
                            (b.mean[k][p], b.se[k][p]),
                            "{sensor} ({i}, {j})"
                        );
                    }
                    continue;
                }
                let q = j * w + (w - 1 - i);
                for (k, sign) in [(0, 1.0), (1, 1.0), (2, -1.0), (3, -1.0)] {
                    assert_eq!(b.mean[k][p], sign * b.mean[k][q], "{sensor} ({i}, {j}) Stokes {k}");
                    assert_eq!(b.se[k][p], b.se[k][q]);
                }
                add_pixel(&mut cmp, &format!("{sensor} ({i}, {j})"), b, a, p);
                let u_z = a.mean[2][p] / (a.se[2][p].powi(2) + b.se[2][p].powi(2)).sqrt();
                if u_z.abs() > 5.0 {
                    polarised += 1;
                }
            }
        }
        cmp.assert_no_outlier(&format!("mirrored against traced columns, {sensor}"));
        // Pixels where U with the wrong sign would stand 10 or more combined
        // standard errors off (U is small in the sun-view frame, where
        // single scattering gives none: 7.6 and 8.7 at most there).
        assert!(polarised >= 1, "{sensor}: no pixel with |U| above 5 standard errors");
    }
}

#[test]
fn with_the_sun_at_the_zenith_every_column_is_the_first_one_turned() {
    // `symmetry = "auto"` (the default) traces one column of an
    // equirectangular image under a sun at the zenith and copies it to
    // every other: that column bit for bit what a render of every column
    // gives it, and the other columns, traced with independent paths,
    // in agreement with it (Q strongly polarised, so a frame that did not
    // turn with the azimuth would be caught).
    //
    // Seed 5 since 2026-11-29: with the day's roulette threshold (0.1 under
    // this zenith sun) seed 4 put the sphere's column 0 of row 4 4.0
    // standard errors high, so 15 comparisons against it read up to 4.36
    // (threshold 4.19). Over seeds 1-16 the two thresholds calibrate alike
    // (mean z² over the sphere's 360 comparisons 0.750 with 0.1, 0.758
    // with 0.03; 1 and 0 seeds over the threshold), the pixel's direction
    // agrees at 400,000 paths and its largest sample is 4-6 times the mean
    // (docs/lab-notes/2026-11-29.md, "The day roulette's failed test").
    for (sensor, observer_km) in [
        ("type = \"sphere\"\nresolution = [16, 8]\n", 2.0),
        (
            "type = \"panorama\"\nresolution = [9, 6]\nstokes_frame = \"sun_view\"\n",
            0.0,
        ),
    ] {
        let render = |symmetry: &str| {
            whole_image(&format!(
                "{}[observer]\naltitude_km = {observer_km}\n[sensor]\n{sensor}symmetry = \"{symmetry}\"\n\
                 [render]\nsamples = 600\nseed = 5\n",
                SKY.replace("elevation_deg = 25.0", "elevation_deg = 90.0")
            ))
        };
        let (cam, all, every) = render("none");
        let (_, one, turned) = render("auto");
        assert_eq!(one.symmetry, atmosim::sensor::symmetry::Symmetry::Rotation);
        assert_eq!(one.traced_columns, 1);
        let (w, _) = cam.size();
        let whole = atmosim::run::shard::Shard::WHOLE;
        let traced_rows = all.traced_rows as u64;
        assert_eq!(one.paths(whole), all.paths(whole) - 600 * traced_rows * (w as u64 - 1));
        let (a, b) = (&every.layers[0], &turned.layers[0]);
        let mut cmp = Comparison::default();
        let mut polarised = 0;
        for j in 0..all.traced_rows {
            let first = j * w;
            for k in 0..4 {
                assert_eq!((a.mean[k][first], a.se[k][first]), (b.mean[k][first], b.se[k][first]));
            }
            for i in 1..w {
                let p = j * w + i;
                for k in 0..4 {
                    assert_eq!(
                        (b.mean[k][p], b.se[k][p]),
                        (b.mean[k][first], b.se[k][first]),
                        "{sensor} ({i}, {j})"
                    );
                }
                add_pixel(&mut cmp, &format!("{sensor} ({i}, {j})"), b, a, p);
                if (a.mean[1][p] / (a.se[1][p].powi(2) + b.se[1][p].powi(2)).sqrt()).abs() > 10.0 {
                    polarised += 1;
                }
            }
        }
        cmp.assert_no_outlier(&format!("turned against traced columns, {sensor}"));
        assert!(
            polarised >= 10,
            "{sensor}: {polarised} pixels with |Q| above 10 standard errors"
        );
    }
}
