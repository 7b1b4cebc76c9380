//! A reduction report (`hamel reduce`) with its reduced system in printing forms: the
//! equations (11) of the kept quasi-velocities, the kinematic equations and the
//! reconstruction, collected, factored and named as a derivation is, with one where-list.

use hamel_derive::{Entry, Model};
use hamel_expr::Expr;
use hamel_reduce::Reduction;

use crate::atoms::Vocabulary;
use crate::printing::{Given, PrintError, Printing};

/// The report as `hamel reduce` writes it, its entries in their printing forms, for
/// `model` (its parameters' order is the printing order; its `[abbreviations]` and `positive`
/// parameters are used as a derivation's are: the equations (11) multiplied through by a
/// denominator proved positive).
///
/// # Errors
/// [`PrintError`]: an entry that cannot be printed exactly; nothing is returned then.
pub fn text<'r>(r: &'r Reduction, model: &Model) -> Result<String, PrintError> {
    let sigma = r.eta.len();
    let vocabulary = Vocabulary {
        parameters: model.parameters.keys().cloned().collect(),
        coordinates: r.coordinates.clone(),
        velocities: (1..=sigma)
            .flat_map(|i| [format!("eta{i}"), format!("eta{i}_dot")])
            .collect(),
    };
    let abbreviations: Vec<(&str, &Expr)> = (model.abbreviations.iter())
        .map(|(k, i)| (k.as_str(), &i.expr))
        .collect();
    let equations: Vec<&Entry> = r
        .reduced_system
        .as_ref()
        .map_or(Vec::new(), |s| s.equations.iter().collect());
    let given = Given {
        abbreviations: &abbreviations,
        positive: &model.positive,
        equations: &equations,
    };
    let show = |p: hamel_derive::Printer<'_, 'r>| r.to_text_with(p);
    Ok(Printing::of(&vocabulary, given, &show)?.text(&show))
}
