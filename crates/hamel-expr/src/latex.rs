//! LaTeX rendering of expressions.

use num_traits::{One, Signed};

use crate::ast::{Expr, Func};

const GREEK: [&str; 24] = [
    "alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa",
    "lambda", "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi",
    "omega", "Omega",
];

/// A name in LaTeX: Greek letters become commands, a trailing number or `_suffix` a subscript
/// (`theta1` → `\theta_{1}`, `m_d` → `m_{d}`, `eta2_dot` → `\dot{\eta}_{2}`).
pub fn latex_name(name: &str) -> String {
    if let Some(base) = name.strip_suffix("_dot") {
        let inner = latex_name(base);
        // put the dot on the letter, not on the subscript
        return match inner.split_once("_{") {
            Some((letter, sub)) => format!("\\dot{{{letter}}}_{{{sub}"),
            None => format!("\\dot{{{inner}}}"),
        };
    }
    let (stem, sub) = match name.split_once('_') {
        Some((s, rest)) => (s.to_string(), Some(rest.to_string())),
        None => {
            let digits = name
                .chars()
                .rev()
                .take_while(|c| c.is_ascii_digit())
                .count();
            if digits > 0 && digits < name.len() {
                (
                    name[..name.len() - digits].to_string(),
                    Some(name[name.len() - digits..].to_string()),
                )
            } else {
                (name.to_string(), None)
            }
        }
    };
    let stem = if GREEK.contains(&stem.as_str()) {
        if stem == "phi" {
            "\\varphi".to_string()
        } else {
            format!("\\{stem}")
        }
    } else if stem.len() > 1 {
        format!("\\mathrm{{{stem}}}")
    } else {
        stem
    };
    match sub {
        Some(s) => format!("{stem}_{{{}}}", s.replace('_', ",")),
        None => stem,
    }
}

fn prec(e: &Expr) -> u8 {
    match e {
        Expr::Add(_) => 1,
        Expr::Mul(_) | Expr::Neg(_) => 2,
        Expr::Num(r) if r.is_negative() => 2,
        Expr::Div(..) => 5, // \frac is self-delimiting
        Expr::Pow(..) => 4,
        _ => 5,
    }
}

fn wrap(e: &Expr, min: u8) -> String {
    let s = e.to_latex();
    if prec(e) < min {
        format!("\\left({s}\\right)")
    } else {
        s
    }
}

impl Expr {
    /// The expression in LaTeX.
    pub fn to_latex(&self) -> String {
        match self {
            Expr::Num(r) => {
                if r.denom().is_one() {
                    r.numer().to_string()
                } else if r.is_negative() {
                    format!("-\\frac{{{}}}{{{}}}", -r.numer(), r.denom())
                } else {
                    format!("\\frac{{{}}}{{{}}}", r.numer(), r.denom())
                }
            }
            Expr::Sym(n) => latex_name(n),
            Expr::Der(q) => {
                let l = latex_name(q);
                match l.split_once("_{") {
                    Some((letter, sub)) => format!("\\dot{{{letter}}}_{{{sub}"),
                    None => format!("\\dot{{{l}}}"),
                }
            }
            Expr::Free { name, args, orders } => {
                let args_tex: Vec<String> = args.iter().map(|a| latex_name(a)).collect();
                let total: u32 = orders.iter().sum();
                let f = latex_name(name);
                if total == 0 {
                    format!("{f}({})", args_tex.join(", "))
                } else {
                    let mut den = String::new();
                    for (a, &o) in args_tex.iter().zip(orders) {
                        if o == 1 {
                            den.push_str(&format!("\\partial {a}"));
                        } else if o > 1 {
                            den.push_str(&format!("\\partial {a}^{{{o}}}"));
                        }
                    }
                    let num = if total == 1 {
                        "\\partial".to_string()
                    } else {
                        format!("\\partial^{{{total}}}")
                    };
                    format!("\\frac{{{num} {f}}}{{{den}}}({})", args_tex.join(", "))
                }
            }
            Expr::Add(v) => {
                let mut s = String::new();
                for (i, t) in v.iter().enumerate() {
                    match t {
                        Expr::Neg(inner) if i > 0 => {
                            s.push_str(" - ");
                            s.push_str(&wrap(inner, 2));
                        }
                        _ => {
                            if i > 0 {
                                s.push_str(" + ");
                            }
                            s.push_str(&wrap(t, 1));
                        }
                    }
                }
                s
            }
            Expr::Mul(v) => v.iter().map(|t| wrap(t, 3)).collect::<Vec<_>>().join(" "),
            Expr::Neg(e) => format!("-{}", wrap(e, 3)),
            Expr::Div(a, b) => format!("\\frac{{{}}}{{{}}}", a.to_latex(), b.to_latex()),
            Expr::Pow(b, e) => {
                // sin(x)^2 reads better as \sin^{2} x
                if let Expr::Call(f @ (Func::Sin | Func::Cos | Func::Tan), arg) = &**b {
                    return format!("\\{}^{{{}}}{}", f.name(), e.to_latex(), func_arg(arg));
                }
                format!("{}^{{{}}}", wrap(b, 5), e.to_latex())
            }
            Expr::Call(f, a) => match f {
                Func::Sqrt => format!("\\sqrt{{{}}}", a.to_latex()),
                Func::Exp => format!("e^{{{}}}", a.to_latex()),
                _ => format!("\\{}{}", f.name(), func_arg(a)),
            },
        }
    }
}

fn func_arg(a: &Expr) -> String {
    match a {
        Expr::Sym(_) => format!(" {}", a.to_latex()),
        _ => format!("\\left({}\\right)", a.to_latex()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse;

    #[test]
    fn names() {
        assert_eq!(latex_name("theta1"), "\\theta_{1}");
        assert_eq!(latex_name("m_d"), "m_{d}");
        assert_eq!(latex_name("phi"), "\\varphi");
        assert_eq!(latex_name("eta2_dot"), "\\dot{\\eta}_{2}");
        assert_eq!(latex_name("rho1"), "\\rho_{1}");
        assert_eq!(latex_name("xC"), "\\mathrm{xC}");
    }

    #[test]
    fn expressions() {
        let e = parse("m/2*der(x)^2 - sin(theta)^2*l").unwrap().expr;
        assert_eq!(
            e.to_latex(),
            "\\frac{m}{2} \\dot{x}^{2} - \\sin^{2} \\theta l"
        );
        let e = parse("sqrt(1 + q2^2)*cos(theta + phi)").unwrap().expr;
        assert_eq!(
            e.to_latex(),
            "\\sqrt{1 + q_{2}^{2}} \\cos\\left(\\theta + \\varphi\\right)"
        );
    }
}
