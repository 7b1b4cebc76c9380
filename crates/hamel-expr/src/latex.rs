//! LaTeX rendering of expressions.

use std::fmt::Write;

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
    let mut out = String::with_capacity(name.len() + 12);
    write_name(name, &mut out);
    out
}

/// [`latex_name`] into `out`.
fn write_name(name: &str, out: &mut String) {
    if let Some(base) = name.strip_suffix("_dot") {
        return dotted(&latex_name(base), out);
    }
    let (stem, sub) = match name.split_once('_') {
        Some((s, rest)) => (s, Some(rest)),
        None => {
            let digits = name
                .chars()
                .rev()
                .take_while(|c| c.is_ascii_digit())
                .count();
            if digits > 0 && digits < name.len() {
                let at = name.len() - digits;
                (&name[..at], Some(&name[at..]))
            } else {
                (name, None)
            }
        }
    };
    if stem == "phi" {
        out.push_str("\\varphi");
    } else if GREEK.contains(&stem) {
        out.push('\\');
        out.push_str(stem);
    } else if stem.len() > 1 {
        out.push_str("\\mathrm{");
        out.push_str(stem);
        out.push('}');
    } else {
        out.push_str(stem);
    }
    if let Some(sub) = sub {
        out.push_str("_{");
        out.extend(sub.chars().map(|c| if c == '_' { ',' } else { c }));
        out.push('}');
    }
}

/// A name's LaTeX `l` with a dot on its letter, not on its subscript (`\\dot{\\eta}_{2}`).
fn dotted(l: &str, out: &mut String) {
    out.push_str("\\dot{");
    match l.split_once("_{") {
        Some((letter, sub)) => {
            out.push_str(letter);
            out.push_str("}_{");
            out.push_str(sub);
        }
        None => {
            out.push_str(l);
            out.push('}');
        }
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

fn wrap_into(e: &Expr, min: u8, out: &mut String) {
    if prec(e) < min {
        out.push_str("\\left(");
        e.write_latex(out);
        out.push_str("\\right)");
    } else {
        e.write_latex(out);
    }
}

impl Expr {
    /// The expression in LaTeX.
    pub fn to_latex(&self) -> String {
        let mut out = String::with_capacity(32);
        self.write_latex(&mut out);
        out
    }

    /// [`Expr::to_latex`] written into `out`.
    pub fn write_latex(&self, out: &mut String) {
        match self {
            Expr::Num(r) => {
                let _ = if r.denom().is_one() {
                    write!(out, "{}", r.numer())
                } else if r.is_negative() {
                    write!(out, "-\\frac{{{}}}{{{}}}", -r.numer(), r.denom())
                } else {
                    write!(out, "\\frac{{{}}}{{{}}}", r.numer(), r.denom())
                };
            }
            Expr::Sym(n) => write_name(n, out),
            Expr::Der(q) => dotted(&latex_name(q), out),
            Expr::Free { name, args, orders } => out.push_str(&free_latex(name, args, orders)),
            Expr::Add(v) => {
                for (i, t) in v.iter().enumerate() {
                    match t {
                        Expr::Neg(inner) if i > 0 => {
                            out.push_str(" - ");
                            wrap_into(inner, 2, out);
                        }
                        _ => {
                            if i > 0 {
                                out.push_str(" + ");
                            }
                            wrap_into(t, 1, out);
                        }
                    }
                }
            }
            Expr::Mul(v) => {
                for (i, t) in v.iter().enumerate() {
                    if i > 0 {
                        out.push(' ');
                    }
                    wrap_into(t, 3, out);
                }
            }
            Expr::Neg(e) => {
                out.push('-');
                wrap_into(e, 3, out);
            }
            Expr::Div(a, b) => {
                out.push_str("\\frac{");
                a.write_latex(out);
                out.push_str("}{");
                b.write_latex(out);
                out.push('}');
            }
            Expr::Pow(b, e) => {
                // sin(x)^2 reads better as \sin^{2} x
                if let Expr::Call(f @ (Func::Sin | Func::Cos | Func::Tan), arg) = &**b {
                    out.push('\\');
                    out.push_str(f.name());
                    out.push_str("^{");
                    e.write_latex(out);
                    out.push('}');
                    func_arg(arg, out);
                    return;
                }
                wrap_into(b, 5, out);
                out.push_str("^{");
                e.write_latex(out);
                out.push('}');
            }
            Expr::Call(f, a) => match f {
                Func::Sqrt => {
                    out.push_str("\\sqrt{");
                    a.write_latex(out);
                    out.push('}');
                }
                Func::Exp => {
                    out.push_str("e^{");
                    a.write_latex(out);
                    out.push('}');
                }
                Func::Atan => {
                    out.push_str("\\arctan");
                    func_arg(a, out);
                }
                _ => {
                    out.push('\\');
                    out.push_str(f.name());
                    func_arg(a, out);
                }
            },
            Expr::Atan2(y, x) => {
                out.push_str("\\operatorname{atan2}\\left(");
                y.write_latex(out);
                out.push_str(", ");
                x.write_latex(out);
                out.push_str("\\right)");
            }
        }
    }
}

/// A free function of the coordinates, or its derivative (`\frac{\partial f}{\partial q}(q)`).
fn free_latex(name: &str, args: &[String], orders: &[u32]) -> String {
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

fn func_arg(a: &Expr, out: &mut String) {
    match a {
        Expr::Sym(_) => {
            out.push(' ');
            a.write_latex(out);
        }
        _ => {
            out.push_str("\\left(");
            a.write_latex(out);
            out.push_str("\\right)");
        }
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
        assert_eq!(latex_name("rho_f_2"), "\\rho_{f,2}");
        assert_eq!(latex_name("Omega"), "\\Omega");
        assert_eq!(latex_name("xy12"), "\\mathrm{xy}_{12}");
        assert_eq!(latex_name("l_dot"), "\\dot{l}");
        assert_eq!(latex_name("rho1_dot"), "\\dot{\\rho}_{1}");
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
