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
//!
//! And the columns the gases' optical depths rest on: water vapour and O₂
//! through each AFGL profile against MODTRAN 6's table of the same
//! profiles (`validation/gases/modtran_columns.txt`), tested.

use std::path::Path;

use super::case::Case;
use super::stats::Value;
use crate::error::{Error, Result};
use crate::job::Job;
use crate::physics::data::Table;

const COLUMNS: (&str, &str) = (
    "gases/modtran_columns.txt",
    include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/validation/gases/modtran_columns.txt"
    )),
);

/// Molecules per cm² in one atm-cm (Loschmidt's number, 273.15 K, 1 atm).
const LOSCHMIDT_PER_CM3: f64 = 2.686_781_1e19;

/// The columns' accuracy floor, relative: the two integrate the same
/// level values between the levels each its own way (MODTRAN to 120 km,
/// atmosim to 100 km, where the water and O₂ above are under 1e-6 of the
/// column); measured 0.05–0.08 % (2026-11-29), the table's own rounding
/// 0.005 %.
const COLUMN_FLOOR: f64 = 1e-3;

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

/// The gas cases.
pub(super) fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "gas_columns",
            title: "AFGL profiles' water vapour and O2 columns against MODTRAN 6's table",
            reference: "validation/gases/modtran_columns.txt (MODTRAN 6 help, Model Atmospheres, Table 1, atm-cm)",
            setup: "the vertical column of each built-in AFGL profile to 100 km as the gases' optical depths use it \
                    (src/physics/gas_columns.rs), in atm-cm",
            floor: "0.1 % of the column: the two integrate the same levels each its own way (measured 0.05-0.08 %)",
            default_samples: 1,
            informational: false,
            ratio_limit: None,
            run: columns,
        },
        Case {
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
        },
    ]
}

fn columns(_samples: u64) -> Result<Vec<Value>> {
    use crate::physics::gas_columns::total_column_cm2;
    use crate::physics::kdistribution::Gas;
    use crate::physics::profile::GasProfile;

    let table = Table::parse(COLUMNS.0, COLUMNS.1, 3)?;
    let mut values = Vec::new();
    for r in &table.rows {
        let name = PROFILES
            .get(r[0] as usize)
            .ok_or_else(|| Error::data(COLUMNS.0, format!("profile index {} out of range", r[0])))?;
        let profile = GasProfile::builtin(name)
            .ok_or_else(|| Error::data(COLUMNS.0, format!("no built-in profile `{name}`")))??
            .truncated(100.0);
        for (gas, label, reference) in [(Gas::H2o, "H2O", r[1]), (Gas::O2, "O2", r[2])] {
            values.push(Value {
                label: format!("{name} {label} column (atm-cm)"),
                group: label.to_string(),
                view_zenith_deg: 0.0,
                azimuth_deg: 0.0,
                component: 0,
                atmosim: total_column_cm2(&profile, gas) / LOSCHMIDT_PER_CM3,
                atmosim_se: 0.0,
                reference,
                reference_se: 0.0,
                floor: COLUMN_FLOOR * reference,
                in_stats: true,
            });
        }
    }
    Ok(values)
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
