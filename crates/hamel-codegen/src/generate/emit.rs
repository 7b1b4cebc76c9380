//! Emission: a tape as straight-line Rust (`let` statements over slots, hoisted constants), the
//! solved body, and the checks the generated code makes.

#[allow(unused_imports)]
use super::*;

pub(super) fn ident(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.chars().next().is_some_and(|c| c.is_ascii_digit()) || s == "self" || s == "type" {
        format!("p_{s}")
    } else {
        s
    }
}

pub(super) fn lit(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// One `let` per shared operation of `tape`, its inputs taken from `slots`.
/// A sine and a cosine of the same argument are computed together (`sin_cos`). In sums and
/// products the operands that do not depend on the state come first, so that with fixed
/// parameters their part is loop-invariant (left-to-right evaluation).
///
/// With a [`Hoist`] plan, `part` selects the fixed half (the lets of `Prepared::new`, plus one
/// `f{k}` per combination of fixed operands) or the varying half (the fixed values it needs
/// read from the prepared array `c`).
pub(super) fn lets(tape: &Tape, slots: &Slots, part: Part) -> String {
    let ops = tape.ops();
    let varying = tape.varying(|i| slots.varying(i));
    let ordered = |k: usize, v: &[usize], sep: &str| -> String {
        let (fixed, moving): (Vec<usize>, Vec<usize>) = v.iter().partition(|&&k| !varying[k]);
        let fixed: Vec<String> = match part {
            Part::Varying(h) if h.part.contains_key(&k) => {
                vec![format!("S::constant(c[{}])", h.part[&k])]
            }
            _ => fixed.iter().map(|k| format!("t{k}")).collect(),
        };
        fixed
            .into_iter()
            .chain(moving.iter().map(|k| format!("t{k}")))
            .collect::<Vec<_>>()
            .join(sep)
    };
    // For each sin(a), the index of cos(a) if the tape has it (and the other way round).
    let mut partner: Vec<Option<usize>> = vec![None; ops.len()];
    {
        let mut cos_of = std::collections::HashMap::new();
        for (k, op) in ops.iter().enumerate() {
            if let Op::Call(Func::Cos, a) = op {
                cos_of.insert(*a, k);
            }
        }
        for (k, op) in ops.iter().enumerate() {
            if let Op::Call(Func::Sin, a) = op
                && let Some(&c) = cos_of.get(a)
            {
                partner[k] = Some(c);
                partner[c] = Some(k);
            }
        }
    }
    let mut paired = vec![false; ops.len()];
    let mut o = String::new();
    for (k, op) in ops.iter().enumerate() {
        if paired[k] {
            continue;
        }
        match part {
            Part::All => {}
            Part::Fixed(h) => {
                if let (Some(_), Op::Add(v) | Op::Mul(v)) = (h.part.get(&k), op) {
                    let sep = if matches!(op, Op::Add(_)) {
                        " + "
                    } else {
                        " * "
                    };
                    let fixed: Vec<String> = v
                        .iter()
                        .filter(|&&a| !varying[a])
                        .map(|a| format!("t{a}"))
                        .collect();
                    let _ = writeln!(o, "    let f{k} = {};", fixed.join(sep));
                }
                if varying[k] {
                    continue;
                }
            }
            Part::Varying(h) if !varying[k] => {
                if let Some(j) = h.op.get(&k) {
                    let _ = writeln!(o, "    let t{k} = S::constant(c[{j}]);");
                    continue;
                } else if !h.consts.contains(&k) {
                    continue;
                }
            }
            Part::Varying(_) => {}
        }
        let rhs = match op {
            Op::Input(i) => slots.text(*i),
            Op::Const(r) => format!("S::constant({})", lit(Expr::rational_to_f64(r))),
            Op::Add(v) => ordered(k, v, " + "),
            Op::Mul(v) => ordered(k, v, " * "),
            Op::Neg(a) => format!("-t{a}"),
            // A constant divisor: a multiplication by its reciprocal, rounded once (a division
            // costs several multiplications; the quotient moves by at most an ulp).
            Op::Div(a, b) => match &ops[*b] {
                Op::Const(r) if *r.numer() != 0.into() => {
                    let recip = Expr::rational_to_f64(&r.recip());
                    format!("t{a} * S::constant({})", lit(recip))
                }
                _ => format!("t{a} / t{b}"),
            },
            Op::PowI(a, n) => format!("t{a}.powi({n})"),
            Op::PowF(a, b) => format!("t{a}.powf(t{b})"),
            Op::Call(f, a) if partner[k].is_some() => {
                let other = partner[k].unwrap();
                paired[other] = true;
                let (sin, cos) = if *f == Func::Sin {
                    (k, other)
                } else {
                    (other, k)
                };
                let _ = writeln!(o, "    let (t{sin}, t{cos}) = t{a}.sin_cos();");
                continue;
            }
            Op::Call(f, a) => {
                let name = match f {
                    Func::Sin => "sin",
                    Func::Cos => "cos",
                    Func::Tan => "tan",
                    Func::Sqrt => "sqrt",
                    Func::Exp => "exp",
                    Func::Log => "ln",
                    Func::Atan => "atan",
                };
                format!("t{a}.{name}()")
            }
            Op::Atan2(y, x) => format!("t{y}.atan2(t{x})"),
        };
        let _ = writeln!(o, "    let t{k} = {rhs};");
    }
    o
}

/// Which operations of a tape [`lets`] writes.
#[derive(Clone, Copy)]
pub(super) enum Part<'a> {
    /// All of them, in one function.
    All,
    /// Those that do not depend on the state, and the hoisted values (`Prepared::new`).
    Fixed(&'a Hoist),
    /// Those that depend on the state, reading the hoisted values from `c`.
    Varying(&'a Hoist),
}

/// The values of a solved tape computed once per parameter set (`Prepared`): the fixed
/// (parameter-only) operations used by a varying one or as a result, and for each varying sum
/// or product with two or more fixed operands, their combination (`f{k}`, left to right, as
/// the unsplit code evaluates it, so the results are unchanged bit for bit). Constants that
/// the varying half uses stay inline there.
pub(super) struct Hoist {
    /// Fixed operation → index in the prepared array.
    pub(super) op: std::collections::HashMap<usize, usize>,
    /// Varying sum or product → index of its fixed operands' combination.
    pub(super) part: std::collections::HashMap<usize, usize>,
    /// Constants used by the varying half.
    pub(super) consts: std::collections::HashSet<usize>,
    /// The names of the prepared array's entries, in order (`t{k}` or `f{k}`).
    pub(super) names: Vec<String>,
    /// The definiteness tests that depend on the parameters alone (checked once).
    pub(super) fixed_tests: Vec<usize>,
    /// The others (checked at every state).
    pub(super) varying_tests: Vec<usize>,
}

impl Hoist {
    /// The plan for `tape` whose outputs are σ + `n_rates` results, then the tests.
    pub(super) fn new(tape: &Tape, slots: &Slots, n_results: usize) -> Hoist {
        let varying = tape.varying(|i| slots.varying(i));
        let ops = tape.ops();
        let mut h = Hoist {
            op: Default::default(),
            part: Default::default(),
            consts: Default::default(),
            names: Vec::new(),
            fixed_tests: Vec::new(),
            varying_tests: Vec::new(),
        };
        let use_fixed = |h: &mut Hoist, a: usize| {
            if !varying[a] && matches!(ops[a], Op::Const(_)) {
                h.consts.insert(a);
            } else if !varying[a] && !h.op.contains_key(&a) {
                h.op.insert(a, h.names.len());
                h.names.push(format!("t{a}"));
            }
        };
        for (k, op) in ops.iter().enumerate() {
            if !varying[k] {
                continue;
            }
            match op {
                Op::Add(v) | Op::Mul(v) => {
                    let fixed: Vec<usize> = v.iter().copied().filter(|&a| !varying[a]).collect();
                    if fixed.len() >= 2 {
                        h.part.insert(k, h.names.len());
                        h.names.push(format!("f{k}"));
                    } else {
                        fixed.into_iter().for_each(|a| use_fixed(&mut h, a));
                    }
                }
                Op::Neg(a) | Op::PowI(a, _) | Op::Call(_, a) => use_fixed(&mut h, *a),
                Op::Div(a, b) | Op::PowF(a, b) | Op::Atan2(a, b) => {
                    use_fixed(&mut h, *a);
                    use_fixed(&mut h, *b);
                }
                Op::Input(_) | Op::Const(_) => {}
            }
        }
        let out = tape.outputs();
        for &o in &out[..n_results] {
            use_fixed(&mut h, o);
        }
        for &o in &out[n_results..] {
            if varying[o] {
                h.varying_tests.push(o);
            } else {
                h.fixed_tests.push(o);
            }
        }
        h
    }
}

/// The error text of a failed definiteness test.
pub(super) const NOT_DEFINITE: &str = "A_Γ is not positive definite (a pivot of its L D Lᵀ factorisation, or a leading minor of a block, is not > 0)";

/// `if !(tests > 0) { return Err(…) }` for the given tape entries (nothing if none).
pub(super) fn definiteness_check(tests: &[usize], place: &str) -> String {
    if tests.is_empty() {
        return String::new();
    }
    format!(
        "    if !({}) {{\n        return Err(runtime::cold_error(\"{NOT_DEFINITE} {place}\"));\n    }}\n",
        tests
            .iter()
            .map(|i| format!("t{i}.value() > 0.0"))
            .collect::<Vec<_>>()
            .join(" && ")
    )
}

/// Where a tape's inputs come from in the generated function: slots are `n` coordinates
/// (`coords[0..n]`), the parameters, then η (`eta[eta_at..]`).
#[derive(Clone, Copy)]
pub(super) struct Slots<'a> {
    pub(super) coords: &'a str,
    pub(super) n: usize,
    pub(super) params: &'a [String],
    /// The parameters set at every evaluation ([`Derivation::live`]): varying, like the state.
    pub(super) live: &'a [String],
    pub(super) eta: &'a str,
    pub(super) eta_at: usize,
}

impl Slots<'_> {
    /// Whether input slot `i` is part of the state (not a parameter).
    pub(super) fn varying(&self, i: usize) -> bool {
        i < self.n
            || i >= self.n + self.params.len()
            || self.live.contains(&self.params[i - self.n])
    }

    /// The Rust text of input slot `i`.
    pub(super) fn text(&self, i: usize) -> String {
        let np = self.params.len();
        if i < self.n {
            format!("{}[{i}]", self.coords)
        } else if i < self.n + np {
            format!("S::constant(p.{})", ident(&self.params[i - self.n]))
        } else {
            format!("{}[{}]", self.eta, self.eta_at + i - self.n - np)
        }
    }
}

/// The straight-line body of `ingredients`: the lets, then `out[j] = …`.
pub(super) fn straight_line(tape: &Tape, slots: &Slots) -> String {
    let mut o = lets(tape, slots, Part::All);
    for (j, i) in tape.outputs().iter().enumerate() {
        let _ = writeln!(o, "    out[{j}] = t{i};");
    }
    o
}

/// The two halves of a solved-form function. The tape's outputs are η̇ (σ), rates
/// (`n_rates`), then the definiteness tests; `ret` writes the result from the texts of η̇ and
/// of the rates. Returns (the body of `prepare_*`, which checks the parameter-only tests and
/// returns the prepared array, the body of `*_from`, which reads that array as `c`, the
/// array's length). Without `hoist` (a form not on the fast path, which is then never compiled
/// unless called), nothing is prepared and the body does it all.
pub(super) fn solved_body(
    tape: &Tape,
    slots: &Slots,
    hoist: bool,
    sigma: usize,
    n_rates: usize,
    ret: impl Fn(String, String) -> String,
) -> (String, String, usize) {
    let h = Hoist::new(tape, slots, sigma + n_rates);
    let (fixed, mut body) = if hoist {
        let mut fixed = lets(tape, slots, Part::Fixed(&h));
        fixed += &definiteness_check(&h.fixed_tests, "for these parameters");
        let _ = writeln!(fixed, "    Ok([{}])", list(h.names.iter().cloned()));
        let mut body = lets(tape, slots, Part::Varying(&h));
        body += &definiteness_check(&h.varying_tests, "here");
        (fixed, body)
    } else {
        let mut body = lets(tape, slots, Part::All);
        let tests = [h.fixed_tests.as_slice(), &h.varying_tests].concat();
        body.push_str(&definiteness_check(&tests, "here"));
        ("    Ok([])\n".to_string(), body)
    };
    let out = tape.outputs();
    let t = |i: &usize| format!("t{i}");
    let _ = writeln!(
        body,
        "    Ok({})",
        ret(
            list(out[..sigma].iter().map(t)),
            list(out[sigma..sigma + n_rates].iter().map(t))
        )
    );
    (fixed, body, if hoist { h.names.len() } else { 0 })
}

pub(super) fn list(items: impl IntoIterator<Item = String>) -> String {
    items.into_iter().collect::<Vec<_>>().join(", ")
}
