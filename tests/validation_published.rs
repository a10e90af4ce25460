//! Checks on the published references that `atmosim validate` does not
//! make itself (the comparisons of atmosim with them are the validation
//! cases, run by tests/cli_validate.rs): the published 16-stream DISORT
//! test 3 answers against the converged 128-stream reference the case uses,
//! and the IPRT B2 depolarisation that the data decide.

mod common;

use atmosim::compat::significance::sidak_threshold;
use atmosim::compat::validate::{iprt_b, statistics};
use common::table;

#[test]
fn disort_test_3_published_answers_agree_with_the_converged_reference() {
    // The published "correct answers" (16 streams) agree with DISORT at 128
    // streams (validation/disort/disort_test3_128streams.txt,
    // scripts/disort_converged.py) within 0.5 % except the nadir radiance at
    // the top of test 3a, 1.2 % high: a 16-stream truncation of the g = 0.75
    // backscatter. This is why the case compares with the 128-stream values.
    let conv = table("validation/disort/disort_test3_128streams.txt");
    let published = table("validation/published/disort_tests_radiance.txt");
    let mut compared = 0;
    for c in conv.rows.iter().filter(|r| r[9] > 0.0) {
        let p = published
            .rows
            .iter()
            .find(|r| r[0] == 3.0 && r[1] == c[0] && r[7] == c[6] && (r[8] - c[7]).abs() < 1e-6)
            .expect("the same direction in the published table");
        let rel = p[10] / c[9] - 1.0;
        let nadir_3a = c[0] == 0.0 && c[6] == 1.0 && c[7] == 180.0;
        if nadir_3a {
            assert!((rel - 0.0116).abs() < 0.0005, "16-stream nadir error {rel}");
        } else {
            assert!(rel.abs() < 0.005, "published vs converged at {c:?}: {rel}");
        }
        compared += 1;
    }
    assert!(compared > 10);
}

#[test]
fn iprt_b2_data_reject_depolarisation_0() {
    // The MYSTIC B2 file is labelled depolarisation 0.00 but the case
    // definition says 0.03; the validation case iprt_b2 passes with 0.03.
    // With 0 the same comparison (the case's seeds and directions, 4000
    // paths per direction) must fail its own Šidák threshold.
    let values = iprt_b(true, 0.0, 4_000).unwrap();
    let s = statistics(&values);
    eprintln!(
        "B2 with depolarisation 0: max |z| {:.2} (threshold {:.2})",
        s.max_abs_z, s.threshold
    );
    assert!(s.max_abs_z > sidak_threshold(values.len(), 0.01), "{}", s.worst);
}
