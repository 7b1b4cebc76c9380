//! The right-hand side traced at a scene's start for its compiled core (issue 63,
//! `hamel_run::traced`): the Whipple bicycle's structured evaluation recorded with its pivots'
//! guards. Where the guards hold the trace is the structured evaluation's function (checked
//! against it at states around the start and along a capsizing run); where the pivots change
//! the guards fail (so the core takes the structured evaluation there). A model with a closed
//! form gets no trace. The CAS runs in-process, on its one worker thread; no compiled core.

use std::path::{Path, PathBuf};

use hamel_run::traced;

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
}

/// max |a − b| / max(1, max |b|).
fn relative(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

#[test]
fn the_bicycles_trace_is_its_structured_evaluation_where_its_guards_hold() {
    let loaded = hamel_run::load(&scene("whipple_bicycle.toml")).unwrap_or_else(|e| panic!("{e}"));
    let start = loaded.scene_trace_start();
    let g = traced::core_trace(&start).unwrap_or_else(|e| panic!("{e}"));
    assert!(!g.undecidable && !g.guards.is_empty());
    let y0 = loaded.in_core_order(&loaded.y0);
    let at = |y: &[f64]| g.tape.eval::<f64>(y).ok();
    let first = at(&y0).expect("the trace at its own point");
    assert!(g.holds(&first));
    let exact = traced::structured_rates(&start, &y0).unwrap();
    assert!(relative(&first[..g.outputs], &exact) < 1e-14);
    // around the start, against double-double: as accurate as the structured evaluation
    let (worst, structured, used) = traced::accuracy(&start, &g);
    assert!(used >= 16, "{used}");
    assert!(worst <= structured.max(1e-12), "{worst:e} {structured:e}");
    // Turning the heading and leaning far: where the guards hold the trace is the same
    // function; somewhere on the way they fail (the pivots of [Z; α] follow the heading).
    let (mut held, mut failed) = (0, 0);
    for k in 0..24 {
        let mut y = y0.clone();
        let turn = k as f64 * std::f64::consts::PI / 12.0;
        y[coordinate(&loaded, "yaw")] = turn;
        y[coordinate(&loaded, "roll")] = 0.05 + 0.05 * k as f64;
        let Some(values) = at(&y) else {
            failed += 1;
            continue;
        };
        if !g.holds(&values) {
            failed += 1;
            continue;
        }
        let exact = traced::structured_rates(&start, &y).unwrap();
        let d = relative(&values[..g.outputs], &exact);
        assert!(d < 1e-12, "turned {turn}: {d:e}");
        held += 1;
    }
    println!("guards held at {held} of 24 states, failed at {failed}");
    assert!(held >= 2 && failed >= 1, "held {held}, failed {failed}");
}

/// The index of coordinate `name` in the trace's order (kept coordinates by model index).
fn coordinate(loaded: &hamel_run::Loaded, name: &str) -> usize {
    let at = (loaded.state_names().iter().position(|c| c == name)).expect(name);
    let k = loaded.state()[at];
    let mut kept = loaded.state().to_vec();
    kept.sort_unstable();
    kept.iter()
        .position(|&x| x == k)
        .expect("a kept coordinate")
}

/// Along the scene's own run (the bicycle upright at 5 m/s, its weave dying out) the guards
/// hold at every output state: the core never leaves its traced path there.
#[test]
fn the_bicycles_guards_hold_along_its_scenes_run() {
    let loaded = hamel_run::load(&scene("whipple_bicycle.toml")).unwrap_or_else(|e| panic!("{e}"));
    let g = traced::core_trace(&loaded.scene_trace_start()).unwrap_or_else(|e| panic!("{e}"));
    let options = hamel_sim::Options {
        rtol: 1e-10,
        atol: 1e-10,
        ..hamel_sim::Options::default()
    };
    let run = loaded
        .integrate(hamel_sim::Method::Dop853, &options)
        .unwrap();
    let mut failed = Vec::new();
    for (t, y) in run.solution.t.iter().zip(run.solution.y.iter()) {
        let y = loaded.in_core_order(y);
        let held = g.tape.eval::<f64>(&y).is_ok_and(|v| g.holds(&v));
        if !held {
            failed.push(*t);
        }
    }
    assert!(failed.is_empty(), "guards fail at t = {failed:?}");
}

#[test]
fn a_model_with_a_closed_form_is_not_traced() {
    let loaded = hamel_run::load(&scene("knife.toml")).unwrap_or_else(|e| panic!("{e}"));
    let why = traced::core_trace(&loaded.scene_trace_start()).unwrap_err();
    assert!(why.contains("closed form"), "{why}");
}
