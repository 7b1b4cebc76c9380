//! `hamel bench`: repeats, timing, structured derivations.

#[allow(unused_imports)]
use super::*;

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
