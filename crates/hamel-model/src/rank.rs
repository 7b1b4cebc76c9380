//! Dependent rows of α, pre-screened numerically: which rows a model keeps and which it drops.
//!
//! **Job**: a model's rows of α may depend on each other (two wheels on one axle give four
//! no-slip rows of rank 3: −sin ψ (L_x − R_x) + cos ψ (L_y − R_y) ≡ 0). hamel keeps a maximal
//! set of rows independent at generic configurations and parameters, the first such rows in
//! the model's order, and drops each other row as a combination of the kept ones; σ = ℓ − rank α.
//!
//! **Inputs**: the model with all its rows. **Outputs**: the kept rows (the model's
//! `constraints`, what every later stage sees) and the [`DependentRow`]s.
//!
//! **Invariant**: this is a pre-screen. The rank is measured at [`SAMPLES`] configurations
//! (completed onto the holonomic constraints h(q) = 0, so that the rank is the rank on the
//! constraint manifold) with every parameter moved to a pseudo-random value near its default;
//! the exact decision is the symbolic stage's (`hamel-derive`): the kept rows certified of full
//! rank, and each dropped row's dependence row_k = Σ_j c_j(q) row_j computed and checked to
//! leave a zero remainder on canonical forms. A rank that is lower at the default parameters
//! than at generic ones (a track width of 0) is a located error naming the rows.

use hamel_expr::EvalError;
use indexmap::IndexMap;
use nalgebra::DMatrix;

use crate::error::ModelError;
use crate::loader::Item;
use crate::model::Model;
use crate::numeric::{NumericModel, sample_configurations};

/// Configurations at which the rank is measured.
pub const SAMPLES: usize = 12;

/// A singular value below this fraction of the largest counts as zero: dependent rows leave
/// rounding (about 1e-15 relative), independent ones at pseudo-random points far more.
const ZERO: f64 = 1e-10;

/// A row of α that depends on the kept rows (found numerically; its exact dependence is the
/// derivation's).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct DependentRow {
    /// Its name (`right_no_slip_y`).
    pub name: String,
    /// Its expression, linear in the velocities.
    pub item: Item,
    /// Its place among all the model's rows (0-based), for writing them back in order.
    pub position: usize,
    /// The kept rows (indices into the model's `constraints`) with a nonzero coefficient in
    /// the dependence at the sample configurations.
    pub on: Vec<usize>,
    /// Whether it depends on them only where the holonomic constraints hold: at samples not
    /// completed onto h = 0 it raises the rank (the pre-screen's finding; the derivation
    /// decides it exactly on the manifold).
    pub only_on_manifold: bool,
}

/// The rows evaluated at sample configurations for one set of parameter values.
struct Samples(Vec<DMatrix<f64>>);

impl Samples {
    /// At sample configurations completed onto the holonomic constraints.
    fn of(model: &Model, params: &IndexMap<String, f64>, seed: u64) -> Result<Samples, ModelError> {
        Samples::at(model, params, seed, true)
    }

    /// At sample configurations, completed onto h = 0 or (`complete: false`) not.
    fn at(
        model: &Model,
        params: &IndexMap<String, f64>,
        seed: u64,
        complete: bool,
    ) -> Result<Samples, ModelError> {
        let nm = NumericModel::new(model, params)?;
        let mut out = Vec::new();
        for mut q in sample_configurations(model.ell(), SAMPLES, seed) {
            if complete && model.completion.complete(&mut q, params).is_err() {
                continue;
            }
            match nm.constraint_matrix::<f64>(&q) {
                Ok(rows) => out.push(DMatrix::from_fn(rows.len(), model.ell(), |i, j| rows[i][j])),
                Err(EvalError::Domain(_)) => continue,
                Err(e) => return Err(model.error(format!("cannot evaluate α: {e}"))),
            }
        }
        Ok(Samples(out))
    }

    /// The largest numerical rank of the rows `rows` over the samples.
    fn rank(&self, rows: &[usize]) -> usize {
        self.0
            .iter()
            .map(|m| numerical_rank(&m.select_rows(rows)))
            .max()
            .unwrap_or(0)
    }

    /// The greedy choice: each row in order, kept when it raises the rank of those kept.
    fn kept(&self, rows: &[usize]) -> Vec<usize> {
        let mut kept: Vec<usize> = Vec::new();
        for &r in rows {
            let mut with = kept.clone();
            with.push(r);
            if self.rank(&with) > kept.len() {
                kept = with;
            }
        }
        kept
    }

    /// The kept rows with a coefficient of at least `ZERO` relative in `row`'s least-squares
    /// dependence on them, at some sample.
    fn support(&self, kept: &[usize], row: usize) -> Vec<usize> {
        if kept.is_empty() {
            return Vec::new(); // every row is zero: nothing to depend on
        }
        let mut on = vec![false; kept.len()];
        for m in &self.0 {
            let k = m.select_rows(kept).transpose();
            let target = m.row(row).transpose();
            let Ok(c) = k.clone().svd(true, true).solve(&target, ZERO) else {
                continue;
            };
            let scale = c.amax().max(f64::MIN_POSITIVE);
            for (flag, x) in on.iter_mut().zip(c.iter()) {
                *flag |= x.abs() > 1e-8 * scale;
            }
        }
        (0..kept.len()).filter(|&i| on[i]).collect()
    }
}

fn numerical_rank(m: &DMatrix<f64>) -> usize {
    if m.nrows() == 0 {
        return 0;
    }
    let sv = m.singular_values();
    let max = sv.amax();
    if max == 0.0 || !max.is_finite() {
        return 0;
    }
    sv.iter().filter(|&&s| s > ZERO * max).count()
}

/// Every parameter that is not derived moved to a pseudo-random value near its default (a
/// zero default to one in [0.3, 1]), the derived ones evaluated from them.
/// When that fails (a derived parameter not finite there), the defaults.
fn generic_parameters(model: &Model) -> IndexMap<String, f64> {
    let mut next = crate::numeric::uniform(31);
    let set: IndexMap<String, f64> = model
        .parameters
        .iter()
        .filter(|(k, _)| !model.derived.contains_key(*k))
        .map(|(k, &v)| {
            let u = next();
            let moved = if v == 0.0 {
                0.3 + 0.7 * u
            } else {
                v * (0.7 + 0.6 * u)
            };
            (k.clone(), moved)
        })
        .collect();
    model
        .parameter_values(&set)
        .unwrap_or_else(|_| model.parameters.clone())
}

impl Model {
    /// Split the model's rows into the kept ones (left in `constraints`) and the dependent
    /// ones (`dependent`), see the module doc. Errors: α cannot be evaluated at any sample, or
    /// its rank is lower at the default parameters than at generic ones.
    pub(crate) fn split_dependent_rows(&mut self) -> Result<(), ModelError> {
        if self.constraints.is_empty() {
            return Ok(());
        }
        let generic = Samples::of(self, &generic_parameters(self), 23)?;
        if generic.0.is_empty() {
            return Err(self.error(
                "α cannot be evaluated at any sample configuration (or the holonomic constraints cannot be completed there)",
            ));
        }
        let all: Vec<usize> = (0..self.constraints.len()).collect();
        let kept = generic.kept(&all);
        self.check_rank_at_defaults(&kept)?;
        if kept.len() == all.len() {
            return Ok(());
        }
        // Off h = 0 (where there are holonomic constraints), to tell which rows depend on the
        // kept ones only on it.
        let off = match self.holonomic.is_empty() {
            true => None,
            false => Some(Samples::at(self, &generic_parameters(self), 37, false)?),
        };
        let rows = std::mem::take(&mut self.constraints);
        let mut dependent = Vec::new();
        for (position, (name, item)) in rows.iter().enumerate() {
            if kept.contains(&position) {
                self.constraints.push((name.clone(), item.clone()));
            } else {
                dependent.push(DependentRow {
                    name: name.clone(),
                    item: item.clone(),
                    position,
                    on: generic.support(&kept, position),
                    only_on_manifold: off.as_ref().is_some_and(|off| {
                        let with: Vec<usize> = kept.iter().copied().chain([position]).collect();
                        off.rank(&with) > kept.len()
                    }),
                });
            }
        }
        self.dependent = dependent;
        Ok(())
    }

    /// The rows `kept` (independent at generic parameters) must be independent at the
    /// defaults as well.
    fn check_rank_at_defaults(&self, kept: &[usize]) -> Result<(), ModelError> {
        let defaults = Samples::of(self, &self.parameters, 29)?;
        if defaults.0.is_empty() || defaults.rank(kept) == kept.len() {
            return Ok(());
        }
        let at_defaults = defaults.kept(kept);
        let lost: Vec<&(String, Item)> = kept
            .iter()
            .filter(|r| !at_defaults.contains(r))
            .map(|&r| &self.constraints[r])
            .collect();
        let names: Vec<String> = lost.iter().map(|(n, _)| format!("`{n}`")).collect();
        Err(self
            .error_at(
                &lost[0].1.site,
                format!(
                    "the constraints are independent for generic parameter values (rank {}) but dependent at the model's defaults (rank {}): {} then {} on the rows before {}",
                    kept.len(),
                    at_defaults.len(),
                    names.join(", "),
                    if names.len() == 1 { "depends" } else { "depend" },
                    if names.len() == 1 { "it" } else { "them" },
                ),
            )
            .with_help("a default value makes two rows parallel (a length of 0?): change the defaults, or remove the rows"))
    }

    /// The rows of α in the model's order, the dependent ones among the kept ones, each with
    /// whether it is kept.
    pub fn all_rows(&self) -> Vec<(&str, &Item, bool)> {
        let mut out: Vec<(&str, &Item, bool)> = self
            .constraints
            .iter()
            .map(|(n, i)| (n.as_str(), i, true))
            .collect();
        for d in &self.dependent {
            out.insert(d.position, (d.name.as_str(), &d.item, false));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use crate::Model;

    /// Two knife edges on one axle (a cart's two wheels seen as blades) and the same knife
    /// typed twice: the rows that depend on the ones before them are dropped, the first kept.
    const AXLE: &str = r#"
name = "axle"
title = "two blades on one axle"
coordinates = ["x", "y", "theta", "a", "b"]
[parameters]
m = 1.0
w = 0.2
r = 0.1
[lagrangian]
kinetic = "m/2*(der(x)^2 + der(y)^2) + m/24*der(theta)^2 + der(a)^2/2 + der(b)^2/2"
[constraints]
left_lateral = "-sin(theta)*der(x) + cos(theta)*der(y)"
left_roll = "cos(theta)*der(x) + sin(theta)*der(y) - w*der(theta) - r*der(a)"
right_lateral = "-sin(theta)*der(x) + cos(theta)*der(y)"
right_roll = "cos(theta)*der(x) + sin(theta)*der(y) + w*der(theta) - r*der(b)"
"#;

    #[test]
    fn dependent_rows_are_dropped_in_order_and_written_back() {
        let m = Model::from_source("axle.toml", AXLE).unwrap();
        let kept: Vec<&str> = m.constraints.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(kept, ["left_lateral", "left_roll", "right_roll"]);
        assert_eq!(m.dependent.len(), 1);
        let d = &m.dependent[0];
        assert_eq!(
            (d.name.as_str(), d.position, d.on.clone()),
            ("right_lateral", 2, vec![0])
        );
        assert_eq!((m.mu(), m.sigma()), (3, 2));
        let order: Vec<&str> = m.all_rows().iter().map(|(n, _, _)| *n).collect();
        assert_eq!(
            order,
            ["left_lateral", "left_roll", "right_lateral", "right_roll"]
        );
        // `hamel expand` writes every row and names the dependent one; it loads back the same.
        let text = m.to_lagrangian_toml();
        assert!(
            text.contains("right_lateral depends on left_lateral"),
            "{text}"
        );
        let back = Model::from_source("back.toml", &text).unwrap();
        assert_eq!(back.dependent.len(), 1);
    }

    #[test]
    fn a_rank_that_drops_only_at_the_defaults_is_an_error_naming_the_rows() {
        let text = AXLE.replace("w = 0.2", "w = 0.0").replace(
            "right_lateral = \"-sin(theta)*der(x) + cos(theta)*der(y)\"\n",
            "",
        );
        let text = text.replace("- r*der(b)", "- r*der(a)");
        let e = Model::from_source("axle.toml", &text)
            .unwrap_err()
            .to_string();
        assert!(e.contains("dependent at the model's defaults"), "{e}");
        assert!(e.contains("`right_roll`"), "{e}");
    }

    /// A blade at the origin of a frame that only turns (the body moves in another): its one
    /// constraint row is zero, so
    /// no row is kept and the zero row depends on nothing (found by the model fuzz target,
    /// which panicked here on the empty least-squares problem).
    #[test]
    fn a_lone_zero_row_depends_on_nothing() {
        let text = r#"
name = "still_blade"
title = "a blade that cannot move"
coordinates = ["x", "y", "theta"]
[parameters]
m = 2.0
[world]
up = "z"
[frames.cart]
origin = ["x", "y", 0]
rotations = [{ axis = "z", angle = "theta" }]
[frames.body]
rotations = [{ axis = "z", angle = "theta" }]
[bodies.sleigh]
frame = "cart"
mass = "m"
inertia = { xx = "m", yy = "m", zz = "m" }
[blades.runner]
frame = "body"
direction = "x"
"#;
        let m = Model::from_source("still.toml", text).unwrap();
        assert_eq!(m.mu(), 0);
        assert_eq!(m.dependent.len(), 1);
        assert!(m.dependent[0].on.is_empty());
        let header = m.to_lagrangian_toml();
        assert!(
            header.contains("depends on nothing: it is zero"),
            "{header}"
        );
    }
}
