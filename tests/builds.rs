//! The builds a user makes share one compiled Symbolica (about 10 minutes on 2 cores): the main
//! binary's (`cargo run --release`, README's main job), the test suite's (`cargo test --release
//! --workspace`) and the Python package's (maturin builds `hamel-python` alone). cargo compiles
//! a dependency once per set of features, and the features of a dependency are those the
//! crates of one build ask for: a dev-dependency or a crate present in one build only (clap,
//! proptest, nix) may turn on a feature the others lack, and then everything above that
//! dependency is compiled again, Symbolica included. hamel-cas (target side) and hamel-codegen
//! (host side: build scripts and proc-macros) ask for those features themselves; this test
//! says which are missing when a new dependency changes them. The fuzz crate, a workspace of
//! its own, keeps a lock file that must follow those dependencies too.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// Each package (`name vVERSION`) of `cargo tree ARGS` with the feature sets it is built with.
fn features(args: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "--offline",
            "--locked",
            "-e",
            "features",
            "--prefix",
            "none",
        ])
        .args(["--format", "{p}|{f}"])
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "cargo tree {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut map: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8(out.stdout).unwrap().lines() {
        let Some((package, features)) = line.split_once('|') else {
            continue; // a feature node of the tree, not a package
        };
        // "name vX.Y.Z (path)" for a workspace crate, "(*)" for one printed before
        let package: Vec<&str> = package.split_whitespace().take(2).collect();
        let features = features.trim_end_matches(" (*)").trim().to_string();
        map.entry(package.join(" ")).or_default().insert(features);
    }
    map
}

/// The packages whose features in the build of `args` are not among the test build's.
fn not_shared(args: &[&str]) -> Vec<String> {
    let all = features(&["--workspace", "-e", "all"]);
    let one = features(args);
    one.iter()
        .filter(|(p, f)| all.get(*p).is_some_and(|a| !f.is_subset(a)))
        .map(|(p, f)| format!("{p}: {f:?}, the test build: {:?}", all[p]))
        .collect()
}

#[test]
fn the_main_job_and_the_python_package_build_what_the_tests_build() {
    for package in ["hamel", "hamel-python"] {
        let differ = not_shared(&["-p", package, "-e", "normal,build"]);
        assert!(
            differ.is_empty(),
            "{package} is built with other features than the test build's, so that a build of \
             it compiles Symbolica again: ask for them in hamel-cas's Cargo.toml (or, for \
             build scripts and proc-macros, hamel-codegen's [build-dependencies]):\n{}",
            differ.join("\n")
        );
    }
}

/// The fuzz crate (fuzz/, its own workspace, built by `.ci/fuzz` with `--locked`) has a lock
/// file of its own: a dependency added to a hamel crate it links must be written there too
/// (`cd fuzz && cargo metadata --format-version 1 >/dev/null`), or CI's fuzz run stops before
/// it starts. Resolved offline; when the registry cache lacks a fuzz-only crate (libfuzzer-sys
/// on a machine that never fuzzed), the test says so and passes.
#[test]
fn the_fuzz_lock_file_is_up_to_date() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let out = Command::new(env!("CARGO"))
        .args(["metadata", "--offline", "--locked", "--format-version", "1"])
        .current_dir(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("cannot update the lock file"),
        "fuzz/Cargo.lock is out of date: run `cargo metadata --format-version 1` in fuzz/ and \
         commit fuzz/Cargo.lock:\n{err}"
    );
    if !out.status.success() {
        eprintln!("skipped: cargo metadata --offline in fuzz/ could not resolve: {err}");
    }
}
