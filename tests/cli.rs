//! The `hamel` command as a user runs it.
//!
//! This test binary makes no computer-algebra calls in-process: it starts `hamel` processes,
//! one at a time (Symbolica, unlicensed, allows one instance per user at a time; the tests of
//! `cli/store.rs` run two at once on purpose, one of them needing no computer algebra). One
//! file per command under `tests/cli/`; this one holds the helpers they share and the tests
//! that concern every command (interruption, output independent of order and threads).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

#[path = "cli/animate.rs"]
mod animate;
#[path = "cli/bench.rs"]
mod bench;
#[path = "cli/cache.rs"]
mod cache;
#[path = "cli/codegen.rs"]
mod codegen;
#[path = "cli/derive.rs"]
mod derive;
#[path = "cli/ensembles.rs"]
mod ensembles;
#[path = "cli/eval.rs"]
mod eval;
#[path = "cli/latex.rs"]
mod latex;
#[path = "cli/linearize.rs"]
mod linearize;
#[path = "cli/plan.rs"]
mod plan;
#[path = "cli/search.rs"]
mod search;
#[path = "cli/simulate.rs"]
mod simulate;
#[path = "cli/smoke.rs"]
mod smoke;
#[path = "cli/store.rs"]
mod store;
#[path = "cli/tradeoff.rs"]
mod tradeoff;

#[path = "common/mod.rs"]
mod common;
use common::ELIMINATE;

static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

fn hamel(args: &[&str], stdin: Option<&str>) -> Output {
    hamel_with_cache(args, stdin, &code_cache())
}

/// [`hamel`] with `HAMEL_CACHE` set to `cache`; arguments may be paths that are not UTF-8.
fn hamel_with_cache<A: AsRef<std::ffi::OsStr>>(
    args: &[A],
    stdin: Option<&str>,
    cache: &Path,
) -> Output {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let mut cmd = hamel_command(args, cache);
    match stdin {
        None => cmd.output().unwrap(),
        Some(text) => {
            use std::io::Write;
            let mut child = cmd
                .stdin(std::process::Stdio::piped())
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap();
            child
                .stdin
                .take()
                .unwrap()
                .write_all(text.as_bytes())
                .unwrap();
            child.wait_with_output().unwrap()
        }
    }
}

/// The `hamel` command with `args`, run in the repository with `HAMEL_CACHE` = `cache`.
fn hamel_command<A: AsRef<std::ffi::OsStr>>(args: &[A], cache: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hamel"));
    cmd.args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("HAMEL_CACHE", cache)
        .env("CARGO", env!("CARGO"));
    cmd
}

/// [`hamel`] and the wall time of the command alone (not of waiting for its turn).
fn hamel_timed(args: &[&str]) -> (Output, std::time::Duration) {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let started = std::time::Instant::now();
    let out = hamel_command(args, &code_cache()).output().unwrap();
    (out, started.elapsed())
}

/// The cache of compiled scene cores the `hamel` processes of this binary share (kept between
/// runs: its entries are keyed by the hamel executable's size and time). Its cargo target
/// directory starts with the outer build's `.rustc_info.json` (see [`build_generated`]).
fn code_cache() -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("hamel-cache");
    seed_rustc_info(&dir.join("target"));
    // hamel refuses a cache others could write to, whatever the umask made it.
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).unwrap();
    dir
}

/// Copy the outer build's cache of rustc's probes into a new target directory.
fn seed_rustc_info(target: &Path) {
    let outer = Path::new(env!("CARGO_TARGET_TMPDIR")).parent().unwrap();
    std::fs::create_dir_all(target).unwrap();
    let cache = target.join(".rustc_info.json");
    if !cache.exists() {
        let _ = std::fs::copy(outer.join(".rustc_info.json"), &cache);
    }
}

/// The `.toml` files of the repository's folders `dirs` (such as `models`, `scenes`), sorted.
fn toml_files(dirs: &[&str]) -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = dirs
        .iter()
        .flat_map(|d| std::fs::read_dir(root.join(d)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

/// Make `dir` with `mode`.
fn dir_with_mode(dir: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::create_dir_all(dir).unwrap();
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(mode)).unwrap();
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `scene` simulated by the compiled engine and by the interpreted one (JSON reports written
/// into `dir`); the compiled one must really have run compiled.
fn compiled_and_interpreted(scene: &Path, dir: &Path) -> (serde_json::Value, serde_json::Value) {
    let run = |engine: &str| -> serde_json::Value {
        let out = dir.join(format!("{engine}.json"));
        let args = [
            "simulate",
            scene.to_str().unwrap(),
            "--format",
            "json",
            "--engine",
            engine,
            "--output",
            out.to_str().unwrap(),
        ];
        let o = hamel(&args, None);
        assert!(o.status.success(), "{engine}: {}", stderr(&o));
        serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap()
    };
    let (c, i) = (run("compiled"), run("interpreted"));
    assert_eq!(c["engine"], "compiled", "{}", scene.display());
    (c, i)
}

/// The coordinate `k`'s values in a simulation report.
fn series(report: &serde_json::Value, k: &str) -> Vec<f64> {
    let values = report["q"][k].as_array();
    (values
        .unwrap_or_else(|| panic!("no q.{k} in {report}"))
        .iter())
    .map(|x| x.as_f64().unwrap())
    .collect()
}

/// max_t |a(t) − b(t)| of coordinate `k` in two reports of one scene.
fn largest_difference(a: &serde_json::Value, b: &serde_json::Value, k: &str) -> f64 {
    (series(a, k).iter().zip(series(b, k)))
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The JSON document on stdout (which may follow Symbolica's notice).
fn json_on_stdout(o: &Output) -> serde_json::Value {
    let out = String::from_utf8_lossy(&o.stdout);
    let start = out.find(['{', '[']).expect("JSON on stdout");
    serde_json::from_str(&out[start..]).expect("valid JSON")
}

/// Build a generated crate offline (no CAS involved), check that its lock file names no
/// symbolica, and copy its binaries `bins` into `into`. The generated crates of the tests share
/// one target directory, so that their dependencies (nalgebra, serde) compile once.
///
/// On the machine this was developed on `/dev/null` is a regular file: build scripts that send
/// a feature probe's stderr there (E0554 "`#![feature]` may not be used on the stable release
/// channel") leave that text in it, and a cold cargo's target-information probe
/// (`rustc - --print=file-names …`, which reads its source from /dev/null) then fails on it.
/// The nested target directory therefore starts with the outer build's cache of those probes
/// (`.rustc_info.json`: same rustc, same arguments; cargo re-probes if they differ). A failure
/// fails the test, naming a broken /dev/null when that is the cause.
fn build_generated(crate_dir: &Path, bins: &[&str], into: &Path) {
    static ONE_BUILD: Mutex<()> = Mutex::new(());
    let _guard = ONE_BUILD.lock().unwrap_or_else(|e| e.into_inner());
    let target = &Path::new(env!("CARGO_TARGET_TMPDIR")).join("generated-target");
    seed_rustc_info(target);
    let build = Command::new(env!("CARGO"))
        .args(["build", "--release", "--offline", "--quiet"])
        .current_dir(crate_dir)
        .env("CARGO_TARGET_DIR", target)
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    if !build.status.success() {
        use std::os::unix::fs::FileTypeExt;
        let dev_null = std::fs::metadata("/dev/null").map(|m| m.file_type().is_char_device());
        panic!(
            "{}{}",
            if dev_null.is_ok_and(|device| !device) {
                "/dev/null is a regular file on this machine, not a device: cargo's probes read what others wrote there\n"
            } else {
                ""
            },
            stderr(&build)
        );
    }
    let lock = std::fs::read_to_string(crate_dir.join("Cargo.lock")).unwrap();
    assert!(!lock.contains("symbolica"));
    for bin in bins {
        std::fs::copy(target.join("release").join(bin), into.join(bin)).unwrap();
    }
}

/// The text of a knife scene with the given extra top-level lines (model path absolute).
fn knife_scene_text(top: &str) -> String {
    format!(
        "model = {:?}\neta = \"paper\"\nt_end = 4.0\noutputs = 9\n{top}\n\
         [initial]\nq = {{ x = 0.0, y = 0.0, theta = 0.3 }}\neta = [1.0, 0.5]\n",
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models/knife.toml")
            .display()
            .to_string()
    )
}

/// A knife scene file with the given extra top-level lines and tables.
fn knife_scene(dir: &Path, name: &str, top: &str, tables: &str) -> PathBuf {
    let scene = dir.join(name);
    std::fs::write(&scene, knife_scene_text(top) + tables).unwrap();
    scene
}

/// The model file name of the reproduction in issue 23: newlines around an item.
const INJECTING_NAME: &str = "b\nfn injected_by_filename() {}\nx.toml";

/// The top-level function names of a Rust file (which must parse).
fn functions(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let file = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    file.items
        .iter()
        .filter_map(|item| match item {
            syn::Item::Fn(f) => Some(f.sig.ident.to_string()),
            _ => None,
        })
        .collect()
}

/// Interrupted (SIGINT) while it computes, `hamel` stops with status 130 and leaves nothing
/// in the output's directory: neither the result, whole or partial, nor a temporary file
/// (writes go through `hamel_model::files`).
#[test]
fn an_interrupted_command_leaves_no_output_behind() {
    let dir = scratch("interrupted");
    let out = dir.join("study.json");
    let args = [
        "linearize",
        "models/unicycle_rider.toml",
        "--steady",
        "upright",
        "--sweep",
        "Omega=1:20:4001",
        "--format",
        "json",
        "--output",
        out.to_str().unwrap(),
    ];
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let child = hamel_command(&args, &code_cache())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    // SAFETY: kill(2) on the child's pid; no memory is involved.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let o = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// The same output byte for byte whatever ran before and however many threads run: commands
/// whose output the snapshots pin down, run in one order with one thread, then in the reverse
/// order with two; only the search's measured run time is left out. (Within one process,
/// tests/snapshots.rs checks the order in which symbols are first created: its tests run in
/// any order, on any thread.)
#[test]
fn output_is_the_same_across_orders_and_thread_counts() {
    let commands: [&[&str]; 6] = [
        &["derive", "models/unicycle_rider.toml", "--format", "json"],
        &["derive", "models/whipple_bicycle.toml", "--format", "json"],
        &[
            "reduce",
            "models/rolling_disk.toml",
            "--eliminate",
            "xC,yC,phi",
            "--format",
            "json",
        ],
        &["expand", "models/bodies/unicycle_rider_bodies.toml"],
        &[
            "linearize",
            "models/whipple_bicycle.toml",
            "--steady",
            "upright",
            "--sweep",
            "v=0:10:41",
            "--format",
            "json",
        ],
        &[
            "search",
            "models/knife.toml",
            "--eliminate",
            "x,y,theta",
            "--format",
            "json",
        ],
    ];
    let run = |order: Vec<usize>, threads: &str| -> Vec<(usize, Vec<u8>)> {
        let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
        let mut out: Vec<(usize, Vec<u8>)> = order
            .into_iter()
            .map(|i| {
                let o = hamel_command(commands[i], &code_cache())
                    .env("RAYON_NUM_THREADS", threads)
                    .output()
                    .unwrap();
                assert!(o.status.success(), "{:?}: {}", commands[i], stderr(&o));
                (i, without_timings(o.stdout))
            })
            .collect();
        out.sort();
        out
    };
    let first = run((0..commands.len()).collect(), "1");
    let second = run((0..commands.len()).rev().collect(), "2");
    for ((i, a), (_, b)) in first.iter().zip(&second) {
        assert!(!a.is_empty(), "{:?} printed nothing", commands[*i]);
        assert!(a == b, "{:?} differs between the runs", commands[*i]);
    }
}

/// The output with the measured run time (`seconds`, in a search's JSON) taken out: the one
/// field that is meant to differ between runs.
fn without_timings(out: Vec<u8>) -> Vec<u8> {
    let text = String::from_utf8(out).unwrap();
    let Some(start) = text.find('{') else {
        return text.into_bytes();
    };
    match serde_json::from_str::<serde_json::Value>(&text[start..]) {
        Ok(mut v) => {
            if let Some(o) = v.as_object_mut() {
                o.remove("seconds");
            }
            v.to_string().into_bytes()
        }
        Err(_) => text.into_bytes(),
    }
}
