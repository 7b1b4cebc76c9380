//! The Taylor method on the bundled scenes' models (issue 63), interpreted: its series come
//! from the structured right-hand side traced at each step (`hamel_runtime::taylor_by_trace`),
//! linear solves included. Every scene's solution at rtol = atol = 1e-14 against DOP853's at
//! 1e-14 (two independent integrators), and the Taylor method's error following its tolerance.
//! The CAS runs in-process, on its one worker thread; no `hamel` process, no compiled core.

use std::path::{Path, PathBuf};

use hamel_run::Loaded;
use hamel_sim::{Method, Options};

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
}

fn tight(tol: f64) -> Options {
    Options {
        rtol: tol,
        atol: tol,
        max_steps: 1_000_000,
        ..Options::default()
    }
}

/// max over the output states of |y − y_ref| / max(1, |y_ref|).
fn difference(loaded: &Loaded, a: Method, b: Method, tol: (f64, f64)) -> (f64, usize) {
    let run = |m: Method, tol: f64| {
        let r = loaded
            .integrate(m, &tight(tol))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(r.failure.is_none(), "{m:?}: {:?}", r.failure);
        r.solution
    };
    let (x, y) = (run(a, tol.0), run(b, tol.1));
    assert_eq!(x.t, y.t);
    let worst = x.y.iter().zip(y.y.iter()).fold(0.0_f64, |m, (u, v)| {
        u.iter()
            .zip(v)
            .fold(m, |m, (p, q)| m.max((p - q).abs() / q.abs().max(1.0)))
    });
    (worst, x.stats.series_evals)
}

/// Closed-form and structured derivations, quasi-velocities of both kinds, a holonomic
/// constraint projected onto (the Routh sphere), a model whose equations swell (the bicycle).
#[test]
fn every_kind_of_model_integrates_with_the_taylor_method_as_with_dop853() {
    for name in [
        "knife.toml",
        "rolling_disk.toml",
        "bar_wheels.toml",
        "unicycle_rider.toml",
        "chaplygin_sleigh.toml",
        "routh_sphere.toml",
        "whipple_bicycle.toml",
    ] {
        let loaded = hamel_run::load(&scene(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let (d, series) = difference(&loaded, Method::Taylor, Method::Dop853, (1e-14, 1e-14));
        println!("{name}: Taylor against DOP853 at 1e-14: {d:.1e} ({series} series)");
        assert!(series > 0);
        assert!(d < 1e-10, "{name}: {d:e}");
    }
}

/// Against its own run at ε, the Taylor method's error falls with its tolerance: within
/// 100·tol at every tolerance from 1e-6 to 1e-13 on the rolling disk.
#[test]
fn the_taylor_methods_error_follows_its_tolerance_on_the_rolling_disk() {
    let loaded = hamel_run::load(&scene("rolling_disk.toml")).unwrap_or_else(|e| panic!("{e}"));
    for k in 6..=13 {
        let tol = 10f64.powi(-k);
        let (d, _) = difference(&loaded, Method::Taylor, Method::Taylor, (tol, 3e-16));
        println!("tol {tol:.0e}: error {d:.1e}");
        assert!(d < 100.0 * tol, "tol {tol:e}: {d:e}");
    }
}

/// On the scenes' compiled cores (the series by the recurrences compiled from the rolling
/// disk's closed form and from the bicycle's trace, the forces' work beside the state on the
/// bicycle, whose loads make the energy a balance): the same solution as DOP853's on the same
/// core, and as the interpreted Taylor run (the series traced at every step).
#[test]
fn the_compiled_cores_give_the_same_series() {
    let cache = std::env::temp_dir().join(format!("hamel-taylor-test-{}", std::process::id()));
    std::fs::create_dir_all(&cache).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&cache, std::fs::Permissions::from_mode(0o700)).unwrap();
    }
    // SAFETY: set before any thread of this test reads it; the tests in this file that run
    // alongside read no cache.
    unsafe { std::env::set_var("HAMEL_CACHE", &cache) };
    for name in ["rolling_disk.toml", "whipple_bicycle.toml"] {
        let loaded = hamel_run::load(&scene(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let compiled = |m: Method| {
            let t = loaded
                .integrate_compiled(m, &tight(1e-13), 1)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(t.run.failure.is_none(), "{name} {m:?}: {:?}", t.run.failure);
            t.run.solution
        };
        let (taylor, dop853) = (compiled(Method::Taylor), compiled(Method::Dop853));
        let interpreted = loaded
            .integrate(Method::Taylor, &tight(1e-13))
            .unwrap()
            .solution;
        assert!(taylor.stats.series_evals > 0 && dop853.stats.series_evals == 0);
        // every series by the compiled recurrences: the rolling disk's closed form, the
        // bicycle's trace of its start with its loads' power (its guards hold along the run)
        assert_eq!(
            taylor.stats.series_traced, 0,
            "{name}: series traced at run time"
        );
        for other in [&dop853, &interpreted] {
            let worst = taylor
                .y
                .iter()
                .zip(other.y.iter())
                .fold(0.0_f64, |m, (u, v)| {
                    u.iter()
                        .zip(v)
                        .fold(m, |m, (p, q)| m.max((p - q).abs() / q.abs().max(1.0)))
                });
            println!(
                "{name}: compiled Taylor against {:?} {worst:.1e}",
                other.stats.series_evals
            );
            assert!(worst < 1e-10, "{name}: {worst:e}");
        }
    }
    std::fs::remove_dir_all(&cache).ok();
}

/// A scene whose inputs change with time asks for a series the trace cannot give (the
/// right-hand side depends on t through them): refused when loaded, at the method's key.
#[test]
fn a_scene_with_inputs_in_time_is_refused_the_taylor_method() {
    let text = std::fs::read_to_string(scene("diff_drive_circle.toml")).unwrap();
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let text = text
        .replace("../models", &models.display().to_string())
        .replace("k_v*(V - eta1)", "k_v*(V*(1 + 0.1*sin(3*t)) - eta1)")
        .replace("method = \"dop853\"", "method = \"taylor\"");
    assert!(text.contains("sin(3*t)") && text.contains("\"taylor\""));
    let dir = std::env::temp_dir().join(format!("hamel-taylor-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("in_time.toml");
    std::fs::write(&path, text).unwrap();
    let e = match hamel_run::load(&path) {
        Ok(_) => panic!("loaded"),
        Err(e) => e.to_string(),
    };
    std::fs::remove_dir_all(&dir).ok();
    assert!(
        e.contains("integrator.method") && e.contains("free of t"),
        "{e}"
    );
}
