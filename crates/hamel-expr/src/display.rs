//! Printing in the model-file syntax (the printed text parses back to the same value).

use std::fmt;

use num_traits::{One, Signed};

use crate::ast::Expr;

// Binding strength: sum 1, product 2, unary minus 3, power 4, atom 5.
fn prec(e: &Expr) -> u8 {
    match e {
        Expr::Add(_) => 1,
        Expr::Mul(_) | Expr::Div(..) => 2,
        Expr::Neg(_) => 3,
        Expr::Num(r) if r.is_negative() || !r.denom().is_one() => 2,
        Expr::Pow(..) => 4,
        _ => 5,
    }
}

fn write_with(f: &mut fmt::Formatter<'_>, e: &Expr, min: u8) -> fmt::Result {
    if prec(e) < min {
        write!(f, "(")?;
        write!(f, "{e}")?;
        write!(f, ")")
    } else {
        write!(f, "{e}")
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expr::Num(r) => {
                if r.denom().is_one() {
                    write!(f, "{}", r.numer())
                } else {
                    write!(f, "{}/{}", r.numer(), r.denom())
                }
            }
            Expr::Sym(n) => write!(f, "{n}"),
            Expr::Der(q) => write!(f, "der({q})"),
            Expr::Free { name, args, orders } => {
                if orders.iter().all(|&o| o == 0) {
                    write!(f, "{name}({})", args.join(", "))
                } else {
                    // d^k name / d arg^k …, written as a named derivative: name_d<arg><order>
                    let mut tag = String::new();
                    for (a, &o) in args.iter().zip(orders) {
                        for _ in 0..o {
                            tag.push_str("_d");
                            tag.push_str(a);
                        }
                    }
                    write!(f, "{name}{tag}({})", args.join(", "))
                }
            }
            Expr::Add(v) => {
                for (i, t) in v.iter().enumerate() {
                    match (i, t) {
                        (0, t) => write_with(f, t, 1)?,
                        (_, Expr::Neg(inner)) => {
                            write!(f, " - ")?;
                            write_with(f, inner, 2)?;
                        }
                        (_, Expr::Num(r)) if r.is_negative() => {
                            write!(f, " - ")?;
                            write_with(f, &Expr::Num(-r.clone()), 2)?;
                        }
                        // a + (-b)*c reads as a - b*c.
                        (_, Expr::Mul(v))
                            if matches!(v.first(), Some(Expr::Neg(_)))
                                || matches!(v.first(), Some(Expr::Num(r)) if r.is_negative()) =>
                        {
                            let mut v = v.clone();
                            v[0] = match &v[0] {
                                Expr::Neg(x) => (**x).clone(),
                                Expr::Num(r) => Expr::Num(-r.clone()),
                                _ => unreachable!("matched above"),
                            };
                            write!(f, " - ")?;
                            write_with(f, &Expr::Mul(v), 2)?;
                        }
                        (_, t) => {
                            write!(f, " + ")?;
                            write_with(f, t, 1)?;
                        }
                    }
                }
                Ok(())
            }
            Expr::Mul(v) => {
                for (i, t) in v.iter().enumerate() {
                    if i > 0 {
                        write!(f, "*")?;
                    }
                    // a*(b/c) must keep its parentheses only when needed for re-parsing:
                    // products and quotients associate left, so a factor that is a quotient
                    // is parenthesised after the first position.
                    let min = if i == 0 { 2 } else { 3 };
                    write_with(f, t, min)?;
                }
                Ok(())
            }
            Expr::Neg(e) => {
                write!(f, "-")?;
                // -(a*b) reads as -a*b: the same value, fewer parentheses.
                let min = if matches!(**e, Expr::Mul(_)) { 2 } else { 3 };
                write_with(f, e, min)
            }
            Expr::Div(a, b) => {
                write_with(f, a, 2)?;
                write!(f, "/")?;
                write_with(f, b, 3)
            }
            Expr::Pow(b, e) => {
                write_with(f, b, 5)?;
                write!(f, "^")?;
                write_with(f, e, 4)
            }
            Expr::Call(func, a) => write!(f, "{}({a})", func.name()),
            Expr::Atan2(y, x) => write!(f, "atan2({y}, {x})"),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::parse;

    /// Printed text parses back to the same value (compared at an arbitrary point).
    #[test]
    fn printing_round_trips() {
        let env = |n: &str| {
            Some(match n {
                "a" => 0.3,
                "b" => -1.7,
                "c" => 2.2,
                "d" => 0.9,
                "x" => 1.1,
                "m" => 2.0,
                "phi" => 0.4,
                "theta" => -0.8,
                _ => return None,
            })
        };
        for s in [
            "a - b*c^2",
            "-x^2 + 1/2*m*x^2",
            "(a + b)/(c*d)",
            "a/(b/c)",
            "2^3^2",
            "(-2)^2",
            "sin(phi)*theta - sin(theta + phi)",
            "a*(b/c)",
            "-(a - b)",
            "-(a*b) + c",
            "a - b*(c - d)",
            "-(a*b)^2",
            "a + (-b)*c",
            "a + (-2)*c*d",
            "a + (-(b + c))*d",
        ] {
            let e = parse(s).unwrap().expr;
            let printed = e.to_string();
            let again = parse(&printed).unwrap().expr;
            let (v1, v2): (f64, f64) = (e.eval(&env).unwrap(), again.eval(&env).unwrap());
            assert!((v1 - v2).abs() < 1e-12, "{s} printed as {printed}");
        }
        assert_eq!(parse("-(a*b)").unwrap().expr.to_string(), "-a*b");
        assert_eq!(parse("a + (-b)*c").unwrap().expr.to_string(), "a - b*c");
    }
}
