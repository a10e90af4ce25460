//! `atmosim validate`: runs validation cases against external references
//! and writes a report; fails (exit 1) when a case fails.

use std::path::PathBuf;

use atmosim::compat::validate;
use atmosim::run::out_dir::Destination;

use super::common::{no_samples, print_text, thread_pool};

#[derive(clap::Args)]
pub struct ValidateArgs {
    /// Cases to run (see --list).
    cases: Vec<String>,
    /// Run every case.
    #[arg(long)]
    all: bool,
    /// List the cases and stop.
    #[arg(long)]
    list: bool,
    /// Paths per direction for every case (default: each case's own, sized for CI).
    #[arg(long)]
    samples: Option<u64>,
    /// Directory for report.md and the plots.
    #[arg(long, default_value = "validation-report")]
    out: PathBuf,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
}

/// Runs the validation cases; Err (exit 1) when one fails.
pub fn run(args: ValidateArgs) -> anyhow::Result<()> {
    if args.list {
        for c in validate::cases() {
            let kind = if c.informational { " (informational)" } else { "" };
            print_text(&format!("{:<24} {}{kind}\n", c.name, c.title))?;
        }
        return Ok(());
    }
    let cases = if args.all {
        validate::cases()
    } else if args.cases.is_empty() {
        anyhow::bail!(atmosim::Error::InvalidValue {
            file: "command line".into(),
            key: "CASE".into(),
            value: "(none)".into(),
            reason: "no case named".into(),
            valid: "one or more case names (atmosim validate --list) or --all".into(),
        });
    } else {
        args.cases
            .iter()
            .map(|name| {
                validate::find(name).ok_or_else(|| atmosim::Error::InvalidValue {
                    file: "command line".into(),
                    key: "CASE".into(),
                    value: name.clone(),
                    reason: "unknown case".into(),
                    valid: validate::cases().iter().map(|c| c.name).collect::<Vec<_>>().join(", "),
                })
            })
            .collect::<Result<Vec<_>, _>>()?
    };
    if args.samples == Some(0) {
        anyhow::bail!(no_samples());
    }
    Destination {
        dir: args.out.clone(),
        file: "command line".into(),
        key: "--out".into(),
    }
    .check_writable()?;
    let pool = thread_pool(args.threads)?;
    let mut results = Vec::with_capacity(cases.len());
    for case in &cases {
        let r = pool.install(|| validate::run(case, args.samples))?;
        print_text(&format!("{}\n", validate::summary(&r)))?;
        results.push(r);
    }
    validate::write_report(&args.out, &results)?;
    print_text(&format!("\n{}\n", validate::TABLE_HEADER))?;
    for r in &results {
        print_text(&format!("{}\n", validate::report_row(r)))?;
    }
    print_text(&format!("wrote {}\n", args.out.join("report.md").display()))?;
    let failed: Vec<&str> = results
        .iter()
        .filter(|r| r.verdict == validate::Verdict::Fail)
        .map(|r| r.case.name)
        .collect();
    if failed.is_empty() {
        Ok(())
    } else {
        anyhow::bail!("{} validation case(s) failed: {}", failed.len(), failed.join(", "))
    }
}
