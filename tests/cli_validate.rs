//! `atmosim validate` run as CI runs it: every case at its reduced default
//! sample count must pass (a failed case exits 1), with the report and one
//! plot per case; plus listing and bad arguments.

use assert_cmd::Command;

fn atmosim() -> Command {
    Command::cargo_bin("atmosim").unwrap()
}

#[test]
fn validate_all_passes_and_writes_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = atmosim()
        .args(["validate", "--all", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}");
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    for case in atmosim::compat::validate::cases() {
        assert!(report.contains(&format!("| {} |", case.name)), "{} missing", case.name);
        let png = std::fs::read(dir.path().join(format!("{}.png", case.name))).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
    assert!(!stdout.contains("FAIL"));
}

#[test]
fn list_names_every_case() {
    let out = atmosim().args(["validate", "--list"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for name in [
        "natraj2009",
        "iprt_b2",
        "pydisort",
        "libradtran_A_polrad",
        "libradtran_H_disort_ps",
        "gas_columns",
        "gases_kato",
    ] {
        assert!(text.contains(name), "{name}");
    }
}

#[test]
fn unknown_case_exits_2() {
    let out = atmosim().args(["validate", "no_such_case"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no_such_case"));
    let out = atmosim().args(["validate"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}
