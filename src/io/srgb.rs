//! Colour: spectral radiance to CIE 1931 XYZ to sRGB, the one conversion
//! the PNG previews of renders and of evaluated sky models use.
//!
//! XYZ is the radiance integrated against the colour-matching functions
//! x̄, ȳ, z̄ of the CIE 1931 standard colorimetric observer (2°), tabulated
//! every 5 nm from 380 to 780 nm (CIE 15:2004, Table T.4;
//! `spectra/cie1931_2deg_5nm.txt`), linear between the nodes and 0 outside
//! them. A rendered channel stands for a band of wavelengths (see
//! [`xyz_weights`]), so its weight is the exact integral of that
//! piecewise-linear function over the band. XYZ goes to linear sRGB by the
//! matrix of IEC 61966-2-1 (primaries x, y = 0.64, 0.33 / 0.30, 0.60 /
//! 0.15, 0.06, white D65), then through the sRGB transfer curve.

use std::sync::OnceLock;

use crate::error::Result;
use crate::physics::data::{self, Table};

/// The CIE 1931 2° colour-matching functions on their 5 nm nodes.
#[derive(Debug, Clone)]
pub struct ColourMatching {
    wavelengths_nm: Vec<f64>,
    xyz: Vec<[f64; 3]>,
}

impl ColourMatching {
    /// Parses the embedded table.
    pub fn parse_cie_1931() -> Result<ColourMatching> {
        let t = Table::parse("cie1931_2deg_5nm", data::CIE_1931_2DEG, 4)?;
        t.require_ascending(0, "wavelengths")?;
        Ok(ColourMatching {
            wavelengths_nm: t.column(0),
            xyz: t.rows.iter().map(|r| [r[1], r[2], r[3]]).collect(),
        })
    }

    /// The embedded CIE 1931 2° observer, parsed once.
    pub fn cie_1931() -> &'static ColourMatching {
        static CMF: OnceLock<ColourMatching> = OnceLock::new();
        // The table is part of the binary and its parse is tested: a
        // failure here is a build defect, not a user's input.
        CMF.get_or_init(|| Self::parse_cie_1931().expect("the embedded CIE 1931 table parses"))
    }

    /// The tabulated wavelengths (nm).
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// (x̄, ȳ, z̄) at λ: linear between the nodes, 0 outside the table.
    pub fn at(&self, lambda_nm: f64) -> [f64; 3] {
        match data::bracket(&self.wavelengths_nm, lambda_nm) {
            Some((i, f)) if i + 1 < self.xyz.len() => {
                std::array::from_fn(|j| self.xyz[i][j] + f * (self.xyz[i + 1][j] - self.xyz[i][j]))
            }
            Some((i, _)) => self.xyz[i],
            None => [0.0; 3],
        }
    }

    /// ∫ (x̄, ȳ, z̄) dλ over [lo, hi] (nm), exact for the piecewise-linear
    /// functions: on each node interval the overlap's trapezoid.
    pub fn integral(&self, lo_nm: f64, hi_nm: f64) -> [f64; 3] {
        let mut sum = [0.0; 3];
        for k in 0..self.wavelengths_nm.len().saturating_sub(1) {
            let (c, d) = (self.wavelengths_nm[k].max(lo_nm), self.wavelengths_nm[k + 1].min(hi_nm));
            if d <= c {
                continue;
            }
            let (fc, fd) = (self.at(c), self.at(d));
            for j in 0..3 {
                sum[j] += 0.5 * (d - c) * (fc[j] + fd[j]);
            }
        }
        sum
    }
}

/// Weights w_i with XYZ = Σ w_i·L(λ_i) for radiances L rendered at
/// `wavelengths_nm` (ascending): each wavelength stands for the band from
/// half-way to its lower neighbour to half-way to its upper one (the first
/// and last as wide on their outer side; a lone wavelength ±20 nm), so
/// that the sky model's 40 nm bands from 320 nm stand for themselves.
pub fn xyz_weights(wavelengths_nm: &[f64]) -> Vec<[f64; 3]> {
    let cmf = ColourMatching::cie_1931();
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
            cmf.integral(lo, hi)
        })
        .collect()
}

/// Linear sRGB from XYZ (IEC 61966-2-1; D65 white at Y = 1 maps to 1, 1, 1).
pub fn xyz_to_linear_srgb([x, y, z]: [f64; 3]) -> [f64; 3] {
    [
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    ]
}

/// The sRGB transfer curve of a linear value, clamped to [0, 1].
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

/// 8-bit sRGB pixels of per-pixel spectral radiances (`spectra[w][pixel]`
/// at `wavelengths_nm[w]`), scaled by `exposure` (or [`auto_exposure`] of
/// their luminance Y). Returns the RGB bytes, row by row, and the exposure.
pub fn srgb_pixels(wavelengths_nm: &[f64], spectra: &[&[f64]], exposure: Option<f64>) -> (Vec<u8>, f64) {
    let weights = xyz_weights(wavelengths_nm);
    let n = spectra.first().map_or(0, |s| s.len());
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

    fn chromaticity(c: [f64; 3]) -> (f64, f64) {
        let s = c[0] + c[1] + c[2];
        (c[0] / s, c[1] / s)
    }

    #[test]
    fn the_table_is_the_cie_1931_observer_at_5_nm() {
        let cmf = ColourMatching::cie_1931();
        let l = cmf.wavelengths_nm();
        assert_eq!(l.len(), 81);
        assert!(l.windows(2).all(|w| w[1] - w[0] == 5.0) && l[0] == 380.0 && l[80] == 780.0);
        // CIE 15:2004 Table T.4: ȳ(555) = 1 by definition; x̄ peaks at
        // 600 nm (1.062200), z̄ at 445 nm (1.782600); x̄(500) = 0.004900.
        assert_eq!(cmf.at(555.0), [0.512050, 1.0, 0.005750]);
        assert_eq!(cmf.at(600.0)[0], 1.062200);
        assert_eq!(cmf.at(445.0)[2], 1.782600);
        assert_eq!(cmf.at(500.0)[0], 0.004900);
        let argmax = |j: usize| {
            (0..81)
                .max_by(|&a, &b| cmf.xyz[a][j].total_cmp(&cmf.xyz[b][j]))
                .map(|k| l[k])
        };
        assert_eq!(
            (argmax(0), argmax(1), argmax(2)),
            (Some(600.0), Some(555.0), Some(445.0))
        );
        // Between nodes linear, outside 0.
        assert!((cmf.at(557.5)[1] - 0.9975).abs() < 1e-12);
        assert_eq!(cmf.at(379.0), [0.0; 3]);
        assert_eq!(cmf.at(781.0), [0.0; 3]);
    }

    #[test]
    fn the_equal_energy_white_sits_at_one_third() {
        // The CIE normalised x̄, ȳ, z̄ to equal areas: the equal-energy
        // illuminant E has x = y = 1/3, and ∫ȳ dλ = 106.857 nm over the
        // 5 nm table (CIE 15:2004: 106.856895 at 1 nm, 360–830 nm).
        let cmf = ColourMatching::cie_1931();
        let s = cmf.integral(380.0, 780.0);
        let (x, y) = chromaticity(s);
        assert!((x - 1.0 / 3.0).abs() < 5e-5 && (y - 1.0 / 3.0).abs() < 5e-5, "{x} {y}");
        assert!((s[1] - 106.857).abs() < 1e-3, "{}", s[1]);
        // The same through 47 channels every 10 nm, as a preview weighs them.
        let wl: Vec<f64> = (0..47).map(|i| 360.0 + 10.0 * i as f64).collect();
        let w = xyz_weights(&wl)
            .iter()
            .fold([0.0; 3], |a, c| [a[0] + c[0], a[1] + c[1], a[2] + c[2]]);
        let (x, y) = chromaticity(w);
        assert!((x - 1.0 / 3.0).abs() < 5e-5 && (y - 1.0 / 3.0).abs() < 5e-5, "{x} {y}");
    }

    #[test]
    fn spectral_lines_land_on_the_published_spectral_locus() {
        // Chromaticity of monochromatic light, CIE 15:2004 Table T.4
        // (four decimals), from the functions at the line; and a 0.2 nm
        // band about it through the integral.
        let cmf = ColourMatching::cie_1931();
        for (l, x, y) in [
            (450.0, 0.1566, 0.0177),
            (500.0, 0.0082, 0.5384),
            (520.0, 0.0743, 0.8338),
            (550.0, 0.3016, 0.6923),
            (600.0, 0.6270, 0.3725),
            (700.0, 0.7347, 0.2653),
        ] {
            let (cx, cy) = chromaticity(cmf.at(l));
            assert!((cx - x).abs() < 1e-4 && (cy - y).abs() < 1e-4, "{l} nm: {cx} {cy}");
            let (bx, by) = chromaticity(cmf.integral(l - 0.1, l + 0.1));
            assert!((bx - x).abs() < 3e-4 && (by - y).abs() < 3e-4, "{l} nm band: {bx} {by}");
        }
    }

    #[test]
    fn the_srgb_matrix_maps_its_primaries_and_the_d65_white() {
        // IEC 61966-2-1: primaries at x, y = (0.64, 0.33), (0.30, 0.60),
        // (0.15, 0.06) with luminances 0.2126, 0.7152, 0.0722, summing to
        // the D65 white (x, y = 0.3127, 0.3290) at Y = 1.
        let xyz = |x: f64, y: f64, big_y: f64| [x / y * big_y, big_y, (1.0 - x - y) / y * big_y];
        for (k, (x, y, big_y)) in [(0.64, 0.33, 0.2126), (0.30, 0.60, 0.7152), (0.15, 0.06, 0.0722)]
            .into_iter()
            .enumerate()
        {
            let rgb = xyz_to_linear_srgb(xyz(x, y, big_y));
            for (j, c) in rgb.iter().enumerate() {
                let expected = if j == k { 1.0 } else { 0.0 };
                assert!((c - expected).abs() < 2e-3, "primary {k}: {rgb:?}");
            }
        }
        for c in xyz_to_linear_srgb(xyz(0.3127, 0.3290, 1.0)) {
            assert!((c - 1.0).abs() < 2e-3);
        }
        // The transfer curve: its two pieces meet, and 0.5 encodes to 0.7354.
        assert!((srgb_encode(0.003_130_8) - 0.040_45).abs() < 1e-5);
        assert!((srgb_encode(0.5) - 0.735_4).abs() < 1e-4);
        assert!((srgb_encode(2.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_sky_models_bands_stand_for_themselves() {
        // 11 bands of 40 nm from 320 nm: each channel's weight is the
        // integral over its own band, and together they cover 320–760 nm.
        let wl: Vec<f64> = (0..11).map(|i| 340.0 + 40.0 * i as f64).collect();
        let w = xyz_weights(&wl);
        let cmf = ColourMatching::cie_1931();
        for (i, l) in wl.iter().enumerate() {
            assert_eq!(w[i], cmf.integral(l - 20.0, l + 20.0));
        }
        assert_eq!(w[0], [0.0; 3]); // 320–360 nm lies below the table
        let total = cmf.integral(320.0, 760.0);
        let sum = w.iter().fold([0.0; 3], |a, c| [a[0] + c[0], a[1] + c[1], a[2] + c[2]]);
        for j in 0..3 {
            assert!((sum[j] - total[j]).abs() < 1e-9);
        }
        // A grey sky at automatic exposure is grey to a few levels.
        let flat = vec![1.0; 4];
        let spectra: Vec<&[f64]> = wl.iter().map(|_| flat.as_slice()).collect();
        let (rgb, exposure) = srgb_pixels(&wl, &spectra, None);
        assert!((exposure * sum[1] - 0.18).abs() < 1e-12);
        let (r, g, b) = (rgb[0] as i32, rgb[1] as i32, rgb[2] as i32);
        assert!((r - g).abs() < 20 && (b - g).abs() < 20, "{r} {g} {b}");
    }
}
