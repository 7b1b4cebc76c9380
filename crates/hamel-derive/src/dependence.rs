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
//!
//! A row that is a combination of the kept rows only where the model's holonomic constraint
//! h = 0 holds (the Ackermann car steered by two tied angles) is decided on that manifold
//! ([`hamel_cas::Manifold`]): the remainders vanish on it, exactly, and the coefficients are
//! defined there; δ must then not vanish on it either ([`check_delta`]).

use hamel_cas::linalg::Combination;
use hamel_cas::{Ex, Field, Manifold, Matrix};
use hamel_model::{DependentRow, Model};

use crate::error::DeriveError;

/// A dropped row's exact dependence on the kept rows of α.
#[derive(Debug)]
pub struct Dependence {
    /// The dropped row's name.
    pub name: String,
    /// Its entries (1×ℓ).
    pub row: Vec<Ex>,
    /// c_j, one per kept row: row = Σ_j c_j α_j.
    pub coefficients: Vec<Ex>,
    /// The holonomic constraint h on whose manifold h = 0 the combination holds (and only
    /// there); `None` when it holds everywhere.
    pub on: Option<String>,
}

/// The manifold of the model's holonomic constraint, where a row may depend on the kept rows
/// that does not elsewhere: the constraint's name and its zero set, or why hamel cannot decide
/// there.
pub(crate) type OnManifold = Result<(String, Manifold), String>;

/// The manifold of `model`'s one holonomic constraint (converted in `f`), or why not.
pub(crate) fn on_manifold(model: &Model, f: &Field) -> OnManifold {
    let [h] = model.holonomic.as_slice() else {
        return Err(format!(
            "hamel decides a dependence on the manifold of one holonomic constraint, and this model has {}",
            model.holonomic.len()
        ));
    };
    let e = f.convert(&h.h).map_err(|e| e.to_string())?;
    let m = f
        .manifold(&e)
        .map_err(|e| format!("on `{} = 0`: {e}", h.name))?;
    Ok((h.name.clone(), m))
}

/// The dependence of `dropped` (converted: its row of α) on the kept rows `alpha`: tried on
/// the kept rows the pre-screen found it to use, then on all of them, then (when `manifold`
/// is given) on all of them where the holonomic constraint holds.
pub(crate) fn dependence(
    alpha: &Matrix,
    dropped: &DependentRow,
    row: Vec<Ex>,
    f: &Field,
    manifold: Option<&OnManifold>,
) -> Result<Dependence, DeriveError> {
    let (mu, ell) = (alpha.rows(), alpha.cols());
    let r = Matrix::from_fn(1, ell, |_, j| row[j].clone());
    let on = &dropped.on;
    let support = Matrix::from_fn(on.len(), ell, |i, j| alpha[(on[i], j)].clone());
    let cas = |cause| DeriveError::DependenceUndecided {
        row: dropped.name.clone(),
        site: dropped.item.site.clone(),
        cause,
    };
    let dependence = |coefficients, on| Dependence {
        name: dropped.name.clone(),
        row: row.clone(),
        coefficients,
        on,
    };
    if let Combination::Of(c) = support.combination(&r).map_err(cas)? {
        let mut coefficients = vec![f.zero(); mu];
        for (&j, c) in on.iter().zip(c) {
            coefficients[j] = c;
        }
        return Ok(dependence(coefficients, None));
    }
    match alpha.combination(&r).map_err(cas)? {
        Combination::Of(c) => Ok(dependence(c, None)),
        Combination::DependentRows(rank) => {
            Err(DeriveError::KeptRowsDependent { rank, mu, on: None })
        }
        Combination::Not => {
            let (name, m) = match manifold {
                None => return Err(not_a_combination(dropped, None)),
                Some(Err(why)) => return Err(not_a_combination(dropped, Some(why.clone()))),
                Some(Ok(on)) => on,
            };
            match alpha.combination_on(&r, m).map_err(cas)? {
                Combination::Of(c) => Ok(dependence(c, Some(name.clone()))),
                Combination::Not => {
                    let why = format!("not on `{name} = 0` either");
                    Err(not_a_combination(dropped, Some(why)))
                }
                Combination::DependentRows(rank) => Err(DeriveError::KeptRowsDependent {
                    rank,
                    mu,
                    on: Some(name.clone()),
                }),
            }
        }
    }
}

/// The error for a row the pre-screen found dependent that is not exactly a combination;
/// `manifold`: what was found (or not decided) on the holonomic constraint's manifold.
fn not_a_combination(dropped: &DependentRow, manifold: Option<String>) -> DeriveError {
    DeriveError::NotACombination {
        row: dropped.name.clone(),
        site: dropped.item.site.clone(),
        manifold,
    }
}

/// δ = det[Z; α] must not vanish on the manifold where a dependence holds: there the kept
/// rows (and Z) must still be independent.
pub(crate) fn check_delta(
    model: &Model,
    dependence: &[Dependence],
    manifold: Option<&OnManifold>,
    delta: &Ex,
) -> Result<(), DeriveError> {
    let Some(d) = dependence.iter().find(|d| d.on.is_some()) else {
        return Ok(());
    };
    let Some(Ok((name, m))) = manifold else {
        return Err(DeriveError::Engine(hamel_cas::CasError::Internal(
            "a dependence on a manifold without it".into(),
        )));
    };
    if m.vanishes(delta) {
        let row = model.dependent.iter().find(|r| r.name == d.name);
        return Err(DeriveError::SingularOnManifold {
            row: d.name.clone(),
            site: row.map(|r| r.item.site.clone()),
            manifold: name.clone(),
        });
    }
    Ok(())
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
