//! Compiled scene cores, cached: what `hamel simulate` runs.
//!
//! **Job**: for a scene's plan, the code generator's crate for exactly that computation — the
//! scene's parameters substituted as exact values before generation ([`Derivation::specialise`]:
//! constants folded, zero terms removed), the dropped coordinates eliminated, the `scene`
//! binary of [`hamel_codegen::SCENE_BIN`] — built once with cargo and kept in a cache, so a
//! second run of the same scene neither regenerates nor recompiles.
//!
//! **Inputs**: the model (its text is part of the key), the quasi-velocity choice, the dropped
//! coordinates, the fixed parameter values; the derivation for code, on a miss only.
//! **Outputs**: a cache [`Entry`] (the crate, its operation counts in `meta.json`, the built
//! binary) and [`run`], which hands the binary one integration job and reads its solution.
//!
//! The cache lives in `$HAMEL_CACHE`, else `$XDG_CACHE_HOME/hamel`, else `~/.cache/hamel`;
//! one directory per key (named by its 64-bit FNV-1a hash, the key's full text in
//! `meta.json` decides), and one shared cargo target directory (`target/`), so the
//! dependencies (nalgebra, serde) compile once. The key holds the hamel version and the size
//! and modification time of the running `hamel` executable (a rebuilt hamel may generate other
//! code), the model file's text, the choice, the dropped coordinates and the parameter values
//! (exact f64 bits). Builds are serialised by a lock file; entries appear by rename, whole.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use hamel_codegen::Generated;
use hamel_derive::Derivation;
use hamel_sim::Solution;
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

/// The cache directory.
pub fn root() -> PathBuf {
    if let Some(d) = std::env::var_os("HAMEL_CACHE").filter(|d| !d.is_empty()) {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return PathBuf::from(d).join("hamel");
    }
    if let Some(d) = std::env::var_os("HOME").filter(|d| !d.is_empty()) {
        return PathBuf::from(d).join(".cache").join("hamel");
    }
    std::env::temp_dir().join("hamel-cache")
}

/// What identifies a scene's code.
#[derive(Clone, Debug)]
pub struct Key {
    text: String,
}

impl Key {
    /// The key of the code for `model` with choice `eta`, `dropped` eliminated and `fixed`
    /// parameters specialised.
    pub fn new(
        model_source: &str,
        eta: &str,
        dropped: &[String],
        fixed: &IndexMap<String, f64>,
    ) -> Key {
        let exe = std::env::current_exe()
            .and_then(std::fs::metadata)
            .map(|m| {
                let modified = m
                    .modified()
                    .ok()
                    .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                    .map_or(0, |d| d.as_nanos());
                format!("{} bytes, modified {modified}", m.len())
            })
            .unwrap_or_else(|_| "unknown".into());
        let params: Vec<String> = fixed
            .iter()
            .map(|(k, v)| format!("{k} = {v:?} ({:#018x})", v.to_bits()))
            .collect();
        Key {
            text: format!(
                "hamel {}; executable {exe}\nchoice: {eta}\ndropped: {}\nparameters: {}\nmodel:\n{model_source}",
                env!("CARGO_PKG_VERSION"),
                dropped.join(", "),
                params.join(", ")
            ),
        }
    }

    /// FNV-1a, 64 bits: the entry's directory name.
    fn hash(&self) -> String {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in self.text.bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        format!("{h:016x}")
    }
}

/// `meta.json` of an entry.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Meta {
    /// The key's text (an entry whose key differs is not this scene's).
    pub key: String,
    /// Operations of the planned right-hand side (shared, specialised).
    pub ops: usize,
    /// Operations of the full system's right-hand side for comparison (all coordinates, the
    /// parameters as inputs).
    pub ops_full: usize,
    /// The solved form the generator chose.
    pub path: String,
}

/// A cache entry: a generated crate, maybe built.
#[derive(Clone, Debug)]
pub struct Entry {
    /// Its directory.
    pub dir: PathBuf,
    /// Its metadata.
    pub meta: Meta,
    /// Whether it was found in the cache (else written by this run).
    pub cached: bool,
}

/// The entry for `key`, if the cache holds it.
pub fn lookup(key: &Key) -> Option<Entry> {
    let dir = root().join(key.hash());
    let meta: Meta =
        serde_json::from_str(&std::fs::read_to_string(dir.join("meta.json")).ok()?).ok()?;
    (meta.key == key.text).then_some(Entry {
        dir,
        meta,
        cached: true,
    })
}

/// Generate the crate for `key` (the scene's code: `d` specialised for `fixed`, `dropped`
/// eliminated) and store it; `ops_full` comes from the caller (the unspecialised full system).
pub fn store(
    key: &Key,
    d: &Derivation,
    fixed: &IndexMap<String, f64>,
    dropped: &[usize],
    ops_of: impl Fn(&Generated) -> Result<usize, String>,
    ops_full: usize,
    command: &str,
) -> Result<Entry, String> {
    let special = d.specialise(fixed)?;
    let generated =
        hamel_codegen::with_simulator(hamel_codegen::generate(&special, dropped, command)?);
    let meta = Meta {
        key: key.text.clone(),
        ops: ops_of(&generated)?,
        ops_full,
        path: generated.solved.name.to_string(),
    };
    let root = root();
    let dir = root.join(key.hash());
    let tmp = root.join(format!("{}.tmp{}", key.hash(), std::process::id()));
    let io = |e: std::io::Error| format!("cannot write the code cache in {}: {e}", root.display());
    let _ = std::fs::remove_dir_all(&tmp);
    // The binary is named after the entry: every entry's crate builds in the one shared target
    // directory, where a fresh (not rebuilt) binary is not copied to `release/` again.
    let bin = bin_name(&dir);
    for (path, text) in &generated.files {
        let (path, text) = match path.as_str() {
            "src/bin/scene.rs" => ("src/scene_main.rs", text.clone()),
            // So is the package: cargo hashes a workspace root's artifacts by its name and
            // version, not its path, so two entries of one model would share a library.
            "Cargo.toml" => (
                "Cargo.toml",
                text.lines()
                    .map(|l| {
                        if l.starts_with("name = ") && !l.contains("hamel_generated") {
                            format!("name = \"hamel-{bin}\"")
                        } else {
                            l.to_string()
                        }
                    })
                    .collect::<Vec<_>>()
                    .join("\n")
                    + format!("\n\n[[bin]]\nname = \"{bin}\"\npath = \"src/scene_main.rs\"\n")
                        .as_str(),
            ),
            _ => (path.as_str(), text.clone()),
        };
        let file = tmp.join(path);
        std::fs::create_dir_all(file.parent().expect("a file in the crate")).map_err(io)?;
        std::fs::write(&file, text).map_err(io)?;
    }
    std::fs::write(
        tmp.join("meta.json"),
        serde_json::to_string_pretty(&meta).expect("serialisable"),
    )
    .map_err(io)?;
    // A stale entry (another key with the same hash, or a half-built one) is replaced whole.
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::rename(&tmp, &dir).map_err(io)?;
    Ok(Entry {
        dir,
        meta,
        cached: false,
    })
}

/// The name of an entry's binary: `scene-` and its directory's name.
fn bin_name(dir: &Path) -> String {
    format!(
        "scene-{}",
        dir.file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned())
    )
}

/// The entry's `scene` binary, built with cargo (offline, release) when missing; returns the
/// path and whether this call built it.
pub fn binary(entry: &Entry) -> Result<(PathBuf, bool), String> {
    let exe = entry.dir.join("scene");
    if exe.is_file() {
        return Ok((exe, false));
    }
    let root = root();
    let io = |e: std::io::Error| format!("code cache {}: {e}", root.display());
    std::fs::create_dir_all(&root).map_err(io)?;
    // One build at a time: the shared target directory has one `release/scene`.
    let lock = std::fs::File::create(root.join("build.lock")).map_err(io)?;
    lock.lock().map_err(io)?;
    if exe.is_file() {
        return Ok((exe, false));
    }
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let target = root.join("target");
    let out = Command::new(&cargo)
        .args(["build", "--release", "--offline", "--quiet", "--bin"])
        .arg(bin_name(&entry.dir))
        .arg("--manifest-path")
        .arg(entry.dir.join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", &target)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run cargo ({}): {e}", Path::new(&cargo).display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = err.lines().rev().take(15).collect();
        return Err(format!(
            "cargo could not build the scene's core in {}:\n{}",
            entry.dir.display(),
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        ));
    }
    let tmp = entry.dir.join(format!("scene.tmp{}", std::process::id()));
    std::fs::copy(target.join("release").join(bin_name(&entry.dir)), &tmp).map_err(io)?;
    std::fs::rename(&tmp, &exe).map_err(io)?;
    Ok((exe, true))
}

/// One integration job for a core's `scene` binary (see `runtime/scene.rs`).
#[derive(Serialize)]
pub struct Job<'a> {
    pub t0: f64,
    pub times: &'a [f64],
    /// The kept coordinates in model order, then η.
    pub y0: Vec<f64>,
    pub method: hamel_sim::Method,
    pub options: hamel_sim::Options,
    pub reference: f64,
    pub energy: bool,
    pub residual: bool,
    pub repeat: usize,
    /// Parameter values other than the core's defaults (a core not specialised).
    pub params: IndexMap<String, f64>,
}

#[derive(Deserialize)]
struct Answer {
    solution: Solution,
    error: Option<String>,
    seconds: f64,
}

/// Run `job` on the binary: the solution (partial on failure), the failure, the median time
/// of one integration measured inside the binary.
pub fn run(binary: &Path, job: &Job) -> Result<(Solution, Option<String>, f64), String> {
    let mut child = Command::new(binary)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", binary.display()))?;
    child
        .stdin
        .take()
        .expect("piped")
        .write_all(serde_json::to_string(job).expect("serialisable").as_bytes())
        .map_err(|e| format!("cannot send the job to {}: {e}", binary.display()))?;
    let out = child
        .wait_with_output()
        .map_err(|e| format!("{}: {e}", binary.display()))?;
    if !out.status.success() {
        return Err(format!(
            "{} failed: {}",
            binary.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    let a: Answer = serde_json::from_slice(&out.stdout)
        .map_err(|e| format!("{}: unreadable answer: {e}", binary.display()))?;
    Ok((a.solution, a.error, a.seconds))
}
