//! The solution's Taylor series of an autonomous ODE y' = f(y) in O(p²) operations per
//! operation of f ([`taylor_by_trace`]): f, written over [`Scalar`], is evaluated once at the
//! state over [`Traced`] numbers, which record its operations on a per-thread program (its
//! branches, pivots among them, decided by the values at the state, as an f64 evaluation
//! decides them); then the automatic differentiation recurrences (Jorba & Zou 2005, §3) run
//! over the program, coefficient k of every node from the lower ones, k = 1 … p − 1.
//!
//! Values that depend on no state variable are folded while tracing, and an operation with a
//! constant operand becomes the cheaper node it is (a sum with a constant touches coefficient
//! 0 only, a product with one scales). [`crate::taylor_by_jets`] computes the same series by
//! truncated power series arithmetic, in O(p³): the tests hold the two against each other.

use std::cell::RefCell;
use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::recur;
use crate::scalar::{RationalParts, Scalar};

/// A node of a traced program; operands are earlier nodes. Public so that a program can be
/// written as data ([`taylor_by_program`]): a generated core's trace of its scene's start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Node {
    /// State variable i.
    Input(usize),
    /// A constant made a node (where a recurrence reads an operand's series).
    Const(f64),
    /// a + b.
    Add(u32, u32),
    /// a − b.
    Sub(u32, u32),
    /// −a.
    Neg(u32),
    /// a + c, c a constant (in coefficient 0 only).
    AddConst(u32, f64),
    /// c·a.
    Scale(u32, f64),
    /// a · b.
    Mul(u32, u32),
    /// a / b.
    Div(u32, u32),
    /// c / b, c a constant.
    ConstDiv(u32, f64),
    /// √a.
    Sqrt(u32),
    /// sin a; cos a is the next node.
    Sin(u32),
    /// cos a, with the node of sin a.
    Cos(u32, u32),
    /// exp a.
    Exp(u32),
    /// ln a.
    Ln(u32),
    /// atan a, with the node of 1 + a².
    Atan(u32, u32),
    /// atan2(y, x), with the node of x² + y².
    Atan2(u32, u32, u32),
}

/// The program being traced on this thread: the nodes and their values at the state.
#[derive(Default)]
struct Program {
    nodes: Vec<Node>,
    values: Vec<f64>,
}

thread_local! {
    static PROGRAM: RefCell<Program> = RefCell::new(Program::default());
}

/// No node: the number is a constant.
const CONSTANT: u32 = u32::MAX;

/// A number of a traced evaluation: its value at the state and the node that computes it
/// (none for a constant).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Traced {
    node: u32,
    v: f64,
}

impl Traced {
    const fn constant_of(v: f64) -> Traced {
        Traced { node: CONSTANT, v }
    }

    fn is_constant(&self) -> bool {
        self.node == CONSTANT
    }

    fn push(node: Node, v: f64) -> Traced {
        PROGRAM.with_borrow_mut(|p| {
            p.nodes.push(node);
            p.values.push(v);
            Traced {
                node: (p.nodes.len() - 1) as u32,
                v,
            }
        })
    }

    /// A unary function's node, or its folded value for a constant.
    fn unary(self, v: f64, node: impl FnOnce(u32) -> Node) -> Traced {
        if self.is_constant() {
            Traced::constant_of(v)
        } else {
            Traced::push(node(self.node), v)
        }
    }
}

impl Add for Traced {
    type Output = Traced;
    fn add(self, o: Traced) -> Traced {
        let v = self.v + o.v;
        match (self.is_constant(), o.is_constant()) {
            (true, true) => Traced::constant_of(v),
            (false, true) => Traced::push(Node::AddConst(self.node, o.v), v),
            (true, false) => Traced::push(Node::AddConst(o.node, self.v), v),
            (false, false) => Traced::push(Node::Add(self.node, o.node), v),
        }
    }
}
impl Sub for Traced {
    type Output = Traced;
    fn sub(self, o: Traced) -> Traced {
        let v = self.v - o.v;
        match (self.is_constant(), o.is_constant()) {
            (true, true) => Traced::constant_of(v),
            (false, true) => Traced::push(Node::AddConst(self.node, -o.v), v),
            (true, false) => {
                let minus = Traced::push(Node::Neg(o.node), -o.v);
                Traced::push(Node::AddConst(minus.node, self.v), v)
            }
            (false, false) => Traced::push(Node::Sub(self.node, o.node), v),
        }
    }
}
impl Neg for Traced {
    type Output = Traced;
    fn neg(self) -> Traced {
        self.unary(-self.v, Node::Neg)
    }
}
impl Mul for Traced {
    type Output = Traced;
    fn mul(self, o: Traced) -> Traced {
        let v = self.v * o.v;
        match (self.is_constant(), o.is_constant()) {
            (true, true) => Traced::constant_of(v),
            (false, true) => Traced::push(Node::Scale(self.node, o.v), v),
            (true, false) => Traced::push(Node::Scale(o.node, self.v), v),
            (false, false) => Traced::push(Node::Mul(self.node, o.node), v),
        }
    }
}
impl Div for Traced {
    type Output = Traced;
    fn div(self, o: Traced) -> Traced {
        let v = self.v / o.v;
        match (self.is_constant(), o.is_constant()) {
            (true, true) => Traced::constant_of(v),
            (false, true) => Traced::push(Node::Scale(self.node, 1.0 / o.v), v),
            (true, false) => Traced::push(Node::ConstDiv(o.node, self.v), v),
            (false, false) => Traced::push(Node::Div(self.node, o.node), v),
        }
    }
}

impl Scalar for Traced {
    crate::plain_itself!();
    fn constant(v: f64) -> Self {
        Traced::constant_of(v)
    }
    fn rational(r: &RationalParts) -> Self {
        Traced::constant_of(r.nearest)
    }
    fn value(&self) -> f64 {
        self.v
    }
    fn sin(self) -> Self {
        self.sin_cos().0
    }
    fn cos(self) -> Self {
        self.sin_cos().1
    }
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = libm::sincos(self.v);
        if self.is_constant() {
            return (Traced::constant_of(s), Traced::constant_of(c));
        }
        let at = PROGRAM.with_borrow(|p| p.nodes.len() as u32);
        let sin = Traced::push(Node::Sin(self.node), s);
        let cos = Traced::push(Node::Cos(self.node, at), c);
        (sin, cos)
    }
    fn sqrt(self) -> Self {
        self.unary(self.v.sqrt(), Node::Sqrt)
    }
    fn exp(self) -> Self {
        self.unary(self.v.exp(), Node::Exp)
    }
    fn ln(self) -> Self {
        self.unary(self.v.ln(), Node::Ln)
    }
    fn atan(self) -> Self {
        if self.is_constant() {
            return Traced::constant_of(self.v.atan());
        }
        let r = Traced::constant(1.0) + self * self;
        Traced::push(Node::Atan(self.node, r.node), self.v.atan())
    }
    fn atan2(self, x: Self) -> Self {
        let v = self.v.atan2(x.v);
        if self.is_constant() && x.is_constant() {
            return Traced::constant_of(v);
        }
        // a constant operand as a node of its own: the recurrence reads both series
        let as_node = |a: Traced| {
            if a.is_constant() {
                Traced::push(Node::Const(a.v), a.v)
            } else {
                a
            }
        };
        let (y, x) = (as_node(self), as_node(x));
        let r = x * x + y * y;
        Traced::push(Node::Atan2(y.node, x.node, r.node), v)
    }
    /// By squaring, as the series program of a tape does.
    fn powi(self, n: i32) -> Self {
        if self.is_constant() {
            return Traced::constant_of(self.v.powi(n));
        }
        let result = crate::power_by_squaring(self, n.unsigned_abs(), |a, b| a * b);
        match result {
            None => Traced::constant_of(1.0),
            Some(r) if n < 0 => Traced::constant(1.0) / r,
            Some(r) => r,
        }
    }
}

/// Why [`taylor_by_trace`] could not give the series.
#[derive(Debug)]
pub enum SeriesFailure<E> {
    /// The right-hand side failed.
    System(E),
    /// A coefficient is not finite (a divisor, root or logarithm at 0 in the series).
    NonFinite,
}

/// The Taylor coefficients of the solution of the autonomous ODE y' = f(y) through `y`, to
/// `order`: `out` gets `order + 1` rows of `y.len()` values, row k holding y⁽ᵏ⁾/k!. `f` is
/// called once, over [`Traced`] numbers.
pub fn taylor_by_trace<E>(
    y: &[f64],
    order: usize,
    out: &mut Vec<f64>,
    f: impl FnOnce(&[Traced], &mut [Traced]) -> Result<(), E>,
) -> Result<(), SeriesFailure<E>> {
    let n = y.len();
    PROGRAM.with_borrow_mut(|p| {
        p.nodes.clear();
        p.values.clear();
    });
    let x: Vec<Traced> = y
        .iter()
        .enumerate()
        .map(|(i, &v)| Traced::push(Node::Input(i), v))
        .collect();
    let mut dx = vec![Traced::constant(0.0); n];
    f(&x, &mut dx).map_err(SeriesFailure::System)?;
    out.clear();
    out.resize((order + 1) * n, 0.0);
    out[..n].copy_from_slice(y);
    PROGRAM.with_borrow(|p| run(&p.nodes, &p.values, &dx, order, out));
    finite(out)
}

fn finite<E>(out: &[f64]) -> Result<(), SeriesFailure<E>> {
    if out.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(SeriesFailure::NonFinite)
    }
}

impl Traced {
    /// Output `node` of a program written as data ([`taylor_by_program`]).
    pub const fn node(node: u32) -> Traced {
        Traced { node, v: 0.0 }
    }

    /// A constant output of a program written as data.
    pub const fn fixed(v: f64) -> Traced {
        Traced::constant_of(v)
    }
}

/// [`taylor_by_trace`] for a right-hand side already traced, held as data: a straight-line
/// program (`nodes`, its first ones the state's inputs; no decision in it depends on the
/// state), whose rates are `outputs` (nodes or constants; as many as `y` has components).
/// Its values at `y` are computed node by node (what tracing records), then the recurrences
/// run as for a trace. What a generated core does with the trace of its scene's start: no
/// tracing at each step, and code as small as the program (data, not instructions).
pub fn taylor_by_program(
    nodes: &[Node],
    outputs: &[Traced],
    y: &[f64],
    order: usize,
    out: &mut Vec<f64>,
) -> Result<(), SeriesFailure<std::convert::Infallible>> {
    let n = outputs.len();
    assert_eq!(
        y.len(),
        n,
        "a state of {} for a program of {n} rates",
        y.len()
    );
    let values = values_at(nodes, y);
    out.clear();
    out.resize((order + 1) * n, 0.0);
    out[..n].copy_from_slice(y);
    run(nodes, &values, outputs, order, out);
    finite(out)
}

/// The values of a program's nodes at the state `y`: the f64 operations tracing records.
fn values_at(nodes: &[Node], y: &[f64]) -> Vec<f64> {
    let mut values: Vec<f64> = Vec::with_capacity(nodes.len());
    for node in nodes {
        let v = |a: u32| values[a as usize];
        let x = match *node {
            Node::Input(i) => y[i],
            Node::Const(c) => c,
            Node::Add(a, b) => v(a) + v(b),
            Node::Sub(a, b) => v(a) - v(b),
            Node::Neg(a) => -v(a),
            Node::AddConst(a, c) => v(a) + c,
            Node::Scale(a, m) => v(a) * m,
            Node::Mul(a, b) => v(a) * v(b),
            Node::Div(a, b) => v(a) / v(b),
            Node::ConstDiv(b, c) => c / v(b),
            Node::Sqrt(a) => v(a).sqrt(),
            Node::Sin(a) => libm::sincos(v(a)).0,
            Node::Cos(a, _) => libm::sincos(v(a)).1,
            Node::Exp(a) => v(a).exp(),
            Node::Ln(a) => v(a).ln(),
            Node::Atan(a, _) => v(a).atan(),
            Node::Atan2(y, x, _) => v(y).atan2(v(x)),
        };
        values.push(x);
    }
    values
}

/// The recurrences over the program: `out` holds y's coefficients row by row, its row 0 the
/// state already (the inputs' values). Every node's coefficients are contiguous (`w` of them),
/// so that the sums of the recurrences run over slices. Where the CPU has FMA, by a copy
/// compiled for it (the recurrences' `mul_add`s one instruction each; the same bits, `recur`).
fn run(nodes: &[Node], values: &[f64], f: &[Traced], order: usize, out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has FMA, the one feature `run_fma` is compiled for.
        unsafe { run_fma(nodes, values, f, order, out) };
        return;
    }
    run_in(nodes, values, f, order, out);
}

/// [`run_in`] compiled for FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
fn run_fma(nodes: &[Node], values: &[f64], f: &[Traced], order: usize, out: &mut [f64]) {
    run_in(nodes, values, f, order, out);
}

/// The body of [`run`] (`values`: the nodes' values at the state, coefficient 0).
#[inline(always)]
fn run_in(nodes: &[Node], values: &[f64], f: &[Traced], order: usize, out: &mut [f64]) {
    let (n, w) = (f.len(), order + 1);
    let mut c = vec![0.0; nodes.len() * w];
    for (i, &v) in values.iter().enumerate() {
        c[i * w] = v;
    }
    for k in 0..order {
        if k > 0 {
            for (i, node) in nodes.iter().enumerate() {
                let (done, rest) = c.split_at_mut(i * w);
                let operand = |a: u32| &done[a as usize * w..a as usize * w + k + 1];
                rest[k] = match *node {
                    Node::Input(j) => out[k * n + j],
                    // its cosine is the next node: its coefficients to k − 1 are known
                    Node::Sin(a) => recur::sin(operand(a), &rest[w..w + k], k),
                    _ => coefficient(*node, k, operand, &rest[..k]),
                };
            }
        }
        for (i, fi) in f.iter().enumerate() {
            let fk = match fi.node {
                CONSTANT if k == 0 => fi.v,
                CONSTANT => 0.0,
                node => c[node as usize * w + k],
            };
            out[(k + 1) * n + i] = fk * recur::inverse(k + 1);
        }
    }
}

/// Coefficient k ≥ 1 of a node other than an input ([`crate::recur`]): `s(a)` is operand a's
/// series to coefficient k, `own` the node's to k − 1.
#[inline(always)]
fn coefficient<'a>(node: Node, k: usize, s: impl Fn(u32) -> &'a [f64], own: &[f64]) -> f64 {
    match node {
        Node::Input(_) | Node::Const(_) => 0.0,
        Node::Add(a, b) => s(a)[k] + s(b)[k],
        Node::Sub(a, b) => s(a)[k] - s(b)[k],
        Node::Neg(a) => -s(a)[k],
        Node::AddConst(a, _) => s(a)[k],
        Node::Scale(a, m) => m * s(a)[k],
        Node::Mul(a, b) if a == b => recur::square(s(a), k),
        Node::Mul(a, b) => recur::product(s(a), s(b), k),
        Node::Div(a, b) => recur::quotient(s(a)[k], s(b), own, k),
        // c/b: the quotient of a series that is c at 0 and zero after
        Node::ConstDiv(b, _) => recur::quotient(0.0, s(b), own, k),
        Node::Sqrt(a) => recur::sqrt(s(a)[k], own, k),
        // sin a, whose cosine comes after it, is computed in `run`
        Node::Sin(..) => unreachable!("computed in run"),
        Node::Cos(a, sin) => recur::cos(s(a), s(sin), k),
        Node::Exp(a) => recur::exp(s(a), own, k),
        Node::Ln(a) => recur::ln(s(a), own, k),
        Node::Atan(a, r) => recur::atan(s(a), s(r), own, k),
        Node::Atan2(y, x, r) => recur::atan2(s(y), s(x), s(r), own, k),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jet::{Jet, taylor_by_jets};

    /// A right-hand side with every operation, constants among the operands.
    fn f<S: Scalar>(x: &[S], dx: &mut [S]) -> Result<(), ()> {
        let (a, b, c) = (x[0], x[1], x[2]);
        let two = S::constant(2.0);
        let (s, co) = (a * two).sin_cos();
        let r = (b * b + S::constant(1.5)).sqrt();
        let q = (S::constant(3.0) - c) / r + S::constant(0.5) / (co + S::constant(2.0));
        dx[0] = b * co - s / two + (-c).exp() * S::constant(0.1);
        dx[1] = (r.ln() - a.powi(3)) * q + b.atan() - c.powi(-2) * S::constant(0.01);
        dx[2] = (b.atan2(c) + S::constant(0.25).atan2(a) + c.atan2(S::constant(-1.0))) * q
            + S::constant(7.0).sqrt();
        Ok(())
    }

    #[test]
    fn the_recurrences_give_the_series_truncated_arithmetic_gives() {
        let y = [0.3, -0.7, 1.2];
        for order in [1, 2, 5, 12, 20] {
            let (mut by_trace, mut by_jets) = (Vec::new(), Vec::new());
            taylor_by_trace(&y, order, &mut by_trace, f::<Traced>).unwrap();
            taylor_by_jets(&y, order, &mut by_jets, f::<Jet>).unwrap();
            assert_eq!(by_trace.len(), by_jets.len());
            for (k, (a, b)) in by_trace.iter().zip(&by_jets).enumerate() {
                let scale = b.abs().max(1e-300);
                assert!(
                    (a - b).abs() <= 1e-13 * scale.max(1.0),
                    "order {order}, entry {k}: {a} against {b}"
                );
            }
        }
    }

    /// A program traced once and held (as a generated core holds its scene's trace) gives at
    /// another state the series a new trace there gives: f has no decision by value.
    #[test]
    fn a_held_program_gives_the_series_of_a_new_trace() {
        let mut out = Vec::new();
        taylor_by_trace(&[0.3, -0.7, 1.2], 3, &mut out, f::<Traced>).unwrap();
        let mut outputs = vec![Traced::constant(0.0); 3];
        PROGRAM.with_borrow_mut(|p| p.nodes.clear());
        let x: Vec<Traced> = (0..3).map(|i| Traced::push(Node::Input(i), 0.1)).collect();
        f(&x, &mut outputs).unwrap();
        let nodes = PROGRAM.with_borrow(|p| p.nodes.clone());
        let outputs: Vec<Traced> = (outputs.iter())
            .map(|o| {
                if o.is_constant() {
                    Traced::fixed(o.v)
                } else {
                    Traced::node(o.node)
                }
            })
            .collect();
        for y in [[0.5, 0.4, -0.9], [-1.1, 2.0, 0.7]] {
            for order in [1, 7, 20] {
                let (mut held, mut traced) = (Vec::new(), Vec::new());
                taylor_by_program(&nodes, &outputs, &y, order, &mut held).unwrap();
                taylor_by_trace(&y, order, &mut traced, f::<Traced>).unwrap();
                for (a, b) in held.iter().zip(&traced) {
                    assert!((a - b).abs() <= 1e-15 * b.abs().max(1.0), "{a} against {b}");
                }
            }
        }
    }

    #[test]
    fn a_constant_right_hand_side_and_a_pole_are_handled() {
        let mut out = Vec::new();
        taylor_by_trace::<()>(&[1.0, 2.0], 4, &mut out, |_, dx| {
            dx[0] = Traced::constant(3.0);
            dx[1] = Traced::constant(0.0);
            Ok(())
        })
        .unwrap();
        assert_eq!(out, vec![1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        // y' = 1/y at y = 0: no series
        let pole = taylor_by_trace::<()>(&[0.0], 3, &mut out, |x, dx| {
            dx[0] = Traced::constant(1.0) / x[0];
            Ok(())
        });
        assert!(matches!(pole, Err(SeriesFailure::NonFinite)));
    }
}
