//! Band channels (`spectrum.band_width_nm`): a band's estimate is the
//! radiance averaged over the band, checked against Gauss–Legendre
//! quadrature of independent single-wavelength renders at nodes inside the
//! band (the radiance is smooth in λ where these bands lie: quadrature error
//! far below the Monte Carlo errors). Tolerances: the Šidák-corrected 1 %
//! threshold over every value compared (`common::Comparison`).

mod common;

use atmosim::render::{Direction, render_directions_all, render_directions_spectral};
use common::{Comparison, job};

/// Six-point Gauss–Legendre nodes and weights on [−1, 1].
const GAUSS_6: [(f64, f64); 6] = [
    (-0.932_469_514_203_152, 0.171_324_492_379_170),
    (-0.661_209_386_466_265, 0.360_761_573_048_139),
    (-0.238_619_186_083_197, 0.467_913_934_572_691),
    (0.238_619_186_083_197, 0.467_913_934_572_691),
    (0.661_209_386_466_265, 0.360_761_573_048_139),
    (0.932_469_514_203_152, 0.171_324_492_379_170),
];

fn directions() -> Vec<Direction> {
    [(0.0, 0.0), (60.0, 0.0), (80.0, 150.0), (120.0, 30.0)]
        .iter()
        .map(|&(z, a)| Direction {
            view_zenith_deg: z,
            azimuth_deg: a,
        })
        .collect()
}

#[test]
fn band_channels_estimate_the_band_averaged_radiance() {
    // (atmosphere, channels (centre, width)): a wide band where Rayleigh
    // varies ×3.6, and a band with ozone beside a monochromatic channel.
    let cases: [(&str, &[(f64, f64)]); 2] = [
        (
            "[atmosphere]\nozone = \"none\"\naerosol = \"continental_average\"\nvisibility_km = 30.0\n",
            &[(380.0, 120.0), (650.0, 100.0)],
        ),
        (
            "[atmosphere]\nozone = \"bogumil\"\naerosol = \"urban\"\n",
            &[(600.0, 40.0), (520.0, 0.0)],
        ),
    ];
    let samples = common::samples(30_000);
    let dirs = directions();
    let mut cmp = Comparison::default();
    for (c, (atmosphere, channels)) in cases.iter().enumerate() {
        let list = |f: &dyn Fn(&(f64, f64)) -> f64| {
            channels
                .iter()
                .map(f)
                .map(|v| format!("{v}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let text = format!(
            "{atmosphere}[spectrum]\nwavelengths_nm = [{}]\nband_width_nm = [{}]\n[sun]\nelevation_deg = 25.0\n\
             [observer]\naltitude_km = 0.2\n[ground]\nalbedo = [0.0, 0.4]\n",
            list(&|c| c.0),
            list(&|c| c.1)
        );
        let banded = job(&text);
        let scene = banded.spectral_scene(&banded.tasks[0]).expect("bands use shared paths");
        let h = banded.observer_altitude_km;
        let shared = render_directions_spectral(&scene, h, &dirs, samples, 3, 0);
        for (w, &(centre, width)) in channels.iter().enumerate() {
            // The reference: quadrature over single-wavelength renders.
            let nodes: Vec<(f64, f64)> = if width > 0.0 {
                GAUSS_6
                    .iter()
                    .map(|&(x, g)| (centre + 0.5 * width * x, 0.5 * g))
                    .collect()
            } else {
                vec![(centre, 1.0)]
            };
            let node_list = nodes.iter().map(|n| format!("{}", n.0)).collect::<Vec<_>>().join(", ");
            let mono = job(&format!(
                "{atmosphere}[spectrum]\nwavelengths_nm = [{node_list}]\n[sun]\nelevation_deg = 25.0\n\
                 [observer]\naltitude_km = 0.2\n[ground]\nalbedo = [0.0, 0.4]\n"
            ));
            let renders: Vec<_> = (0..nodes.len())
                .map(|k| render_directions_all(&mono.scene(k), h, &dirs, samples, 100 + k as u64, 0))
                .collect();
            for a in 0..2 {
                for d in 0..dirs.len() {
                    for s in 0..3 {
                        let (mut mean, mut var) = (0.0, 0.0);
                        for (k, &(_, g)) in nodes.iter().enumerate() {
                            let t = &renders[k][a][d];
                            mean += g * t.mean()[s];
                            var += (g * t.standard_error()[s]).powi(2);
                        }
                        let x = &shared[w][a][d];
                        cmp.add(
                            || {
                                format!(
                                    "case {c}: {centre} ± {} nm, albedo {a}, direction {d}, Stokes {s}",
                                    width / 2.0
                                )
                            },
                            x.mean()[s],
                            x.standard_error()[s],
                            mean,
                            var.sqrt(),
                        );
                    }
                }
            }
        }
    }
    println!(
        "{}",
        cmp.assert_no_outlier("band channels vs quadrature of single wavelengths")
    );
}

#[test]
fn a_wide_band_differs_from_its_centre_wavelength() {
    // The band estimate is not the centre's radiance: over 320–440 nm the
    // zenith sky differs from its 380 nm value by many standard errors.
    let base = "[atmosphere]\nozone = \"none\"\naerosol = \"none\"\n[sun]\nelevation_deg = 25.0\n";
    let band = job(&format!(
        "{base}[spectrum]\nwavelengths_nm = [380.0]\nband_width_nm = 120.0\n"
    ));
    let centre = job(&format!("{base}[spectrum]\nwavelengths_nm = [380.0]\n"));
    let dirs = &directions()[..1];
    let h = band.observer_altitude_km;
    let b = render_directions_spectral(&band.spectral_scene(&band.tasks[0]).unwrap(), h, dirs, 100_000, 1, 0);
    let c = render_directions_all(&centre.scene(0), h, dirs, 100_000, 2, 0);
    let (x, y) = (&b[0][0][0], &c[0][0]);
    let z = (x.mean()[0] - y.mean()[0]) / x.standard_error()[0].hypot(y.standard_error()[0]);
    assert!(z.abs() > 5.0, "band {} vs centre {}: z = {z}", x.mean()[0], y.mean()[0]);
}
