//! Lists the sources that generated crates vendor, so that a file added to either crate is
//! vendored without a hand-kept list: the numeric runtime (`crates/hamel-runtime/src/*.rs`,
//! into every generated crate) and the integrators (`crates/hamel-sim/src/*.rs`, with
//! `with_simulator`), both under `vendor/` in the generated crate.
//! `$OUT_DIR/{runtime,sim}_sources.rs` are `&[(path inside the crate, text)]` of `include_str!`s.

use std::fmt::Write;
use std::path::Path;

fn main() {
    list("hamel-runtime", "runtime_sources.rs");
    list("hamel-sim", "sim_sources.rs");
}

fn list(krate: &str, target: &str) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(krate)
        .join("src");
    println!("cargo::rerun-if-changed={}", dir.display());
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{} is readable: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect();
    files.sort();
    let mut out = String::from("&[\n");
    for f in &files {
        let name = f.file_name().expect("a file").to_string_lossy();
        let path = f.canonicalize().expect("an existing file");
        writeln!(
            out,
            "    (\"vendor/{krate}/src/{name}\", include_str!({path:?})),"
        )
        .expect("a String");
    }
    out.push_str("]\n");
    let target = Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join(target);
    std::fs::write(target, out).expect("OUT_DIR is writable");
}
