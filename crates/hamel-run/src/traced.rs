//! The scene's right-hand side traced at its start for its compiled core (issue 63): the
//! structured evaluation (ingredients, the LU of [Z; α] and of A_Γ, the contractions of (11))
//! run once on [`hamel_expr::Traced`] numbers at the initial state, in the core's order
//! (kept coordinates by model index, then η), with every pivot decision recorded as a guard
//! ([`hamel_expr::trace_guarded`]).
//!
//! **Job**: give the code generator straight-line code for the scene's equations where the
//! derivation has no closed form (the Whipple bicycle), as `--export-python` gives numba.
//! **Input**: a [`Start`] (`Loaded::trace_start`): a model without a closed form (the core
//! solves one where there is), its parameters all fixed (none live, none varied by an
//! ensemble: the trace folds their values in). **Output**: a [`hamel_codegen::TracedPath`],
//! or the reason there is none.
//! **Invariants**: the tape computes the structured evaluation's function wherever its guards
//! hold (the same pivots up to threshold pivoting's factor 1/2); it is used only where it is
//! as accurate as the structured evaluation in f64, measured at states around the start
//! against double-double ([`accuracy`]), the rule the solved forms pass (`hamel-codegen`'s
//! `path.rs`). The tape depends on the pivots taken, not on the point: the cache keys the
//! core by it ([`fingerprint`]).

use hamel_expr::{DD, Guarded, Scalar};
use indexmap::IndexMap;

/// What the trace needs of a loaded scene ([`crate::Loaded::trace_start`]).
pub struct Start<'a> {
    /// The structured evaluator.
    pub compiled: &'a hamel_derive::Compiled,
    /// The derivation (its sizes, coordinates, whether it has a closed form).
    pub d: &'a hamel_derive::Derivation,
    /// The kept coordinates, by model index (the core's order).
    pub kept: Vec<usize>,
    /// The scene's parameter values.
    pub params: &'a IndexMap<String, f64>,
    /// Whether the core folds every parameter in (none live, none varied by members).
    pub all_fixed: bool,
    /// The value of the dropped coordinates.
    pub reference: f64,
    /// The initial state in the core's order (kept coordinates, then η).
    pub y0: Vec<f64>,
    /// Whether the core's state carries the forces' work W (the energy requested of a model
    /// with forces): its rate, the power q̇ᵀF, is then traced as one more output, so that the
    /// core's compiled series covers the whole state.
    pub work: bool,
}

/// Sample states around the start at which the trace is compared ([`accuracy`]).
const SAMPLES: usize = 64;

/// The scene's right-hand side traced at its start, guarded; the reason where there is none: the
/// model has a closed form, a parameter is not fixed, the trace fails, or a decision cannot be
/// guarded.
pub fn core_trace(s: &Start) -> Result<Guarded, String> {
    if s.d.closed().is_some() {
        return Err("the model has a closed form (the core solves it)".into());
    }
    if !s.all_fixed {
        return Err("parameters set in time or varied by members are not folded in".into());
    }
    let names: Vec<String> = (s.kept.iter())
        .map(|&k| s.d.coordinates[k].clone())
        .chain((1..=s.d.sigma).map(|i| format!("eta{i}")))
        .collect();
    let guarded = hamel_expr::trace_guarded(&names, &s.y0, |y| rates(s, y))
        .map_err(|e| format!("the trace failed: {e}"))?;
    if guarded.undecidable {
        return Err("a decision by value cannot be guarded (dependent constraint rows)".into());
    }
    Ok(guarded)
}

/// The reduced rates at y (core order) over any scalar: the kept coordinates' rates, then η̇;
/// with [`Start::work`], then the power q̇ᵀF (W's rate, which W does not enter).
fn rates<S: Scalar>(s: &Start, y: &[S]) -> Result<Vec<S>, hamel_derive::NumericError> {
    let (qs, eta) = y.split_at(s.kept.len());
    let mut q = vec![S::constant(s.reference); s.d.ell];
    for (i, &k) in s.kept.iter().enumerate() {
        q[k] = qs[i];
    }
    let r = s.compiled.rhs::<S>(&q, eta, s.params)?;
    let mut out: Vec<S> = (s.kept.iter().map(|&k| r.q_dot[k]))
        .chain(r.eta_dot.iter().copied())
        .collect();
    if s.work {
        let f = (s.compiled.forces_at(&q, &r.q_dot, s.params)?).unwrap_or_default();
        let power = (f.iter().zip(&r.q_dot)).fold(S::constant(0.0), |w, (f, v)| w + *f * *v);
        out.push(power);
    }
    Ok(out)
}

/// The reduced rates at `y` (the core's order) by the structured evaluation, in f64.
pub fn structured_rates(s: &Start, y: &[f64]) -> Result<Vec<f64>, String> {
    rates::<f64>(s, y).map_err(|e| e.to_string())
}

/// How the trace compares at states around the start where its guards hold: its largest
/// relative error in f64 (max |Δ| / max(1, max |rate|)), the structured evaluation's in f64,
/// both against the structured evaluation in double-double, and the number of states used.
/// States: each coordinate moved by up to ±0.1, each η component by up to ±10 % (at least
/// ±0.1), a fixed pseudo-random sequence.
pub fn accuracy(s: &Start, guarded: &Guarded) -> (f64, f64, usize) {
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        2.0 * ((seed >> 11) as f64 / (1u64 << 53) as f64) - 1.0
    };
    let (mut worst, mut structured, mut used) = (0.0_f64, 0.0_f64, 0);
    for _ in 0..SAMPLES {
        let y: Vec<f64> = (s.y0.iter().enumerate())
            .map(|(i, &v)| {
                let spread = if i < s.kept.len() {
                    0.1
                } else {
                    (0.1 * v.abs()).max(0.1)
                };
                v + spread * next()
            })
            .collect();
        let Ok(values) = guarded.tape.eval::<f64>(&y) else {
            continue;
        };
        let yd: Vec<DD> = y.iter().map(|&v| DD::constant(v)).collect();
        let (true, Ok(exact), Ok(plain)) = (
            guarded.holds(&values),
            rates::<DD>(s, &yd),
            rates::<f64>(s, &y),
        ) else {
            continue;
        };
        let exact: Vec<f64> = exact.iter().map(|x| x.value()).collect();
        let scale = exact.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
        let error = |v: &[f64]| {
            (v.iter().zip(&exact)).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs())) / scale
        };
        worst = worst.max(error(&values[..guarded.outputs]));
        structured = structured.max(error(&plain));
        used += 1;
    }
    (worst, structured, used)
}

/// What identifies the traced code: SHA-256 of the tape and its guards as text (the same
/// pivots give the same tape, wherever in their region the start lies).
pub fn fingerprint(guarded: &Guarded) -> String {
    use sha2::Digest;
    let text = format!("{:?}\n{:?}", guarded.tape, guarded.guards);
    format!("{:x}", sha2::Sha256::digest(text.as_bytes()))
}

/// The trace `guarded` of `s` if the core should use it: with a sentence saying how it was
/// measured, or the reason it is not used.
pub fn checked(s: &Start, guarded: Guarded) -> Result<hamel_codegen::TracedPath, String> {
    let (worst, structured, used) = accuracy(s, &guarded);
    if used < SAMPLES / 4 || worst > structured.max(1e-12) {
        return Err(format!(
            "at {used} of {SAMPLES} states around the start where its guards hold, its relative error in f64 is {worst:.1e}, above max(1e-12, the structured evaluation's {structured:.1e}), or too few states"
        ));
    }
    let note = format!(
        "traced at the scene's start; at {used} of {SAMPLES} states around it where its guards hold, its relative error in f64 is at most {worst:.1e} (the structured evaluation's in f64: {structured:.1e}; reference: double-double)"
    );
    Ok(hamel_codegen::TracedPath { guarded, note })
}

/// What the cache needs of the trace of `s` ([`crate::cache::CoreTrace`]), or why there is none.
pub fn for_core(s: Start<'_>) -> Result<crate::cache::CoreTrace<'_>, String> {
    let guarded = core_trace(&s)?;
    Ok(crate::cache::CoreTrace {
        fingerprint: fingerprint(&guarded),
        make: Box::new(move || checked(&s, guarded)),
    })
}
