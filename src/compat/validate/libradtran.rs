//! The libRadtran 2.0.3 (uvspec) runs at 540 nm, sun zenith 45°, observers
//! at 0 and 10 km (validation/libradtran/uvspec_540nm_sza45.txt), each
//! reproduced from its uvspec input file (validation/libradtran/*.inp)
//! through `atmosim uvspec`'s parser, so the cases also pin the umu/phi
//! mapping: every (umu, phi) of an input must land on a reference row's
//! (view zenith, azimuth).
//!
//! Geometry per comparison: polRadtran and `disort_pp` are plane-parallel,
//! and so is atmosim. `disort_ps` is pseudo-spherical, which attenuates only
//! the direct beam along its spherical path and keeps the diffuse field
//! plane-parallel; atmosim's `pseudo_spherical` geometry does the same, so
//! that the comparison tests the transport rather than the approximation
//! (full spherical geometry differs from it by several per cent near the
//! horizon, where the line of sight's air mass differs).

use super::case::Case;
use super::cases::push;
use super::stats::Value;
use crate::compat::uvspec::UvspecInput;
use crate::error::{Error, Result};
use crate::film::directions::render_directions_all;
use crate::physics::data::Table;
use crate::sampling::stream::Render;

const REFERENCE: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/validation/libradtran/uvspec_540nm_sza45.txt"
));

macro_rules! embedded {
    ($($name:literal),* $(,)?) => {
        &[$(($name, include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/validation/libradtran/", $name)))),*]
    };
}

/// The input files and the files they name.
pub static FILES: &[(&str, &str)] = embedded![
    "A_disort_pp.inp",
    "A_disort_ps.inp",
    "A_polrad.inp",
    "B_disort_pp.inp",
    "B_disort_ps.inp",
    "B_polrad.inp",
    "H_disort_pp.inp",
    "H_disort_ps.inp",
    "H_540nm_aer_tau.txt",
    "H_540nm_aer_ssa.txt",
    "H_540nm_aer_gg.txt",
];

/// An embedded uvspec input, parsed (its files resolved among [`FILES`]).
pub fn input(name: &str) -> Result<UvspecInput> {
    let find = |n: &str| FILES.iter().find(|(f, _)| *f == n).map(|(_, t)| *t);
    let text = find(name).ok_or_else(|| Error::data("validation", format!("no embedded input `{name}`")))?;
    let resolve = |n: &str| {
        find(n)
            .map(str::to_string)
            .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, "not embedded"))
    };
    UvspecInput::parse(text, &format!("validation/libradtran/{name}"), &resolve)
}

/// Relative accuracy floor of scalar DISORT (32 streams).
const DISORT_FLOOR: f64 = 1e-5;
/// Relative accuracy floor assumed for polRadtran (16 streams).
const POLRAD_FLOOR: f64 = 2e-4;

/// The accuracy floor of a reference row in the z test (closed set).
#[derive(Debug, Clone, Copy)]
enum Floor {
    /// This fraction of the row's I, for each component.
    Relative(f64),
    /// polRadtran with Mie aerosol (B): [`POLRAD_FLOOR`]·I plus the row's own
    /// truncation error, estimated as the part of its difference from
    /// plane-parallel DISORT (32 streams, intensity-corrected) that the
    /// gas-only atmosphere (A) does not show, where the two solvers differ
    /// only by polarisation: |I_pol,B − I_pp,B·I_pol,A/I_pp,A|; for each
    /// component (the truncated phase function is the one all four
    /// elements are expanded with).
    PolradMie,
}

/// The reference's I for `atmosphere` and `solver` in the direction of `row`.
fn reference_i(reference: &Table, atmosphere: f64, solver: f64, row: &[f64]) -> Option<f64> {
    reference
        .rows
        .iter()
        .find(|r| r[0] == atmosphere && r[1] == solver && r[2] == row[2] && r[3] == row[3] && r[4] == row[4])
        .map(|r| r[5])
}

impl Floor {
    fn of(self, reference: &Table, row: &[f64]) -> Result<f64> {
        match self {
            Floor::Relative(f) => Ok(f * row[5]),
            Floor::PolradMie => {
                let missing = || Error::data("uvspec_540nm_sza45.txt", "a direction lacks its A or disort_pp row");
                let pp_b = reference_i(reference, 1.0, 0.0, row).ok_or_else(missing)?;
                let pol_a = reference_i(reference, 0.0, 2.0, row).ok_or_else(missing)?;
                let pp_a = reference_i(reference, 0.0, 0.0, row).ok_or_else(missing)?;
                Ok(POLRAD_FLOOR * row[5] + (row[5] - pp_b * pol_a / pp_a).abs())
            }
        }
    }
}

/// Compares the run of `inp` with the reference rows of `atmosphere` and
/// `solver` (codes of the reference file), every direction in the
/// statistics.
fn compare(inp: &str, atmosphere: f64, solver: f64, floor: Floor, samples: u64) -> Result<Vec<Value>> {
    let reference = Table::parse("uvspec_540nm_sza45.txt", REFERENCE, 9)?;
    let input = input(inp)?;
    let job = input.job(samples, 17, false)?;
    let directions = input.directions();
    let dirs: Vec<_> = directions.iter().map(|(_, _, d)| *d).collect();
    let mut values = Vec::new();
    for task in &job.tasks {
        let z = task.observer_altitude_km;
        let scene = job.scene_for(task, 0);
        let tallies = render_directions_all(
            &scene,
            z,
            &dirs,
            samples,
            job.render.seed,
            Render::channel(task.index, 0),
        )
        .swap_remove(0)
        .swap_remove(0);
        for ((umu, phi, d), t) in directions.iter().zip(&tallies) {
            let row = reference
                .rows
                .iter()
                .find(|r| {
                    r[0] == atmosphere && r[1] == solver && r[2] == z && (r[3] - d.view_zenith_deg).abs() < 1e-3 && {
                        let da = (r[4] - d.azimuth_deg).rem_euclid(360.0);
                        da.min(360.0 - da) < 1e-6
                    }
                })
                .ok_or_else(|| {
                    Error::data(
                        "uvspec_540nm_sza45.txt",
                        format!(
                            "no reference row for {inp} zout {z} umu {umu} phi {phi} (θ {:.4}, φ {})",
                            d.view_zenith_deg, d.azimuth_deg
                        ),
                    )
                })?;
            let polarized = row[8] == 1.0;
            let components: &[usize] = if polarized { &[0, 1, 2] } else { &[0] };
            let label = format!("zout {z} umu {umu} phi {phi}");
            let floor = floor.of(&reference, row)?;
            push(&mut values, &label, *d, t, components, &row[5..8], &[], floor, true);
        }
    }
    Ok(values)
}

const DISORT_FLOOR_NOTE: &str = "1e-5 × I: 7 printed digits (5e-7), 32-stream truncation (32 and 128 streams agree \
     to 5e-6 for Rayleigh and HG layers, validation/disort/pydisort.txt), atmosim's layer optical depths against \
     uvspec's (Rayleigh 1e-6 per layer, ozone column 1e-5: tests/atmosphere_libradtran.rs)";
const POLRAD_FLOOR_NOTE: &str = "2e-4 × I (and of Q, U), assumed: 16-stream polRadtran has no convergence study \
     here; 2e-4 is the size of the polrad − disort_pp difference of the ground-reflected radiance at 0 km (1.8e-4), \
     which bounds truncation plus polarisation in the downward flux";
const POLRAD_MIE_NOTE: &str = "2e-4 × I plus polRadtran's own truncation error per direction, estimated as \
     |I_pol,B − I_pp,B·I_pol,A/I_pp,A| (the polrad − disort_pp difference that the gas-only atmosphere A, where the \
     two differ only by polarisation, does not show), for I, Q and U alike: 16 streams cannot expand the Mie forward \
     peak, which makes polRadtran's I 27 % high 90° from the sun and 80 % low looking at it. Informational: that \
     estimate misses up to 0.3 % of I where aerosol changes the polarisation's effect on I (upwelling at 10 km), and \
     the reference has no other measure of its Q, U accuracy; measured: |ΔQ|, |ΔU| ≤ 0.4 % of I everywhere \
     (docs/validation.md)";

/// The libRadtran cases.
pub(super) fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "libradtran_A_polrad",
            title: "libRadtran 540 nm, gases only (A), polarised, against polRadtran",
            reference: "validation/libradtran/uvspec_540nm_sza45.txt, atmosphere A, polrad (I, Q, U); input \
                        validation/libradtran/A_polrad.inp",
            setup: "plane-parallel (as polRadtran), polarised, R 6370 km, top 120 km, albedo 0.2",
            floor: POLRAD_FLOOR_NOTE,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| compare("A_polrad.inp", 0.0, 2.0, Floor::Relative(POLRAD_FLOOR), n),
        },
        Case {
            name: "libradtran_A_disort_pp",
            title: "libRadtran 540 nm, gases only (A), scalar, against plane-parallel DISORT",
            reference: "uvspec_540nm_sza45.txt, atmosphere A, disort_pp; input A_disort_pp.inp",
            setup: "plane-parallel, scalar",
            floor: DISORT_FLOOR_NOTE,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| compare("A_disort_pp.inp", 0.0, 0.0, Floor::Relative(DISORT_FLOOR), n),
        },
        Case {
            name: "libradtran_A_disort_ps",
            title: "libRadtran 540 nm, gases only (A), scalar, against pseudo-spherical DISORT",
            reference: "uvspec_540nm_sza45.txt, atmosphere A, disort_ps; input A_disort_ps.inp",
            setup: "pseudo-spherical (direct beam through spherical shells of 6370 km, diffuse transport \
                    plane-parallel: what disort_ps computes), scalar",
            floor: DISORT_FLOOR_NOTE,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| compare("A_disort_ps.inp", 0.0, 1.0, Floor::Relative(DISORT_FLOOR), n),
        },
        Case {
            name: "libradtran_H_disort_pp",
            title: "libRadtran 540 nm, OPAC as Henyey–Greenstein (H), scalar, against plane-parallel DISORT",
            reference: "uvspec_540nm_sza45.txt, atmosphere H, disort_pp; input H_disort_pp.inp with \
                        H_540nm_aer_{tau,ssa,gg}.txt",
            setup: "plane-parallel, scalar, aerosol from the per-layer τ, ω, g files",
            floor: DISORT_FLOOR_NOTE,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| compare("H_disort_pp.inp", 2.0, 0.0, Floor::Relative(DISORT_FLOOR), n),
        },
        Case {
            name: "libradtran_H_disort_ps",
            title: "libRadtran 540 nm, OPAC as Henyey–Greenstein (H), scalar, against pseudo-spherical DISORT",
            reference: "uvspec_540nm_sza45.txt, atmosphere H, disort_ps; input H_disort_ps.inp",
            setup: "pseudo-spherical (as disort_ps), scalar",
            floor: DISORT_FLOOR_NOTE,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| compare("H_disort_ps.inp", 2.0, 1.0, Floor::Relative(DISORT_FLOOR), n),
        },
        Case {
            name: "libradtran_B_disort_pp",
            title: "libRadtran 540 nm, OPAC with Mie phase matrices (B), scalar, against plane-parallel DISORT",
            reference: "uvspec_540nm_sza45.txt, atmosphere B, disort_pp; input B_disort_pp.inp",
            setup: "plane-parallel, scalar, OPAC continental_average with atmosim's Mie phase matrices \
                    (aerosol_phase = \"mie\"), every direction including the sun's",
            floor: DISORT_FLOOR_NOTE,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| compare("B_disort_pp.inp", 1.0, 0.0, Floor::Relative(DISORT_FLOOR), n),
        },
        Case {
            name: "libradtran_B_disort_ps",
            title: "libRadtran 540 nm, OPAC with Mie phase matrices (B), scalar, against pseudo-spherical DISORT",
            reference: "uvspec_540nm_sza45.txt, atmosphere B, disort_ps; input B_disort_ps.inp",
            setup: "pseudo-spherical (as disort_ps), scalar, OPAC continental_average with Mie phase matrices",
            floor: DISORT_FLOOR_NOTE,
            default_samples: 10_000,
            informational: false,
            ratio_limit: None,
            run: |n| compare("B_disort_ps.inp", 1.0, 1.0, Floor::Relative(DISORT_FLOOR), n),
        },
        Case {
            name: "libradtran_B_polrad",
            title: "libRadtran 540 nm, OPAC with Mie phase matrices (B), polarised, polRadtran (informational)",
            reference: "uvspec_540nm_sza45.txt, atmosphere B, polrad; input B_polrad.inp",
            setup: "plane-parallel, polarised, OPAC continental_average with Mie phase matrices (P11, P12, \
                    P33, P34)",
            floor: POLRAD_MIE_NOTE,
            default_samples: 10_000,
            informational: true,
            ratio_limit: None,
            run: |n| compare("B_polrad.inp", 1.0, 2.0, Floor::PolradMie, n),
        },
    ]
}
