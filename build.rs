//! Builds `prism` a second time, for baseline x86-64, and hands its path to
//! the crate as `PRISM_BASELINE_BINARY`: the main build targets x86-64-v3
//! (`.cargo/config.toml`), and on a CPU without AVX2 `prism` runs the
//! embedded baseline build instead (src/cpu.rs). One `cargo build
//! --release` makes both.
//!
//! Only release builds for x86-64 Linux (glibc) embed one. The second
//! build has a target folder of its own (`target/baseline`): its flags
//! differ, and the running build holds the lock on its own folder. It is
//! built without LTO, in 16 codegen units and incrementally, and stripped:
//! a fallback for old CPUs, quick to rebuild after a change. `PRISM_BASELINE_BUILD` marks it,
//! so that it does not build a third.

use std::env;
use std::path::PathBuf;
use std::process::Command;

fn main() {
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=Cargo.toml");
    println!("cargo:rerun-if-changed=Cargo.lock");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=PRISM_BASELINE_BUILD");
    println!("cargo:rustc-check-cfg=cfg(prism_baseline_embedded)");
    let var = |name: &str| env::var(name).unwrap_or_default();
    // glibc: it hands `.init_array` functions the arguments (src/cpu.rs).
    let wanted = var("CARGO_CFG_TARGET_ARCH") == "x86_64"
        && var("CARGO_CFG_TARGET_OS") == "linux"
        && var("CARGO_CFG_TARGET_ENV") == "gnu"
        && var("PROFILE") == "release"
        && env::var_os("PRISM_BASELINE_BUILD").is_none();
    if !wanted {
        return;
    }
    // OUT_DIR is TARGET/PROFILE/build/prism-HASH/out (or one level deeper
    // under TARGET/TRIPLE when cross compiling).
    let out = PathBuf::from(var("OUT_DIR"));
    let target_dir = out
        .ancestors()
        .find(|p| p.join("CACHEDIR.TAG").exists())
        .unwrap_or_else(|| out.ancestors().nth(4).expect("OUT_DIR is deep"))
        .join("baseline");
    let cargo = env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut build = Command::new(cargo);
    build
        .args(["build", "--release", "--offline", "--bin", "prism"])
        .arg("--target-dir")
        .arg(&target_dir)
        .args(["--target", &var("TARGET")])
        .current_dir(var("CARGO_MANIFEST_DIR"))
        // Flags of the running build that must not reach this one.
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("RUSTC_WORKSPACE_WRAPPER")
        .env("RUSTFLAGS", "-C target-cpu=x86-64")
        .env("PRISM_BASELINE_BUILD", "1")
        .env("CARGO_PROFILE_RELEASE_LTO", "false")
        .env("CARGO_PROFILE_RELEASE_CODEGEN_UNITS", "16")
        .env("CARGO_PROFILE_RELEASE_INCREMENTAL", "true")
        .env("CARGO_PROFILE_RELEASE_DEBUG", "false")
        .env("CARGO_PROFILE_RELEASE_STRIP", "true");
    let status = build.status().expect("cargo runs");
    assert!(
        status.success(),
        "the baseline x86-64 build of prism failed"
    );
    let binary = target_dir.join(var("TARGET")).join("release/prism");
    println!("cargo:rustc-env=PRISM_BASELINE_BINARY={}", binary.display());
    println!("cargo:rustc-cfg=prism_baseline_embedded");
}
