//! The full Natraj et al. (2009) sweep: every τ ≤ 1, every albedo, every
//! μ0, μ ≥ 0.1, every φ, top and bottom (28,812 directions). Ignored by
//! default (hours at 10⁶ paths per direction on 2 cores); run with
//!
//!   ATMOSIM_VALIDATION_SAMPLES=1000000 cargo test --release --test natraj_sweep -- --ignored --nocapture
//!
//! Criteria (transport-core issue): no |z| beyond the Šidák threshold, I
//! within 0.3 % and |ΔQ|, |ΔU| below 3e-4 in Natraj's π-normalised units.

mod common;

use std::f64::consts::PI;

use atmosim::render::Direction;
use common::{Comparison, job, layers_toml, render, samples, table};

#[test]
#[ignore]
fn natraj_2009_full_sweep() {
    let t = table("validation/published/natraj2009.txt");
    let n = samples(1_000_000);
    let rows: Vec<&Vec<f64>> = t
        .rows
        .iter()
        .filter(|r| r[4].to_radians().cos().abs() >= 0.1 - 1e-9)
        .collect();
    let mut keys: Vec<[f64; 4]> = rows.iter().map(|r| [r[0], r[1], r[2], r[3]]).collect();
    keys.sort_by(|a, b| a.partial_cmp(b).unwrap());
    keys.dedup();
    let mut cmp = Comparison::default();
    let (mut max_rel_i, mut max_dq, mut max_du) = (0.0f64, 0.0f64, 0.0f64);
    let mut worst_i = String::new();
    let start = std::time::Instant::now();
    // ATMOSIM_SUN_SAMPLING=collision|sun_aware|auto (default auto).
    let sun_sampling = std::env::var("ATMOSIM_SUN_SAMPLING").unwrap_or_else(|_| "auto".into());
    // ATMOSIM_SWEEP_CSV=path writes every comparison for analysis.
    let mut dump =
        String::from("tau,albedo,mu0,level,view_zenith_deg,azimuth_deg,I,I_se,I_ref,Q,Q_se,Q_ref,U,U_se,U_ref\n");
    for [tau, albedo, mu0, level] in keys {
        let group: Vec<&Vec<f64>> = rows
            .iter()
            .copied()
            .filter(|r| r[0] == tau && r[1] == albedo && r[2] == mu0 && r[3] == level)
            .collect();
        let dirs: Vec<Direction> = group
            .iter()
            .map(|r| Direction {
                view_zenith_deg: r[4],
                azimuth_deg: r[5],
            })
            .collect();
        let text = format!(
            "{}[ground]\nalbedo = {albedo:?}\n[sun]\nzenith_deg = {:?}\n[observer]\naltitude_km = {level:?}\n[render]\nseed = 2009\nsun_sampling = \"{sun_sampling}\"\n",
            layers_toml(&[(0.0, 1.0, tau, 0.0)], 0.0),
            mu0.acos().to_degrees()
        );
        let tallies = render(&job(&text), level, &dirs, n);
        for (r, tl) in group.iter().zip(&tallies) {
            let (m, se) = (tl.mean(), tl.standard_error());
            for k in 0..3 {
                let what = || {
                    format!(
                        "{} τ {tau} A {albedo} μ0 {mu0} level {level} θ {} φ {}",
                        ["I", "Q", "U"][k],
                        r[4],
                        r[5]
                    )
                };
                cmp.add(what, m[k], se[k], r[6 + k], 0.5e-8 / PI);
            }
            dump.push_str(&format!(
                "{tau},{albedo},{mu0},{level},{},{},{},{},{},{},{},{},{},{},{}\n",
                r[4], r[5], m[0], se[0], r[6], m[1], se[1], r[7], m[2], se[2], r[8]
            ));
            let rel = (m[0] / r[6] - 1.0).abs();
            if rel > max_rel_i {
                max_rel_i = rel;
                worst_i = format!(
                    "τ {tau} A {albedo} μ0 {mu0} level {level} θ {} φ {}: {} vs {}",
                    r[4], r[5], m[0], r[6]
                );
            }
            max_dq = max_dq.max(PI * (m[1] - r[7]).abs());
            max_du = max_du.max(PI * (m[2] - r[8]).abs());
        }
    }
    if let Ok(path) = std::env::var("ATMOSIM_SWEEP_CSV") {
        std::fs::write(path, dump).unwrap();
    }
    eprintln!(
        "Natraj sweep: {} directions × {n} paths in {:.0} s; max |ΔI/I| = {:.3} % ({worst_i}); max π|ΔQ| = {max_dq:.2e}; max π|ΔU| = {max_du:.2e}",
        rows.len(),
        start.elapsed().as_secs_f64(),
        100.0 * max_rel_i
    );
    cmp.assert_no_outlier("Natraj 2009 full sweep");
    assert!(max_rel_i < 0.003, "I error {max_rel_i}");
    assert!(max_dq < 3e-4 && max_du < 3e-4, "Q/U errors {max_dq} {max_du}");
}
