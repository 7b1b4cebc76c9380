//! A reduction report (`hamel reduce`) with its reduced system in printing forms: the
//! equations (11) of the kept quasi-velocities, the kinematic equations and the
//! reconstruction, collected, factored and named as a derivation is, with one where-list.

use hamel_expr::Expr;
use hamel_reduce::Reduction;

use crate::atoms::Vocabulary;
use crate::printing::{Given, PrintError, Printing};

/// The report as `hamel reduce` writes it, its entries in their printing forms. `parameters`
/// are the model's (their order is the printing order), `abbreviations` the model's
/// `[abbreviations]`.
///
/// # Errors
/// [`PrintError`]: an entry that cannot be printed exactly; nothing is returned then.
pub fn text<'r>(
    r: &'r Reduction,
    parameters: &[String],
    abbreviations: &[(&str, &Expr)],
) -> Result<String, PrintError> {
    let sigma = r.eta.len();
    let vocabulary = Vocabulary {
        parameters: parameters.to_vec(),
        coordinates: r.coordinates.clone(),
        velocities: (1..=sigma)
            .flat_map(|i| [format!("eta{i}"), format!("eta{i}_dot")])
            .collect(),
    };
    let show = |p: hamel_derive::Printer<'_, 'r>| r.to_text_with(p);
    let given = Given {
        abbreviations,
        ..Given::default()
    };
    Ok(Printing::of(&vocabulary, given, &show)?.text(&show))
}
