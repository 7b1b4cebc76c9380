//! The variables of a field: what each stands for (coordinates, parameters, velocities, sin
//! and cos of base angles, free functions, kernels), the polynomials over them, and the
//! half-angle ring's correspondence with them. Data only: the arithmetic is in
//! [`crate::field`], lowest terms in [`crate::half`].

use std::cell::RefCell;
use std::collections::HashMap;

use hamel_expr::Func;
use num_bigint::BigInt;
use symbolica::prelude::*;

/// Polynomials over the integers in the field variables.
pub(crate) type Poly = MultivariatePolynomial<IntegerRing, u16>;

/// A coordinate or a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Sym {
    Coord(usize),
    Param(usize),
}

/// What a field variable stands for.
#[derive(Clone, Debug)]
pub(crate) enum VarKind {
    /// The coordinate itself (when it occurs outside sin/cos).
    Coord(usize),
    /// A parameter.
    Param(usize),
    /// der(q_i).
    Velocity(usize),
    /// sin of angle `a`.
    Sin(usize),
    /// cos of angle `a`.
    Cos(usize),
    /// A free function (index into `free`) differentiated `orders[j]` times in its j-th argument.
    Free { func: usize, orders: Vec<u32> },
    /// log, exp or sqrt of an argument (index into `kernels`).
    Kernel(usize),
    /// A plain symbol with no dependence on the coordinates.
    Unknown(usize),
}

/// A base angle of the trigonometric variables.
#[derive(Clone, Debug)]
pub(crate) enum Angle {
    /// `symbol / denom`.
    Symbol { sym: Sym, denom: u32 },
    /// An argument that is not a rational-linear combination of symbols.
    Kernel { arg: (Poly, Poly) },
}

#[derive(Clone, Debug)]
pub(crate) struct AngleVars {
    pub angle: Angle,
    pub sin: usize,
    pub cos: usize,
}

/// The function of a kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum KernelFunc {
    /// exp, log, sqrt or atan of one argument.
    Of(Func),
    /// atan2(y, x).
    Atan2,
}

/// A transcendental or algebraic kernel.
#[derive(Clone, Debug)]
pub(crate) struct Kernel {
    pub func: KernelFunc,
    /// The argument N/D (for sqrt, the polynomial radicand G, with denominator 1). For atan2,
    /// the two polynomials (Y, X) of atan2(Y, X): atan2(Ny/Dy, Nx/Dx) is kept as
    /// atan2(Ny·Dy·Dx², Nx·Dx·Dy²), the same angle (both scaled by (Dx·Dy)² > 0).
    pub arg: (Poly, Poly),
}

pub(crate) struct FieldInner {
    pub coordinates: Vec<String>,
    pub parameters: Vec<String>,
    pub free: Vec<(String, Vec<usize>)>,
    pub unknowns: Vec<String>,
    pub kinds: Vec<VarKind>,
    pub angles: Vec<AngleVars>,
    pub kernels: RefCell<Vec<Kernel>>,
    /// (variable, G) with variable² = G, in creation order.
    pub relations: RefCell<Vec<(usize, Poly)>>,
    pub zero: Poly,
    /// The half-angle ring, where lowest terms are computed ([`crate::half`]).
    pub half: HalfRing,
    /// Index of each variable by kind, for lookups.
    pub coord_var: Vec<Option<usize>>,
    pub param_var: Vec<Option<usize>>,
    pub velocity_var: Vec<usize>,
    pub unknown_var: Vec<usize>,
    pub free_var: HashMap<(usize, Vec<u32>), usize>,
    pub kernel_var: Vec<usize>,
    /// Memo of dv/dq_k.
    pub dvar: RefCell<DerivativeMemo>,
    /// This field's number, distinct among the fields of a process: with a variable's index,
    /// what tells an exported atom apart ([`FieldInner::atom_id`]).
    pub uid: u32,
}

/// Memo of d(variable v)/dq_i by (v, i), as numerator and denominator; `None` where it is zero.
pub(crate) type DerivativeMemo = HashMap<(usize, usize), Option<(Poly, Poly)>>;

/// The variables of the half-angle ring and their correspondence with the field's.
pub(crate) struct HalfRing {
    /// The zero polynomial of the half-angle ring (carries its variable list).
    pub zero: Poly,
    /// Field variable → half-angle-ring variable (sin u and cos u → t of u).
    pub of_var: Vec<usize>,
    /// Angle → its t.
    pub t: Vec<usize>,
    /// Half-angle-ring variable → field variable (`None` for a t).
    pub back: Vec<Option<usize>>,
}

impl HalfRing {
    /// The half-angle ring for field variables of these kinds; `ring(n)` makes the zero
    /// polynomial of a ring with n variables.
    pub fn new(kinds: &[VarKind], ring: impl Fn(usize) -> Poly) -> HalfRing {
        let (mut of_var, mut t, mut back) = (Vec::new(), Vec::new(), Vec::new());
        for (v, k) in kinds.iter().enumerate() {
            match k {
                VarKind::Sin(a) | VarKind::Cos(a) => {
                    if t.len() <= *a {
                        t.resize(*a + 1, usize::MAX);
                    }
                    if t[*a] == usize::MAX {
                        t[*a] = back.len();
                        back.push(None);
                    }
                    of_var.push(t[*a]);
                }
                _ => {
                    of_var.push(back.len());
                    back.push(Some(v));
                }
            }
        }
        HalfRing {
            zero: ring(back.len()),
            of_var,
            t,
            back,
        }
    }
}

pub(crate) fn int(n: i64) -> Integer {
    Integer::from(n)
}

pub(crate) fn big_to_integer(b: &BigInt) -> Integer {
    b.to_string().parse().expect("decimal integer")
}

pub(crate) fn integer_to_big(i: &Integer) -> BigInt {
    i.to_string().parse().expect("decimal integer")
}
