//! The dropped rows of α, decided exactly: each is a combination of the kept rows.
//!
//! The model's pre-screen (`hamel_model`'s `rank`) keeps a maximal set of rows independent at
//! generic configurations and drops the others ([`hamel_model::DependentRow`]). Here, on the
//! CAS thread, each dropped row d is shown to be d = Σ_j c_j(q) α_j with the kept rows α_j:
//! Gauss–Jordan on the transposed system, consistent when every remainder is zero in normal
//! form (`hamel_cas::Matrix::combination`), so that σ = ℓ − rank α is a theorem, not a
//! sample. The kept rows themselves are certified of full rank by the caller. The factors of
//! the coefficients' denominators are where the kept rows lose rank: δ = det[Z; α] vanishes
//! there too (the singular set holds them), though Γ may not have a pole there (another row
//! takes over).

use hamel_cas::linalg::Combination;
use hamel_cas::{Ex, Field, Matrix};
use hamel_model::{DependentRow, Model, ModelError};

/// A dropped row's exact dependence on the kept rows of α.
#[derive(Debug)]
pub struct Dependence {
    /// The dropped row's name.
    pub name: String,
    /// Its entries (1×ℓ).
    pub row: Vec<Ex>,
    /// c_j, one per kept row: row = Σ_j c_j α_j.
    pub coefficients: Vec<Ex>,
}

/// The dependence of `dropped` (converted: its row of α) on the kept rows `alpha`: tried on
/// the kept rows the pre-screen found it to use, then on all of them.
pub(crate) fn dependence(
    model: &Model,
    alpha: &Matrix,
    dropped: &DependentRow,
    row: Vec<Ex>,
    f: &Field,
) -> Result<Dependence, ModelError> {
    let (mu, ell) = (alpha.rows(), alpha.cols());
    let r = Matrix::from_fn(1, ell, |_, j| row[j].clone());
    let on = &dropped.on;
    let support = Matrix::from_fn(on.len(), ell, |i, j| alpha[(on[i], j)].clone());
    let mut coefficients = vec![f.zero(); mu];
    let cas = |e| {
        model.error_at(
            &dropped.item.site,
            format!(
                "the dependence of the row `{}` could not be decided: {e}",
                dropped.name
            ),
        )
    };
    match support.combination(&r).map_err(cas)? {
        Combination::Of(c) => {
            for (&j, c) in on.iter().zip(c) {
                coefficients[j] = c;
            }
        }
        _ => match alpha.combination(&r).map_err(cas)? {
            Combination::Of(c) => coefficients = c,
            Combination::Not => return Err(not_a_combination(model, dropped)),
            Combination::DependentRows(rank) => {
                return Err(model.error(format!(
                    "the kept rows of α have rank {rank} < {mu}: the numeric pre-screen kept a dependent row"
                )));
            }
        },
    }
    Ok(Dependence {
        name: dropped.name.clone(),
        row,
        coefficients,
    })
}

fn not_a_combination(model: &Model, dropped: &DependentRow) -> ModelError {
    let manifold = if model.holonomic.is_empty() {
        String::new()
    } else {
        " (it may depend on them only where the holonomic constraints hold; hamel does not decide that yet)".into()
    };
    model
        .error_at(
            &dropped.item.site,
            format!(
                "the row `{}` depends on the other rows at every sample configuration, but it is not exactly a combination of them{manifold}",
                dropped.name
            ),
        )
        .with_help("the rows may be nearly, not exactly, dependent: check the row's expression and the parameters' defaults")
}

impl Dependence {
    /// The factors of its coefficients' denominators, sorted by text: where the kept rows it
    /// is combined from lose rank.
    pub fn rank_loss_factors(&self) -> Vec<Ex> {
        let mut factors: Vec<Ex> = Vec::new();
        for c in &self.coefficients {
            for x in c.denominator_factors() {
                if !factors.contains(&x) {
                    factors.push(x);
                }
            }
        }
        factors.sort_by_cached_key(|e| e.to_string());
        factors
    }
}

/// The factors at which the kept rows lose rank (the coefficients' denominators' factors),
/// each with its power in δ = det[Z; α]: divided out one at a time while it still divides
/// the numerator (exact, in normal form).
pub(crate) fn rank_loss(dependence: &[Dependence], delta: &Ex) -> Vec<(Ex, u32)> {
    let mut factors: Vec<Ex> = Vec::new();
    for x in dependence.iter().flat_map(Dependence::rank_loss_factors) {
        if !factors.contains(&x) {
            factors.push(x);
        }
    }
    factors.sort_by_cached_key(|e| e.to_string());
    factors
        .into_iter()
        .filter_map(|f| {
            let mut rest = delta.clone();
            let mut power = 0;
            while rest.numerator_factors().contains(&f) {
                match rest.div(&f) {
                    Ok(q) => rest = q,
                    Err(_) => break,
                }
                power += 1;
            }
            (power > 0).then_some((f, power))
        })
        .collect()
}
