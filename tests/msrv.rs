//! The `rust-version` of Cargo.toml is a promise: atmosim builds with that
//! compiler. This test checks what can be checked without that compiler:
//! every dependency declares no newer one, the language features the code
//! uses (let chains, Rust 1.88) are no newer, and the compiler running the
//! tests is no older. (Newer standard-library APIs are caught by clippy's
//! `incompatible_msrv` lint, which reads the same key.)

use std::path::Path;
use std::process::Command;

/// "1.88" or "1.88.0" as (major, minor).
fn version(text: &str) -> (u32, u32) {
    let mut parts = text
        .trim()
        .split('.')
        .map(|p| p.parse::<u32>().unwrap_or_else(|_| panic!("{text}")));
    (parts.next().unwrap(), parts.next().unwrap_or(0))
}

fn declared() -> (u32, u32) {
    let manifest = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml")).unwrap();
    let line = manifest
        .lines()
        .find_map(|l| l.strip_prefix("rust-version = "))
        .expect("Cargo.toml declares rust-version");
    version(line.trim_matches('"'))
}

#[test]
fn no_dependency_needs_a_newer_compiler() {
    let ours = declared();
    let out = Command::new(env!("CARGO"))
        .args(["metadata", "--format-version", "1", "--locked", "--manifest-path"])
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    // Each package object has "name", …, "rust_version": "x.y" or null.
    let mut checked = 0;
    for chunk in text.split("\"rust_version\":").skip(1) {
        let value = chunk.trim_start();
        if let Some(rest) = value.strip_prefix('"') {
            let v = &rest[..rest.find('"').unwrap()];
            assert!(
                version(v) <= ours,
                "a dependency needs Rust {v}, Cargo.toml promises {ours:?}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 10, "only {checked} rust_version fields found");
}

#[test]
fn the_code_needs_no_newer_compiler_than_declared_and_the_running_one_is_not_older() {
    let ours = declared();
    // let chains (`if let … && let …`, `&& let` in conditions): Rust 1.88.
    let mut uses_let_chains = false;
    let mut dirs = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join("src")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                uses_let_chains |= std::fs::read_to_string(&p).unwrap().contains("&& let ");
            }
        }
    }
    if uses_let_chains {
        assert!(ours >= (1, 88), "let chains need Rust 1.88, Cargo.toml says {ours:?}");
    }
    assert!(ours >= (1, 85), "edition 2024 needs Rust 1.85");
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let out = Command::new(rustc).arg("--version").output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let running = version(text.split_whitespace().nth(1).unwrap().split('-').next().unwrap());
    assert!(running >= ours, "{text} is older than the declared {ours:?}");
}
