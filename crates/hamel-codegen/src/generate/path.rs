//! Which path the generated `fast` takes: the solved form or the structured one, chosen by
//! comparing them at sampled and near-singular states against the stated accuracy.

#[allow(unused_imports)]
use super::*;

/// Which path the generated `fast` takes, and why.
pub(super) struct PathChoice {
    pub(super) solved: bool,
    pub(super) doc: String,
}

/// States at which the paths are compared: a fixed pseudo-random sequence (deterministic) of
/// (q, η, parameter factors): q in [-3, 3] (every third in [-0.1, 0.1]), η in [-2, 2]; every
/// other state has each parameter scaled by a factor in [0.5, 2] (the others use the defaults).
pub(super) fn sample_states(
    ell: usize,
    sigma: usize,
    npar: usize,
    n: usize,
) -> Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|k| {
            // Every third state near q = 0 (where mechanisms often sit upright, and terms of
            // expanded forms cancel).
            let spread = if k % 3 == 2 { 0.1 } else { 3.0 };
            let q = (0..ell).map(|_| spread * (2.0 * next() - 1.0)).collect();
            let eta = (0..sigma).map(|_| -2.0 + 4.0 * next()).collect();
            let factors = (0..npar)
                .map(|_| {
                    let f = 0.5 * 4.0_f64.powf(next());
                    if k % 2 == 1 { f } else { 1.0 }
                })
                .collect();
            (q, eta, factors)
        })
        .collect()
}

/// Floating-point errors at up to 200 sample states ([`sample_states`]: half of them at other
/// parameters) with [Z; α] well conditioned and A_Γ positive definite, relative (max |Δ| / max(1, max |·|) over η̇ and q̇), against the
/// structured evaluation in double-double arithmetic (about 32 digits): the largest error of
/// the solved tape in f64, the largest error of the structured evaluation in f64, and the
/// number of states used. The reference also checks that the candidate is the same function.
pub(super) fn deviation(
    d: &Derivation,
    compiled: &hamel_derive::Compiled,
    solved: &Tape,
) -> (f64, f64, usize) {
    use hamel_expr::{DD, Scalar};
    let (ell, sigma) = (d.ell, d.sigma);
    let (mut worst, mut worst_structured) = (0.0_f64, 0.0_f64);
    let mut used = 0;
    for (q, eta, factors) in sample_states(ell, sigma, d.parameters.len(), 400) {
        let mut params = d.parameters.clone();
        for (v, f) in params.values_mut().zip(&factors) {
            *v *= f;
        }
        if used == 200 {
            break;
        }
        if compiled.condition(&q, &params).map_or(true, |c| c > 1e6) {
            continue;
        }
        let dd = |v: &[f64]| v.iter().map(|&x| DD::constant(x)).collect::<Vec<_>>();
        let (Ok(r), Ok(s)) = (
            compiled.rhs::<DD>(&dd(&q), &dd(&eta), &params),
            compiled.rhs::<f64>(&q, &eta, &params),
        ) else {
            continue;
        };
        let Some(out) = solved_at(solved, &q, &params, &eta, ell + sigma) else {
            continue;
        };
        let (eta_dot, q_dot) = out.split_at(sigma);
        let exact: Vec<f64> = r
            .eta_dot
            .iter()
            .chain(&r.q_dot)
            .map(|x| x.value())
            .collect();
        let scale = exact.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
        let error = |v: Vec<f64>| {
            v.iter()
                .zip(&exact)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
                / scale
        };
        worst = worst.max(error(eta_dot.iter().chain(q_dot).copied().collect()));
        worst_structured =
            worst_structured.max(error(s.eta_dot.iter().chain(&s.q_dot).copied().collect()));
        used += 1;
    }
    (worst, worst_structured, used)
}

/// The solved tape in f64 at (q, η): η̇ then q̇ (`n` = σ + ℓ values), or `None` where it fails
/// or a definiteness pivot after them is not positive.
pub(super) fn solved_at(
    solved: &Tape,
    q: &[f64],
    params: &indexmap::IndexMap<String, f64>,
    eta: &[f64],
    n: usize,
) -> Option<Vec<f64>> {
    let inputs: Vec<f64> = q
        .iter()
        .chain(params.values())
        .chain(eta)
        .copied()
        .collect();
    let mut out = solved.eval::<f64>(&inputs).ok()?;
    if out[n..].iter().any(|&p| p <= 0.0) {
        return None;
    }
    out.truncate(n);
    Some(out)
}

/// A configuration approaching the singular set, with what any candidate is compared against:
/// (q, η) and η̇ in double-double, its largest magnitude, and κ.
pub(super) struct NearSingular {
    pub(super) q: Vec<f64>,
    pub(super) eta_dot: Vec<hamel_expr::DD>,
    pub(super) scale: f64,
    pub(super) kappa: f64,
}

/// Configurations approaching each factor of δ that depends on the coordinates (distances
/// 1e-2 … 1e-7 on both sides, default parameters), with the structured evaluation in
/// double-double and the problem's own condition number κ ([`hamel_derive::conditioning`]) at
/// each: computed once, for every candidate; with the η they share.
pub(super) fn near_singular_states(
    d: &Derivation,
    compiled: &hamel_derive::Compiled,
) -> (Vec<NearSingular>, Vec<f64>) {
    use hamel_derive::conditioning::{problem_condition, singular_points};
    use hamel_expr::DD;
    let params = &d.parameters;
    let eta: Vec<f64> = (0..d.sigma)
        .map(|i| [0.8, -1.3, 0.4][i % 3] / (1 + i / 3) as f64)
        .collect();
    let dd = |v: &[f64]| v.iter().map(|&x| DD::from_f64(x)).collect::<Vec<_>>();
    let states = singular_points(d, params, 1)
        .iter()
        .flat_map(|point| point.approach(2..=7))
        .filter_map(|q| {
            let r = compiled.rhs::<DD>(&dd(&q), &dd(&eta), params).ok()?;
            let kappa = problem_condition(compiled, &q, &eta, params).ok()?;
            let scale = r
                .eta_dot
                .iter()
                .fold(0.0_f64, |m, x| m.max(x.to_f64().abs()));
            kappa.is_finite().then_some(NearSingular {
                q,
                eta_dot: r.eta_dot,
                scale,
                kappa,
            })
        })
        .collect();
    (states, eta)
}

/// The worst relative error of η̇ from the solved tape in f64 at `states`, as a multiple of
/// (κ + 1)·ε, and the number of states used. Where the solved form divides by the factors of δ
/// it keeps the digits the problem has; where its expanded numerators cancel it may not.
pub(super) fn near_singular_set(
    d: &Derivation,
    (states, eta): &(Vec<NearSingular>, Vec<f64>),
    solved: &Tape,
) -> (f64, usize) {
    use hamel_expr::DD;
    let (mut worst, mut used) = (0.0_f64, 0);
    for s in states {
        let Some(out) = solved_at(solved, &s.q, &d.parameters, eta, d.ell + d.sigma) else {
            continue;
        };
        let error = out[..d.sigma]
            .iter()
            .zip(&s.eta_dot)
            .map(|(a, b)| (DD::from_f64(*a) - *b).to_f64().abs())
            .fold(0.0, f64::max)
            / s.scale.max(f64::MIN_POSITIVE);
        worst = worst.max(error / ((s.kappa + 1.0) * f64::EPSILON));
        used += 1;
    }
    (worst, used)
}

/// The path of the generated `fast`: the candidate solved forms are tried from the fewest
/// operations at run time with fixed parameters ([`Tape::varying_operation_count`]; total
/// operations break ties). One is used when its shared operation count is at most the
/// structured path's estimate (the ingredients' plus ℓ³ + σ²ℓ², a lower estimate of what the
/// structured runtime adds: the LU of [Z; α] and the contractions of (11)) and it agrees with
/// a double-double reference at 200 sample states at least as well as the structured path, or
/// to 1e-12 ([`deviation`]), and within [`STATED_MULTIPLE`] (κ + 1)·ε approaching the singular
/// set ([`near_singular_states`], [`near_singular_set`]). Its expanded forms
/// can cancel badly in floating point (derivation.md §4), hence the check; the decision only
/// selects a code path, exactness is not at stake. Returns the choice and the candidate used
/// (the cheapest one when the structured path is taken) with its tape; no candidate for a
/// structured derivation, which has no closed form to solve.
pub(super) fn choose_path(
    d: &Derivation,
    ingredient_ops: usize,
    candidates: Vec<Candidate>,
    inputs: &[String],
    slots: &Slots,
) -> Result<(PathChoice, Option<(Candidate, Tape)>), String> {
    let ell = d.ell;
    if candidates.is_empty() {
        let doc = format!(
            "structured (the derivation is in structured form, docs/derivation.md §6: no closed form to solve; estimate: {} operations = ingredients + ℓ³ + σ²ℓ²)",
            ingredient_ops + ell.pow(3) + d.sigma.pow(2) * ell.pow(2)
        );
        return Ok((PathChoice { solved: false, doc }, None));
    }
    let mut tried: Vec<(usize, usize, Candidate, Tape)> = candidates
        .into_iter()
        .map(|c| {
            let tape = Tape::compile(&c.exprs.iter().collect::<Vec<_>>(), inputs)
                .map_err(|e| e.to_string())?;
            Ok((
                tape.varying_operation_count(|i| slots.varying(i)),
                tape.operation_count(),
                c,
                tape,
            ))
        })
        .collect::<Result<_, String>>()?;
    tried.sort_by_key(|t| (t.0, t.1));
    let ops_s = ingredient_ops + ell.pow(3) + d.sigma.pow(2) * ell.pow(2);
    let compiled = d.compile().map_err(|e| e.to_string())?;
    let near_states = near_singular_states(d, &compiled);
    let mut notes = Vec::new();
    let mut pick = None;
    for (k, (run, ops, c, tape)) in tried.iter().enumerate() {
        if *ops > ops_s {
            notes.push(format!("`{}` ({ops} operations) is more than that", c.name));
            continue;
        }
        let (worst, structured, used) = deviation(d, &compiled, tape);
        let (near, near_used) = near_singular_set(d, &near_states, tape);
        if used >= 100 && worst <= structured.max(1e-12) && near <= STATED_MULTIPLE {
            let near = if near_used == 0 {
                String::new()
            } else {
                format!(
                    "; at {near_used} states approaching the singular set, at most {near:.1e} (κ + 1)·ε"
                )
            };
            pick = Some((
                k,
                format!(
                    "solved form (`{}`): {ops} operations, {run} of them at run time with fixed parameters, against the structured path's {ops_s} (ingredients + ℓ³ + σ²ℓ²); at {used} sample states its relative error in f64 is at most {worst:.1e} (structured path: {structured:.1e}; reference: double-double){near}",
                    c.name
                ),
            ));
            break;
        }
        if near > STATED_MULTIPLE {
            notes.push(format!(
                "`{}` loses digits approaching the singular set: relative error {near:.1e} (κ + 1)·ε, above {STATED_MULTIPLE}",
                c.name
            ));
            continue;
        }
        notes.push(format!(
            "`{}` has relative error {worst:.1e} at {used} sample states, above max(1e-12, the structured path's {structured:.1e}), or too few states",
            c.name
        ));
    }
    let (solved, k, mut doc) = match pick {
        Some((k, doc)) => (true, k, doc),
        None => (
            false,
            0,
            format!("structured (estimate: {ops_s} operations = ingredients + ℓ³ + σ²ℓ²)"),
        ),
    };
    if !notes.is_empty() {
        doc += &format!("; not used: {}", notes.join("; "));
    }
    doc += &format!(
        ". Candidates (operations at run time / in all): {}.",
        list(
            tried
                .iter()
                .map(|(run, ops, c, _)| format!("`{}` {run}/{ops}", c.name))
        )
    );
    let (_, _, c, tape) = tried.swap_remove(k);
    Ok((PathChoice { solved, doc }, Some((c, tape))))
}
