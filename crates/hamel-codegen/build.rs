//! Lists the integrators' sources (`crates/hamel-sim/src/*.rs`) that `with_simulator` vendors
//! into a generated crate, so that a file added to hamel-sim is vendored without a hand-kept
//! list: `$OUT_DIR/sim_sources.rs` is a `&[(path inside the crate, text)]` of `include_str!`s.

use std::fmt::Write;
use std::path::Path;

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../hamel-sim/src");
    println!("cargo::rerun-if-changed={}", dir.display());
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("crates/hamel-sim/src is readable")
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
            "    (\"hamel-sim/src/{name}\", include_str!({path:?})),"
        )
        .expect("a String");
    }
    out.push_str("]\n");
    let target =
        Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("sim_sources.rs");
    std::fs::write(target, out).expect("OUT_DIR is writable");
}
