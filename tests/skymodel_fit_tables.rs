//! `atmosim fit` on a real (tiny) render job:
//! - without a `transmittance` directory it computes the tables itself from
//!   the render job the renders name: the dataset's transmittance part must
//!   be the one a fit of `atmosim transmittance`'s own tables (layout
//!   "sky_model", the default 32 × 64 nodes) gives, and a job file that is
//!   gone is refused before any image is fitted;
//! - fitted in shards (`--shard K/N`) and joined (`--combine`), the grid
//!   gives the very bytes of the fit in one go.

mod common;

use std::path::Path;

use atmosim::skymodel::dataset::{Dataset, Transmittance};
use common::{atmosim, run_ok};

/// A tiny render job and the transmittance job of the same atmosphere.
const ATMOSPHERE: &str = r#"[planet]
radius_km = 6378.0
top_km = 100.0

[atmosphere]
profile = "us_standard"
ozone = "bogumil"
aerosol = "continental_average"
visibility_km = [40.0, 90.0]

[spectrum]
wavelengths_nm = [500.0, 540.0]
band_width_nm = 40.0

[observer]
altitude_km = [0.0, 5.0]
"#;

fn render_job() -> String {
    format!(
        "{ATMOSPHERE}
[sun]
elevation_deg = [10.0, 30.0]

[ground]
albedo = [0.0]

[sensor]
type = \"sphere\"
resolution = [16, 8]
stokes_frame = \"sun_view\"

[render]
samples = 2
polarized = true
seed = 1

[output]
directory = \"renders\"
units = \"absolute\"
"
    )
}

fn tables_job() -> String {
    format!(
        "{ATMOSPHERE}
[transmittance]
layout = \"sky_model\"
estimator = \"analytic\"

[output]
directory = \"tables\"
"
    )
}

fn run(root: &Path, args: &[&str]) -> std::process::Output {
    atmosim().current_dir(root).args(args).output().unwrap()
}

/// √T at every node, channel, visibility and observer altitude.
fn sqrt_t(t: &Transmittance) -> Vec<f64> {
    let nodes = t.d_dim * t.a_dim;
    let (n_alt, n_vis) = (t.altitudes_m.len(), t.visibilities_km.len());
    let channels = t.v.len() / (n_vis * n_alt * t.rank);
    let mut out = Vec::new();
    for alt in 0..n_alt {
        for vis in 0..n_vis {
            for c in 0..channels {
                for node in 0..nodes {
                    let s: f64 = (0..t.rank)
                        .map(|r| {
                            f64::from(t.u[(alt * nodes + node) * t.rank + r])
                                * f64::from(t.v[((vis * n_alt + alt) * channels + c) * t.rank + r])
                        })
                        .sum();
                    out.push(s);
                }
            }
        }
    }
    out
}

/// Renders the tiny job (and its tables) in a fresh directory.
fn rendered() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::write(root.join("sky.toml"), render_job()).unwrap();
    std::fs::write(root.join("tables.toml"), tables_job()).unwrap();
    for args in [["render", "sky.toml", "-q"], ["transmittance", "tables.toml", "-q"]] {
        run_ok(root, &args);
    }
    dir
}

#[test]
fn shards_fitted_apart_and_joined_are_the_whole_fit() {
    let dir = rendered();
    let root = dir.path();
    std::fs::write(
        root.join("fit.toml"),
        "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"sky.dat\"\nresolution = 61\n",
    )
    .unwrap();
    std::fs::write(
        root.join("parts.toml"),
        "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"parts/sky.dat\"\nresolution = 61\n",
    )
    .unwrap();
    let ok = |args: &[&str]| {
        run_ok(root, args);
    };
    ok(&["fit", "fit.toml", "-q"]);
    // Before every shard is there, --combine refuses and writes nothing.
    ok(&["fit", "parts.toml", "--shard", "2/2", "-q"]);
    let out = run(root, &["fit", "parts.toml", "--combine"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing 1"));
    assert!(!root.join("parts/sky.dat").exists());
    ok(&["fit", "parts.toml", "--shard", "1/2", "-q"]);
    ok(&["fit", "parts.toml", "--combine"]);
    let whole = std::fs::read(root.join("sky.dat")).unwrap();
    assert_eq!(
        std::fs::read(root.join("parts/sky.dat")).unwrap(),
        whole,
        "joined shards differ from the whole fit"
    );
    // The figures: the same rows in the same order.
    assert_eq!(
        std::fs::read_to_string(root.join("parts/sky.dat.fit.csv")).unwrap(),
        std::fs::read_to_string(root.join("sky.dat.fit.csv")).unwrap()
    );
    let provenance = std::fs::read_to_string(root.join("parts/sky.dat.toml")).unwrap();
    assert!(
        provenance.contains("shards = 2") && provenance.contains("images = 16"),
        "{provenance}"
    );
    // More shards than visibilities: refused.
    let out = run(root, &["fit", "parts.toml", "--shard", "1/3", "-q"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("at most 2"));
}

#[test]
fn without_a_table_directory_the_fit_computes_the_render_jobs_tables() {
    let dir = rendered();
    let root = dir.path();
    std::fs::write(
        root.join("with.toml"),
        "renders = \"renders\"\ntransmittance = \"tables\"\nout = \"with.dat\"\nresolution = 61\n",
    )
    .unwrap();
    std::fs::write(
        root.join("without.toml"),
        "renders = \"renders\"\nout = \"without.dat\"\nresolution = 61\n",
    )
    .unwrap();
    for file in ["with.toml", "without.toml"] {
        let out = run(root, &["fit", file, "-q"]);
        assert!(out.status.success(), "{file}: {}", String::from_utf8_lossy(&out.stderr));
    }
    let with = Dataset::read(&root.join("with.dat")).unwrap().transmittance;
    let without = Dataset::read(&root.join("without.dat")).unwrap().transmittance;
    assert_eq!((without.d_dim, without.a_dim), (64, 32));
    assert_eq!(
        (&without.altitudes_m, &without.visibilities_km),
        (&with.altitudes_m, &with.visibilities_km)
    );
    // The same tables (the directory's held as f32, the computed ones in
    // f64) fitted the same way: √T agrees to a few f32 roundings of the
    // stored factors (√T ≤ 1, rank 12: 12 products of f32 values, each
    // rounded to 2⁻²⁴ relative, about 1e-6 together), not to the fit's
    // own error.
    let (a, b) = (sqrt_t(&with), sqrt_t(&without));
    assert_eq!(a.len(), b.len());
    let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    assert!(worst < 1e-5, "largest |Δ√T| {worst}");
    // The sidecar says where the tables came from.
    let provenance = std::fs::read_to_string(root.join("without.dat.toml")).unwrap();
    assert!(provenance.contains("transmittance_tables"), "{provenance}");

    // fit-report has no table directory to compare with: it quotes the
    // fit's own figure at the nodes.
    let out = run(root, &["fit-report", "without.toml"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report = std::fs::read_to_string(root.join("without.dat.report/report.md")).unwrap();
    assert!(report.contains("as the fit measured it"), "{report}");

    // With the job file gone, the fit stops before fitting an image, names
    // the file and says what to do instead.
    std::fs::remove_file(root.join("sky.toml")).unwrap();
    let out = run(root, &["fit", "without.toml", "-q"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("sky.toml") && err.contains("atmosim transmittance"),
        "{err}"
    );
}
