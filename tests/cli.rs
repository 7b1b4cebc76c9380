//! The `hamel` command as a user runs it.
//!
//! This test binary makes no computer-algebra calls in-process: it starts `hamel` processes,
//! one at a time (Symbolica, unlicensed, allows one instance per user at a time).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

#[path = "cli/ensembles.rs"]
mod ensembles;
#[path = "cli/latex.rs"]
mod latex;
#[path = "cli/smoke.rs"]
mod smoke;

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

/// Build a generated crate offline in its own target directory (no CAS involved) and check
/// that its lock file names no symbolica.
///
/// On the machine this was developed on `/dev/null` is a regular file: build scripts that send
/// a feature probe's stderr there (E0554 "`#![feature]` may not be used on the stable release
/// channel") leave that text in it, and a cold cargo's target-information probe
/// (`rustc - --print=file-names …`, which reads its source from /dev/null) then fails on it.
/// The nested target directory therefore starts with the outer build's cache of those probes
/// (`.rustc_info.json`: same rustc, same arguments; cargo re-probes if they differ). A failure
/// fails the test, naming a broken /dev/null when that is the cause.
fn build_generated(crate_dir: &Path, target: &Path) {
    static ONE_BUILD: Mutex<()> = Mutex::new(());
    let _guard = ONE_BUILD.lock().unwrap_or_else(|e| e.into_inner());
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
}

#[test]
fn derive_writes_json_to_a_file() {
    let dir = scratch("derive_json");
    let file = dir.join("knife.json");
    let o = hamel(
        &[
            "derive",
            "models/knife.toml",
            "--format",
            "json",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    for key in [
        "gamma",
        "theta",
        "delta",
        "a_gamma",
        "q",
        "q_paper",
        "q_correction",
        "equations",
        "singular_set",
        "kinematics",
        "energy",
        "checks",
    ] {
        assert!(d.get(key).is_some(), "missing `{key}`");
    }
    assert_eq!(d["gamma"].as_array().unwrap().len(), 3);
    assert_eq!(d["checks"]["paper_is_exact"], true);
    assert_eq!(d["checks"]["energy_conserved"], true);
    assert!(stderr(&o).contains("derived knife with quasi-velocities `paper`"));
}

#[test]
fn derive_json_on_stdout_parses_after_the_notice() {
    let o = hamel(
        &["derive", "models/chaplygin_sleigh.toml", "--format", "json"],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let d = json_on_stdout(&o);
    assert_eq!(d["checks"]["paper_is_exact"], false);
    assert_eq!(d["eta_name"], "paper_style");
    // Each object's size is reported, and is the size of what is printed.
    for key in ["gamma", "a_gamma", "q", "equations", "energy"] {
        let mut chars = 0;
        let mut count = |s: &serde_json::Value| chars += s.as_str().unwrap().chars().count();
        fn walk(v: &serde_json::Value, f: &mut dyn FnMut(&serde_json::Value)) {
            match v {
                serde_json::Value::Array(a) => a.iter().for_each(|x| walk(x, f)),
                s => f(s),
            }
        }
        walk(&d[key], &mut count);
        assert_eq!(d["sizes"][key]["characters"], chars, "{key}");
        assert!(d["sizes"][key]["operations"].as_u64().unwrap() > 0, "{key}");
    }
}

#[test]
fn derive_text_and_latex() {
    let o = hamel(
        &["derive", "models/bar_blade.toml", "--eta", "paper_z13"],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("equations of motion (true, from (9)):"));
    assert!(text.contains("free functions: z13(phi)"));
    let o = hamel(&["derive", "models/knife.toml", "--format", "latex"], None);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("\\begin{align*}"));
}

/// `hamel derive models/unicycle_rider.toml --eta velocities ARGS --output OUT`: what it wrote.
fn derive_unicycle(out: &Path, args: &[&str]) -> String {
    let mut all = vec![
        "derive",
        "models/unicycle_rider.toml",
        "--eta",
        "velocities",
    ];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--output", out.to_str().unwrap()]);
    let o = hamel(&all, None);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::read_to_string(out).unwrap()
}

/// The text, the JSON and the LaTeX document of one derivation use the same names for the
/// same groups (issue 22): the text's where-list is the JSON's, in order, and every name the
/// LaTeX where-list defines is one of them, under the same number.
#[test]
fn derive_text_json_and_latex_share_their_names() {
    let dir = scratch("shared_names");
    let run = |format: &str, file: &str| derive_unicycle(&dir.join(file), &["--format", format]);
    let text = run("text", "u.txt");
    let where_list: Vec<(String, String)> = text
        .split("\nwhere\n")
        .nth(1)
        .expect("a where-list")
        .lines()
        .map(|l| {
            let (name, def) = l.trim().split_once(" = ").unwrap();
            (name.to_string(), def.to_string())
        })
        .collect();
    assert!(where_list.len() >= 5, "{where_list:?}");
    let json: serde_json::Value = serde_json::from_str(&run("json", "u.json")).unwrap();
    let names: Vec<(String, String)> = json["printed"]["names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| {
            let args: Vec<&str> = n["args"]
                .as_array()
                .unwrap()
                .iter()
                .map(|a| a.as_str().unwrap())
                .collect();
            let name = n["name"].as_str().unwrap();
            let name = if args.is_empty() {
                name.to_string()
            } else {
                format!("{name}({})", args.join(", "))
            };
            (name, n["definition"].as_str().unwrap().to_string())
        })
        .collect();
    assert_eq!(names, where_list);
    // A canonical entry and its printed form: A[1,3] is −F(θ, θ₁) cos φ, a name of the list.
    let a13 = json["a"][0][2].as_str().unwrap();
    let printed = json["printed"]["entries"][a13].as_str().unwrap();
    assert!(
        printed.starts_with("-F") && printed.ends_with("*cos(phi)"),
        "{printed}"
    );
    let latex = run("latex", "u.tex");
    let defined = latex
        .split("\\noindent where")
        .nth(1)
        .expect("a LaTeX where-list");
    for line in defined.lines().filter(|l| l.contains("&=")) {
        let name = line.split("&=").next().unwrap().trim();
        let (letter, rest) = if let Some(r) = name.strip_prefix("\\kappa_{") {
            ("kappa", r)
        } else if let Some(r) = name.strip_prefix("F_{") {
            ("F", r)
        } else {
            // One of the model's [abbreviations], written as given (`m`).
            assert!(
                where_list.iter().any(|(n, _)| n == name),
                "{name} in the LaTeX is not in the text's where-list"
            );
            continue;
        };
        let number = rest.split('}').next().unwrap();
        let text_name = format!("{letter}{number}");
        assert!(
            where_list
                .iter()
                .any(|(n, _)| n == &text_name || n.starts_with(&format!("{text_name}("))),
            "{name} in the LaTeX is not {text_name} of the text"
        );
    }
}

/// The paper's section 3.4: the unicycle's matrix A (its upper triangle) and the definitions
/// under it, as the paper typesets them (Talamucci 2015, between (37) and (38)).
const PAPER_UNICYCLE_A: &str = "$$\\begin{pmatrix} m & 0 & -F_1 \\cos \\phi & 0 & -\\kappa_1 \\cos \\theta \\sin \\phi & -m_r \\ell \\cos \\theta_1 \\sin \\phi \\\\ m & -F_1 \\sin \\phi & 0 & \\kappa_1 \\cos \\theta \\cos \\phi & m_r \\ell \\cos \\theta_1 \\cos \\phi & \\\\ & F_2 & -I_d \\sin \\theta & 0 & 0 & \\\\ & & I_d & 0 & 0 & \\\\ & & & \\kappa_2 + \\frac{1}{2} I_d & \\kappa_3 \\cos(\\theta + \\theta_1) & \\\\ & & & & m_r \\ell^2 & \\end{pmatrix}$$";
const PAPER_UNICYCLE_DEFINITIONS: &str = "where  $m = m_d + m_f + m_r$ ,  $I_d = \\frac{1}{2} m_d R^2$ ,  $\\kappa_2 = m_f \\ell_1^2 + m_r(\\rho_1 + \\rho_2)^2 + m_d R$ ,  $\\kappa_3 = m_r \\rho(\\rho_1 + \\rho_2)$  and  $F_1(\\theta, \\theta_1) = (m_f \\rho_1 + m_r(\\rho_1 + \\rho_2) + m_d R) \\sin \\theta + m_r \\rho \\sin \\theta_1$ ,  $F_2(\\theta, \\theta_1) = \\left( \\frac{1}{2} I_d + m_d R^2 + m_f \\rho_1^2 + m_r(\\rho_1 + \\rho_2)^2 \\right) \\sin^2 \\theta + m_r \\rho^2 \\sin^2 \\theta_1 + 2m_r \\rho(\\rho_1 + \\rho_2) \\sin \\theta \\sin \\theta_1$ .";

/// Issue 22: the unicycle's A with its where-list is at most twice as long as the paper's
/// matrix with its definitions (lengths in printed glyphs, `hamel_print::width`), and each
/// entry of A is on one line.
#[test]
fn the_unicycles_a_with_its_names_is_at_most_twice_the_papers() {
    let out = scratch("unicycle_a").join("a.tex");
    let tex = derive_unicycle(&out, &["--format", "latex", "--fragment", "--only", "a"]);
    let body: Vec<&str> = tex
        .lines()
        .filter(|l| !l.starts_with('%') && !l.contains("{align*}") && !l.contains("noindent"))
        .collect();
    let ours: usize = body.iter().map(|l| hamel_print::width(l)).sum();
    let paper =
        hamel_print::width(PAPER_UNICYCLE_A) + hamel_print::width(PAPER_UNICYCLE_DEFINITIONS);
    assert!(
        ours <= 2 * paper,
        "A with its where-list: {ours} glyphs, the paper's {paper}\n{tex}"
    );
    let a = body[0];
    assert!(
        a.starts_with("A &= \\begin{pmatrix}") && a.ends_with("\\end{pmatrix}"),
        "{a}"
    );
    assert!(
        !body.iter().any(|l| l.starts_with("&\\quad")),
        "an entry broken over lines\n{tex}"
    );
    // The paper's F₁ cos φ and κ₁: a function of (θ, θ₁) times cos φ, and m_r(ρ₁ + ρ₂).
    assert!(a.contains("(\\theta, \\theta_{1}) \\cos \\varphi"), "{a}");
    assert!(
        tex.contains("m_{r} \\left(\\rho_{1} + \\rho_{2}\\right)"),
        "{tex}"
    );
    // `--only` belongs to the LaTeX output: with another format it is a usage error.
    let o = hamel(&["derive", "models/knife.toml", "--only", "a"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("use it with --format latex"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_bad_model_is_an_error_with_file_place_and_reason_and_writes_nothing() {
    let dir = scratch("bad_model");
    let out = dir.join("out.json");
    let o = hamel(
        &[
            "derive",
            "tests/filetests/unknown_symbol.toml",
            "--format",
            "json",
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains("tests/filetests/unknown_symbol.toml:11:16: constraints.no_slip: unknown symbol `thetta`"), "{err}");
    assert!(!out.exists(), "no output may be written on error");
    assert!(
        String::from_utf8_lossy(&o.stdout).find('{').is_none(),
        "no JSON on stdout on error"
    );
}

#[test]
fn an_unknown_choice_lists_the_available_ones() {
    let o = hamel(&["derive", "models/knife.toml", "--eta", "nope"], None);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("no quasi-velocity choice named `nope`") && err.contains("paper, general"),
        "{err}"
    );
}

#[test]
fn a_missing_file_is_an_error() {
    let o = hamel(&["derive", "models/does_not_exist.toml"], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("models/does_not_exist.toml: cannot read the file"));
}

#[test]
fn eval_gives_the_sleigh_equations() {
    let dir = scratch("eval");
    let state = dir.join("states.json");
    std::fs::write(
        &state,
        r#"[{"q": {"x": 0.1, "y": 0.2, "theta": 0.3}, "eta": [1.5, 0.5]},
            {"q": {"x": 0, "y": 0, "theta": 1}, "eta": [-1, 2], "params": {"m": 4}}]"#,
    )
    .unwrap();
    let out = dir.join("out.json");
    let o = hamel(
        &[
            "eval",
            "models/chaplygin_sleigh.toml",
            "--state",
            state.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let v = v.as_array().unwrap();
    assert_eq!(v.len(), 2);
    // m v̇ = m a ω² and (I + m a²) ω̇ = −m a v ω (defaults m = 2, I = 0.05, a = 0.2).
    let (a, i) = (0.2, 0.05);
    for (k, (m, vel, w)) in [(2.0, 1.5, 0.5), (4.0, -1.0, 2.0)].into_iter().enumerate() {
        let ed = &v[k]["eta_dot"];
        assert!((ed[0].as_f64().unwrap() - a * w * w).abs() < 1e-12);
        assert!((ed[1].as_f64().unwrap() + m * a * vel * w / (i + m * a * a)).abs() < 1e-12);
        // the paper's form misses the correction: v̇ = 0 there
        assert!(v[k]["eta_dot_paper"][0].as_f64().unwrap().abs() < 1e-12);
    }
    assert!((v[0]["q_dot"]["x"].as_f64().unwrap() - 1.5 * 0.3_f64.cos()).abs() < 1e-12);
    assert!(v[0]["energy"].as_f64().is_some());
}

#[test]
fn eval_reads_stdin_and_a_single_object() {
    let o = hamel(
        &["eval", "models/knife.toml", "--state", "-"],
        Some(r#"{"q": {"x": 0, "y": 0, "theta": 0.5}, "eta": [1, 2]}"#),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_on_stdout(&o);
    assert!(v.is_object());
    assert_eq!(v["eta_dot"].as_array().unwrap().len(), 2);
}

#[test]
fn eval_at_a_singular_state_names_the_state_and_writes_nothing() {
    let dir = scratch("eval_singular");
    let state = dir.join("states.json");
    // For the knife with eta = (der(x), der(theta)), det[Z; α] = cos(theta): singular at π/2.
    std::fs::write(
        &state,
        r#"[{"q": {"x": 0, "y": 0, "theta": 0.3}, "eta": [1, 1]},
            {"q": {"x": 0, "y": 0, "theta": 1.5707963267948966}, "eta": [1, 1]}]"#,
    )
    .unwrap();
    let out = dir.join("out.json");
    let o = hamel(
        &[
            "eval",
            "tests/filetests/singular_set_reported.toml",
            "--state",
            state.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("state 2: the quasi-velocity map is singular at this configuration"),
        "{err}"
    );
    assert!(
        err.contains("cos(theta) = 0") && err.contains("theta = 1.5707963267948966"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn eval_with_free_functions_needs_their_definitions() {
    let o = hamel(
        &[
            "eval",
            "models/knife.toml",
            "--eta",
            "general",
            "--state",
            "-",
        ],
        Some(r#"{"q": {"x": 0, "y": 0, "theta": 0.5}, "eta": [1, 2]}"#),
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("give them under \"functions\""),
        "{}",
        stderr(&o)
    );
    let o = hamel(
        &[
            "eval",
            "models/knife.toml",
            "--eta",
            "general",
            "--state",
            "-",
        ],
        Some(
            r#"{"q": {"x": 0, "y": 0, "theta": 0.5}, "eta": [1, 2], "functions": {"z11": "cos(theta)", "z12": "sin(theta)"}}"#,
        ),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // With z11 = cos θ, z12 = sin θ this is the paper's choice: free motion, η̇ = 0.
    let v = json_on_stdout(&o);
    assert!(
        v["eta_dot"][0].as_f64().unwrap().abs() < 1e-12
            && v["eta_dot"][1].as_f64().unwrap().abs() < 1e-12
    );
}

#[test]
fn eval_rejects_bad_states_clearly() {
    for (input, expect) in [
        (
            r#"{"q": {"x": 0, "y": 0}, "eta": [1, 2]}"#,
            "state 1: missing coordinate `theta`",
        ),
        (
            r#"{"q": {"x": 0, "y": 0, "theta": 0}, "eta": [1]}"#,
            "state 1: \"eta\" must have σ = 2 values, found 1",
        ),
        (
            r#"{"q": {"x": 0, "y": 0, "theta": 0}, "eta": [1, 2], "params": {"mass": 1}}"#,
            "state 1: unknown parameter `mass`",
        ),
        (
            r#"{"q": {"x": 0, "y": 0, "theta": 0}, "eta": [1, 2],}"#,
            "<stdin>:1:",
        ),
        (
            r#"[{"q": {"x": 0, "y": 0, "theta": 0}, "eta": [1, 2]}, {"eta": [1, 2]}]"#,
            "state 2: missing field `q`",
        ),
    ] {
        let o = hamel(&["eval", "models/knife.toml", "--state", "-"], Some(input));
        assert_eq!(o.status.code(), Some(1), "{input}");
        assert!(stderr(&o).contains(expect), "{input}: {}", stderr(&o));
    }
}

#[test]
fn search_writes_json_candidates_and_reports_progress() {
    let dir = scratch("search_json");
    let file = dir.join("knife.json");
    let o = hamel(
        &[
            "search",
            "models/knife.toml",
            "--eliminate",
            "x,y,theta",
            "--format",
            "json",
            "--progress",
            "always",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // Plain progress lines on a non-terminal stderr, ending with a summary.
    assert!(stderr(&o).contains("search: done,"), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let candidates = v["candidates"].as_array().unwrap();
    assert!(!candidates.is_empty());
    for c in candidates {
        assert!(c["name"].is_string());
        assert_eq!(c["eliminated"], serde_json::json!(["x", "y", "theta"]));
        assert!(c["free_functions"].is_array());
        let eta = c["eta"].as_array().unwrap();
        assert_eq!(eta.len(), 2);
        assert!(eta.iter().all(|e| e.as_str().unwrap().contains("der(")));
        // The TOML block is ready to paste: it parses and names the same rows.
        let t: toml::Value = toml::from_str(c["toml"].as_str().unwrap()).unwrap();
        let name = c["name"].as_str().unwrap();
        assert_eq!(
            t["quasi_velocities"][name]["eta"].as_array().unwrap().len(),
            2
        );
    }
    // The knife's z11 = cos θ, z12 = sin θ is among them.
    assert!(candidates.iter().any(|c| {
        c["eta"]
            .as_array()
            .unwrap()
            .iter()
            .any(|e| e == "cos(theta)*der(x) + sin(theta)*der(y)")
    }));
    assert_eq!(v["stop"]["reason"], "completed");
}

#[test]
fn search_honours_its_budget_and_rejects_a_bad_one() {
    let dir = scratch("search_budget");
    let file = dir.join("out.json");
    let args = |budget: &'static str| {
        vec![
            "search",
            "models/unicycle_rider.toml",
            "--eliminate",
            "xC,yC,phi,psi",
            "--format",
            "json",
            budget,
        ]
    };
    let mut a = args("--budget=0.05");
    a.extend(["--output", file.to_str().unwrap()]);
    let o = hamel(&a, None);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let reason = v["stop"]["reason"].as_str().unwrap();
    assert!(
        reason == "budget" || reason == "budget_during_check",
        "{reason}"
    );
    // Far fewer candidates generated than the full search (which generates over a hundred).
    let generated: u64 = v["families"]
        .as_object()
        .unwrap()
        .values()
        .map(|f| f["generated"].as_u64().unwrap())
        .sum();
    assert!(generated < 50, "{generated}");

    let _ = std::fs::remove_file(&file);
    let mut a = args("--budget=-1");
    a.extend(["--output", file.to_str().unwrap()]);
    let o = hamel(&a, None);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--budget must be a positive number"),
        "{}",
        stderr(&o)
    );
    assert!(!file.exists(), "no partial output");
}

#[test]
fn codegen_writes_a_crate_that_builds_offline_and_evaluates_like_hamel_eval() {
    let dir = scratch("codegen_knife");
    let out = dir.join("knife_core");
    let args = [
        "codegen",
        "models/knife.toml",
        "--eta",
        "paper",
        "--eliminate",
        "x,y",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = hamel(&args, None);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("operations as trees"), "{}", stderr(&o));
    let model_rs = std::fs::read_to_string(out.join("src/model.rs")).unwrap();
    assert!(model_rs.contains("pub const ELIMINATED: [usize; 2] = [0, 1];"));
    // A second run refuses to overwrite, --force overwrites.
    let o = hamel(&args, None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("not empty"), "{}", stderr(&o));
    let mut forced = args.to_vec();
    forced.push("--force");
    assert!(hamel(&forced, None).status.success());

    // It builds offline, with its own target directory, and needs no computer algebra.
    build_generated(&out, &dir.join("target"));

    let states = dir.join("states.json");
    std::fs::write(
        &states,
        r#"[{"q": {"x": 0.1, "y": 0.2, "theta": 0.3}, "eta": [1.0, 0.5]},
            {"q": {"x": -1, "y": 2, "theta": 2.2}, "eta": [-0.7, 1.5], "params": {"m": 2.5}}]"#,
    )
    .unwrap();
    let generated = Command::new(dir.join("target/release/eval"))
        .args(["--state", states.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(generated.status.success(), "{}", stderr(&generated));
    let reference = hamel(
        &[
            "eval",
            "models/knife.toml",
            "--eta",
            "paper",
            "--state",
            states.to_str().unwrap(),
        ],
        None,
    );
    let (g, mut r) = (json_on_stdout(&generated), json_on_stdout(&reference));
    // A generated core's `eval` prints the constraint forces (issue 58), not λ by row (the
    // knife's one row is its own force: the same number, under `constraint_forces`).
    for state in r.as_array_mut().unwrap() {
        let state = state.as_object_mut().unwrap();
        let pushes = state.remove("constraint_multipliers");
        assert!(pushes.is_some_and(|m| m.as_object().unwrap().len() == 1));
        assert!(state["constraint_forces"]["no_slip"].is_number());
    }
    // Same shape and keys in the same order; values to 1e-12.
    fn close(a: &serde_json::Value, b: &serde_json::Value) -> bool {
        use serde_json::Value::*;
        match (a, b) {
            (Number(x), Number(y)) => {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                (x - y).abs() <= 1e-12 * y.abs().max(1.0)
            }
            (Array(x), Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(a, b)| close(a, b)),
            (Object(x), Object(y)) => {
                x.keys().eq(y.keys()) && x.iter().zip(y).all(|((_, a), (_, b))| close(a, b))
            }
            _ => a == b,
        }
    }
    assert!(close(&g, &r), "generated {g}\nhamel eval {r}");

    // A bad state: an error naming the state, nothing on stdout.
    std::fs::write(&states, r#"{"q": {"x": 0, "y": 0}, "eta": [1, 2]}"#).unwrap();
    let bad = Command::new(dir.join("target/release/eval"))
        .args(["--state", states.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
    assert!(
        stderr(&bad).contains("state 1: missing coordinate `theta`"),
        "{}",
        stderr(&bad)
    );
    assert!(bad.stdout.is_empty());
}

#[test]
fn codegen_refuses_an_elimination_that_does_not_hold() {
    let dir = scratch("codegen_refuses");
    let out = dir.join("core");
    let o = hamel(
        &[
            "codegen",
            "models/vertical_knife.toml",
            "--eliminate",
            "theta",
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("do not eliminate theta"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "no partial output");
}

#[test]
fn simulate_the_knife_follows_its_closed_form_solution() {
    let dir = scratch("simulate_knife");
    let file = dir.join("knife.json");
    let o = hamel(
        &[
            "simulate",
            "scenes/knife.toml",
            "--format",
            "json",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("RHS evaluations, energy drift"),
        "{}",
        stderr(&o)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(v["complete"], true);
    let t = v["t"].as_array().unwrap();
    assert_eq!(t.len(), 101);
    // With η = (1, 0.5) constant: θ = 0.3 + t/2, x = 2(sin θ − sin 0.3), y = −2(cos θ − cos 0.3).
    for (j, tj) in t.iter().enumerate() {
        let tj = tj.as_f64().unwrap();
        let th = 0.3 + 0.5 * tj;
        let at = |c: &str| v["q"][c][j].as_f64().unwrap();
        assert!((at("theta") - th).abs() < 1e-9);
        assert!((at("x") - 2.0 * (th.sin() - 0.3f64.sin())).abs() < 1e-9);
        assert!((at("y") + 2.0 * (th.cos() - 0.3f64.cos())).abs() < 1e-9);
    }
    let stats = &v["stats"];
    assert!(stats["steps"].as_u64().unwrap() > 0);
    // --plot: an SVG with both panels and the coordinate names; a bad extension is refused.
    let svg = dir.join("knife.svg");
    let o = hamel(
        &[
            "simulate",
            "scenes/knife.toml",
            "--output",
            dir.join("k.csv").to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg"));
    for label in ["quasi-velocities", "theta", "eta2"] {
        assert!(text.contains(label), "{label} missing from the plot");
    }
    let o = hamel(
        &["simulate", "scenes/knife.toml", "--plot", "/tmp/x.pdf"],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(".svg or .png"), "{}", stderr(&o));
    assert!(stats["energy_drift"].as_f64().unwrap() < 1e-12);
    // Not requested: α(q)Γ(q)η is identically zero, computed only when named.
    assert!(stats["constraint_drift"].is_null(), "{stats}");
}

#[test]
fn simulate_stops_at_the_singular_set_and_keeps_what_it_computed() {
    let dir = scratch("simulate_singular");
    let scene = dir.join("bar.toml");
    std::fs::write(
        &scene,
        format!(
            "model = {:?}\neta = \"paper\"\nt_end = 2.0\noutputs = 21\n\
             [initial]\nq = {{ x = 0.0, y = 0.0, theta = 0.0, phi = 1.3 }}\neta = [0.5, 1.0]\n",
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("models/bar_blade.toml")
                .display()
                .to_string()
        ),
    )
    .unwrap();
    let csv = dir.join("bar.csv");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--output",
            csv.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("singular"), "{e}");
    assert!(e.contains("phi = 1.570796"), "{e}");
    // On the way it warns how close the path came: the condition number of [Z; α].
    assert!(
        e.contains("warning: the path comes near the singular set")
            && e.contains("condition number of [Z; α] reaches"),
        "{e}"
    );
    assert!(e.contains("INCOMPLETE"), "{e}");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("# incomplete:"), "{text}");
    // Rows up to the singularity (φ reaches π/2 near t = 0.3): t = 0, 0.1, 0.2.
    assert_eq!(text.lines().count(), 5, "{text}");
}

#[test]
fn simulate_rejects_a_bad_scene_with_the_place_and_reason() {
    let dir = scratch("simulate_bad");
    let scene = dir.join("bad.toml");
    let csv = dir.join("out.csv");
    for (body, expect) in [
        (
            "model = \"../../../../models/knife.toml\"\nt_end = 1\noutputs = 3\n[initial]\nq = { x = 0, y = 0 }\neta = [1, 0]\n",
            "missing coordinate `theta`",
        ),
        (
            "model = \"../../../../models/knife.toml\"\nt_end = 1\noutputs = 3\n[initial]\nq = { x = 0, y = 0, theta = 0 }\neta = [1, 0]\n[integrator]\nmethod = \"euler\"\n",
            "unknown variant `euler`, expected one of `rk4`, `dopri5`, `dop853`, `vern9`, `gauss-legendre`",
        ),
        (
            "model = \"../../../../models/knife.toml\"\nt_end = 1\noutputs = 3\nspeed = 2\n",
            "unknown field `speed`",
        ),
    ] {
        std::fs::write(&scene, body).unwrap();
        let o = hamel(
            &[
                "simulate",
                scene.to_str().unwrap(),
                "--output",
                csv.to_str().unwrap(),
            ],
            None,
        );
        assert_eq!(o.status.code(), Some(1), "{body}");
        assert!(stderr(&o).contains(expect), "{body}: {}", stderr(&o));
        assert!(stderr(&o).contains("bad.toml"), "{}", stderr(&o));
        assert!(!csv.exists(), "no output for a bad scene");
    }
}

#[test]
fn codegen_with_simulator_integrates_the_knife_without_the_cas() {
    let dir = scratch("codegen_simulator");
    let out = dir.join("knife_sim");
    let o = hamel(
        &[
            "codegen",
            "models/knife.toml",
            "--eta",
            "paper",
            "--eliminate",
            "x,y",
            "--with-simulator",
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    build_generated(&out, &dir.join("target"));
    let state = dir.join("state.json");
    std::fs::write(
        &state,
        r#"{"q": {"x": 0, "y": 0, "theta": 0.3}, "eta": [1.0, 0.5]}"#,
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "--state",
            state.to_str().unwrap(),
            "--t-end",
            "10",
            "--outputs",
            "11",
        ];
        args.extend(extra);
        let o = Command::new(dir.join("target/release/simulate"))
            .args(&args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        json_on_stdout(&o)
    };
    // Full: θ = 0.3 + t/2, x = 2(sin θ − sin 0.3) at t = 10.
    let v = run(&[]);
    let th = 0.3 + 5.0_f64;
    assert!((v["q"]["theta"][10].as_f64().unwrap() - th).abs() < 1e-9);
    assert!((v["q"]["x"][10].as_f64().unwrap() - 2.0 * (th.sin() - 0.3f64.sin())).abs() < 1e-9);
    assert_eq!(v["complete"], true);
    // Reduced: only θ and η are integrated.
    let v = run(&["--reduced", "--method", "gauss-legendre"]);
    let q = v["q"].as_object().unwrap();
    assert_eq!(q.keys().collect::<Vec<_>>(), vec!["theta"]);
    assert!((v["q"]["theta"][10].as_f64().unwrap() - th).abs() < 1e-9);
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

#[test]
fn plan_integrates_only_what_the_scene_requests() {
    let dir = scratch("plan");
    let plan = |top: &str| {
        let scene = knife_scene(&dir, "k.toml", top, "");
        let o = hamel(&["plan", scene.to_str().unwrap(), "--format", "json"], None);
        assert!(o.status.success(), "{}", stderr(&o));
        json_on_stdout(&o)
    };
    let names = |v: &serde_json::Value| -> Vec<String> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|s| s.as_str().unwrap().to_string())
            .collect()
    };
    // The knife's equations (η̇ = 0) contain no coordinate: only η is integrated.
    let p = plan("request = [\"theta\", \"eta\"]");
    assert_eq!(names(&p["integrated"]), ["eta1", "eta2"]);
    assert_eq!(names(&p["reconstructed"]), ["theta"]);
    assert_eq!(names(&p["dropped"]), ["x", "y"]);
    assert_eq!(p["eta"], "paper");
    assert!(p["ops"].as_u64().unwrap() < p["ops_full"].as_u64().unwrap());
    // x needs θ (ẋ = η1 cos θ): both are reconstructed, y is dropped.
    let p = plan("request = [\"x\"]");
    assert_eq!(names(&p["reconstructed"]), ["x", "theta"]);
    assert_eq!(names(&p["dropped"]), ["y"]);
    // Everything by default.
    let p = plan("");
    assert_eq!(names(&p["reconstructed"]), ["x", "y", "theta"]);
    assert!(names(&p["dropped"]).is_empty());
    // The unicycle's dynamics need θ and θ1; asking for θ alone drops the rolling coordinates.
    let scene = dir.join("u.toml");
    std::fs::write(
        &scene,
        std::fs::read_to_string("scenes/unicycle_rider.toml")
            .unwrap()
            .replace(
                "../models/",
                &format!("{}/models/", env!("CARGO_MANIFEST_DIR")),
            )
            .replace("[initial]", "request = [\"theta\"]\n[initial]"),
    )
    .unwrap();
    let o = hamel(&["plan", scene.to_str().unwrap(), "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let p = json_on_stdout(&o);
    assert_eq!(
        names(&p["integrated"]),
        ["theta", "theta1", "eta1", "eta2", "eta3", "eta4"]
    );
    assert!(names(&p["reconstructed"]).is_empty());
    assert_eq!(names(&p["dropped"]), ["xC", "yC", "phi", "psi"]);
}

#[test]
fn simulate_with_a_request_writes_only_that_and_agrees_with_the_closed_form() {
    let dir = scratch("simulate_request");
    let scene = knife_scene(
        &dir,
        "k.toml",
        "request = [\"theta\"]",
        "[accuracy]\nrtol = 1e-11\natol = 1e-12\n",
    );
    let file = dir.join("k.json");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--format",
            "json",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let q = v["q"].as_object().unwrap();
    assert_eq!(q.keys().collect::<Vec<_>>(), ["theta"]);
    assert!(v.get("eta").is_none() && v.get("energy").is_none(), "{v}");
    for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
        let th = 0.3 + 0.5 * t.as_f64().unwrap();
        assert!((v["q"]["theta"][j].as_f64().unwrap() - th).abs() < 1e-9);
    }
    // CSV: the header names only what was requested.
    let o = hamel(&["simulate", scene.to_str().unwrap()], None);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("\nt,theta\n"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
}

/// A requested constraint residual is a column at every output (JSON and CSV), rounding only
/// (αΓ = 0), and its largest value is the reported drift.
#[test]
fn simulate_writes_a_requested_constraint_residual_at_every_output() {
    let dir = scratch("simulate_residual");
    let scene = knife_scene(
        &dir,
        "k.toml",
        "request = [\"theta\", \"constraint_residual\"]",
        "",
    );
    let file = dir.join("k.json");
    let args = [
        "simulate",
        scene.to_str().unwrap(),
        "--format",
        "json",
        "--output",
    ];
    let o = hamel(&[&args[..], &[file.to_str().unwrap()]].concat(), None);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let residual: Vec<f64> = v["constraint_residual"]
        .as_array()
        .unwrap_or_else(|| panic!("no constraint_residual in {v}"))
        .iter()
        .map(|r| r.as_f64().unwrap())
        .collect();
    assert_eq!(residual.len(), v["t"].as_array().unwrap().len());
    assert!(
        residual.iter().all(|r| (0.0..1e-15).contains(r)),
        "{residual:?}"
    );
    let largest = residual.iter().copied().fold(0.0, f64::max);
    assert_eq!(v["stats"]["constraint_drift"].as_f64(), Some(largest));
    let o = hamel(&["simulate", scene.to_str().unwrap()], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = String::from_utf8_lossy(&o.stdout);
    assert!(csv.contains("\nt,theta,constraint_residual\n"), "{csv}");
}

#[test]
fn a_bad_request_or_accuracy_is_an_error_naming_the_scene() {
    let dir = scratch("simulate_bad_request");
    let out = dir.join("out.csv");
    for (top, tables, expect) in [
        (
            "request = [\"speed\"]",
            "",
            "`speed` is not an output of this scene",
        ),
        (
            "",
            "[accuracy]\nrtol = 1e-8\natol = 1e-10\n[integrator]\nmethod = \"rk4\"\nstep = 0.1\n",
            "not both",
        ),
    ] {
        let scene = knife_scene(&dir, "bad.toml", top, tables);
        for cmd in ["plan", "simulate"] {
            let o = hamel(
                &[
                    cmd,
                    scene.to_str().unwrap(),
                    "--output",
                    out.to_str().unwrap(),
                ],
                None,
            );
            assert_eq!(o.status.code(), Some(1), "{cmd} {top} {tables}");
            assert!(stderr(&o).contains(expect), "{}", stderr(&o));
            assert!(stderr(&o).contains("bad.toml"), "{}", stderr(&o));
            assert!(!out.exists(), "no output for a bad scene");
        }
    }
}

/// Initial velocities given as q̇ are projected onto the constraints in the kinetic metric (for
/// the knife: the sideways component of the velocity of the contact point is removed, θ̇ is
/// kept), the correction is reported, and the run starts from η = Z q̇.
#[test]
fn simulate_projects_initial_velocities_given_as_q_dot() {
    let dir = scratch("simulate_q_dot");
    let scene = dir.join("k.toml");
    std::fs::write(
        &scene,
        knife_scene_text("request = [\"x\", \"y\", \"theta\"]").replace(
            "eta = [1.0, 0.5]",
            "q_dot = { x = 1.0, y = 0.5, theta = 0.5 }",
        ),
    )
    .unwrap();
    let file = dir.join("k.json");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--format",
            "json",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("projected onto the constraints"),
        "{}",
        stderr(&o)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let p = &v["initial_projection"];
    let (s, c) = 0.3f64.sin_cos();
    let side = s * 1.0 - c * 0.5; // n·v with n = (sin θ, −cos θ)
    let expect = [1.0 - side * s, 0.5 + side * c, 0.5];
    for (k, name) in ["x", "y", "theta"].iter().enumerate() {
        assert!(
            (p["q_dot"][name].as_f64().unwrap() - expect[k]).abs() < 1e-12,
            "{p}"
        );
    }
    assert!(
        (p["correction"].as_f64().unwrap() - side.abs() * c).abs() < 1e-12,
        "{p}"
    );
    assert!(p["kinetic_after"].as_f64().unwrap() < p["kinetic_before"].as_f64().unwrap());
    // The forward speed is the tangential one: x = u (sin θ − sin 0.3)/θ̇ …
    let u = c * 1.0 + s * 0.5;
    for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
        let th = 0.3 + 0.5 * t.as_f64().unwrap();
        let at = |n: &str| v["q"][n][j].as_f64().unwrap();
        assert!((at("theta") - th).abs() < 1e-9);
        assert!((at("x") - 2.0 * u * (th.sin() - s)).abs() < 1e-8);
        assert!((at("y") + 2.0 * u * (th.cos() - c)).abs() < 1e-8);
    }
    // Both, or neither, is an error.
    for (body, expect) in [
        (
            knife_scene_text("").replace(
                "eta = [1.0, 0.5]",
                "eta = [1.0, 0.5]\nq_dot = { x = 1.0, y = 0.0, theta = 0.0 }",
            ),
            "not both",
        ),
        (
            knife_scene_text("").replace("eta = [1.0, 0.5]", "q_dot = { x = 1.0, theta = 0.0 }"),
            "missing the velocity of `y`",
        ),
    ] {
        std::fs::write(&scene, body).unwrap();
        let o = hamel(&["simulate", scene.to_str().unwrap()], None);
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains(expect), "{}", stderr(&o));
    }
}

#[test]
fn tradeoff_measures_every_integrator_and_recommends_one_that_meets_the_target() {
    let dir = scratch("tradeoff");
    let json = dir.join("t.json");
    let svg = dir.join("t.svg");
    let o = hamel(
        &[
            "tradeoff",
            "scenes/knife.toml",
            "--format",
            "json",
            "--output",
            json.to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(
        t["reference_check"].as_f64().unwrap() < 1e-12,
        "{}",
        t["reference_check"]
    );
    let rows = t["rows"].as_array().unwrap();
    for m in ["dop853", "dopri5", "rk4", "gauss-legendre"] {
        assert!(rows.iter().any(|r| r["method"] == m), "{m} missing");
    }
    // DOP853's error falls as its tolerance tightens (1e-5 against 1e-12).
    let err = |tol: f64| {
        rows.iter()
            .find(|r| r["method"] == "dop853" && r["tol"].as_f64() == Some(tol))
            .unwrap()["error_span"]
            .as_f64()
            .unwrap()
    };
    assert!(
        err(1e-12) < 1e-3 * err(1e-5),
        "{} {}",
        err(1e-12),
        err(1e-5)
    );
    // The recommendation meets the target (the scene's 1e-10 / 1e-12) and is the fastest that does.
    let rec = &rows[t["recommended"].as_u64().unwrap() as usize];
    assert!(rec["target_ratio"].as_f64().unwrap() <= 1.0);
    let fastest = rows
        .iter()
        .filter(|r| r["complete"] == true && r["target_ratio"].as_f64().unwrap() <= 1.0)
        .map(|r| r["seconds"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert_eq!(rec["seconds"].as_f64().unwrap(), fastest);
    assert_eq!(
        t["engine"], "compiled",
        "timed on the scene's core by default"
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("work–precision") && text.contains("dop853"));
}

#[test]
fn tradeoff_exports_the_planned_system_for_scipy_timed_on_the_compiled_core() {
    let dir = scratch("tradeoff_export");
    let json = dir.join("knife.json");
    let o = hamel(
        &[
            "tradeoff",
            "scenes/knife.toml",
            "--export-python",
            json.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["engine"], "compiled", "timed on the scene's core");
    let times = v["times"].as_array().unwrap().len();
    assert_eq!(v["reference"].as_array().unwrap().len(), times);
    let rows = v["hamel"].as_array().unwrap();
    assert!(rows.iter().any(|r| r["method"] == "dop853"));
    assert!(
        rows.iter()
            .all(|r| r["seconds"].as_f64().unwrap() > 0.0 && r["rhs_evals"].as_u64().unwrap() > 0)
    );
    // The Python right-hand side is the knife's (x, y, θ, η₁, η₂)' = (η₁ cos θ, η₁ sin θ, η₂, 0, 0)
    // at the initial state; checked with python3 when it is installed.
    let script = format!(
        "from math import *\n{}\nimport json\nprint(json.dumps(rhs(0.0, {})))\n",
        v["python"].as_str().unwrap(),
        v["y0"]
    );
    match Command::new("python3").arg("-c").arg(&script).output() {
        Ok(p) if p.status.success() => {
            let f: Vec<f64> = serde_json::from_slice(&p.stdout).unwrap();
            let y0: Vec<f64> = serde_json::from_value(v["y0"].clone()).unwrap();
            let (th, e1, e2) = (y0[2], y0[3], y0[4]);
            let want = [e1 * th.cos(), e1 * th.sin(), e2, 0.0, 0.0];
            for (a, b) in f.iter().zip(want) {
                assert!((a - b).abs() <= 1e-15, "{f:?} against {want:?}");
            }
        }
        _ => eprintln!("python3 not available: the exported function is not evaluated"),
    }
}

#[test]
fn simulate_with_only_an_accuracy_target_uses_the_recommended_setting() {
    let dir = scratch("simulate_accuracy");
    let scene = knife_scene(&dir, "k.toml", "", "[accuracy]\nrtol = 1e-6\natol = 1e-8\n");
    let o = hamel(
        &["simulate", scene.to_str().unwrap(), "--format", "json"],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("accuracy rtol = 1e-6, atol = 1e-8: using "),
        "{e}"
    );
    let v = json_on_stdout(&o);
    // The closed form, to the target.
    for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
        let th = 0.3 + 0.5 * t.as_f64().unwrap();
        let x = 2.0 * (th.sin() - 0.3f64.sin());
        assert!((v["q"]["x"][j].as_f64().unwrap() - x).abs() <= 1e-8 + 1e-6 * x.abs());
    }
    // A target below what f64 allows is refused clearly rather than attempted.
    let scene = knife_scene(&dir, "k.toml", "", "[accuracy]\nrtol = 0.0\natol = 1e-8\n");
    let o = hamel(&["simulate", scene.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("rtol must be in (0, 1)"),
        "{}",
        stderr(&o)
    );
    // 1e-15 is below what f64 allows: a clear message, no output, no attempt.
    let scene = knife_scene(
        &dir,
        "k.toml",
        "",
        "[accuracy]\nrtol = 1e-15\natol = 1e-15\n",
    );
    let out = dir.join("out.csv");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("below what f64 arithmetic can deliver"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

/// A loose tolerance still returns the trajectory, with its global error estimated by a check
/// run (and said on stderr); `--estimate-error` does the same for any setting. The estimate is
/// compared with the knife's true error (closed form: θ = θ₀ + η₂t, x = (η₁/η₂)(sin θ − sin θ₀),
/// y = −(η₁/η₂)(cos θ − cos θ₀)).
#[test]
fn loose_tolerances_return_a_result_with_its_error_estimate() {
    let dir = scratch("loose");
    let true_error = |v: &serde_json::Value| {
        let mut e = 0.0_f64;
        for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
            let th = 0.3 + 0.5 * t.as_f64().unwrap();
            let exact = [
                ("x", 2.0 * (th.sin() - 0.3f64.sin())),
                ("y", -2.0 * (th.cos() - 0.3f64.cos())),
                ("theta", th),
            ];
            for (name, x) in exact {
                let got = v["q"][name][j].as_f64().unwrap();
                e = e.max((got - x).abs() / x.abs().max(1.0));
            }
        }
        e
    };
    for (integrator, flag, loose) in [
        ("method = \"dop853\"\nrtol = 0.1\natol = 0.1\n", None, true),
        (
            "method = \"dopri5\"\nrtol = 1e-2\natol = 1e-2\n",
            None,
            true,
        ),
        (
            "method = \"rk4\"\nstep = 0.25\n",
            Some("--estimate-error"),
            false,
        ),
    ] {
        let scene = knife_scene(&dir, "k.toml", "", &format!("[integrator]\n{integrator}"));
        let mut args = vec!["simulate", scene.to_str().unwrap(), "--format", "json"];
        args.extend(flag);
        let o = hamel(&args, None);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(stderr(&o).contains("is loose"), loose, "{}", stderr(&o));
        let v = json_on_stdout(&o);
        assert_eq!(v["complete"], true);
        let estimate = v["stats"]["error_estimate"].as_f64().expect("an estimate");
        let truth = true_error(&v);
        assert!(
            truth > 1e-9,
            "{integrator}: the run is not loose ({truth:e})"
        );
        assert!(
            (0.5 * truth..=2.0 * truth).contains(&estimate),
            "{integrator}: estimate {estimate:e}, true error {truth:e}"
        );
    }
    // Without the flag, a tight run is not checked twice.
    let scene = knife_scene(&dir, "k.toml", "", "");
    let o = hamel(
        &["simulate", scene.to_str().unwrap(), "--format", "json"],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(json_on_stdout(&o)["stats"].get("error_estimate").is_none());
}

/// `[expressions]`: named outputs of the coordinates, parameters and η. Requested, they are
/// evaluated at the output times with the scene's parameter values, and the coordinates they
/// need are kept in the state (reconstructed) while the others are dropped; bad ones are
/// refused with the key and the reason.
#[test]
fn scene_expressions_are_outputs_and_plan_what_they_need() {
    let dir = scratch("expressions");
    let tables = "[parameters]\nm = 3.0\n[expressions]\nahead = \"x + m*cos(theta)/10\"\nspeed2 = \"eta1^2\"\nside = \"y\"\n";
    let scene = knife_scene(&dir, "k.toml", "request = [\"ahead\", \"speed2\"]", tables);
    let o = hamel(&["plan", scene.to_str().unwrap(), "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let p = json_on_stdout(&o);
    // x and θ are needed by `ahead` (reconstructed); y by nothing requested (dropped).
    assert_eq!(p["reconstructed"], serde_json::json!(["x", "theta"]));
    assert_eq!(p["dropped"], serde_json::json!(["y"]));
    assert_eq!(p["expressions"]["ahead"], serde_json::json!(["x", "theta"]));
    assert!(p["expressions"].get("side").is_none(), "not requested");
    let o = hamel(
        &["simulate", scene.to_str().unwrap(), "--format", "json"],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_on_stdout(&o);
    assert!(
        v["q"].as_object().unwrap().is_empty(),
        "no coordinate requested"
    );
    let ahead = v["expressions"]["ahead"].as_array().unwrap();
    let speed2 = v["expressions"]["speed2"].as_array().unwrap();
    assert!(v["expressions"].get("side").is_none());
    for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
        let th = 0.3 + 0.5 * t.as_f64().unwrap();
        let want = 2.0 * (th.sin() - 0.3f64.sin()) + 3.0 * th.cos() / 10.0;
        assert!((ahead[j].as_f64().unwrap() - want).abs() < 1e-9, "t = {t}");
        assert!((speed2[j].as_f64().unwrap() - 1.0).abs() < 1e-12);
    }
    // CSV columns.
    let o = hamel(&["simulate", scene.to_str().unwrap()], None);
    assert!(String::from_utf8_lossy(&o.stdout).contains("t,ahead,speed2\n"));
    // Bad expressions: the scene file, the key and the reason; nothing written.
    for (table, key, reason) in [
        ("bad = \"x + zz\"", "expressions.bad", "unknown name `zz`"),
        ("theta = \"x\"", "expressions.theta", "already a coordinate"),
        ("v = \"der(x)\"", "expressions.v", "`der(x)`"),
        ("w = \"x +\"", "expressions.w", "cannot parse"),
    ] {
        let scene = knife_scene(&dir, "bad.toml", "", &format!("[expressions]\n{table}\n"));
        let out = dir.join("bad.csv");
        let o = hamel(
            &[
                "simulate",
                scene.to_str().unwrap(),
                "--output",
                out.to_str().unwrap(),
            ],
            None,
        );
        assert_eq!(o.status.code(), Some(1), "{table}");
        let e = stderr(&o);
        assert!(
            e.contains("bad.toml") && e.contains(key) && e.contains(reason),
            "{table}: {e}"
        );
        assert!(!out.exists());
    }
    let scene = knife_scene(&dir, "bad.toml", "request = [\"nope\"]", tables);
    let o = hamel(&["plan", scene.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("or an expression (ahead, speed2, side)"),
        "{}",
        stderr(&o)
    );
}

/// Every bundled scene is valid: it plans, and its plan integrates η.
#[test]
fn every_bundled_scene_plans() {
    let mut n = 0;
    for entry in std::fs::read_dir("scenes").unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let o = hamel(&["plan", path.to_str().unwrap(), "--format", "json"], None);
        assert!(o.status.success(), "{}: {}", path.display(), stderr(&o));
        let p = json_on_stdout(&o);
        assert!(
            p["integrated"]
                .as_array()
                .unwrap()
                .iter()
                .any(|s| s == "eta1")
        );
        n += 1;
    }
    assert!(n >= 8, "a scene per bundled model");
}

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
fn plan_measure_compares_the_plan_with_the_full_system() {
    let o = hamel(
        &[
            "plan",
            "scenes/bar_wheels.toml",
            "--format",
            "json",
            "--measure",
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_on_stdout(&o);
    let m = &v["measured"];
    // φ, η1, η2 against x, y, θ, ψ1, φ, η1, η2.
    assert_eq!(m["states"], serde_json::json!([3, 7]));
    assert!(m["ops"][0].as_u64().unwrap() < m["ops"][1].as_u64().unwrap());
    assert!(m["max_difference"].as_f64().unwrap() < 1e-8, "{m}");
    for i in 0..2 {
        assert!(m["seconds"][i].as_f64().unwrap() > 0.0, "{m}");
        assert!(m["rhs_evals"][i].as_u64().unwrap() > 0, "{m}");
    }
}

#[test]
fn eta_auto_takes_a_regular_reducing_choice_from_the_search() {
    let dir = scratch("eta_auto");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/knife.toml");
    let scene = |name: &str, initial: &str| {
        let path = dir.join(name);
        std::fs::write(
            &path,
            format!(
                "model = {:?}\neta = \"auto\"\nrequest = [\"theta\", \"eta\"]\nt_end = 10.0\noutputs = 11\n\
                 [initial]\nq = {{ x = 0.0, y = 0.0, theta = 0.3 }}\n{initial}\n",
                model.display().to_string()
            ),
        )
        .unwrap();
        path
    };
    let good = scene("auto.toml", "q_dot = { x = 0.95, y = 0.3, theta = 0.5 }");
    let o = hamel(&["plan", good.to_str().unwrap(), "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("eta = auto: using") && e.contains("regular everywhere"),
        "{e}"
    );
    let plan = json_on_stdout(&o);
    assert_eq!(plan["dropped"], serde_json::json!(["x", "y"]));
    assert_ne!(plan["eta"], "paper");
    let out = dir.join("auto.json");
    let o = hamel(
        &[
            "simulate",
            good.to_str().unwrap(),
            "--format",
            "json",
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    // The sideways velocity is removed by the projection; θ̇ = 0.5 stays: θ(10) = 5.3.
    let theta = v["q"]["theta"]
        .as_array()
        .unwrap()
        .last()
        .unwrap()
        .as_f64()
        .unwrap();
    assert!((theta - 5.3).abs() < 1e-9, "{theta}");
    // η of a choice not yet made cannot be given.
    let bad = scene("bad.toml", "eta = [1.0, 0.5]");
    let o = hamel(&["plan", bad.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("bad.toml") && e.contains("initial.eta") && e.contains("q_dot"),
        "{e}"
    );
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

#[test]
fn a_model_file_name_cannot_inject_code_into_a_generated_crate() {
    use std::os::unix::ffi::OsStrExt;
    let dir = scratch("hostile_name");
    let knife = std::fs::read_to_string("models/knife.toml").unwrap();
    // The reproduction of the issue, and a name that is not UTF-8 with a raw-string end.
    let names = [
        std::ffi::OsString::from(INJECTING_NAME),
        std::ffi::OsStr::from_bytes(b"k\xff\"#*\nfn injected_by_filename() {}\n.toml").to_owned(),
    ];
    for (i, name) in names.iter().enumerate() {
        let model = dir.join(name);
        std::fs::write(&model, &knife).unwrap();
        let out = dir.join(format!("out{i}"));
        let args: Vec<&std::ffi::OsStr> = vec![
            "codegen".as_ref(),
            model.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ];
        let o = hamel_with_cache(&args, None, &code_cache());
        assert!(o.status.success(), "{}", stderr(&o));
        let fns = functions(&out.join("src/model.rs"));
        assert!(!fns.iter().any(|f| f == "injected_by_filename"), "{fns:?}");
        assert!(fns.iter().any(|f| f == "full_rhs"), "{fns:?}");
        let text = std::fs::read_to_string(out.join("src/model.rs")).unwrap();
        assert!(
            text.contains("\\nfn injected_by_filename() {}\\n"),
            "the name is shown, escaped"
        );
    }
    // A scene of that model: its cached core is generated with the model's path in it.
    let model = dir.join(INJECTING_NAME);
    let scene = dir.join("scene.toml");
    let text = knife_scene_text("").replace(
        &format!(
            "{:?}",
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("models/knife.toml")
                .display()
                .to_string()
        ),
        &toml::Value::String(model.display().to_string()).to_string(),
    );
    std::fs::write(&scene, text).unwrap();
    let o = hamel(&["plan", scene.to_str().unwrap(), "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let code = PathBuf::from(json_on_stdout(&o)["code"].as_str().unwrap());
    let fns = functions(&code.join("src/model.rs"));
    assert!(!fns.iter().any(|f| f == "injected_by_filename"), "{fns:?}");
    let manifest: toml::Table = std::fs::read_to_string(code.join("Cargo.toml"))
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        manifest["bin"][0]["name"]
            .as_str()
            .unwrap()
            .starts_with("scene-")
    );
}

/// Make `dir` with `mode`.
fn dir_with_mode(dir: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::create_dir_all(dir).unwrap();
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(mode)).unwrap();
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

#[test]
fn search_budget_is_a_wall_even_during_an_exact_check() {
    // The snakeboard eliminating x, y, θ, ψ: the ansatz finds its candidates in about a second,
    // then the exact check of the family with unknown functions takes minutes.
    let dir = scratch("search_wall");
    let file = dir.join("out.json");
    let budget = 5.0;
    let (o, took) = hamel_timed(&[
        "search",
        "models/snakeboard.toml",
        "--eliminate",
        "x,y,theta,psi",
        "--budget",
        "5",
        "--format",
        "json",
        "--output",
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The whole command, set-up and the abandoned check included, within the budget + 2 s.
    assert!(
        took.as_secs_f64() < budget + 2.0,
        "took {:.2} s with a budget of {budget} s",
        took.as_secs_f64()
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let stop = &v["stop"];
    assert!(
        stop["reason"] == "budget_during_check" || stop["reason"] == "budget",
        "{stop}"
    );
    if stop["reason"] == "budget_during_check" {
        assert!(!stop["eta"].as_array().unwrap().is_empty(), "{stop}");
    }
    // What was found before the deadline is reported, each a pasteable choice.
    let candidates = v["candidates"].as_array().unwrap();
    assert!(!candidates.is_empty());
    for c in candidates {
        assert_eq!(
            c["eliminated"],
            serde_json::json!(["x", "y", "theta", "psi"])
        );
        let t: toml::Table = c["toml"].as_str().unwrap().parse().unwrap();
        assert!(
            t["quasi_velocities"]
                .as_table()
                .unwrap()
                .contains_key(c["name"].as_str().unwrap())
        );
    }
    // Symbolica's notice is passed through, and the next command runs (the worker's
    // Symbolica instance ended with it).
    let o = hamel(&["derive", "models/knife.toml", "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Planning is pure: loading a scene and integrating it on the interpreted evaluator writes
/// nothing to the code cache (it is not even created); `hamel plan`, which reports the core's
/// operation counts, prepares the scene's core there, and nothing else.
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
    assert!(
        !cache.exists(),
        "the interpreted run created the code cache"
    );
    let o = hamel_with_cache(&["plan", "scenes/knife.toml"], None, &cache);
    assert!(o.status.success(), "{}", stderr(&o));
    let entries: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "build.lock" && n != "target")
        .collect();
    assert_eq!(entries.len(), 1, "one entry, the scene's core: {entries:?}");
    assert!(!cache.join("target").exists(), "plan builds nothing");
}

/// `hamel bench --min-time`: each model and choice is derived until that much time has been
/// spent on it, and at least `--repeat` times; `--min-time 0` derives it exactly `--repeat`
/// times; a time that is not from 0 to 600 seconds is refused with the reason.
#[test]
fn bench_repeats_until_the_minimum_time() {
    let path = format!("{}/models/knife.toml", env!("CARGO_MANIFEST_DIR"));
    let rows = |args: &[&str]| {
        let mut all = vec!["bench", path.as_str(), "--format", "json"];
        all.extend_from_slice(args);
        let o = hamel(&all, None);
        assert!(o.status.success(), "{}", stderr(&o));
        let v = json_on_stdout(&o);
        let rows = v["derivations"].as_array().expect("rows").clone();
        assert_eq!(rows.len(), 2, "knife's two choices: {v}");
        rows
    };
    for d in rows(&["--repeat", "2", "--min-time", "0.05"]) {
        let (repeats, spent) = (d["repeats"].as_u64(), d["seconds_spent"].as_f64());
        assert!(repeats.is_some_and(|n| n >= 2), "{d}");
        assert!(spent.is_some_and(|s| s >= 0.05), "{d}");
    }
    for d in rows(&["--repeat", "3", "--min-time", "0"]) {
        assert_eq!(d["repeats"], 3, "{d}");
    }
    let o = hamel(&["bench", &path, "--min-time=700"], None);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("--min-time") && e.contains("not between 0 and 600 seconds"),
        "{e}"
    );
}

/// `hamel bench` on a structured derivation (the bicycle has no closed A_Γ to measure): a row
/// with its time and `–` for the sizes of A_Γ, in Markdown and in JSON; no panic.
#[test]
fn bench_reports_a_structured_derivation() {
    let path = format!("{}/models/whipple_bicycle.toml", env!("CARGO_MANIFEST_DIR"));
    let o = hamel(&["bench", &path, "--repeat", "1"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let row = out
        .lines()
        .find(|l| l.starts_with("| whipple_bicycle | benchmark | 8 | 3 |"))
        .unwrap_or_else(|| panic!("no bicycle row in\n{out}"));
    // Derivation time, printing time and their ratio, then the baseline not run.
    assert!(
        row.contains(" ms | ") && row.contains(" % | not run (use --sympy) |"),
        "{row}"
    );
    let o = hamel(&["bench", &path, "--repeat", "1", "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_on_stdout(&o);
    let d = &v["derivations"];
    assert!(d[0]["hamel_a_gamma_chars"].is_null(), "{v}");
    assert!(
        d[0]["hamel_seconds"].as_f64().is_some_and(|s| s > 0.0),
        "{v}"
    );
    assert!(
        d[0]["print_seconds"].as_f64().is_some_and(|s| s > 0.0),
        "{v}"
    );
    // The bicycle's linearisation about upright running, swept over v, has its row too.
    let l = &v["linearisations"][0];
    assert_eq!(l["steady"], "upright", "{v}");
    assert_eq!(l["sweep"], "v=0:10:21", "{v}");
    assert!(l["hamel_seconds"].as_f64().is_some_and(|s| s > 0.0), "{v}");
    assert_eq!(l["sympy"]["status"], "not run (use --sympy)", "{v}");
    assert!(
        out.contains("| whipple_bicycle --steady upright --sweep v=0:10:21 |"),
        "{out}"
    );
}

/// `--set NAME=VALUE` on `simulate`: the same trajectory as the scene with that value in its
/// `[parameters]`, and another than without it; a derived parameter, an unknown name and a
/// malformed pair are errors that write nothing.
#[test]
fn simulate_sets_parameters_from_the_command_line() {
    let root = env!("CARGO_MANIFEST_DIR");
    let scene = format!("{root}/scenes/unicycle_rider.toml");
    let dir = scratch("set");
    let text = std::fs::read_to_string(&scene)
        .unwrap()
        .replace(
            "model = \"../models/unicycle_rider.toml\"",
            &format!("model = \"{root}/models/unicycle_rider.toml\""),
        )
        .replace("[initial]", "[parameters]\nm_f = 2.25\n\n[initial]");
    let written = dir.join("scene.toml");
    std::fs::write(&written, text).unwrap();
    let run = |path: &str, extra: &[&str]| {
        let mut args = vec![
            "simulate",
            path,
            "--engine",
            "interpreted",
            "--format",
            "json",
        ];
        args.extend(extra);
        let o = hamel(&args, None);
        assert!(o.status.success(), "{}", stderr(&o));
        json_on_stdout(&o)["q"].clone()
    };
    let by_flag = run(&scene, &["--set", "m_f=2.25"]);
    assert_eq!(by_flag, run(written.to_str().unwrap(), &[]));
    assert_ne!(by_flag, run(&scene, &[]));
    let bicycle = format!("{root}/scenes/whipple_bicycle.toml");
    let out = dir.join("never.csv");
    for (set, says) in [
        ("d1=1.0", "`d1` is derived from other parameters"),
        (
            "wheelbase=1.0",
            "`wheelbase` is not a parameter or input of the model",
        ),
        ("w", "write NAME=VALUE"),
    ] {
        let o = hamel(
            &[
                "simulate",
                &bicycle,
                "--set",
                set,
                "--output",
                out.to_str().unwrap(),
            ],
            None,
        );
        assert!(
            !o.status.success() && stderr(&o).contains(says),
            "{set}: {}",
            stderr(&o)
        );
        assert!(!out.exists());
    }
}

/// `hamel linearize`: the bicycle's sweep as JSON in the issue's shape (points with their
/// eigenvalues, crossings with their kinds, the matrices), its figure, and a small map; errors
/// (an unknown steady motion, a plot without a sweep, an unknown swept name) exit 1 and write
/// nothing.
#[test]
fn linearize_writes_sweeps_maps_and_figures_and_nothing_on_errors() {
    let dir = scratch("linearize");
    let (json, svg) = (dir.join("sweep.json"), dir.join("fig.svg"));
    let model = "models/whipple_bicycle.toml";
    let args = [
        "linearize",
        model,
        "--steady",
        "upright",
        "--sweep",
        "v=0:10:21",
    ];
    let more = [
        "--format",
        "json",
        "--output",
        json.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ];
    let o = hamel(&[&args[..], &more[..]].concat(), None);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["parameter"], "v");
    let points = v["points"].as_array().unwrap();
    assert_eq!(points.len(), 21);
    assert!(
        points
            .iter()
            .all(|p| p["eigenvalues"].as_array().unwrap().len() == 4),
        "{v}"
    );
    let kinds: Vec<&str> = v["crossings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["hopf", "real_zero"]);
    let weave = v["crossings"][0]["value"].as_f64().unwrap();
    assert!((weave - 4.29238253634111).abs() < 1e-10, "{weave}");
    assert!(
        v["matrices"]["m"].is_array() && v["matrices"]["gravity"]["parameter"] == "g",
        "{v}"
    );
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));

    let map = dir.join("map.json");
    let o = hamel(
        &[
            "linearize",
            model,
            "--steady",
            "upright",
            "--sweep",
            "v=3:7:5",
            "--sweep",
            "c=0.04:0.12:3",
            "--format",
            "json",
            "--output",
            map.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&map).unwrap()).unwrap();
    let rows = m["values"].as_array().unwrap();
    assert_eq!((rows.len(), rows[0].as_array().unwrap().len()), (3, 5));
    assert_eq!(
        m["stability"][1][2], "asymptotic",
        "the benchmark (c = 0.08) at 5 m/s: {m}"
    );

    let out = dir.join("bad.json");
    for (bad, want) in [
        (
            vec!["--steady", "rolling"],
            "no steady motion named `rolling`",
        ),
        (
            vec!["--steady", "upright", "--plot", "x.svg"],
            "--plot draws a sweep or a map",
        ),
        (
            vec!["--steady", "upright", "--sweep", "speed=0:1:3"],
            "`speed` is neither a parameter",
        ),
        (
            vec!["--steady", "upright", "--sweep", "d1=0:1:3"],
            "derived parameter",
        ),
    ] {
        let o = hamel(
            &[
                &["linearize", model, "--output", out.to_str().unwrap()][..],
                &bad[..],
            ]
            .concat(),
            None,
        );
        assert_eq!(o.status.code(), Some(1), "{bad:?}");
        assert!(stderr(&o).contains(want), "{bad:?}: {}", stderr(&o));
        assert!(
            !out.exists() && !Path::new("x.svg").exists(),
            "{bad:?} wrote something"
        );
    }
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

/// `hamel reduce` writes the reduced system as `hamel derive` writes equations (issue 22):
/// collected, rate terms first, named groups defined once in a where-list, every name it
/// uses defined there.
#[test]
fn reduce_prints_the_reduced_system_with_its_names() {
    let o = hamel(
        &[
            "reduce",
            "models/unicycle_rider.toml",
            "--eta",
            "velocities",
            "--eliminate",
            "phi",
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    let (report, where_list) = text.split_once("\nwhere\n").expect("a where-list");
    let defined: Vec<&str> = where_list
        .lines()
        .filter_map(|l| l.trim().split(" = ").next())
        .map(|n| n.split('(').next().unwrap())
        .collect();
    let system = report
        .split("Reduced system")
        .nth(1)
        .expect("a reduced system");
    let first = system.lines().find(|l| l.contains("(11.1) 0 = ")).unwrap();
    let rhs = first.split(" 0 = ").nth(1).unwrap();
    // Rate terms first.
    let rate = rhs.find("eta1_dot").expect("η̇₁ in (11.1)");
    assert!(!rhs[..rate].contains("eta1*"), "{rhs}");
    for word in system.split(|c: char| !c.is_alphanumeric() && c != '_') {
        let named = (word.starts_with("kappa") || word.starts_with('F'))
            && word[1..].chars().last().is_some_and(|c| c.is_ascii_digit());
        if named {
            assert!(
                defined.contains(&word),
                "{word} is not defined in\n{where_list}"
            );
        }
    }
}

/// The bicycle's derivation is structured (no closed form): its export is the structured
/// right-hand side traced at the initial state into straight-line Python (issue 56). Both forms,
/// run by python3, agree with `hamel eval` (the structured evaluator) at random states to
/// 1e-12 relative.
#[test]
fn tradeoff_exports_the_structured_bicycle_as_python_that_agrees_with_the_evaluator() {
    use rand::{Rng, SeedableRng};
    let dir = scratch("tradeoff_export_bicycle");
    let bicycle = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/whipple_bicycle.toml");
    let scene = smoke::short_scene(&bicycle, &dir, 1.0);
    let json = dir.join("bicycle.json");
    let o = hamel(
        &[
            "tradeoff",
            scene.to_str().unwrap(),
            "--export-python",
            json.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let names: Vec<String> = serde_json::from_value(v["state"].clone()).unwrap();
    let held = v["held"].as_object().unwrap().clone();
    // Random states: angles and rates well away from the upright start, wheel angles anywhere.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(56);
    let ys: Vec<Vec<f64>> = (0..24)
        .map(|_| {
            (names.iter())
                .map(|n| match n.as_str() {
                    "roll" | "steer" | "pitch" => rng.random_range(-0.7..0.7),
                    "eta3" => rng.random_range(-25.0..25.0),
                    _ => rng.random_range(-3.0..3.0),
                })
                .collect()
        })
        .collect();
    let is_eta = |n: &String| n.starts_with("eta");
    let states: Vec<serde_json::Value> = (ys.iter())
        .map(|y| {
            let mut q: serde_json::Map<String, serde_json::Value> = (names.iter().zip(y))
                .filter(|(n, _)| !is_eta(n))
                .map(|(n, x)| (n.clone(), (*x).into()))
                .collect();
            q.extend(held.clone());
            let eta: Vec<f64> = (names.iter().zip(y))
                .filter(|(n, _)| is_eta(n))
                .map(|(_, x)| *x)
                .collect();
            serde_json::json!({ "q": q, "eta": eta })
        })
        .collect();
    let state_file = dir.join("states.json");
    std::fs::write(&state_file, serde_json::to_string(&states).unwrap()).unwrap();
    let evaluated = dir.join("evaluated.json");
    let o = hamel(
        &[
            "eval",
            "models/whipple_bicycle.toml",
            "--eta",
            "benchmark",
            "--state",
            state_file.to_str().unwrap(),
            "--output",
            evaluated.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let ev: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(&evaluated).unwrap()).unwrap();
    let want: Vec<Vec<f64>> = (ev.iter())
        .map(|e| {
            (names.iter().filter(|n| !is_eta(n)))
                .map(|n| e["q_dot"][n].as_f64().unwrap())
                .chain(
                    e["eta_dot"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|x| x.as_f64().unwrap()),
                )
                .collect()
        })
        .collect();
    let script = format!(
        "from math import *\nimport json, sys\n{}\n{}\nys = json.load(sys.stdin)\n\
         out = []\nfor y in ys:\n    dy = [0.0] * len(y)\n    rhs_into(0.0, y, dy)\n    \
         out.append([rhs(0.0, y), dy])\nprint(json.dumps(out))\n",
        v["python"].as_str().unwrap(),
        v["python_into"].as_str().unwrap()
    );
    // As a file: the bicycle's two functions are longer than one argument may be.
    let script_file = dir.join("check.py");
    std::fs::write(&script_file, script).unwrap();
    let spawned = Command::new("python3")
        .arg(&script_file)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn();
    let mut child = match spawned {
        Ok(child) => child,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            eprintln!("python3 not found: the exported functions are not evaluated");
            return;
        }
        Err(e) => panic!("python3 did not start: {e}"),
    };
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().unwrap();
        let states = serde_json::to_string(&ys).unwrap();
        // A failure to write means python3 stopped: its stderr says why (asserted below).
        let _ = stdin.write_all(states.as_bytes());
    }
    let p = child.wait_with_output().unwrap();
    assert!(p.status.success(), "{}", String::from_utf8_lossy(&p.stderr));
    let got: Vec<[Vec<f64>; 2]> = serde_json::from_slice(&p.stdout).unwrap();
    let mut worst = 0.0_f64;
    for (pair, w) in got.iter().zip(&want) {
        let scale = w.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
        for form in pair {
            assert_eq!(form.len(), w.len());
            let err = (form.iter().zip(w)).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
            worst = worst.max(err / scale);
        }
    }
    assert_eq!(got.len(), ys.len());
    assert!(worst <= 1e-12, "worst relative difference {worst:.2e}");
    eprintln!(
        "the exported bicycle against hamel eval at {} states: {worst:.1e}",
        ys.len()
    );
}

/// A scene whose inputs follow a law of the time and a table (the Segway pushed by
/// T_L = A sin(w t) and T_R from a table): the compiled core, which sets the live parameters
/// (t, the tabled input) at every evaluation, integrates what the interpreted evaluator does;
/// a table that does not increase is refused with exit 1, its key named, and no output written,
/// as is the Python export of a table (which it cannot write).
#[test]
fn simulate_drives_inputs_by_laws_and_tables_on_both_engines() {
    let dir = scratch("driven");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/segway.toml");
    let scene = |table: &str| {
        format!(
            "model = {model:?}\neta = \"body\"\nt_end = 2.0\noutputs = 21\nrequest = [\"theta\", \"x\", \"psi\"]\n\
             [gains]\nA = 0.2\nw = 3.0\n[inputs]\nT_L = \"A*sin(w*t)\"\nT_R = {{ times = {table}, values = [0.0, 0.1, -0.1, 0.05], interpolation = \"cubic\" }}\n\
             [initial]\nq = {{ x = 0.0, y = 0.0, psi = 0.0, theta = 0.05, phiL = 0.0, phiR = 0.0 }}\neta = [0.0, 0.0, 0.0]\n\
             [integrator]\nmethod = \"dop853\"\nrtol = 1e-10\natol = 1e-12\n"
        )
    };
    let good = dir.join("good.toml");
    std::fs::write(&good, scene("[0.0, 0.7, 1.4, 2.0]")).unwrap();
    let (c, i) = compiled_and_interpreted(&good, &dir);
    for k in ["theta", "x", "psi"] {
        let scale = series(&i, k).iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        assert!(scale > 1e-3, "{k} moves: {scale}");
        let worst = largest_difference(&c, &i, k);
        assert!(
            worst <= 1e-8 * scale,
            "{k}: compiled vs interpreted {worst:.1e}"
        );
    }
    // The Python export cannot read a table: refused, naming the input, writing nothing.
    let export = dir.join("export.json");
    let o = hamel(
        &[
            "tradeoff",
            good.to_str().unwrap(),
            "--export-python",
            export.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("inputs.T_R"), "{}", stderr(&o));
    assert!(!export.exists());
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, scene("[0.0, 0.7, 0.7, 2.0]")).unwrap();
    let out = dir.join("bad.csv");
    let o = hamel(
        &[
            "simulate",
            bad.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("inputs.T_R"), "{}", stderr(&o));
    assert!(!out.exists(), "no partial output");
}

/// The Ackermann car (tests/models/ackermann_car.toml: the right front knuckle turned by an
/// arctangent of the left's angle; ackermann_atan2.toml: by atan2), driven and steered by a
/// law: its compiled core, with the arctangent's sine and cosine as straight-line code,
/// integrates what the interpreted evaluator does, and the work of the torques balances the
/// energy.
#[test]
fn the_ackermann_car_runs_compiled_with_its_arctangent() {
    for name in ["ackermann_car", "ackermann_atan2"] {
        ackermann_runs_compiled(name);
    }
}

fn ackermann_runs_compiled(name: &str) {
    let dir = scratch(name);
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/models/{name}.toml"));
    let scene = dir.join("car.toml");
    std::fs::write(
        &scene,
        format!(
            "model = {model:?}\neta = \"drive\"\nt_end = 8.0\noutputs = 81\nrequest = [\"x\", \"y\", \"psi\", \"delta\", \"energy\"]\n\
             [inputs]\nT_drive = 20.0\nT_steer = \"-200*(delta - 0.3*sin(t)) - 50*eta2\"\n\
             [initial]\nq = {{ x = 0.0, y = 0.0, psi = 0.0, delta = 0.0, phiRL = 0.0, phiRR = 0.0, phiFL = 0.0, phiFR = 0.0 }}\neta = [2.0, 0.0]\n\
             [integrator]\nmethod = \"dop853\"\nrtol = 1e-10\natol = 1e-12\n"
        ),
    )
    .unwrap();
    let (c, i) = compiled_and_interpreted(&scene, &dir);
    for k in ["x", "y", "psi", "delta"] {
        let worst = largest_difference(&c, &i, k);
        assert!(worst <= 1e-9, "{k}: compiled vs interpreted {worst:.1e}");
    }
    let turned = c["q"]["psi"]
        .as_array()
        .unwrap()
        .last()
        .unwrap()
        .as_f64()
        .unwrap();
    assert!(turned.abs() > 0.05, "{name}: the car turns: ψ = {turned}");
    assert!(c["stats"]["energy_balance_drift"].as_f64().unwrap() <= 1e-9);
}

/// A bare atan2 in U (tests/models/atan2_knife.toml) becomes `atan2` in the compiled core: the
/// trajectory and the energy it reports are the interpreted evaluator's, and the energy is
/// conserved.
#[test]
fn a_bare_atan2_runs_compiled() {
    let dir = scratch("atan2");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/atan2_knife.toml");
    let scene = dir.join("knife.toml");
    std::fs::write(
        &scene,
        format!(
            "model = {model:?}\neta = \"paper\"\nt_end = 6.0\noutputs = 61\nrequest = [\"x\", \"y\", \"energy\"]\n\
             [initial]\nq = {{ x = 0.5, y = 0.8, theta = 0.3 }}\neta = [1.5, 1.0]\n\
             [integrator]\nmethod = \"dop853\"\nrtol = 1e-11\natol = 1e-13\n"
        ),
    )
    .unwrap();
    let (c, i) = compiled_and_interpreted(&scene, &dir);
    for k in ["x", "y"] {
        let worst = largest_difference(&c, &i, k);
        assert!(worst <= 1e-9, "{k}: compiled vs interpreted {worst:.1e}");
    }
    assert!(
        c["stats"]["energy_drift"].as_f64().unwrap() <= 1e-9,
        "{}",
        c["stats"]
    );
}

/// The skidding disk (issue 58): the friction monitor stops the compiled run at μ = 0.2 between
/// the output times where the friction ratio the disk needs crosses μ, with the violation in
/// the report and a non-zero exit; the compiled core's forces are the interpreted
/// evaluator's; at μ = 1 the same scene runs through, keeping the largest ratio and the
/// smallest normal force.
#[test]
fn the_friction_monitor_stops_a_skidding_disk() {
    let dir = scratch("skid");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rolling_disk_skid.toml");
    let run = |scene: &Path, engine: &str| -> (Output, serde_json::Value) {
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
        let report = serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap();
        (o, report)
    };
    let (o, c) = run(&scene, "compiled");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("wheel `disk` would slip"),
        "{}",
        stderr(&o)
    );
    assert_eq!(c["engine"], "compiled");
    let v = &c["friction"]["violation"];
    assert_eq!(
        (v["kind"].as_str(), v["t_before"].as_f64(), v["t"].as_f64()),
        (Some("slip"), Some(0.16), Some(0.17))
    );
    assert!(v["ratio"].as_f64().unwrap() > 0.2);
    assert_eq!(
        c["t"].as_array().unwrap().len(),
        18,
        "the outputs up to the violation"
    );
    let (_, i) = run(&scene, "interpreted");
    for k in ["longitudinal", "lateral", "normal"] {
        let key = format!("force.disk.{k}");
        let (a, b) = (
            c["forces"][&key].as_array().unwrap(),
            i["forces"][&key].as_array().unwrap(),
        );
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-10 * y.abs().max(1.0),
                "{key}: compiled {x}, interpreted {y}"
            );
        }
    }
    let grippy = dir.join("grippy.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    let text = text.replace("mu = 0.2", "mu = 1.0").replace(
        "\"../models",
        &format!("\"{}/models", env!("CARGO_MANIFEST_DIR")),
    );
    std::fs::write(&grippy, text).unwrap();
    let (o, g) = run(&grippy, "compiled");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(g["t"].as_array().unwrap().len(), 201);
    let disk = &g["friction"]["contacts"]["disk"];
    let ratio = disk["largest_friction_ratio"].as_f64().unwrap();
    assert!((0.2..1.0).contains(&ratio), "{disk}");
    assert!(disk["smallest_normal"].as_f64().unwrap() > 0.0, "{disk}");
    assert!(g["friction"]["violation"].is_null());
}

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
