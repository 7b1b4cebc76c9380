//! `hamel derive`, `expand` and `reduce`: output formats, names, located errors.

#[allow(unused_imports)]
use super::*;

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
