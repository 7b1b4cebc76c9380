//! The exact check that a steady motion is one: the steady values substituted into the closed
//! form of the equations (11), and the residuals decided zero on canonical forms, identically
//! in the model's and the steady parameters (inputs at zero). Where that cannot be done (a
//! structured derivation, coordinates completed by Newton's method, free functions, square
//! roots) the reason is kept and each point is checked numerically instead.

use hamel_cas::{CasError, Ex, Field, FieldSpec, Matrix};
use hamel_derive::Derivation;
use hamel_expr::Expr;
use hamel_model::{Coord, Model, Steady};

use hamel_model::SteadyCheck;

/// The coordinates of a study: dropped (the equations are free of them), completed from the
/// holonomic constraints, and in the state.
#[derive(Clone, Debug)]
pub struct Partition {
    /// Dropped (their proof is the reduction's).
    pub dropped: Vec<Coord>,
    /// Kept and completed from the holonomic constraints.
    pub dependent: Vec<Coord>,
    /// In the state (kept, not dependent).
    pub state_q: Vec<Coord>,
}

/// The partition of `model`'s coordinates when those `reduction` proves absent are dropped.
/// Error: a holonomic constraint mentions a dropped coordinate.
pub fn partition(
    model: &Model,
    reduction: Option<&crate::Reduction>,
) -> Result<Partition, crate::ReduceError> {
    let dropped: Vec<Coord> = reduction.map_or(Vec::new(), |r| r.ground_truth.absent_in(model));
    let completion = &model.completion;
    let is_dependent = |k: &Coord| completion.dependent().contains(&k.index());
    if let Some(&k) = dropped.iter().find(|k| completion.mentions(k.index())) {
        return Err(crate::ReduceError::DroppedInHolonomic {
            coordinate: model.coordinate_name(k).to_string(),
        });
    }
    let dependent: Vec<Coord> = (completion.dependent().iter())
        .map(|&k| Coord::new(k))
        .filter(|k| !dropped.contains(k))
        .collect();
    let state_q: Vec<Coord> = (model.coords())
        .filter(|k| !dropped.contains(k) && !is_dependent(k))
        .collect();
    Ok(Partition {
        dropped,
        dependent,
        state_q,
    })
}

/// Indices of `ks`, for the numeric vectors in model order.
fn indices(ks: &[Coord]) -> Vec<usize> {
    ks.iter().map(|k| k.index()).collect()
}

/// The exact check of the steady motion `name` of `model` on the derivation `d`, with the
/// coordinates `reduction` proves absent dropped (in the pass: `crate::pass`).
pub(crate) fn check_dropped(
    model: &Model,
    name: &str,
    d: &Derivation,
    reduction: Option<&crate::Reduction>,
) -> Result<SteadyCheck, crate::ReduceError> {
    let steady = model.steady(name)?;
    let p = partition(model, reduction)?;
    Ok(check(&Inputs {
        model,
        steady,
        derivation: d,
        state_q: &indices(&p.state_q),
        dependent: &indices(&p.dependent),
    }))
}

/// Trees larger than this (operations) are not checked exactly: the numeric check stands in.
const LARGEST: usize = 200_000;

/// What the check needs from the study being prepared.
pub(crate) struct Inputs<'a> {
    pub model: &'a Model,
    pub steady: &'a Steady,
    pub derivation: &'a Derivation,
    /// Coordinates in the state (their rates must vanish).
    pub state_q: &'a [usize],
    /// Coordinates completed numerically from the holonomic constraints.
    pub dependent: &'a [usize],
}

/// Decide exactly, where it can be done, that the steady state is steady.
pub(crate) fn check(i: &Inputs<'_>) -> SteadyCheck {
    match job(i) {
        Ok(Job::Ready(work)) => match hamel_cas::run(move || work.decide()) {
            Ok(Ok(check)) => check,
            Ok(Err(e)) | Err(e) => {
                numeric(format!("the computer algebra could not decide it ({e})"))
            }
        },
        Ok(Job::Numeric(why)) => numeric(why),
        Err(e) => numeric(e),
    }
}

fn numeric(why: String) -> SteadyCheck {
    SteadyCheck::Numeric { why }
}

enum Job {
    Ready(Work),
    Numeric(String),
}

/// The trees of the check, with the steady values in place of the coordinates.
struct Work {
    parameters: Vec<String>,
    /// Z(q*) (σ×ℓ) and α(q*) (μ×ℓ).
    z: Vec<Vec<Expr>>,
    alpha: Vec<Vec<Expr>>,
    /// The velocities given, by coordinate.
    given: Vec<Option<Expr>>,
    /// The equations (11) at q*, η̇ = 0, inputs 0; still in η.
    equations: Vec<Expr>,
    /// Names of the state's coordinates, by index (for residuals).
    coordinates: Vec<String>,
    state_q: Vec<usize>,
}

fn job(i: &Inputs<'_>) -> Result<Job, String> {
    let d = i.derivation;
    let Some(closed) = d.closed() else {
        return Ok(Job::Numeric(
            "the derivation is in structured form, without closed-form equations".into(),
        ));
    };
    if !i.dependent.is_empty() {
        let names: Vec<&str> = i
            .dependent
            .iter()
            .map(|&k| i.model.coordinates[k].as_str())
            .collect();
        return Ok(Job::Numeric(format!(
            "{} completed numerically from the holonomic constraints",
            names.join(", ")
        )));
    }
    if !d.free_functions.is_empty() {
        return Ok(Job::Numeric(
            "the quasi-velocities have free functions".into(),
        ));
    }
    let values = coordinate_values(i.model, i.steady);
    let at_q = |e: &Expr| substitute(e, &|n| values.get(n).cloned());
    let zero_rates = |e: &Expr| {
        let sigma = d.sigma;
        substitute(e, &|n| {
            let rate = (1..=sigma).any(|k| n == format!("eta{k}_dot"));
            (rate || i.model.inputs.iter().any(|u| u == n)).then(|| Expr::int(0))
        })
    };
    let equations: Vec<Expr> = closed
        .equations
        .iter()
        .map(|e| zero_rates(&at_q(&e.expr)))
        .collect();
    let size: usize = equations.iter().map(Expr::tree_operations).sum();
    if size > LARGEST {
        return Ok(Job::Numeric(format!(
            "the equations are too large to substitute exactly ({size} operations)"
        )));
    }
    let matrix = |m: &hamel_derive::Mat| -> Vec<Vec<Expr>> {
        let row = |r: &Vec<hamel_derive::Entry>| r.iter().map(|e| at_q(&e.expr)).collect();
        m.entries.iter().map(row).collect()
    };
    let mut given = vec![None; i.model.coordinates.len()];
    for (k, item) in &i.steady.velocities {
        given[*k] = Some(item.expr.clone());
    }
    let work = Work {
        parameters: d
            .parameters
            .keys()
            .chain(i.steady.parameters.keys())
            .cloned()
            .collect(),
        z: matrix(&d.z),
        alpha: matrix(&d.alpha),
        given,
        equations,
        coordinates: i.model.coordinates.clone(),
        state_q: i.state_q.to_vec(),
    };
    if work.has_square_roots() {
        return Ok(Job::Numeric(
            "square roots: their canonical forms do not decide zero".into(),
        ));
    }
    Ok(Job::Ready(work))
}

/// Every coordinate's steady value (0 where none is given).
fn coordinate_values(model: &Model, steady: &Steady) -> std::collections::HashMap<String, Expr> {
    let mut values: std::collections::HashMap<String, Expr> = model
        .coordinates
        .iter()
        .map(|c| (c.clone(), Expr::int(0)))
        .collect();
    for (k, item) in &steady.q {
        values.insert(model.coordinates[*k].clone(), item.expr.clone());
    }
    values
}

/// `e` with each symbol that `by` names replaced.
fn substitute(e: &Expr, by: &dyn Fn(&str) -> Option<Expr>) -> Expr {
    e.map(&mut |node| match node {
        Expr::Sym(n) => by(&n).unwrap_or(Expr::Sym(n)),
        other => other,
    })
}

impl Work {
    fn trees(&self) -> impl Iterator<Item = &Expr> {
        let m = self.z.iter().chain(&self.alpha).flatten();
        m.chain(self.given.iter().flatten()).chain(&self.equations)
    }

    fn has_square_roots(&self) -> bool {
        self.trees().any(|e| {
            e.any(&mut |n| match n {
                Expr::Call(hamel_expr::Func::Sqrt, _) => true,
                Expr::Pow(_, x) => x.as_integer().is_none(),
                _ => false,
            })
        })
    }

    fn field(&self, expressions: Vec<Expr>) -> Result<Field, CasError> {
        Field::new(&FieldSpec {
            parameters: self.parameters.clone(),
            expressions,
            ..FieldSpec::default()
        })
    }

    /// On the computer-algebra thread: the velocities, η*, and the residuals.
    fn decide(self) -> Result<SteadyCheck, CasError> {
        let f = self.field(self.trees().cloned().collect())?;
        let q_dot = self.velocities(&f)?;
        let Some(q_dot) = q_dot else {
            return Ok(numeric(
                "the constraints do not determine the velocities not given".into(),
            ));
        };
        let mut residuals = Vec::new();
        for &k in &self.state_q {
            if !q_dot[k].is_zero() {
                residuals.push((
                    format!("d({})/dt", self.coordinates[k]),
                    q_dot[k].to_string(),
                ));
            }
        }
        let eta: Vec<Expr> = self
            .z
            .iter()
            .map(|row| {
                let z = row.iter().map(|e| f.convert(e));
                let terms = z.zip(&q_dot).map(|(z, v)| z.map(|z| &z * v));
                terms
                    .collect::<Result<Vec<Ex>, _>>()
                    .map(|t| t.iter().fold(f.zero(), |acc, x| &acc + x).to_expr())
            })
            .collect::<Result<_, _>>()?;
        let equations: Vec<Expr> = self
            .equations
            .iter()
            .map(|e| {
                substitute(e, &|n| {
                    let i = n.strip_prefix("eta")?.parse::<usize>().ok()?;
                    eta.get(i.checked_sub(1)?).cloned()
                })
            })
            .collect();
        let g = self.field(equations.clone())?;
        for (i, e) in equations.iter().enumerate() {
            let r = g.convert(e)?;
            if !r.is_zero() {
                residuals.push((
                    format!("row {} of (11) at d(eta)/dt = 0", i + 1),
                    r.to_string(),
                ));
            }
        }
        Ok(if residuals.is_empty() {
            SteadyCheck::Exact
        } else {
            SteadyCheck::NotIdentically { residuals }
        })
    }

    /// q̇*: the velocities given, and the others from α(q*)q̇ = 0 (exact inverse); `None` when
    /// the constraints do not determine them.
    fn velocities(&self, f: &Field) -> Result<Option<Vec<Ex>>, CasError> {
        let ell = self.given.len();
        let mut q_dot = vec![f.zero(); ell];
        for (k, g) in self.given.iter().enumerate() {
            if let Some(e) = g {
                q_dot[k] = f.convert(e)?;
            }
        }
        let unknown: Vec<usize> = (0..ell).filter(|&k| self.given[k].is_none()).collect();
        if unknown.len() != self.alpha.len() {
            return Ok(None);
        }
        if unknown.is_empty() {
            return Ok(Some(q_dot));
        }
        let alpha =
            Matrix::try_from_fn(self.alpha.len(), ell, |i, j| f.convert(&self.alpha[i][j]))?;
        let a = Matrix::from_fn(unknown.len(), unknown.len(), |i, j| {
            alpha[(i, unknown[j])].clone()
        });
        let Some((inverse, _)) = a.inverse()? else {
            return Ok(None);
        };
        let b: Vec<Ex> = (0..self.alpha.len())
            .map(|i| {
                (0..ell)
                    .filter(|&k| self.given[k].is_some())
                    .fold(f.zero(), |acc, k| &acc - &(&alpha[(i, k)] * &q_dot[k]))
            })
            .collect();
        for (r, &k) in unknown.iter().enumerate() {
            q_dot[k] = b
                .iter()
                .enumerate()
                .fold(f.zero(), |acc, (c, x)| &acc + &(&inverse[(r, c)] * x));
        }
        Ok(Some(q_dot))
    }
}
