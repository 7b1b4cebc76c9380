//! Random mechanical systems against the independent oracle (issue 19).
//!
//! proptest draws models (tests/random/spec.rs: hand-typed Lagrangians with trigonometric
//! constraints, chains of bodies on a knife edge, rolling disks with riders; quasi-velocities
//! that are the default velocities, rotated ones or conjugate momenta) and checks, for each:
//! * η̇ of the Boltzmann–Hamel equations against the Lagrange-multiplier form at random states
//!   on the constraint manifold ([`common::oracle::compare_with`]): 1e-12 relative in f64
//!   where cond[Z; α] ≤ 100 and cond[Z; α]·cond(A_Γ) ≤ 1e4, and the checked evaluation
//!   (f64 repeated in double-double where its error estimate asks) to 1e-10 up to cond 1e4,
//!   1e-20 in double-double, and the closed form's expanded equations in double-double;
//! * the energy T − U, computed from the model's own A and U, along a short trajectory
//!   integrated from hamel's equations (DOP853, tolerance 1e-12);
//! * `reduce`'s ground truth: at random states, moving a coordinate it proves absent does not
//!   change η̇ (double-double, 1e-20).
//!
//! A few models run by default (`HAMEL_RANDOM_MODELS`, default 6); the release check runs
//! 1,000: `HAMEL_RANDOM_MODELS=1000 cargo test --release --test random_models -- --nocapture`.
//! The seed is fixed (`HAMEL_RANDOM_SEED`, default 19), so a run is reproducible;
//! `HAMEL_RANDOM_TRACE=1` prints each model before it is checked. A failure is
//! shrunk by proptest and printed as a model file: it goes into tests/models/random/, which
//! `regressions_stay_fixed` checks on every run.
//!
//! The CAS runs in-process, on its one worker thread; this binary starts no `hamel` process.

mod common;
#[path = "random/spec.rs"]
mod spec;

use std::collections::BTreeMap;
use std::sync::Mutex;

use common::oracle::{
    F64_CONDITION, F64_PROBLEM, TOL, WELL_CONDITIONED, WELL_CONDITIONED_PROBLEM, Worst,
    compare_with, dd,
};
use common::rel_error;
use hamel_derive::{Compiled, Derivation};
use hamel_expr::DD;
use hamel_model::{Model, NumericModel};
use hamel_sim::{Method, OdeSystem, Options, SystemError, integrate};
use indexmap::IndexMap;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestError, TestRng, TestRunner};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spec::Spec;

/// States compared with the oracle per model.
const STATES: usize = 20;
/// States compared with the oracle per regression model (tests/models/random/).
const REGRESSION_STATES: usize = 60;
/// States at which each coordinate proved absent is moved.
const MOVES: usize = 5;

/// What the checks of one model measured.
#[derive(Clone, Debug, Default)]
struct Measured {
    family: String,
    /// f64 (cond ≤ 100), f64 (≤ 1e4), double-double, closed form in double-double, the
    /// checked evaluation, f64 error / estimate.
    worst: [f64; 6],
    energy_drift: Option<f64>,
    absent: usize,
    structured: bool,
    /// States compared in f64: held to 1e-12, and to 1e-10 (see [`Worst`]).
    f64_states: [usize; 2],
}

/// The checks of one model (a failed assertion is a panic, which proptest catches and shrinks).
fn check(text: &str, family: &str, seed: u64, states: usize) -> Measured {
    let model = Model::from_source("random.toml", text).unwrap_or_else(|e| panic!("{e}"));
    let choice = model.choices[0].name.clone();
    let all = model.coordinates.clone();
    let (reduction, d) = common::reduce_with_derivation(&model, Some(&choice), &all)
        .unwrap_or_else(|e| panic!("{e}"));
    let w = compare_with(&model, &choice, &d, seed, states);
    assert_oracle(&w);
    let c = d.compile().unwrap();
    let absent: Vec<usize> = reduction
        .ground_truth
        .absent
        .iter()
        .map(|n| all.iter().position(|c| c == n).unwrap())
        .collect();
    check_absent(&c, &d, &absent, seed);
    Measured {
        family: family.to_string(),
        worst: [
            w.well_conditioned_f64,
            w.structured_f64,
            w.structured_dd,
            w.symbolic_dd,
            w.checked_f64,
            w.estimate_ratio,
        ],
        energy_drift: energy_drift(&model, &c, &d, seed),
        absent: absent.len(),
        structured: w.structured_form,
        f64_states: [w.well_conditioned_states, w.f64_states],
    }
}

fn assert_oracle(w: &Worst) {
    let line = format!(
        "f64 {:.1e} at {} states (cond ≤ {WELL_CONDITIONED}, problem ≤ {WELL_CONDITIONED_PROBLEM:e}), {:.1e} at {} (cond ≤ {F64_CONDITION}, problem ≤ {F64_PROBLEM:e}); dd {:.1e}; symbolic dd {:.1e}; checked {:.1e}; f64 error / estimate {:.2}",
        w.well_conditioned_f64,
        w.well_conditioned_states,
        w.structured_f64,
        w.f64_states,
        w.structured_dd,
        w.symbolic_dd,
        w.checked_f64,
        w.estimate_ratio
    );
    // In q̈ the f64 error of η̇ (about cond[Z; α]·ε) is multiplied by |Γ| again: about
    // cond²·ε, 2.4e-10 at cond 4e3. So past the well-conditioned states, what is held to
    // 1e-10 is the checked evaluation (which `simulate` uses: it repeats in double-double
    // where its error estimate asks). How far the f64 error of η̇ exceeds that estimate is
    // reported, not asserted: the estimate is first order (the regression models reach 11;
    // docs/reliability.md §3).
    assert!(
        w.well_conditioned_f64 <= 1e-12
            && w.structured_dd <= 1e-20
            && w.symbolic_dd <= TOL
            && w.checked_f64 <= TOL,
        "against the oracle: {line}"
    );
}

/// Moving a coordinate the ground truth proves absent leaves η̇ unchanged (double-double).
fn check_absent(c: &Compiled, d: &Derivation, absent: &[usize], seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xab5e);
    let params = &d.parameters;
    for &k in absent {
        let mut moved = 0;
        for _ in 0..20 * MOVES {
            if moved == MOVES {
                break;
            }
            let q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-3.0..3.0)).collect();
            let eta: Vec<f64> = (0..d.sigma).map(|_| rng.random_range(-2.0..2.0)).collect();
            let mut q2 = q.clone();
            q2[k] = rng.random_range(-3.0..3.0);
            let at = |q: &[f64]| {
                let cond = c.condition(q, params).ok()?;
                (cond <= 1e6).then_some(())?;
                let (q, eta) = (dd(q), dd(&eta));
                c.rhs::<DD>(&q, &eta, params).ok().map(|r| r.eta_dot)
            };
            let (Some(a), Some(b)) = (at(&q), at(&q2)) else {
                continue;
            };
            let e = rel_error(&a, &b);
            assert!(
                e <= 1e-20,
                "{} is proved absent, but moving it from {} to {} changes η̇ by {e:.1e} (q = {q:?}, η = {eta:?})",
                d.coordinates[k],
                q[k],
                q2[k]
            );
            moved += 1;
        }
        assert_eq!(
            moved, MOVES,
            "too few regular states to move {}",
            d.coordinates[k]
        );
    }
}

/// hamel's equations (q̇ = Γη and η̇ of (11)) as an ODE system, y = (q, η).
struct Flow<'a> {
    c: &'a Compiled,
    params: &'a IndexMap<String, f64>,
    ell: usize,
    sigma: usize,
    /// The largest cond[Z; α] met along the path.
    condition: std::cell::Cell<f64>,
}

impl OdeSystem for Flow<'_> {
    fn dim(&self) -> usize {
        self.ell + self.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        let (q, eta) = y.split_at(self.ell);
        let e = self
            .c
            .evaluate(q, eta, self.params)
            .map_err(|e| SystemError::new(e.to_string()))?;
        self.condition.set(self.condition.get().max(e.condition));
        dy[..self.ell].copy_from_slice(&e.q_dot);
        dy[self.ell..].copy_from_slice(&e.eta_dot);
        Ok(())
    }
}

/// The largest relative change of T − U (from the model's A and U, not from the derivation)
/// along 1 s from a well-conditioned random state; `None` when the path comes near the singular
/// set of [Z; α] (cond > 1e4) or the integration stops there (it is counted, not hidden).
fn energy_drift(model: &Model, c: &Compiled, d: &Derivation, seed: u64) -> Option<f64> {
    let nm = NumericModel::new(model, &IndexMap::new()).unwrap();
    let params = &d.parameters;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xe7e7);
    let (q, eta) = loop {
        let q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-1.0..1.0)).collect();
        let eta: Vec<f64> = (0..d.sigma).map(|_| rng.random_range(-1.0..1.0)).collect();
        if c.condition(&q, params).is_ok_and(|k| k <= WELL_CONDITIONED) {
            break (q, eta);
        }
    };
    let flow = Flow {
        c,
        params,
        ell: d.ell,
        sigma: d.sigma,
        condition: std::cell::Cell::new(0.0),
    };
    let y0: Vec<f64> = q.iter().chain(&eta).copied().collect();
    let times: Vec<f64> = (1..=10).map(|i| i as f64 / 10.0).collect();
    let options = Options {
        rtol: 1e-12,
        atol: 1e-12,
        ..Options::default()
    };
    let solution = integrate(&flow, Method::Dop853, 0.0, &y0, &times, &options).ok()?;
    let energy = |y: &[f64]| {
        let (q, eta) = y.split_at(d.ell);
        let qd = c.rhs::<f64>(q, eta, params).unwrap().q_dot;
        let a = nm.mass_matrix::<f64>(q).unwrap();
        let t: f64 = (0..d.ell)
            .flat_map(|i| (0..d.ell).map(move |j| (i, j)))
            .map(|(i, j)| 0.5 * qd[i] * a[i][j] * qd[j])
            .sum();
        let residual = hamel_oracle::constraint_residual(&nm, q, &qd).unwrap();
        assert!(residual <= 1e-9 * (1.0 + t.sqrt()), "α q̇ = {residual:.1e}");
        (t - nm.potential::<f64>(q).unwrap(), t)
    };
    let (e0, t0) = energy(&y0);
    let scale = e0.abs().max(t0).max(1e-3);
    let drift = solution
        .y
        .iter()
        .map(|y| (energy(y).0 - e0).abs() / scale)
        .fold(0.0, f64::max);
    let condition = flow.condition.get();
    if condition > F64_CONDITION {
        return None; // near the singular set f64 loses cond·ε: counted, not asserted
    }
    assert!(
        drift <= 1e-8,
        "energy drifts by {drift:.1e} in 1 s; largest cond[Z; α] {condition:.1e}; {} steps",
        solution.stats.steps
    );
    Some(drift)
}

/// Everything the run measured, for the summary.
#[derive(Default)]
struct Tally {
    measured: Vec<Measured>,
    rejected: BTreeMap<String, usize>,
}

static TALLY: Mutex<Tally> = Mutex::new(Tally {
    measured: Vec::new(),
    rejected: BTreeMap::new(),
});

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .map(|v| {
            v.parse()
                .unwrap_or_else(|_| panic!("{name} must be a number"))
        })
        .unwrap_or(default)
}

/// One drawn model: written, loaded (a system that hamel refuses, such as dependent
/// constraints, is rejected and counted), checked.
fn run_one(spec: &Spec, seed: u64) -> Result<(), TestCaseError> {
    let system = spec.system_text();
    let loaded = Model::from_source("random.toml", &system)
        .and_then(|base| Model::from_source("random.toml", &spec.model_text(&base)));
    let Ok(model) = loaded else {
        let reason = loaded.unwrap_err().to_string();
        let first = reason.lines().next().unwrap_or_default().to_string();
        if std::env::var_os("HAMEL_RANDOM_TRACE").is_some() {
            eprintln!("refused {}: {reason}", spec.family());
        }
        *TALLY.lock().unwrap().rejected.entry(first).or_default() += 1;
        return Err(TestCaseError::reject(reason));
    };
    if std::env::var_os("HAMEL_RANDOM_TRACE").is_some() {
        eprintln!(
            "checking {} (seed {seed}):\n{}",
            spec.family(),
            model.source
        );
    }
    let measured = check(&model.source, &spec.family(), seed, STATES);
    TALLY.lock().unwrap().measured.push(measured);
    Ok(())
}

#[test]
fn random_models_match_the_oracle() {
    let cases = env_or("HAMEL_RANDOM_MODELS", 6) as u32;
    let seed = env_or("HAMEL_RANDOM_SEED", 19);
    let config = Config {
        cases,
        max_global_rejects: cases.max(64) * 2,
        failure_persistence: None,
        max_shrink_iters: 200,
        max_shrink_time: 300_000,
        ..Config::default()
    };
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &bytes);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let counter = std::sync::atomic::AtomicU64::new(0);
    let result = runner.run(&spec::spec(), |s| {
        let n = counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        run_one(&s, seed.wrapping_mul(1_000_003).wrapping_add(n))
    });
    let tally = TALLY.lock().unwrap();
    eprintln!("{}", summary(&tally));
    match result {
        Ok(()) => {}
        Err(TestError::Fail(reason, s)) => {
            let text = Model::from_source("random.toml", &s.system_text())
                .map(|base| s.model_text(&base))
                .unwrap_or_else(|_| s.system_text());
            panic!(
                "{reason}\nthe smallest failing model (save it in tests/models/random/):\n{text}"
            )
        }
        Err(TestError::Abort(reason)) => panic!("aborted: {reason}"),
    }
    assert!(tally.measured.len() >= cases as usize);
    let rejected: usize = tally.rejected.values().sum();
    assert!(
        rejected * 4 <= tally.measured.len().max(4),
        "{rejected} of {} drawn models were refused",
        rejected + tally.measured.len()
    );
}

fn summary(t: &Tally) -> String {
    let mut by_family: BTreeMap<&str, usize> = BTreeMap::new();
    for m in &t.measured {
        *by_family.entry(&m.family).or_default() += 1;
    }
    let worst = |i: usize| t.measured.iter().map(|m| m.worst[i]).fold(0.0, f64::max);
    let states = |i: usize| t.measured.iter().map(|m| m.f64_states[i]).sum::<usize>();
    let drifts: Vec<f64> = t.measured.iter().filter_map(|m| m.energy_drift).collect();
    let mut s = format!(
        "random models checked: {} ({} in structured form)\n",
        t.measured.len(),
        t.measured.iter().filter(|m| m.structured).count()
    );
    for (f, n) in by_family {
        s += &format!("  {f}: {n}\n");
    }
    s += &format!(
        "worst relative error against the oracle: f64 {:.1e} at {} states (cond[Z; α] ≤ {WELL_CONDITIONED}, cond[Z; α]·cond(A_Γ) ≤ {WELL_CONDITIONED_PROBLEM:e}), {:.1e} at {} (≤ {F64_CONDITION}, ≤ {F64_PROBLEM:e}); double-double {:.1e}; closed form in double-double {:.1e}; checked evaluation {:.1e}; f64 error of η̇ / its estimate {:.2}\n",
        worst(0),
        states(0),
        worst(1),
        states(1),
        worst(2),
        worst(3),
        worst(4),
        worst(5)
    );
    s += &format!(
        "energy along 1 s: {} trajectories, worst drift {:.1e}; {} met the singular set\n",
        drifts.len(),
        drifts.iter().copied().fold(0.0, f64::max),
        t.measured.len() - drifts.len()
    );
    s += &format!(
        "coordinates proved absent and moved: {}\n",
        t.measured.iter().map(|m| m.absent).sum::<usize>()
    );
    for (reason, n) in &t.rejected {
        s += &format!("refused ({n}): {reason}\n");
    }
    s
}

/// The models the random runs found trouble with (tests/models/random/), each now a fixed
/// test: `closed_form_too_large.toml` made `derive` run for minutes; it is now derived in
/// structured form, and checked like any random model. `rider_with_ill_conditioned_mass.toml`
/// failed the f64 comparison by 3.3e-11 where A_Γ's condition number reached 1e5 (the oracle's
/// own f64 error was as large): the 1e-12 is now asked where the whole problem is well
/// conditioned, not only [Z; α].
#[test]
fn regressions_stay_fixed() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/models/random");
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    paths.sort();
    assert!(!paths.is_empty());
    for p in &paths {
        let text = std::fs::read_to_string(p).unwrap();
        let name = p.file_stem().unwrap().to_string_lossy().to_string();
        // Seeded by name, so that adding a file changes no other file's states.
        let seed = name
            .bytes()
            .fold(19u64, |h, b| h.wrapping_mul(31).wrapping_add(b as u64));
        let m = check(&text, &name, seed, REGRESSION_STATES);
        eprintln!("{name}: f64 error of η̇ / its estimate {:.1}", m.worst[5]);
        if name == "closed_form_too_large" {
            assert!(m.structured, "{name} should be derived in structured form");
        }
        if name == "rider_with_ill_conditioned_mass" {
            // [Z; α] is well conditioned throughout, A_Γ is not everywhere: the states where
            // f64 cannot give 1e-12 (hamel's nor the oracle's) are left to double-double.
            assert!(
                m.f64_states[0] < REGRESSION_STATES && m.f64_states[0] >= REGRESSION_STATES / 2,
                "{name}: {:?} of {REGRESSION_STATES} states compared in f64",
                m.f64_states
            );
        }
    }
}
