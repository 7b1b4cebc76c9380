//! The discrete Lagrange–d'Alembert method on hamel's models over long horizons (issue 63):
//! the scenes' models as `hamel_sim::dla::Nonholonomic` systems (A, U, ∇U, ∂A/∂q and α from the
//! derivation's ingredients). The energy error stays bounded with no trend, the constraints
//! hold to round-off. The CAS runs in-process on its one worker thread (loading the scenes).

use std::path::{Path, PathBuf};

use hamel_sim::dla::Variant;

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
}

/// The slope of a least-squares line through the samples over the last 90 % of the run, in
/// units of the run's length (so comparable with the spread), and the spread max − min.
fn trend_and_spread(e: &[f64]) -> (f64, f64) {
    let tail = &e[e.len() / 10..];
    let n = tail.len() as f64;
    let mean_x = (n - 1.0) / 2.0;
    let mean_y = tail.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, y) in tail.iter().enumerate() {
        let dx = i as f64 - mean_x;
        sxy += dx * (y - mean_y);
        sxx += dx * dx;
    }
    let spread = e.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - e.iter().cloned().fold(f64::INFINITY, f64::min);
    ((sxy / sxx * n).abs(), spread)
}

fn long_run(name: &str, h: f64, steps: usize) {
    let loaded = hamel_run::load(&scene(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    let run = loaded
        .long_horizon(h, steps, 100, Variant::Reversible)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let (trend, spread) = trend_and_spread(&run.energy_error);
    let relative = spread / run.energy0.abs();
    println!(
        "{name}: {steps} steps of {h}: energy {:.6}, error spread {relative:.1e} (relative), trend {:.1e}, constraint {:.1e}",
        run.energy0,
        trend / run.energy0.abs(),
        run.constraint
    );
    assert!(relative < 1e-2, "{name}: energy error spread {relative:e}");
    assert!(
        trend < spread,
        "{name}: trend {trend:e} against spread {spread:e}"
    );
    assert!(
        run.constraint < 1e-12,
        "{name}: constraint {:e}",
        run.constraint
    );
}

#[test]
fn the_rolling_disk_keeps_its_energy_over_long_horizons() {
    long_run("rolling_disk.toml", 0.01, 200_000);
}

#[test]
fn the_chaplygin_sleigh_keeps_its_energy_over_long_horizons() {
    long_run("chaplygin_sleigh.toml", 0.01, 200_000);
}

#[test]
fn a_model_with_forces_is_refused() {
    let loaded = hamel_run::load(&scene("whipple_bicycle.toml")).unwrap();
    let e = loaded
        .long_horizon(0.01, 10, 1, Variant::Reversible)
        .unwrap_err();
    assert!(e.to_string().contains("conservative"), "{e}");
}

/// `scene`'s text with its `[accuracy]` replaced by `method = "dla"` at `step`, loaded.
fn on_dla(name: &str, step: f64) -> hamel_run::Loaded {
    let text = std::fs::read_to_string(scene(name)).unwrap();
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let cut = text.find("[accuracy]").expect("the scene sets an accuracy");
    let text = format!(
        "{}[integrator]\nmethod = \"dla\"\nstep = {step}\n",
        text[..cut].replace("../models", &models.display().to_string())
    );
    let dir = std::env::temp_dir().join(format!("hamel-dla-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{step}_{name}"));
    std::fs::write(&path, text).unwrap();
    let loaded = hamel_run::load(&path).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_file(&path).ok();
    loaded
}

/// A scene with `method = "dla"`: its outputs in the scene's state (η from q̇), second order
/// in the step against DOP853 at 1e-13, the energy and the constraints as the method keeps
/// them, through the same monitors and the same trajectory as the other methods.
#[test]
fn a_scene_runs_on_the_dla_method_at_second_order() {
    let reference = {
        let loaded = hamel_run::load(&scene("chaplygin_sleigh.toml")).unwrap();
        let options = hamel_sim::Options {
            rtol: 1e-13,
            atol: 1e-13,
            ..Default::default()
        };
        loaded
            .integrate(hamel_sim::Method::Dop853, &options)
            .unwrap()
            .solution
    };
    let mut errors = Vec::new();
    for h in [0.02, 0.01] {
        let loaded = on_dla("chaplygin_sleigh.toml", h);
        let simulated =
            hamel_run::simulate::run_loaded(&loaded, hamel_run::Engine::Compiled, false).unwrap();
        assert!(simulated.failure.is_none(), "{:?}", simulated.failure);
        let trajectory = simulated.trajectory;
        assert_eq!(trajectory.engine, hamel_run::Engine::Interpreted);
        let run = loaded
            .integrate(loaded.integrator.method, &loaded.integrator.options)
            .unwrap();
        let s = &run.solution;
        assert!(s.complete && s.t == reference.t);
        let error = (s.y.iter().zip(reference.y.iter()))
            .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
            .fold(0.0, f64::max);
        let (energy, constraint) = (s.stats.energy_drift, s.stats.constraint_drift);
        println!(
            "chaplygin sleigh on dla, step {h}: {} steps, error {error:.2e} against dop853, energy drift {energy:?}, constraint {constraint:?}",
            s.stats.steps
        );
        assert!(energy.unwrap() < 1e-3, "{energy:?}");
        errors.push(error);
    }
    let order = (errors[0] / errors[1]).log2();
    assert!((order - 2.0).abs() < 0.2, "observed order {order}");
}

/// The mean spacing of the maxima of the state's component `name` over a DOP853 run of the
/// scene: the period of its oscillation.
fn period_of(loaded: &hamel_run::Loaded, name: &str) -> f64 {
    let k = loaded.state_names().iter().position(|n| n == name).unwrap();
    let run = loaded
        .integrate(hamel_sim::Method::Dop853, &Default::default())
        .unwrap();
    let (t, y) = (&run.solution.t, &run.solution.y);
    let peaks: Vec<f64> = (1..t.len() - 1)
        .filter(|&i| y[i][k] > y[i - 1][k] && y[i][k] >= y[i + 1][k])
        .map(|i| t[i])
        .collect();
    (peaks[peaks.len() - 1] - peaks[0]) / (peaks.len() - 1) as f64
}

/// The acceptance's 10⁶ periods (issue 63), about 8 minutes a model: run with
/// `cargo test --release -p hamel-run --test long_horizon -- --ignored --nocapture`. The rolling
/// disk's period is its tilt's oscillation (measured on a DOP853 run of the scene, ≈ 0.46 s);
/// the sleigh does not oscillate (it settles into a straight run): its period is the time
/// constant of that settling.
#[test]
#[ignore]
fn a_million_periods() {
    // HAMEL_PERIODS: fewer periods for a quick look
    let periods: f64 = std::env::var("HAMEL_PERIODS").map_or(1e6, |p| p.parse().unwrap());
    let disk = hamel_run::load(&scene("rolling_disk.toml")).unwrap();
    let period = period_of(&disk, "theta");
    let steps = (periods * period / 0.01) as usize;
    println!("rolling disk: tilt period {period:.4} s, 10^6 periods = {steps} steps of 0.01");
    long_run("rolling_disk.toml", 0.01, steps);
    // m v̇ = m a ω², (I + m a²) ω̇ = −m a v ω: the turning decays at the rate kV, k = m a/(I +
    // m a²), V = √(2E/m) (E = 1.0416 in the scene: V = 1.0206, 1/kV = 0.318 s)
    let (m, i, a, e) = (2.0, 0.05, 0.2, 1.0416_f64);
    let time = (i + m * a * a) / (m * a * (2.0 * e / m).sqrt());
    let steps = (periods * time / 0.01) as usize;
    println!("chaplygin sleigh: time constant {time:.4} s, 10^6 of them = {steps} steps of 0.01");
    long_run("chaplygin_sleigh.toml", 0.01, steps);
}

/// The rolling disk's ingredients do not involve its position on the ground nor its spin
/// angle, and involve its heading and tilt only through sines and cosines: a long run keeps
/// the first three at zero and the angles within π of it (`hamel_sim::dla::Positions`).
#[test]
fn the_rolling_disks_coordinates_are_classified_from_its_trees() {
    use hamel_sim::dla::Coordinate;
    let loaded = hamel_run::load(&scene("rolling_disk.toml")).unwrap();
    let d = hamel_derive::derive(loaded.model(), Some("velocities")).unwrap();
    let kinds = hamel_run::dla::coordinates(&d);
    let two_pi = 2.0 * std::f64::consts::PI;
    // xC, yC, phi, psi, theta
    assert_eq!(
        kinds,
        [
            Coordinate::Absent,
            Coordinate::Absent,
            Coordinate::Periodic(two_pi),
            Coordinate::Absent,
            Coordinate::Periodic(two_pi)
        ]
    );
}
