//! Property tests (proptest) of every reader of outside bytes: job files,
//! uvspec inputs, state files (checkpoints and shards share one format) and
//! EXR images. Whatever the bytes, a reader must return a value or a user
//! error (the binary's exit code 2, with a message naming the file): never
//! panic, hang or make a huge allocation.
//!
//! Random bytes rarely get past a reader's first check, so most inputs are
//! built from the reader's own grammar (the job schema's sections and keys,
//! uvspec's keywords, the state format's fields) with values from plausible
//! to absurd (0, −0, 1e300, 5e-324, nan, inf, i64::MAX, wrong types,
//! garbage words), or are valid files damaged by small edits; damaged state
//! files get their checksum recomputed, so the parser's deeper paths run.
//!
//! Cases per reader: `ATMOSIM_FUZZ_CASES` (default 3000, for CI: about
//! 15 s in all on two cores), and a hundredth of that (default 200) for
//! the checks of the real binary, one process per case. Seeds are fixed: a run is reproducible, and a failure is
//! shrunk to a small input that proptest prints. The long run of the issue:
//! `ATMOSIM_FUZZ_CASES=100000 cargo test --release --test readers_fuzz -- --nocapture`
//! (each test prints its cases, how many were read (Ok) and refused (Err),
//! and its time).
//!
//! Every single allocation of this test binary is capped (`CappedAlloc`),
//! so a size field read from damaged bytes that would allocate gigabytes
//! aborts the run on every machine instead of succeeding where memory is
//! overcommitted; a case that runs past [`HANG_LIMIT`] aborts it with the
//! input.
//!
//! (Over 600 lines: one grammar per reader and the generators that damage
//! it; the four readers share the harness that runs them.)

use std::alloc::{GlobalAlloc, Layout as AllocLayout, System};
use std::cell::Cell;
use std::fmt::Debug;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use atmosim::Error;
use atmosim::compat::uvspec::{IGNORED_KEYWORDS, NUMERICAL_KEYWORDS, UvspecInput};
use atmosim::film::tally::Tally;
use atmosim::fnv;
use atmosim::io::exr::{Channel, read_exr_bytes, write_exr};
use atmosim::job::Job;
use atmosim::run::checkpoint::{StateFile, shard_path, write_state};
use atmosim::run::layout::Layout;
use atmosim::run::shard::Shard;
use proptest::prelude::*;
use proptest::sample::{Index, select, subsequence};
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};

// Limits

/// Largest single allocation: far above what any input here needs, far
/// below what a length read from damaged bytes can ask for.
const MAX_ALLOCATION: usize = 256 << 20;

/// Refuses allocations above [`MAX_ALLOCATION`]: the refusal aborts the
/// test binary ("memory allocation of N bytes failed").
struct CappedAlloc;

// SAFETY: forwards to the system allocator, or fails (null) before it.
unsafe impl GlobalAlloc for CappedAlloc {
    unsafe fn alloc(&self, layout: AllocLayout) -> *mut u8 {
        if layout.size() > MAX_ALLOCATION {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: AllocLayout) -> *mut u8 {
        if layout.size() > MAX_ALLOCATION {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: AllocLayout, new_size: usize) -> *mut u8 {
        if new_size > MAX_ALLOCATION {
            return std::ptr::null_mut();
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: AllocLayout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: CappedAlloc = CappedAlloc;

/// Longest a case may take: parsing is milliseconds; this leaves room for
/// a loaded machine and a debug build.
const CASE_LIMIT: Duration = Duration::from_secs(10);
/// A case still running after this is taken for a hang.
const HANG_LIMIT: Duration = Duration::from_secs(60);

/// Cases per reader: `ATMOSIM_FUZZ_CASES`, else `default`.
fn cases(default: u32) -> u32 {
    std::env::var("ATMOSIM_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// Cases of a check of the binary (one process each): a hundredth of
/// `ATMOSIM_FUZZ_CASES`, else `default`.
fn cli_cases(default: u32) -> u32 {
    std::env::var("ATMOSIM_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse::<u32>().ok())
        .map_or(default, |n| (n / 100).max(1))
}

// The runner

/// What a reader did with one input.
enum Outcome {
    /// Read it (Ok).
    Read,
    /// Refused it with a user error (Err, exit code 2).
    Refused,
}

/// The outcome of a reader's result: a user error whose message names
/// `file` (data errors name the data file they are about), else a
/// failure of the property.
fn outcome<T>(result: &atmosim::Result<T>, file: &str) -> Result<Outcome, String> {
    match result {
        Ok(_) => Ok(Outcome::Read),
        Err(e) if !e.is_user_error() => Err(format!("not a user error (exit code 1): {e:?}")),
        Err(e) if !matches!(e, Error::Data { .. }) && !e.to_string().contains(file) => {
            Err(format!("the message does not name {file}: {e}"))
        }
        Err(_) => Ok(Outcome::Refused),
    }
}

/// Aborts the process when a case runs past [`HANG_LIMIT`], printing it.
struct Watchdog {
    case: Arc<Mutex<(Option<Instant>, String)>>,
    done: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Watchdog {
    fn start(reader: &'static str) -> Watchdog {
        let case = Arc::new(Mutex::new((None::<Instant>, String::new())));
        let done = Arc::new(AtomicBool::new(false));
        let thread = {
            let (case, done) = (case.clone(), done.clone());
            std::thread::spawn(move || {
                while !done.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(200));
                    let c = case.lock().unwrap_or_else(|e| e.into_inner());
                    if let Some(t) = c.0.filter(|t| t.elapsed() > HANG_LIMIT) {
                        eprintln!(
                            "{reader}: a case has run for {:?} (a hang); the input:\n{}",
                            t.elapsed(),
                            c.1
                        );
                        std::process::abort();
                    }
                }
            })
        };
        Watchdog {
            case,
            done,
            thread: Some(thread),
        }
    }

    fn enter(&self, input: String) {
        *self.case.lock().unwrap_or_else(|e| e.into_inner()) = (Some(Instant::now()), input);
    }

    fn leave(&self) {
        self.case.lock().unwrap_or_else(|e| e.into_inner()).0 = None;
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.done.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Runs `check` on `cases` inputs drawn from `strategy` with a fixed seed.
/// A panic, a case slower than [`CASE_LIMIT`] or an `Err` of `check`
/// fails the test (after proptest shrinks the input). Prints the counts and
/// the time, and requires both outcomes to occur: a generator that only
/// ever reaches the first check tests little.
fn fuzz<S>(
    reader: &'static str,
    seed: u8,
    cases: u32,
    strategy: S,
    check: impl Fn(&S::Value) -> Result<Outcome, String>,
) where
    S: Strategy,
    S::Value: Debug,
{
    let config = Config {
        cases,
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        max_shrink_iters: 2000,
        // A failure is reported after at most this much shrinking, even
        // when every try is slow.
        max_shrink_time: 120_000,
        ..Config::default()
    };
    let mut runner = TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]));
    let watchdog = Watchdog::start(reader);
    let (read, refused, slowest) = (Cell::new(0u64), Cell::new(0u64), Cell::new(Duration::ZERO));
    let start = Instant::now();
    let result = runner.run(&strategy, |input| {
        watchdog.enter(format!("{input:?}"));
        let t = Instant::now();
        let result = check(&input);
        let dt = t.elapsed();
        watchdog.leave();
        slowest.set(slowest.get().max(dt));
        prop_assert!(dt < CASE_LIMIT, "{reader}: one case took {dt:?}");
        match result.map_err(TestCaseError::fail)? {
            Outcome::Read => read.set(read.get() + 1),
            Outcome::Refused => refused.set(refused.get() + 1),
        }
        Ok(())
    });
    println!(
        "{reader}: {} cases, {} Ok, {} Err, {:.2} s (slowest case {:.1} ms)",
        read.get() + refused.get(),
        read.get(),
        refused.get(),
        start.elapsed().as_secs_f64(),
        slowest.get().as_secs_f64() * 1e3
    );
    if let Err(e) = result {
        panic!("{reader}: {e}");
    }
    assert_eq!(read.get() + refused.get(), cases as u64, "{reader}: cases run");
    if cases >= 50 {
        assert!(read.get() > 0 && refused.get() > 0, "{reader}: only one outcome");
    }
}

// Values of TOML, as text

/// Numbers from plausible to absurd, some of them not TOML at all.
const NUMBERS: &[&str] = &[
    "0",
    "-0.0",
    "0.0",
    "1",
    "-1",
    "0.5",
    "0.999999",
    "1.0000001",
    "2",
    "3",
    "45",
    "90",
    "-90",
    "90.0001",
    "180",
    "180.5",
    "360",
    "-360",
    "400",
    "540",
    "550.0",
    "1000",
    "6378",
    "100",
    "120",
    "1e6",
    "1e300",
    "-1e300",
    "1e-300",
    "5e-324",
    "nan",
    "-nan",
    "inf",
    "-inf",
    "+inf",
    "16384",
    "16385",
    "100000",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551615",
    "4294967296",
    "1_000",
    "0x10",
    "0o7",
    "0b1",
    "1e400",
    "1.",
    ".5",
    "1e",
    "--1",
];

/// Words of the schema's closed sets, the built-in tables' names, file
/// names (in the test's directory) and garbage.
const WORDS: &[&str] = &[
    "spherical",
    "plane_parallel",
    "pseudo_spherical",
    "bogumil",
    "molina",
    "none",
    "bodhaine",
    "directions",
    "fisheye",
    "panorama",
    "sphere",
    "up",
    "down",
    "equidistant",
    "equisolid",
    "stereographic",
    "box",
    "center",
    "layered",
    "smooth",
    "analytic",
    "ratio_tracking",
    "residual_ratio_tracking",
    "auto",
    "sun_aware",
    "collision",
    "normalized",
    "absolute",
    "us_standard",
    "tropical",
    "midlatitude_summer",
    "midlatitude_winter",
    "subarctic_summer",
    "subarctic_winter",
    "continental_average",
    "continental_clean",
    "continental_polluted",
    "urban",
    "profile.txt",
    "bad_profile.txt",
    "empty.txt",
    "missing.txt",
    "out",
    "",
    " ",
    "Spherical",
    "NONE",
    "desert",
    "afglus",
];

/// Bits of TOML syntax, mostly broken.
const TOKENS: &[&str] = &[
    "\"unterminated",
    "'",
    "[",
    "]",
    "{",
    "}",
    "[[",
    "=",
    "\"\"\"",
    "1979-05-27T07:32:00Z",
    "07:32:00",
    "{}",
    "[]",
    "[,]",
    "{ a = }",
    "nan nan",
    "true false",
    "\"\\u0000\"",
    "\"\\x41\"",
    "'''x'''",
    "\"\\uD800\"",
];

fn float(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{x:?}")
    }
}

/// A TOML basic string of `s`.
fn quote(s: &str) -> String {
    let mut q = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => q.push_str("\\\""),
            '\\' => q.push_str("\\\\"),
            c if c.is_control() => q.push_str(&format!("\\u{:04X}", c as u32)),
            c => q.push(c),
        }
    }
    q.push('"');
    q
}

fn number() -> BoxedStrategy<String> {
    prop_oneof![
        3 => select(NUMBERS).prop_map(str::to_string),
        2 => any::<f64>().prop_map(float),
        2 => (-200.0..1000.0f64).prop_map(float),
        1 => any::<i64>().prop_map(|i| i.to_string()),
        1 => (-5i64..70_000).prop_map(|i| i.to_string()),
    ]
    .boxed()
}

fn string() -> BoxedStrategy<String> {
    prop_oneof![
        3 => select(WORDS).prop_map(quote),
        1 => "\\PC{0,12}".prop_map(|s| quote(&s)),
        1 => select(TOKENS).prop_map(str::to_string),
    ]
    .boxed()
}

fn scalar() -> BoxedStrategy<String> {
    prop_oneof![
        4 => number(),
        2 => string(),
        1 => select(&["true", "false", "True"][..]).prop_map(str::to_string),
    ]
    .boxed()
}

fn array(element: BoxedStrategy<String>, len: std::ops::RangeInclusive<usize>) -> BoxedStrategy<String> {
    prop::collection::vec(element, len)
        .prop_map(|v| format!("[{}]", v.join(", ")))
        .boxed()
}

/// Any value: scalars, arrays (empty, mixed, nested) and inline tables.
fn any_value() -> BoxedStrategy<String> {
    prop_oneof![
        4 => scalar(),
        2 => array(number(), 0..=16),
        1 => array(scalar(), 0..=16),
        1 => array(array(number(), 0..=3), 0..=16),
        1 => prop::collection::vec(("[a-z_]{1,10}", scalar()), 0..4).prop_map(|kv| {
            let kv: Vec<String> = kv.iter().map(|(k, v)| format!("{k} = {v}")).collect();
            format!("{{ {} }}", kv.join(", "))
        }),
    ]
    .boxed()
}

// Job files

/// What a key takes, and its plausible values.
#[derive(Debug, Clone, Copy)]
enum Kind {
    Num(f64, f64),
    NumOrList(f64, f64),
    List(f64, f64),
    Int(i64, i64),
    IntOrPair(i64, i64),
    Pairs,
    Bool,
    Word(&'static [&'static str]),
}

use Kind::*;

const GEOMETRIES: &[&str] = &["spherical", "plane_parallel", "pseudo_spherical", "flat"];
const PROFILES: &[&str] = &[
    "us_standard",
    "tropical",
    "midlatitude_winter",
    "subarctic_summer",
    "afglus",
];
const PROFILE_FILES: &[&str] = &["profile.txt", "bad_profile.txt", "empty.txt", "missing.txt", "."];
const OZONE: &[&str] = &["bogumil", "molina", "none", "gome"];
const RAYLEIGH: &[&str] = &["bodhaine", "none", "penndorf"];
const AEROSOLS: &[&str] = &[
    "continental_average",
    "continental_clean",
    "urban",
    "none",
    "desert",
    "desert_spheroids",
    "maritime_tropical",
];
const AEROSOL_PHASES: &[&str] = &["mie", "hg", "rayleigh"];
const SENSORS: &[&str] = &["directions", "fisheye", "panorama", "sphere", "camera"];
const HEMISPHERES: &[&str] = &["up", "down", "side"];
const PROJECTIONS: &[&str] = &["equidistant", "equisolid", "stereographic", "orthographic"];
const FILTERS: &[&str] = &["box", "center", "gauss"];
const STOKES_FRAMES: &[&str] = &["meridian", "sun_view", "camera"];
const MEDIA: &[&str] = &["layered", "smooth", "voxel"];
const SUN_TRANSMITTANCE: &[&str] = &["analytic", "ratio_tracking", "delta"];
const SUN_SAMPLING: &[&str] = &["auto", "sun_aware", "collision", "never"];
const TRACKING_LAYERS: &[&str] = &["auto", "profile", "merged", "fine"];
const UNITS: &[&str] = &["normalized", "absolute", "photons"];
const TARGET_ALBEDOS: &[&str] = &["all", "above_zero", "nonzero"];
const DIRECTORIES: &[&str] = &["out", "o/p", "", "."];
const ESTIMATORS: &[&str] = &["ratio_tracking", "residual_ratio_tracking", "analytic", "delta"];

/// The job schema (src/job/raw.rs): each section's keys.
const SECTIONS: &[(&str, &[(&str, Kind)])] = &[
    (
        "planet",
        &[
            ("radius_km", Num(1.0, 10_000.0)),
            ("top_km", Num(1.0, 130.0)),
            ("geometry", Word(GEOMETRIES)),
        ],
    ),
    (
        "atmosphere",
        &[
            ("profile", Word(PROFILES)),
            ("profile_file", Word(PROFILE_FILES)),
            ("ozone", Word(OZONE)),
            ("ozone_column_du", Num(0.0, 600.0)),
            ("rayleigh", Word(RAYLEIGH)),
            ("aerosol", Word(AEROSOLS)),
            ("aerosol_phase", Word(AEROSOL_PHASES)),
            ("visibility_km", NumOrList(1.0, 200.0)),
        ],
    ),
    (
        "spectrum",
        &[
            ("wavelengths_nm", List(250.0, 900.0)),
            ("band_width_nm", NumOrList(0.0, 40.0)),
        ],
    ),
    ("observer", &[("altitude_km", NumOrList(0.0, 20.0))]),
    (
        "sun",
        &[
            ("zenith_deg", NumOrList(0.0, 180.0)),
            ("elevation_deg", NumOrList(-90.0, 90.0)),
            ("angular_radius_deg", Num(0.0, 1.0)),
        ],
    ),
    ("ground", &[("albedo", NumOrList(0.0, 1.0))]),
    (
        "sensor",
        &[
            ("type", Word(SENSORS)),
            ("view_zenith_deg", List(0.0, 180.0)),
            ("azimuth_deg", List(-360.0, 360.0)),
            ("directions", Pairs),
            ("fluxes", Bool),
            ("resolution", IntOrPair(1, 64)),
            ("hemisphere", Word(HEMISPHERES)),
            ("projection", Word(PROJECTIONS)),
            ("pixel_filter", Word(FILTERS)),
            ("stokes_frame", Word(STOKES_FRAMES)),
        ],
    ),
    (
        "render",
        &[
            ("samples", Int(0, 100_000)),
            ("noise_target", Num(0.0, 1.5)),
            ("pilot_samples", Int(0, 100)),
            ("max_samples", Int(0, 100_000)),
            ("noise_target_albedos", Word(TARGET_ALBEDOS)),
            ("seed", Int(0, 1000)),
            ("polarized", Bool),
            ("max_scattering_order", Int(0, 10)),
            ("medium", Word(MEDIA)),
            ("sun_transmittance", Word(SUN_TRANSMITTANCE)),
            ("tracking_layers", Word(TRACKING_LAYERS)),
            ("majorant_scale", Num(1.0, 4.0)),
            ("forced_collisions", Bool),
            ("sun_samples_per_flight", Int(0, 4)),
            ("sun_sampling", Word(SUN_SAMPLING)),
            ("first_vertex_splitting", Bool),
            ("roulette_threshold", Num(0.0, 1.5)),
            ("shared_wavelengths", Bool),
            ("spectral_groups", Int(0, 4)),
        ],
    ),
    (
        "output",
        &[
            ("directory", Word(DIRECTORIES)),
            ("sun", Bool),
            ("units", Word(UNITS)),
            ("preview", Bool),
            ("exposure", Num(0.0, 10.0)),
        ],
    ),
    (
        "transmittance",
        &[
            ("altitude_nodes", Int(0, 40)),
            ("distance_nodes", Int(0, 70)),
            ("max_distance_km", Num(0.0, 3000.0)),
            ("altitudes_km", List(0.0, 100.0)),
            ("distances_km", List(0.0, 3000.0)),
            ("estimator", Word(ESTIMATORS)),
            ("samples", Int(0, 2000)),
            ("export_sqrt", Bool),
        ],
    ),
];

/// The keys of `[[atmosphere.layers]]` and `[[atmosphere.aerosol_layers]]`.
const LAYER: &[(&str, Kind)] = &[
    ("bottom_km", Num(0.0, 50.0)),
    ("top_km", Num(0.0, 100.0)),
    ("tau_rayleigh", Num(0.0, 1.0)),
    ("rayleigh_depolarization", Num(0.0, 0.1)),
    ("tau_absorption", Num(0.0, 1.0)),
    ("tau_aerosol", Num(0.0, 1.0)),
    ("aerosol_ssa", Num(0.0, 1.0)),
    ("aerosol_g", Num(-1.0, 1.0)),
];
const AEROSOL_LAYER: &[(&str, Kind)] = &[
    ("bottom_km", Num(0.0, 10.0)),
    ("top_km", Num(0.0, 20.0)),
    ("tau", Num(0.0, 1.0)),
    ("ssa", Num(0.0, 1.0)),
    ("g", Num(-1.0, 1.0)),
];

/// A plausible value of a key: of its type, mostly in range; short lists
/// (a job's grid is the product of its lists).
fn plausible(kind: Kind) -> BoxedStrategy<String> {
    let num = |lo: f64, hi: f64| (lo..=hi).prop_map(float).boxed();
    match kind {
        Num(lo, hi) => num(lo, hi),
        NumOrList(lo, hi) => prop_oneof![num(lo, hi), array(num(lo, hi), 1..=3)].boxed(),
        List(lo, hi) => array(num(lo, hi), 1..=4),
        Int(lo, hi) => (lo..=hi).prop_map(|i| i.to_string()).boxed(),
        IntOrPair(lo, hi) => prop_oneof![
            (lo..=hi).prop_map(|i| i.to_string()),
            (lo..=hi, lo..=hi).prop_map(|(w, h)| format!("[{w}, {h}]")),
        ]
        .boxed(),
        Pairs => array(
            (0.0..=180.0f64, -360.0..=360.0f64)
                .prop_map(|(z, a)| format!("[{}, {}]", float(z), float(a)))
                .boxed(),
            1..=4,
        ),
        Bool => any::<bool>().prop_map(|b| b.to_string()).boxed(),
        Word(words) => select(words).prop_map(quote).boxed(),
    }
}

/// `key = value` lines for some of `keys` (each at most once), and now and
/// then a key the schema does not know.
fn key_lines(keys: &'static [(&'static str, Kind)]) -> BoxedStrategy<String> {
    let lines = subsequence(keys, 0..=keys.len().min(6)).prop_flat_map(|chosen| {
        chosen
            .into_iter()
            .map(|(key, kind)| {
                prop_oneof![3 => plausible(kind), 1 => any_value()].prop_map(move |v| format!("{key} = {v}\n"))
            })
            .collect::<Vec<_>>()
    });
    let unknown = prop::option::weighted(
        0.05,
        ("[a-z_]{1,10}", any_value()).prop_map(|(k, v)| format!("{k} = {v}\n")),
    );
    (lines, unknown)
        .prop_map(|(lines, unknown)| lines.concat() + &unknown.unwrap_or_default())
        .boxed()
}

/// A job file built from the schema: some sections in any order, some
/// layer tables.
fn structured_job() -> BoxedStrategy<String> {
    let sections: Vec<BoxedStrategy<Option<String>>> = SECTIONS
        .iter()
        .map(|&(name, keys)| {
            prop::option::weighted(0.5, key_lines(keys).prop_map(move |body| format!("[{name}]\n{body}"))).boxed()
        })
        .collect();
    let tables = |name: &'static str, keys: &'static [(&'static str, Kind)]| {
        prop::collection::vec(key_lines(keys).prop_map(move |b| format!("[[{name}]]\n{b}")), 0..=3)
    };
    (
        sections,
        prop::option::weighted(0.15, tables("atmosphere.layers", LAYER)),
        prop::option::weighted(0.15, tables("atmosphere.aerosol_layers", AEROSOL_LAYER)),
    )
        .prop_map(|(sections, layers, aerosol_layers)| {
            let mut parts: Vec<String> = sections.into_iter().flatten().collect();
            parts.extend(layers.unwrap_or_default());
            parts.extend(aerosol_layers.unwrap_or_default());
            parts
        })
        .prop_shuffle()
        .prop_map(|parts| parts.concat())
        .boxed()
}

/// A small edit of a text's bytes.
#[derive(Debug, Clone)]
enum Edit {
    Flip(Index, u8),
    Set(Index, u8),
    Delete(Index, usize),
    DuplicateLine(Index),
    Truncate(Index),
    Insert(Index, String),
}

/// Bytes that matter to TOML, uvspec and numbers, and a few that are not
/// text at all.
const SPECIAL_BYTES: &[u8] = b"=[]{}\"'#\n., -+0123456789e_\t\\\0\x7f\xff";

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<Index>(), 0..8u8).prop_map(|(i, b)| Edit::Flip(i, b)),
        (any::<Index>(), select(SPECIAL_BYTES)).prop_map(|(i, b)| Edit::Set(i, b)),
        (any::<Index>(), 1..16usize).prop_map(|(i, n)| Edit::Delete(i, n)),
        any::<Index>().prop_map(Edit::DuplicateLine),
        any::<Index>().prop_map(Edit::Truncate),
        (
            any::<Index>(),
            prop_oneof![any_value(), select(TOKENS).prop_map(str::to_string)]
        )
            .prop_map(|(i, s)| Edit::Insert(i, s)),
    ]
}

/// `text` with `edits` applied, as text again (bytes that are not UTF-8
/// become U+FFFD: the readers take `&str`).
fn edited(text: &str, edits: &[Edit]) -> String {
    let mut b = text.as_bytes().to_vec();
    for e in edits {
        let at = |i: &Index, len: usize| if len == 0 { 0 } else { i.index(len) };
        match e {
            Edit::Flip(i, bit) if !b.is_empty() => {
                let k = at(i, b.len());
                b[k] ^= 1 << bit;
            }
            Edit::Set(i, v) if !b.is_empty() => {
                let k = at(i, b.len());
                b[k] = *v;
            }
            Edit::Delete(i, n) => {
                let k = at(i, b.len());
                b.drain(k..(k + n).min(b.len()));
            }
            Edit::DuplicateLine(i) => {
                let k = at(i, b.len());
                let start = b[..k].iter().rposition(|&c| c == b'\n').map_or(0, |p| p + 1);
                let end = b[k..].iter().position(|&c| c == b'\n').map_or(b.len(), |p| k + p + 1);
                let line = b[start..end].to_vec();
                b.splice(end..end, line);
            }
            Edit::Truncate(i) => b.truncate(at(i, b.len() + 1)),
            Edit::Insert(i, s) => {
                let k = at(i, b.len() + 1);
                b.splice(k..k, s.bytes());
            }
            _ => {}
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

/// The files of a repository directory with extension `ext`.
fn repo_files(dir: &str, ext: &str) -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    paths.sort();
    assert!(!paths.is_empty(), "no .{ext} files in {}", dir.display());
    paths.iter().map(|p| std::fs::read_to_string(p).unwrap()).collect()
}

/// Job files: built from the schema, then damaged or not, and the
/// examples damaged.
fn job_text() -> BoxedStrategy<String> {
    let examples = repo_files("examples", "toml");
    prop_oneof![
        4 => structured_job(),
        1 => (structured_job(), prop::collection::vec(edit(), 1..4)).prop_map(|(t, e)| edited(&t, &e)),
        2 => (select(examples), prop::collection::vec(edit(), 0..4)).prop_map(|(t, e)| edited(&t, &e)),
    ]
    .boxed()
}

/// A directory with the files job and uvspec inputs name: a valid AFGL
/// profile, damaged ones, uvspec layer files.
fn data_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let afgl = Path::new(env!("CARGO_MANIFEST_DIR")).join("atmospheres/afgl/us_standard.txt");
    let profile = std::fs::read_to_string(afgl).unwrap();
    let damaged: String = profile
        .lines()
        .take(12)
        .map(|l| l.replacen("0", "nan", 1) + "\n")
        .collect();
    let layer = |v: &str| format!("# z value\n2.0 0.0\n1.0 {v}\n0.0 {v}\n");
    let (tau, ssa, gg) = (layer("0.1"), layer("0.9"), layer("0.7"));
    for (name, text) in [
        ("profile.txt", profile.as_str()),
        ("bad_profile.txt", damaged.as_str()),
        ("empty.txt", ""),
        ("tau.dat", tau.as_str()),
        ("ssa.dat", ssa.as_str()),
        ("gg.dat", gg.as_str()),
        ("wild.dat", "0 -1\n5 1e300\n7 nan\n"),
        ("bad.dat", "1 2 3\nx y\n"),
        ("one.dat", "0 0.1\n"),
    ] {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    dir
}

#[test]
fn job_files() {
    let dir = data_dir();
    fuzz("job TOML", 1, cases(3000), job_text(), |text| {
        let job = Job::parse(text, "fuzz.toml", dir.path());
        outcome(&job, "fuzz.toml")
    });
}

// uvspec inputs

const AFGL: &[&str] = &[
    "afglus",
    "afglms",
    "afglt",
    "afglsw",
    "afglus.dat",
    "../data/atmmod/afglmw.dat",
    "profile.txt",
    "bad_profile.txt",
    "missing.dat",
    "afglxx",
];
const LAYER_FILES: &[&str] = &[
    "tau.dat",
    "ssa.dat",
    "gg.dat",
    "wild.dat",
    "bad.dat",
    "one.dat",
    "missing.dat",
];
const OPAC: &[&str] = &[
    "continental_average",
    "urban",
    "continental_clean",
    "maritime_clean",
    "../opac/urban.mix",
];
const SOLVERS: &[&str] = &[
    "disort",
    "fdisort2",
    "twostr",
    "polradtran",
    "mystic",
    "montecarlo",
    "sdisort",
    "spsdisort",
    "sos",
    "rodents",
];
const COLUMNS: &[&str] = &[
    "lambda", "zout", "edir", "edn", "eup", "uavg", "uu", "u0u", "umu", "phi", "sza", "bogus",
];

/// The keywords of the uvspec subset (src/compat/uvspec/input.rs).
const KEYWORDS: &[&str] = &[
    "atmosphere_file",
    "albedo",
    "sza",
    "phi0",
    "umu",
    "phi",
    "zout",
    "wavelength",
    "earth_radius",
    "aerosol_default",
    "aerosol_species_file",
    "aerosol_visibility",
    "aerosol_file",
    "mol_modify",
    "crs_model",
    "mol_abs_param",
    "output_quantity",
    "rte_solver",
    "pseudospherical",
    "mc_spherical",
    "mc_polarisation",
    "mc_polarization",
    "polradtran",
    "source",
    "output_user",
];

fn words(list: &'static [&'static str]) -> BoxedStrategy<String> {
    select(list).prop_map(str::to_string).boxed()
}

fn nums(lo: f64, hi: f64, n: std::ops::RangeInclusive<usize>) -> BoxedStrategy<Vec<String>> {
    prop::collection::vec((lo..=hi).prop_map(|x| format!("{x}")), n).boxed()
}

/// Plausible arguments of a uvspec keyword.
fn uvspec_args(keyword: &'static str) -> BoxedStrategy<Vec<String>> {
    let one = |s: BoxedStrategy<String>| s.prop_map(|w| vec![w]).boxed();
    match keyword {
        "atmosphere_file" => one(words(AFGL)),
        "albedo" => nums(0.0, 1.0, 1..=1),
        "sza" => nums(0.0, 180.0, 1..=1),
        "phi0" => nums(-360.0, 360.0, 1..=1),
        "umu" => nums(-1.0, 1.0, 1..=5),
        "phi" => nums(0.0, 360.0, 1..=5),
        "zout" => prop::collection::vec(
            prop_oneof![
                (0.0..30.0f64).prop_map(|z| format!("{z}")),
                words(&["sur", "boa", "toa", "SUR"])
            ],
            1..=4,
        )
        .boxed(),
        "wavelength" => (250.0..900.0f64, any::<bool>())
            .prop_map(|(w, twice)| {
                if twice {
                    vec![format!("{w}"); 2]
                } else {
                    vec![format!("{w}")]
                }
            })
            .boxed(),
        "earth_radius" => nums(1000.0, 10_000.0, 1..=1),
        "aerosol_species_file" => one(words(OPAC)),
        "aerosol_visibility" => nums(1.0, 200.0, 1..=1),
        "aerosol_file" => (words(&["tau", "ssa", "gg", "moments"]), words(LAYER_FILES))
            .prop_map(|(a, b)| vec![a, b])
            .boxed(),
        "mol_modify" => (
            words(&["O3", "o3", "NO2", "H2O"]),
            (0.0..500.0f64).prop_map(|x| format!("{x}")),
            words(&["DU", "CM_2", "du", "ppm"]),
        )
            .prop_map(|(a, b, c)| vec![a, b, c])
            .boxed(),
        "crs_model" => (
            words(&["rayleigh", "o3", "O3", "no2"]),
            words(&["Bodhaine", "Bogumil", "Molina", "bodhaine", "Nicolet"]),
        )
            .prop_map(|(a, b)| vec![a, b])
            .boxed(),
        "mol_abs_param" => one(words(&["crs", "reptran"])),
        "output_quantity" => one(words(&["transmittance", "reflectivity"])),
        "rte_solver" => one(words(SOLVERS)),
        "mc_spherical" => prop::collection::vec(words(&["1D", "3D"]), 0..=1).boxed(),
        "polradtran" => prop_oneof![
            words(&["1", "2", "3", "4", "3.0"]).prop_map(|n| vec!["nstokes".to_string(), n]),
            Just(vec!["src_code".to_string(), "2".to_string()]),
        ]
        .boxed(),
        "source" => prop::collection::vec(words(&["solar", "thermal", "kurucz.dat"]), 1..=2).boxed(),
        "output_user" => prop::collection::vec(words(COLUMNS), 1..=5).boxed(),
        _ => Just(Vec::new()).boxed(),
    }
}

/// An argument of any kind.
fn wild_arg() -> BoxedStrategy<String> {
    prop_oneof![
        3 => select(NUMBERS).prop_map(str::to_string),
        2 => any::<f64>().prop_map(|x| x.to_string()),
        2 => select(WORDS).prop_map(str::to_string),
        1 => words(LAYER_FILES),
        1 => "\\PC{1,8}",
    ]
    .boxed()
}

/// One line of a uvspec input.
fn uvspec_line() -> BoxedStrategy<String> {
    let keyword = prop_oneof![
        6 => select(KEYWORDS),
        1 => select(NUMERICAL_KEYWORDS),
        1 => select(IGNORED_KEYWORDS),
    ];
    let plausible = keyword.prop_flat_map(|k| uvspec_args(k).prop_map(move |a| format!("{k} {}", a.join(" "))));
    let wild = (
        prop_oneof![select(KEYWORDS).prop_map(str::to_string), "[a-z_]{1,12}"],
        prop::collection::vec(wild_arg(), 0..5),
    )
        .prop_map(|(k, a)| format!("{k} {}", a.join(" ")));
    let line = prop_oneof![5 => plausible, 2 => wild, 1 => "(# .{0,10})?"];
    (line, prop::option::weighted(0.1, "# \\PC{0,8}"))
        .prop_map(|(l, comment)| l + &comment.unwrap_or_default())
        .boxed()
}

/// A uvspec input built from the keyword list: mostly with the two lines
/// every input needs, so that most get past the final checks.
fn structured_uvspec() -> BoxedStrategy<String> {
    (
        prop::option::weighted(0.85, Just("atmosphere_file afglus".to_string())),
        prop::option::weighted(0.85, Just("wavelength 540".to_string())),
        prop::collection::vec(uvspec_line(), 0..10),
    )
        .prop_map(|(a, w, mut lines)| {
            lines.extend(a);
            lines.extend(w);
            lines
        })
        .prop_shuffle()
        .prop_map(|lines| lines.join("\n") + "\n")
        .boxed()
}

/// The uvspec unit test's input with every keyword of the subset.
const EVERY_KEYWORD: &str = include_str!("data/every_keyword.inp");

fn uvspec_text() -> BoxedStrategy<String> {
    let mut inputs = repo_files("validation/libradtran", "inp");
    inputs.push(EVERY_KEYWORD.to_string());
    prop_oneof![
        4 => structured_uvspec(),
        1 => (structured_uvspec(), prop::collection::vec(edit(), 1..4)).prop_map(|(t, e)| edited(&t, &e)),
        2 => (select(inputs), prop::collection::vec(edit(), 0..4)).prop_map(|(t, e)| edited(&t, &e)),
    ]
    .boxed()
}

#[test]
fn uvspec_inputs() {
    let dir = data_dir();
    let samples = prop_oneof![8 => 1..1_000_000u64, 1 => Just(0u64), 1 => Just(u64::MAX)];
    let strategy = (uvspec_text(), samples, any::<u64>(), any::<bool>());
    fuzz(
        "uvspec input",
        2,
        cases(3000),
        strategy,
        |(text, samples, seed, full)| {
            let resolve = |name: &str| std::fs::read_to_string(dir.path().join(name));
            let mut input = match UvspecInput::parse(text, "fuzz.inp", &resolve) {
                Ok(input) => input,
                Err(e) => return outcome::<()>(&Err(e), "fuzz.inp"),
            };
            // As `UvspecInput::from_file` does: files are next to the input.
            input.dir = dir.path().to_path_buf();
            outcome(&input.job(*samples, *seed, *full), "fuzz.inp")
        },
    );
}

// State files

/// FNV-1a over little-endian 8-byte words: the state format's checksum
/// (src/run/checkpoint.rs, module docs).
fn checksum(words: &[u8]) -> u64 {
    words.chunks_exact(8).fold(0xcbf2_9ce4_8422_2325, |h, w| {
        (h ^ u64::from_le_bytes(w.try_into().unwrap())).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Job texts of the state files: small jobs of one and of several tasks,
/// an image, and texts that are no job.
const STATE_JOBS: &[&str] = &[
    "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [540.0]\n[sensor]\nview_zenith_deg = [0.0, 60.0]\nazimuth_deg = [0.0]\n[render]\nsamples = 3000\n",
    "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [450.0, 600.0]\n[sun]\nzenith_deg = [30.0, 60.0]\n[ground]\nalbedo = [0.0, 0.5]\n[render]\nsamples = 700\n",
    "[atmosphere]\naerosol = \"none\"\n[spectrum]\nwavelengths_nm = [500.0, 600.0]\nband_width_nm = 20.0\n[sensor]\ntype = \"fisheye\"\nresolution = 4\n[render]\nsamples = 9\n",
    "",
    "[render]\nsamples = 0\n",
    "not a job",
    "[atmosphere]\nprofile_file = \"missing.txt\"\n",
];

/// Valid state files of the first three jobs: parsed, laid out and
/// filled with sums (finite, and a few that are not), some complete.
fn state_files(dir: &Path) -> Vec<StateFile> {
    let mut files = Vec::new();
    for (j, text) in STATE_JOBS[..3].iter().enumerate() {
        let job = Job::parse(text, "state.toml", dir).unwrap();
        for (t, task) in job.tasks.iter().enumerate().take(2) {
            let layout = Layout::new(&job, task, job.spectral_scene(task).is_some());
            let shard = Shard::new(1 + t as u64, 3).unwrap();
            let mut state = layout.empty_state(&job, task, shard);
            for (e, (done, tallies)) in state.done.iter_mut().zip(&mut state.tallies).enumerate() {
                let r = layout.range(e, shard);
                *done = if (j + e) % 2 == 0 {
                    r.end - r.start
                } else {
                    (r.end - r.start) / 2
                };
                for (k, tally) in tallies.iter_mut().enumerate() {
                    let x = (k as f64 + 1.0) * 0.25;
                    *tally = Tally {
                        sum: [x, -x, 1e-300, if k == 1 { f64::NAN } else { x * x }],
                        sum_sq: [x * x, x * x, 0.0, f64::INFINITY],
                        samples: *done * 7,
                        non_finite: k as u64 % 3,
                    };
                }
            }
            files.push(StateFile::new(&job, state));
        }
    }
    files
}

/// An edit of a state file's fields, encoded afterwards.
#[derive(Debug, Clone)]
enum StateEdit {
    Task(u64),
    Shard(u64, u64),
    Done(Index, u64),
    DropEstimate,
    DropTally(Index),
    /// A job text of [`STATE_JOBS`]; with its hash when true (as a file of
    /// that job has).
    JobText(Index, bool),
    JobHash(String),
    JobDir(String),
}

/// An edit of a state file's bytes.
#[derive(Debug, Clone)]
enum ByteEdit {
    Flip(Index, u8),
    Word(Index, u64),
    InsertWord(Index, u64),
    RemoveWord(Index),
    Truncate(Index),
    Extend(Vec<u8>),
}

/// Word values that matter to lengths and counts.
const WORDS64: &[u64] = &[
    0,
    1,
    2,
    3,
    7,
    8,
    9,
    16,
    80,
    81,
    1 << 31,
    1 << 32,
    1 << 60,
    1 << 63,
    u64::MAX / 80 + 1,
    u64::MAX - 7,
    u64::MAX,
];

fn word64() -> BoxedStrategy<u64> {
    prop_oneof![3 => select(WORDS64), 1 => any::<u64>(), 1 => 0..4096u64].boxed()
}

fn state_edit() -> impl Strategy<Value = StateEdit> {
    prop_oneof![
        word64().prop_map(StateEdit::Task),
        (word64(), word64()).prop_map(|(i, n)| StateEdit::Shard(i, n)),
        (any::<Index>(), word64()).prop_map(|(i, d)| StateEdit::Done(i, d)),
        Just(StateEdit::DropEstimate),
        any::<Index>().prop_map(StateEdit::DropTally),
        (any::<Index>(), any::<bool>()).prop_map(|(i, h)| StateEdit::JobText(i, h)),
        "[0-9a-f]{0,17}".prop_map(StateEdit::JobHash),
        select(&["", ".", "/nonexistent", "a\u{0}b"][..]).prop_map(|d| StateEdit::JobDir(d.to_string())),
    ]
}

fn byte_edit() -> impl Strategy<Value = ByteEdit> {
    prop_oneof![
        3 => (any::<Index>(), 0..8u8).prop_map(|(i, b)| ByteEdit::Flip(i, b)),
        3 => (any::<Index>(), word64()).prop_map(|(i, w)| ByteEdit::Word(i, w)),
        1 => (any::<Index>(), word64()).prop_map(|(i, w)| ByteEdit::InsertWord(i, w)),
        1 => any::<Index>().prop_map(ByteEdit::RemoveWord),
        1 => any::<Index>().prop_map(ByteEdit::Truncate),
        1 => prop::collection::vec(any::<u8>(), 1..40).prop_map(ByteEdit::Extend),
    ]
}

/// How a state file's bytes are made.
#[derive(Debug, Clone)]
enum StateInput {
    /// A valid file (by index), its fields and bytes edited, the checksum
    /// recomputed or not.
    Edited {
        base: Index,
        fields: Vec<StateEdit>,
        bytes: Vec<ByteEdit>,
        rechecksum: bool,
    },
    /// The header, then random words, checksummed.
    Words(Vec<u64>),
    /// Random bytes.
    Bytes(Vec<u8>),
}

fn state_input() -> impl Strategy<Value = StateInput> {
    prop_oneof![
        8 => (
            any::<Index>(),
            prop::collection::vec(state_edit(), 0..3),
            prop::collection::vec(byte_edit(), 0..4),
            prop::bool::weighted(0.9),
        )
            .prop_map(|(base, fields, bytes, rechecksum)| StateInput::Edited { base, fields, bytes, rechecksum }),
        1 => prop::collection::vec(word64(), 0..40).prop_map(StateInput::Words),
        1 => prop::collection::vec(any::<u8>(), 0..300).prop_map(StateInput::Bytes),
    ]
}

/// The bytes of a state input, from the valid `files`.
fn state_bytes(input: &StateInput, files: &[StateFile]) -> Vec<u8> {
    let put_checksum = |b: &mut Vec<u8>| {
        if b.len() >= 8 && b.len().is_multiple_of(8) {
            let n = b.len() - 8;
            let sum = checksum(&b[..n]);
            b[n..].copy_from_slice(&sum.to_le_bytes());
        }
    };
    match input {
        StateInput::Bytes(b) => b.clone(),
        StateInput::Words(words) => {
            let mut b = b"ATMOSIM-STATE-1\n".to_vec();
            for w in words {
                b.extend(w.to_le_bytes());
            }
            b.extend([0; 8]);
            put_checksum(&mut b);
            b
        }
        StateInput::Edited {
            base,
            fields,
            bytes,
            rechecksum,
        } => {
            let mut f = files[base.index(files.len())].clone();
            for e in fields {
                let s = &mut f.state;
                match e {
                    StateEdit::Task(t) => s.task = *t as usize,
                    StateEdit::Shard(i, n) => {
                        // Only what the encoder can write: a valid shard.
                        if let Some(shard) = Shard::new(*i, *n) {
                            s.shard = shard;
                        }
                    }
                    StateEdit::Done(i, d) if !s.done.is_empty() => {
                        let k = i.index(s.done.len());
                        s.done[k] = *d;
                    }
                    StateEdit::DropEstimate => {
                        s.done.pop();
                        s.tallies.pop();
                    }
                    StateEdit::DropTally(i) => {
                        if let Some(list) = s.tallies.iter_mut().find(|l| !l.is_empty()) {
                            let k = i.index(list.len());
                            list.remove(k);
                        }
                    }
                    StateEdit::JobText(i, rehash) => {
                        f.job_text = STATE_JOBS[i.index(STATE_JOBS.len())].to_string();
                        if *rehash {
                            s.job_hash = format!("{:016x}", fnv::bytes(f.job_text.as_bytes()));
                        }
                    }
                    StateEdit::JobHash(h) => s.job_hash = h.clone(),
                    StateEdit::JobDir(d) => f.job_dir = PathBuf::from(d),
                    _ => {}
                }
            }
            let mut b = f.to_bytes();
            for e in bytes {
                let words = b.len() / 8;
                match e {
                    ByteEdit::Flip(i, bit) if !b.is_empty() => {
                        let k = i.index(b.len());
                        b[k] ^= 1 << bit;
                    }
                    ByteEdit::Word(i, w) if words > 0 => {
                        let k = 8 * i.index(words);
                        b[k..k + 8].copy_from_slice(&w.to_le_bytes());
                    }
                    ByteEdit::InsertWord(i, w) => {
                        let k = 8 * i.index(words + 1);
                        b.splice(k..k, w.to_le_bytes());
                    }
                    ByteEdit::RemoveWord(i) if words > 0 => {
                        let k = 8 * i.index(words);
                        b.drain(k..k + 8);
                    }
                    ByteEdit::Truncate(i) => b.truncate(i.index(b.len() + 1)),
                    ByteEdit::Extend(more) => b.extend(more),
                    _ => {}
                }
            }
            if *rechecksum {
                put_checksum(&mut b);
            }
            b
        }
    }
}

/// Reads a state file, then uses it as `merge` and `render --resume` do.
fn check_state(bytes: &[u8]) -> Result<Outcome, String> {
    let f = match StateFile::from_bytes(bytes, "fuzz.shard") {
        Ok(f) => f,
        Err(e) => return outcome::<()>(&Err(e), "fuzz.shard"),
    };
    // What was read encodes to a file that reads back to the same bytes.
    let again = f.to_bytes();
    let back = StateFile::from_bytes(&again, "again").map_err(|e| format!("re-encoded file refused: {e}"))?;
    if back.to_bytes() != again {
        return Err("re-encoding changed the file".into());
    }
    let job = f.job();
    outcome(&job, &f.job_file).map_err(|e| format!("the file's job: {e}"))?;
    // merge and resume lay out a task of the job only for a file of that job.
    if let Ok(job) = job
        && job.hash == f.state.job_hash
        && let Some(task) = job.tasks.get(f.state.task)
    {
        let mut layout = Layout::new(&job, task, job.spectral_scene(task).is_some());
        layout.allocate(&f.state);
        if layout.fits(&f.state) {
            let _ = f.state.is_complete(&layout);
            let _ = layout.done_paths(&f.state);
            let _ = f.state.non_finite(&layout);
            let mut total = f.state.clone();
            total.add(&f.state, &layout);
        }
    }
    Ok(Outcome::Read)
}

#[test]
fn state_files_checkpoints_and_shards() {
    let dir = data_dir();
    let files = state_files(dir.path());
    fuzz("state file", 3, cases(3000), state_input(), |input| {
        check_state(&state_bytes(input, &files))
    });
}

// EXR images

/// Valid EXRs of the writer: a few sizes, channels and attributes.
fn exr_files() -> Vec<Vec<u8>> {
    let dir = tempfile::tempdir().unwrap();
    let image = |width: usize, height: usize, channels: &[&str], attributes: &[(&str, &str)]| {
        let p = dir.path().join("t.exr");
        let n = width * height;
        let channels = channels
            .iter()
            .enumerate()
            .map(|(c, name)| Channel {
                name: name.to_string(),
                samples: (0..n).map(|i| ((i * 7 + c * 13) % 17) as f32 * 0.37 - 1.0).collect(),
            })
            .collect();
        let attributes: Vec<(String, String)> =
            attributes.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        write_exr(&p, width, height, channels, &attributes).unwrap();
        std::fs::read(&p).unwrap()
    };
    let mut files = vec![
        image(3, 2, &["540nm.I", "blocked"], &[("units", "1")]),
        image(
            16,
            8,
            &["a.I", "a.Q", "a.U", "a.V"],
            &[("job_hash", "0123456789abcdef"), ("grid", "x^3")],
        ),
        image(1, 1, &["T"], &[]),
        image(64, 1, &["T", "sqrtT"], &[("note", "a longer text attribute, ünïcode")]),
    ];
    files.extend(foreign_exr_files());
    files
}

/// EXRs of what the writer never makes but a reader may be given: every
/// compression the exr crate writes, scan lines and tiles, f16, f32 and
/// u32 channels.
fn foreign_exr_files() -> Vec<Vec<u8>> {
    use exr::prelude::*;
    let (width, height) = (19, 11);
    let n = width * height;
    let value = |i: usize| ((i * 7) % 13) as f32 * 0.25 - 1.0;
    let mut files = Vec::new();
    for compression in [
        Compression::Uncompressed,
        Compression::RLE,
        Compression::ZIP1,
        Compression::ZIP16,
        Compression::PIZ,
        Compression::PXR24,
        Compression::B44,
        Compression::B44A,
    ] {
        for blocks in [Blocks::ScanLines, Blocks::Tiles(Vec2(8, 4))] {
            let channels = AnyChannels::sort(SmallVec::from_vec(vec![
                AnyChannel::new("h", FlatSamples::F16((0..n).map(|i| f16::from_f32(value(i))).collect())),
                AnyChannel::new("f", FlatSamples::F32((0..n).map(value).collect())),
                AnyChannel::new("u", FlatSamples::U32((0..n).map(|i| (i % 5) as u32).collect())),
            ]));
            let encoding = Encoding {
                compression,
                blocks,
                line_order: LineOrder::Increasing,
            };
            let layer = Layer::new((width, height), LayerAttributes::named("x"), encoding, channels);
            let mut bytes = std::io::Cursor::new(Vec::new());
            Image::from_layer(layer).write().to_buffered(&mut bytes).unwrap();
            files.push(bytes.into_inner());
        }
    }
    files
}

#[derive(Debug, Clone)]
enum ExrEdit {
    Flip(Index, u8),
    Byte(Index, u8),
    U32(Index, u32),
    Delete(Index, usize),
    Truncate(Index),
    Extend(Vec<u8>),
}

#[derive(Debug, Clone)]
enum ExrInput {
    Edited(Index, Vec<ExrEdit>),
    /// EXR's magic number and version, then random bytes.
    Headed(Vec<u8>),
    Bytes(Vec<u8>),
}

fn exr_input() -> impl Strategy<Value = ExrInput> {
    let u32s = prop_oneof![
        select(
            &[
                0u32,
                1,
                2,
                0x7fff_ffff,
                0x8000_0000,
                0xffff_ffff,
                0xffff,
                0x3fff_ffff,
                1 << 20
            ][..]
        ),
        any::<u32>()
    ];
    let edit = prop_oneof![
        3 => (any::<Index>(), 0..8u8).prop_map(|(i, b)| ExrEdit::Flip(i, b)),
        2 => (any::<Index>(), select(&[0u8, 1, 0x7f, 0x80, 0xff][..])).prop_map(|(i, b)| ExrEdit::Byte(i, b)),
        2 => (any::<Index>(), u32s).prop_map(|(i, v)| ExrEdit::U32(i, v)),
        1 => (any::<Index>(), 1..64usize).prop_map(|(i, n)| ExrEdit::Delete(i, n)),
        1 => any::<Index>().prop_map(ExrEdit::Truncate),
        1 => prop::collection::vec(any::<u8>(), 1..64).prop_map(ExrEdit::Extend),
    ];
    prop_oneof![
        8 => (any::<Index>(), prop::collection::vec(edit, 0..5)).prop_map(|(i, e)| ExrInput::Edited(i, e)),
        1 => prop::collection::vec(any::<u8>(), 0..600).prop_map(ExrInput::Headed),
        1 => prop::collection::vec(any::<u8>(), 0..600).prop_map(ExrInput::Bytes),
    ]
}

fn exr_bytes(input: &ExrInput, files: &[Vec<u8>]) -> Vec<u8> {
    match input {
        ExrInput::Bytes(b) => b.clone(),
        ExrInput::Headed(b) => [&[0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0][..], b].concat(),
        ExrInput::Edited(base, edits) => {
            let mut b = files[base.index(files.len())].clone();
            for e in edits {
                let len = b.len();
                match e {
                    ExrEdit::Flip(i, bit) if len > 0 => b[i.index(len)] ^= 1 << bit,
                    ExrEdit::Byte(i, v) if len > 0 => b[i.index(len)] = *v,
                    ExrEdit::U32(i, v) if len >= 4 => {
                        let k = i.index(len - 3);
                        b[k..k + 4].copy_from_slice(&v.to_le_bytes());
                    }
                    ExrEdit::Delete(i, n) if len > 0 => {
                        let k = i.index(len);
                        b.drain(k..(k + n).min(len));
                    }
                    ExrEdit::Truncate(i) => b.truncate(i.index(len + 1)),
                    ExrEdit::Extend(more) => b.extend(more),
                    _ => {}
                }
            }
            b
        }
    }
}

#[test]
fn exr_images() {
    let files = exr_files();
    fuzz("EXR", 4, cases(3000), exr_input(), |input| {
        let bytes = exr_bytes(input, &files);
        match read_exr_bytes(&bytes, "fuzz.exr") {
            Ok(image) => {
                // What was read is consistent: every channel has a sample per pixel.
                let n = image.width * image.height;
                match image.channels.iter().find(|c| c.samples.len() != n) {
                    Some(c) => Err(format!("{}: {} samples for {n} pixels", c.name, c.samples.len())),
                    None => Ok(Outcome::Read),
                }
            }
            Err(e @ Error::Data { .. }) if e.to_string().contains("fuzz.exr") => Ok(Outcome::Refused),
            Err(e) => Err(format!("not a data error naming the file: {e:?}")),
        }
    });
}

// The binary

/// Checks a run of the binary: exit code 0 or 2 (never 1, a panic's 101
/// or a signal), no panic message, and on exit 2 a message that starts
/// with `error: ` (after uvspec's warnings).
fn check_run(out: &std::process::Output) -> Result<Outcome, String> {
    let err = String::from_utf8_lossy(&out.stderr);
    if err.contains("panicked") {
        return Err(format!("panic: {err}"));
    }
    match out.status.code() {
        Some(0) => Ok(Outcome::Read),
        Some(2) => {
            let message = err
                .lines()
                .skip_while(|l| l.starts_with("warning: "))
                .collect::<Vec<_>>()
                .join("\n");
            if message.starts_with("error: ") && message.len() > "error: ".len() {
                Ok(Outcome::Refused)
            } else {
                Err(format!("exit code 2 without an error message: {err:?}"))
            }
        }
        code => Err(format!("exit code {code:?}: {err}")),
    }
}

/// The binary, killed when it runs past [`CASE_LIMIT`].
fn atmosim() -> assert_cmd::Command {
    let mut command = assert_cmd::Command::cargo_bin("atmosim").unwrap();
    command.timeout(CASE_LIMIT);
    command
}

#[test]
fn binary_on_job_files() {
    let dir = data_dir();
    fuzz("CLI atmosphere", 5, cli_cases(200), job_text(), |text| {
        std::fs::write(dir.path().join("job.toml"), text).unwrap();
        let out = atmosim()
            .current_dir(dir.path())
            .args(["atmosphere", "job.toml", "--format", "csv"])
            .output()
            .unwrap();
        check_run(&out)
    });
}

#[test]
fn binary_on_uvspec_inputs() {
    let dir = data_dir();
    fuzz("CLI uvspec", 6, cli_cases(200), uvspec_text(), |text| {
        std::fs::write(dir.path().join("in.inp"), text).unwrap();
        let out = atmosim()
            .current_dir(dir.path())
            .args(["uvspec", "in.inp", "--print-job"])
            .output()
            .unwrap();
        check_run(&out)
    });
}

#[test]
fn binary_on_damaged_shards() {
    // A job of one task in two shards, both complete; the second damaged,
    // alone or beside the first.
    let dir = data_dir();
    let job = Job::parse(STATE_JOBS[0], "job.toml", dir.path()).unwrap();
    let task = &job.tasks[0];
    let layout = Layout::new(&job, task, job.spectral_scene(task).is_some());
    let shards: Vec<StateFile> = (1..=2)
        .map(|k| {
            let shard = Shard::new(k, 2).unwrap();
            let mut state = layout.empty_state(&job, task, shard);
            for (e, done) in state.done.iter_mut().enumerate() {
                let r = layout.range(e, shard);
                *done = r.end - r.start;
            }
            for tally in state.tallies.iter_mut().flatten() {
                *tally = Tally {
                    sum: [1.0, 0.1, -0.1, 0.0],
                    sum_sq: [2.0, 0.1, 0.1, 0.0],
                    samples: 10,
                    non_finite: 0,
                };
            }
            StateFile::new(&job, state)
        })
        .collect();
    let out_dir = tempfile::tempdir().unwrap();
    let first = shard_path(out_dir.path(), shards[0].state.shard);
    std::fs::create_dir_all(first.parent().unwrap()).unwrap();
    let second = shard_path(out_dir.path(), shards[1].state.shard);
    let first_bytes = shards[0].to_bytes();
    fuzz(
        "CLI merge",
        7,
        cli_cases(200),
        (state_input(), any::<bool>()),
        |(input, alone)| {
            if *alone {
                let _ = std::fs::remove_file(&first);
            } else {
                std::fs::write(&first, &first_bytes).unwrap();
            }
            std::fs::write(&second, state_bytes(input, &shards[1..])).unwrap();
            let out = atmosim()
                .args(["merge", "--quiet"])
                .arg(out_dir.path())
                .output()
                .unwrap();
            check_run(&out)
        },
    );
}

// Regressions: inputs the fuzzing found

/// `altitude_nodes = 10¹²` allocated the node list while the job was read.
#[test]
fn huge_transmittance_node_counts_are_refused() {
    for key in ["altitude_nodes", "distance_nodes"] {
        for n in ["1000000000000", "9223372036854775807", "100001"] {
            let text = format!("[transmittance]\n{key} = {n}\n");
            let e = Job::parse(&text, "job.toml", Path::new(".")).unwrap_err().to_string();
            assert!(
                e.contains("job.toml") && e.contains(&format!("transmittance.{key}")) && e.contains("too many nodes"),
                "{e}"
            );
        }
    }
    assert!(Job::parse("[transmittance]\naltitude_nodes = 100000\n", "job.toml", Path::new(".")).is_ok());
}

/// A shard "1 of 2⁶²" made `merge` list every missing shard by name.
#[test]
fn merge_of_a_shard_of_a_huge_count_names_a_few_missing() {
    let dir = tempfile::tempdir().unwrap();
    let job = Job::parse(STATE_JOBS[0], "job.toml", dir.path()).unwrap();
    let task = &job.tasks[0];
    let layout = Layout::new(&job, task, false);
    let shard = Shard::new(1, 1 << 62).unwrap();
    let state = layout.empty_state(&job, task, shard);
    let path = shard_path(dir.path(), shard);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    write_state(&job, &state, &path).unwrap();
    let start = Instant::now();
    let e = atmosim::run::merge::merge(dir.path(), &|_: &str| {}).unwrap_err();
    assert!(start.elapsed() < Duration::from_secs(5), "{:?}", start.elapsed());
    let message = e.to_string();
    assert!(e.is_user_error(), "{message}");
    assert!(
        message.contains("missing shard(s) 2/4611686018427387904, 3/4611686018427387904")
            && message.contains("and 4611686018427387893 more"),
        "{message}"
    );
}

/// A data window of 2¹⁶ × 2¹⁶ pixels in a small file made the exr crate
/// allocate 16 GiB per channel before reading a block.
#[test]
fn exr_of_a_huge_data_window_is_refused() {
    let mut bytes = exr_files().swap_remove(0);
    let key = b"dataWindow\0box2i\0\x10\0\0\0";
    let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len();
    for (k, v) in [0i32, 0, 0xffff, 0xffff].iter().enumerate() {
        bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    let e = read_exr_bytes(&bytes, "big.exr").err().unwrap();
    let message = e.to_string();
    assert!(matches!(e, Error::Data { .. }), "{e:?}");
    assert!(
        message.starts_with("big.exr: not a readable OpenEXR file") && message.contains("65536 × 65536"),
        "{message}"
    );
}

/// `read_exr` of a file that is no EXR is a user error naming the file
/// (it was an I/O error of kind `Other`: exit code 1).
#[test]
fn exr_reader_errors_are_user_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("image.exr");
    std::fs::write(&path, b"not an EXR").unwrap();
    let e = atmosim::io::exr::read_exr(&path).err().unwrap();
    assert!(e.is_user_error() && e.to_string().contains("image.exr"), "{e}");
    let missing = atmosim::io::exr::read_exr(&dir.path().join("missing.exr"))
        .err()
        .unwrap();
    assert!(
        missing.is_user_error() && missing.to_string().contains("missing.exr"),
        "{missing}"
    );
}
