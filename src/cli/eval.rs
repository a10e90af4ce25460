//! `atmosim eval DATASET`: a sky-model dataset evaluated with the Prague
//! runtime's semantics: a summary of the file, answers to a CSV of the
//! runtime's API arguments, or sphere and fisheye images (EXR + PNG).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use atmosim::physics::solar::SolarSpectrum;
use atmosim::sensor::camera::{Camera, Hemisphere, Projection};
use atmosim::skymodel::dataset::Dataset;
use atmosim::skymodel::eval_image::{EvalView, evaluate, write};
use atmosim::skymodel::queries;
use atmosim::skymodel::runtime::Model;
use clap::ValueEnum;

use super::common::print_text;

#[derive(clap::Args)]
pub struct EvalArgs {
    /// The dataset file (as `atmosim fit` writes it, or any Prague sky model dataset).
    dataset: PathBuf,
    /// Print the dataset's axes and table sizes only.
    #[arg(long)]
    info: bool,
    /// Answer a CSV of queries (columns view_x_m, view_y_m, view_z_m, dir_x, dir_y, dir_z,
    /// sun_elevation_deg, sun_azimuth_deg, visibility_km, albedo, wavelength_nm, distance_m)
    /// on stdout, with sky_radiance, sun_radiance, polarisation, transmittance appended.
    #[arg(long)]
    queries: Option<PathBuf>,
    /// The image's camera: a full sphere (equirectangular, 2:1) or an up-looking fisheye.
    #[arg(long, value_enum, default_value_t = CameraArg::Sphere)]
    camera: CameraArg,
    /// Image height in pixels (a sphere is twice as wide).
    #[arg(long, default_value_t = 256)]
    resolution: usize,
    /// Sun elevation (degrees).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    elevation: f64,
    /// The viewpoint's height above the ground (m; the runtime adds 50 m).
    #[arg(long, default_value_t = 0.0)]
    altitude: f64,
    /// Ground visibility (km; default: the dataset's first).
    #[arg(long)]
    visibility: Option<f64>,
    /// Ground albedo (default: the dataset's first).
    #[arg(long)]
    albedo: Option<f64>,
    /// Output directory of the images.
    #[arg(long, default_value = "out/eval")]
    out: PathBuf,
}

#[derive(Clone, Copy, ValueEnum)]
enum CameraArg {
    Sphere,
    Fisheye,
}

fn invalid(key: &str, value: impl std::fmt::Display, valid: &str) -> atmosim::Error {
    atmosim::Error::InvalidValue {
        file: "command line".into(),
        key: key.into(),
        value: value.to_string(),
        reason: "out of range".into(),
        valid: valid.into(),
    }
}

pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    let dataset = Dataset::read(&args.dataset)?;
    if args.info {
        return print_text(&format!("{}: {dataset}\n", args.dataset.display()));
    }
    let name = args.dataset.display().to_string();
    let model = Model::new(&name, dataset, SolarSpectrum::kurucz()?)?;
    if let Some(q) = &args.queries {
        let text = std::fs::read_to_string(q).map_err(|e| atmosim::Error::io(q, e))?;
        let answer = queries::answer(&model, &text, &q.display().to_string())?;
        return print_text(&answer);
    }
    let axes = &model.dataset().axes;
    if !(1..=8192).contains(&args.resolution) {
        return Err(invalid("--resolution", args.resolution, "1 to 8192").into());
    }
    if !(-90.0..=90.0).contains(&args.elevation) {
        return Err(invalid("--elevation", args.elevation, "-90 to 90 degrees").into());
    }
    if !(args.altitude >= 0.0 && args.altitude.is_finite()) {
        return Err(invalid("--altitude", args.altitude, "≥ 0 m").into());
    }
    let albedo = args.albedo.unwrap_or(axes.albedos[0]);
    if !(0.0..=1.0).contains(&albedo) {
        return Err(invalid("--albedo", albedo, "0 to 1").into());
    }
    let visibility = args.visibility.unwrap_or(axes.visibilities_km[0]);
    if !(visibility > 0.0 && visibility.is_finite()) {
        return Err(invalid("--visibility", visibility, "> 0 km").into());
    }
    let camera = match args.camera {
        CameraArg::Sphere => Camera::Sphere {
            width: 2 * args.resolution,
            height: args.resolution,
        },
        CameraArg::Fisheye => Camera::Fisheye {
            resolution: args.resolution,
            hemisphere: Hemisphere::Up,
            projection: Projection::Equidistant,
        },
    };
    let wavelengths_nm: Vec<f64> = (0..axes.channels)
        .map(|c| axes.channel_start_nm + (c as f64 + 0.5) * axes.channel_width_nm)
        .collect();
    let view = EvalView {
        viewpoint_z_m: args.altitude,
        sun_elevation_deg: args.elevation,
        visibility_km: visibility,
        albedo,
        wavelengths_nm,
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let start = std::time::Instant::now();
    let image = evaluate(&model, &camera, &view);
    let stem = match args.camera {
        CameraArg::Sphere => "sphere",
        CameraArg::Fisheye => "fisheye",
    };
    let attributes = vec![
        ("dataset".to_string(), name.clone()),
        ("sun_elevation_deg".to_string(), format!("{}", args.elevation)),
        ("viewpoint_z_m".to_string(), format!("{}", args.altitude)),
        ("visibility_km".to_string(), format!("{visibility}")),
        ("albedo".to_string(), format!("{albedo}")),
        (
            "sensor".to_string(),
            match camera {
                Camera::Sphere { width, height } => format!(
                    "sphere (equirectangular) {width}x{height}: x from azimuth +180 to -180 deg, the sun's azimuth at the centre"
                ),
                _ => format!(
                    "fisheye {0}x{0}, hemisphere Up, projection Equidistant; image up = the sun's azimuth",
                    args.resolution
                ),
            },
        ),
    ];
    write(&args.out, stem, &image, &view, &attributes)?;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {}x{} pixels × {} channels in {:.2} s → {}",
        name,
        image.width,
        image.height,
        view.wavelengths_nm.len(),
        start.elapsed().as_secs_f64(),
        args.out.join(format!("{stem}.exr")).display()
    )
    .context("writing to stdout")?;
    Ok(())
}
