//! `atmosim validate`: the transport and the atmosphere against external
//! references, one case per reference table (the project's copies in
//! `validation/`, embedded at compile time so the command runs anywhere).
//!
//! Each case renders the directions of its reference with fixed seeds and
//! reports the seed's statistics (`stats`): mean and median ratio
//! atmosim/reference, mean, median and largest absolute relative
//! difference, Pearson correlation over the intensities, and the largest
//! |z|, z = (atmosim − reference)/combined standard error, against the
//! Šidák threshold for a 1 % family-wise false alarm. A case passes when no
//! |z| exceeds it; informational cases (a reference computed with physics
//! atmosim does not have) report without a verdict.

use std::path::Path;

use crate::error::Result;

mod case;
mod cases;
mod gases;
pub(crate) mod libradtran;
pub mod plot;
pub mod stats;

pub use case::{Case, CaseResult, Verdict};
pub use cases::iprt_b;
pub use stats::{GroupRatio, Statistics, Value, statistics};

/// Every case, in report order.
pub fn cases() -> Vec<Case> {
    let mut all = cases::published();
    all.extend(libradtran::cases());
    all.extend(gases::cases());
    all
}

/// The case named `name`.
pub fn find(name: &str) -> Option<Case> {
    cases().into_iter().find(|c| c.name == name)
}

/// Runs a case with `samples` paths per direction (its default if `None`),
/// in the current rayon pool.
pub fn run(case: &Case, samples: Option<u64>) -> Result<CaseResult> {
    let samples = samples.unwrap_or(case.default_samples);
    let start = std::time::Instant::now();
    let values = (case.run)(samples)?;
    let stats = statistics(&values);
    let ratios_pass = case
        .ratio_limit
        .is_none_or(|limit| stats.group_ratios.iter().all(|g| (g.ratio - 1.0).abs() <= limit));
    let verdict = if case.informational {
        Verdict::Informational
    } else if stats.passes() && ratios_pass {
        Verdict::Pass
    } else {
        Verdict::Fail
    };
    Ok(CaseResult {
        case: *case,
        samples,
        values,
        stats,
        verdict,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The case's line of the summary table (markdown).
pub fn report_row(r: &CaseResult) -> String {
    let s = &r.stats;
    format!(
        "| {} | {} | {} | {:.5} | {:.5} | {:.2e} | {:.2e} | {:.2e} | {:.6} | {:.2} | {:.2} | {:.0} % | {} |",
        r.case.name,
        r.samples,
        s.values,
        s.mean_ratio,
        s.median_ratio,
        s.mean_abs_rel_diff,
        s.median_abs_rel_diff,
        s.max_abs_rel_diff,
        s.correlation,
        s.max_abs_z,
        s.threshold,
        100.0 * s.within_one_sigma,
        r.verdict.label()
    )
}

/// Header of the summary table.
pub const TABLE_HEADER: &str = "| case | paths/dir | values | mean ratio | median ratio | mean abs rel diff | median abs rel diff | max abs rel diff | correlation | max abs z | Šidák threshold | abs z < 1 | verdict |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|";

/// The groups' inverse-variance mean ratios, and the case's limit on them.
fn group_ratio_line(r: &CaseResult) -> String {
    let groups: Vec<String> = r.stats.group_ratios.iter().map(GroupRatio::describe).collect();
    let limit = match r.case.ratio_limit {
        Some(l) => format!(" (limit 1 ± {l})"),
        None => String::new(),
    };
    format!("inverse-variance mean ratio{limit}: {}", groups.join("; "))
}

/// The text printed per case on the terminal.
pub fn summary(r: &CaseResult) -> String {
    let s = &r.stats;
    format!(
        "{name}: {verdict} ({secs:.1} s, {samples} paths per direction)\n  {values} values ({intens} intensities): \
         mean ratio {mr:.5}, median ratio {mdr:.5}; |rel diff| mean {ma:.2e}, median {md:.2e}, max {mx:.2e}; \
         correlation {c:.6}\n  {groups}\n  max |z| {z:.2} (Šidák threshold {t:.2}), {w:.0} % within 1σ; worst: {worst}",
        groups = group_ratio_line(r),
        name = r.case.name,
        verdict = r.verdict.label(),
        secs = r.seconds,
        samples = r.samples,
        values = s.values,
        intens = s.intensities,
        mr = s.mean_ratio,
        mdr = s.median_ratio,
        ma = s.mean_abs_rel_diff,
        md = s.median_abs_rel_diff,
        mx = s.max_abs_rel_diff,
        c = s.correlation,
        z = s.max_abs_z,
        t = s.threshold,
        w = 100.0 * s.within_one_sigma,
        worst = s.worst
    )
}

/// The markdown report of a set of results: the summary table, then per
/// case its reference, set-up, accuracy floor, worst value and plot.
pub fn report_markdown(results: &[CaseResult]) -> String {
    let mut s = String::from("# atmosim validation report\n\n");
    s.push_str(&format!(
        "atmosim {}. Ratios, relative differences and the correlation are over the intensities (I) the \
         statistics include; z = (atmosim − reference)/√(se² + se_ref² + floor²) over every compared Stokes \
         component; a case passes when no |z| exceeds the Šidák threshold for a 1 % family-wise false alarm \
         over its values. `info` cases are reported without a verdict.\n\n",
        env!("CARGO_PKG_VERSION")
    ));
    s.push_str(TABLE_HEADER);
    s.push('\n');
    for r in results {
        s.push_str(&report_row(r));
        s.push('\n');
    }
    for r in results {
        let c = &r.case;
        s.push_str(&format!(
            "\n## {} — {}\n\n- Reference: {}\n- atmosim: {}\n- Accuracy floor: {}\n- Per group, {}\n- Worst value: {}\n- Time: {:.1} s\n\n![{}]({}.png)\n",
            c.name,
            c.title,
            c.reference,
            c.setup,
            c.floor,
            group_ratio_line(r),
            r.stats.worst,
            r.seconds,
            c.name,
            c.name
        ));
    }
    s
}

/// Writes `report.md` and one `<case>.png` per result into `dir`.
pub fn write_report(dir: &Path, results: &[CaseResult]) -> Result<()> {
    for r in results {
        plot::write_ratio_plot(&dir.join(format!("{}.png", r.case.name)), r)?;
    }
    crate::io::atomic::write_atomic(&dir.join("report.md"), report_markdown(results).as_bytes())
}
