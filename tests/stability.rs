//! Numerical stability at the extremes (issue 5 §4; figures in docs/stability.md).
//!
//! * Near the singular set of the quasi-velocities: the 3.2 bar under the paper's Z as
//!   φ → π/2 (δ = det[Z; α] → 0). The f64 evaluation of the true equations against the same
//!   in double-double: the error grows with the condition number of [Z; α] and stays within a
//!   small multiple of cond · ε.
//! * Extreme parameters: one mass scaled by 1e±8 (mass ratios 1e-8 … 1e8), one length by 1e±4,
//!   for the knife, the 3.2 bar, the rolling disk and the unicycle: q̈ = Γ̇η + Γη̇ from the f64
//!   evaluation against the Lagrange-multiplier oracle in double-double, within 1e-12 or, where
//!   [Z; α] or A_Γ is ill-conditioned (mass ratios of 1e8 make A_Γ so; the condition number of
//!   [Z; α] is not scale-free: lengths of 1e4 m next to angles make it large), within
//!   100 (cond [Z; α] + cond A_Γ)·ε.
//!
//! Each test prints its table (`cargo test --release --test stability -- --nocapture`). The CAS
//! runs in-process, on its one worker thread.

mod common;

use hamel_derive::conditioning::{STATED_MULTIPLE, problem_condition, singular_points};
use hamel_derive::{Compiled, derive};
use hamel_expr::{DD, Dual, Scalar};
use hamel_model::NumericModel;
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn dd(v: &[f64]) -> Vec<DD> {
    v.iter().map(|&x| DD::from_f64(x)).collect()
}

/// max |a − b| / max |b|.
fn relative(a: &[f64], b: &[DD]) -> f64 {
    let scale = b.iter().fold(0.0_f64, |m, x| m.max(x.value().abs()));
    a.iter()
        .zip(b)
        .map(|(x, y)| (DD::from_f64(*x) - *y).value().abs())
        .fold(0.0, f64::max)
        / scale.max(f64::MIN_POSITIVE)
}

#[test]
fn accuracy_degrades_with_the_condition_number_near_the_singular_set() {
    let model = common::models()
        .into_iter()
        .find(|m| m.name == "bar_blade")
        .unwrap();
    let d = derive(&model, Some("paper")).unwrap();
    let c = d.compile().unwrap();
    let params = d.parameters.clone();
    let eta = [0.5, 0.3];
    println!("| π/2 − φ | cond [Z; α] | rel. error of η̇ in f64 | error / (cond·ε) |");
    println!("|---|---|---|---|");
    let mut last_cond = 0.0;
    for k in 1..=8 {
        let eps = 10f64.powi(-k);
        let q = [0.1, 0.2, 0.3, std::f64::consts::FRAC_PI_2 - eps];
        let cond = c.condition(&q, &params).unwrap();
        let f = c.rhs::<f64>(&q, &eta, &params).unwrap();
        let r = c.rhs::<DD>(&dd(&q), &dd(&eta), &params).unwrap();
        let err = relative(&f.eta_dot, &r.eta_dot);
        let ratio = err / (cond * f64::EPSILON);
        println!("| 1e-{k} | {cond:.1e} | {err:.1e} | {ratio:.2} |");
        // The condition number grows like 1/ε, and the error stays within 10·cond·ε.
        assert!(cond > last_cond * 5.0, "cond {cond:e} after {last_cond:e}");
        assert!(ratio < 10.0, "error {err:e} at cond {cond:e}");
        last_cond = cond;
    }
    // At the singular set itself the evaluation refuses, naming the reason.
    let q = [0.1, 0.2, 0.3, std::f64::consts::FRAC_PI_2];
    match c.rhs::<f64>(&q, &eta, &params) {
        Err(e) => assert!(e.to_string().contains("singular"), "{e}"),
        Ok(r) => assert!(
            r.eta_dot.iter().all(|x| x.is_finite()) && c.condition(&q, &params).unwrap() > 1e15,
            "at φ = π/2 (in f64, cos φ = 6e-17) the evaluation must refuse or be finite and report the condition"
        ),
    }
}

/// q̈ = Γ̇η + Γη̇ from the structured f64 evaluation (Γ̇η by dual numbers along q̇ = Γη).
fn q_ddot(c: &Compiled, q: &[f64], eta: &[f64], params: &IndexMap<String, f64>) -> Vec<f64> {
    let r = c.rhs::<f64>(q, eta, params).unwrap();
    let qdual: Vec<Dual<f64>> = q
        .iter()
        .zip(&r.q_dot)
        .map(|(&v, &dv)| Dual::new(v, dv))
        .collect();
    let gamma = c.gamma::<Dual<f64>>(&qdual, params).unwrap();
    (0..q.len())
        .map(|k| {
            (0..eta.len()).fold(0.0, |acc, s| {
                acc + gamma[k][s].d * eta[s] + gamma[k][s].v * r.eta_dot[s]
            })
        })
        .collect()
}

#[test]
fn extreme_parameters_against_the_oracle_in_double_double() {
    let models = common::models();
    let cases = [
        ("knife", "paper"),
        ("bar_blade", "paper"),
        ("rolling_disk", "velocities"),
        ("unicycle_rider", "velocities"),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    println!(
        "| model | parameter × factor | states | worst rel. error of q̈ (f64 vs oracle in DD) | worst error / ((cond [Z; α] + cond A_Γ)·ε) |"
    );
    println!("|---|---|---|---|---|");
    for (name, eta_name) in cases {
        let model = models.iter().find(|m| m.name == name).unwrap();
        let d = derive(model, Some(eta_name)).unwrap();
        let c = d.compile().unwrap();
        let mass = d.parameters.keys().find(|k| k.starts_with('m')).cloned();
        let length = d
            .parameters
            .keys()
            .find(|k| k.starts_with('l') || k.starts_with('R') || k.starts_with("rho"))
            .cloned();
        let mut settings = Vec::new();
        for f in [1e-8, 1e8] {
            settings.extend(mass.clone().map(|m| (m, f)));
        }
        for f in [1e-4, 1e4] {
            settings.extend(length.clone().map(|l| (l, f)));
        }
        for (param, factor) in settings {
            let mut params = d.parameters.clone();
            *params.get_mut(&param).unwrap() *= factor;
            let nm = NumericModel::new(model, &params).unwrap();
            let (mut worst, mut worst_scaled, mut n) = (0.0_f64, 0.0_f64, 0);
            for _ in 0..200 {
                if n == 20 {
                    break;
                }
                let q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-1.5..1.5)).collect();
                let v: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-2.0..2.0)).collect();
                let cond = c.condition(&q, &params).unwrap();
                let qd = hamel_oracle::project(&nm, &q, &v).unwrap();
                let z = nm.quasi_velocity_matrix::<f64>(eta_name, &q).unwrap();
                let eta: Vec<f64> = z
                    .iter()
                    .map(|row| row.iter().zip(&qd).map(|(a, b)| a * b).sum())
                    .collect();
                // The oracle in double-double at the same state (q̇ = Γη recomputed there).
                let r = c.rhs::<DD>(&dd(&q), &dd(&eta), &params).unwrap();
                let Ok(oracle) = hamel_oracle::accelerations::<DD>(&nm, &dd(&q), &r.q_dot) else {
                    continue;
                };
                let e = relative(&q_ddot(&c, &q, &eta, &params), &oracle.q_ddot);
                let a = c.rhs::<f64>(&q, &eta, &params).unwrap().a_gamma;
                let sv =
                    nalgebra::DMatrix::from_fn(d.sigma, d.sigma, |i, j| a[i][j]).singular_values();
                let cond = cond + sv.max() / sv.min();
                worst = worst.max(e);
                worst_scaled = worst_scaled.max(e / (cond * f64::EPSILON));
                // Within 1e-12, or within 100 cond·ε where [Z; α] or A_Γ is ill-conditioned
                // (cond: the sum of their condition numbers).
                assert!(
                    e <= 1e-12 + 100.0 * cond * f64::EPSILON,
                    "{name} with {param} × {factor:e} at q = {q:?}: error {e:e}, cond {cond:e}"
                );
                n += 1;
            }
            println!(
                "| {name} ({eta_name}) | {param} × {factor:.0e} | {n} | {worst:.1e} | {worst_scaled:.2} |"
            );
            assert!(n >= 10, "{name}: too few states");
        }
    }
}

struct Disk(&'static hamel_models::Core);

impl hamel_sim::OdeSystem for Disk {
    fn dim(&self) -> usize {
        self.0.dims.ell + self.0.dims.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), hamel_sim::SystemError> {
        (self.0.full_into)(y, dy).map_err(|e| hamel_sim::SystemError::new(e.to_string()))
    }
    fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
        let ell = self.0.dims.ell;
        (self.0.full)(&y[..ell], &y[ell..]).ok().map(|r| r.energy)
    }
    /// ‖α(q)q̇‖∞ of the reconstruction, q̇ = Γ(q)η.
    fn constraint_residual(&self, _t: f64, y: &[f64]) -> Option<f64> {
        let ell = self.0.dims.ell;
        let mut dy = vec![0.0; y.len()];
        (self.0.full_into)(y, &mut dy).ok()?;
        Some(
            (self.0.constraint_residual)(&y[..ell], &dy[..ell])
                .iter()
                .fold(0.0_f64, |m, r| m.max(r.abs())),
        )
    }
}

/// The same disk in the Lagrange-multiplier form, state (q, q̇): q̈ from
/// [A αᵀ; α 0][q̈; λ] = [∇U − (Ȧq̇ − ∇_q T); −α̇q̇] (the oracle, f64). It enforces the constraints
/// only at acceleration level, so α(q)q̇ is free to drift.
struct Multipliers<'m>(NumericModel<'m>, usize);

impl hamel_sim::OdeSystem for Multipliers<'_> {
    fn dim(&self) -> usize {
        2 * self.1
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), hamel_sim::SystemError> {
        let ell = y.len() / 2;
        let a = hamel_oracle::accelerations::<f64>(&self.0, &y[..ell], &y[ell..])
            .map_err(|e| hamel_sim::SystemError::new(e.to_string()))?;
        dy[..ell].copy_from_slice(&y[ell..]);
        dy[ell..].copy_from_slice(&a.q_ddot);
        Ok(())
    }
    fn constraint_residual(&self, _t: f64, y: &[f64]) -> Option<f64> {
        let ell = y.len() / 2;
        hamel_oracle::constraint_residual(&self.0, &y[..ell], &y[ell..]).ok()
    }
}

/// Energy drift of the rolling disk (generated core, 1 kg, R = 0.3 m, rolling at ψ̇ = 10 rad/s
/// tilted by 0.1 rad: it nutates and precesses) after 10^k characteristic periods T = 2π/ψ̇,
/// k = 1 … `decades`, per integrator; the growth law from the last two decades: drift ∝ t^p
/// with p ≈ 1 linear, ≈ ½ random walk, ≈ 0 bounded.
fn long_horizon(decades: i32) -> Vec<(String, Vec<f64>, f64, Vec<f64>)> {
    use hamel_sim::{Method, Options};
    let core = hamel_models::MODELS
        .iter()
        .find(|c| c.model == "rolling_disk" && c.eta == "velocities")
        .unwrap();
    let period = 2.0 * std::f64::consts::PI / 10.0;
    let y0 = [0.0, 0.0, 0.0, 0.0, 0.1, 0.0, 10.0, 0.0];
    let times: Vec<f64> = (0..=decades).map(|k| period * 10f64.powi(k)).collect();
    let e0 = hamel_sim::OdeSystem::energy(&Disk(core), 0.0, &y0).unwrap();
    let methods = [
        ("dop853 1e-10", Method::Dop853, 1e-10),
        ("dopri5 1e-10", Method::Dopri5, 1e-10),
        (
            "rk4 T/100",
            Method::Rk4 {
                step: period / 100.0,
            },
            1e-10,
        ),
        (
            "gauss-legendre T/40",
            Method::GaussLegendre {
                stages: 3,
                step: Some(period / 40.0),
            },
            1e-12,
        ),
    ];
    let mut rows = Vec::new();
    for (name, method, tol) in methods {
        let options = Options {
            rtol: tol,
            atol: tol,
            max_steps: 100_000_000,
            ..Options::default()
        };
        // A run that exceeds its step budget keeps the decades it reached.
        let s = match hamel_sim::integrate(&Disk(core), method, 0.0, &y0, &times, &options) {
            Ok(s) => s,
            Err(e) => *e.partial,
        };
        let drift: Vec<f64> = s
            .energy
            .iter()
            .map(|e| ((e.unwrap() - e0) / e0).abs().max(1e-17))
            .collect();
        let n = drift.len();
        let p = if n >= 2 {
            (drift[n - 1] / drift[n - 2]).log10()
        } else {
            f64::NAN
        };
        let residual: Vec<f64> = s.constraint.iter().map(|r| r.unwrap()).collect();
        rows.push((name.to_string(), drift, p, residual));
    }
    rows
}

fn print_long_horizon(rows: &[(String, Vec<f64>, f64, Vec<f64>)]) {
    let decades = rows[0].1.len();
    print!("| integrator |");
    for k in 0..decades {
        print!(" after 1e{k} T |");
    }
    println!(" growth exponent p |");
    println!("|---|{}---|", "---|".repeat(decades));
    for (name, drift, p, _) in rows {
        print!("| {name} |");
        for k in 0..decades {
            match drift.get(k) {
                Some(d) => print!(" {d:.1e} |"),
                None => print!(" (step budget) |"),
            }
        }
        println!(" {p:.2} |");
    }
    println!("\nconstraint residual ‖α(q)q̇‖∞ of the reconstruction (q̇ = Γ(q)η):\n");
    print!("| integrator |");
    for k in 0..decades {
        print!(" after 1e{k} T |");
    }
    println!();
    println!("|---|{}", "---|".repeat(decades));
    for (name, _, _, residual) in rows {
        print!("| {name} |");
        for r in residual {
            print!(" {r:.1e} |");
        }
        println!();
    }
}

/// 10⁴ periods (a few seconds): the symplectic Gauss–Legendre method keeps the energy bounded
/// near round-off, the explicit methods drift, and every drift stays small.
#[test]
fn long_horizon_energy_drift_over_ten_thousand_periods() {
    let rows = long_horizon(4);
    print_long_horizon(&rows);
    assert!(
        rows.iter().all(|r| r.1.len() == 5),
        "every run reaches 10⁴ periods"
    );
    let gl = rows.iter().find(|r| r.0.starts_with("gauss")).unwrap();
    assert!(gl.1.iter().all(|&d| d < 1e-10), "{:?}", gl.1);
    for (name, drift, _, residual) in &rows {
        assert!(drift.iter().all(|&d| d < 1e-4), "{name}: {drift:?}");
        // The reconstruction stays on the constraints to round-off, whatever the horizon:
        // α(q)Γ(q) = 0 identically, so only rounding in q̇ = Γη is left.
        assert!(residual.iter().all(|&r| r < 1e-13), "{name}: {residual:?}");
    }
}

/// Constraint drift, Boltzmann–Hamel reconstruction against the Lagrange-multiplier form: the
/// same disk from the same state, DOP853 at rtol = atol = `tol`, for 10^`decades` periods;
/// the largest ‖α(q)q̇‖∞ over the outputs (one per period) up to 1, 10, … periods. The multiplier form enforces α q̈ + α̇ q̇ = 0 only, so the residual of the velocity
/// constraint is integrated error and grows; q̇ = Γ(q)η satisfies it identically.
fn constraint_drift(decades: i32, tol: f64) -> (Vec<f64>, Vec<f64>) {
    use hamel_sim::{Method, OdeSystem, Options};
    let core = hamel_models::MODELS
        .iter()
        .find(|c| c.model == "rolling_disk" && c.eta == "velocities")
        .unwrap();
    let model = hamel_model::Model::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/models/rolling_disk.toml"
    ))
    .unwrap();
    let nm = NumericModel::new(&model, &IndexMap::new()).unwrap();
    let period = 2.0 * std::f64::consts::PI / 10.0;
    let y0 = [0.0, 0.0, 0.0, 0.0, 0.1, 0.0, 10.0, 0.0];
    let ell = core.dims.ell;
    let mut dy = vec![0.0; y0.len()];
    Disk(core).rhs(0.0, &y0, &mut dy).unwrap();
    let z0: Vec<f64> = y0[..ell].iter().chain(&dy[..ell]).copied().collect();
    // Every period an output; the residual reported at 10^k T is its largest value so far.
    let n = 10usize.pow(decades as u32);
    let times: Vec<f64> = (1..=n).map(|j| period * j as f64).collect();
    let options = Options {
        rtol: tol,
        atol: tol,
        max_steps: 100_000_000,
        ..Options::default()
    };
    let bh = hamel_sim::integrate(&Disk(core), Method::Dop853, 0.0, &y0, &times, &options).unwrap();
    let lm = hamel_sim::integrate(
        &Multipliers(nm, ell),
        Method::Dop853,
        0.0,
        &z0,
        &times,
        &options,
    )
    .unwrap();
    let running_max = |s: &hamel_sim::Solution| -> Vec<f64> {
        (0..=decades)
            .map(|k| {
                s.constraint[..10usize.pow(k as u32)]
                    .iter()
                    .map(|r| r.unwrap())
                    .fold(0.0, f64::max)
            })
            .collect()
    };
    let (bh, lm) = (running_max(&bh), running_max(&lm));
    println!(
        "| form | {} |",
        (0..=decades)
            .map(|k| format!("up to 1e{k} T"))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|{}", "---|".repeat(decades as usize + 1));
    for (name, r) in [
        ("Boltzmann–Hamel, q̇ = Γ(q)η", &bh),
        ("Lagrange multipliers, (q, q̇)", &lm),
    ] {
        println!(
            "| {name} | {} |",
            r.iter()
                .map(|x| format!("{x:.1e}"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
    }
    (bh, lm)
}

/// 10³ periods in the suite: the multiplier form's residual grows to many times the
/// reconstruction's, which stays at round-off.
#[test]
fn the_multiplier_form_drifts_off_the_constraints_and_the_reconstruction_does_not() {
    let (bh, lm) = constraint_drift(3, 1e-6);
    assert!(bh.iter().all(|&r| r < 1e-14), "{bh:?}");
    let last = *lm.last().unwrap();
    assert!(
        last > 1e4 * bh.last().unwrap().max(1e-16),
        "{lm:?} against {bh:?}"
    );
}

/// 10⁴ periods at two tolerances (minutes): `cargo test --release --test stability -- --ignored
/// --nocapture`.
#[test]
#[ignore]
fn constraint_drift_over_ten_thousand_periods() {
    for tol in [1e-6, 1e-10] {
        println!("\nDOP853 at rtol = atol = {tol:e}:\n");
        constraint_drift(4, tol);
    }
}

/// 10⁶ periods (minutes): `cargo test --release --test stability -- --ignored --nocapture`.
/// Runs that exceed 10⁸ steps report the decades they reached.
#[test]
#[ignore]
fn long_horizon_energy_drift_over_a_million_periods() {
    print_long_horizon(&long_horizon(6));
}

/// Very fast and very slow motions: η scaled by 1e±6 at random states of the generated cores
/// (knife, 3.2 bar, rolling disk, unicycle), q̈ = Γ̇η + Γη̇ in f64 against the Lagrange-multiplier
/// oracle in double-double: no overflow, no loss beyond the conditioning (the velocity-quadratic
/// terms scale by 1e±12 against gravity, which stays).
#[test]
fn very_fast_and_very_slow_motions_against_the_oracle() {
    use hamel_models::runtime::DualN as GDual;
    let models = common::models();
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    println!("| core | η × | states | worst rel. error of q̈ |");
    println!("|---|---|---|---|");
    for (name, eta_name) in [
        ("knife", "paper"),
        ("bar_blade", "paper"),
        ("rolling_disk", "velocities"),
        ("unicycle_rider", "velocities"),
    ] {
        let core = hamel_models::MODELS
            .iter()
            .find(|c| c.model == name && c.eta == eta_name)
            .unwrap();
        let model = models.iter().find(|m| m.name == name).unwrap();
        let nm = NumericModel::new(model, &IndexMap::new()).unwrap();
        for scale in [1e-6, 1.0, 1e6] {
            let (mut worst, mut n) = (0.0_f64, 0);
            while n < 20 {
                let q: Vec<f64> = (0..core.dims.ell)
                    .map(|_| rng.random_range(-1.5..1.5))
                    .collect();
                let eta: Vec<f64> = (0..core.dims.sigma)
                    .map(|_| scale * rng.random_range(-2.0..2.0))
                    .collect();
                let Ok(g) = (core.full)(&q, &eta) else {
                    continue;
                };
                let qd: Vec<GDual<1>> = q
                    .iter()
                    .zip(&g.q_dot)
                    .map(|(&x, &dx)| GDual { v: x, d: [dx] })
                    .collect();
                let ed: Vec<GDual<1>> = eta.iter().map(|&x| GDual { v: x, d: [0.0] }).collect();
                let gd = (core.full_dual)(&qd, &ed).unwrap();
                let ge = (core.full)(&q, &g.eta_dot).unwrap();
                let q_ddot: Vec<f64> = (0..core.dims.ell)
                    .map(|k| gd.q_dot[k].d[0] + ge.q_dot[k])
                    .collect();
                let Ok(oracle) = hamel_oracle::accelerations::<DD>(&nm, &dd(&q), &dd(&g.q_dot))
                else {
                    continue;
                };
                assert!(q_ddot.iter().all(|x| x.is_finite()));
                worst = worst.max(relative(&q_ddot, &oracle.q_ddot));
                n += 1;
            }
            println!("| {name} ({eta_name}) | {scale:.0e} | {n} | {worst:.1e} |");
            assert!(worst < 1e-9, "{name} with η × {scale:e}: {worst:e}");
        }
    }
}

/// The rolling disk lying almost flat (θ → π/2) under the plain velocities (φ̇, ψ̇, θ̇): the
/// configuration is physically singular (at θ = π/2 the motion φ̇ = ψ̇ has no kinetic energy),
/// so A_Γ has an eigenvalue ∝ cos²θ. The structured f64 evaluation agrees with the same in
/// double-double, which agrees with the Lagrange-multiplier oracle in double-double to 1e-16.
/// Its error is that of any solve with the Gram matrix A_Γ, rounded: ε·cond A_Γ ∝ ε/cos²θ
/// (the exactly rounded A_Γ and b = A_Γη̇ solved in f64 lose as much). Asserted: within
/// 10·cond A_Γ·ε. Not yet met: the target of the problem's own conditioning (∝ 1/cos θ);
/// docs/stability.md says what it needs.
#[test]
fn the_flat_disk_keeps_the_digits_its_conditioning_allows() {
    let models = common::models();
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/models/rolling_disk.toml");
    // The second choice: body rates about the disk's diameter and axis.
    let text = std::fs::read_to_string(file).unwrap()
        + "\n[quasi_velocities.body_rates]\neta = [\"cos(theta)*der(phi)\", \"der(theta)\", \"der(psi) - sin(theta)*der(phi)\"]\n";
    let with_rates = hamel_model::Model::from_source(file, &text).unwrap();
    let model = models.iter().find(|m| m.name == "rolling_disk").unwrap();
    let nm = NumericModel::new(model, &IndexMap::new()).unwrap();
    println!(
        "| choice | π/2 − θ | κ of the problem | cond A_Γ | f64 throughout | `evaluate` (adaptive) | its precision | error / ((κ + 1)·ε) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (m, choice) in [(model, "velocities"), (&with_rates, "body_rates")] {
        let d = derive(m, Some(choice)).unwrap();
        let c = d.compile().unwrap();
        let params = d.parameters.clone();
        for k in 1..=7 {
            let h = 10f64.powi(-k);
            let q = [0.3, -0.2, 0.7, 1.1, std::f64::consts::FRAC_PI_2 - h];
            let eta = [0.8, -1.3, 0.4];
            let plain = c.rhs::<f64>(&q, &eta, &params).unwrap();
            let r = c.rhs::<DD>(&dd(&q), &dd(&eta), &params).unwrap();
            // The independent oracle: q̈ in double-double at q̇ = Γη, against Γη̇ + Γ̇η.
            let o = hamel_oracle::accelerations::<DD>(&nm, &dd(&q), &r.q_dot).unwrap();
            if choice == "velocities" {
                let structured: Vec<f64> = r.eta_dot.iter().map(|x| x.value()).collect();
                assert!(relative(&structured, &o.q_ddot[2..]) < 1e-15);
            }
            let ev = c.evaluate(&q, &eta, &params).unwrap();
            let kappa = problem_condition(&c, &q, &eta, &params).unwrap();
            let ag = nalgebra::DMatrix::from_fn(3, 3, |i, j| r.a_gamma[i][j].value());
            let e = ag.symmetric_eigen().eigenvalues;
            let (raw, err) = (
                relative(&plain.eta_dot, &r.eta_dot),
                relative(&ev.eta_dot, &r.eta_dot),
            );
            let ratio = err / ((kappa + 1.0) * f64::EPSILON);
            println!(
                "| {choice} | 1e-{k} | {kappa:.1e} | {:.1e} | {raw:.1e} | {err:.1e} | {:?} | {ratio:.2} |",
                e.max() / e.min(),
                ev.precision
            );
            assert!(
                ratio <= STATED_MULTIPLE,
                "{choice}, θ = π/2 − 1e-{k}: error {err:e}, κ {kappa:e}"
            );
        }
    }
}

/// One evaluator's worst error over a sweep, and its ratio to κ·ε.
#[derive(Default, Clone, Copy)]
struct Worst {
    error: f64,
    ratio: f64,
    states: usize,
}

impl Worst {
    /// Records one state; the ratio is error / ((κ + 1)·ε): no f64 result is better than its
    /// own rounding, whatever κ.
    fn add(&mut self, error: f64, kappa: f64) {
        self.error = self.error.max(error);
        self.ratio = self.ratio.max(error / ((kappa + 1.0) * f64::EPSILON));
        self.states += 1;
    }
}

/// Every evaluator, at states approaching q_k → target from both sides (distances 1e-1 … 1e-8),
/// against the same equations in double-double: (κ range, eval, generated fast, generated
/// structured).
fn sweep(
    c: &Compiled,
    core: Option<&hamel_models::Core>,
    params: &IndexMap<String, f64>,
    at: (&[f64], usize, usize),
    rng: &mut ChaCha8Rng,
) -> ((f64, f64), [Worst; 3]) {
    let (q_star, k, sigma) = at;
    let ell = q_star.len();
    let mut worst = [Worst::default(); 3];
    let mut kappas = (f64::INFINITY, 0.0_f64);
    for side in [1.0, -1.0] {
        for e in 1..=8 {
            let mut q = q_star.to_vec();
            q[k] += side * 10f64.powi(-e);
            let eta: Vec<f64> = (0..sigma).map(|_| rng.random_range(-2.0..2.0)).collect();
            let Ok(reference) = c.rhs::<DD>(&dd(&q), &dd(&eta), params) else {
                continue;
            };
            let Ok(kappa) = problem_condition(c, &q, &eta, params) else {
                continue;
            };
            if !kappa.is_finite() {
                continue;
            }
            kappas = (kappas.0.min(kappa), kappas.1.max(kappa));
            if let Ok(ev) = c.evaluate(&q, &eta, params) {
                worst[0].add(relative(&ev.eta_dot, &reference.eta_dot), kappa);
            }
            if let Some(core) = core {
                let mut y: Vec<f64> = q.iter().chain(&eta).copied().collect();
                let mut dy = vec![0.0; y.len()];
                if (core.full_into_per_call)(&y, &mut dy).is_ok() {
                    worst[1].add(relative(&dy[ell..], &reference.eta_dot), kappa);
                }
                y.truncate(ell);
                if let Ok(r) = (core.full)(&y, &eta) {
                    worst[2].add(relative(&r.eta_dot, &reference.eta_dot), kappa);
                }
            }
        }
    }
    (kappas, worst)
}

#[test]
fn every_evaluator_near_every_singular_configuration_is_within_a_multiple_of_the_problems_condition()
 {
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    println!(
        "| model (choice) | approaching | states | κ of the problem | eval: error, / (κ + 1)ε | generated fast | generated structured |"
    );
    println!("|---|---|---|---|---|---|---|");
    let show = |w: &Worst| {
        if w.states == 0 {
            "—".to_string()
        } else {
            format!("{:.1e}, {:.2}", w.error, w.ratio)
        }
    };
    for model in common::models() {
        let mut choices: Vec<Option<String>> =
            model.choices.iter().map(|c| Some(c.name.clone())).collect();
        if choices.is_empty() {
            choices.push(None);
        }
        for choice in choices {
            let d = derive(&model, choice.as_deref()).unwrap();
            // Families with free functions (z13(phi), …) have no numeric values.
            let Ok(c) = d.compile() else { continue };
            let params = d.parameters.clone();
            let core = hamel_models::MODELS
                .iter()
                .find(|k| k.model == model.name && k.eta == d.eta_name && k.scene.is_empty());
            let sigma = d.eta.len();
            let mut targets: Vec<(String, Vec<f64>, usize)> = Vec::new();
            for p in singular_points(&d, &params, 14) {
                let g = &d.singular_set()[p.factor].text;
                let label = if g.chars().count() <= 40 {
                    format!("{g} = 0")
                } else {
                    format!(
                        "factor {} of δ = 0 ({} characters)",
                        p.factor + 1,
                        g.chars().count()
                    )
                };
                targets.push((label, p.q, p.coordinate));
            }
            if targets.is_empty() {
                println!(
                    "| {} ({}) | singular nowhere in q ({}) | | | | | |",
                    model.name,
                    d.eta_name,
                    if d.singular_set().is_empty() {
                        "δ has no factor".to_string()
                    } else {
                        "factors of parameters only".to_string()
                    }
                );
            }
            // Where the physics is singular: the disk (and the unicycle's wheel) lying flat.
            if matches!(model.name.as_str(), "rolling_disk" | "unicycle_rider") {
                let k = d.coordinates.iter().position(|c| c == "theta").unwrap();
                let mut q: Vec<f64> = (0..d.coordinates.len())
                    .map(|_| rng.random_range(-3.0..3.0))
                    .collect();
                q[k] = std::f64::consts::FRAC_PI_2;
                targets.push(("theta = π/2 (lying flat)".into(), q, k));
            }
            for (label, q, k) in targets {
                let (kappa, worst) = sweep(&c, core, &params, (&q, k, sigma), &mut rng);
                println!(
                    "| {} ({}) | {label} | {} | {:.1e} … {:.1e} | {} | {} | {} |",
                    model.name,
                    d.eta_name,
                    worst[0].states,
                    kappa.0,
                    kappa.1,
                    show(&worst[0]),
                    show(&worst[1]),
                    show(&worst[2])
                );
                for (w, evaluator) in
                    worst
                        .iter()
                        .zip(["eval", "generated fast", "generated structured"])
                {
                    assert!(
                        w.ratio <= STATED_MULTIPLE,
                        "{} ({}) approaching {label}: {evaluator} error {:e} is {:.1} (κ + 1)·ε",
                        model.name,
                        d.eta_name,
                        w.error,
                        w.ratio
                    );
                }
            }
        }
    }
}

/// How often `evaluate` repeats an f64 evaluation in double-double at ordinary states (uniform
/// in (−3, 3) for q, (−2, 2) for η; states where cond [Z; α] > 1e6 skipped), and whether its
/// estimate can be trusted: a result kept in f64 must be within the threshold of the
/// double-double evaluation, a repeated one within a few units of rounding.
#[test]
fn the_double_double_repeat_is_decided_by_an_estimate_that_holds() {
    let mut rng = ChaCha8Rng::seed_from_u64(15);
    println!(
        "| model (choice) | states | repeated in double-double | worst error kept in f64 | largest estimate |"
    );
    println!("|---|---|---|---|---|");
    let mut total = (0usize, 0usize);
    for model in common::models() {
        for choice in &model.choices {
            let d = derive(&model, Some(&choice.name)).unwrap();
            let Ok(c) = d.compile() else { continue };
            let params = d.parameters.clone();
            let (mut n, mut repeated, mut kept, mut largest) = (0usize, 0usize, 0.0_f64, 0.0_f64);
            while n < 200 {
                let q: Vec<f64> = (0..d.coordinates.len())
                    .map(|_| rng.random_range(-3.0..3.0))
                    .collect();
                let eta: Vec<f64> = (0..d.eta.len())
                    .map(|_| rng.random_range(-2.0..2.0))
                    .collect();
                if c.condition(&q, &params).unwrap() > 1e6 {
                    continue;
                }
                let Ok(ev) = c.evaluate(&q, &eta, &params) else {
                    continue;
                };
                let reference = c.rhs::<DD>(&dd(&q), &dd(&eta), &params).unwrap();
                let err = relative(&ev.eta_dot, &reference.eta_dot);
                n += 1;
                largest = largest.max(ev.f64_error_estimate);
                if ev.precision == hamel_derive::Precision::DoubleDouble {
                    repeated += 1;
                    assert!(
                        err <= 4.0 * f64::EPSILON,
                        "{}: repeated, error {err:e}",
                        model.name
                    );
                } else {
                    kept = kept.max(err);
                    // The estimate is first order and leaves out the constants of the error
                    // bounds (dot products of length ℓ, the ingredients): a factor 8 of slack.
                    assert!(
                        err <= 8.0 * hamel_derive::DOUBLE_DOUBLE_ABOVE,
                        "{} at {q:?}, {eta:?}: kept in f64 with error {err:e}, estimate {:e}",
                        model.name,
                        ev.f64_error_estimate
                    );
                }
            }
            println!(
                "| {} ({}) | {n} | {repeated} | {kept:.1e} | {largest:.1e} |",
                model.name, d.eta_name
            );
            total = (total.0 + n, total.1 + repeated);
        }
    }
    println!("| all | {} | {} | | |", total.0, total.1);
}
