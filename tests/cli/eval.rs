//! `hamel eval`: states in, right-hand sides out; bad states refused with their place.

#[allow(unused_imports)]
use super::*;

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
