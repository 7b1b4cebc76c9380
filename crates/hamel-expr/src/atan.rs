//! sin, cos and tan of angles made with arctangents, written algebraically.
//!
//! A frame turned by δ = atan(u) (a steering linkage, Ackermann geometry) has a rotation of
//! cos δ and sin δ. These are algebraic in u, exactly:
//! cos(atan u) = 1/√(1 + u²), sin(atan u) = u/√(1 + u²) (atan's range is (−π/2, π/2), where
//! cos is positive), and an angle a + k·atan(u) is unfolded by the addition formulas. The
//! exact algebra (hamel-cas) then sees square roots, which it handles, instead of an angle it
//! could not relate to u. A bare atan(u) is a kernel of its own (its derivative is
//! u'/(1 + u²)). The same for atan2(y, x), the angle of the point (x, y) in (−π, π]:
//! cos = x/√(x² + y²), sin = y/√(x² + y²) in every quadrant.

use crate::ast::{Expr, Func};
use crate::build::{add, div, mul, sub};

impl Expr {
    /// Whether an arctangent (atan or atan2) occurs in the tree.
    pub fn has_atan(&self) -> bool {
        self.any(&mut |e| matches!(e, Expr::Call(Func::Atan, _) | Expr::Atan2(..)))
    }

    /// The tree with every sin, cos and tan of an argument a + Σ kᵢ·θᵢ, each θᵢ an atan(uᵢ)
    /// or an atan2(yᵢ, xᵢ) (kᵢ integers)
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

/// An arctangent term ±θ of an angle, θ = atan(u) or atan2(y, x): cos θ = x/r and
/// sin θ = y/r with r = √(x² + y²) (for atan, x = 1 and y = u).
struct AtanTerm {
    negative: bool,
    x: Expr,
    y: Expr,
}

impl AtanTerm {
    fn of(negative: bool, angle: &Expr) -> AtanTerm {
        let (x, y) = match angle {
            Expr::Atan2(y, x) => ((**x).clone(), (**y).clone()),
            Expr::Call(Func::Atan, u) => (Expr::int(1), (**u).clone()),
            _ => unreachable!("an arctangent"),
        };
        AtanTerm { negative, x, y }
    }

    /// r = √(x² + y²).
    fn radius(&self) -> Expr {
        let square = |e: &Expr| match e.as_integer() {
            Some(1) => Expr::int(1),
            _ => Expr::powi(e.clone(), 2),
        };
        Expr::call(Func::Sqrt, add(square(&self.x), square(&self.y)))
    }
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
            Some((k, angle)) => {
                atans.extend((0..k.unsigned_abs()).map(|_| AtanTerm::of(k < 0, angle)))
            }
            None => rest.push(t.clone()),
        }
    }
    (atans, rest)
}

/// `t` as k·θ with θ an atan(u) or atan2(y, x) (returned whole) and k a small nonzero
/// integer, if it is one.
fn multiple_of_atan(t: &Expr) -> Option<(i64, &Expr)> {
    const MOST: i64 = 8;
    match t {
        Expr::Call(Func::Atan, _) | Expr::Atan2(..) => Some((1, t)),
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
    // cos θ = x/r, sin θ = y/r.
    let r = first.radius();
    let (x, y) = (first.x.clone(), first.y.clone());
    let (cos, sin) = if first.negative {
        (
            add(mul(c0.clone(), x.clone()), mul(s0.clone(), y.clone())),
            sub(mul(s0, x), mul(c0, y)),
        )
    } else {
        (
            sub(mul(c0.clone(), x.clone()), mul(s0.clone(), y.clone())),
            add(mul(s0, x), mul(c0, y)),
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
            "cos(atan2(y, x))",
            "sin(atan2(y - 3, x*y) - 2*atan2(-x, y))",
            "tan(x + atan2(-y, -x))*cos(atan(y) + atan2(x, 2))",
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

    /// atan2 parses with two arguments only, evaluates in every quadrant (and refuses the
    /// origin), and differentiates to (x dy − y dx)/(x² + y²).
    #[test]
    fn atan2_parses_evaluates_and_differentiates() {
        assert!(
            parse("atan2(x)")
                .unwrap_err()
                .message
                .contains("two arguments")
        );
        let e = parse("atan2(y, x*y - 1)").unwrap().expr;
        for (x, y) in [(0.3, -1.2), (-2.5, 0.7), (4.0, 2.0), (0.5, -3.0)] {
            assert_eq!(at(&e, x, y), f64::atan2(y, x * y - 1.0));
            let dx = e.diff("x").unwrap();
            let h = 1e-6;
            let numeric = (at(&e, x + h, y) - at(&e, x - h, y)) / (2.0 * h);
            assert!((at(&dx, x, y) - numeric).abs() <= 1e-8, "({x}, {y})");
        }
        let origin = parse("atan2(y, x)").unwrap().expr;
        assert!(at_checked(&origin, 0.0, 0.0).is_err());
    }

    fn at_checked(e: &crate::Expr, x: f64, y: f64) -> Result<f64, crate::EvalError> {
        let env = move |name: &str| match name {
            "x" => Some(x),
            "y" => Some(y),
            _ => None,
        };
        e.eval::<f64>(&env)
    }
}
