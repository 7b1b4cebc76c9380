//! hamel's models on the discrete Lagrange–d'Alembert integrator ([`hamel_sim::dla`]), for
//! long horizons: L = ½ q̇ᵀA(q)q̇ + U(q) with α(q)q̇ = 0 as a [`Nonholonomic`] system.
//!
//! **Inputs**: a derivation's compiled ingredients ([`Compiled::ingredients_at`]: A, U, ∇U,
//! ∂A/∂q, α on one tape) and parameter values. **Outputs**: M = A, V = −U, ∂L/∂q =
//! ½ q̇ᵀ(∂A/∂q)q̇ + ∇U and A = α's independent rows, at any q. **Invariant**: only models whose
//! energy is conserved are accepted ([`ModelSystem::new`]): no forces beyond ∇U, no holonomic
//! constraints (the method keeps none), no parameters set in time.

use hamel_derive::Compiled;
use hamel_expr::{Expr, Func};
use hamel_runtime::{Dims, Layout};
use hamel_sim::dla::{Coordinate, Nonholonomic};
use indexmap::IndexMap;
use nalgebra::DMatrix;

/// Why a model cannot run on the discrete Lagrange–d'Alembert integrator.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DlaRefusal {
    /// Its forces do work: the method is for conservative systems.
    #[error(
        "the model has forces beyond ∇U: the discrete Lagrange–d'Alembert method integrates conservative systems (use dop853, vern9 or taylor)"
    )]
    Forces,
    /// It has holonomic constraints the method does not keep.
    #[error(
        "the model has holonomic constraints, which the discrete Lagrange–d'Alembert method does not keep"
    )]
    Holonomic,
}

/// A model as a [`Nonholonomic`] system at fixed parameter values.
pub struct ModelSystem<'a> {
    compiled: &'a Compiled,
    params: IndexMap<String, f64>,
    dims: Dims,
    layout: Layout,
    /// The last configuration evaluated and its ingredients: a step asks for M, ∂L/∂q and α at
    /// the same q, which one evaluation of the tape gives.
    last: std::cell::RefCell<(Vec<f64>, Vec<f64>)>,
    /// How M, ∂L/∂q, α and U depend on each coordinate ([`coordinates`]).
    kinds: Vec<Coordinate>,
}

impl<'a> ModelSystem<'a> {
    /// The model of `compiled` at `params`; `holonomic` says whether it has holonomic
    /// constraints.
    pub fn new(
        compiled: &'a Compiled,
        params: IndexMap<String, f64>,
        holonomic: bool,
    ) -> Result<Self, DlaRefusal> {
        if compiled.has_forces() {
            return Err(DlaRefusal::Forces);
        }
        if holonomic {
            return Err(DlaRefusal::Holonomic);
        }
        let dims = compiled.dims();
        Ok(ModelSystem {
            compiled,
            params,
            dims,
            layout: Layout::new(dims),
            last: Default::default(),
            kinds: vec![Coordinate::General; dims.ell],
        })
    }

    /// With how the system depends on each coordinate ([`coordinates`]).
    pub fn with_coordinates(mut self, kinds: Vec<Coordinate>) -> Self {
        if kinds.len() == self.dims.ell {
            self.kinds = kinds;
        }
        self
    }

    /// The ingredients at q (NaN where they cannot be evaluated: the integrator then stops on
    /// a non-finite value), evaluated once per configuration.
    fn ingredients(&self, q: &[f64]) -> std::cell::Ref<'_, [f64]> {
        if self.last.borrow().0 != q {
            let out = self
                .compiled
                .ingredients_at(q, &self.params)
                .unwrap_or_else(|_| vec![f64::NAN; self.layout.len]);
            *self.last.borrow_mut() = (q.to_vec(), out);
        }
        std::cell::Ref::map(self.last.borrow(), |(_, out)| out.as_slice())
    }
}

impl Nonholonomic for ModelSystem<'_> {
    fn dim(&self) -> usize {
        self.dims.ell
    }
    fn constraints(&self) -> usize {
        self.dims.mu
    }
    fn mass(&self, q: &[f64], m: &mut DMatrix<f64>) {
        let out = self.ingredients(q);
        let l = self.dims.ell;
        *m = DMatrix::from_row_slice(l, l, &out[self.layout.a..self.layout.a + l * l]);
    }
    /// ∂L/∂q_k = ½ vᵀ(∂A/∂q_k)v + ∂U/∂q_k.
    fn force(&self, q: &[f64], v: &[f64], f: &mut [f64]) {
        let out = self.ingredients(q);
        let l = self.dims.ell;
        for (k, fk) in f.iter_mut().enumerate() {
            let da = &out[self.layout.da + k * l * l..self.layout.da + (k + 1) * l * l];
            let quadratic: f64 = (0..l)
                .map(|i| (0..l).map(|j| v[i] * da[i * l + j] * v[j]).sum::<f64>())
                .sum();
            *fk = 0.5 * quadratic + out[self.layout.grad_u + k];
        }
    }
    /// α's independent rows (its dependent ones, after them, add nothing).
    fn constraint_matrix(&self, q: &[f64], a: &mut DMatrix<f64>) {
        let out = self.ingredients(q);
        let (l, m) = (self.dims.ell, self.dims.mu);
        let alpha = &out[self.layout.alpha..self.layout.alpha + m * l];
        *a = DMatrix::from_row_slice(m, l, alpha);
    }
    fn potential(&self, q: &[f64]) -> f64 {
        -self.ingredients(q)[self.layout.u]
    }
    fn coordinate(&self, k: usize) -> Coordinate {
        self.kinds[k]
    }
}

/// How the ingredients a step reads (A, ∂A/∂q, U, ∇U and α's kept rows, from the derivation's
/// expressions: decided on the trees, not by sampling) depend on each coordinate: not at all
/// (absent from every tree), periodically with period 2π (only inside sin, cos and tan, through
/// integer multiples of it), or otherwise.
pub fn coordinates(d: &hamel_derive::Derivation) -> Vec<Coordinate> {
    let general = vec![Coordinate::General; d.ell];
    let Ok(exprs) = d.ingredient_exprs() else {
        return general;
    };
    let layout = Layout::new(d.dims());
    if exprs.len() != layout.len {
        return general;
    }
    let (l, m) = (d.ell, d.dims().mu);
    let read: Vec<&Expr> = [
        layout.alpha..layout.alpha + m * l,
        layout.a..layout.a + l * l,
        layout.u..layout.u + 1,
        layout.grad_u..layout.grad_u + l,
        layout.da..layout.da + l * l * l,
    ]
    .into_iter()
    .flat_map(|r| exprs[r].iter().copied())
    .collect();
    (d.coordinates.iter())
        .map(|c| {
            if !read.iter().any(|e| mentions(e, c)) {
                Coordinate::Absent
            } else if read.iter().all(|e| periodic_in(e, c)) {
                Coordinate::Periodic(2.0 * std::f64::consts::PI)
            } else {
                Coordinate::General
            }
        })
        .collect()
}

fn mentions(e: &Expr, c: &str) -> bool {
    e.any(&mut |x| match x {
        Expr::Sym(s) | Expr::Der(s) => s == c,
        Expr::Free { args, .. } => args.iter().any(|a| a == c),
        _ => false,
    })
}

/// Whether `e` is 2π-periodic in `c` by its form: every occurrence of `c` inside sin, cos or
/// tan of n·c + (terms free of c), n an integer.
fn periodic_in(e: &Expr, c: &str) -> bool {
    if !mentions(e, c) {
        return true;
    }
    match e {
        Expr::Call(Func::Sin | Func::Cos | Func::Tan, arg) => integer_multiple(arg, c),
        Expr::Add(v) | Expr::Mul(v) => v.iter().all(|x| periodic_in(x, c)),
        Expr::Neg(x) => periodic_in(x, c),
        Expr::Div(a, b) | Expr::Pow(a, b) | Expr::Atan2(a, b) => {
            periodic_in(a, c) && periodic_in(b, c)
        }
        Expr::Call(_, x) => periodic_in(x, c),
        Expr::Num(_) | Expr::Sym(_) | Expr::Der(_) | Expr::Free { .. } => false,
    }
}

/// Whether `arg` is n·c + (terms free of c) with n a nonzero integer.
fn integer_multiple(arg: &Expr, c: &str) -> bool {
    let term = |t: &Expr| match t {
        Expr::Sym(s) => s == c,
        Expr::Neg(x) => matches!(&**x, Expr::Sym(s) if s == c),
        Expr::Mul(v) => {
            v.len() == 2
                && v.iter().any(|x| matches!(x, Expr::Sym(s) if s == c))
                && v.iter().any(|x| x.as_integer().is_some())
        }
        _ => false,
    };
    match arg {
        Expr::Add(v) => v.iter().all(|t| !mentions(t, c) || term(t)),
        t => term(t),
    }
}

/// A long run of the discrete Lagrange–d'Alembert method on a scene's model
/// ([`crate::Loaded::long_horizon`]).
#[derive(Clone, Debug)]
pub struct LongRun {
    /// Steps taken.
    pub steps: usize,
    /// The energy at the start.
    pub energy0: f64,
    /// The energy's error E − E₀ at every `every`-th step (the start first).
    pub energy_error: Vec<f64>,
    /// The largest ‖α(q)q̇‖∞ over the run.
    pub constraint: f64,
    /// The configuration and velocities at the end.
    pub q: Vec<f64>,
    /// q̇ at the end.
    pub v: Vec<f64>,
}

impl crate::Loaded {
    /// The scene's model as a [`Nonholonomic`] system, with its initial configuration and
    /// velocities q̇₀ = Γ(q₀)η₀ (every coordinate, whatever the plan keeps).
    pub fn long_horizon_system(
        &self,
    ) -> Result<(ModelSystem<'_>, Vec<f64>, Vec<f64>), hamel_model::ModelError> {
        if !self.live.is_empty() {
            return Err(self.error(
                "integrator",
                "parameters set at every step: the discrete Lagrange–d'Alembert method integrates conservative systems".into(),
            ));
        }
        let holonomic = !self.model.holonomic.is_empty();
        let system = ModelSystem::new(&self.compiled, self.params.clone(), holonomic)
            .map_err(|e| self.error("integrator", e.to_string()))?
            .with_coordinates(coordinates(&self.d));
        let eta = &self.y0[self.state.len()..];
        let e = self
            .compiled
            .evaluate(&self.q0, eta, &self.params)
            .map_err(|e| self.error("initial", e.to_string()))?;
        Ok((system, self.q0.clone(), e.q_dot))
    }

    /// `steps` steps of `h` from the scene's initial state, the energy error kept every
    /// `every` steps (a run of 10⁶ steps keeps what a plot of it needs).
    pub fn long_horizon(
        &self,
        h: f64,
        steps: usize,
        every: usize,
        variant: hamel_sim::dla::Variant,
    ) -> Result<LongRun, hamel_model::ModelError> {
        let (system, mut q, mut v) = self.long_horizon_system()?;
        let energy0 = hamel_sim::dla::energy(&system, &q, &v);
        let mut dla = hamel_sim::dla::Dla::new(&system, h, variant);
        let (mut energy_error, mut constraint) = (vec![0.0], 0.0_f64);
        let mut a = DMatrix::zeros(system.constraints(), system.dim());
        let mut positions = hamel_sim::dla::Positions::new(&system, &q);
        for step in 1..=steps {
            positions.recentre();
            dla.step(&mut positions.local, &mut v)
                .map_err(|e| self.error("integrator", format!("step {step}: {e}")))?;
            let q = &positions.local;
            if step % every == 0 {
                energy_error.push(hamel_sim::dla::energy(&system, q, &v) - energy0);
                system.constraint_matrix(q, &mut a);
                let r = &a * nalgebra::DVector::from_column_slice(&v);
                constraint = constraint.max(r.amax());
            }
        }
        positions.absolute(&mut q);
        Ok(LongRun {
            steps,
            energy0,
            energy_error,
            constraint,
            q,
            v,
        })
    }
}

impl crate::Loaded {
    /// A scene run with `method = "dla"`: the model on the discrete Lagrange–d'Alembert method
    /// with step `h` ([`hamel_sim::dla::integrate`]; the step before an output off the step
    /// grid shortened), its states at the outputs in the plan's order (η = Z(q)q̇), with the
    /// scene's monitors (energy, constraint residual) evaluated as for the other methods.
    pub fn integrate_dla(
        &self,
        h: f64,
        variant: hamel_sim::dla::Variant,
        options: &hamel_sim::Options,
    ) -> Result<crate::Run, hamel_model::ModelError> {
        let (system, q0, v0) = self.long_horizon_system()?;
        let (trajectory, failure) = match hamel_sim::dla::integrate(
            &system,
            (h, variant),
            (self.scene.t0, &q0, &v0),
            &self.times,
            options.max_steps,
        ) {
            Ok(t) => (t, None),
            Err(e) => (
                *e.partial.clone(),
                Some(self.error("integrator", e.to_string())),
            ),
        };
        let mut y = hamel_sim::States::with_capacity(self.y0.len(), trajectory.t.len());
        for (q, v) in trajectory.q.iter().zip(trajectory.v.iter()) {
            y.push(&self.planned_state(q, v)?);
        }
        let solution = self.monitored(trajectory.t, y, trajectory.steps, failure.is_none())?;
        Ok(crate::Run {
            solution,
            failure,
            max_condition: None,
            constraint_forces: Vec::new(),
            monitored: None,
        })
    }

    /// The state in the plan's order (the state's coordinates, then η = Z(q)q̇) from every
    /// coordinate and its rate.
    fn planned_state(&self, q: &[f64], v: &[f64]) -> Result<Vec<f64>, hamel_model::ModelError> {
        let rows = (self.compiled)
            .quasi_velocity_map(q, &self.params)
            .map_err(|e| self.error("integrator", e.to_string()))?;
        let eta = rows[..self.d.sigma]
            .iter()
            .map(|z| z.iter().zip(v).map(|(a, b)| a * b).sum::<f64>());
        Ok(self.state.iter().map(|&k| q[k]).chain(eta).collect())
    }

    /// A solution of states `y` at `t` with the scene's monitors at each, their drift over the
    /// run (from the initial state), `steps` steps.
    fn monitored(
        &self,
        t: Vec<f64>,
        y: hamel_sim::States,
        steps: usize,
        complete: bool,
    ) -> Result<hamel_sim::Solution, hamel_model::ModelError> {
        use hamel_sim::OdeSystem;
        let system = self.system()?;
        let mut energy = vec![None; t.len()];
        system.energies(&t, y.as_flat(), &mut energy);
        let mut constraint = vec![None; t.len()];
        system.constraint_residuals(&t, y.as_flat(), &mut constraint);
        let e0 = system.energy(self.scene.t0, &self.y0);
        let largest = |v: &[Option<f64>], of: &dyn Fn(f64) -> f64| {
            v.iter().flatten().map(|&x| of(x)).reduce(f64::max)
        };
        let stats = hamel_sim::Stats {
            steps,
            energy_drift: e0.and_then(|e0| {
                largest(&energy, &|e| (e - e0).abs()).map(|d| d / e0.abs().max(f64::MIN_POSITIVE))
            }),
            constraint_drift: largest(&constraint, &f64::abs),
            ..Default::default()
        };
        Ok(hamel_sim::Solution {
            t,
            y,
            energy,
            constraint,
            stats,
            complete,
            ..Default::default()
        })
    }
}
