//! The sky-model dataset file: its layout read back by an independent
//! parser, exact round trips, the half rounding, and the strict reader's
//! refusals (truncation at every byte, trailing bytes, damaged counts that
//! must not allocate). Then the runtime's evaluation of hand-made datasets
//! whose answers are known in closed form.

use std::alloc::{GlobalAlloc, Layout, System};
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::atomic::{AtomicUsize, Ordering};

use atmosim::physics::solar::SolarSpectrum;
use atmosim::skymodel::angles::PLANET_RADIUS_M;
use atmosim::skymodel::dataset::{
    Axes, ComponentFit, Dataset, DatasetFit, PolarisationFit, RadianceConfigFit, RadianceFit, Transmittance,
    nearest_half,
};
use atmosim::skymodel::runtime::{Model, Parameters, SUN_RADIUS};
use half::f16;

/// Records the largest single allocation, so that a test can show that a
/// damaged count allocates nothing near what it claims.
struct Largest;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Largest {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Largest = Largest;

const RANK: usize = 2;
const SUN_BREAKS: [f64; 3] = [0.0, 0.5, PI];
const ZENITH_BREAKS: [f64; 2] = [0.0, PI];
const EMPH_BREAKS: [f64; 4] = [0.0, 1.0, 2.0, PI];

/// 2 visibilities × 1 albedo × 1 altitude × 2 elevations × 2 channels = 8
/// configurations; values that differ everywhere, zenith values large (so
/// that only their scaling keeps them inside the half range).
fn tiny_fit() -> DatasetFit {
    let axes = Axes {
        visibilities_km: vec![20.0, 60.0],
        albedos: vec![0.3],
        altitudes_m: vec![0.0],
        elevations_deg: vec![-2.0, 30.0],
        channels: 2,
        channel_start_nm: 400.0,
        channel_width_nm: 40.0,
    };
    let mut coefs = Vec::new();
    for c in 0..8 {
        for k in 0..RANK {
            coefs.extend((0..3).map(|i| 0.1 + 0.37 * c as f64 + 0.05 * i as f64 - k as f64));
            coefs.extend((0..2).map(|i| (c + 1) as f64 * 1.0e5 * (i as f64 + 0.3) * if k == 0 { 1.0 } else { -1.0 }));
        }
        coefs.extend((0..4).map(|i| 1.0 + 0.01 * c as f64 + 0.1 * i as f64));
    }
    DatasetFit {
        axes,
        radiance: radiance(RANK, [&SUN_BREAKS, &ZENITH_BREAKS, &EMPH_BREAKS], 8, coefs),
        transmittance: Transmittance {
            d_dim: 2,
            a_dim: 3,
            altitudes_m: vec![0.0, 1000.0],
            visibilities_km: vec![40.0],
            rank: 1,
            u: (0..12).map(|i| 0.5 + 0.01 * i as f64).collect(),
            v: (0..4).map(|i| 1.0 - 0.1 * i as f64).collect(),
        },
        polarisation: Some(polarisation(
            1,
            [&[0.0, PI], &[0.0, 1.5, PI]],
            8,
            (0..8 * 5).map(|i| 0.001 * i as f64 - 0.01),
        )),
    }
}

/// Rank components of `rank` × (`n_sun`, `n_zenith`) values from `values`.
fn components(values: &mut impl Iterator<Item = f64>, rank: usize, n_sun: usize, n_zenith: usize) -> Vec<ComponentFit> {
    let mut take = |n: usize| values.take(n).collect::<Vec<f64>>();
    (0..rank)
        .map(|_| ComponentFit {
            sun: take(n_sun),
            zenith: take(n_zenith),
        })
        .collect()
}

/// Radiance from values in the file's order: per configuration `rank` ×
/// (sun, zenith), then the emphasis values.
fn radiance(rank: usize, breaks: [&[f64]; 3], configs: usize, values: impl IntoIterator<Item = f64>) -> RadianceFit {
    let [sun, zenith, emph] = breaks;
    let mut values = values.into_iter();
    RadianceFit {
        sun_breaks: sun.to_vec(),
        zenith_breaks: zenith.to_vec(),
        emph_breaks: emph.to_vec(),
        configs: (0..configs)
            .map(|_| RadianceConfigFit {
                components: components(&mut values, rank, sun.len(), zenith.len()),
                emph: values.by_ref().take(emph.len()).collect(),
            })
            .collect(),
    }
}

/// Polarisation from values in the file's order.
fn polarisation(
    rank: usize,
    breaks: [&[f64]; 2],
    configs: usize,
    values: impl IntoIterator<Item = f64>,
) -> PolarisationFit {
    let [sun, zenith] = breaks;
    let mut values = values.into_iter();
    PolarisationFit {
        sun_breaks: sun.to_vec(),
        zenith_breaks: zenith.to_vec(),
        configs: (0..configs)
            .map(|_| components(&mut values, rank, sun.len(), zenith.len()))
            .collect(),
    }
}

/// A fit's radiance values in the file's order.
fn flat(fit: &RadianceFit) -> Vec<f64> {
    let component = |c: &ComponentFit| c.sun.iter().chain(&c.zenith).copied().collect::<Vec<_>>();
    fit.configs
        .iter()
        .flat_map(|c| c.components.iter().flat_map(component).chain(c.emph.iter().copied()))
        .collect()
}

fn tiny() -> Dataset {
    Dataset::encode(&tiny_fit(), "tiny").expect("the tiny fit encodes")
}

/// An independent little-endian cursor.
struct Cursor<'a>(&'a [u8], usize);

impl Cursor<'_> {
    fn bytes<const N: usize>(&mut self) -> [u8; N] {
        let b: [u8; N] = self.0[self.1..self.1 + N].try_into().unwrap();
        self.1 += N;
        b
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.bytes())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.bytes())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.bytes())
    }
    fn half(&mut self) -> f64 {
        f16::from_bits(u16::from_le_bytes(self.bytes())).to_f64()
    }
    fn list(&mut self) -> Vec<f64> {
        let n = self.i32();
        (0..n).map(|_| self.f64()).collect()
    }
}

fn assert_rel(got: f64, want: f64, tol: f64, what: &str) {
    assert!((got - want).abs() <= tol * want.abs(), "{what}: {got} vs {want}");
}

#[test]
fn the_bytes_have_the_runtimes_layout() {
    let fit = tiny_fit();
    let dataset = tiny();
    let bytes = dataset.to_bytes();
    let mut c = Cursor(&bytes, 0);
    assert_eq!(c.i32(), 2, "nVis at byte 0");
    assert_eq!([c.f64(), c.f64()], [20.0, 60.0]);
    assert_eq!(c.list(), [0.3]);
    assert_eq!(c.list(), [0.0]);
    assert_eq!(c.list(), [-2.0, 30.0]);
    assert_eq!((c.i32(), c.f64(), c.f64()), (2, 400.0, 40.0));
    assert_eq!(c.i32(), RANK as i32);
    assert_eq!(c.list(), SUN_BREAKS);
    assert_eq!(c.list(), ZENITH_BREAKS);
    assert_eq!(c.list(), EMPH_BREAKS);
    let fitted = flat(&fit.radiance);
    let mut fitted = fitted.iter();
    let mut decoded = dataset.radiance.coefs.iter();
    for config in 0..8 {
        for k in 0..RANK {
            for _ in 0..3 {
                let (h, want) = (c.half(), *fitted.next().unwrap());
                assert_rel(h, want, 2f64.powi(-11), &format!("sun, configuration {config}"));
                assert_eq!(*decoded.next().unwrap(), h as f32);
            }
            let scale = c.f64();
            let zenith: Vec<f64> = (0..2).map(|_| *fitted.next().unwrap()).collect();
            assert_eq!(
                scale,
                1.0 / zenith.iter().fold(0.0f64, |m, z| m.max(z.abs())),
                "component {k}"
            );
            for want in zenith {
                let h = c.half();
                assert!(h.abs() <= 1.0, "scaled zenith values use [-1, 1]");
                assert_rel(h / scale, want, 2f64.powi(-11), "zenith");
                assert_eq!(
                    *decoded.next().unwrap(),
                    (h / scale) as f32,
                    "the runtime's f32(half / scale)"
                );
            }
        }
        for _ in 0..4 {
            let (h, want) = (c.half(), *fitted.next().unwrap());
            assert_rel(h, want, 2f64.powi(-11), "emphasis");
            assert_eq!(*decoded.next().unwrap(), h as f32);
        }
    }
    // Transmittance: dDim, aDim, nVisT, nAltT, rankT, then f32 tables.
    assert_eq!([c.i32(), c.i32(), c.i32(), c.i32(), c.i32()], [2, 3, 1, 2, 1]);
    assert_eq!([c.f32(), c.f32()], [0.0, 1000.0]);
    assert_eq!(c.f32(), 40.0);
    for want in fit.transmittance.u.iter().chain(&fit.transmittance.v) {
        assert_eq!(c.f32(), *want as f32);
    }
    // Polarisation: rankP, breaks, then f32 values.
    assert_eq!(c.i32(), 1);
    assert_eq!(c.list(), [0.0, PI]);
    assert_eq!(c.list(), [0.0, 1.5, PI]);
    for want in fit
        .polarisation
        .as_ref()
        .unwrap()
        .configs
        .iter()
        .flatten()
        .flat_map(|c| c.sun.iter().chain(&c.zenith))
    {
        assert_eq!(c.f32(), *want as f32);
    }
    assert_eq!(c.1, bytes.len(), "nothing after the polarisation part");
}

#[test]
fn writing_and_reading_round_trip_exactly() {
    let dataset = tiny();
    let bytes = dataset.to_bytes();
    let back = Dataset::from_bytes(&bytes, "tiny").unwrap();
    assert_eq!(back, dataset);
    assert_eq!(back.to_bytes(), bytes);
    // Without the polarisation part, too.
    let mut fit = tiny_fit();
    fit.polarisation = None;
    let dataset = Dataset::encode(&fit, "tiny").unwrap();
    assert_eq!(Dataset::from_bytes(&dataset.to_bytes(), "tiny").unwrap(), dataset);
    // And through a file.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tiny.dat");
    dataset.write(&path).unwrap();
    assert_eq!(Dataset::read(&path).unwrap(), dataset);
}

#[test]
fn halves_are_the_nearest_ties_to_even() {
    let h = |x: f64| nearest_half(x).to_f64();
    let u = 2f64.powi(-10);
    assert_eq!(h(1.0 + u / 2.0), 1.0, "a tie goes to the even neighbour");
    assert_eq!(h(1.0 + 1.5 * u), 1.0 + 2.0 * u, "a tie goes to the even neighbour");
    // Just above a tie: two roundings (through f32) would give 1.
    assert_eq!(h(1.0 + u / 2.0 + 2f64.powi(-40)), 1.0 + u);
    assert_eq!(h(-(1.0 + u / 2.0 + 2f64.powi(-40))), -(1.0 + u));
    assert_eq!(h(65519.0), 65504.0);
    assert!(nearest_half(65520.0).is_infinite());
    assert_eq!(h(1.5 * 2f64.powi(-24)), 2.0 * 2f64.powi(-24), "subnormal tie to even");
    assert_eq!(
        h(2f64.powi(-14) * (1.0 - 2f64.powi(-12))),
        2f64.powi(-14),
        "rounds up into the normals"
    );
    assert_eq!(h(2f64.powi(-26)), 0.0);
    assert!(nearest_half(-0.0).is_sign_negative());
    assert!(nearest_half(f64::NAN).is_nan());
    // Relative error ≤ 2^-11 over the normal range, and no neighbour nearer.
    let mut x = 2f64.powi(-14);
    while x < 47000.0 {
        for v in [x, -x * 1.37] {
            let got = h(v);
            assert!((got - v).abs() <= v.abs() * 2f64.powi(-11), "{v} → {got}");
            let bits = nearest_half(v).to_bits();
            for n in [bits - 1, bits + 1].map(|b| f16::from_bits(b).to_f64()) {
                assert!((got - v).abs() <= (n - v).abs(), "{v} → {got}, {n} is nearer");
            }
        }
        x *= 1.0123456789;
    }
}

#[test]
fn every_truncation_is_refused() {
    let bytes = tiny().to_bytes();
    let mut no_polarisation = tiny_fit();
    no_polarisation.polarisation = None;
    let end_of_transmittance = Dataset::encode(&no_polarisation, "t").unwrap().to_bytes().len();
    for len in 0..bytes.len() {
        match Dataset::from_bytes(&bytes[..len], "cut") {
            Ok(d) => {
                assert_eq!(
                    len, end_of_transmittance,
                    "only the end of the transmittance part is an end"
                );
                assert!(d.polarisation.is_none());
            }
            Err(e) => {
                let message = e.to_string();
                assert!(message.starts_with("cut: truncated at byte"), "{len}: {message}");
            }
        }
    }
    let e = Dataset::from_bytes(&bytes[..end_of_transmittance + 2], "cut").unwrap_err();
    assert!(e.to_string().contains("reading rankPol"), "{e}");
}

#[test]
fn errors_name_the_field_and_its_offset() {
    let bytes = tiny().to_bytes();
    // The last byte of the first zenith value of configuration 5, component 1.
    let header = 4 + 16 + 4 + 8 + 4 + 8 + 4 + 16 + 4 + 8 + 8 + 4 + (4 + 24) + (4 + 16) + (4 + 32);
    let config_len = RANK * (3 * 2 + 8 + 2 * 2) + 4 * 2;
    let zenith_scale_at = header + 5 * config_len + (3 * 2 + 8 + 2 * 2) + 3 * 2;
    let e = Dataset::from_bytes(&bytes[..zenith_scale_at + 3], "cut").unwrap_err();
    let expected = format!(
        "cut: truncated at byte {}: reading zenithScale of configuration 5 (visibility 1, albedo 0, altitude 0, \
         elevation 0, channel 1), rank component 1 (1 × 8 bytes) at byte {zenith_scale_at}",
        zenith_scale_at + 3
    );
    assert_eq!(e.to_string(), expected);
    let mut damaged = bytes.clone();
    damaged[zenith_scale_at..zenith_scale_at + 8].copy_from_slice(&0.0f64.to_le_bytes());
    let e = Dataset::from_bytes(&damaged, "d").unwrap_err().to_string();
    assert!(
        e.contains(&format!(
            "rank component 1 at byte {zenith_scale_at}: 0e0, must be finite and non-zero"
        )),
        "{e}"
    );
    // A half infinity among the sun values.
    let mut damaged = bytes.clone();
    damaged[header + 2..header + 4].copy_from_slice(&f16::INFINITY.to_le_bytes());
    let e = Dataset::from_bytes(&damaged, "d").unwrap_err().to_string();
    assert!(e.contains(&format!("sunCoefsRad of configuration 0 (visibility 0, albedo 0, altitude 0, elevation 0, channel 0), rank component 0: value 1 at byte {}", header + 2)), "{e}");
}

#[test]
fn trailing_bytes_are_refused() {
    let mut bytes = tiny().to_bytes();
    let len = bytes.len();
    bytes.push(0);
    let e = Dataset::from_bytes(&bytes, "t").unwrap_err();
    assert_eq!(
        e.to_string(),
        format!("t: 1 bytes after the polarisation part (from byte {len})")
    );
}

#[test]
fn damaged_counts_are_refused_without_allocating() {
    let bytes = tiny().to_bytes();
    let damage = |at: usize, value: i32| {
        let mut d = bytes.clone();
        d[at..at + 4].copy_from_slice(&value.to_le_bytes());
        Dataset::from_bytes(&d, "d").unwrap_err().to_string()
    };
    let e = damage(0, i32::MAX);
    assert!(
        e.contains("nVis = 2147483647 at byte 0 calls for 17179869176 bytes of values"),
        "{e}"
    );
    assert!(damage(0, -1).contains("nVis = -1 at byte 0: must be at least 1"));
    assert!(damage(0, 0).contains("must be at least 1"));
    // channels, then rank: the values are read on until they make no sense
    // or the file ends, never allocated by the count.
    let channels_at = 4 + 16 + 4 + 8 + 4 + 8 + 4 + 16;
    damage(channels_at, i32::MAX);
    damage(channels_at + 20, i32::MAX);
    // The sun breaks' count: 2^31 − 1 breaks would need 16 GiB.
    assert!(damage(channels_at + 24, i32::MAX).contains("nSunBreaks = 2147483647"));
    assert!(damage(channels_at + 24, 1).contains("nSunBreaks = 1 at byte"));
    // The transmittance's dimensions.
    let mut no_polarisation = tiny_fit();
    no_polarisation.polarisation = None;
    let transmittance_at = Dataset::encode(&no_polarisation, "t").unwrap().to_bytes().len() - 4 * (2 + 1 + 12 + 4) - 20;
    for k in 0..5 {
        assert!(
            damage(transmittance_at + 4 * k, i32::MAX).contains("truncated"),
            "dimension {k}"
        );
        assert!(
            damage(transmittance_at + 4 * k, 0).contains("must be at least 1"),
            "dimension {k}"
        );
    }
    let largest = LARGEST.load(Ordering::Relaxed);
    assert!(largest < 1 << 24, "an allocation of {largest} bytes");
}

#[test]
fn checks_of_values_are_strict() {
    let bytes = tiny().to_bytes();
    let put = |at: usize, value: f64| {
        let mut d = bytes.clone();
        d[at..at + 8].copy_from_slice(&value.to_le_bytes());
        Dataset::from_bytes(&d, "d").unwrap_err().to_string()
    };
    assert!(put(4, 70.0).contains("visibilities: 70 then 60 is not strictly ascending"));
    assert!(put(4, f64::NAN).contains("is not finite"));
    let start_at = 4 + 16 + 4 + 8 + 4 + 8 + 4 + 16 + 4;
    assert!(put(start_at, -1.0).contains("channelStart -1 nm"));
    assert!(put(start_at + 8, 0.0).contains("channelWidth 0 nm"));
    let sun_breaks_at = start_at + 16 + 4 + 4;
    assert!(put(sun_breaks_at + 16, 3.2).contains("sunBreaks: break 3.2 is outside [0, π]"));
    assert!(put(sun_breaks_at + 16, 0.4).contains("not strictly ascending"));
    // π written as f32 rounds past π: still allowed.
    let mut d = bytes.clone();
    d[sun_breaks_at + 16..sun_breaks_at + 24].copy_from_slice(&(std::f32::consts::PI as f64).to_le_bytes());
    assert!(Dataset::from_bytes(&d, "d").is_ok());
}

#[test]
fn fits_that_the_file_cannot_hold_are_refused() {
    let refuse = |change: &dyn Fn(&mut DatasetFit)| {
        let mut fit = tiny_fit();
        change(&mut fit);
        Dataset::encode(&fit, "fit").unwrap_err().to_string()
    };
    let e = refuse(&|f| f.radiance.configs[3].components[1].sun[1] = f64::NAN);
    assert!(e.contains("configuration 3 (visibility 0, albedo 0, altitude 0, elevation 1, channel 1), rank component 1: sun value NaN is not finite"), "{e}");
    let e = refuse(&|f| f.radiance.configs[1].components[0].sun[0] = 7.0e4);
    assert!(e.contains("configuration 1 (visibility 0, albedo 0, altitude 0, elevation 0, channel 1), rank component 0: sun value 70000 is beyond the half range"), "{e}");
    let e = refuse(&|f| f.radiance.configs[0].components[0].zenith[0] = f64::INFINITY);
    assert!(e.contains("configuration 0 (visibility 0, albedo 0, altitude 0, elevation 0, channel 0), rank component 0: zenith value inf"), "{e}");
    let e = refuse(&|f| f.radiance.configs[0].emph[3] = -1.0e9);
    assert!(e.contains("configuration 0 (visibility 0, albedo 0, altitude 0, elevation 0, channel 0): emphasis value -1000000000 is beyond"), "{e}");
    let e = refuse(&|f| drop(f.radiance.configs.pop()));
    assert!(e.contains("radiance: 7 configurations, the axes call for 8"), "{e}");
    let e = refuse(&|f| {
        f.radiance.configs[2].components[0].zenith.pop();
    });
    assert!(e.contains("radiance of configuration 2 (visibility 0, albedo 0, altitude 0, elevation 1, channel 0), rank component 0: 3 sun and 1 zenith values for 3 and 2 breaks"), "{e}");
    let e = refuse(&|f| drop(f.radiance.configs[5].components.pop()));
    assert!(e.contains("configuration 5 (visibility 1, albedo 0, altitude 0, elevation 0, channel 1): 1 rank components, the first configuration has 2"), "{e}");
    let e = refuse(&|f| {
        f.radiance.configs[4].emph.pop();
    });
    assert!(e.contains("3 emphasis values for 4 breaks"), "{e}");
    let e = refuse(&|f| f.transmittance.u[4] = f64::NAN);
    assert!(e.contains("transmittance U[4]: NaN is not finite in f32"), "{e}");
    let e = refuse(&|f| f.polarisation.as_mut().unwrap().configs[1][0].zenith[0] = 1e39);
    assert!(e.contains("polarisation of configuration 1 (visibility 0, albedo 0, altitude 0, elevation 0, channel 1), rank component 0"), "{e}");
    let e = refuse(&|f| f.radiance.emph_breaks = vec![0.0]);
    assert!(e.contains("emphBreaks: 1, must be in [2, "), "{e}");
    let e = refuse(&|f| f.axes.elevations_deg = vec![]);
    assert!(e.contains("elevations: 0, must be in [1, "), "{e}");
}

#[test]
fn a_zero_zenith_component_is_written_with_scale_one() {
    let mut fit = tiny_fit();
    fit.radiance.configs[0].components[0].zenith = vec![0.0, -0.0];
    let dataset = Dataset::encode(&fit, "z").unwrap();
    assert_eq!(dataset.radiance.zenith_scales[0], 1.0);
    assert_eq!(&dataset.radiance.coefs[3..5], &[0.0, 0.0]);
    assert_eq!(Dataset::from_bytes(&dataset.to_bytes(), "z").unwrap(), dataset);
}

#[test]
fn the_summary_gives_the_counts() {
    let text = tiny().to_string();
    for line in [
        "visibilities (km):      2 (20 … 60)",
        "configurations:         8",
        "radiance:               rank 2, breaks: sun 3, zenith 2, emphasis 4",
        "transmittance:          rank 1, 2 distances × 3 altitudes",
        "polarisation:           rank 1, breaks: sun 2, zenith 3",
    ] {
        assert!(text.contains(line), "{line:?} in\n{text}");
    }
}

// The runtime's evaluation.

/// The top of the runtime's atmosphere (m) and its greatest distance
/// parameter (a ground arc, m).
const TOP_M: f64 = 100_000.0;
const MAX_ARC_M: f64 = 1_571_524.413613;

/// One visibility, albedo and altitude; `elevations_deg` and
/// `channels` as given. Radiance rank 1: sun breaks [0, 1, 2, 3],
/// zenith and emphasis breaks [0, π], per configuration [sun ×4,
/// zenith ×2, emphasis ×2]. Polarisation rank 1: sun breaks [0, π],
/// zenith breaks [0, π/2, π], per configuration [sun ×2, zenith ×3].
/// Transmittance: 2 × 2 nodes, √T = 1 everywhere.
fn fit(
    elevations_deg: &[f64],
    channels: usize,
    rad: impl Fn(usize) -> [f64; 8],
    pol: impl Fn(usize) -> [f64; 5],
) -> DatasetFit {
    let configs = elevations_deg.len() * channels;
    DatasetFit {
        axes: Axes {
            visibilities_km: vec![40.0],
            albedos: vec![0.5],
            altitudes_m: vec![0.0],
            elevations_deg: elevations_deg.to_vec(),
            channels,
            channel_start_nm: 400.0,
            channel_width_nm: 40.0,
        },
        radiance: radiance(
            1,
            [&[0.0, 1.0, 2.0, 3.0], &[0.0, PI], &[0.0, PI]],
            configs,
            (0..configs).flat_map(&rad),
        ),
        transmittance: Transmittance {
            d_dim: 2,
            a_dim: 2,
            altitudes_m: vec![0.0],
            visibilities_km: vec![40.0],
            rank: 1,
            u: vec![1.0; 4],
            v: vec![1.0; channels],
        },
        polarisation: Some(polarisation(
            1,
            [&[0.0, PI], &[0.0, FRAC_PI_2, PI]],
            configs,
            (0..configs).flat_map(&pol),
        )),
    }
}

fn model(fit: &DatasetFit) -> Model {
    let dataset = Dataset::encode(fit, "test").unwrap();
    Model::new("test", dataset, SolarSpectrum::kurucz().unwrap()).unwrap()
}

fn view(gamma: f64, zero: f64, shadow: f64, elevation: f64) -> Parameters {
    Parameters {
        theta: zero,
        gamma,
        shadow,
        zero,
        elevation,
        altitude_m: 50.0,
        visibility_km: 40.0,
        albedo: 0.5,
    }
}

const ONES: [f64; 5] = [1.0; 5];

#[test]
fn radiance_is_piecewise_linear_in_gamma_and_alpha() {
    // sun(γ) = 0.5 + γ/4 at the breaks, zenith(α) = 1 + α/π.
    let m = model(&fit(
        &[0.0, 30.0],
        1,
        |_| [0.5, 0.75, 1.0, 1.25, 1.0, 2.0, 1.0, 1.0],
        |_| ONES,
    ));
    for gamma in [0.0f64, 0.3, 1.0, 1.7, 2.5, 3.0, 3.1, -0.2] {
        for (zero, shadow, elevation) in [(0.4, 2.0, 0.2), (1.3, 0.7, -0.05), (2.0, 2.9, 0.0)] {
            let alpha = if elevation < 0.0 { shadow } else { zero };
            let expected = (0.5 + gamma.clamp(0.0, 3.0) / 4.0) * (1.0 + alpha / PI);
            let got = m.sky_radiance(&view(gamma, zero, shadow, elevation), 420.0);
            assert!(
                (got - expected).abs() < 1e-12,
                "γ {gamma} α {alpha}: {got} vs {expected}"
            );
        }
    }
}

#[test]
fn emphasis_multiplies_and_negative_radiance_is_clamped() {
    let m = model(&fit(&[0.0], 1, |_| [1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 1.0, 0.5], |_| ONES));
    let got = m.sky_radiance(&view(0.5, 1.2, 0.0, 0.1), 420.0);
    assert!((got - 2.0 * (1.0 - 0.5 * 1.2 / PI)).abs() < 1e-12, "{got}");
    let m = model(&fit(
        &[0.0],
        1,
        |_| [-1.0, -1.0, -0.5, 0.5, 2.0, 2.0, 1.0, 1.0],
        |_| ONES,
    ));
    assert_eq!(m.sky_radiance(&view(0.5, 1.2, 0.0, 0.1), 420.0), 0.0);
    let got = m.sky_radiance(&view(2.5, 1.2, 0.0, 0.1), 420.0);
    assert!(
        (got - 0.0).abs() < 1e-15 && got >= 0.0,
        "the clamp is applied after the emphasis: {got}"
    );
    let got = m.sky_radiance(&view(2.75, 1.2, 0.0, 0.1), 420.0);
    assert!((got - 0.5).abs() < 1e-12, "{got}");
}

#[test]
fn elevation_is_interpolated_linearly_and_tiny_factors_are_skipped() {
    let m = model(&fit(
        &[0.0, 30.0],
        1,
        |c| {
            [[1.0; 4], [3.0; 4]][c]
                .into_iter()
                .chain([1.0; 4])
                .collect::<Vec<_>>()
                .try_into()
                .unwrap()
        },
        |_| ONES,
    ));
    let at = |deg: f64| m.sky_radiance(&view(0.5, 1.0, 1.0, deg.to_radians()), 420.0);
    assert!((at(10.0) - (1.0 + 2.0 / 3.0)).abs() < 1e-12);
    assert!((at(22.5) - 2.5).abs() < 1e-12);
    assert_eq!(at(-5.0), 1.0);
    assert_eq!(at(45.0), 3.0);
    // A factor of 5·10⁻⁷ is skipped: the lower configuration exactly.
    assert_eq!(at(30.0 * 5e-7), 1.0);
    assert!((at(30.0 * 2e-6) - (1.0 + 4e-6)).abs() < 1e-12);
}

#[test]
fn a_wavelength_takes_its_channels_value() {
    let m = model(&fit(
        &[0.0],
        2,
        |c| {
            [[1.0; 4], [2.0; 4]][c]
                .into_iter()
                .chain([1.0; 4])
                .collect::<Vec<_>>()
                .try_into()
                .unwrap()
        },
        |_| ONES,
    ));
    let p = view(0.5, 1.0, 1.0, 0.1);
    for (lambda, expected) in [
        (399.99, 0.0),
        (400.0, 1.0),
        (439.999, 1.0),
        (440.0, 2.0),
        (479.999, 2.0),
        (480.0, 0.0),
        (f64::NAN, 0.0),
    ] {
        assert_eq!(m.sky_radiance(&p, lambda), expected, "λ {lambda}");
    }
    assert_eq!(m.transmittance(&p, 480.0, 1000.0), 0.0);
    assert_eq!(m.transmittance(&p, 399.0, 1000.0), 0.0);
    assert_eq!(m.polarisation(&p, 480.0).unwrap(), 0.0);
    assert_eq!(m.sun_radiance(&view(0.0, 0.0, 0.0, 1.0), 480.0), 0.0);
}

#[test]
fn polarisation_is_the_negated_sum_at_alpha_zero_unclamped() {
    let rad = |_| [1.0; 8];
    // sun = 1, zenith(x) = 2x/π: α is θ′ even for a sun below the horizon.
    let m = model(&fit(&[0.0], 1, rad, |_| [1.0, 1.0, 0.0, 1.0, 2.0]));
    let got = m.polarisation(&view(0.5, 1.0, 2.0, -0.1), 420.0).unwrap();
    assert!((got + 2.0 / PI).abs() < 1e-12, "{got}");
    let m = model(&fit(&[0.0], 1, rad, |_| [-1.0, -1.0, 1.0, 1.0, 1.0]));
    assert_eq!(m.polarisation(&view(0.5, 1.0, 2.0, 0.1), 420.0).unwrap(), 1.0);
    let mut no_polarisation = fit(&[0.0], 1, rad, |_| ONES);
    no_polarisation.polarisation = None;
    let e = model(&no_polarisation)
        .polarisation(&view(0.5, 1.0, 2.0, 0.1), 420.0)
        .unwrap_err();
    assert!(e.to_string().contains("no polarisation"), "{e}");
}

/// Transmittance: 2 observer altitudes (0, 1000 m), 2 visibilities
/// (20, 60 km); √T at the nodes (d, a) of the lower observer altitude
/// `u0`, half of it at the upper one; V = 1 at 20 km, 0.5 at 60 km.
fn transmittance_model(u0: [f64; 4]) -> Model {
    let mut f = fit(&[0.0], 1, |_| [1.0; 8], |_| ONES);
    f.transmittance = Transmittance {
        d_dim: 2,
        a_dim: 2,
        altitudes_m: vec![0.0, 1000.0],
        visibilities_km: vec![20.0, 60.0],
        rank: 1,
        u: u0.iter().copied().chain(u0.iter().map(|u| u / 2.0)).collect(),
        v: vec![1.0, 1.0, 0.5, 0.5],
    };
    model(&f)
}

fn path(theta: f64, altitude_m: f64, visibility_km: f64) -> Parameters {
    Parameters {
        theta,
        altitude_m,
        visibility_km,
        ..view(0.0, theta, 0.0, 0.5)
    }
}

// u(d, a) in U's order: (d0, a0), (d0, a1), (d1, a0), (d1, a1).
const U0: [f64; 4] = [0.875, 0.75, 0.625, 0.5];

#[test]
fn transmittance_at_the_nodes_and_between_them() {
    let m = transmittance_model(U0);
    // On the ground looking up over 0 m: the node (0, 0).
    assert_eq!(m.transmittance(&path(0.0, 0.0, 20.0), 420.0, 0.0), 0.875 * 0.875);
    // Looking down from the ground: no path at all.
    assert_eq!(m.transmittance(&path(1.8, 0.0, 20.0), 420.0, 5000.0), 0.875 * 0.875);
    // Straight up to 6.25 km: halfway (in altitude³) to the 12.5 km node.
    let got = m.transmittance(&path(0.0, 0.0, 20.0), 420.0, 6250.0);
    assert!((got - 0.8125f64.powi(2)).abs() < 1e-12, "{got}");
    // Straight up through the top: the last altitude node.
    assert_eq!(m.transmittance(&path(0.0, 0.0, 20.0), 420.0, f64::MAX), 0.75 * 0.75);
    // Between the visibilities (40 km) and observer altitudes (250 m).
    let got = m.transmittance(&path(0.0, 0.0, 40.0), 420.0, 0.0);
    assert!((got - (0.75 * 0.875f64).powi(2)).abs() < 1e-12, "{got}");
    // At 250 m the path's end is 250 m up (2 % of the way to the 12.5 km
    // node in altitude³), and a quarter of the way to the upper
    // observer altitude, whose values are halved.
    let root = (0.875 + (0.75 - 0.875) * 0.02) * (1.0 - 0.25 * 0.5);
    let got = m.transmittance(&path(0.0, 250.0, 20.0), 420.0, 0.0);
    assert!((got - root * root).abs() < 1e-12, "{got}");
}

#[test]
fn a_slanted_path_is_bilinear_in_altitude_cubed_and_distance_to_the_fourth() {
    let m = transmittance_model(U0);
    let (theta, h, s) = (80f64.to_radians(), 1000.0, 20_000.0);
    // The path's end by the law of cosines, its ground arc by atan2.
    let r0 = PLANET_RADIUS_M + h;
    let r = (r0 * r0 + s * s + 2.0 * r0 * s * theta.cos()).sqrt();
    let arc = (s * theta.sin()).atan2(r0 + s * theta.cos()) * PLANET_RADIUS_M;
    let a = (r - PLANET_RADIUS_M) / TOP_M / 0.125;
    let d = arc / MAX_ARC_M / 0.0625;
    assert!(
        a > 0.0 && a < 1.0 && d > 0.0 && d < 1.0,
        "inside the first cell: {a} {d}"
    );
    let root = (1.0 - d) * ((1.0 - a) * U0[0] + a * U0[1]) + d * ((1.0 - a) * U0[2] + a * U0[3]);
    // At the upper observer altitude node: U halved.
    let got = m.transmittance(&path(theta, h, 20.0), 420.0, s);
    assert!(
        (got - (root / 2.0).powi(2)).abs() < 1e-9,
        "{got} vs {}",
        (root / 2.0).powi(2)
    );
}

#[test]
fn negative_node_values_are_clamped_before_the_altitude_interpolation() {
    let m = transmittance_model([-0.5, 0.5, 0.0, 0.0]);
    assert_eq!(m.transmittance(&path(0.0, 0.0, 20.0), 420.0, 0.0), 0.0);
    let got = m.transmittance(&path(0.0, 0.0, 20.0), 420.0, 6250.0);
    assert!((got - 0.0625).abs() < 1e-12, "(0 + 0.5)/2 squared: {got}");
}

#[test]
fn the_sun_is_its_disc_radiance_times_the_transmittance() {
    let m = transmittance_model(U0);
    let solar = SolarSpectrum::kurucz().unwrap();
    let omega = 2.0 * PI * (1.0 - SUN_RADIUS.cos());
    // From the ground straight up through the top: T = u(d0, a1)².
    let mut p = path(0.0, 0.0, 20.0);
    p.gamma = 0.004;
    let expected = solar.irradiance(420.0).unwrap() / omega * 0.75 * 0.75;
    assert!((m.sun_radiance(&p, 420.0) / expected - 1.0).abs() < 1e-9);
    p.gamma = 0.0047;
    assert_eq!(m.sun_radiance(&p, 420.0), 0.0);
}

#[test]
fn an_inconsistent_dataset_is_refused() {
    let mut dataset = Dataset::encode(&fit(&[0.0], 1, |_| [1.0; 8], |_| ONES), "t").unwrap();
    dataset.radiance.coefs.pop();
    let e = Model::new("broken", dataset, SolarSpectrum::kurucz().unwrap()).unwrap_err();
    assert!(e.to_string().starts_with("broken: radiance: 7 values"), "{e}");
}
