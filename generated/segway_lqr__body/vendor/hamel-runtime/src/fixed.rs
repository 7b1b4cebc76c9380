//! The right-hand side in fixed-size arrays ([`Fixed`], for generated code: L = ℓ, M = μ,
//! G = σ known at compile time, no allocation) and in vectors ([`Rhs`]).

use crate::scalar::Scalar;
use crate::structured::{Dims, Failure, Structured};

/// The arithmetic of a result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// IEEE double precision (or the caller's type).
    F64,
    /// Double-double (about 32 digits), rounded at the end.
    DoubleDouble,
}

impl Precision {
    /// `f64` or `double_double`, as `hamel eval` prints it.
    pub fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::DoubleDouble => "double_double",
        }
    }
}

/// The right-hand side at one state, in fixed-size arrays (L coordinates, G = σ).
#[derive(Clone, Copy, Debug)]
pub struct Fixed<S, const L: usize, const G: usize> {
    /// η̇ from the true equations (11).
    pub eta_dot: [S; G],
    /// η̇ from the paper's equations (equal to `eta_dot` when not asked for).
    pub eta_dot_paper: [S; G],
    /// q̇ = Γη.
    pub q_dot: [S; L],
    /// A_Γ = ΓᵀAΓ.
    pub a_gamma: [[S; G]; G],
    /// F, the right side of A_Γ η̇ = F (true equations).
    pub forcing: [S; G],
    /// E = ½ q̇ᵀAq̇ − U.
    pub energy: S,
    /// |Γ|ᵀ(|∇U| + |∇_q T| + |Ȧq̇| + |AΓ̇η|), values only (see
    /// [`Structured::forcing_scale`]).
    pub forcing_scale: [f64; G],
    /// The arithmetic the values come from: an f64 evaluation is repeated in double-double
    /// when its error estimate exceeds [`crate::DOUBLE_DOUBLE_ABOVE`].
    pub precision: Precision,
    /// [`Structured::f64_error_estimate`] at this state (0 when not computed: types other
    /// than f64).
    pub f64_error_estimate: f64,
}

impl<S: Scalar, const L: usize, const G: usize> Fixed<S, L, G> {
    /// The results of an evaluation, copied out of its storage.
    #[inline(always)]
    pub fn read(r: &Structured<'_, S>) -> Self {
        let ag = r.a_gamma();
        Fixed {
            eta_dot: std::array::from_fn(|i| r.eta_dot()[i]),
            eta_dot_paper: std::array::from_fn(|i| r.eta_dot_paper()[i]),
            q_dot: std::array::from_fn(|i| r.q_dot()[i]),
            a_gamma: std::array::from_fn(|i| std::array::from_fn(|j| ag[i * G + j])),
            forcing: std::array::from_fn(|i| r.forcing()[i]),
            energy: r.energy(),
            forcing_scale: std::array::from_fn(|i| r.forcing_scale()[i]),
            precision: Precision::F64,
            f64_error_estimate: 0.0,
        }
    }
}

impl<T: Scalar, const L: usize, const G: usize> Fixed<T, L, G> {
    /// The values (rounded to f64) as values of `S`.
    pub fn narrow<S: Scalar>(self) -> Fixed<S, L, G> {
        let r = |x: T| S::constant(x.value());
        Fixed {
            eta_dot: self.eta_dot.map(r),
            eta_dot_paper: self.eta_dot_paper.map(r),
            q_dot: self.q_dot.map(r),
            a_gamma: self.a_gamma.map(|row| row.map(r)),
            forcing: self.forcing.map(r),
            energy: r(self.energy),
            forcing_scale: self.forcing_scale,
            precision: self.precision,
            f64_error_estimate: self.f64_error_estimate,
        }
    }
}

/// Storage for one structured evaluation with sizes known at compile time: `W`, `I`, `R` at
/// least [`Dims::scalars`], [`Dims::indices`], [`Dims::reals`] (generated code computes them
/// as constants).
pub struct Storage<S, const W: usize, const I: usize, const R: usize> {
    s: [S; W],
    idx: [usize; I],
    re: [f64; R],
}

impl<S: Scalar, const W: usize, const I: usize, const R: usize> Storage<S, W, I, R> {
    /// Zeroed storage, on the stack.
    #[inline(always)]
    pub fn new() -> Self {
        Storage {
            s: [S::constant(0.0); W],
            idx: [0; I],
            re: [0.0; R],
        }
    }

    /// A structured evaluation for sizes `d` in this storage.
    #[inline(always)]
    pub fn structured(&mut self, d: Dims) -> Result<Structured<'_, S>, Failure> {
        Structured::new(d, &mut self.s, &mut self.idx, &mut self.re)
    }
}

impl<S: Scalar, const W: usize, const I: usize, const R: usize> Default for Storage<S, W, I, R> {
    fn default() -> Self {
        Self::new()
    }
}

/// Storage for one structured evaluation with sizes known at run time.
#[derive(Clone, Debug)]
pub struct Buffers<S> {
    d: Dims,
    s: Vec<S>,
    idx: Vec<usize>,
    re: Vec<f64>,
}

impl<S: Scalar> Buffers<S> {
    /// Zeroed storage for sizes `d`.
    pub fn new(d: Dims) -> Self {
        Buffers {
            d,
            s: vec![S::constant(0.0); d.scalars()],
            idx: vec![0; d.indices()],
            re: vec![0.0; d.reals()],
        }
    }

    /// A structured evaluation in this storage.
    pub fn structured(&mut self) -> Structured<'_, S> {
        Structured::new(self.d, &mut self.s, &mut self.idx, &mut self.re)
            .expect("Buffers::new sized the storage for its dims")
    }
}

/// The right-hand side at one state, in vectors.
#[derive(Clone, Debug)]
pub struct Rhs<S> {
    /// η̇ from the true equations (11).
    pub eta_dot: Vec<S>,
    /// η̇ from the paper's equations.
    pub eta_dot_paper: Vec<S>,
    /// q̇ = Γη.
    pub q_dot: Vec<S>,
    /// A_Γ = ΓᵀAΓ (σ×σ).
    pub a_gamma: Vec<Vec<S>>,
    /// F, the right side of A_Γ η̇ = F (true equations).
    pub forcing: Vec<S>,
    /// E = ½ q̇ᵀAq̇ − U.
    pub energy: S,
    /// The arithmetic the values come from.
    pub precision: Precision,
    /// The estimate that decided it (see [`Fixed::f64_error_estimate`]).
    pub f64_error_estimate: f64,
}

impl<S: Scalar> Rhs<S> {
    /// The results of an evaluation, copied out of its storage (as computed: in the scalar
    /// type's own arithmetic, the f64 error estimate not yet computed).
    pub fn read(r: &Structured<'_, S>) -> Self {
        let sigma = r.dims().sigma.max(1);
        Rhs {
            eta_dot: r.eta_dot().to_vec(),
            eta_dot_paper: r.eta_dot_paper().to_vec(),
            q_dot: r.q_dot().to_vec(),
            a_gamma: r.a_gamma().chunks(sigma).map(<[S]>::to_vec).collect(),
            forcing: r.forcing().to_vec(),
            energy: r.energy(),
            precision: Precision::F64,
            f64_error_estimate: 0.0,
        }
    }
}

impl<S: Copy, const L: usize, const G: usize> From<Fixed<S, L, G>> for Rhs<S> {
    fn from(f: Fixed<S, L, G>) -> Self {
        Rhs {
            eta_dot: f.eta_dot.to_vec(),
            eta_dot_paper: f.eta_dot_paper.to_vec(),
            q_dot: f.q_dot.to_vec(),
            a_gamma: f.a_gamma.iter().map(|r| r.to_vec()).collect(),
            forcing: f.forcing.to_vec(),
            energy: f.energy,
            precision: f.precision,
            f64_error_estimate: f.f64_error_estimate,
        }
    }
}
