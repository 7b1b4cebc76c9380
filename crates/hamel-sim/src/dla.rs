//! A structure-preserving integrator for nonholonomic mechanical systems (issue 63): the
//! discrete Lagrange–d'Alembert method with the midpoint discrete Lagrangian and the discrete
//! constraint taken at the midpoint, which makes it reversible (McLachlan & Perlmutter,
//! "Integrators for nonholonomic mechanical systems", J. Nonlinear Sci. 16 (2006); Modin &
//! Verdier, "What makes nonholonomic integrators work?", Numer. Math. 145 (2020)).
//!
//! The system: L = ½ vᵀM(q)v − V(q) with linear velocity constraints A(q)v = 0
//! ([`Nonholonomic`]). With L_d(q₀, q₁) = h L(q̄, v̄), q̄ = (q₀ + q₁)/2, v̄ = (q₁ − q₀)/h, one
//! step from (q₀, v₀) (A(q₀)v₀ = 0) to (q₁, v₁) solves
//!
//! * M(q₀)v₀ + D₁L_d(q₀, q₁) + (h/2)A(q₀)ᵀλ = 0 and A(q̄)(q₁ − q₀) = 0 for (q₁, λ) (Newton's
//!   method, its Jacobian by differences; [`Variant::LeftPoint`] takes A(q₀) in the second,
//!   the non-reversible variant);
//! * M(q₁)v₁ − (h/2)A(q₁)ᵀμ = D₂L_d(q₀, q₁) and A(q₁)v₁ = 0 for (v₁, μ) (linear).
//!
//! Eliminating v, the positions satisfy the discrete Lagrange–d'Alembert equations
//! D₂L_d(q_{k−1}, q_k) + D₁L_d(q_k, q_{k+1}) + (h/2)A(q_k)ᵀ(λ_k + μ_k) = 0 on the discrete
//! constraint A(q̄)(q_{k+1} − q_k) = 0. The map is reversible: from (q₁, −v₁) it returns to
//! (q₀, −v₀) with the multipliers exchanged, which is what keeps the energy error bounded over
//! long times on reversible systems (McLachlan & Perlmutter's contact oscillator); the
//! left-point constraint breaks that, and its energy drifts. The velocity constraints hold to
//! round-off at every step (the second stage imposes them).
//!
//! **Inputs**: a [`Nonholonomic`] system, a fixed step h, the variant. **Outputs**: the state
//! after each step; [`DlaError`] when Newton's method does not converge or a matrix is
//! singular. **Invariant**: the positions are solved to round-off (or the step fails), so the
//! method's reversibility survives in floating point; the matrices' buffers are kept in
//! [`Dla`].

use nalgebra::{DMatrix, DVector};

/// A natural mechanical system with linear velocity constraints: L = ½ vᵀM(q)v − V(q),
/// A(q)v = 0, n coordinates and m constraint rows.
pub trait Nonholonomic {
    /// n.
    fn dim(&self) -> usize;
    /// m.
    fn constraints(&self) -> usize;
    /// M(q) into `m` (n × n, symmetric positive definite).
    fn mass(&self, q: &[f64], m: &mut DMatrix<f64>);
    /// ∂L/∂q at (q, v) = ½ vᵀ(∂M/∂q)v − ∇V(q), into `f`.
    fn force(&self, q: &[f64], v: &[f64], f: &mut [f64]);
    /// A(q) into `a` (m × n).
    fn constraint_matrix(&self, q: &[f64], a: &mut DMatrix<f64>);
    /// V(q).
    fn potential(&self, q: &[f64]) -> f64;
    /// How M, ∂L/∂q, A and V depend on coordinate k (default: in any way). A long run keeps
    /// the coordinates they do not depend on at zero, and periodic ones within half a period
    /// of it, their offsets apart ([`Positions`]): the steps then see small values whatever
    /// the angle or distance travelled, and keep every digit of their increments.
    fn coordinate(&self, _k: usize) -> Coordinate {
        Coordinate::General
    }
}

/// How a system depends on one of its coordinates ([`Nonholonomic::coordinate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Coordinate {
    /// In any way.
    General,
    /// Not at all: the system is invariant under its translations.
    Absent,
    /// Periodically, with this period.
    Periodic(f64),
}

/// The configuration of a long run, split into what the steps see and offsets: the
/// coordinates the system does not depend on moved back to zero before each step, the
/// periodic ones back within half a period of zero ([`Coordinate`]), so that a step's
/// increments are computed from small values (a coordinate of 10⁶ rad has an ulp of 1e-10: its
/// increment over a step of 0.01 would keep only six digits). The configuration reported is
/// the offset plus the local value.
#[derive(Clone, Debug)]
pub struct Positions {
    kinds: Vec<Coordinate>,
    /// What the steps see.
    pub local: Vec<f64>,
    offset: Vec<f64>,
}

impl Positions {
    /// From the configuration `q` of `system`.
    pub fn new<S: Nonholonomic + ?Sized>(system: &S, q: &[f64]) -> Self {
        Positions {
            kinds: (0..q.len()).map(|k| system.coordinate(k)).collect(),
            local: q.to_vec(),
            offset: vec![0.0; q.len()],
        }
    }

    /// Moves what it may of the local values into the offsets (before a step).
    pub fn recentre(&mut self) {
        for ((kind, x), o) in self.kinds.iter().zip(&mut self.local).zip(&mut self.offset) {
            let shift = match *kind {
                Coordinate::General => 0.0,
                Coordinate::Absent => *x,
                Coordinate::Periodic(period) => (*x / period).round() * period,
            };
            if shift != 0.0 {
                *o += shift;
                *x -= shift;
            }
        }
    }

    /// The configuration: offsets plus local values.
    pub fn absolute(&self, q: &mut [f64]) {
        for ((q, x), o) in q.iter_mut().zip(&self.local).zip(&self.offset) {
            *q = o + x;
        }
    }
}

/// Where the discrete constraint is taken.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Variant {
    /// A((q₀ + q₁)/2)(q₁ − q₀) = 0: reversible (McLachlan & Perlmutter).
    #[default]
    Reversible,
    /// A(q₀)(q₁ − q₀) = 0: not reversible (Cortés & Martínez's choice; its energy drifts on
    /// the contact oscillator, Modin & Verdier 2020).
    LeftPoint,
}

/// Why a step failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DlaError {
    /// Newton's method on the position stage did not reach round-off.
    #[error(
        "the discrete Lagrange–d'Alembert step did not converge (residual {residual:.1e} after {iterations} Newton iterations)"
    )]
    NoConvergence {
        /// The residual's size at the end.
        residual: f64,
        /// Iterations made.
        iterations: usize,
    },
    /// A singular Jacobian or constraint system (constraints dependent, or M singular).
    #[error("a singular system in the {0} stage")]
    Singular(&'static str),
    /// A non-finite value.
    #[error("a non-finite value in the {0} stage")]
    NotFinite(&'static str),
    /// An output time before the time reached ([`integrate`] runs forward).
    #[error("the output time {0} is before the time reached: the outputs must increase")]
    OutputOrder(f64),
    /// A run ([`integrate`]) needed more steps than it was allowed.
    #[error("more than max_steps = {0} steps needed")]
    TooManySteps(usize),
}

/// Most Newton iterations per step.
const MAX_NEWTON: usize = 30;

/// The integrator: a system, a step, a variant, and its buffers.
pub struct Dla<'s, S: Nonholonomic + ?Sized> {
    system: &'s S,
    h: f64,
    variant: Variant,
    mass: DMatrix<f64>,
    a: DMatrix<f64>,
    force: Vec<f64>,
    mid: Vec<f64>,
    rate: Vec<f64>,
    unknowns: DVector<f64>,
    residual: DVector<f64>,
    shifted: DVector<f64>,
    jacobian: DMatrix<f64>,
    kkt: DMatrix<f64>,
    /// M(q₀)v₀ and A(q₀) of the step under way.
    start_momentum: Vec<f64>,
    start_a: DMatrix<f64>,
}

impl<'s, S: Nonholonomic + ?Sized> Dla<'s, S> {
    /// The integrator for `system` with step `h`.
    pub fn new(system: &'s S, h: f64, variant: Variant) -> Self {
        let (n, m) = (system.dim(), system.constraints());
        Dla {
            system,
            h,
            variant,
            mass: DMatrix::zeros(n, n),
            a: DMatrix::zeros(m, n),
            force: vec![0.0; n],
            mid: vec![0.0; n],
            rate: vec![0.0; n],
            unknowns: DVector::zeros(n + m),
            residual: DVector::zeros(n + m),
            shifted: DVector::zeros(n + m),
            jacobian: DMatrix::zeros(n + m, n + m),
            kkt: DMatrix::zeros(n + m, n + m),
            start_momentum: vec![0.0; n],
            start_a: DMatrix::zeros(m, n),
        }
    }

    /// The step from now on (a run shortens the step before an output off the step grid).
    pub fn set_step(&mut self, h: f64) {
        self.h = h;
    }

    /// One step: (q, v) ← (q₁, v₁).
    pub fn step(&mut self, q: &mut [f64], v: &mut [f64]) -> Result<(), DlaError> {
        let n = self.system.dim();
        self.system.mass(q, &mut self.mass);
        let momentum = &self.mass * DVector::from_column_slice(v);
        self.start_momentum.copy_from_slice(momentum.as_slice());
        self.system.constraint_matrix(q, &mut self.start_a);
        // The guess: an explicit Euler step, the multipliers 0.
        for i in 0..n {
            self.unknowns[i] = q[i] + self.h * v[i];
        }
        for k in n..self.unknowns.len() {
            self.unknowns[k] = 0.0;
        }
        self.positions(q)?;
        let q1: Vec<f64> = self.unknowns.as_slice()[..n].to_vec();
        self.velocities(q, &q1, v)?;
        q.copy_from_slice(&q1);
        Ok(())
    }

    /// The residual of the position stage at `x` = (q₁, λ), from q₀, into `out`.
    fn position_residual(&mut self, q0: &[f64], x: &DVector<f64>, out: &mut DVector<f64>) {
        let n = q0.len();
        self.midpoint(q0, &x.as_slice()[..n]);
        // M(q₀)v₀ + (h/2)F(q̄, v̄) − M(q̄)v̄ + (h/2)A(q₀)ᵀλ
        let lambda = x.rows(n, x.len() - n);
        let pushed = self.start_a.transpose() * lambda;
        let mv = &self.mass * DVector::from_column_slice(&self.rate);
        for i in 0..n {
            out[i] = self.start_momentum[i] + 0.5 * self.h * (self.force[i] + pushed[i]) - mv[i];
        }
        // The discrete constraint A(·)(q₁ − q₀)/h.
        match self.variant {
            Variant::Reversible => self.system.constraint_matrix(&self.mid, &mut self.a),
            Variant::LeftPoint => self.a.copy_from(&self.start_a),
        }
        let c = &self.a * DVector::from_column_slice(&self.rate);
        for (k, value) in c.iter().enumerate() {
            out[n + k] = *value;
        }
    }

    /// q̄, v̄ and, at them, M(q̄) and F(q̄, v̄).
    fn midpoint(&mut self, q0: &[f64], q1: &[f64]) {
        for i in 0..q0.len() {
            self.mid[i] = 0.5 * (q0[i] + q1[i]);
            self.rate[i] = (q1[i] - q0[i]) / self.h;
        }
        self.system.mass(&self.mid, &mut self.mass);
        self.system.force(&self.mid, &self.rate, &mut self.force);
    }

    /// Newton's method on the position stage, its Jacobian by forward differences, to
    /// round-off: `unknowns` holds (q₁, λ) after.
    fn positions(&mut self, q0: &[f64]) -> Result<(), DlaError> {
        let size = self.unknowns.len();
        let mut residual = std::mem::replace(&mut self.residual, DVector::zeros(0));
        let mut shifted = std::mem::replace(&mut self.shifted, DVector::zeros(0));
        let mut previous = f64::INFINITY;
        let result = (|| {
            for iteration in 0..MAX_NEWTON {
                let x = self.unknowns.clone();
                self.position_residual(q0, &x, &mut residual);
                let norm = residual.amax();
                if !norm.is_finite() {
                    return Err(DlaError::NotFinite("position"));
                }
                let scale = 1.0 + x.amax();
                if norm <= 4.0 * f64::EPSILON * scale || (iteration > 2 && norm >= previous) {
                    if norm <= 1e-10 * scale {
                        return Ok(());
                    }
                    return Err(DlaError::NoConvergence {
                        residual: norm,
                        iterations: iteration,
                    });
                }
                previous = norm;
                for j in 0..size {
                    let delta = 1e-7 * (1.0 + x[j].abs());
                    let mut moved = x.clone();
                    moved[j] += delta;
                    self.position_residual(q0, &moved, &mut shifted);
                    for i in 0..size {
                        self.jacobian[(i, j)] = (shifted[i] - residual[i]) / delta;
                    }
                }
                let step = self
                    .jacobian
                    .clone()
                    .lu()
                    .solve(&residual)
                    .ok_or(DlaError::Singular("position"))?;
                self.unknowns -= step;
            }
            Err(DlaError::NoConvergence {
                residual: previous,
                iterations: MAX_NEWTON,
            })
        })();
        self.residual = residual;
        self.shifted = shifted;
        result
    }

    /// The velocity stage: M(q₁)v₁ − (h/2)A(q₁)ᵀμ = D₂L_d(q₀, q₁), A(q₁)v₁ = 0, into `v`.
    fn velocities(&mut self, q0: &[f64], q1: &[f64], v: &mut [f64]) -> Result<(), DlaError> {
        let n = q0.len();
        self.midpoint(q0, q1);
        // D₂L_d = (h/2)F(q̄, v̄) + M(q̄)v̄
        let mv = &self.mass * DVector::from_column_slice(&self.rate);
        let mut rhs = DVector::zeros(self.unknowns.len());
        for i in 0..n {
            rhs[i] = 0.5 * self.h * self.force[i] + mv[i];
        }
        self.system.mass(q1, &mut self.mass);
        self.system.constraint_matrix(q1, &mut self.a);
        let m = self.a.nrows();
        self.kkt.fill(0.0);
        self.kkt.view_mut((0, 0), (n, n)).copy_from(&self.mass);
        self.kkt
            .view_mut((0, n), (n, m))
            .copy_from(&(self.a.transpose() * (-0.5 * self.h)));
        self.kkt.view_mut((n, 0), (m, n)).copy_from(&self.a);
        let solution = self
            .kkt
            .clone()
            .lu()
            .solve(&rhs)
            .ok_or(DlaError::Singular("velocity"))?;
        if solution.iter().any(|x| !x.is_finite()) {
            return Err(DlaError::NotFinite("velocity"));
        }
        v.copy_from_slice(&solution.as_slice()[..n]);
        Ok(())
    }
}

/// The energy ½ vᵀM(q)v + V(q).
pub fn energy<S: Nonholonomic + ?Sized>(system: &S, q: &[f64], v: &[f64]) -> f64 {
    let n = system.dim();
    let mut m = DMatrix::zeros(n, n);
    system.mass(q, &mut m);
    let v = DVector::from_column_slice(v);
    0.5 * v.dot(&(&m * &v)) + system.potential(q)
}

/// A run's states at its output times ([`integrate`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    /// The output times reached.
    pub t: Vec<f64>,
    /// q at each.
    pub q: crate::States,
    /// q̇ at each.
    pub v: crate::States,
    /// Steps taken.
    pub steps: usize,
}

/// A run that failed: the step's error, its time, and the outputs reached before it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("at t = {time}: {error}")]
pub struct RunError {
    /// What failed.
    pub error: DlaError,
    /// The time the failing step started from.
    pub time: f64,
    /// The outputs reached.
    pub partial: Box<Trajectory>,
}

/// Steps of `h` (> 0) from (t0, q0, v0) to each of `output_times` (increasing, after t0),
/// the step before an output off the step grid shortened to land on it (as the fixed-step
/// Runge–Kutta methods do: outputs on the grid keep the method's reversibility whole); at most
/// `max_steps` steps ([`DlaError::TooManySteps`] past it).
pub fn integrate<S: Nonholonomic + ?Sized>(
    system: &S,
    (h, variant): (f64, Variant),
    (t0, q0, v0): (f64, &[f64], &[f64]),
    output_times: &[f64],
    max_steps: usize,
) -> Result<Trajectory, RunError> {
    let n = system.dim();
    let mut run = Trajectory {
        q: crate::States::with_capacity(n, output_times.len()),
        v: crate::States::with_capacity(n, output_times.len()),
        ..Trajectory::default()
    };
    let (mut positions, mut v, mut t) = (Positions::new(system, q0), v0.to_vec(), t0);
    let mut q = q0.to_vec();
    let mut dla = Dla::new(system, h, variant);
    for &t_out in output_times {
        // full steps, with the round-off of the times forgiven, then one to land on t_out
        let slack = 16.0 * f64::EPSILON * t.abs().max(t_out.abs());
        let span = t_out - t;
        if span < 0.0 {
            return Err(RunError {
                error: DlaError::OutputOrder(t_out),
                time: t,
                partial: Box::new(run),
            });
        }
        let steps = if span == 0.0 {
            0
        } else {
            (((span - slack) / h * (1.0 - 1e-12)).ceil() as usize).max(1)
        };
        let start = t;
        for k in 1..=steps {
            let fail = |error, run: &mut Trajectory| RunError {
                error,
                time: t,
                partial: Box::new(std::mem::take(run)),
            };
            if run.steps >= max_steps {
                return Err(fail(DlaError::TooManySteps(max_steps), &mut run));
            }
            let t_next = if k == steps {
                t_out
            } else {
                start + h * k as f64
            };
            // a full step is h itself, the last one too when t_out is on the grid
            let full = k < steps || (t_next - t - h).abs() <= slack;
            dla.set_step(if full { h } else { t_next - t });
            positions.recentre();
            (dla.step(&mut positions.local, &mut v)).map_err(|e| fail(e, &mut run))?;
            run.steps += 1;
            t = t_next;
        }
        positions.absolute(&mut q);
        run.t.push(t_out);
        run.q.push(&q);
        run.v.push(&v);
    }
    Ok(run)
}
