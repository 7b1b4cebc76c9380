//! The quasi-velocities hamel takes when a model file names none: the independent velocities.
//!
//! A model is L and α; a choice of Z is what `hamel search` looks for. So that every other
//! command works on L and α alone, a model without `[quasi_velocities]` gets one choice,
//! `velocities`: the paper's block form (17) with Z₁₁ = I and Z₁₂ = 0, i.e. η = the velocities
//! of σ of the coordinates, the other μ velocities following from α q̇ = 0. Of the C(ℓ, σ) sets
//! of σ coordinates, the one taken is the set whose [Z; α] is best conditioned at the model's
//! default parameters: the smallest worst-case 2-norm condition number over
//! [`SAMPLES`] fixed sample configurations (ties: the first set in coordinate order). The rule
//! is in docs/model-format.md.

use hamel_expr::{EvalError, Expr};
use indexmap::IndexMap;
use nalgebra::DMatrix;

use crate::error::ModelError;
use crate::loader::Item;
use crate::model::{ChoiceOrigin, Model, QuasiVelocityChoice};
use crate::numeric::{NumericModel, sample_configurations};

/// Sample configurations over which the conditioning of each candidate set is measured.
pub const SAMPLES: usize = 16;

/// The name of the default choice.
pub const NAME: &str = "velocities";

/// The k-subsets of 0..n in lexicographic order.
pub fn combinations(n: usize, k: usize) -> Vec<Vec<usize>> {
    if k > n {
        return Vec::new();
    }
    let mut out = Vec::new();
    let mut c: Vec<usize> = (0..k).collect();
    loop {
        out.push(c.clone());
        let Some(i) = (0..k).rev().find(|&i| c[i] != i + n - k) else {
            return out;
        };
        c[i] += 1;
        for j in i + 1..k {
            c[j] = c[j - 1] + 1;
        }
    }
}

/// The 2-norm condition number of [Z; α] with Z the unit rows of `set`; infinite when singular
/// (a condition number above 10¹³).
fn condition(alpha: &[Vec<f64>], set: &[usize], ell: usize) -> f64 {
    let rows = set.len() + alpha.len();
    let m = DMatrix::from_fn(rows, ell, |i, j| {
        if i < set.len() {
            f64::from(u8::from(set[i] == j))
        } else {
            alpha[i - set.len()][j]
        }
    });
    let sv = m.singular_values();
    let (max, min) = sv
        .iter()
        .fold((0.0_f64, f64::INFINITY), |(a, b), &s| (a.max(s), b.min(s)));
    // Numerically singular (beyond what f64 can tell from zero) counts as singular.
    if max.is_finite() && min > 1e-13 * max {
        max / min
    } else {
        f64::INFINITY
    }
}

impl Model {
    /// The default choice (see the module doc), with the worst condition number in its
    /// description. Errors: α cannot be evaluated at any sample configuration, or every set of
    /// σ velocities leaves [Z; α] singular there (the constraints are dependent).
    pub(crate) fn independent_velocities(&self) -> Result<QuasiVelocityChoice, ModelError> {
        let (ell, sigma) = (self.ell(), self.sigma());
        let nm = NumericModel::new(self, &IndexMap::new())?;
        let mut alphas = Vec::new();
        for q in sample_configurations(ell, SAMPLES, 17) {
            match nm.constraint_matrix::<f64>(&q) {
                Ok(a) => alphas.push(a),
                Err(EvalError::Domain(_)) => continue,
                Err(e) => return Err(self.error(format!("cannot evaluate α: {e}"))),
            }
        }
        let mut best: Option<(f64, Vec<usize>)> = None;
        for set in combinations(ell, sigma) {
            let worst = alphas
                .iter()
                .map(|a| condition(a, &set, ell))
                .fold(0.0_f64, f64::max);
            if worst.is_finite() && best.as_ref().is_none_or(|(b, _)| worst < *b) {
                best = Some((worst, set));
            }
        }
        let Some((worst, set)) = best else {
            return Err(self
                .error("no set of independent velocities completes α: the constraints are dependent (or α cannot be evaluated) at the default parameters")
                .with_help("give a choice of quasi-velocities in [quasi_velocities.NAME]"));
        };
        let names: Vec<String> = set
            .iter()
            .map(|&j| format!("der({})", self.coordinates[j]))
            .collect();
        Ok(QuasiVelocityChoice {
            name: NAME.into(),
            description: Some(format!(
                "the independent velocities {} (the paper's (17) with Z11 = I, Z12 = 0) whose [Z; alpha] is best conditioned at the default parameters (worst condition number {worst:.3} over {} sample configurations)",
                names.join(", "),
                alphas.len()
            )),
            eta: set
                .iter()
                .enumerate()
                .map(|(i, &j)| {
                    Item::synthetic(
                        &format!("quasi_velocities.{NAME}.eta[{}]", i + 1),
                        Expr::Der(self.coordinates[j].clone()),
                    )
                })
                .collect(),
            free_functions: Vec::new(),
            origin: ChoiceOrigin::Independent,
        })
    }

    /// When `choice` is the default that hamel chose (the file names no quasi-velocities), a
    /// note for the user that names it and gives the table to paste; else `None`.
    pub fn default_choice_note(&self, choice: &QuasiVelocityChoice) -> Option<String> {
        (choice.origin == ChoiceOrigin::Independent).then(|| {
            let rows: Vec<String> = choice.eta.iter().map(|e| format!("\"{}\"", e.text)).collect();
            format!(
                "note: {} names no quasi-velocities, so hamel takes `{}`: {}. To keep it, paste\n  [quasi_velocities.{}]\n  eta = [{}]",
                self.file,
                choice.name,
                choice.description.as_deref().unwrap_or_default(),
                choice.name,
                rows.join(", ")
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn combinations_in_order() {
        assert_eq!(
            combinations(4, 2),
            [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]
        );
        assert_eq!(combinations(3, 0), [Vec::<usize>::new()]);
        assert!(combinations(2, 3).is_empty());
    }

    #[test]
    fn condition_numbers() {
        // The knife: α = (sin θ, −cos θ, 0) at θ = 0 is (0, −1, 0).
        let alpha = vec![vec![0.0, -1.0, 0.0]];
        assert!((condition(&alpha, &[0, 2], 3) - 1.0).abs() < 1e-15);
        assert_eq!(condition(&alpha, &[1, 2], 3), f64::INFINITY);
        // α = (1, 1, 0): {y, θ} gives [[0,1,0],[0,0,1],[1,1,0]], singular values φ, 1, 1/φ.
        let alpha = vec![vec![1.0, 1.0, 0.0]];
        let golden = (1.0 + 5f64.sqrt()) / 2.0;
        assert!((condition(&alpha, &[1, 2], 3) - golden * golden).abs() < 1e-12);
    }
}
