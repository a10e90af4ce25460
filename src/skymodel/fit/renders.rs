//! The renders a fit reads: image tasks of one or more render jobs' output
//! directories, gathered into the sky model's grid of visibility × ground
//! albedo × observer altitude × sun elevation × channel, each image turned
//! into sphere images by `render_layers`.
//!
//! A task is read from its `image.exr` attributes and `task.toml`.
//! Everything is checked before any image is read: every configuration
//! present once, the same wavelengths, albedos, units and planet in every
//! task.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::io::exr::read_exr_attributes;
use crate::io::sky_image::IMAGE_FILE;
use crate::polarization::stokes_frame::StokesFrame;
use crate::sensor::camera::{Camera, Hemisphere, Projection};
use crate::skymodel::angles::PLANET_RADIUS_M;

/// How one configuration's sky was rendered.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// One full-sphere image.
    Sphere { exr: PathBuf, camera: Camera },
    /// An up- and a down-looking fisheye.
    Fisheyes {
        up: PathBuf,
        up_camera: Camera,
        down: PathBuf,
        down_camera: Camera,
    },
}

/// One configuration of the grid (all albedos and channels inside).
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigRender {
    pub visibility_km: f64,
    pub altitude_km: f64,
    pub elevation_deg: f64,
    pub source: Source,
    /// The Stokes frame the images were written in.
    pub frame: StokesFrame,
    /// Samples per pixel (of each image); for a render to a noise target,
    /// the task's paths over the image's pixels (a mean over the image,
    /// the mirrored half counting as none).
    pub samples: u64,
}

/// The rendered grid, checked and ordered.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderGrid {
    pub visibilities_km: Vec<f64>,
    pub albedos: Vec<f64>,
    pub altitudes_km: Vec<f64>,
    pub elevations_deg: Vec<f64>,
    pub wavelengths_nm: Vec<f64>,
    pub channel_start_nm: f64,
    pub channel_width_nm: f64,
    /// Every image carries Q and U.
    pub polarised: bool,
    /// The configurations, visibility (outermost) → altitude → elevation.
    pub configs: Vec<ConfigRender>,
    /// The render jobs' hashes and files, for provenance.
    pub jobs: Vec<(String, String)>,
    /// The atmosphere as the images state it (profile, aerosol).
    pub atmosphere: String,
}

impl RenderGrid {
    /// The configuration at grid indices (visibility, altitude, elevation).
    pub fn config(&self, vis: usize, alt: usize, elev: usize) -> &ConfigRender {
        &self.configs[(vis * self.altitudes_km.len() + alt) * self.elevations_deg.len() + elev]
    }

    /// The elevations just below and above the horizon when the grid has
    /// both but no 0° node. The runtime measures α from the shadow point
    /// below the horizon and from the zenith above it, and between those
    /// two nodes reads both tables in the query's α: one of them in the
    /// other's coordinates.
    pub fn horizon_gap(&self) -> Option<(f64, f64)> {
        let below = self
            .elevations_deg
            .iter()
            .copied()
            .filter(|&e| e < 0.0)
            .reduce(f64::max)?;
        let above = self
            .elevations_deg
            .iter()
            .copied()
            .filter(|&e| e > 0.0)
            .reduce(f64::min)?;
        (!self.elevations_deg.contains(&0.0)).then_some((below, above))
    }

    /// The grid of the visibilities `range` (indices) alone: a shard of
    /// the fit.
    pub fn visibilities(&self, range: std::ops::Range<usize>) -> RenderGrid {
        let per_visibility = self.altitudes_km.len() * self.elevations_deg.len();
        RenderGrid {
            visibilities_km: self.visibilities_km[range.clone()].to_vec(),
            configs: self.configs[range.start * per_visibility..range.end * per_visibility].to_vec(),
            ..self.clone()
        }
    }
}

/// The attributes of one task's image that the grid needs.
struct TaskInfo {
    dir: PathBuf,
    camera: Camera,
    visibility_km: f64,
    altitude_km: f64,
    elevation_deg: f64,
    wavelengths_nm: Vec<f64>,
    band_width_nm: Vec<f64>,
    albedos: Vec<f64>,
    units: String,
    frame: StokesFrame,
    polarised: bool,
    samples: u64,
    job: (String, String),
    atmosphere: String,
}

/// Finds and checks every image task under `dirs` (a directory that holds
/// `image.exr` itself is one task; otherwise each subdirectory that holds
/// one is).
pub fn scan(dirs: &[PathBuf]) -> Result<RenderGrid> {
    let mut tasks = Vec::new();
    for dir in dirs {
        if !dir.is_dir() {
            return Err(Error::data(
                dir.display().to_string(),
                "not a directory (`renders` names a render job's output directory)",
            ));
        }
        if dir.join(IMAGE_FILE).is_file() {
            tasks.push(task_info(dir)?);
            continue;
        }
        let mut subdirs: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(|e| Error::io(dir, e))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.join(IMAGE_FILE).is_file())
            .collect();
        subdirs.sort();
        if subdirs.is_empty() {
            return Err(Error::data(
                dir.display().to_string(),
                format!("no task directory with an {IMAGE_FILE} (render the job first, and `atmosim merge` shards)"),
            ));
        }
        for sub in subdirs {
            tasks.push(task_info(&sub)?);
        }
    }
    grid_of(tasks)
}

fn task_info(dir: &Path) -> Result<TaskInfo> {
    let exr = dir.join(IMAGE_FILE);
    let name = exr.display().to_string();
    let attrs: BTreeMap<String, String> = read_exr_attributes(&exr)
        .ok_or_else(|| Error::data(&name, "not a readable OpenEXR file"))?
        .into_iter()
        .collect();
    let get = |k: &str| {
        attrs
            .get(k)
            .cloned()
            .ok_or_else(|| Error::data(&name, format!("no `{k}` attribute: not an atmosim image")))
    };
    let number = |k: &str| -> Result<f64> {
        let text = get(k)?;
        text.trim()
            .parse::<f64>()
            .map_err(|_| Error::data(&name, format!("attribute `{k}` = {text:?} is not a number")))
    };
    let list = |k: &str| -> Result<Vec<f64>> {
        get(k)?
            .split_whitespace()
            .map(|v| {
                v.parse::<f64>()
                    .map_err(|_| Error::data(&name, format!("attribute `{k}` holds {v:?}, not a number")))
            })
            .collect()
    };
    let visibility = get("visibility_km")?;
    let visibility_km = if visibility == "none" {
        0.0
    } else {
        number("visibility_km")?
    };
    let radius = number("planet_radius_km")?;
    if (radius * 1000.0 - PLANET_RADIUS_M).abs() > 1e-6 {
        return Err(Error::data(
            &name,
            format!("rendered with planet.radius_km = {radius}; the sky-model runtime assumes 6378 km"),
        ));
    }
    let geometry = get("geometry")?;
    if geometry != "Spherical" {
        return Err(Error::data(
            &name,
            format!("rendered in {geometry} geometry; a sky model needs spherical shells"),
        ));
    }
    let frame_text = get("stokes_frame")?;
    let frame = if frame_text.starts_with("sun_view") {
        StokesFrame::SunView
    } else {
        StokesFrame::Meridian
    };
    let task_toml = std::fs::read_to_string(dir.join("task.toml")).map_err(|e| Error::io(dir.join("task.toml"), e))?;
    let table: toml::Table = toml::from_str(&task_toml)
        .map_err(|e| Error::data(dir.join("task.toml").display().to_string(), e.to_string()))?;
    let band_width_nm = table
        .get("band_width_nm")
        .and_then(|v| v.as_array())
        .map(|a| a.iter().filter_map(|x| x.as_float()).collect())
        .unwrap_or_default();
    Ok(TaskInfo {
        dir: dir.to_path_buf(),
        camera: camera_of(&get("sensor")?, &name)?,
        visibility_km,
        altitude_km: number("observer_altitude_km")?,
        elevation_deg: number("sun_elevation_deg")?,
        wavelengths_nm: list("wavelengths_nm")?,
        band_width_nm,
        albedos: list("albedos")?,
        units: get("units")?,
        frame,
        polarised: get("polarized")? == "true",
        samples: match number("samples_per_pixel") {
            Ok(n) => n as u64,
            // A noise target names itself there: the task's paths per pixel.
            Err(_) => {
                let camera = camera_of(&get("sensor")?, &name)?;
                let (w, h) = camera.size();
                let paths = table
                    .get("paths")
                    .and_then(|v| v.as_integer())
                    .ok_or_else(|| Error::data(&name, "a noise-target render whose task.toml gives no `paths`"))?;
                (paths.max(0) as u64) / (w * h).max(1) as u64
            }
        },
        job: (get("job_hash")?, get("job_file")?),
        // An image written before the `gases` attribute existed counts as
        // without gases.
        atmosphere: format!(
            "profile {}, aerosol {}, gases {}",
            get("profile")?,
            get("aerosol")?,
            attrs.get("gases").map_or("none", String::as_str)
        ),
    })
}

/// The camera an image's `sensor` attribute describes.
fn camera_of(sensor: &str, name: &str) -> Result<Camera> {
    let size = |text: &str| -> Option<(usize, usize)> {
        let dims = text.split_whitespace().find(|w| w.contains('x'))?;
        let dims = dims.trim_end_matches([',', ':']);
        let (w, h) = dims.split_once('x')?;
        Some((w.parse().ok()?, h.parse().ok()?))
    };
    let bad = || {
        Error::data(
            name,
            format!("sensor {sensor:?}: a fit needs a full-sphere image or up and down fisheyes"),
        )
    };
    if sensor.starts_with("sphere") {
        let (width, height) = size(sensor).ok_or_else(bad)?;
        Ok(Camera::Sphere { width, height })
    } else if sensor.starts_with("fisheye") {
        let (resolution, _) = size(sensor).ok_or_else(bad)?;
        let hemisphere = if sensor.contains("hemisphere Up") {
            Hemisphere::Up
        } else if sensor.contains("hemisphere Down") {
            Hemisphere::Down
        } else {
            return Err(bad());
        };
        let projection = if sensor.contains("projection Equidistant") {
            Projection::Equidistant
        } else if sensor.contains("projection Equisolid") {
            Projection::Equisolid
        } else if sensor.contains("projection Stereographic") {
            Projection::Stereographic
        } else {
            return Err(bad());
        };
        Ok(Camera::Fisheye {
            resolution,
            hemisphere,
            projection,
        })
    } else {
        Err(bad())
    }
}

/// The sorted distinct values (to 1e-9) of `values`.
fn distinct(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs().max(1.0));
    v
}

fn grid_of(tasks: Vec<TaskInfo>) -> Result<RenderGrid> {
    let first = &tasks[0];
    let name = |t: &TaskInfo| t.dir.display().to_string();
    for t in &tasks {
        let differs = |what: &str, a: &dyn std::fmt::Debug, b: &dyn std::fmt::Debug| {
            Error::data(
                name(t),
                format!(
                    "{what} {a:?} differs from {b:?} of {}: a fit needs one set for every task",
                    name(first)
                ),
            )
        };
        if t.wavelengths_nm != first.wavelengths_nm {
            return Err(differs("wavelengths", &t.wavelengths_nm, &first.wavelengths_nm));
        }
        if t.band_width_nm != first.band_width_nm {
            return Err(differs("band widths", &t.band_width_nm, &first.band_width_nm));
        }
        if t.albedos != first.albedos {
            return Err(differs("albedos", &t.albedos, &first.albedos));
        }
        if t.units != first.units {
            return Err(differs("units", &t.units, &first.units));
        }
        if t.polarised != first.polarised {
            return Err(differs("polarisation", &t.polarised, &first.polarised));
        }
        if t.atmosphere != first.atmosphere {
            return Err(differs("atmosphere", &t.atmosphere, &first.atmosphere));
        }
    }
    if !first.units.starts_with("W m-2") {
        return Err(Error::data(
            name(first),
            "rendered per unit solar irradiance: the sky model's radiance is absolute (W m-2 sr-1 nm-1), \
             render with `output.units = \"absolute\"`",
        ));
    }
    let (channel_start_nm, channel_width_nm) =
        channels(&first.wavelengths_nm, &first.band_width_nm).map_err(|m| Error::data(name(first), m))?;
    let visibilities_km = distinct(tasks.iter().map(|t| t.visibility_km));
    let altitudes_km = distinct(tasks.iter().map(|t| t.altitude_km));
    let elevations_deg = distinct(tasks.iter().map(|t| t.elevation_deg));
    let index = |list: &[f64], v: f64| list.iter().position(|x| (x - v).abs() <= 1e-9 * v.abs().max(1.0));
    let n = visibilities_km.len() * altitudes_km.len() * elevations_deg.len();
    let mut slots: Vec<Vec<&TaskInfo>> = vec![Vec::new(); n];
    for t in &tasks {
        let k = (index(&visibilities_km, t.visibility_km).expect("listed") * altitudes_km.len()
            + index(&altitudes_km, t.altitude_km).expect("listed"))
            * elevations_deg.len()
            + index(&elevations_deg, t.elevation_deg).expect("listed");
        slots[k].push(t);
    }
    let mut configs = Vec::with_capacity(n);
    for (k, slot) in slots.iter().enumerate() {
        let e = k % elevations_deg.len();
        let a = (k / elevations_deg.len()) % altitudes_km.len();
        let v = k / (elevations_deg.len() * altitudes_km.len());
        let what = format!(
            "visibility {} km, observer {} km, sun elevation {}°",
            visibilities_km[v], altitudes_km[a], elevations_deg[e]
        );
        let source = match slot.as_slice() {
            [] => {
                return Err(Error::data(
                    dirs_text(&tasks),
                    format!("no render of {what}: the grid of visibilities × altitudes × elevations is incomplete"),
                ));
            }
            [one] => match one.camera {
                Camera::Sphere { .. } => Source::Sphere {
                    exr: one.dir.join(IMAGE_FILE),
                    camera: one.camera,
                },
                _ => {
                    return Err(Error::data(
                        name(one),
                        format!("{what}: a fisheye alone; the fit needs its other hemisphere too"),
                    ));
                }
            },
            [x, y] => {
                let hemisphere = |t: &TaskInfo| match t.camera {
                    Camera::Fisheye { hemisphere, .. } => Some(hemisphere),
                    _ => None,
                };
                let (up, down) = match (hemisphere(x), hemisphere(y)) {
                    (Some(Hemisphere::Up), Some(Hemisphere::Down)) => (x, y),
                    (Some(Hemisphere::Down), Some(Hemisphere::Up)) => (y, x),
                    _ => {
                        return Err(Error::data(
                            format!("{} and {}", name(x), name(y)),
                            format!("two renders of {what}, not an up and a down fisheye"),
                        ));
                    }
                };
                Source::Fisheyes {
                    up: up.dir.join(IMAGE_FILE),
                    up_camera: up.camera,
                    down: down.dir.join(IMAGE_FILE),
                    down_camera: down.camera,
                }
            }
            more => {
                return Err(Error::data(
                    more.iter().map(|t| name(t)).collect::<Vec<_>>().join(", "),
                    format!("{} renders of {what}", more.len()),
                ));
            }
        };
        if slot.iter().any(|t| t.frame != slot[0].frame) {
            return Err(Error::data(
                name(slot[0]),
                format!("{what}: images in different Stokes frames"),
            ));
        }
        configs.push(ConfigRender {
            visibility_km: visibilities_km[v],
            altitude_km: altitudes_km[a],
            elevation_deg: elevations_deg[e],
            source,
            frame: slot[0].frame,
            samples: slot.iter().map(|t| t.samples).min().unwrap_or(0),
        });
    }
    let mut jobs: Vec<(String, String)> = tasks.iter().map(|t| t.job.clone()).collect();
    jobs.sort();
    jobs.dedup();
    Ok(RenderGrid {
        visibilities_km,
        albedos: first.albedos.clone(),
        altitudes_km,
        elevations_deg,
        wavelengths_nm: first.wavelengths_nm.clone(),
        channel_start_nm,
        channel_width_nm,
        polarised: first.polarised,
        configs,
        jobs,
        atmosphere: first.atmosphere.clone(),
    })
}

fn dirs_text(tasks: &[TaskInfo]) -> String {
    let mut parents: Vec<String> = tasks
        .iter()
        .map(|t| t.dir.parent().unwrap_or(&t.dir).display().to_string())
        .collect();
    parents.dedup();
    parents.join(", ")
}

/// The runtime's channels from the rendered wavelengths: equally spaced
/// centres, each channel [start + k·width, start + (k + 1)·width) around
/// its centre. Bands must be as wide as the spacing; single wavelengths
/// stand for the channel around them.
pub fn channels(wavelengths_nm: &[f64], band_width_nm: &[f64]) -> std::result::Result<(f64, f64), String> {
    let band = band_width_nm.first().copied().filter(|&w| w > 0.0);
    let width = if wavelengths_nm.len() >= 2 {
        let step = wavelengths_nm[1] - wavelengths_nm[0];
        for w in wavelengths_nm.windows(2) {
            if ((w[1] - w[0]) - step).abs() > 1e-6 * step.abs().max(1.0) || step <= 0.0 {
                return Err(format!(
                    "wavelengths {wavelengths_nm:?} are not equally spaced and ascending: the runtime's channels are"
                ));
            }
        }
        if let Some(b) = band
            && (b - step).abs() > 1e-6 * step
        {
            return Err(format!(
                "bands {b} nm wide at a spacing of {step} nm: the runtime's channels tile the spectrum, \
                 so bands must be as wide as their spacing"
            ));
        }
        step
    } else if let Some(b) = band {
        b
    } else {
        return Err(
            "one wavelength without a band width: the runtime's channel width is undefined \
                    (render a band, spectrum.band_width_nm, or two or more wavelengths)"
                .into(),
        );
    };
    Ok((wavelengths_nm[0] - width / 2.0, width))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_tile_the_spectrum_around_the_centres() {
        let w: Vec<f64> = (0..11).map(|k| 340.0 + 40.0 * k as f64).collect();
        assert_eq!(channels(&w, &[40.0; 11]), Ok((320.0, 40.0)));
        assert_eq!(channels(&w, &[]), Ok((320.0, 40.0)));
        // The wide range's 55 bands, 280–2480 nm.
        let wide: Vec<f64> = (0..55).map(|k| 300.0 + 40.0 * k as f64).collect();
        assert_eq!(channels(&wide, &[40.0; 55]), Ok((280.0, 40.0)));
        assert!(
            channels(&w, &[20.0; 11])
                .unwrap_err()
                .contains("as wide as their spacing")
        );
        assert!(
            channels(&[400.0, 450.0, 460.0], &[])
                .unwrap_err()
                .contains("equally spaced")
        );
        assert_eq!(channels(&[550.0], &[10.0]), Ok((545.0, 10.0)));
        assert!(channels(&[550.0], &[]).is_err());
    }

    #[test]
    fn cameras_are_read_from_the_sensor_attribute() {
        assert_eq!(
            camera_of("sphere (equirectangular) 96x48: x from azimuth +180 to -180 deg", "t").unwrap(),
            Camera::Sphere { width: 96, height: 48 }
        );
        assert_eq!(
            camera_of(
                "fisheye 64x64, hemisphere Down, projection Equisolid; image up = the sun's azimuth",
                "t"
            )
            .unwrap(),
            Camera::Fisheye {
                resolution: 64,
                hemisphere: Hemisphere::Down,
                projection: Projection::Equisolid
            }
        );
        assert!(camera_of("panorama 90x90: x from azimuth +90", "t").is_err());
    }
}
