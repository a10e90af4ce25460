//! A configuration's rendered images read into [`Layer`]s: per albedo and
//! channel, radiance, its standard error and the signed degree of
//! polarisation in the sun–view frame, on a sphere image. Full-sphere
//! renders are used pixel for pixel; an `up` and a `down` fisheye are
//! resampled (bilinear) onto a sphere image twice as wide as they are high.

use std::collections::BTreeMap;
use std::path::Path;

use glam::DVec3;

use super::SphereImage;
use super::renders::{ConfigRender, RenderGrid, Source};
use crate::error::{Error, Result};
use crate::io::exr::read_exr;
use crate::io::sky_image::layer_name;
use crate::polarization::stokes::{Stokes, StokesRotation};
use crate::polarization::stokes_frame::StokesFrame;
use crate::sensor::camera::Camera;

/// One (albedo, channel) image of a configuration, on the sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    pub albedo: f64,
    pub wavelength_nm: f64,
    /// I (the renders' units).
    pub radiance: SphereImage,
    /// The standard error of I.
    pub radiance_se: SphereImage,
    /// Q/I in the sun–view frame (positive for single Rayleigh
    /// scattering); 0 where I is 0. `None` for unpolarised renders.
    pub polarisation: Option<SphereImage>,
}

/// Reads a configuration's images: one [`Layer`] per albedo and channel,
/// albedo outermost, as the dataset orders them.
pub fn load(grid: &RenderGrid, config: &ConfigRender) -> Result<Vec<Layer>> {
    let sun_elevation = config.elevation_deg.to_radians();
    let sun = DVec3::new(sun_elevation.cos(), 0.0, sun_elevation.sin());
    let mut layers = Vec::new();
    match &config.source {
        Source::Sphere { exr, camera } => {
            let image = Image::read(exr, *camera)?;
            let (w, h) = camera.size();
            for &albedo in &grid.albedos {
                for &lambda in &grid.wavelengths_nm {
                    let key = layer_name(lambda, albedo);
                    layers.push(layer_from(albedo, lambda, w, h, grid.polarised, |k, v| {
                        image.pixel(&key, k, v, sun, config.frame, grid.polarised)
                    })?);
                }
            }
        }
        Source::Fisheyes {
            up,
            up_camera,
            down,
            down_camera,
        } => {
            let up = Image::read(up, *up_camera)?;
            let down = Image::read(down, *down_camera)?;
            let n = up.width.max(down.width);
            for &albedo in &grid.albedos {
                for &lambda in &grid.wavelengths_nm {
                    let key = layer_name(lambda, albedo);
                    // Per-pixel values of each fisheye first (the frame is
                    // per pixel), then resampled as scalars.
                    let fields = |img: &Image| -> Result<[Vec<f64>; 3]> {
                        let cells = img.width * img.height;
                        let mut out = [vec![0.0; cells], vec![0.0; cells], vec![0.0; cells]];
                        for j in 0..img.height {
                            for i in 0..img.width {
                                let Some(ray) = img.camera.centre_ray(i, j) else {
                                    continue;
                                };
                                let k = j * img.width + i;
                                let (value, se, p) =
                                    img.pixel(&key, k, ray.direction, sun, config.frame, grid.polarised)?;
                                out[0][k] = value;
                                out[1][k] = se;
                                // Q_sv itself resamples linearly; P = Q_sv/I after.
                                out[2][k] = p * value;
                            }
                        }
                        Ok(out)
                    };
                    let (fu, fd) = (fields(&up)?, fields(&down)?);
                    layers.push(layer_from(albedo, lambda, 2 * n, n, grid.polarised, |_, v| {
                        let (img, f) = if v.z >= 0.0 { (&up, &fu) } else { (&down, &fd) };
                        let value = img.bilinear(&f[0], v);
                        let q = img.bilinear(&f[2], v);
                        Ok((value, img.bilinear(&f[1], v), if value > 0.0 { q / value } else { 0.0 }))
                    })?);
                }
            }
        }
    }
    Ok(layers)
}

/// A `w` × `h` layer whose pixel k, looking along v, has the (I, se of I,
/// Q/I) that `pixel(k, v)` gives.
fn layer_from(
    albedo: f64,
    wavelength_nm: f64,
    w: usize,
    h: usize,
    polarised: bool,
    mut pixel: impl FnMut(usize, DVec3) -> Result<(f64, f64, f64)>,
) -> Result<Layer> {
    let mut layer = Layer {
        albedo,
        wavelength_nm,
        radiance: SphereImage::zeros(w, h),
        radiance_se: SphereImage::zeros(w, h),
        polarisation: polarised.then(|| SphereImage::zeros(w, h)),
    };
    for j in 0..h {
        for i in 0..w {
            let k = j * w + i;
            let (value, se, p) = pixel(k, layer.radiance.direction(i, j))?;
            layer.radiance.values[k] = value;
            layer.radiance_se.values[k] = se;
            if let Some(pol) = layer.polarisation.as_mut() {
                pol.values[k] = p;
            }
        }
    }
    Ok(layer)
}

/// One image's channels by name.
struct Image {
    name: String,
    camera: Camera,
    width: usize,
    height: usize,
    channels: BTreeMap<String, Vec<f32>>,
}

impl Image {
    fn read(path: &Path, camera: Camera) -> Result<Image> {
        let exr = read_exr(path)?;
        if (exr.width, exr.height) != camera.size() {
            return Err(Error::data(
                path.display().to_string(),
                format!(
                    "{} × {} pixels, but its sensor says {:?}",
                    exr.width,
                    exr.height,
                    camera.size()
                ),
            ));
        }
        Ok(Image {
            name: path.display().to_string(),
            camera,
            width: exr.width,
            height: exr.height,
            channels: exr.channels.into_iter().map(|c| (c.name, c.samples)).collect(),
        })
    }

    fn channel(&self, name: &str) -> Result<&[f32]> {
        self.channels
            .get(name)
            .map(|v| v.as_slice())
            .ok_or_else(|| Error::data(&self.name, format!("no channel `{name}`")))
    }

    /// (I, se of I, Q/I in the sun–view frame) at pixel `k`, whose centre
    /// looks along `v`.
    fn pixel(
        &self,
        layer: &str,
        k: usize,
        v: DVec3,
        sun: DVec3,
        frame: StokesFrame,
        polarised: bool,
    ) -> Result<(f64, f64, f64)> {
        let i = self.channel(&format!("{layer}.I"))?[k] as f64;
        let se = self.channel(&format!("{layer}.I_se"))?[k] as f64;
        if !polarised || i <= 0.0 {
            return Ok((i, se, 0.0));
        }
        let q = self.channel(&format!("{layer}.Q"))?[k] as f64;
        let u = self.channel(&format!("{layer}.U"))?[k] as f64;
        let q_sv = match frame {
            StokesFrame::SunView => q,
            StokesFrame::Meridian => {
                let phi = v.y.atan2(v.x);
                let from = StokesFrame::Meridian.axis(v, phi, sun);
                let to = StokesFrame::SunView.axis(v, phi, sun);
                StokesRotation::between(from, to, -v).apply(Stokes([i, q, u, 0.0])).q()
            }
        };
        Ok((i, se, q_sv / i))
    }

    /// Bilinear value of a per-pixel field at direction `v` (0 outside).
    fn bilinear(&self, field: &[f64], v: DVec3) -> f64 {
        let Some((x, y)) = self.camera.point_of(v) else {
            return 0.0;
        };
        let (x, y) = (x - 0.5, y - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: f64, j: f64| {
            let i = (i.max(0.0) as usize).min(self.width - 1);
            let j = (j.max(0.0) as usize).min(self.height - 1);
            field[j * self.width + i]
        };
        (1.0 - fy) * ((1.0 - fx) * at(x0, y0) + fx * at(x0 + 1.0, y0))
            + fy * ((1.0 - fx) * at(x0, y0 + 1.0) + fx * at(x0 + 1.0, y0 + 1.0))
    }
}
