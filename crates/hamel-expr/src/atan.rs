//! sin, cos and tan of angles made with arctangents, written algebraically.
//!
//! A frame turned by δ = atan(u) (a steering linkage, Ackermann geometry) has a rotation of
//! cos δ and sin δ. These are algebraic in u, exactly:
//! cos(atan u) = 1/√(1 + u²), sin(atan u) = u/√(1 + u²) (atan's range is (−π/2, π/2), where
//! cos is positive), and an angle a + k·atan(u) is unfolded by the addition formulas. The
//! exact algebra (hamel-cas) then sees square roots, which it handles, instead of an angle it
//! could not relate to u. A bare atan(u) is a kernel of its own (its derivative is
//! u'/(1 + u²)).

use crate::ast::{Expr, Func};
use crate::build::{add, div, mul, sub};

impl Expr {
    /// Whether an arctangent occurs in the tree.
    pub fn has_atan(&self) -> bool {
        self.any(&mut |e| matches!(e, Expr::Call(Func::Atan, _)))
    }

    /// The tree with every sin, cos and tan of an argument a + Σ kᵢ·atan(uᵢ) (kᵢ integers)
    /// written without the arctangents' sines and cosines (see the module doc); everything
    /// else as it was. Equal to the tree wherever both are defined.
    pub fn unfold_trig_of_atan(&self) -> Expr {
        if !self.has_atan() {
            return self.clone();
        }
        self.map(&mut |e| match e {
            Expr::Call(f @ (Func::Sin | Func::Cos | Func::Tan), arg) => {
                let (atans, rest) = atan_terms(&arg);
                if atans.is_empty() {
                    return Expr::Call(f, arg);
                }
                let (c, s) = cos_sin(&atans, rest);
                match f {
                    Func::Sin => s,
                    Func::Cos => c,
                    _ => div(s, c),
                }
            }
            other => other,
        })
    }
}

/// An arctangent term ±atan(u) of an angle.
struct AtanTerm {
    negative: bool,
    u: Expr,
}

/// The angle's arctangent terms (k·atan(u) as |k| terms) and the sum of the others.
fn atan_terms(arg: &Expr) -> (Vec<AtanTerm>, Vec<Expr>) {
    let terms: Vec<&Expr> = match arg {
        Expr::Add(v) => v.iter().collect(),
        other => vec![other],
    };
    let (mut atans, mut rest) = (Vec::new(), Vec::new());
    for t in terms {
        match multiple_of_atan(t) {
            Some((k, u)) => atans.extend((0..k.unsigned_abs()).map(|_| AtanTerm {
                negative: k < 0,
                u: u.clone(),
            })),
            None => rest.push(t.clone()),
        }
    }
    (atans, rest)
}

/// `t` as k·atan(u) with k a small nonzero integer, if it is one.
fn multiple_of_atan(t: &Expr) -> Option<(i64, &Expr)> {
    const MOST: i64 = 8;
    match t {
        Expr::Call(Func::Atan, u) => Some((1, u)),
        Expr::Neg(x) => multiple_of_atan(x).map(|(k, u)| (-k, u)),
        Expr::Mul(v) if v.len() == 2 => {
            let (k, a) = match (v[0].as_rational(), v[1].as_rational()) {
                (Some(k), _) => (k, &v[1]),
                (_, Some(k)) => (k, &v[0]),
                _ => return None,
            };
            if !k.is_integer() {
                return None;
            }
            let k: i64 = k.to_integer().try_into().ok()?;
            let (j, u) = multiple_of_atan(a)?;
            (k != 0 && (k * j).abs() <= MOST).then_some((k * j, u))
        }
        _ => None,
    }
}

/// (cos, sin) of Σ rest + Σ ±atan(uᵢ), by the addition formulas.
fn cos_sin(atans: &[AtanTerm], rest: Vec<Expr>) -> (Expr, Expr) {
    let Some((first, others)) = atans.split_first() else {
        if rest.is_empty() {
            return (Expr::int(1), Expr::int(0));
        }
        let a = crate::build::sum(rest);
        return (Expr::call(Func::Cos, a.clone()), Expr::call(Func::Sin, a));
    };
    let (c0, s0) = cos_sin(others, rest);
    // cos(atan u) = 1/r, sin(atan u) = u/r, r = √(1 + u²).
    let r = Expr::call(
        Func::Sqrt,
        add(Expr::int(1), Expr::powi(first.u.clone(), 2)),
    );
    let su = first.u.clone();
    let (cos, sin) = if first.negative {
        (
            add(c0.clone(), mul(s0.clone(), su.clone())),
            sub(s0, mul(c0, su)),
        )
    } else {
        (
            sub(c0.clone(), mul(s0.clone(), su.clone())),
            add(s0, mul(c0, su)),
        )
    };
    (div(cos, r.clone()), div(sin, r))
}

#[cfg(test)]
mod tests {
    use crate::parse;

    fn at(e: &crate::Expr, x: f64, y: f64) -> f64 {
        let env = move |name: &str| match name {
            "x" => Some(x),
            "y" => Some(y),
            _ => None,
        };
        e.eval::<f64>(&env).unwrap()
    }

    /// The unfolded trees equal the originals wherever they are defined, and hold no sine or
    /// cosine of an arctangent.
    #[test]
    fn unfolded_trig_of_atan_is_the_same_function() {
        for text in [
            "sin(atan(x))",
            "cos(atan(x*y - 1))",
            "tan(y + atan(x))",
            "cos(y - atan(x) + 2*atan(y^2))",
            "sin(-3*atan(x/2) + y)*cos(atan(y))",
            "atan(sin(x)) + sin(y)",
        ] {
            let e = parse(text).unwrap().expr;
            let u = e.unfold_trig_of_atan();
            let trig_of_atan = u.any(&mut |n| {
                matches!(n, crate::Expr::Call(crate::Func::Sin | crate::Func::Cos | crate::Func::Tan, a)
                    if a.has_atan())
            });
            assert!(!trig_of_atan, "{text} → {u}: {e:?}");
            for (x, y) in [(0.3, -1.2), (-2.5, 0.7), (4.0, 2.0)] {
                let (a, b) = (at(&e, x, y), at(&u, x, y));
                assert!(
                    (a - b).abs() <= 1e-14 * (1.0 + a.abs()),
                    "{text}: {a} vs {b}"
                );
            }
        }
    }
}
