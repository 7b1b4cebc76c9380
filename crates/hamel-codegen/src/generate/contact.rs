//! The constraint forces in generated code (issue 58): the map of their components
//! ([`hamel_eval::Contacts`], made by the derivation from the model's bodies) as straight-line
//! code of (q, the parameters, q̇), and the reports read off the multipliers λ and q̈ of the
//! structured evaluation, the supports' normal forces solved by the vendored runtime
//! (`hamel_runtime::support_normals`).
//!
//! A derivation whose supports were not released (`Model::with_supports` not called: the
//! scenes that request no force) gets a `constraint_forces_fixed` that returns none and costs
//! nothing.

use std::fmt::Write;

use hamel_derive::{Contacts, Derivation, NormalSlot, Report};

use super::{Slots, list, straight_line};
use crate::{CodegenError, escape};

/// The placeholders of the constraint forces: `nf` (how many components), `force_names`,
/// `nu`, `undetermined_names`, `constraint_forces_fn` (the functions themselves).
pub(super) fn fields(
    d: &Derivation,
    slots: Slots,
) -> Result<[(&'static str, String); 5], CodegenError> {
    let contacts = if d.contact_forces.released {
        let inputs: Vec<String> = (d.coordinates.iter())
            .chain(d.parameters.keys())
            .cloned()
            .collect();
        let map = d
            .contacts(&inputs)
            .map_err(|e| CodegenError::Ingredients(format!("the constraint forces' map: {e}")))?;
        Some(map)
    } else {
        None
    };
    let names = contacts.as_ref().map_or_else(Vec::new, Contacts::names);
    let undetermined = contacts.as_ref().map_or(&[][..], |c| &c.undetermined[..]);
    let function = match &contacts {
        Some(c) => with_map(c, slots),
        None => WITHOUT_MAP.to_string(),
    };
    Ok([
        ("nf", names.len().to_string()),
        (
            "force_names",
            list(names.iter().map(|n| escape::rust_str(n))),
        ),
        ("nu", undetermined.len().to_string()),
        (
            "undetermined_names",
            list(undetermined.iter().map(|n| escape::rust_str(n))),
        ),
        ("constraint_forces_fn", function),
    ])
}

/// Without a map: no component, nothing computed.
const WITHOUT_MAP: &str = "\
/// The constraint forces at (q, η): none, as this core was generated without their map (the
/// derivation did not release the supports of the wheels the frames keep on the ground: only
/// `hamel codegen` and the scenes that request a force do).
pub fn constraint_forces_fixed<S: Scalar>(q: &[S], eta: &[S], p: &Parameters) -> Result<([S; 0], runtime::Precision), EvalError> {
    Ok(([], runtime::Precision::F64))
}
";

/// The functions with a map: its tape's values, the reports, the checked evaluation.
fn with_map(c: &Contacts, slots: Slots) -> String {
    let velocities = Slots { eta: "qd", ..slots };
    let nv = c.tape.outputs().len();
    let mut o = String::new();
    let _ = write!(
        o,
        "/// The coefficients of the constraint forces' map at (q, q̇) ({nv} values: directions, \
         scales, the supports' equations), straight-line code.\n\
         fn contact_values<S: Scalar>(q: &[S], qd: &[S], p: &Parameters, out: &mut [S]) {{\n{}}}\n\n",
        straight_line(&c.tape, &velocities)
    );
    let _ = write!(
        o,
        "/// The reported components from the map's values `v`, the multipliers λ (α's rows) and q̈.\n\
         fn contact_reports<S: Scalar>(v: &[S], lambda: &[S], qdd: &[S], out: &mut [S]) -> Result<(), EvalError> {{\n{}    Ok(())\n}}\n\n",
        reports(c)
    );
    o + CHECKED.replace("@nv@", &nv.to_string()).as_str()
}

/// The checked evaluation: the structured one, its constraint force, and in double-double
/// where f64 would lose digits.
const CHECKED: &str = "\
/// The constraint forces at (q, η), in the order of [`CONSTRAINT_FORCES`], and the precision
/// they were computed in: λ and q̈ from the structured evaluation ([`runtime::Structured::constraint_force`]),
/// repeated in double-double where its f64 error estimate is above
/// [`runtime::DOUBLE_DOUBLE_ABOVE`], as [`rhs_fixed`] is. Nothing is differentiated numerically.
pub fn constraint_forces_fixed<S: Scalar>(q: &[S], eta: &[S], p: &Parameters) -> Result<([S; NF], runtime::Precision), EvalError> {
    let mut out = [S::constant(0.0); LEN];
    ingredients(q, p, &mut out);
    let mut storage = Storage::<S>::new();
    let mut s = storage.structured(DIMS)?;
    evaluate_into(&mut s, &out, q, eta, p, false)?;
    let zero = S::constant(0.0);
    let (mut r, mut y) = ([zero; ELL], [zero; { DIMS.m_rows() }]);
    let (mut qdd, mut tmp, mut qd) = ([zero; ELL], [zero; ELL], [zero; ELL]);
    s.constraint_force(&out, &mut r, &mut y, &mut qdd, &mut tmp);
    qd.copy_from_slice(s.q_dot());
    if S::CHECKED && s.f64_error_estimate(&out) > runtime::DOUBLE_DOUBLE_ABOVE {
        let (q, eta) = (runtime::widen::<S, Wide, ELL>(q), runtime::widen::<S, Wide, SIGMA>(eta));
        let (wide, _) = constraint_forces_fixed::<Wide>(&q, &eta, p)?;
        return Ok((wide.map(|x| S::constant(x.value())), runtime::Precision::DoubleDouble));
    }
    let mut v = [zero; @nv@];
    contact_values(q, &qd, p, &mut v);
    let mut f = [zero; NF];
    contact_reports(&v, &y[SIGMA..], &qdd, &mut f)?;
    if f.iter().any(|x| !x.value().is_finite()) {
        return Err(EvalError::NotFinite(\"the constraint forces\"));
    }
    Ok((f, runtime::Precision::F64))
}
";

/// The body of `contact_reports`: each support solved once, then one line per report.
fn reports(c: &Contacts) -> String {
    let mut o = String::new();
    for (k, s) in c.supports.iter().enumerate() {
        let solved = c.reports.iter().any(|r| {
            matches!(r, Report::Normal { slot: NormalSlot::Support { support, .. }, .. } if *support == k)
        });
        let layout = format!(
            "runtime::SupportLayout {{ at: {}, ell: ELL, rows: {}, wheels: {} }}",
            s.at,
            s.rows.len(),
            s.wheels
        );
        let rows = list(s.rows.iter().map(usize::to_string));
        let _ = writeln!(o, "    let (layout{k}, rows{k}) = ({layout}, [{rows}]);");
        if solved {
            let _ = writeln!(
                o,
                "    let mut n{k} = [S::constant(0.0); {w}];\n    \
                 if !runtime::support_normals(layout{k}, &rows{k}, v, lambda, qdd, &mut n{k}) {{\n        \
                 return Err(EvalError::Check(\"the normal forces of a support: its contacts are on one line (G is rank deficient)\"));\n    }}",
                w = s.wheels
            );
        }
    }
    for (j, r) in c.reports.iter().enumerate() {
        let value = match r {
            Report::Combination { terms, .. } if terms.is_empty() => "S::constant(0.0)".into(),
            Report::Combination { terms, .. } => (terms.iter())
                .map(|(row, at)| format!("lambda[{row}] * v[{at}]"))
                .collect::<Vec<_>>()
                .join(" + "),
            Report::Normal { slot, .. } => match slot {
                NormalSlot::Row(i) => format!("lambda[{i}]"),
                NormalSlot::Support { support, index } => format!("n{support}[{index}]"),
            },
            Report::TotalNormal { support, .. } => format!(
                "runtime::support_equations(layout{support}, &rows{support}, v, lambda, qdd)[0]"
            ),
        };
        let _ = writeln!(o, "    out[{j}] = {value};");
    }
    o
}
