//! The fit's settings file (`atmosim fit FIT.toml`): where the renders
//! are, where the dataset goes, and how the fit is made. Only `renders`
//! and `out` are required; every other key has the default the Prague sky
//! model's supplement used where it states one.
//!
//! Paths are taken from the current directory, as a job's
//! `output.directory` is.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};

/// Resolved fit settings.
#[derive(Debug, Clone, PartialEq)]
pub struct FitSettings {
    /// The render jobs' output directories (each holds one directory per task).
    pub renders: Vec<PathBuf>,
    /// A transmittance job's output directory (tables on the `sky_model`
    /// layout), if given; without it the fit computes the tables of the
    /// render jobs' atmosphere itself (32 × 64 nodes, analytic).
    pub transmittance: Option<PathBuf>,
    /// The dataset file to write.
    pub out: PathBuf,
    /// Rank of the radiance decomposition (seed: 9).
    pub rank: usize,
    /// Rank of the polarisation decomposition (seed: 5); 0 writes no
    /// polarisation part.
    pub polarisation_rank: usize,
    /// Rank of the transmittance decomposition per observer altitude.
    pub transmittance_rank: TransmittanceRank,
    /// Nodes per axis of the (γ, α) table (seed: 361, 0.5°).
    pub resolution: usize,
    /// Break counts of the stored functions (seed: 275, 205, 118).
    pub sun_breaks: usize,
    pub zenith_breaks: usize,
    pub emph_breaks: usize,
    /// σ of the Gaussian blur of the (γ, α) table, in nodes (seed: 1; 0 = none).
    pub blur_sigma: f64,
    /// Sweeps of the weighted decomposition's alternating solve (0: the
    /// plain SVD of the filled table).
    pub impute_iterations: usize,
    /// The weight of a (γ, α) cell filled harmonically (no sky has it)
    /// relative to a cell with data, in the decomposition (1: the plain
    /// SVD of the filled table).
    pub fill_weight: f64,
    /// Whether a table's cells that its own sky lacks are borrowed from the
    /// neighbouring sun elevations' tables where they have them (the
    /// supplement's dilation) before the rest is filled harmonically.
    pub neighbour_fill: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFit {
    renders: Option<OneOrMany>,
    transmittance: Option<String>,
    out: Option<String>,
    rank: Option<i64>,
    polarisation_rank: Option<i64>,
    transmittance_rank: Option<RankValue>,
    resolution: Option<i64>,
    sun_breaks: Option<i64>,
    zenith_breaks: Option<i64>,
    emph_breaks: Option<i64>,
    blur_sigma: Option<f64>,
    impute_iterations: Option<i64>,
    fill_weight: Option<f64>,
    neighbour_fill: Option<bool>,
}

/// A rank written as a number or as a word (`"auto"`).
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum RankValue {
    Number(i64),
    Word(String),
}

/// The rank of the transmittance decomposition: fixed, or chosen per
/// grid (`"auto"`, the default): the smallest from the supplement's 12 up,
/// in steps of [`AUTO_RANK_STEP`], whose largest error in T at the nodes
/// is at most [`AUTO_MAX_ERROR`], at most the number of (visibility,
/// channel) columns, where the decomposition is exact. Eleven bands of
/// 40 nm stay at 12 (6.6e-4); 55 bands from 280 to 2480 nm, whose gas
/// bands differ from each other, needed 20 (8.2e-4, against 1.53e-2 at 12;
/// docs/sky-models.md, "A 55-channel dataset").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransmittanceRank {
    Fixed(usize),
    Auto,
}

/// The first rank `"auto"` tries: the supplement's.
pub const AUTO_RANK_START: usize = 12;

/// The step between the ranks `"auto"` tries.
pub const AUTO_RANK_STEP: usize = 4;

/// The largest error in T at the nodes `"auto"` accepts: a fifth of the
/// grid's target of 0.005 (docs/sky-models.md, the mini grid's table).
pub const AUTO_MAX_ERROR: f64 = 1e-3;

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum OneOrMany {
    One(String),
    Many(Vec<String>),
}

impl FitSettings {
    /// Reads and checks the settings file at `path`.
    pub fn from_file(path: &Path) -> Result<FitSettings> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Checks settings text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<FitSettings> {
        let raw: RawFit = toml::from_str(text).map_err(|e| Error::JobSyntax {
            file: file.to_string(),
            message: e.to_string().trim_end().to_string(),
        })?;
        let invalid = |key: &str, value: String, reason: &str, valid: &str| Error::InvalidValue {
            file: file.to_string(),
            key: key.to_string(),
            value,
            reason: reason.to_string(),
            valid: valid.to_string(),
        };
        let renders: Vec<PathBuf> = match raw.renders {
            None => {
                return Err(invalid(
                    "renders",
                    "missing".into(),
                    "required",
                    "a render job's output directory, or a list of them",
                ));
            }
            Some(OneOrMany::One(s)) => vec![PathBuf::from(s)],
            Some(OneOrMany::Many(v)) => v.into_iter().map(PathBuf::from).collect(),
        };
        if renders.is_empty() || renders.iter().any(|p| p.as_os_str().is_empty()) {
            return Err(invalid(
                "renders",
                format!("{renders:?}"),
                "no directory",
                "a render job's output directory, or a list of them",
            ));
        }
        let out = match raw.out {
            Some(s) if !s.is_empty() => PathBuf::from(s),
            Some(_) => {
                return Err(invalid(
                    "out",
                    "\"\"".into(),
                    "empty",
                    "the dataset file to write, e.g. \"sky.dat\"",
                ));
            }
            None => {
                return Err(invalid(
                    "out",
                    "missing".into(),
                    "required",
                    "the dataset file to write, e.g. \"sky.dat\"",
                ));
            }
        };
        let count = |key: &str, v: Option<i64>, default: usize, lo: i64, hi: i64| -> Result<usize> {
            match v {
                None => Ok(default),
                Some(n) if (lo..=hi).contains(&n) => Ok(n as usize),
                Some(n) => Err(invalid(key, n.to_string(), "out of range", &format!("{lo} to {hi}"))),
            }
        };
        let resolution = count("resolution", raw.resolution, 361, 9, 4001)?;
        let rank = count("rank", raw.rank, 9, 1, resolution as i64)?;
        let polarisation_rank = count("polarisation_rank", raw.polarisation_rank, 5, 0, resolution as i64)?;
        let transmittance_rank = match raw.transmittance_rank {
            None => TransmittanceRank::Auto,
            Some(RankValue::Word(w)) if w == "auto" => TransmittanceRank::Auto,
            Some(RankValue::Word(w)) => {
                return Err(invalid(
                    "transmittance_rank",
                    format!("{w:?}"),
                    "not a rank",
                    "\"auto\" or 1 to 1000",
                ));
            }
            Some(RankValue::Number(n)) if (1..=1000).contains(&n) => TransmittanceRank::Fixed(n as usize),
            Some(RankValue::Number(n)) => {
                return Err(invalid(
                    "transmittance_rank",
                    n.to_string(),
                    "out of range",
                    "\"auto\" or 1 to 1000",
                ));
            }
        };
        let sun_breaks = count("sun_breaks", raw.sun_breaks, 275, 2, 100_000)?;
        let zenith_breaks = count("zenith_breaks", raw.zenith_breaks, 205, 3, 100_000)?;
        let emph_breaks = count("emph_breaks", raw.emph_breaks, 118, 3, 100_000)?;
        let real = |key: &str, v: Option<f64>, default: f64, hi: f64| -> Result<f64> {
            let v = v.unwrap_or(default);
            if v.is_finite() && (0.0..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(invalid(key, v.to_string(), "out of range", &format!("0 to {hi}")))
            }
        };
        Ok(FitSettings {
            renders,
            transmittance: raw.transmittance.map(PathBuf::from),
            out,
            rank,
            polarisation_rank,
            transmittance_rank,
            resolution,
            sun_breaks,
            zenith_breaks,
            emph_breaks,
            blur_sigma: real("blur_sigma", raw.blur_sigma, 1.0, 20.0)?,
            impute_iterations: count("impute_iterations", raw.impute_iterations, 50, 0, 1000)?,
            fill_weight: real("fill_weight", raw.fill_weight, 1e-6, 1.0)?,
            neighbour_fill: raw.neighbour_fill.unwrap_or(true),
        })
    }

    /// The settings as TOML, for the dataset's provenance sidecar.
    pub fn to_toml(&self) -> String {
        let q = |p: &Path| format!("{:?}", p.display().to_string());
        let renders: Vec<String> = self.renders.iter().map(|p| q(p)).collect();
        let mut s = format!("renders = [{}]\n", renders.join(", "));
        if let Some(t) = &self.transmittance {
            s.push_str(&format!("transmittance = {}\n", q(t)));
        }
        s.push_str(&format!(
            "out = {}\nrank = {}\npolarisation_rank = {}\ntransmittance_rank = {}\nresolution = {}\n\
             sun_breaks = {}\nzenith_breaks = {}\nemph_breaks = {}\nblur_sigma = {:?}\nimpute_iterations = {}\nfill_weight = {:?}\nneighbour_fill = {}\n",
            q(&self.out),
            self.rank,
            self.polarisation_rank,
            match self.transmittance_rank {
                TransmittanceRank::Fixed(n) => n.to_string(),
                TransmittanceRank::Auto => "\"auto\"".to_string(),
            },
            self.resolution,
            self.sun_breaks,
            self.zenith_breaks,
            self.emph_breaks,
            self.blur_sigma,
            self.impute_iterations,
            self.fill_weight,
            self.neighbour_fill
        ));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_required_keys_are_enough_and_the_defaults_are_the_seeds() {
        let s = FitSettings::parse("renders = \"r\"\nout = \"sky.dat\"\n", "fit.toml").unwrap();
        assert_eq!(s.renders, vec![PathBuf::from("r")]);
        assert_eq!(
            (s.rank, s.polarisation_rank, s.transmittance_rank),
            (9, 5, TransmittanceRank::Auto)
        );
        assert_eq!(
            (s.sun_breaks, s.zenith_breaks, s.emph_breaks, s.resolution),
            (275, 205, 118, 361)
        );
        assert_eq!(s.blur_sigma, 1.0);
        assert_eq!((s.impute_iterations, s.fill_weight), (50, 1e-6));
        assert_eq!(s.transmittance, None);
        assert!(s.neighbour_fill);
        // The provenance text reads back as the same settings.
        assert_eq!(FitSettings::parse(&s.to_toml(), "again").unwrap(), s);
        let fixed = FitSettings::parse("renders = \"r\"\nout = \"x\"\ntransmittance_rank = 20\n", "f").unwrap();
        assert_eq!(fixed.transmittance_rank, TransmittanceRank::Fixed(20));
        assert_eq!(FitSettings::parse(&fixed.to_toml(), "again").unwrap(), fixed);
    }

    #[test]
    fn bad_settings_name_their_key() {
        for (text, key) in [
            ("out = \"x\"\n", "renders"),
            ("renders = \"r\"\n", "out"),
            ("renders = \"r\"\nout = \"x\"\nrank = 0\n", "rank"),
            ("renders = \"r\"\nout = \"x\"\nresolution = 3\n", "resolution"),
            ("renders = \"r\"\nout = \"x\"\nblur_sigma = -1.0\n", "blur_sigma"),
            ("renders = \"r\"\nout = \"x\"\nfill_weight = 2.0\n", "fill_weight"),
            ("renders = \"r\"\nout = \"x\"\nfill_weight = -1e-4\n", "fill_weight"),
            ("renders = []\nout = \"x\"\n", "renders"),
            ("renders = \"r\"\nout = \"x\"\nrnak = 3\n", "rnak"),
            ("renders = \"r\"\nout = \"x\"\nneighbour_fill = 1\n", "neighbour_fill"),
            (
                "renders = \"r\"\nout = \"x\"\ntransmittance_rank = 0\n",
                "transmittance_rank",
            ),
            (
                "renders = \"r\"\nout = \"x\"\ntransmittance_rank = \"automatic\"\n",
                "transmittance_rank",
            ),
        ] {
            let e = FitSettings::parse(text, "fit.toml").unwrap_err();
            assert!(e.is_user_error());
            assert!(e.to_string().contains(key), "{text}: {e}");
        }
    }
}
