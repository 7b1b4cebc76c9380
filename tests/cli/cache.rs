//! The code cache of compiled scene cores: private, verified, built once, untouched by the interpreted engine.

#[allow(unused_imports)]
use super::*;

/// The file's modification time.
fn modified(path: &Path) -> std::time::SystemTime {
    std::fs::metadata(path).unwrap().modified().unwrap()
}

#[test]
fn simulate_builds_a_specialised_core_once_and_reuses_it() {
    let dir = scratch("core_cache");
    let (first, second, interpreted) = (
        dir.join("first.json"),
        dir.join("second.json"),
        dir.join("interpreted.json"),
    );
    let run = |out: &Path, engine: &str| {
        let o = hamel(
            &[
                "simulate",
                "scenes/bar_wheels.toml",
                "--format",
                "json",
                "--output",
                out.to_str().unwrap(),
                "--engine",
                engine,
            ],
            None,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let plan = json_on_stdout(&hamel(
        &["plan", "scenes/bar_wheels.toml", "--format", "json"],
        None,
    ));
    let code = PathBuf::from(plan["code"].as_str().unwrap());
    // Another test may have built this scene's core in the shared cache: start without it.
    let _ = std::fs::remove_file(code.join("scene"));
    let e = run(&first, "compiled");
    assert!(e.contains("built into"), "{e}");
    let exe = code.join("scene");
    let built = modified(&exe);
    let e = run(&second, "compiled");
    assert!(e.contains("cached in"), "{e}");
    assert_eq!(modified(&exe), built, "the second run rebuilt the core");
    let plan = json_on_stdout(&hamel(
        &["plan", "scenes/bar_wheels.toml", "--format", "json"],
        None,
    ));
    assert_eq!(plan["cached"], true);
    // Specialised: the scene fixes every parameter, so the core has none left, and its
    // planned right-hand side has fewer operations than the general full system's.
    let model = std::fs::read_to_string(code.join("src/model.rs")).unwrap();
    assert!(
        model.contains("pub const NAMES: [&str; 0] = [];"),
        "{model}"
    );
    assert!(plan["ops"].as_u64().unwrap() < plan["ops_full"].as_u64().unwrap());
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (a, b) = (read(&first), read(&second));
    assert_eq!(a["engine"], "compiled");
    // The compiled core and the interpreted evaluator integrate the same equations.
    run(&interpreted, "interpreted");
    let c = read(&interpreted);
    assert_eq!(c["engine"], "interpreted");
    let flat = |v: &serde_json::Value| -> Vec<f64> {
        let mut out: Vec<f64> = v["q"]["phi"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        for row in v["eta"].as_array().unwrap() {
            out.extend(row.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()));
        }
        out
    };
    let (fa, fb, fc) = (flat(&a), flat(&b), flat(&c));
    assert_eq!(fa.len(), 3 * 201);
    let worst = |u: &[f64], v: &[f64]| {
        u.iter()
            .zip(v)
            .map(|(x, y)| (x - y).abs() / y.abs().max(1.0))
            .fold(0.0, f64::max)
    };
    // The scene gives an accuracy target (1e-10), and the setting that meets it fastest is
    // chosen by timing, which may differ from run to run: the runs agree to the target, not
    // bit for bit.
    assert!(
        worst(&fa, &fb) < 1e-8,
        "first vs second run: {:e}",
        worst(&fa, &fb)
    );
    assert!(
        worst(&fa, &fc) < 1e-8,
        "compiled vs interpreted: {:e}",
        worst(&fa, &fc)
    );
}

#[test]
fn a_code_cache_others_could_write_is_refused_and_a_new_one_is_private() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let dir = scratch("cache_modes");
    let out = dir.join("plan.json");
    let plan = |cache: &Path| {
        hamel_with_cache(
            &[
                "plan",
                "scenes/knife.toml",
                "--format",
                "json",
                "--output",
                out.to_str().unwrap(),
            ],
            None,
            cache,
        )
    };
    for (name, mode, says) in [
        ("world", 0o777, "writable by all users"),
        ("group", 0o770, "writable by its group"),
    ] {
        let cache = dir.join(name);
        dir_with_mode(&cache, mode);
        let o = plan(&cache);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("refusing the code cache") && e.contains(says),
            "{e}"
        );
        assert!(e.contains("knife.toml"), "the error names the file: {e}");
        assert!(!out.exists(), "nothing is written");
        assert_eq!(
            std::fs::read_dir(&cache).unwrap().count(),
            0,
            "nothing is cached"
        );
    }
    // Owned by another user (only root can make one here).
    let cache = dir.join("other");
    dir_with_mode(&cache, 0o700);
    let chown = Command::new("chown")
        .args(["65534", cache.to_str().unwrap()])
        .output();
    if chown.is_ok_and(|o| o.status.success()) {
        let o = plan(&cache);
        assert_eq!(o.status.code(), Some(1));
        assert!(
            stderr(&o).contains("is owned by user 65534"),
            "{}",
            stderr(&o)
        );
        // A link someone else owns, to a directory of ours.
        let mine = dir.join("mine");
        dir_with_mode(&mine, 0o700);
        let link = dir.join("link");
        std::os::unix::fs::symlink(&mine, &link).unwrap();
        let chown = Command::new("chown")
            .args(["-h", "65534", link.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(chown.status.success());
        let o = plan(&link);
        assert_eq!(o.status.code(), Some(1));
        assert!(
            stderr(&o).contains("symbolic link owned by user 65534"),
            "{}",
            stderr(&o)
        );
    } else {
        eprintln!("cannot chown here (not root): the other-owner case is skipped");
    }
    // A missing cache is created private, with its parents.
    let cache = dir.join("new/cache");
    let o = plan(&cache);
    assert!(o.status.success(), "{}", stderr(&o));
    let mode = std::fs::metadata(&cache).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o700);
    // SAFETY: geteuid has no preconditions.
    assert_eq!(std::fs::metadata(&cache).unwrap().uid(), unsafe {
        libc::geteuid()
    });
}

#[test]
fn a_planted_binary_in_the_cache_is_rebuilt_not_run() {
    let dir = scratch("planted");
    let marker = dir.join("planted-binary-ran");
    let out = dir.join("knife.json");
    let simulate = || {
        hamel(
            &[
                "simulate",
                "scenes/knife.toml",
                "--format",
                "json",
                "--output",
                out.to_str().unwrap(),
            ],
            None,
        )
    };
    let o = simulate();
    assert!(o.status.success(), "{}", stderr(&o));
    let honest = std::fs::read_to_string(&out).unwrap();
    let plan = json_on_stdout(&hamel(
        &["plan", "scenes/knife.toml", "--format", "json"],
        None,
    ));
    let exe = PathBuf::from(plan["code"].as_str().unwrap()).join("scene");
    let meta = |exe: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(exe.with_file_name("meta.json")).unwrap())
            .unwrap()
    };
    assert_eq!(meta(&exe)["binary_sha256"].as_str().unwrap().len(), 64);
    // Replace the built core with a program that would leave a mark.
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::write(&exe, format!("#!/bin/sh\ntouch '{}'\n", marker.display())).unwrap();
        std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let o = simulate();
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("warning: the cached core") && e.contains("not running it"),
        "{e}"
    );
    assert!(!marker.exists(), "the planted binary ran");
    // The core was rebuilt, and its hash recorded anew.
    let rebuilt = std::fs::read(&exe).unwrap();
    assert!(!rebuilt.starts_with(b"#!"));
    let sha: String = {
        use sha2::Digest;
        sha2::Sha256::digest(&rebuilt)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    };
    assert_eq!(meta(&exe)["binary_sha256"].as_str().unwrap(), sha);
    let again = std::fs::read_to_string(&out).unwrap();
    let solution = |s: &str| -> (serde_json::Value, serde_json::Value) {
        let v: serde_json::Value = serde_json::from_str(s).unwrap();
        (v["q"].clone(), v["eta"].clone())
    };
    assert_eq!(solution(&honest), solution(&again));
    // The next run finds the rebuilt core good: no warning.
    let o = simulate();
    assert!(
        !stderr(&o).contains("warning: the cached core"),
        "{}",
        stderr(&o)
    );
}

/// Planning is pure: loading a scene and integrating it on the interpreted evaluator writes
/// nothing to the code cache (only the derivation store, `derivations/`, and its workers'
/// `work/` are made in the cache directory); `hamel plan`, which reports the core's operation
/// counts, prepares the scene's core there, and nothing else.
#[test]
fn the_interpreted_engine_leaves_the_code_cache_alone() {
    let dir = scratch("pure_plan");
    let cache = dir.join("cache");
    let o = hamel_with_cache(
        &["simulate", "scenes/knife.toml", "--engine", "interpreted"],
        None,
        &cache,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let made = || -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(&cache)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n != "derivations" && n != "work")
            .collect();
        v.sort();
        v
    };
    assert!(made().is_empty(), "the interpreted run wrote {:?}", made());
    let o = hamel_with_cache(&["plan", "scenes/knife.toml"], None, &cache);
    assert!(o.status.success(), "{}", stderr(&o));
    let entries: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !["build.lock", "target", "derivations", "work"].contains(&n.as_str()))
        .collect();
    // the scene's core and the vendored crates it shares with every other entry
    let (shared, entries): (Vec<_>, Vec<_>) = entries.into_iter().partition(|n| n == "vendor");
    assert_eq!(shared.len(), 1, "the vendored crates kept once");
    assert_eq!(entries.len(), 1, "one entry, the scene's core: {entries:?}");
    assert!(!cache.join("target").exists(), "plan builds nothing");
}

/// With `HAMEL_NATIVE=1` a scene's core is built for this CPU (`-C target-cpu=native`, fused
/// multiply–adds) as an entry of its own, in the cache's `target-native/`, its key naming the
/// build and the CPU's features; the portable entry stays as it was. Both integrate the same
/// equations: to the scene's tolerance, not bit for bit (a fused multiply–add rounds once).
#[test]
fn a_core_built_for_this_cpu_is_an_entry_of_its_own() {
    let dir = scratch("native");
    let native = |args: &[&str]| {
        let _guard = super::ONE_AT_A_TIME
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        let mut cmd = super::hamel_command(args, &code_cache());
        cmd.env("HAMEL_NATIVE", "1").output().unwrap()
    };
    let plan = ["plan", "scenes/knife.toml", "--format", "json"];
    let portable_code = json_on_stdout(&hamel(&plan, None))["code"].clone();
    let native_code = json_on_stdout(&native(&plan))["code"].clone();
    assert_ne!(portable_code, native_code, "one entry for both builds");
    let (p_out, n_out) = (dir.join("portable.json"), dir.join("native.json"));
    let simulate = |out: &Path| {
        let out = out.to_str().unwrap().to_string();
        [
            "simulate",
            "scenes/knife.toml",
            "--format",
            "json",
            "--output",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([out])
        .collect::<Vec<String>>()
    };
    let args = simulate(&p_out);
    let o = hamel(&args.iter().map(String::as_str).collect::<Vec<_>>(), None);
    assert!(o.status.success(), "{}", stderr(&o));
    let args = simulate(&n_out);
    let o = native(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let code = PathBuf::from(native_code.as_str().unwrap());
    let meta = std::fs::read_to_string(code.join("meta.json")).unwrap();
    assert!(meta.contains("build: native"), "{meta}");
    assert!(meta.contains("CPU features: "), "{meta}");
    assert!(code_cache().join("target-native/release").is_dir());
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (a, b) = (read(&p_out), read(&n_out));
    assert_eq!(
        (&a["engine"], &b["engine"]),
        (&"compiled".into(), &"compiled".into())
    );
    for k in ["x", "y", "theta"] {
        let d = largest_difference(&a, &b, k);
        assert!(d < 1e-8, "{k}: portable and native differ by {d:e}");
    }
}

/// The times cargo last compiled the vendored crates in the cache's target directory.
fn vendored_builds(cache: &Path) -> Vec<(String, std::time::SystemTime)> {
    let fingerprints = cache.join("target/release/.fingerprint");
    let mut found: Vec<_> = std::fs::read_dir(&fingerprints)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with("hamel-sim-") || name.starts_with("hamel-runtime-")
        })
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, modified(&p.join("invoked.timestamp")))
        })
        .collect();
    found.sort();
    found
}

/// Every entry's crate points at one copy of the vendored hamel-runtime and hamel-sim, so a
/// new scene's core compiles its own code only, not them again.
#[test]
fn a_new_core_does_not_compile_the_vendored_crates_again() {
    let cache = code_cache();
    let simulate = |scene: &str| {
        let out = scratch("shared_vendor").join("run.csv");
        let args = ["simulate", scene, "--output", out.to_str().unwrap()];
        let o = hamel(&args, None);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    simulate("scenes/knife.toml");
    let before = vendored_builds(&cache);
    assert!(!before.is_empty(), "the vendored crates were built");
    let plan = ["plan", "scenes/vertical_knife.toml", "--format", "json"];
    let code = PathBuf::from(
        json_on_stdout(&hamel(&plan, None))["code"]
            .as_str()
            .unwrap(),
    );
    // Another test may have built this core: start without its entry.
    std::fs::remove_dir_all(&code).unwrap();
    let e = simulate("scenes/vertical_knife.toml");
    assert!(e.contains("built into"), "{e}");
    assert_eq!(
        vendored_builds(&cache),
        before,
        "the new core rebuilt a vendored crate"
    );
    let manifest = std::fs::read_to_string(code.join("Cargo.toml")).unwrap();
    assert!(manifest.contains("path = \"../vendor/"), "{manifest}");
    assert!(!code.join("vendor").exists());
}
