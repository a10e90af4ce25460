//! `atmosim fit-report`: how well a dataset holds the renders it was
//! fitted from: per image the SNR with solid-angle weights against the
//! render and the render's own noise floor, the normalised mean absolute
//! error by albedo, elevation, altitude, visibility and channel (box plots
//! as PNG), the polarisation error, the explained variance by rank (from
//! the fit's figures), the interpolation ratio at renders between the
//! nodes, and the transmittance's largest absolute error on and off the
//! nodes; written as Markdown.
//!
//! Against the converged sky: the same figures against reference renders
//! of the grid's configurations made apart from the fit's renders (more
//! samples, any resolution), with the references' own noise floor and the
//! SNR with their noise taken out ([`score::Sums::debiased_snr_db`]); and
//! the render noise the dataset inherits, from a twin dataset fitted from
//! renders with another seed ([`twin`]). Each per-image table is also
//! written as CSV.

pub mod boxplot;
pub mod half_loss;
pub mod interpolation;
pub mod regions;
pub mod score;
pub mod transmittance_check;
pub mod twin;

use std::path::Path;

use boxplot::{five_numbers, write_box_plot};
use interpolation::InterpolationScore;
use score::ImageScore;
use transmittance_check::TransmittanceError;
use twin::TwinScore;

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
    /// The dataset against reference renders (`--reference`), and where
    /// they came from.
    pub reference: Vec<ImageScore>,
    pub reference_source: String,
    /// The seed-to-seed comparison with a twin dataset (`--twin`).
    pub twin: Vec<TwinScore>,
    pub twin_source: String,
}

/// (mean, minimum) of `values`; NaN for none.
pub fn mean_min(values: &[f64]) -> (f64, f64) {
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    (
        values.iter().sum::<f64>() / values.len() as f64,
        values.iter().copied().fold(f64::INFINITY, f64::min),
    )
}

/// The summary of the dataset against reference renders.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceSummary {
    pub images: usize,
    /// SNR against the references as they are: (mean, minimum), dB.
    pub snr_db: (f64, f64),
    /// The references' own noise floor: (mean, minimum), dB.
    pub noise_floor_db: (f64, f64),
    /// The debiased SNR, images whose error the references' noise does not
    /// resolve counted at their lower bound: (mean, minimum), dB.
    pub debiased_snr_db: (f64, f64),
    /// How many images were counted at their lower bound.
    pub unresolved: usize,
    /// The polarisation error: (mean, maximum).
    pub polarisation_error: Option<(f64, f64)>,
    /// NMAE: (mean, maximum).
    pub nmae: (f64, f64),
}

/// The figures of `reference` scores; `None` for none.
pub fn reference_summary(reference: &[ImageScore]) -> Option<ReferenceSummary> {
    if reference.is_empty() {
        return None;
    }
    let pick = |f: fn(&ImageScore) -> f64| reference.iter().map(f).collect::<Vec<f64>>();
    let max = |v: &[f64]| v.iter().copied().fold(0.0f64, f64::max);
    let pol: Vec<f64> = reference.iter().filter_map(|s| s.polarisation_error).collect();
    let nmae = pick(|s| s.nmae);
    Some(ReferenceSummary {
        images: reference.len(),
        snr_db: mean_min(&pick(|s| s.snr_db)),
        noise_floor_db: mean_min(&pick(|s| s.noise_floor_db)),
        debiased_snr_db: mean_min(&pick(|s| s.debiased_snr_db.unwrap_or(s.debiased_snr_lower_db))),
        unresolved: reference.iter().filter(|s| s.debiased_snr_db.is_none()).count(),
        polarisation_error: (!pol.is_empty()).then(|| (pol.iter().sum::<f64>() / pol.len() as f64, max(&pol))),
        nmae: (nmae.iter().sum::<f64>() / nmae.len() as f64, max(&nmae)),
    })
}

/// (mean, extreme) of a figure over images.
pub type Spread = (f64, f64);

/// The summary of a seed-to-seed comparison: (seed-to-seed SNR mean and
/// minimum, dB; the polarisation difference's mean and maximum).
pub fn twin_summary(twin: &[TwinScore]) -> Option<(Spread, Option<Spread>)> {
    if twin.is_empty() {
        return None;
    }
    let snr: Vec<f64> = twin.iter().map(|t| t.seed_to_seed_snr_db).collect();
    let pol: Vec<f64> = twin.iter().filter_map(|t| t.polarisation_difference).collect();
    Some((
        mean_min(&snr),
        (!pol.is_empty()).then(|| {
            (
                pol.iter().sum::<f64>() / pol.len() as f64,
                pol.iter().copied().fold(0.0f64, f64::max),
            )
        }),
    ))
}

/// A value for a table, rounded to 1e-9 so that an elevation computed as
/// 90° − zenith prints as written in the job (−4.2, not −4.200000000000003).
fn tidy(x: f64) -> String {
    format!("{}", (x * 1e9).round() / 1e9)
}

/// A Markdown table of the mean share per region of `rows` (elevation,
/// altitude (m), shares), grouped by sun elevation and observer altitude.
fn region_table(what: &str, rows: &[(f64, f64, [f64; 4])]) -> String {
    let mut keys: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.1)).collect();
    keys.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    keys.dedup();
    let names: Vec<&str> = regions::Region::ALL.iter().map(|r| r.name()).collect();
    let mut md = format!(
        "\n{what}, mean share per region (aureole: within {}° of the sun; horizon: θ′ within {}° of 90°; below: \
         beyond it; sky: the rest):\n\n| elevation | altitude (m) | {} |\n|---|---|{}\n",
        regions::AUREOLE_DEG,
        regions::HORIZON_DEG,
        names.join(" | "),
        "---|".repeat(names.len())
    );
    for (e, h) in keys {
        let group: Vec<&[f64; 4]> = rows.iter().filter(|r| r.0 == e && r.1 == h).map(|r| &r.2).collect();
        let n = group.len().max(1) as f64;
        let means: Vec<String> = (0..4)
            .map(|k| format!("{:.2}", group.iter().map(|g| g[k]).sum::<f64>() / n))
            .collect();
        md.push_str(&format!("| {} | {h} | {} |\n", tidy(e), means.join(" | ")));
    }
    md
}

/// The per-image scores as CSV.
pub fn scores_csv(scores: &[ImageScore]) -> String {
    let mut s = String::from(
        "visibility_km,albedo,altitude_m,elevation_deg,wavelength_nm,snr_db,noise_floor_db,debiased_snr_db,\
         debiased_snr_lower_db,debiased_snr_sd_db,nmae,polarisation_error,excess_aureole,excess_horizon,\
         excess_below,excess_sky\n",
    );
    for x in scores {
        s.push_str(&format!(
            "{},{},{},{},{},{:.4},{:.4},{},{:.4},{:.4},{:.6},{},{:.4},{:.4},{:.4},{:.4}\n",
            tidy(x.visibility_km),
            tidy(x.albedo),
            tidy(x.altitude_m),
            tidy(x.elevation_deg),
            tidy(x.wavelength_nm),
            x.snr_db,
            x.noise_floor_db,
            x.debiased_snr_db.map_or(String::new(), |v| format!("{v:.4}")),
            x.debiased_snr_lower_db,
            x.debiased_snr_sd_db,
            x.nmae,
            x.polarisation_error.map_or(String::new(), |v| format!("{v:.6}")),
            x.excess_by_region[0],
            x.excess_by_region[1],
            x.excess_by_region[2],
            x.excess_by_region[3]
        ));
    }
    s
}

/// The seed-to-seed scores as CSV.
pub fn twin_csv(twin: &[TwinScore]) -> String {
    let mut s = String::from(
        "visibility_km,albedo,altitude_m,elevation_deg,wavelength_nm,seed_to_seed_snr_db,inherited_snr_db,\
         polarisation_difference,difference_aureole,difference_horizon,difference_below,difference_sky\n",
    );
    for t in twin {
        s.push_str(&format!(
            "{},{},{},{},{},{:.4},{:.4},{},{:.4},{:.4},{:.4},{:.4}\n",
            tidy(t.visibility_km),
            tidy(t.albedo),
            tidy(t.altitude_m),
            tidy(t.elevation_deg),
            tidy(t.wavelength_nm),
            t.seed_to_seed_snr_db,
            t.inherited_snr_db(),
            t.polarisation_difference.map_or(String::new(), |v| format!("{v:.6}")),
            t.difference_by_region[0],
            t.difference_by_region[1],
            t.difference_by_region[2],
            t.difference_by_region[3]
        ));
    }
    s
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
        let snr: Vec<f64> = extras.interpolation.iter().map(|s| s.snr_interpolated_db).collect();
        let (m, lo) = mean_min(&snr);
        md.push_str(&format!(
            "| SNR of the interpolated dataset against the between-node renders, mean / minimum over {} images | {m:.2} / {lo:.2} dB |\n",
            snr.len()
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
    let own_debiased: Vec<f64> = scores
        .iter()
        .map(|s| s.debiased_snr_db.unwrap_or(s.debiased_snr_lower_db))
        .collect();
    if !own_debiased.is_empty() {
        let (m, lo) = mean_min(&own_debiased);
        md.push_str(&format!(
            "| SNR with the renders' noise taken out, mean / minimum (flatters: the fit follows part of its renders' \
             noise; see the reference below) | {m:.2} / {lo:.2} dB |\n"
        ));
    }
    if let Some(r) = reference_summary(&extras.reference) {
        md.push_str(&format!(
            "\n## Against the converged sky\n\n{} images of reference renders ({}) made apart from the fit's renders, \
             compared at their pixel centres with the dataset at their configurations (solid-angle weights). The \
             references' noise adds to the error in expectation: the debiased SNR takes it out (exact in expectation \
             for renders independent of the fit's); where the references' noise does not resolve an image's error \
             (its excess over the noise within two standard deviations) the image counts at its lower bound.\n\n\
             | figure | value |\n|---|---|\n",
            r.images, extras.reference_source
        ));
        md.push_str(&format!(
            "| SNR against the references, mean / minimum | {:.2} / {:.2} dB |\n\
             | the references' own noise floor, mean / minimum | {:.2} / {:.2} dB |\n\
             | SNR against the converged sky (debiased), mean / minimum | {:.2} / {:.2} dB |\n\
             | images not resolved by the references (counted at their lower bound) | {} |\n\
             | NMAE, mean / max | {:.4} / {:.4} |\n",
            r.snr_db.0,
            r.snr_db.1,
            r.noise_floor_db.0,
            r.noise_floor_db.1,
            r.debiased_snr_db.0,
            r.debiased_snr_db.1,
            r.unresolved,
            r.nmae.0,
            r.nmae.1
        ));
        if let Some((m, x)) = r.polarisation_error {
            md.push_str(&format!(
                "| polarisation: radiance-weighted mean abs. error of the degree of polarisation, mean / max | {m:.4} / {x:.4} |\n"
            ));
        }
        let rows: Vec<(f64, f64, [f64; 4])> = extras
            .reference
            .iter()
            .map(|t| (t.elevation_deg, t.altitude_m, t.excess_by_region))
            .collect();
        md.push_str(&region_table(
            "Where the error against the references lies (its excess over their noise)",
            &rows,
        ));
        md.push_str(
            "\nPer image (`reference.csv`):\n\n| visibility | albedo | altitude (m) | elevation | channel | SNR (dB) | \
             reference noise floor (dB) | debiased SNR (dB) | NMAE | pol. error |\n|---|---|---|---|---|---|---|---|---|---|\n",
        );
        for s in &extras.reference {
            md.push_str(&format!(
                "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {} | {:.4} | {} |\n",
                s.visibility_km,
                s.albedo,
                s.altitude_m,
                tidy(s.elevation_deg),
                s.wavelength_nm,
                s.snr_db,
                s.noise_floor_db,
                s.debiased_snr_db
                    .map_or(format!("≥ {:.2}", s.debiased_snr_lower_db), |v| format!("{v:.2}")),
                s.nmae,
                s.polarisation_error.map_or("—".into(), |p| format!("{p:.4}"))
            ));
        }
    }
    if let Some(((m, lo), pol)) = twin_summary(&extras.twin) {
        md.push_str(&format!(
            "\n## Render noise carried into the dataset\n\nThe twin dataset {} was fitted from the same configurations \
             rendered with an independent seed; both evaluated at the pixel centres of each image. Their difference is \
             two draws of the noise a dataset inherits from its renders, so one dataset's inherited noise is {TWO:.2} dB \
             below it.\n\n| figure | value |\n|---|---|\n\
             | seed-to-seed SNR, mean / minimum | {m:.2} / {lo:.2} dB |\n\
             | one dataset against its inherited noise, mean / minimum | {:.2} / {:.2} dB |\n",
            extras.twin_source,
            m + twin::TWO_DRAWS_DB,
            lo + twin::TWO_DRAWS_DB,
            TWO = twin::TWO_DRAWS_DB
        ));
        if let Some((pm, px)) = pol {
            md.push_str(&format!(
                "| degree of polarisation, radiance-weighted mean abs. difference, mean / max | {pm:.4} / {px:.4} |\n"
            ));
        }
        let rows: Vec<(f64, f64, [f64; 4])> = extras
            .twin
            .iter()
            .map(|t| (t.elevation_deg, t.altitude_m, t.difference_by_region))
            .collect();
        md.push_str(&region_table("Where the seed-to-seed difference lies", &rows));
        md.push_str("\nPer image: `twin.csv`.\n");
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
            .map(|&v| (tidy(v), scores.iter().filter(|s| key(s) == v).map(|s| s.nmae).collect()))
            .collect();
        let png = format!("nmae_by_{file}.png");
        write_box_plot(&dir.join(&png), &format!("NMAE by {title}"), &groups)?;
        md.push_str(&format!("### By {title}\n\n![NMAE by {title}]({png})\n\n| {title} | median | max | SNR min (dB) |\n|---|---|---|---|\n"));
        for (label, g) in &groups {
            let f = five_numbers(g).unwrap_or([f64::NAN; 5]);
            let snr_min = scores
                .iter()
                .filter(|s| tidy(key(s)) == *label)
                .fold(f64::INFINITY, |m, s| m.min(s.snr_db));
            md.push_str(&format!("| {label} | {:.4} | {:.4} | {snr_min:.2} |\n", f[2], f[4]));
        }
        md.push('\n');
    }
    if !extras.explained.is_empty() {
        md.push_str("## Explained variance of the (γ, α) tables by rank (over their cells with data)\n\n| rank | mean | minimum |\n|---|---|---|\n");
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
        md.push_str("\nEvery image:\n\n| visibility | albedo | altitude (m) | elevation | channel | rmse(B, I) | rmse(B, F) | ratio | SNR(B, I) (dB) |\n|---|---|---|---|---|---|---|---|---|\n");
        for s in &extras.interpolation {
            md.push_str(&format!(
                "| {} | {} | {} | {} | {} | {:.4e} | {:.4e} | {:.3} | {:.2} |\n",
                s.visibility_km,
                s.albedo,
                s.altitude_m,
                tidy(s.elevation_deg),
                s.wavelength_nm,
                s.rmse_interpolated,
                s.rmse_fit,
                s.ratio(),
                s.snr_interpolated_db
            ));
        }
        md.push('\n');
    }
    md.push_str("## Per image\n\n(`images.csv`)\n\n| visibility | albedo | altitude (m) | elevation | channel | SNR (dB) | noise floor (dB) | NMAE | pol. error |\n|---|---|---|---|---|---|---|---|---|\n");
    for s in scores {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.4} | {} |\n",
            s.visibility_km,
            s.albedo,
            s.altitude_m,
            tidy(s.elevation_deg),
            s.wavelength_nm,
            s.snr_db,
            s.noise_floor_db,
            s.nmae,
            s.polarisation_error.map_or("—".into(), |p| format!("{p:.4}"))
        ));
    }
    write_atomic(&dir.join("images.csv"), scores_csv(scores).as_bytes())?;
    if !extras.reference.is_empty() {
        write_atomic(&dir.join("reference.csv"), scores_csv(&extras.reference).as_bytes())?;
    }
    if !extras.twin.is_empty() {
        write_atomic(&dir.join("twin.csv"), twin_csv(&extras.twin).as_bytes())?;
    }
    write_atomic(&dir.join("report.md"), md.as_bytes())?;
    Ok(md)
}
