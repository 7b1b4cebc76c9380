//! The reduced right-hand side traced at a scene's start, written as straight-line f64 code
//! with its guards (issue 63): what a core without a closed form (the Whipple bicycle) runs
//! instead of the structured evaluation wherever the pivots taken at the start still stand.
//!
//! The trace (`hamel_expr::trace_guarded`, made by `hamel-run`) records the structured
//! evaluation — ingredients, the LU of [Z; α] and A_Γ with the pivots chosen at the start, the
//! contractions of (11) — as one tape of the reduced state, the parameters folded in. Each
//! pivot decision is a guard |p| > f · max |others| on the tape's values; where one fails
//! (a pivot below half its column's largest candidate, or towards the floor at which the
//! structured evaluation counts it zero), or a value is not finite, the generated
//! `traced_rates` returns None and the caller evaluates the structured form.

use std::collections::HashMap;
use std::fmt::Write;

use hamel_expr::{Guarded, Tape};

use super::emit::{Part, Slots, lets, lit};

/// A scene's right-hand side traced at its start, for its core: the guarded tape (inputs the
/// reduced state (kept coordinates, then η), outputs its rates, then the guards' values) and a
/// sentence saying how its accuracy was measured.
#[derive(Clone, Debug)]
pub struct TracedPath {
    /// The trace.
    pub guarded: Guarded,
    /// How it was checked (written into the core's documentation).
    pub note: String,
}

/// The placeholders of the traced path: `traced` (whether there is one) and `traced_fn`, the
/// documented `traced_rates(x) -> Option<[f64; REDUCED_DIM]>` (without a trace a stub that
/// returns None; with one, the tape's code and, on x86-64, its copy compiled for AVX-512).
pub(super) fn fields(traced: Option<&TracedPath>, n: usize) -> [(&'static str, String); 2] {
    let Some(t) = traced else {
        let stub = "/// none: this core was not generated with one.\n#[inline(always)]\n\
                    fn traced_rates(x: &[f64]) -> Option<[f64; REDUCED_DIM]> {\n    let _ = x;\n    None\n}\n";
        return [("traced", "false".into()), ("traced_fn", stub.into())];
    };
    let doc = format!(
        "{} operations and {} guards, {}.",
        t.guarded.tape.operation_count(),
        t.guarded.guards.len(),
        t.note
    );
    let function = format!(
        "{}{DISPATCH}{}}}\n\n{}",
        crate::escape::doc_comment("///", &doc),
        body(&t.guarded, n),
        super::program::statics(&t.guarded.tape, t.guarded.outputs)
    );
    [("traced", "true".into()), ("traced_fn", function)]
}

/// `traced_rates` choosing the copy for AVX-512 where the CPU has it, that copy, and the head of
/// the plain body (which follows, then its closing brace).
const DISPATCH: &str = "///
/// Where the CPU has AVX-512 it runs a copy compiled for it ([`traced_rates_avx512`]): the same
/// operations in the same order, the same bits, with 32 registers where x86-64 has 16 (a long
/// straight line spills less).
fn traced_rates(x: &[f64]) -> Option<[f64; REDUCED_DIM]> {
    #[cfg(target_arch = \"x86_64\")]
    {
        if std::arch::is_x86_feature_detected!(\"avx512f\") {
            // SAFETY: the CPU has AVX-512F, the one feature the copy is compiled for.
            return unsafe { traced_rates_avx512(x) };
        }
    }
    traced_rates_plain(x)
}

/// [`traced_rates_plain`] compiled for AVX-512.
#[cfg(target_arch = \"x86_64\")]
#[target_feature(enable = \"avx512f\")]
fn traced_rates_avx512(x: &[f64]) -> Option<[f64; REDUCED_DIM]> {
    traced_rates_plain(x)
}

/// The body of [`traced_rates`].
#[inline(always)]
#[allow(unused_variables, clippy::all)]
fn traced_rates_plain(x: &[f64]) -> Option<[f64; REDUCED_DIM]> {
";

/// The body of `traced_rates`: the tape's lets in f64, the guards, then the rates.
fn body(g: &Guarded, n: usize) -> String {
    let tape: &Tape = &g.tape;
    let slots = Slots {
        coords: "x",
        n: tape.inputs().len(),
        params: &[],
        live: &[],
        eta: "x",
        eta_at: 0,
    };
    let mut o = String::from("    type S = f64;\n");
    o += &lets(tape, &slots, Part::All);
    let value = |j: usize| format!("t{}", tape.outputs()[j]);
    // one largest magnitude per set of compared values
    let mut largest: HashMap<&[usize], usize> = HashMap::new();
    let mut conditions = Vec::new();
    for guard in &g.guards {
        let chosen = format!("{}.abs()", value(guard.chosen));
        if guard.others.is_empty() {
            conditions.push(format!("{chosen} > 0.0"));
            continue;
        }
        let next = largest.len();
        let m = *largest.entry(&guard.others).or_insert_with(|| {
            let max = (guard.others.iter())
                .map(|&j| format!(".max({}.abs())", value(j)))
                .collect::<String>();
            let _ = writeln!(o, "    let m{next}: f64 = 0.0_f64{max};");
            next
        });
        conditions.push(format!("{chosen} > {} * m{m}", lit(guard.factor)));
    }
    let rates: Vec<String> = (0..n).map(value).collect();
    let _ = writeln!(o, "    let v = [{}];", rates.join(", "));
    conditions.push("v.iter().all(|r| r.is_finite())".into());
    let _ = writeln!(o, "    ({}).then_some(v)", conditions.join("\n        && "));
    o
}

/// The placeholders `series_written` and `series_looped` from the trace: where its guards hold
/// at the state (and its rates are finite), the Taylor method's recurrences run over the trace
/// held as data ([`super::program`], `runtime::taylor_by_program`, which chooses its copy for
/// FMA itself); elsewhere None, and the scene core traces the structured evaluation there. The
/// series' state is the trace's outputs: the reduced state, then the forces' work where the
/// trace gives its rate (the power, which W does not enter).
pub(super) fn series_fields() -> [(&'static str, String); 2] {
    let body = "    let _ = prep;
    traced_rates(x)?;
    Some(
        runtime::taylor_by_program(&TRACED_PROGRAM, &TRACED_OUTPUTS, &x[..SERIES_DIM], order, out)
            .map_err(|_| runtime::cold_error(\"the Taylor series is not finite here\")),
    )
";
    [
        ("series_written", body.into()),
        ("series_looped", body.into()),
    ]
}
