//! Previews: spectral radiance to CIE 1931 XYZ to sRGB, and PNG files.
//!
//! The colour-matching functions are the multi-lobe Gaussian fit of
//! Wyman, Sloan & Shirley (2013), "Simple Analytic Approximations to the
//! CIE XYZ Color Matching Functions", JCGT 2(2) (within a few per cent of
//! the tabulated 2° observer). A rendered wavelength stands for the band
//! from half-way to its lower neighbour to half-way to its upper one (a
//! lone wavelength: ±20 nm). XYZ → linear sRGB with the IEC 61966-2-1
//! matrix (D65 white), then the sRGB transfer curve.

use std::io::BufWriter;
use std::path::Path;

use crate::error::{Error, Result};
use crate::io::atomic::write_atomic;

fn lobe(lambda: f64, mu: f64, s1: f64, s2: f64) -> f64 {
    let t = (lambda - mu) / if lambda < mu { s1 } else { s2 };
    (-0.5 * t * t).exp()
}

/// CIE 1931 2° colour-matching functions (x̄, ȳ, z̄) at λ (nm).
pub fn cie_xyz(lambda: f64) -> [f64; 3] {
    let x = 1.056 * lobe(lambda, 599.8, 37.9, 31.0) + 0.362 * lobe(lambda, 442.0, 16.0, 26.7)
        - 0.065 * lobe(lambda, 501.1, 20.4, 26.2);
    let y = 0.821 * lobe(lambda, 568.8, 46.9, 40.5) + 0.286 * lobe(lambda, 530.9, 16.3, 31.1);
    let z = 1.217 * lobe(lambda, 437.0, 11.8, 36.0) + 0.681 * lobe(lambda, 459.0, 26.0, 13.8);
    [x, y, z]
}

/// Weights w_i such that XYZ = Σ w_i·L(λ_i): the CMF integrated (1 nm
/// steps) over each wavelength's band.
pub fn xyz_weights(wavelengths_nm: &[f64]) -> Vec<[f64; 3]> {
    let n = wavelengths_nm.len();
    (0..n)
        .map(|i| {
            let l = wavelengths_nm[i];
            let lo = if i > 0 {
                0.5 * (l + wavelengths_nm[i - 1])
            } else if n > 1 {
                l - 0.5 * (wavelengths_nm[1] - l)
            } else {
                l - 20.0
            };
            let hi = if i + 1 < n {
                0.5 * (l + wavelengths_nm[i + 1])
            } else if n > 1 {
                l + 0.5 * (l - wavelengths_nm[n - 2])
            } else {
                l + 20.0
            };
            let steps = ((hi - lo).ceil() as usize).max(1);
            let dl = (hi - lo) / steps as f64;
            let mut w = [0.0; 3];
            for k in 0..steps {
                let c = cie_xyz(lo + (k as f64 + 0.5) * dl);
                for j in 0..3 {
                    w[j] += c[j] * dl;
                }
            }
            w
        })
        .collect()
}

/// Linear sRGB from XYZ (IEC 61966-2-1).
pub fn xyz_to_linear_srgb([x, y, z]: [f64; 3]) -> [f64; 3] {
    [
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    ]
}

/// The sRGB transfer curve of a linear value in [0, 1].
pub fn srgb_encode(v: f64) -> f64 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// The exposure that maps the median positive luminance to middle grey
/// (0.18), the usual automatic exposure of cameras.
pub fn auto_exposure(luminance: &[f64]) -> f64 {
    let mut y: Vec<f64> = luminance
        .iter()
        .copied()
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    if y.is_empty() {
        return 1.0;
    }
    y.sort_by(f64::total_cmp);
    0.18 / y[y.len() / 2]
}

/// Writes an 8-bit PNG (`channels` = 1 grey or 3 RGB) with text chunks.
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    channels: usize,
    pixels: &[u8],
    text: &[(&str, String)],
) -> Result<()> {
    let fail = |m: String| Error::io(path, std::io::Error::other(m));
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(BufWriter::new(&mut bytes), width as u32, height as u32);
        encoder.set_color(if channels == 3 {
            png::ColorType::Rgb
        } else {
            png::ColorType::Grayscale
        });
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        for (k, v) in text {
            encoder
                .add_text_chunk(k.to_string(), v.clone())
                .map_err(|e| fail(e.to_string()))?;
        }
        let mut writer = encoder.write_header().map_err(|e| fail(e.to_string()))?;
        writer.write_image_data(pixels).map_err(|e| fail(e.to_string()))?;
    }
    write_atomic(path, &bytes)
}

/// An sRGB preview: per pixel spectral radiances (`spectra[w][pixel]`) at
/// `wavelengths_nm`, scaled by `exposure` (or auto). Returns the 8-bit RGB
/// pixels and the exposure used.
pub fn srgb_preview(wavelengths_nm: &[f64], spectra: &[&[f64]], exposure: Option<f64>) -> (Vec<u8>, f64) {
    let weights = xyz_weights(wavelengths_nm);
    let n = spectra[0].len();
    let xyz: Vec<[f64; 3]> = (0..n)
        .map(|p| {
            let mut c = [0.0; 3];
            for (w, s) in weights.iter().zip(spectra) {
                for j in 0..3 {
                    c[j] += w[j] * s[p];
                }
            }
            c
        })
        .collect();
    let exposure = exposure.unwrap_or_else(|| auto_exposure(&xyz.iter().map(|c| c[1]).collect::<Vec<_>>()));
    let mut out = Vec::with_capacity(3 * n);
    for c in &xyz {
        let rgb = xyz_to_linear_srgb([c[0] * exposure, c[1] * exposure, c[2] * exposure]);
        for v in rgb {
            out.push((srgb_encode(v) * 255.0).round() as u8);
        }
    }
    (out, exposure)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_matching_functions_hit_the_cie_peaks() {
        // CIE 1931 2°: ȳ(555) = 1.000, x̄(600) = 1.062, z̄(445) = 1.782
        // (the fit is within a few per cent).
        assert!((cie_xyz(555.0)[1] - 1.0).abs() < 0.01);
        assert!((cie_xyz(600.0)[0] - 1.062).abs() < 0.03);
        assert!((cie_xyz(445.0)[2] - 1.782).abs() < 0.06);
        // ∫ȳ dλ ≈ 106.86 nm for the tabulated function.
        let int_y: f64 = (360..=830).map(|l| cie_xyz(l as f64)[1]).sum();
        assert!((int_y / 106.86 - 1.0).abs() < 0.01, "{int_y}");
    }

    #[test]
    fn an_equal_energy_spectrum_is_nearly_neutral() {
        let wl: Vec<f64> = (0..47).map(|i| 380.0 + 10.0 * i as f64).collect();
        let w = xyz_weights(&wl);
        let xyz = w.iter().fold([0.0; 3], |a, c| [a[0] + c[0], a[1] + c[1], a[2] + c[2]]);
        // Illuminant E: x = y = 1/3.
        let s = xyz[0] + xyz[1] + xyz[2];
        assert!((xyz[0] / s - 1.0 / 3.0).abs() < 0.01 && (xyz[1] / s - 1.0 / 3.0).abs() < 0.01);
    }

    #[test]
    fn srgb_of_the_d65_white_is_white() {
        // D65 white point XYZ = (0.9505, 1, 1.089).
        let rgb = xyz_to_linear_srgb([0.9505, 1.0, 1.089]);
        for c in rgb {
            assert!((c - 1.0).abs() < 2e-3, "{rgb:?}");
        }
        assert!((srgb_encode(0.5) - 0.7354).abs() < 1e-3);
    }
}
