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
//! dependencies (nalgebra, serde) compile once; the crates every generated crate vendors
//! (hamel-runtime, hamel-sim) are kept once too (`vendor/<hash>`, [`vendor`]). The key holds
//! the hamel version and the size and modification time of the running `hamel` executable (a
//! rebuilt hamel may generate other code), the model file's text, the choice, the dropped
//! coordinates and the parameter values (exact f64 bits). Builds are serialised by a lock
//! file; entries appear by rename, whole.
//!
//! **Builds for this machine** ([`Build`]): with `HAMEL_NATIVE=1` the cores are compiled for
//! the CPU they run on (`-C target-cpu=native`, its vector units, and multiply–adds fused: what
//! heyoka's JIT does), in a target directory of their own (`target-native/`), the CPU's feature
//! list part of the key: a cache shared by machines of other CPUs builds each its own. Fused
//! multiply–adds round once where a multiplication and an addition round twice, so such a core's
//! results differ from the portable one's in the last bits; the default stays portable.

use std::borrow::Cow;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use hamel_codegen::Generated;
use hamel_derive::Derivation;
use hamel_expr::{Expr, Tape};
use hamel_model::{Model, ModelError};
use hamel_sim::job::Progress;
pub use hamel_sim::job::{Answer, Job, JobError, Member};
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use crate::plan::Plan;

mod vendor;

/// Why the code cache could not give a scene's core, or the core could not run.
#[derive(Clone, Debug, thiserror::Error)]
pub enum CacheError {
    /// The cache directory is refused: hamel would build and run code others could change.
    #[error(
        "refusing the code cache {}: {why}. hamel compiles and runs code from it, so it must be a directory of your own that nobody else can write to (chmod 700 it, or set HAMEL_CACHE to another directory)",
        dir.display()
    )]
    Refused {
        /// The directory.
        dir: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// Reading or writing the cache failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The system's error.
        #[source]
        source: std::sync::Arc<std::io::Error>,
    },
    /// The scene's code could not be generated.
    #[error("cannot generate the planned right-hand side: {0}")]
    Codegen(#[from] hamel_codegen::CodegenError),
    /// The derivation could not be specialised for the scene's parameter values.
    #[error("cannot generate the planned right-hand side: {0}")]
    Specialise(#[from] hamel_derive::SpecialiseError),
    /// cargo could not be started.
    #[error("cannot run cargo ({}): {source}", cargo.display())]
    NoCargo {
        /// The cargo command tried.
        cargo: PathBuf,
        /// The system's error.
        #[source]
        source: std::sync::Arc<std::io::Error>,
    },
    /// cargo failed on the entry's crate (the last lines of its output).
    #[error("cargo {command} failed for the generated core in {}:\n{log}", dir.display())]
    Cargo {
        /// `build` or `clean`.
        command: String,
        /// The entry's directory.
        dir: PathBuf,
        /// The end of cargo's error output.
        log: String,
    },
    /// The built core refused the job or could not finish it.
    #[error("{}: {error}", binary.display())]
    Job {
        /// The core's binary.
        binary: PathBuf,
        /// Why, as the core reports it.
        error: JobError,
    },
    /// The built core could not run the job, or answered with something unreadable.
    #[error("{}: {why}", binary.display())]
    Core {
        /// The core's binary.
        binary: PathBuf,
        /// What went wrong.
        why: String,
    },
}

impl CacheError {
    /// As a [`ModelError`], after `context` (such as "the check run failed"; may be empty):
    /// never located in the scene file, since it is not the input's. The machine's
    /// ([`hamel_model::ErrorKind::Environment`]: the cache directory, the file system, cargo)
    /// or hamel's own ([`hamel_model::ErrorKind::Engine`]: code generation, the built core).
    pub fn into_model_error(self, context: &str) -> ModelError {
        let message = if context.is_empty() {
            self.to_string()
        } else {
            format!("{context}: {self}")
        };
        match self {
            CacheError::Refused { .. }
            | CacheError::Io { .. }
            | CacheError::NoCargo { .. }
            | CacheError::Cargo { .. } => ModelError::environment(message),
            CacheError::Codegen(_)
            | CacheError::Specialise(_)
            | CacheError::Job { .. }
            | CacheError::Core { .. } => ModelError::engine(message),
        }
    }

    /// An I/O failure on `what`.
    fn io(what: impl Into<String>, e: std::io::Error) -> CacheError {
        CacheError::Io {
            what: what.into(),
            source: std::sync::Arc::new(e),
        }
    }
}

/// Where the cache lives ([`hamel_cache::location`]). Not checked: see [`root`].
pub fn location() -> PathBuf {
    hamel_cache::location()
}

/// The cache directory, created private (mode 0700) when missing. hamel builds and runs
/// code from it, so it refuses a directory that another user could write to
/// ([`hamel_cache::root`]).
pub fn root() -> Result<PathBuf, CacheError> {
    hamel_cache::root().map_err(|e| match e {
        hamel_cache::RootError::Refused { dir, why } => CacheError::Refused { dir, why },
        hamel_cache::RootError::Io { dir, source } => CacheError::Io {
            what: format!(
                "the code cache {} (set HAMEL_CACHE to a directory of your own)",
                dir.display()
            ),
            source,
        },
    })
}

/// How the cached cores are compiled.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Build {
    /// For any CPU of the target (the default): the same bits on every machine.
    #[default]
    Portable,
    /// For this machine's CPU (`HAMEL_NATIVE=1`): its features (rustc's list for
    /// `target-cpu=native`) are part of the key.
    Native {
        /// The `target_feature` lines rustc prints for the host CPU.
        features: String,
    },
}

/// The flags of a native build: the host's CPU, and multiply–adds fused.
const NATIVE_RUSTFLAGS: &str = "-C target-cpu=native -C llvm-args=-fp-contract=fast";

impl Build {
    /// The build this process uses: native when `HAMEL_NATIVE` is `1` (or `true`), asked of
    /// rustc once.
    pub fn current() -> Result<Build, CacheError> {
        static BUILD: std::sync::OnceLock<Result<Build, CacheError>> = std::sync::OnceLock::new();
        BUILD
            .get_or_init(|| {
                let on = std::env::var("HAMEL_NATIVE").is_ok_and(|v| v == "1" || v == "true");
                if on {
                    native_features()
                } else {
                    Ok(Build::Portable)
                }
            })
            .clone()
    }

    /// The cargo target directory under the cache's root.
    fn target_dir(&self, root: &Path) -> PathBuf {
        match self {
            Build::Portable => root.join("target"),
            Build::Native { .. } => root.join("target-native"),
        }
    }

    /// Its line in a key.
    fn key_text(&self) -> String {
        match self {
            Build::Portable => "build: portable".into(),
            Build::Native { features } => {
                format!("build: native ({NATIVE_RUSTFLAGS}); CPU features: {features}")
            }
        }
    }
}

/// rustc's target features for `-C target-cpu=native`.
fn native_features() -> Result<Build, CacheError> {
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let out = Command::new(&rustc)
        .args(["--print", "cfg", "-C", "target-cpu=native"])
        .stdin(Stdio::null())
        .output()
        .map_err(|e| {
            CacheError::io(
                format!("cannot run {} for HAMEL_NATIVE", rustc.display()),
                e,
            )
        })?;
    if !out.status.success() {
        return Err(CacheError::io(
            "HAMEL_NATIVE: rustc --print cfg -C target-cpu=native failed".to_string(),
            std::io::Error::other(String::from_utf8_lossy(&out.stderr).into_owned()),
        ));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let features: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("target_feature=\""))
        .map(|f| f.trim_end_matches('"'))
        .collect();
    Ok(Build::Native {
        features: features.join(","),
    })
}

/// What identifies a scene's code.
#[derive(Clone, Debug)]
pub struct Key {
    text: String,
    build: Build,
}

impl Key {
    /// The key of the code for `model` (its text, the scene's control closing its loop, and
    /// whether its supports are released: a core with the constraint forces' map or without)
    /// with choice `eta`, `dropped` eliminated and `fixed` parameters specialised.
    pub fn new(
        model: &Model,
        eta: &str,
        dropped: &[String],
        fixed: &IndexMap<String, f64>,
        build: &Build,
    ) -> Key {
        let exe = hamel_cache::executable_identity();
        let params: Vec<String> = fixed
            .iter()
            .map(|(k, v)| format!("{k} = {v:?} ({:#018x})", v.to_bits()))
            .collect();
        Key {
            text: format!(
                "hamel {}; executable {exe}\n{}\nchoice: {eta}\ndropped: {}\nparameters: {}\nsupports released (the constraint forces' map): {}\ncontrol:\n{}\nmodel:\n{}",
                env!("CARGO_PKG_VERSION"),
                build.key_text(),
                dropped.join(", "),
                params.join(", "),
                model.contact_forces.released,
                model.control,
                model.source
            ),
            build: build.clone(),
        }
    }

    /// The key of the C-ABI library of `model`'s full system with choice `eta`, the `fixed`
    /// parameters specialised and the others inputs ([`prepare_library`]).
    pub fn library(model: &Model, eta: &str, fixed: &IndexMap<String, f64>) -> Key {
        let mut key = Key::new(model, eta, &[], fixed, &Build::Portable);
        key.text.push_str(
            "
artifact: the C-ABI library (hamel_codegen::with_c_abi)",
        );
        key
    }

    /// The key's text (what identifies the code).
    pub fn text(&self) -> &str {
        &self.text
    }

    /// FNV-1a, 64 bits: the entry's directory name.
    fn hash(&self) -> String {
        hamel_sim::job::fingerprint(&self.text)
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
    /// SHA-256 of the built `scene` binary, recorded when hamel built it and verified before
    /// every run ([`binary`]).
    #[serde(default)]
    pub binary_sha256: Option<String>,
    /// How it is compiled (the key says it too).
    #[serde(default)]
    pub build: Build,
    /// The right-hand side traced at the scene's start that the core runs where its guards
    /// hold: its size and how it was checked, or why there is none (None: not a scene's core).
    #[serde(default)]
    pub traced: Option<String>,
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

/// The entry for `key`, if the cache holds it. Errors: the cache directory is refused
/// ([`root`]).
pub fn lookup(key: &Key) -> Result<Option<Entry>, CacheError> {
    let dir = root()?.join(key.hash());
    let Some(meta) = std::fs::read_to_string(dir.join("meta.json"))
        .ok()
        .and_then(|text| serde_json::from_str::<Meta>(&text).ok())
    else {
        return Ok(None);
    };
    Ok((meta.key == key.text).then_some(Entry {
        dir,
        meta,
        cached: true,
    }))
}

/// Generate the crate for `key` (the scene's code: `d` specialised for `fixed`, `dropped`
/// eliminated) and store it; `ops_full` comes from the caller (the unspecialised full system).
pub fn store(
    key: &Key,
    (d, traced): (&Derivation, Result<&hamel_codegen::TracedPath, String>),
    fixed: &IndexMap<String, f64>,
    dropped: &[hamel_model::Coord],
    ops_of: impl Fn(&Generated) -> Result<usize, CacheError>,
    ops_full: usize,
    command: &str,
) -> Result<Entry, CacheError> {
    let special = d.specialise(fixed)?;
    let generated =
        hamel_codegen::generate_traced(&special, dropped, command, traced.as_ref().ok().copied());
    let mut generated = hamel_codegen::with_simulator(generated?)?;
    let dir = root()?.join(key.hash());
    // The binary and the package are named after the entry ([`Artifact::crate_name`]).
    generated.edit_manifest(|doc| {
        let scene = Artifact::Scene;
        hamel_codegen::manifest::rename_package(doc, &scene.package(&dir));
        hamel_codegen::manifest::add_binary(doc, &scene.crate_name(&dir), "src/scene_main.rs");
    })?;
    let meta = Meta {
        key: key.text.clone(),
        ops: ops_of(&generated)?,
        ops_full,
        path: generated.solved.name.to_string(),
        binary_sha256: None,
        build: key.build.clone(),
        traced: Some(match traced {
            Ok(t) => format!(
                "{} operations, {} guards: {}",
                t.guarded.tape.operation_count(),
                t.guarded.guards.len(),
                t.note
            ),
            Err(why) => format!("none: {why}"),
        }),
    };
    write_entry(key, &generated, meta)
}

/// Write the crate `generated` and `meta` as the entry of `key`, whole (by rename).
fn write_entry(key: &Key, generated: &Generated, meta: Meta) -> Result<Entry, CacheError> {
    let root = root()?;
    let dir = root.join(key.hash());
    let tmp = root.join(format!("{}.tmp{}", key.hash(), std::process::id()));
    let io = |e| {
        CacheError::io(
            format!("cannot write the code cache in {}", root.display()),
            e,
        )
    };
    let _ = std::fs::remove_dir_all(&tmp);
    let vendored = vendor::Vendored::of(&generated.files);
    let shared = (!vendored.is_empty())
        .then(|| vendored.shared(&root))
        .transpose()?;
    for (path, text) in &generated.files {
        let (path, text) = match (path.as_str(), &shared) {
            (p, _) if p.starts_with("vendor/") => continue,
            ("src/bin/scene.rs", _) => ("src/scene_main.rs", Cow::Borrowed(text)),
            ("Cargo.toml", Some(shared)) => {
                use hamel_codegen::manifest::{edit, relocate_vendored};
                let relocated = edit(text, |doc| relocate_vendored(doc, shared))?;
                ("Cargo.toml", Cow::Owned(relocated))
            }
            (path, _) => (path, Cow::Borrowed(text)),
        };
        let file = tmp.join(path);
        std::fs::create_dir_all(file.parent().expect("a file in the crate")).map_err(io)?;
        std::fs::write(&file, text.as_bytes()).map_err(io)?;
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

/// The right-hand side traced at a scene's start that its core may run
/// ([`crate::traced`]): what identifies it (part of the key), and what checks it on a miss.
pub struct CoreTrace<'a> {
    /// SHA-256 of the tape and its guards ([`crate::traced::fingerprint`]).
    pub fingerprint: String,
    /// The trace checked for the core, or why it is not used.
    pub make: Box<dyn FnOnce() -> Result<hamel_codegen::TracedPath, String> + 'a>,
}

/// The scene's core for `plan`: the cache entry of its code (the derivation `d` specialised for
/// the `fixed` parameter values, the dropped coordinates eliminated, with `trace` where there
/// is one), found in the cache or generated into it. Nothing is built here ([`binary`] builds
/// on first use).
pub fn prepare(
    model: &Model,
    d: &Derivation,
    plan: &Plan,
    fixed: &IndexMap<String, f64>,
    trace: Result<CoreTrace<'_>, String>,
) -> Result<Entry, CacheError> {
    let mut key = Key::new(model, &d.eta_name, &plan.dropped, fixed, &Build::current()?);
    key.text += &match &trace {
        Ok(t) => format!("\ntraced at the start: {}", t.fingerprint),
        Err(_) => "\ntraced at the start: none".into(),
    };
    cached(&key, || {
        let traced = trace.and_then(|t| (t.make)());
        let full = hamel_codegen::generate(d, &[], "plan")?;
        let ops_full = ops_of(&full, d.sigma, &(0..d.ell).collect::<Vec<_>>())?;
        // The specialised crate's solved form has every coordinate's rate; the planned
        // state's are counted.
        let state = plan.state();
        let ops = |g: &Generated| ops_of(g, d.sigma, &state);
        store(
            &key,
            (d, traced.as_ref().map_err(Clone::clone)),
            fixed,
            &plan.dropped_ix,
            ops,
            ops_full,
            &format!("hamel simulate (scene of {}, {})", model.file, d.eta_name),
        )
    })
}

/// The C-ABI library of `model`'s full system with the choice of `d` (every coordinate; the
/// `fixed` parameters specialised as a scene's are, the others inputs:
/// [`hamel_codegen::with_c_abi`]), found in the cache or generated into it; [`library`] builds
/// it. What hamel's Python package opens.
pub fn prepare_library(
    model: &Model,
    d: &Derivation,
    fixed: &IndexMap<String, f64>,
) -> Result<Entry, CacheError> {
    let key = Key::library(model, &d.eta_name, fixed);
    cached(&key, || {
        let d = &d.specialise(fixed)?;
        let dir = root()?.join(key.hash());
        let command = format!("hamel's Python package ({}, {})", model.file, d.eta_name);
        let mut generated = hamel_codegen::with_c_abi(
            hamel_codegen::generate(d, &[], &command)?,
            &Artifact::Library.crate_name(&dir),
        )?;
        generated.edit_manifest(|doc| {
            hamel_codegen::manifest::rename_package(doc, &Artifact::Library.package(&dir));
        })?;
        let ops = ops_of(&generated, d.sigma, &(0..d.ell).collect::<Vec<_>>())?;
        let meta = Meta {
            key: key.text.clone(),
            ops,
            ops_full: ops,
            path: generated.solved.name.to_string(),
            binary_sha256: None,
            build: key.build.clone(),
            traced: None,
        };
        write_entry(&key, &generated, meta)
    })
}

/// The entry for `key`: the stored one, else what `make` stores.
pub fn cached(
    key: &Key,
    make: impl FnOnce() -> Result<Entry, CacheError>,
) -> Result<Entry, CacheError> {
    match lookup(key)? {
        Some(entry) => Ok(entry),
        None => make(),
    }
}

/// Operations of η̇ and the rates of `coords` in the solved form of `g`, common subexpressions
/// shared; without a solved form (a structured derivation), those of the ingredients, which
/// every state needs whole (the LU of [Z; α] and the contractions of (11) come on top).
fn ops_of(g: &Generated, sigma: usize, coords: &[usize]) -> Result<usize, CacheError> {
    let solved = &g.solved;
    if solved.exprs.is_empty() {
        return Ok(g.ops_shared);
    }
    let exprs: Vec<&Expr> = solved.exprs[..sigma]
        .iter()
        .chain(coords.iter().map(|&k| &solved.exprs[sigma + k]))
        .collect();
    Tape::compile(&exprs, &solved.inputs)
        .map(|t| t.operation_count())
        .map_err(|e| CacheError::Codegen(e.into()))
}

/// What `hamel plan` reports of an entry.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Arithmetic operations of the planned right-hand side (η̇ and the rates of the integrated
    /// and reconstructed coordinates, common subexpressions shared, in the solved form the
    /// code generator chooses).
    pub ops: usize,
    /// The same for the full system (all coordinates), for comparison.
    pub ops_full: usize,
    /// The directory of the scene's generated code in the cache.
    pub code: String,
    /// Whether that code was found in the cache (else generated by this run).
    pub cached: bool,
}

impl Entry {
    /// What `hamel plan` reports of it.
    pub fn summary(&self) -> Summary {
        Summary {
            ops: self.meta.ops,
            ops_full: self.meta.ops_full,
            code: self.dir.display().to_string(),
            cached: self.cached,
        }
    }
}

impl Summary {
    /// The operation counts as a line of text.
    pub fn to_text(&self) -> String {
        format!(
            "operations of the right-hand side: {} (full system: {})\n",
            self.ops, self.ops_full
        )
    }
}

/// What an entry builds: a scene's `scene` binary ([`prepare`]) or the C-ABI library
/// ([`prepare_library`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Artifact {
    /// The scene's integration binary.
    Scene,
    /// The shared library with the C ABI.
    Library,
}

impl Artifact {
    /// Its file in the entry's directory.
    fn file(self) -> String {
        match self {
            Artifact::Scene => "scene".into(),
            Artifact::Library => format!("core{}", std::env::consts::DLL_SUFFIX),
        }
    }

    /// The name cargo gives it, after the entry: every entry's crate builds in the one shared
    /// target directory, where a fresh (not rebuilt) artefact is not copied to `release/` again.
    fn crate_name(self, dir: &Path) -> String {
        let hash = dir
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        match self {
            Artifact::Scene => format!("scene-{hash}"),
            Artifact::Library => format!("hamel_core_{hash}"),
        }
    }

    /// The package's name (cargo hashes a workspace root's artefacts by its name and version,
    /// not its path: two entries of one model would otherwise share a library).
    fn package(self, dir: &Path) -> String {
        match self {
            Artifact::Scene => format!("hamel-{}", self.crate_name(dir)),
            Artifact::Library => self.crate_name(dir).replace('_', "-"),
        }
    }

    /// Where cargo leaves it in the shared target directory `target`.
    fn built(self, target: &Path, dir: &Path) -> PathBuf {
        let release = target.join("release");
        match self {
            Artifact::Scene => release.join(self.crate_name(dir)),
            Artifact::Library => release.join(format!(
                "{}{}{}",
                std::env::consts::DLL_PREFIX,
                self.crate_name(dir),
                std::env::consts::DLL_SUFFIX
            )),
        }
    }

    /// cargo's option selecting it.
    fn target(self, dir: &Path) -> Vec<String> {
        match self {
            Artifact::Scene => vec!["--bin".into(), self.crate_name(dir)],
            Artifact::Library => vec!["--lib".into()],
        }
    }
}

/// The entry's `scene` binary, built with cargo (offline, release) when missing ([`built`]).
pub fn binary(entry: &Entry) -> Result<Binary, CacheError> {
    built(entry, Artifact::Scene)
}

/// The entry's C-ABI library ([`prepare_library`]), built with cargo when missing ([`built`]).
pub fn library(entry: &Entry) -> Result<Binary, CacheError> {
    built(entry, Artifact::Library)
}

/// The entry's `artifact`, built with cargo (offline, release) when missing; returns the
/// path and whether this call built it. An artefact whose SHA-256 is not the one recorded in
/// `meta.json` when hamel built it (planted, altered, or built by something else) is never
/// run or loaded: it is rebuilt from the entry's source, with a warning.
pub fn built(entry: &Entry, artifact: Artifact) -> Result<Binary, CacheError> {
    let exe = entry.dir.join(artifact.file());
    let root = root()?;
    let found = |path| Binary { path, built: false };
    if verify(&entry.dir, &exe)? == Check::Good {
        return Ok(found(exe));
    }
    let io = |e| CacheError::io(format!("code cache {}", root.display()), e);
    // One build at a time in the shared target directory.
    let lock = std::fs::File::create(root.join("build.lock")).map_err(io)?;
    lock.lock().map_err(io)?;
    match verify(&entry.dir, &exe)? {
        Check::Good => return Ok(found(exe)),
        Check::Missing => {}
        Check::Mismatch(why) => {
            let verb = match artifact {
                Artifact::Scene => "running",
                Artifact::Library => "loading",
            };
            log::warn!(
                "the cached core {} {why}: not {verb} it; rebuilding it from its source",
                exe.display()
            );
            std::fs::remove_file(&exe).map_err(io)?;
            // Whatever cargo kept of this entry is not trusted either: build it anew.
            let package = artifact.package(&entry.dir);
            cargo(
                entry,
                &root,
                &[
                    "clean",
                    "--release",
                    "--offline",
                    "--quiet",
                    "--package",
                    &package,
                ],
            )?;
        }
    }
    let target = artifact.target(&entry.dir);
    let mut args = vec!["build", "--release", "--offline", "--quiet"];
    args.extend(target.iter().map(String::as_str));
    cargo(entry, &root, &args)?;
    let tmp = entry
        .dir
        .join(format!("{}.tmp{}", artifact.file(), std::process::id()));
    let target = entry.meta.build.target_dir(&root);
    std::fs::copy(artifact.built(&target, &entry.dir), &tmp).map_err(io)?;
    record_hash(&entry.dir, &sha256(&tmp).map_err(io)?).map_err(io)?;
    std::fs::rename(&tmp, &exe).map_err(io)?;
    Ok(Binary {
        path: exe,
        built: true,
    })
}

/// A scene's built core ([`binary`]).
pub struct Binary {
    /// The executable.
    pub path: PathBuf,
    /// This call built it.
    pub built: bool,
}

/// What [`verify`] found.
#[derive(Debug, PartialEq)]
enum Check {
    /// The binary is the one hamel built.
    Good,
    /// No binary.
    Missing,
    /// A binary that is not the one recorded (the reason).
    Mismatch(String),
}

/// Compare the binary with the hash recorded in the entry's `meta.json` (read now: another
/// process may have built it since the entry was looked up).
fn verify(dir: &Path, exe: &Path) -> Result<Check, CacheError> {
    if !exe.exists() {
        return Ok(Check::Missing);
    }
    let found =
        sha256(exe).map_err(|e| CacheError::io(format!("cannot read {}", exe.display()), e))?;
    let recorded = std::fs::read_to_string(dir.join("meta.json"))
        .ok()
        .and_then(|text| serde_json::from_str::<Meta>(&text).ok())
        .and_then(|m| m.binary_sha256);
    Ok(match recorded {
        Some(r) if r == found => Check::Good,
        Some(r) => Check::Mismatch(format!("has SHA-256 {found}, not {r} as built")),
        None => Check::Mismatch("was not built by hamel (no SHA-256 recorded)".into()),
    })
}

/// Run cargo with `args` on the entry's crate with the cache's shared target directory.
fn cargo(entry: &Entry, root: &Path, args: &[&str]) -> Result<(), CacheError> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut command = Command::new(&cargo);
    command
        .args(args)
        .arg("--manifest-path")
        .arg(entry.dir.join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", entry.meta.build.target_dir(root))
        .stdin(Stdio::null());
    if let Build::Native { .. } = entry.meta.build {
        command.env("RUSTFLAGS", NATIVE_RUSTFLAGS);
    }
    let out = command.output().map_err(|e| CacheError::NoCargo {
        cargo: PathBuf::from(&cargo),
        source: std::sync::Arc::new(e),
    })?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = err.lines().rev().take(15).collect();
        return Err(CacheError::Cargo {
            command: args[0].to_string(),
            dir: entry.dir.clone(),
            log: tail.into_iter().rev().collect::<Vec<_>>().join("\n"),
        });
    }
    Ok(())
}

/// The SHA-256 of a file, in hexadecimal.
fn sha256(path: &Path) -> std::io::Result<String> {
    use sha2::{Digest, Sha256};
    let mut file = std::fs::File::open(path)?;
    let mut hasher = Sha256::new();
    std::io::copy(&mut file, &mut hasher)?;
    Ok(hex(&hasher.finalize()))
}

/// Bytes (a digest) in lowercase hexadecimal.
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Record the built binary's hash in the entry's `meta.json` (written whole, by rename).
fn record_hash(dir: &Path, hash: &str) -> std::io::Result<()> {
    let path = dir.join("meta.json");
    let mut meta: Meta = serde_json::from_str(&std::fs::read_to_string(&path)?)
        .map_err(|e| std::io::Error::other(format!("{}: {e}", path.display())))?;
    meta.binary_sha256 = Some(hash.to_string());
    let text = serde_json::to_string_pretty(&meta).expect("serialisable");
    hamel_cache::write_atomic(dir, "meta.json", text.as_bytes())
}

/// Run the ensemble `job` on the binary with `threads` threads (0: one per core): what it
/// writes (its JSON lines), with `progress(done, total)` called as members finish.
pub fn run_ensemble(
    binary: &Path,
    job: &Job,
    threads: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<String, CacheError> {
    use std::io::{BufRead, Read};
    let mut child = spawn(binary, &["--progress", "--threads", &threads.to_string()])?;
    let stderr = child.stderr.take().expect("piped");
    let mut stdout = child.stdout.take().expect("piped");
    let (out, errors) = std::thread::scope(|scope| {
        // Progress lines are read as they come; anything else is kept for the error message.
        let reader = scope.spawn(move || {
            let mut other = String::new();
            for line in std::io::BufReader::new(stderr)
                .lines()
                .map_while(Result::ok)
            {
                match Progress::parse(&line) {
                    Some(p) => progress(p.done, p.total),
                    None => other.push_str(&(line + "\n")),
                }
            }
            other
        });
        let sent = child
            .stdin
            .take()
            .expect("piped")
            .write_all(job.to_text().0.as_bytes());
        let mut out = String::new();
        let read = stdout.read_to_string(&mut out);
        let other = reader.join().unwrap_or_default();
        (sent.and(read).map(|_| out), other)
    });
    let status = child.wait().map_err(|e| core(binary, e.to_string()))?;
    if !status.success() {
        return Err(refused(binary, &errors));
    }
    out.map_err(|e| core(binary, format!("cannot exchange the job with it: {e}")))
}

/// The core `binary` started with `args`, its standard streams piped.
fn spawn(binary: &Path, args: &[&str]) -> Result<std::process::Child, CacheError> {
    Command::new(binary)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| core(binary, format!("cannot run it: {e}")))
}

/// The core could not run or answered with something unreadable.
fn core(binary: &Path, why: String) -> CacheError {
    CacheError::Core {
        binary: binary.to_path_buf(),
        why,
    }
}

/// The core failed: its typed [`JobError`] when it wrote one, else what it wrote.
fn refused(binary: &Path, stderr: &str) -> CacheError {
    match JobError::from_report(stderr) {
        Some(error) => CacheError::Job {
            binary: binary.to_path_buf(),
            error,
        },
        None => core(binary, format!("failed: {}", stderr.trim())),
    }
}

/// Run `job` on the binary: the solution (partial on failure), why it stopped, the median
/// time of one integration measured inside the binary.
pub fn run(binary: &Path, job: &Job) -> Result<Answer, CacheError> {
    let mut child = spawn(binary, &[])?;
    child
        .stdin
        .take()
        .expect("piped")
        .write_all(job.to_text().0.as_bytes())
        .map_err(|e| core(binary, format!("cannot send it the job: {e}")))?;
    let out = child
        .wait_with_output()
        .map_err(|e| core(binary, e.to_string()))?;
    if !out.status.success() {
        return Err(refused(binary, &String::from_utf8_lossy(&out.stderr)));
    }
    serde_json::from_slice(&out.stdout).map_err(|e| core(binary, format!("unreadable answer: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene that requests constraint forces derives with the supports released and gets a
    /// core with the forces' map: never the core of the same model without them.
    #[test]
    fn a_core_with_the_forces_map_has_a_key_of_its_own() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/whipple_bicycle.toml"
        );
        let model = Model::load(path).unwrap();
        let fixed = IndexMap::new();
        let portable = &Build::Portable;
        let plain = Key::new(&model, "benchmark", &[], &fixed, portable);
        let supported = Key::new(
            &model.with_supports().unwrap(),
            "benchmark",
            &[],
            &fixed,
            portable,
        );
        assert_ne!(plain.text, supported.text);
    }

    /// A core built for one CPU is never another build's: the build and the CPU's features
    /// are in the key, and native builds have a target directory of their own.
    #[test]
    fn the_build_is_part_of_the_key() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/knife.toml");
        let model = Model::load(path).unwrap();
        let fixed = IndexMap::new();
        let builds = [
            Build::Portable,
            Build::Native {
                features: "avx2,fma".into(),
            },
            Build::Native {
                features: "sse2".into(),
            },
        ];
        let keys: Vec<Key> = (builds.iter())
            .map(|b| Key::new(&model, "paper", &[], &fixed, b))
            .collect();
        assert_ne!(keys[0].hash(), keys[1].hash());
        assert_ne!(keys[1].hash(), keys[2].hash());
        assert!(keys[1].text.contains("CPU features: avx2,fma"));
        let root = Path::new("/cache");
        assert_eq!(builds[0].target_dir(root), root.join("target"));
        assert_eq!(builds[1].target_dir(root), root.join("target-native"));
    }
}
