//! The wide range's gas absorption against a second, independent source:
//! the band-mean direct transmittance of the vertical column through each
//! AFGL profile at sun zenith 0° and 60°, against the Kato et al. (1999)
//! correlated-k tables (HITRAN 2000, libRadtran's `kato2`;
//! `validation/gases/kato_band_transmittance.txt`, derived by
//! `scripts/derive_gases.py`).
//!
//! Kato's tables hold the mixture of the gases that absorb in a band (its
//! "H₂O" tables carry CO₂, O₂ and the rest as functions of the water
//! amount), so atmosim's side has every k-distribution gas on (H₂O, CO₂,
//! O₂, CH₄, N₂O), plane-parallel, without Rayleigh, ozone or aerosol.
//! Kato's bands (20–320 nm) do not fall on the 40 nm grid: atmosim's
//! pseudo-spectrum spreads each 40 nm band's absorption over the whole
//! band, so a Kato band that cuts a 40 nm band part-way compares
//! different wavelengths. Informational: a comparison of two sources
//! (LOWTRAN 7's band model and HITRAN 2000 line-by-line), not a test.

use std::path::Path;

use super::case::Case;
use super::stats::Value;
use crate::error::{Error, Result};
use crate::job::Job;
use crate::physics::data::Table;

const KATO: (&str, &str) = (
    "gases/kato_band_transmittance.txt",
    include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/validation/gases/kato_band_transmittance.txt"
    )),
);

/// The profiles in the reference's order.
const PROFILES: [&str; 6] = [
    "us_standard",
    "midlatitude_summer",
    "midlatitude_winter",
    "subarctic_summer",
    "subarctic_winter",
    "tropical",
];

/// The gas case.
pub(super) fn cases() -> Vec<Case> {
    vec![Case {
        name: "gases_kato",
        title: "Wide-range gas absorption: band transmittance against Kato et al. 1999",
        reference: "validation/gases/kato_band_transmittance.txt (Kato correlated-k, HITRAN 2000): \
                    vertical column of the six AFGL profiles, μ0 1 and 0.5, Kato bands 566–2275 nm",
        setup: "atmosim's k-distributions (LOWTRAN 7 band model) of H2O, CO2, O2, CH4, N2O; plane-parallel, \
                no Rayleigh, ozone or aerosol; band mean of exp(-tau/mu0) on 0.05 nm cells (deterministic)",
        floor: "none: informational (two absorption sources compared; Kato's bands are not on the 40 nm grid)",
        default_samples: 1,
        informational: true,
        ratio_limit: None,
        run: kato,
    }]
}

fn kato(_samples: u64) -> Result<Vec<Value>> {
    let table = Table::parse(KATO.0, KATO.1, 6)?;
    let mut values = Vec::new();
    for (p, profile) in PROFILES.iter().enumerate() {
        let text = format!(
            "[planet]\ngeometry = \"plane_parallel\"\n[atmosphere]\nprofile = \"{profile}\"\nrayleigh = \"none\"\n\
             ozone = \"none\"\naerosol = \"none\"\ngases = [\"h2o\", \"co2\", \"o2\", \"ch4\", \"n2o\"]\n\
             [spectrum]\nwavelengths_nm = [1380.0]\nband_width_nm = 2200.0\n"
        );
        let job = Job::parse(&text, "gases_kato", Path::new("."))
            .map_err(|e| Error::data("gases_kato", format!("the case's job: {e}")))?;
        for r in table.rows.iter().filter(|r| r[0] == p as f64) {
            let (lo, hi) = (r[2], r[3]);
            for (zenith, mu, reference) in [(0.0, 1.0, r[4]), (60.0, 0.5, r[5])] {
                values.push(Value {
                    label: format!("{profile} {lo:.1}-{hi:.1} nm sun zenith {zenith}"),
                    group: format!("sun zenith {zenith}"),
                    view_zenith_deg: zenith,
                    azimuth_deg: 0.0,
                    component: 0,
                    atmosim: job.atmosphere.band_transmittance(lo, hi, mu),
                    atmosim_se: 0.0,
                    reference,
                    reference_se: 0.0,
                    floor: 0.0,
                    in_stats: true,
                });
            }
        }
    }
    Ok(values)
}
