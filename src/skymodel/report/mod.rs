//! `atmosim fit-report`: how well a dataset holds the renders it was
//! fitted from: per image the SNR with solid-angle weights against the
//! render and the render's own noise floor, the normalised mean absolute
//! error by albedo, elevation, altitude, visibility and channel (box plots
//! as PNG), the polarisation error, the explained variance by rank (from
//! the fit's figures), the interpolation ratio at renders between the
//! nodes, and the transmittance's largest absolute error on and off the
//! nodes; written as Markdown.

pub mod boxplot;
pub mod half_loss;
pub mod interpolation;
pub mod score;
pub mod transmittance_check;

use std::path::Path;

use boxplot::{five_numbers, write_box_plot};
use interpolation::InterpolationScore;
use score::ImageScore;
use transmittance_check::TransmittanceError;

use crate::error::Result;
use crate::io::atomic::write_atomic;

/// What a report holds besides the per-image scores.
#[derive(Debug, Clone, Default)]
pub struct ReportExtras {
    pub interpolation: Vec<InterpolationScore>,
    /// The largest |ΔT| at the fitted nodes and off them.
    pub transmittance_on_nodes: Option<TransmittanceError>,
    pub transmittance_off_nodes: Option<TransmittanceError>,
    /// Explained variance by rank: (rank, mean, minimum) over the images.
    pub explained: Vec<(usize, f64, f64)>,
    pub dataset: String,
    pub core_seconds_per_image: Option<f64>,
    /// The halves' loss: the SNR of the written dataset against its
    /// unrounded fit, (mean, minimum) over the images, in dB.
    pub half_float_snr_db: Option<(f64, f64)>,
}

/// Summary figures of the scores: (mean, minimum, median) of the SNR.
pub fn snr_summary(scores: &[ImageScore]) -> (f64, f64, f64) {
    let snr: Vec<f64> = scores.iter().map(|s| s.snr_db).collect();
    let mean = snr.iter().sum::<f64>() / snr.len().max(1) as f64;
    let f = five_numbers(&snr).unwrap_or([f64::NAN; 5]);
    (mean, f[0], f[2])
}

/// Writes `report.md` and its box plots into `dir`; returns the Markdown.
pub fn write_report(dir: &Path, scores: &[ImageScore], extras: &ReportExtras) -> Result<String> {
    let (mean, min, median) = snr_summary(scores);
    let floor: Vec<f64> = scores.iter().map(|s| s.noise_floor_db).collect();
    let floor_mean = floor.iter().sum::<f64>() / floor.len().max(1) as f64;
    let floor_min = floor.iter().fold(f64::INFINITY, |m, &x| m.min(x));
    let mut md = format!("# Fit report: {}\n\n", extras.dataset);
    md.push_str(&format!(
        "{} images compared at their rendered pixels (the dataset at each image's own configuration, no interpolation; \
         solid-angle weights).\n\n",
        scores.len()
    ));
    md.push_str("| figure | value |\n|---|---|\n");
    md.push_str(&format!(
        "| SNR mean | {mean:.2} dB |\n| SNR minimum | {min:.2} dB |\n| SNR median | {median:.2} dB |\n"
    ));
    md.push_str(&format!(
        "| renders' noise floor (SNR of a perfect fit), mean / minimum | {floor_mean:.2} / {floor_min:.2} dB |\n"
    ));
    let pol: Vec<f64> = scores.iter().filter_map(|s| s.polarisation_error).collect();
    if !pol.is_empty() {
        md.push_str(&format!(
            "| polarisation: radiance-weighted mean abs. error of the degree of polarisation, mean / max over images | {:.4} / {:.4} |\n",
            pol.iter().sum::<f64>() / pol.len() as f64,
            pol.iter().fold(0.0f64, |m, &x| m.max(x))
        ));
    }
    for (what, t) in [
        ("on", &extras.transmittance_on_nodes),
        ("off", &extras.transmittance_off_nodes),
    ] {
        if let Some(t) = t.as_ref().filter(|t| t.points == 0) {
            md.push_str(&format!(
                "| transmittance max abs. error {what} the nodes ({}) | {:.2e} |\n",
                t.worst_at, t.max_abs
            ));
        } else if let Some(t) = t {
            md.push_str(&format!(
                "| transmittance abs. error {what} the nodes, max / 99th percentile / mean ({} points; largest at {}) | {:.2e} / {:.2e} / {:.2e} |\n",
                t.points, t.worst_at, t.max_abs, t.p99_abs, t.mean_abs
            ));
        }
    }
    if !extras.interpolation.is_empty() {
        let ratios: Vec<f64> = extras.interpolation.iter().map(InterpolationScore::ratio).collect();
        let f = five_numbers(&ratios).unwrap_or([f64::NAN; 5]);
        md.push_str(&format!(
            "| interpolation ratio rmse(render, interpolated) / rmse(render, fit), median / max over {} images | {:.3} / {:.3} |\n",
            ratios.len(),
            f[2],
            f[4]
        ));
    }
    if let Some((mean, min)) = extras.half_float_snr_db {
        md.push_str(&format!(
            "| loss from half floats: SNR of the dataset against its unrounded fit, mean / minimum | {mean:.2} / {min:.2} dB |\n"
        ));
    }
    if let Some(s) = extras.core_seconds_per_image {
        md.push_str(&format!("| fit time | {s:.3} core-seconds per image |\n"));
    }
    md.push_str("\n## Normalised mean absolute error\n\n");
    type Key = fn(&ImageScore) -> f64;
    let axes: [(&str, &str, Key); 5] = [
        ("albedo", "albedo", |s| s.albedo),
        ("elevation", "sun elevation (deg)", |s| s.elevation_deg),
        ("altitude", "observer altitude (m)", |s| s.altitude_m),
        ("visibility", "visibility (km)", |s| s.visibility_km),
        ("channel", "channel centre (nm)", |s| s.wavelength_nm),
    ];
    for (file, title, key) in axes {
        let mut values: Vec<f64> = scores.iter().map(key).collect();
        values.sort_by(f64::total_cmp);
        values.dedup();
        let groups: Vec<(String, Vec<f64>)> = values
            .iter()
            .map(|&v| {
                (
                    format!("{v}"),
                    scores.iter().filter(|s| key(s) == v).map(|s| s.nmae).collect(),
                )
            })
            .collect();
        let png = format!("nmae_by_{file}.png");
        write_box_plot(&dir.join(&png), &format!("NMAE by {title}"), &groups)?;
        md.push_str(&format!("### By {title}\n\n![NMAE by {title}]({png})\n\n| {title} | median | max | SNR min (dB) |\n|---|---|---|---|\n"));
        for (label, g) in &groups {
            let f = five_numbers(g).unwrap_or([f64::NAN; 5]);
            let snr_min = scores
                .iter()
                .filter(|s| format!("{}", key(s)) == *label)
                .fold(f64::INFINITY, |m, s| m.min(s.snr_db));
            md.push_str(&format!("| {label} | {:.4} | {:.4} | {snr_min:.2} |\n", f[2], f[4]));
        }
        md.push('\n');
    }
    if !extras.explained.is_empty() {
        md.push_str("## Explained variance of the (γ, α) tables by rank\n\n| rank | mean | minimum |\n|---|---|---|\n");
        for (r, m, lo) in &extras.explained {
            md.push_str(&format!("| {r} | {m:.6} | {lo:.6} |\n"));
        }
        md.push('\n');
    }
    if !extras.interpolation.is_empty() {
        md.push_str("## Interpolation between nodes\n\nBy sun elevation of the between-node render:\n\n| elevation | images | ratio median | ratio max |\n|---|---|---|---|\n");
        let mut elevations: Vec<f64> = extras.interpolation.iter().map(|s| s.elevation_deg).collect();
        elevations.sort_by(f64::total_cmp);
        elevations.dedup();
        for e in elevations {
            let ratios: Vec<f64> = extras
                .interpolation
                .iter()
                .filter(|s| s.elevation_deg == e)
                .map(InterpolationScore::ratio)
                .collect();
            let f = five_numbers(&ratios).unwrap_or([f64::NAN; 5]);
            md.push_str(&format!("| {e} | {} | {:.3} | {:.3} |\n", ratios.len(), f[2], f[4]));
        }
        md.push_str("\nEvery image:\n\n| visibility | albedo | altitude (m) | elevation | channel | rmse(B, I) | rmse(B, F) | ratio |\n|---|---|---|---|---|---|---|---|\n");
        for s in &extras.interpolation {
            md.push_str(&format!(
                "| {} | {} | {} | {} | {} | {:.4e} | {:.4e} | {:.3} |\n",
                s.visibility_km,
                s.albedo,
                s.altitude_m,
                s.elevation_deg,
                s.wavelength_nm,
                s.rmse_interpolated,
                s.rmse_fit,
                s.ratio()
            ));
        }
        md.push('\n');
    }
    md.push_str("## Per image\n\n| visibility | albedo | altitude (m) | elevation | channel | SNR (dB) | noise floor (dB) | NMAE | pol. error |\n|---|---|---|---|---|---|---|---|---|\n");
    for s in scores {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.4} | {} |\n",
            s.visibility_km,
            s.albedo,
            s.altitude_m,
            s.elevation_deg,
            s.wavelength_nm,
            s.snr_db,
            s.noise_floor_db,
            s.nmae,
            s.polarisation_error.map_or("—".into(), |p| format!("{p:.4}"))
        ));
    }
    write_atomic(&dir.join("report.md"), md.as_bytes())?;
    Ok(md)
}
