//! The derivation store and the computer algebra's one thread (issue 59): what is stored is
//! used without the computer algebra; a command derives in a worker process that exits, so
//! that it holds no licence thread while it computes numbers; the store is private and trusts
//! no entry it did not write.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Output, Stdio};
use std::time::{Duration, Instant};

use super::{ONE_AT_A_TIME, hamel_command, hamel_with_cache, json_on_stdout, scratch, stderr};

/// The derivation store (issue 59): the second `hamel eval` of a model reads its derivation
/// from the store and starts no computer algebra (stdout is JSON from its first byte, no
/// notice), with the same numbers; the store is private; an entry tampered with is not
/// trusted (a warning, derived anew, the same numbers).
#[test]
fn a_stored_derivation_is_evaluated_without_the_computer_algebra() {
    let dir = scratch("store");
    let cache = dir.join("cache");
    let states = dir.join("states.json");
    std::fs::write(
        &states,
        r#"[{"q": {"x": 0.1, "y": 0.2, "theta": 0.3}, "eta": [1.0, 0.5]}]"#,
    )
    .unwrap();
    let eval = || {
        let args = [
            "eval",
            "models/knife.toml",
            "--state",
            states.to_str().unwrap(),
        ];
        let o = hamel_with_cache(&args, None, &cache);
        assert!(o.status.success(), "{}", stderr(&o));
        o
    };
    let first = eval();
    let second = eval();
    let text = String::from_utf8(second.stdout.clone()).unwrap();
    assert!(
        text.starts_with('['),
        "stdout is JSON from its first byte: {text}"
    );
    assert!(!text.contains("Symbolica") && !stderr(&second).contains("Symbolica"));
    assert_eq!(json_on_stdout(&first), json_on_stdout(&second));
    let store = cache.join("derivations");
    use std::os::unix::fs::PermissionsExt;
    assert_eq!(
        std::fs::metadata(&store).unwrap().permissions().mode() & 0o777,
        0o700
    );
    let entry = std::fs::read_dir(&store)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let mut bytes = std::fs::read(&entry).unwrap();
    let at = bytes.len() / 2;
    bytes[at] ^= 0x55;
    std::fs::write(&entry, bytes).unwrap();
    let third = eval();
    assert!(
        stderr(&third).contains("corrupt or not this model's"),
        "{}",
        stderr(&third)
    );
    assert_eq!(json_on_stdout(&first), json_on_stdout(&third));
    // --no-store derives anew (the computer algebra runs: its notice is printed)
    let args = [
        "eval",
        "models/knife.toml",
        "--state",
        states.to_str().unwrap(),
        "--no-store",
    ];
    let fresh = hamel_with_cache(&args, None, &cache);
    assert!(fresh.status.success(), "{}", stderr(&fresh));
    assert!(String::from_utf8_lossy(&fresh.stdout).contains("Symbolica"));
    assert_eq!(json_on_stdout(&first), json_on_stdout(&fresh));
}

/// The children of process `pid`: their ids and command lines (from /proc).
fn children(pid: u32) -> Vec<(i32, String)> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    let parent_of = |stat: &str| -> Option<u32> {
        // pid (comm) state ppid …: comm may hold spaces and parentheses
        let rest = &stat[stat.rfind(')')? + 1..];
        rest.split_whitespace().nth(1)?.parse().ok()
    };
    entries
        .filter_map(Result::ok)
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .bytes()
                .all(|b| b.is_ascii_digit())
        })
        .filter(|e| {
            std::fs::read_to_string(e.path().join("stat"))
                .ok()
                .and_then(|s| parent_of(&s))
                == Some(pid)
        })
        .filter_map(|e| {
            let id = e.file_name().to_string_lossy().parse().ok()?;
            let line = std::fs::read(e.path().join("cmdline")).ok()?;
            Some((id, String::from_utf8_lossy(&line).replace('\0', " ")))
        })
        .collect()
}

/// Wait (at most `limit`) until `done` holds, checking every 20 ms; false when it never did.
fn wait_until(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
    let started = Instant::now();
    while started.elapsed() < limit {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

/// A private cache directory of its own in `dir`.
fn own_cache(dir: &Path) -> PathBuf {
    let cache = dir.join("cache");
    super::dir_with_mode(&cache, 0o700);
    cache
}

/// `hamel args` with `cache`, for a test that holds [`ONE_AT_A_TIME`] itself.
fn output(args: &[&str], cache: &Path) -> Output {
    hamel_command(args, cache).output().unwrap()
}

/// Start `hamel args` (stdout and stderr piped) with `cache`.
fn start(args: &[&str], cache: &Path) -> Child {
    hamel_command(args, cache)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Acceptance of issue 59: while `hamel search` holds the computer algebra's one thread (its
/// 20 s budget), `hamel simulate`, `hamel linearize` and `hamel eval` of stored models succeed,
/// with the same output and no Symbolica notice: what is stored starts no Symbolica thread
/// (one would abort: the licence allows one at a time).
#[test]
fn stored_commands_run_beside_a_search() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("beside_search");
    let cache = own_cache(&dir);
    let simulate = ["simulate", "scenes/knife.toml", "--format", "json"];
    let linearize = [
        "linearize",
        "models/rolling_disk.toml",
        "--steady",
        "upright",
        "--format",
        "json",
    ];
    let states = dir.join("states.json");
    std::fs::write(
        &states,
        r#"{"q": {"x": 0.1, "y": 0.2, "theta": 0.3}, "eta": [1.0, 0.5]}"#,
    )
    .unwrap();
    let eval = [
        "eval",
        "models/knife.toml",
        "--state",
        states.to_str().unwrap(),
    ];
    let run = |args: &[&str]| output(args, &cache);
    let first: Vec<_> = [&simulate[..], &linearize[..], &eval[..]].map(run).into();
    for o in &first {
        assert!(o.status.success(), "{}", stderr(o));
    }
    let search = [
        "search",
        "models/snakeboard.toml",
        "--eliminate",
        "x,y,theta,psi",
        "--budget",
        "20",
    ];
    let mut searching = start(&search, &cache);
    // The worker's notice, passed through to the search's stdout: it holds the thread now.
    let mut stdout = searching.stdout.take().unwrap();
    let mut seen = Vec::new();
    let mut byte = [0u8; 1];
    while !String::from_utf8_lossy(&seen).contains("Symbolica") {
        assert_eq!(
            stdout.read(&mut byte).unwrap(),
            1,
            "the search printed no notice"
        );
        seen.push(byte[0]);
    }
    for (args, before) in [&simulate[..], &linearize[..], &eval[..]]
        .into_iter()
        .zip(&first)
    {
        let o = run(args);
        assert!(
            o.status.success(),
            "{args:?} beside a search: {}",
            stderr(&o)
        );
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(
            !text.contains("Symbolica"),
            "{args:?} started the computer algebra"
        );
        assert_eq!(json_on_stdout(&o), json_on_stdout(before), "{args:?}");
    }
    // what is not stored must be derived, which the licence does not allow now: a clear
    // error (Symbolica's own notice untouched on stdout), exit 1, nothing written
    let out = dir.join("unstored.json");
    let state = states.to_str().unwrap();
    let unstored = ["eval", "models/vertical_knife.toml", "--state", state];
    let o = output(
        &[&unstored[..], &["--output", out.to_str().unwrap()]].concat(),
        &cache,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("another process holds"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    assert!(
        searching.try_wait().unwrap().is_none(),
        "the search ended before the other commands ran"
    );
    // it runs to its wall (and its worker with it), so that no thread is left held
    let mut rest = Vec::new();
    stdout.read_to_end(&mut rest).unwrap();
    let status = searching.wait().unwrap();
    assert!(status.success(), "the search failed: {status}");
}

/// A knife ensemble of `members` members over `t_end` seconds (final states kept).
fn knife_ensemble(dir: &Path, name: &str, members: usize, t_end: f64) -> PathBuf {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/knife.toml");
    let text = format!(
        "model = {model:?}\neta = \"paper\"\nt_end = {t_end:?}\noutputs = 2\nrequest = [\"x\", \"y\", \"theta\"]\n\n[initial]\nq = {{ x = 0.0, y = 0.0, theta = 0.3 }}\neta = [1.0, 0.5]\n\n[integrator]\nmethod = \"dop853\"\nrtol = 1e-12\natol = 1e-12\n\n[ensemble]\nmembers = {members}\nseed = 7\nsave = \"final\"\n\n[ensemble.vary]\ntheta = {{ uniform = [0.0, 6.283185307179586] }}\neta2 = {{ uniform = [-1.0, 1.0] }}\n"
    );
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Acceptance of issue 59: a 10⁴-member ensemble that must derive (`--no-store`) does so in
/// a worker process that exits; while its members run, another command starts the computer
/// algebra (`hamel derive`) and succeeds. (The ensemble is then ended: its result is tested
/// elsewhere.)
#[test]
fn an_ensemble_holds_no_licence_thread_while_its_members_run() {
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("ensemble_licence");
    let cache = super::code_cache();
    // the core compiled and cached by a small run of the same scene
    let small = knife_ensemble(&dir, "small.toml", 10, 400.0);
    let o = output(&["simulate", small.to_str().unwrap()], &cache);
    assert!(o.status.success(), "{}", stderr(&o));
    let big = knife_ensemble(&dir, "big.toml", 10_000, 4000.0);
    let out = dir.join("big.csv");
    let args = [
        "simulate",
        big.to_str().unwrap(),
        "--output",
        out.to_str().unwrap(),
        "--no-store",
    ];
    let mut ensemble = start(&args, &cache);
    let pid = ensemble.id();
    // the members run in the compiled core, a child started once the derivation is done
    let core = || {
        children(pid)
            .into_iter()
            .find(|(_, c)| c.contains("scene --progress"))
    };
    assert!(
        wait_until(Duration::from_secs(120), || core().is_some()),
        "the ensemble's members never started"
    );
    let derive = output(&["derive", "models/vertical_knife.toml"], &dir);
    let running = ensemble.try_wait().unwrap().is_none();
    // the ensemble, and its core, ended here: the test is about the thread, not the result
    if let Some((core, _)) = core() {
        unsafe { libc::kill(core, libc::SIGKILL) };
    }
    let _ = ensemble.kill();
    let done = ensemble.wait_with_output().unwrap();
    assert!(
        derive.status.success(),
        "a derivation while the ensemble runs: {}",
        stderr(&derive)
    );
    assert!(
        running,
        "the ensemble ended before the derivation: make it longer"
    );
    // the ensemble derived (--no-store): the computer algebra ran, in its worker
    assert!(String::from_utf8_lossy(&done.stdout).contains("Symbolica"));
}

/// Acceptance of issue 59: the store refuses what the code cache refuses. A cache another
/// user could write to is not used (a warning; the command still works, deriving in its own
/// process, and stores nothing); an entry another user owns is not read (a warning; derived
/// anew and replaced by one of ours); a model edited by one character is derived anew.
#[test]
fn the_store_trusts_only_its_own_entries() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let dir = scratch("store_trust");
    let states = dir.join("states.json");
    std::fs::write(
        &states,
        r#"{"q": {"x": 0.1, "y": 0.2, "theta": 0.3}, "eta": [1.0, 0.5]}"#,
    )
    .unwrap();
    let model = dir.join("knife.toml");
    let text = std::fs::read_to_string("models/knife.toml").unwrap();
    std::fs::write(&model, &text).unwrap();
    let eval = |cache: &Path| {
        let args = [
            "eval",
            model.to_str().unwrap(),
            "--state",
            states.to_str().unwrap(),
        ];
        let o = hamel_with_cache(&args, None, cache);
        assert!(o.status.success(), "{}", stderr(&o));
        o
    };
    let derived =
        |o: &std::process::Output| String::from_utf8_lossy(&o.stdout).contains("Symbolica");
    // world-writable: refused, nothing stored
    let open = dir.join("open");
    std::fs::create_dir_all(&open).unwrap();
    std::fs::set_permissions(&open, std::fs::Permissions::from_mode(0o777)).unwrap();
    let o = eval(&open);
    assert!(stderr(&o).contains("refusing the cache"), "{}", stderr(&o));
    assert!(!open.join("derivations").exists());
    let reference = json_on_stdout(&o);
    // another user's entry: refused, derived anew, replaced
    let cache = own_cache(&dir);
    assert!(derived(&eval(&cache)));
    assert!(!derived(&eval(&cache)), "stored: no computer algebra");
    let entries = || -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(cache.join("derivations"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        v.sort();
        v
    };
    let [entry] = &entries()[..] else {
        panic!("one entry: {:?}", entries())
    };
    if unsafe { libc::geteuid() } == 0 {
        std::os::unix::fs::chown(entry, Some(4242), Some(4242)).unwrap();
        let o = eval(&cache);
        assert!(stderr(&o).contains("owned by user 4242"), "{}", stderr(&o));
        assert!(derived(&o));
        assert_eq!(json_on_stdout(&o), reference);
        assert_eq!(std::fs::metadata(entry).unwrap().uid(), unsafe {
            libc::geteuid()
        });
    } else {
        eprintln!("skipped: another user's entry (needs root to make one)");
    }
    // writable by others: refused too
    std::fs::set_permissions(entry, std::fs::Permissions::from_mode(0o666)).unwrap();
    let o = eval(&cache);
    assert!(stderr(&o).contains("writable by others"), "{}", stderr(&o));
    assert!(derived(&o));
    // one character of the model changed (in a comment): a new key, derived anew
    std::fs::write(
        &model,
        text.replacen("# q = (x, y, theta)", "# q = (x, y, Theta)", 1),
    )
    .unwrap();
    let o = eval(&cache);
    assert!(
        derived(&o),
        "a model edited by one character is derived anew"
    );
    assert_eq!(json_on_stdout(&o), reference);
    assert_eq!(entries().len(), 2);
    // hamel store ls lists both, clear empties the store
    let ls = hamel_with_cache(&["store", "ls"], None, &cache);
    let listing = String::from_utf8_lossy(&ls.stdout);
    assert!(listing.contains("2 stored derivations, "), "{listing}");
    assert!(
        listing.contains("knife.toml") && listing.contains("choice paper"),
        "{listing}"
    );
    let clear = hamel_with_cache(&["store", "clear"], None, &cache);
    assert!(clear.status.success() && stderr(&clear).contains("removed 2"));
    assert!(entries().is_empty());
    the_store_keeps_to_its_limit(&cache, &model, &states);
}

/// Over `HAMEL_STORE_MAX_MB`, entries go (the least recently used first), never the one just
/// written.
fn the_store_keeps_to_its_limit(cache: &Path, knife: &Path, states: &Path) {
    let eval = |model: &Path, limit: &str| {
        let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
        let args = [
            "eval",
            model.to_str().unwrap(),
            "--state",
            states.to_str().unwrap(),
        ];
        let o = hamel_command(&args, cache)
            .env("HAMEL_STORE_MAX_MB", limit)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    };
    let names = || -> Vec<String> {
        let ls = hamel_with_cache(&["store", "ls"], None, cache);
        let text = String::from_utf8_lossy(&ls.stdout).to_string();
        assert!(text.contains("limit"), "{text}");
        text.lines()
            .filter(|l| l.contains(".derivation"))
            .map(String::from)
            .collect()
    };
    let knife_2 = knife.with_file_name("knife_2.toml");
    let text = std::fs::read_to_string(knife).unwrap();
    std::fs::write(&knife_2, text.replacen("# ", "# (a copy) ", 1)).unwrap();
    eval(knife, "1024");
    eval(&knife_2, "1024");
    assert_eq!(names().len(), 2);
    // A limit of zero at the next write: only the entry just written stays.
    std::fs::write(&knife_2, text.replacen("# ", "# (another copy) ", 1)).unwrap();
    eval(&knife_2, "0");
    let left = names();
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(left[0].contains("knife_2.toml"), "{left:?}");
}

/// `hamel eval … | head -c 1`: when the reader of stdout has gone before the deriving worker
/// prints the computer algebra's notice, the worker ends quietly and the command says why
/// (exit 1): no panic, no backtrace.
#[test]
fn a_closed_output_ends_the_deriving_worker_quietly() {
    let dir = scratch("store_closed_output");
    let cache = own_cache(&dir);
    let states = dir.join("s.json");
    std::fs::write(
        &states,
        r#"{"q": {"x": 0.1, "y": 0.2, "theta": 0.3}, "eta": [1.0, 0.5]}"#,
    )
    .unwrap();
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let args = [
        "eval",
        "models/knife.toml",
        "--state",
        states.to_str().unwrap(),
    ];
    let mut child = start(&args, &cache);
    drop(child.stdout.take()); // the reader has gone
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        status.code() == Some(1) && err.contains("the output was closed"),
        "{status:?}: {err}"
    );
}
