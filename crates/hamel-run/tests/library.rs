//! The scene library as a Rust user calls it: load a scene, read its plan, simulate it, trade
//! it off — against the knife edge's closed-form motion. The CAS runs in-process, on its one
//! worker thread; nothing here starts a `hamel` process or builds a compiled core.

use std::path::{Path, PathBuf};

use hamel_run::tradeoff::{self, Range};
use hamel_run::{Engine, Loaded};

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
}

fn knife() -> Loaded {
    hamel_run::load(&scene("knife.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// The knife edge with the paper's quasi-velocities: η = (speed along the blade, θ̇) are
/// constant, so θ = θ₀ + η₂t, x = (sin θ − sin θ₀)/η₂, y = (cos θ₀ − cos θ)/η₂ (scene:
/// θ₀ = 0.3, η = (1, 0.5), x₀ = y₀ = 0).
#[test]
fn the_knife_follows_its_circle() {
    let loaded = knife();
    let hamel_run::simulate::Simulated {
        trajectory: traj,
        failure,
        ..
    } = hamel_run::simulate::run_loaded(&loaded, Engine::Interpreted, false)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(failure.is_none(), "{failure:?}");
    assert!(traj.complete);
    assert_eq!(traj.t.len(), 101);
    let (theta0, w) = (0.3_f64, 0.5_f64);
    let mut worst = 0.0_f64;
    for (j, &t) in traj.t.iter().enumerate() {
        let theta = theta0 + w * t;
        let exact = [
            ("x", (theta.sin() - theta0.sin()) / w),
            ("y", (theta0.cos() - theta.cos()) / w),
            ("theta", theta),
        ];
        for (name, value) in exact {
            worst = worst.max((traj.q[name][j] - value).abs());
        }
        assert!((traj.eta[j][0] - 1.0).abs() < 1e-12 && (traj.eta[j][1] - w).abs() < 1e-12);
    }
    // DOP853 at rtol 1e-10, atol 1e-12 over 10 s.
    assert!(worst < 1e-8, "largest error {worst:e}");
}

/// The plan is a pure decision: the knife's equations (11) are free of every coordinate, so
/// only η is integrated and the requested coordinates are reconstructed.
#[test]
fn the_plan_integrates_eta_and_reconstructs_the_coordinates() {
    let loaded = knife();
    let plan = &loaded.plan;
    assert_eq!(plan.integrated, ["eta1", "eta2"]);
    assert_eq!(plan.reconstructed, ["x", "y", "theta"]);
    assert!(plan.dropped.is_empty());
    assert_eq!(plan.eta, "paper");
}

/// Among the adaptive settings, the recommended one meets the scene's target, and no faster
/// measured setting is recommended over it.
#[test]
fn the_tradeoff_recommends_a_setting_that_meets_the_target() {
    let loaded = knife();
    let table = tradeoff::table(&loaded, Range::Adaptive, Engine::Interpreted)
        .unwrap_or_else(|e| panic!("{e}"));
    let i = table.recommended.expect("a setting meets rtol 1e-10");
    let best = &table.rows[i];
    assert!(best.complete && best.target_ratio <= 1.0, "{best:?}");
    for r in &table.rows {
        if r.complete && r.target_ratio <= 1.0 {
            assert!(r.seconds >= best.seconds, "{r:?} is faster than {best:?}");
        }
    }
}
