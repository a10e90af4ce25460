//! The book against the code: every job file shown in README.md, docs/ and
//! examples/ parses; the job-key reference (docs/job-files.md) is the job
//! schema's, key by key, with its values, defaults and ranges; the outputs
//! chapter (docs/outputs.md) names exactly what a render writes; and every
//! repository path the book names exists. Each check is a function of the
//! text, shown failing on a drifted copy by a test beside it. (The commands
//! shown are checked against the command line in `src/cli/doc_commands.rs`.)

mod common;

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;
use std::sync::{Mutex, OnceLock};

use atmosim::job::Job;
use atmosim::skymodel::fit::settings::FitSettings;
use common::markdown::{self, Block};

// Job files

/// A fit-settings file has the fit's required keys at the top level; a
/// job file has none of them.
fn is_fit_settings(text: &str) -> bool {
    text.parse::<toml::Table>()
        .is_ok_and(|t| t.contains_key("renders") || t.contains_key("out"))
}

/// The job files (and fit settings) among `files` (name, text) that do
/// not parse, each with its error.
fn unparsed_job_files(files: &[(String, String)]) -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    files
        .iter()
        .filter_map(|(name, text)| {
            let result = if is_fit_settings(text) {
                FitSettings::parse(text, name).map(|_| ())
            } else {
                Job::parse(text, name, dir).map(|_| ())
            };
            result.err().map(|e| format!("{name}: {e}"))
        })
        .collect()
}

/// Every ```toml block of the book, named by file and line.
fn toml_blocks() -> Vec<(String, String)> {
    let mut out = Vec::new();
    for file in markdown::doc_files() {
        for Block { lang, line, text } in markdown::fenced_blocks(&markdown::read(&file)) {
            if lang == "toml" {
                out.push((format!("{file}:{line}"), text));
            }
        }
    }
    out
}

/// Every .toml file under examples/.
fn example_files() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = Vec::new();
    let mut stack = vec![root.join("examples")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "toml") {
                let name = p.strip_prefix(root).unwrap().display().to_string();
                out.push((name, std::fs::read_to_string(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn every_job_file_in_the_book_and_the_examples_parses() {
    let blocks = toml_blocks();
    let examples = example_files();
    assert!(blocks.len() >= 5, "{} toml blocks", blocks.len());
    assert!(examples.len() >= 20, "{} example files", examples.len());
    let fits = blocks
        .iter()
        .chain(&examples)
        .filter(|(_, t)| is_fit_settings(t))
        .count();
    assert!(fits >= 2, "{fits} fit-settings files");
    let failed = unparsed_job_files(&[blocks, examples].concat());
    assert!(failed.is_empty(), "{}", failed.join("\n\n"));
}

#[test]
fn a_drifted_job_file_is_caught() {
    let good = "[render]\nsamples = 64\n".to_string();
    assert!(unparsed_job_files(&[("good".into(), good)]).is_empty());
    for drifted in [
        "[render]\nsampels = 64\n",                          // a key renamed
        "[sensor]\ntype = \"cylinder\"\n",                   // a value that is not one
        "[sun]\nelevation_deg = 120.0\n",                    // out of range
        "renders = \"out/r\"\nrank = 9\n",                   // fit settings without `out`
        "renders = \"out/r\"\nout = \"s.dat\"\nranks = 9\n", // a fit key renamed
    ] {
        let failed = unparsed_job_files(&[("drifted".into(), drifted.into())]);
        assert_eq!(failed.len(), 1, "not caught: {drifted}");
    }
}

// The job schema, discovered from the serde structs' own refusals

const PROBE: &str = "__probe__";

/// Which sections are arrays of tables.
type Arrays = BTreeSet<String>;

/// The job text of `lines` (section, `key = value`), each section once,
/// parents before children, arrays of tables as `[[…]]`.
fn job_text(lines: &[(String, String)], arrays: &Arrays) -> String {
    let mut by_section: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (s, l) in lines {
        by_section.entry(s).or_default().push(l);
    }
    let mut text = String::new();
    for (s, ls) in by_section {
        if !s.is_empty() {
            text += &if arrays.contains(s) {
                format!("[[{s}]]\n")
            } else {
                format!("[{s}]\n")
            };
        }
        for l in ls {
            text += l;
            text.push('\n');
        }
    }
    text
}

fn parse(text: &str) -> Result<Job, String> {
    Job::parse(text, "probe.toml", Path::new(env!("CARGO_MANIFEST_DIR"))).map_err(|e| e.to_string())
}

/// The backticked names after "expected" in a serde refusal of an unknown
/// field or variant (`None` when the error is another).
fn expected_names(error: &str, what: &str) -> Option<Vec<String>> {
    let line = error
        .lines()
        .find(|l| l.contains(&format!("unknown {what} `{PROBE}`")))?;
    let tail = &line[line.find("expected")?..];
    Some(tail.split('`').skip(1).step_by(2).map(String::from).collect())
}

/// The schema: per section, its keys; and per (section, key) of a closed
/// set of strings, the set.
#[derive(Debug, Default)]
struct Schema {
    sections: BTreeMap<String, Vec<String>>,
    arrays: Arrays,
    variants: BTreeMap<(String, String), BTreeSet<String>>,
}

fn schema() -> &'static Schema {
    static SCHEMA: OnceLock<Schema> = OnceLock::new();
    SCHEMA.get_or_init(discover_schema)
}

fn discover_schema() -> Schema {
    let mut schema = Schema::default();
    let top = parse(&format!("{PROBE} = 1\n")).unwrap_err();
    let mut stack: Vec<String> = expected_names(&top, "field").expect("top-level sections");
    while let Some(section) = stack.pop() {
        let as_table = parse(&format!("[{section}]\n{PROBE} = 1\n")).unwrap_err();
        let keys = match expected_names(&as_table, "field") {
            Some(k) => k,
            None => {
                let as_array = parse(&format!("[[{section}]]\n{PROBE} = 1\n")).unwrap_err();
                schema.arrays.insert(section.clone());
                expected_names(&as_array, "field").unwrap_or_else(|| panic!("{section}: {as_array}"))
            }
        };
        for key in &keys {
            let child = format!("{section}.{key}");
            let as_table = parse(&format!("[{child}]\n{PROBE} = 1\n")).err().unwrap_or_default();
            let as_array = parse(&format!("[[{child}]]\n{PROBE} = 1\n")).err().unwrap_or_default();
            if expected_names(&as_table, "field").is_some() || expected_names(&as_array, "field").is_some() {
                stack.push(child);
                continue;
            }
            let arrays = schema.arrays.clone();
            let line = (section.clone(), format!("{key} = \"{PROBE}\""));
            let text = job_text(&[line], &arrays);
            if let Some(v) = parse(&text).err().and_then(|e| expected_names(&e, "variant")) {
                schema
                    .variants
                    .insert((section.clone(), key.clone()), v.into_iter().collect());
            }
        }
        schema.sections.insert(section, keys);
    }
    schema
}

// The key reference

/// One row of the reference: its section, cells and line.
#[derive(Debug, Clone)]
struct Row {
    section: String,
    key: String,
    kind: String,
    default: String,
    range: String,
    line: usize,
}

/// The reference's rows, from the tables under "### `[section]`" headings.
fn reference_rows(chapter: &str) -> Vec<Row> {
    let mut rows = Vec::new();
    for (heading, body) in markdown::sections(chapter, 3) {
        let Some(section) = heading
            .strip_prefix("`[")
            .and_then(|h| h.strip_suffix("]`"))
            .map(|h| h.trim_start_matches('[').trim_end_matches(']').to_string())
        else {
            continue;
        };
        for (line, cells) in markdown::table_rows(&body) {
            if cells.len() != 6 || cells[0] == "key" {
                continue;
            }
            let key = markdown::cell_code(&cells[0]).first().cloned().unwrap_or_default();
            rows.push(Row {
                section: section.clone(),
                key,
                kind: cells[1].clone(),
                default: cells[3].clone(),
                range: cells[4].clone(),
                line,
            });
        }
    }
    rows
}

/// Keys that mean something only beside another: what a check sets first.
fn context(section: &str, key: &str) -> Vec<(String, String)> {
    let s = |sec: &str, line: &str| (sec.to_string(), line.to_string());
    let mut lines = match (section, key) {
        // A planet of 1 m is valid, its default transmittance distances not.
        ("planet", "radius_km") => vec![s("transmittance", "max_distance_km = 0.000001")],
        ("sensor", "resolution" | "hemisphere" | "projection" | "pixel_filter" | "symmetry") => {
            vec![s("sensor", "type = \"fisheye\"")]
        }
        ("render", "pilot_samples" | "max_samples") => vec![s("render", "noise_target = 0.1")],
        // "above_zero" needs an albedo above 0, "image" an image.
        ("render", "noise_target_albedos" | "noise_target_per") => vec![
            s("render", "noise_target = 0.1"),
            s("ground", "albedo = 0.5"),
            s("sensor", "type = \"fisheye\""),
        ],
        // The gases take bands; their scalings need their gas.
        ("atmosphere", "gases") => vec![s("spectrum", "band_width_nm = 40.0")],
        ("atmosphere", "precipitable_water_cm" | "co2_ppm") => vec![
            s("spectrum", "band_width_nm = 40.0"),
            s("atmosphere", "gases = \"all\""),
        ],
        ("atmosphere.layers", _) => vec![
            s("atmosphere.layers", "bottom_km = 0.0"),
            s("atmosphere.layers", "top_km = 1.0"),
        ],
        ("atmosphere.aerosol_layers", _) => vec![
            s("atmosphere.aerosol_layers", "bottom_km = 0.0"),
            s("atmosphere.aerosol_layers", "top_km = 1.0"),
            s("atmosphere.aerosol_layers", "tau = 0.1"),
        ],
        _ => Vec::new(),
    };
    lines.retain(|(sec, l)| !(sec == section && l.starts_with(&format!("{key} ="))));
    lines
}

/// The resolved job, less what names its text, as comparable text; or
/// the error. Remembered: the drifted copies ask again for the same jobs.
fn resolved(text: &str) -> Result<String, String> {
    static SEEN: OnceLock<Mutex<HashMap<String, Result<String, String>>>> = OnceLock::new();
    let seen = SEEN.get_or_init(Default::default);
    if let Some(r) = seen.lock().unwrap().get(text) {
        return r.clone();
    }
    let r = parse(text).map(|mut job| {
        job.text.clear();
        job.hash.clear();
        format!("{job:?}")
    });
    seen.lock().unwrap().insert(text.to_string(), r.clone());
    r
}

/// An interval `[a, b]`, `(a, b]`, … with ∞ for no bound.
#[derive(Debug, Clone, Copy)]
struct Interval {
    lo: Option<(f64, bool)>, // (bound, closed)
    hi: Option<(f64, bool)>,
}

fn interval(span: &str) -> Option<Interval> {
    let s = span.trim();
    let (open, close) = (s.chars().next()?, s.chars().last()?);
    if !"[(".contains(open) || !"])".contains(close) {
        return None;
    }
    let (a, b) = s[1..s.len() - 1].split_once(',')?;
    let bound = |t: &str, closed: bool| -> Option<Option<(f64, bool)>> {
        let t = t.trim();
        if t.ends_with('∞') {
            Some(None)
        } else {
            Some(Some((t.replace('−', "-").parse().ok()?, closed)))
        }
    };
    Some(Interval {
        lo: bound(a, open == '[')?,
        hi: bound(b, close == ']')?,
    })
}

/// A value of the row's type as TOML.
fn value(kind: &str, x: f64) -> String {
    let v = if kind.starts_with("whole number") {
        format!("{}", x.round() as i64)
    } else {
        format!("{x:?}")
    };
    if kind.starts_with("list of") {
        format!("[{v}]")
    } else {
        v
    }
}

/// What of the reference `chapter` disagrees with the schema.
fn reference_drift(chapter: &str) -> Vec<String> {
    let schema = schema();
    let rows = reference_rows(chapter);
    let mut drift = Vec::new();
    // Keys: the schema's and the reference's, section by section.
    let documented: BTreeSet<(String, String)> = rows.iter().map(|r| (r.section.clone(), r.key.clone())).collect();
    let actual: BTreeSet<(String, String)> = schema
        .sections
        .iter()
        .flat_map(|(s, keys)| keys.iter().map(move |k| (s.clone(), k.clone())))
        .collect();
    for (s, k) in actual.difference(&documented) {
        drift.push(format!("[{s}] {k}: in the schema, not in the reference"));
    }
    for (s, k) in documented.difference(&actual) {
        drift.push(format!("[{s}] {k}: in the reference, not in the schema"));
    }
    let arrays = &schema.arrays;
    let with = |row: &Row, extra: Option<String>| -> String {
        let mut lines = context(&row.section, &row.key);
        if let Some(v) = extra {
            lines.push((row.section.clone(), format!("{} = {v}", row.key)));
        }
        job_text(&lines, arrays)
    };
    let mut checked = (0, 0, 0);
    for row in rows
        .iter()
        .filter(|r| actual.contains(&(r.section.clone(), r.key.clone())))
    {
        let at = format!("docs line {}: [{}] {}", row.line, row.section, row.key);
        let spans = markdown::cell_code(&row.range);
        // The listed values: a closed set is the schema's, and each value
        // listed is accepted.
        let listed: BTreeSet<String> = spans
            .iter()
            .filter_map(|s| s.strip_prefix('"').and_then(|s| s.strip_suffix('"')))
            .map(String::from)
            .collect();
        if let Some(variants) = schema.variants.get(&(row.section.clone(), row.key.clone()))
            && &listed != variants
        {
            drift.push(format!("{at}: values {listed:?}, the schema's {variants:?}"));
        }
        for v in spans
            .iter()
            .filter(|s| s.starts_with('"') || *s == "true" || *s == "false")
        {
            if let Err(e) = resolved(&with(row, Some(v.clone()))) {
                drift.push(format!("{at}: listed value {v} is refused: {e}"));
            }
        }
        // The default, where written as a value: the same job as none.
        let default = markdown::cell_code(&row.default);
        if default.len() == 1 && row.default == format!("`{}`", default[0]) {
            checked.0 += 1;
            match (
                resolved(&with(row, None)),
                resolved(&with(row, Some(default[0].clone()))),
            ) {
                (Ok(a), Ok(b)) if a == b => {}
                (Ok(_), Ok(_)) => drift.push(format!("{at}: default {} is not the default", default[0])),
                (a, b) => drift.push(format!("{at}: default {}: {a:?} / {b:?}", default[0])),
            }
        }
        // The interval: accepted up to its ends, refused beyond.
        if let Some(iv) = spans.iter().find_map(|s| interval(s)) {
            checked.1 += 1;
            let step = |b: f64| {
                if row.kind.starts_with("whole number") {
                    1.0
                } else {
                    1e-6 * b.abs().max(1.0)
                }
            };
            let mut probes = Vec::new();
            if let Some((lo, closed)) = iv.lo {
                probes.push((if closed { lo } else { lo + step(lo) }, true));
                probes.push((if closed { lo - step(lo) } else { lo }, false));
            }
            if let Some((hi, closed)) = iv.hi {
                probes.push((if closed { hi } else { hi - step(hi) }, true));
                probes.push((if closed { hi + step(hi) } else { hi }, false));
            }
            for (x, accepted) in probes {
                let v = value(&row.kind, x);
                match (resolved(&with(row, Some(v.clone()))), accepted) {
                    (Ok(_), true) => {}
                    (Err(e), false) if e.contains(&row.key) => {}
                    (Err(e), true) => drift.push(format!("{at}: {v} inside the range is refused: {e}")),
                    (Err(e), false) => {
                        drift.push(format!("{at}: {v} beyond the range is refused without the key: {e}"))
                    }
                    (Ok(_), false) => drift.push(format!("{at}: {v} beyond the range is accepted")),
                }
            }
        }
        if !listed.is_empty() {
            checked.2 += 1;
        }
    }
    // The named sets that are tables, not enums.
    for (key, names) in [
        ("profile", names(atmosim::physics::data::AFGL_PROFILES, &[])),
        (
            "aerosol",
            names(atmosim::physics::data::OPAC_MIXTURES, &["desert_spheroids"]),
        ),
    ] {
        let row = rows.iter().find(|r| r.section == "atmosphere" && r.key == key);
        let listed: BTreeSet<String> = row
            .map(|r| {
                markdown::cell_code(&r.range)
                    .iter()
                    .filter_map(|s| s.strip_prefix('"').and_then(|s| s.strip_suffix('"')))
                    .filter(|s| *s != "none")
                    .map(String::from)
                    .collect()
            })
            .unwrap_or_default();
        if listed != names {
            drift.push(format!("[atmosphere] {key}: values {listed:?}, the built-in {names:?}"));
        }
    }
    if checked.0 < 40 || checked.1 < 25 || checked.2 < 20 {
        drift.push(format!(
            "only {} defaults, {} ranges and {} value lists checked",
            checked.0, checked.1, checked.2
        ));
    }
    drift
}

fn names(set: &[(&str, &str)], without: &[&str]) -> BTreeSet<String> {
    set.iter()
        .map(|(n, _)| n.to_string())
        .filter(|n| !without.contains(&n.as_str()))
        .collect()
}

#[test]
fn the_job_key_reference_is_the_schema() {
    let drift = reference_drift(&markdown::read("docs/job-files.md"));
    assert!(drift.is_empty(), "docs/job-files.md:\n{}", drift.join("\n"));
}

#[test]
fn a_drifted_key_reference_is_caught() {
    let chapter = markdown::read("docs/job-files.md");
    let row = |key: &str| {
        chapter
            .lines()
            .find(|l| l.starts_with(&format!("| `{key}` |")))
            .unwrap()
            .to_string()
    };
    let seed = row("seed");
    let samples = row("samples");
    let medium = row("medium");
    let albedo = row("albedo");
    let roulette = row("roulette_threshold");
    for (what, drifted) in [
        ("a key left out", chapter.replace(&format!("{seed}\n"), "")),
        ("a key renamed", chapter.replace("| `seed` |", "| `random_seed` |")),
        (
            "a wrong default",
            chapter.replace(&samples, &samples.replace("`100000`", "`10000`")),
        ),
        (
            "a value that is not one",
            chapter.replace(&medium, &medium.replace("`\"smooth\"`", "`\"smoothed\"`")),
        ),
        (
            "a range too wide",
            chapter.replace(&albedo, &albedo.replace("`[0, 1]`", "`[0, 2]`")),
        ),
        (
            "an open end closed",
            chapter.replace(&roulette, &roulette.replace("`(0, 1]`", "`[0, 1]`")),
        ),
    ] {
        assert_ne!(drifted, chapter, "{what}: the copy did not drift");
        let drift = reference_drift(&drifted);
        assert!(!drift.is_empty(), "{what}: not caught");
    }
}

// The outputs chapter

/// OpenEXR's own attributes, which every file has.
const EXR_STANDARD: [&str; 8] = [
    "channels",
    "compression",
    "dataWindow",
    "displayWindow",
    "lineOrder",
    "pixelAspectRatio",
    "screenWindowCenter",
    "screenWindowWidth",
];

/// A channel's name with its wavelength and albedo as the chapter writes
/// them: `540nm_a030.I` → `<λ>nm_a<albedo×100>.I`.
fn channel_pattern(name: &str) -> String {
    let digits = name
        .find("nm")
        .filter(|&i| i > 0 && name[..i].chars().all(|c| c.is_ascii_digit() || c == 'p'));
    let Some(i) = digits else { return name.to_string() };
    let rest = &name[i + 2..];
    match rest.strip_prefix("_a") {
        Some(a) if a.len() > 3 && a[..3].chars().all(|c| c.is_ascii_digit()) => {
            format!("<λ>nm_a<albedo×100>{}", &a[3..])
        }
        _ => format!("<λ>nm{rest}"),
    }
}

/// What a file holds, by name: a CSV's columns, `task.toml`'s keys, an
/// EXR's channels (as patterns) and attributes; nothing for a PNG.
fn contents(path: &Path) -> BTreeSet<String> {
    let name = path.file_name().unwrap().to_string_lossy();
    let text = || std::fs::read_to_string(path).unwrap();
    if name.ends_with(".csv") {
        text().lines().next().unwrap().split(',').map(String::from).collect()
    } else if name.ends_with(".toml") {
        text()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .filter_map(|l| l.split_once(" = ").map(|(k, _)| k.trim().to_string()))
            .collect()
    } else if name.ends_with(".exr") {
        let exr = atmosim::io::exr::read_exr(path).unwrap();
        let channels = exr.channels.iter().map(|c| channel_pattern(&c.name));
        let attributes = exr
            .attributes
            .iter()
            .map(|(k, _)| k.clone())
            .filter(|k| !EXR_STANDARD.contains(&k.as_str()));
        channels.chain(attributes).collect()
    } else {
        BTreeSet::new()
    }
}

/// Every kind of output, rendered small: per file name, the union of
/// what it held over the renders.
fn written() -> &'static BTreeMap<String, BTreeSet<String>> {
    static WRITTEN: OnceLock<BTreeMap<String, BTreeSet<String>>> = OnceLock::new();
    WRITTEN.get_or_init(|| {
        let one = "[spectrum]\nwavelengths_nm = [550.0]\n";
        let two = "[spectrum]\nwavelengths_nm = [450.0, 550.0]\n";
        let sun = "[sun]\nangular_radius_deg = 0.2666\n[output]\nsun = true\n";
        let directions = "[sensor]\nview_zenith_deg = [0.0]\nazimuth_deg = [0.0]\n";
        let image = "[sensor]\ntype = \"fisheye\"\nresolution = 4\n";
        let target = "[render]\nnoise_target = 0.3\npilot_samples = 4\n";
        let jobs = [
            ("render", format!("{one}{sun}{directions}{target}")),
            ("render", format!("{one}{directions}[render]\nsamples = 2\n")),
            ("render", format!("{one}{sun}{image}[render]\nsamples = 2\n")),
            ("render", format!("{two}{image}{target}")),
            ("render", format!("{two}{image}{target}shared_wavelengths = false\n")),
            (
                "transmittance",
                format!(
                    "{one}[transmittance]\naltitude_nodes = 2\ndistance_nodes = 2\nsamples = 2\nexport_sqrt = true\n"
                ),
            ),
        ];
        let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (command, job) in jobs {
            let dir = common::run_job(&job, &[command, "job.toml", "--out", "o", "-q"]);
            for file in common::files_under(&dir.path().join("o")) {
                let name = file.file_name().unwrap().to_string_lossy().to_string();
                out.entry(name).or_default().extend(contents(&file));
            }
        }
        out
    })
}

/// What of the outputs chapter disagrees with what was `written`.
fn outputs_drift(chapter: &str, written: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let mut documented: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (heading, body) in markdown::sections(chapter, 3) {
        let spans = markdown::cell_code(&heading);
        let [file] = spans.as_slice() else { continue };
        let names = markdown::table_rows(&body)
            .into_iter()
            .filter_map(|(_, cells)| markdown::cell_code(&cells[0]).first().cloned())
            .collect();
        documented.insert(file.clone(), names);
    }
    let mut drift = Vec::new();
    for (file, names) in written {
        let Some(listed) = documented.get(file) else {
            drift.push(format!("{file}: written, not in the chapter"));
            continue;
        };
        for n in names.difference(listed) {
            drift.push(format!("{file}: `{n}` written, not in the chapter"));
        }
        for n in listed.difference(names) {
            drift.push(format!("{file}: `{n}` in the chapter, not written"));
        }
    }
    for file in documented.keys().filter(|f| !written.contains_key(*f)) {
        drift.push(format!("{file}: in the chapter, not written"));
    }
    drift
}

#[test]
fn the_outputs_chapter_names_what_is_written() {
    let written = written();
    for file in [
        "task.toml",
        "radiance.csv",
        "fluxes.csv",
        "noise.csv",
        "sun.csv",
        "image.exr",
        "transmittance.exr",
    ] {
        assert!(written.contains_key(file), "no {file} among {:?}", written.keys());
    }
    let drift = outputs_drift(&markdown::read("docs/outputs.md"), written);
    assert!(drift.is_empty(), "docs/outputs.md:\n{}", drift.join("\n"));
}

#[test]
fn a_drifted_outputs_chapter_is_caught() {
    let chapter = markdown::read("docs/outputs.md");
    let written = written();
    assert!(outputs_drift(&chapter, written).is_empty());
    for (what, drifted) in [
        (
            "a task.toml key left out",
            chapter.replace("| `paths` | Paths traced (the pilot's included). |\n", ""),
        ),
        (
            "a column that is not written",
            chapter.replace(
                "| `V_se` | Of V. |\n",
                "| `V_se` | Of V. |\n| `W` | A fifth Stokes parameter. |\n",
            ),
        ),
        (
            "an attribute renamed",
            chapter.replace("| `seed` | The seed. |", "| `random_seed` | The seed. |"),
        ),
        (
            "a file renamed",
            chapter.replace("### `dolp.png`", "### `polarisation.png`"),
        ),
    ] {
        assert_ne!(drifted, chapter, "{what}: the copy did not drift");
        assert!(!outputs_drift(&drifted, written).is_empty(), "{what}: not caught");
    }
}

// Paths named in the book

/// Chapters written on another branch at the time of writing, named by the
/// book before they arrive (none now).
const OWNED_ELSEWHERE: [&str; 0] = [];

/// The repository paths in the book's code spans (those starting with a
/// top-level folder of the repository or naming a top-level file) that do
/// not exist. Output paths (`out/…`) and placeholders (`<…>`, `…`, `*`)
/// are not repository paths.
fn missing_paths(files: &[(String, String)]) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tops = [
        "src/",
        "tests/",
        "examples/",
        "scripts/",
        "docs/",
        "validation/",
        "atmospheres/",
        "spectra/",
        ".ci/",
        "python/",
    ];
    let mut missing = Vec::new();
    for (file, text) in files {
        for (line, span) in markdown::inline_code(text) {
            for word in span.split_whitespace() {
                let path = word.trim_end_matches([',', '.', ':', ';', ')']).trim_start_matches('(');
                let repo = tops.iter().any(|t| path.starts_with(t))
                    || [
                        "README.md",
                        "CONVENTIONS.md",
                        "Cargo.toml",
                        "LICENSE-MIT",
                        "LICENSE-APACHE",
                    ]
                    .contains(&path);
                if !repo
                    || path.contains(['<', '…', '*', '{'])
                    || path.ends_with("...")
                    || OWNED_ELSEWHERE.contains(&path)
                {
                    continue;
                }
                // A path with a `::` item or a line suffix names the file.
                let path = path.split("::").next().unwrap().split(':').next().unwrap();
                if !root.join(path).exists() {
                    missing.push(format!("{file}:{line}: `{path}`"));
                }
            }
        }
    }
    missing
}

#[test]
fn every_repository_path_the_book_names_exists() {
    let files: Vec<(String, String)> = markdown::doc_files()
        .into_iter()
        .map(|f| {
            let text = markdown::read(&f);
            (f, text)
        })
        .collect();
    let missing = missing_paths(&files);
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

#[test]
fn a_stale_path_is_caught() {
    let text = "See `src/io/srgb.rs` and `tests/docs.rs`.\n".to_string();
    assert!(missing_paths(&[("t".into(), text.clone())]).is_empty());
    let drifted = text.replace("src/io/srgb.rs", "src/io/colour.rs");
    assert_eq!(missing_paths(&[("t".into(), drifted)]).len(), 1);
}

// The fit's settings

/// What of the fit-settings table in `chapter` (docs/sky-models.md)
/// disagrees with the settings' schema: its keys, defaults and ranges.
fn fit_reference_drift(chapter: &str) -> Vec<String> {
    let parse = |text: &str| FitSettings::parse(text, "probe.toml").map_err(|e| e.to_string());
    let keys: BTreeSet<String> = expected_names(&parse(&format!("{PROBE} = 1\n")).unwrap_err(), "field")
        .expect("the fit's keys")
        .into_iter()
        .collect();
    let rows: Vec<(usize, Vec<String>)> = markdown::table_rows(chapter)
        .into_iter()
        .filter(|(_, cells)| cells.len() == 4 && cells[0] != "key")
        .collect();
    let documented: BTreeSet<String> = rows
        .iter()
        .filter_map(|(_, cells)| markdown::cell_code(&cells[0]).first().cloned())
        .collect();
    let mut drift = Vec::new();
    for k in keys.difference(&documented) {
        drift.push(format!("fit key {k}: in the schema, not in the chapter"));
    }
    for k in documented.difference(&keys) {
        drift.push(format!("fit key {k}: in the chapter, not in the schema"));
    }
    let base = "renders = \"r\"\nout = \"o.dat\"\n";
    let with = |key: &str, v: &str| format!("{}{key} = {v}\n", base.replace(&format!("{key} = "), "# "));
    for (line, cells) in &rows {
        let Some(key) = markdown::cell_code(&cells[0]).first().cloned() else {
            continue;
        };
        let at = format!("docs line {line}: fit key {key}");
        let default = markdown::cell_code(&cells[1]);
        if default.len() == 1 && cells[1] == format!("`{}`", default[0]) {
            match (parse(base), parse(&with(&key, &default[0]))) {
                (Ok(a), Ok(b)) if a == b => {}
                (a, b) => drift.push(format!("{at}: default {}: {a:?} / {b:?}", default[0])),
            }
        }
        for span in markdown::cell_code(&cells[2]) {
            if (span == "true" || span == "false")
                && let Err(e) = parse(&with(&key, &span))
            {
                drift.push(format!("{at}: {span} refused: {e}"));
            }
            let Some(iv) = interval(&span) else { continue };
            let whole = !cells[1].contains('.');
            let step = |b: f64| if whole { 1.0 } else { 1e-6 * b.abs().max(1.0) };
            let value = |x: f64| {
                if whole {
                    format!("{}", x.round() as i64)
                } else {
                    format!("{x:?}")
                }
            };
            let mut probes = Vec::new();
            for (bound, below) in [(iv.lo, true), (iv.hi, false)] {
                let Some((b, closed)) = bound else { continue };
                let out = if below { b - step(b) } else { b + step(b) };
                let inside = if below { b + step(b) } else { b - step(b) };
                probes.push((if closed { b } else { inside }, true));
                probes.push((if closed { out } else { b }, false));
            }
            for (x, accepted) in probes {
                match (parse(&with(&key, &value(x))), accepted) {
                    (Ok(_), true) => {}
                    (Err(e), false) if e.contains(&key) => {}
                    (r, _) => drift.push(format!(
                        "{at}: {} {}: {r:?}",
                        value(x),
                        if accepted { "inside" } else { "beyond" }
                    )),
                }
            }
        }
    }
    drift
}

#[test]
fn the_fit_settings_table_is_the_fits_schema() {
    let drift = fit_reference_drift(&markdown::read("docs/sky-models.md"));
    assert!(drift.is_empty(), "docs/sky-models.md:\n{}", drift.join("\n"));
}

#[test]
fn a_drifted_fit_settings_table_is_caught() {
    let chapter = markdown::read("docs/sky-models.md");
    assert!(fit_reference_drift(&chapter).is_empty());
    for (what, drifted) in [
        (
            "a key left out",
            chapter.replace("| `emph_breaks` |", "| emph_breaks |"),
        ),
        (
            "a wrong default",
            chapter.replace("| `rank` | `9` |", "| `rank` | `8` |"),
        ),
        ("a range too wide", chapter.replace("`[0, 20]`", "`[0, 30]`")),
    ] {
        assert_ne!(drifted, chapter, "{what}: the copy did not drift");
        assert!(!fit_reference_drift(&drifted).is_empty(), "{what}: not caught");
    }
}

// Links between the book's pages

/// A heading's anchor as GitHub makes it: lower case, spaces to hyphens,
/// punctuation dropped (letters, digits, `-` and `_` kept).
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            '-' | '_' => Some(c),
            c if c.is_alphanumeric() => Some(c),
            _ => None,
        })
        .flat_map(char::to_lowercase)
        .collect()
}

/// The anchors of a Markdown text's headings.
fn anchors(text: &str) -> BTreeSet<String> {
    markdown::prose_lines(text)
        .into_iter()
        .filter_map(|(_, l)| {
            let hashes = l.chars().take_while(|&c| c == '#').count();
            (hashes > 0 && l[hashes..].starts_with(' ')).then(|| anchor(&l[hashes..]))
        })
        .collect()
}

/// The relative links of `files` (path, text) whose target file or
/// heading does not exist; `read` gives the text of a linked file.
fn broken_links(files: &[(String, String)], read: &dyn Fn(&str) -> Option<String>) -> Vec<String> {
    let mut broken = Vec::new();
    for (file, text) in files {
        let dir = Path::new(file).parent().unwrap_or(Path::new(""));
        for (line, l) in markdown::prose_lines(text) {
            let mut rest = l.as_str();
            while let Some(k) = rest.find("](") {
                let after = &rest[k + 2..];
                let Some(end) = after.find(')') else { break };
                let target = &after[..end];
                rest = &after[end..];
                if target.contains("://") || target.starts_with("mailto:") || target.is_empty() {
                    continue;
                }
                let (path, fragment) = target.split_once('#').unwrap_or((target, ""));
                let resolved = if path.is_empty() {
                    file.clone()
                } else {
                    normalise(&dir.join(path))
                };
                if OWNED_ELSEWHERE.contains(&resolved.as_str()) {
                    continue;
                }
                let Some(linked) = read(&resolved) else {
                    broken.push(format!("{file}:{line}: {target}: no file {resolved}"));
                    continue;
                };
                if !fragment.is_empty() && resolved.ends_with(".md") && !anchors(&linked).contains(fragment) {
                    broken.push(format!("{file}:{line}: {target}: no heading #{fragment} in {resolved}"));
                }
            }
        }
    }
    broken
}

/// `a/b/../c` → `a/c`, as a repository path.
fn normalise(path: &Path) -> String {
    let mut parts: Vec<String> = Vec::new();
    for c in path.components() {
        match c {
            std::path::Component::ParentDir => {
                parts.pop();
            }
            std::path::Component::Normal(p) => parts.push(p.to_string_lossy().to_string()),
            _ => {}
        }
    }
    parts.join("/")
}

fn read_repository_file(rel: &str) -> Option<String> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    if p.is_dir() {
        return Some(String::new());
    }
    std::fs::read(&p).ok().map(|b| String::from_utf8_lossy(&b).into_owned())
}

#[test]
fn every_link_in_the_book_arrives() {
    let files: Vec<(String, String)> = markdown::doc_files()
        .into_iter()
        .map(|f| {
            let text = markdown::read(&f);
            (f, text)
        })
        .collect();
    let links: usize = files.iter().map(|(_, t)| t.matches("](").count()).sum();
    assert!(links > 100, "{links} links");
    let broken = broken_links(&files, &read_repository_file);
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

#[test]
fn a_broken_link_is_caught() {
    let page = |text: &str| vec![("docs/a.md".to_string(), text.to_string())];
    let read = |p: &str| match p {
        "docs/b.md" => Some("# B\n\n## The planet's shadow\n".to_string()),
        _ => None,
    };
    assert!(broken_links(&page("See [b](b.md#the-planets-shadow).\n"), &read).is_empty());
    assert_eq!(broken_links(&page("See [b](c.md).\n"), &read).len(), 1);
    assert_eq!(
        broken_links(&page("See [b](b.md#the-planet-shadow).\n"), &read).len(),
        1
    );
}
