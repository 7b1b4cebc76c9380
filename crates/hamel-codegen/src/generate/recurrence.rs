//! A series node's recurrence (issue 63): how coefficient k ≥ 1 of a node of the Taylor
//! program comes from the lower ones, written two ways.
//!
//! * **Looped** ([`Step::looped`]): a call of `runtime::recur` with the coefficient index `k` a
//!   variable, inside `for k in 0..order`: any order, small code.
//! * **Unrolled** ([`Step::unrolled`]): for one literal k, the recurrence's sums written out
//!   term by term at constant indices, in exactly the order in which `runtime::recur` adds them
//!   (the four partial sums of `convolve`, the running sum of `weighted`), so that both ways
//!   give the same bits. What heyoka's JIT does for each order: with every index a constant the
//!   coefficient buffer is a fixed array whose slots the compiler keeps in registers, and no
//!   loop of variable length is left (measured 1.7–2.8× faster per series,
//!   docs/design/integrators.md).
//!   The rarer recurrences (exp, ln, atan, atan2) stay calls, with k a literal.
//!
//! Coefficient `k` of node `j` is `c[j * w + k]` (written out: the constant index itself);
//! `out[k * n + i]` holds coefficient k of the state's component i.

use super::emit::lit;

/// How a node's coefficient k ≥ 1 is computed (`runtime::recur`'s recurrences).
#[derive(Clone, Debug)]
pub(super) enum Step {
    /// The state's component i: its coefficient k is already in `out`.
    State(usize),
    /// A value fixed over the step: coefficient k ≥ 1 is zero.
    Zero,
    /// `by` · a, `by` fixed over the step (Rust text).
    Scale(usize, String),
    /// −a.
    Neg(usize),
    /// The sum of nodes (a sum's fixed terms touch coefficient 0 only).
    Sum(Vec<usize>),
    /// a · b.
    Product(usize, usize),
    /// a².
    Square(usize),
    /// a / b (`a` None: a dividend fixed over the step); `own` is this node.
    Quotient {
        a: Option<usize>,
        b: usize,
        own: usize,
    },
    /// sin a, from a and cos a.
    Sin { a: usize, cos: usize },
    /// cos a, from a and sin a.
    Cos { a: usize, sin: usize },
    /// √a.
    Sqrt { a: usize, own: usize },
    /// exp a or ln a (`runtime::recur::exp`, `ln`).
    Call {
        f: &'static str,
        a: usize,
        own: usize,
    },
    /// atan a, with r = 1 + a².
    Atan { a: usize, r: usize, own: usize },
    /// atan2(y, x), with r = x² + y².
    Atan2 {
        y: usize,
        x: usize,
        r: usize,
        own: usize,
    },
}

/// Coefficient `k` of a node: `c[node * w + k]`.
pub(super) fn at(node: usize, k: &str) -> String {
    format!("c[{node} * w + {k}]")
}

/// A node's coefficients from 0: `&c[node * w..]`.
fn from(node: usize) -> String {
    format!("&c[{node} * w..]")
}

/// A node's own coefficients 0..k.
fn own_below(node: usize, k: &str) -> String {
    format!("&c[{node} * w..{node} * w + {k}]")
}

impl Step {
    /// Coefficient k as a Rust expression with `k` a variable (`n`: the state's dimension).
    pub(super) fn looped(&self, n: usize) -> String {
        let k = "k";
        match self {
            Step::State(i) => format!("out[k * {n} + {i}]"),
            Step::Product(a, b) => {
                format!("runtime::recur::product({}, {}, k)", from(*a), from(*b))
            }
            Step::Square(a) => format!("runtime::recur::square({}, k)", from(*a)),
            Step::Quotient { a, b, own } => format!(
                "runtime::recur::quotient({}, {}, {}, k)",
                a.map_or("0.0".to_string(), |a| at(a, k)),
                from(*b),
                own_below(*own, k)
            ),
            Step::Sin { a, cos } => format!("runtime::recur::sin({}, {}, k)", from(*a), from(*cos)),
            Step::Cos { a, sin } => format!("runtime::recur::cos({}, {}, k)", from(*a), from(*sin)),
            Step::Sqrt { a, own } => {
                format!(
                    "runtime::recur::sqrt({}, {}, k)",
                    at(*a, k),
                    own_below(*own, k)
                )
            }
            _ => self.linear_or_call(k, &|node| at(node, k)),
        }
    }

    /// The reciprocal the written-out recurrence multiplies by (`r{own}`, computed once from
    /// coefficient 0 as `runtime::recur` computes it at every k), as a `let`; None for a step
    /// without one.
    pub(super) fn reciprocal(&self) -> Option<String> {
        match self {
            Step::Quotient { b, own, .. } => {
                Some(format!("let r{own}: f64 = 1.0 / {};", at(*b, "0")))
            }
            Step::Sqrt { own, .. } => Some(format!(
                "let r{own}: f64 = 1.0 / (2.0 * {});",
                at(*own, "0")
            )),
            _ => None,
        }
    }

    /// Coefficient `k` (a literal) as a Rust expression with every index a constant
    /// (coefficient i of node j at `c[j · width + i]`) and the sums written out in
    /// `runtime::recur`'s order of addition; a quotient or root multiplies by its
    /// [`Step::reciprocal`], a sine or cosine by 1/k.
    pub(super) fn unrolled(&self, n: usize, k: usize, width: usize) -> String {
        let c = |node: usize, i: usize| format!("c[{}]", node * width + i);
        match self {
            Step::State(i) => format!("out[{}]", k * n + i),
            Step::Product(a, b) => format!(
                "{}.mul_add({}, {}.mul_add({}, {}))",
                c(*a, k),
                c(*b, 0),
                c(*a, 0),
                c(*b, k),
                convolve((1..k).map(|i| (c(*a, i), c(*b, k - i)))),
            ),
            Step::Square(a) => square(k, |i| c(*a, i)),
            Step::Quotient { a, b, own } => format!(
                "({} - {}.mul_add({}, {})) * r{own}",
                a.map_or("0.0".to_string(), |a| c(a, k)),
                c(*b, k),
                c(*own, 0),
                convolve((1..k).map(|j| (c(*b, j), c(*own, k - j)))),
            ),
            Step::Sin { a, cos } => format!(
                "{} * {}",
                weighted(k, |m| (c(*a, m), c(*cos, k - m))),
                lit(1.0 / k as f64)
            ),
            Step::Cos { a, sin } => format!(
                "-{} * {}",
                weighted(k, |m| (c(*a, m), c(*sin, k - m))),
                lit(1.0 / k as f64)
            ),
            Step::Sqrt { a, own } => format!(
                "({} - {}) * r{own}",
                c(*a, k),
                convolve((0..k.saturating_sub(1)).map(|i| (c(*own, 1 + i), c(*own, k - 1 - i)))),
            ),
            _ => self.linear_or_call(&k.to_string(), &|node| c(node, k)),
        }
    }

    /// The steps written alike both ways (`coef`: a node's coefficient k): the linear ones,
    /// and the calls kept as calls (their slices through `w`).
    fn linear_or_call(&self, k: &str, coef: &dyn Fn(usize) -> String) -> String {
        match self {
            Step::Zero => "0.0".into(),
            Step::Scale(a, by) => format!("{by} * {}", coef(*a)),
            Step::Neg(a) => format!("-{}", coef(*a)),
            Step::Sum(list) => (list.iter().map(|&a| coef(a)))
                .collect::<Vec<_>>()
                .join(" + "),
            Step::Call { f, a, own } => format!(
                "runtime::recur::{f}({}, {}, {k})",
                from(*a),
                own_below(*own, k)
            ),
            Step::Atan { a, r, own } => format!(
                "runtime::recur::atan({}, {}, {}, {k})",
                from(*a),
                from(*r),
                own_below(*own, k)
            ),
            Step::Atan2 { y, x, r, own } => format!(
                "runtime::recur::atan2({}, {}, {}, {}, {k})",
                from(*y),
                from(*x),
                from(*r),
                own_below(*own, k)
            ),
            Step::State(_)
            | Step::Product(..)
            | Step::Square(_)
            | Step::Quotient { .. }
            | Step::Sin { .. }
            | Step::Cos { .. }
            | Step::Sqrt { .. } => unreachable!("written by looped and unrolled"),
        }
    }
}

/// Terms x·y fused one after another into a running sum from 0.0, as `runtime::recur` adds
/// them: `xₙ.mul_add(yₙ, … x₁.mul_add(y₁, 0.0))`.
fn fused<'a>(terms: impl IntoIterator<Item = &'a (String, String)>) -> String {
    (terms.into_iter()).fold("0.0".to_string(), |s, (x, y)| {
        format!("{x}.mul_add({y}, {s})")
    })
}

/// `runtime::recur::convolve` written out: Σ xᵢ·yᵢ in four partial sums, term i into sum
/// i mod 4 over whole chunks of four, the rest into the first, then (s₀ + s₁) + (s₂ + s₃);
/// each partial sum starts from 0.0 and fuses its terms in, as the runtime's do.
fn convolve(pairs: impl Iterator<Item = (String, String)>) -> String {
    let terms: Vec<(String, String)> = pairs.collect();
    let whole = terms.len() / 4 * 4;
    let mut acc: [Vec<&(String, String)>; 4] = Default::default();
    for (i, t) in terms.iter().enumerate() {
        acc[if i < whole { i % 4 } else { 0 }].push(t);
    }
    let s = |t: &[&(String, String)]| fused(t.iter().copied());
    format!(
        "(({} + {}) + ({} + {}))",
        s(&acc[0]),
        s(&acc[1]),
        s(&acc[2]),
        s(&acc[3])
    )
}

/// `runtime::recur::square` written out (`c(i)`: coefficient i of the operand).
fn square(k: usize, c: impl Fn(usize) -> String) -> String {
    let terms: Vec<(String, String)> = (1..k.div_ceil(2)).map(|i| (c(i), c(k - i))).collect();
    let s = format!("2.0 * {}", fused(&terms));
    let base = match k % 2 {
        0 => format!("{}.mul_add({}, {s})", c(k / 2), c(k / 2)),
        _ => s,
    };
    format!("(2.0 * {}).mul_add({}, {base})", c(0), c(k))
}

/// `runtime::recur::weighted` written out: Σ_{m=1}^{k} (m·a[m])·b[k − m], one running sum.
fn weighted(k: usize, pair: impl Fn(usize) -> (String, String)) -> String {
    let terms: Vec<(String, String)> = (1..=k)
        .map(|m| {
            let (a, b) = pair(m);
            (format!("({m}.0 * {a})"), b)
        })
        .collect();
    fused(&terms)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The written-out sums follow the runtime's order: whole chunks of four into four partial
    /// sums, the tail into the first.
    #[test]
    fn convolve_is_written_in_the_runtimes_order() {
        let pairs = (0..6).map(|i| (format!("a{i}"), format!("b{}", 5 - i)));
        assert_eq!(
            convolve(pairs),
            "((a5.mul_add(b0, a4.mul_add(b1, a0.mul_add(b5, 0.0))) + a1.mul_add(b4, 0.0)) + \
             (a2.mul_add(b3, 0.0) + a3.mul_add(b2, 0.0)))"
        );
        assert_eq!(convolve(std::iter::empty()), "((0.0 + 0.0) + (0.0 + 0.0))");
        assert_eq!(
            Step::Sin { a: 0, cos: 1 }.unrolled(2, 2, 21),
            "(2.0 * c[2]).mul_add(c[21], (1.0 * c[1]).mul_add(c[22], 0.0)) * 0.5"
        );
        assert_eq!(Step::State(1).unrolled(3, 4, 21), "out[13]");
        assert_eq!(Step::Sum(vec![0, 2]).unrolled(3, 4, 21), "c[4] + c[46]");
    }
}
