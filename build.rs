//! Build script: `ATMOSIM_SLURM=required` at build time turns on the
//! `atmosim_slurm` cfg, under which the end-to-end SLURM test runs; without
//! it that test is compiled as ignored, so `cargo test` reports it as
//! ignored, never as passed (`.ci/run` starts a cluster and sets it).

fn main() {
    println!("cargo::rustc-check-cfg=cfg(atmosim_slurm)");
    println!("cargo::rerun-if-env-changed=ATMOSIM_SLURM");
    println!("cargo::rerun-if-changed=build.rs");
    if std::env::var("ATMOSIM_SLURM").is_ok_and(|v| v == "required") {
        println!("cargo::rustc-cfg=atmosim_slurm");
    }
}
