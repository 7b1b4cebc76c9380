//! Compiling a derivation for numeric evaluation without the computer-algebra engine: its
//! ingredients (Z, α, A, U, ∇U and the exact derivatives ∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k) onto a
//! [`Tape`] for the structured evaluation of `hamel_eval` ([`Compiled`]), and the expanded
//! symbolic equations for checking them ([`SymbolicCompiled`]).

use hamel_eval::{Compiled, NumericError, SymbolicCompiled, SymbolicLayout};
use hamel_expr::Tape;
use hamel_runtime::Dims;
use indexmap::IndexMap;

use crate::derivation::{Derivation, Entry, Mat};

fn add_mat<'a>(exprs: &mut Vec<&'a hamel_expr::Expr>, m: &'a Mat) -> usize {
    let at = exprs.len();
    exprs.extend(m.entries.iter().flatten().map(|e| &e.expr));
    at
}

fn add_list<'a>(exprs: &mut Vec<&'a hamel_expr::Expr>, v: &'a [Entry]) -> usize {
    let at = exprs.len();
    exprs.extend(v.iter().map(|e| &e.expr));
    at
}

/// Free functions left in the trees, as input names (`z13(phi)`, `z13_dphi(phi)`, …), sorted.
fn free_inputs(exprs: &[&hamel_expr::Expr]) -> Vec<String> {
    let mut names = Vec::new();
    for e in exprs {
        e.visit(&mut |n| {
            if let hamel_expr::Expr::Free { .. } = n {
                let s = n.to_string();
                if !names.contains(&s) {
                    names.push(s);
                }
            }
        });
    }
    names.sort();
    names
}

impl Derivation {
    /// The ingredients of the structured evaluation, in order: Z (σ×ℓ, row-major), α (μ×ℓ,
    /// then the model's dependent rows), A (ℓ×ℓ), U, ∇U + F (ℓ), ∂A/∂q_k (ℓ blocks ℓ×ℓ), ∂Z/∂q_k
    /// (ℓ blocks σ×ℓ), ∂α/∂q_k (ℓ blocks: μ×ℓ, then the dependent rows'); the first five from the model's [`Trees`](crate::Trees) where there are.
    /// Compiled here and printed as Rust by the code generator (whose runtime `Layout` has the
    /// same offsets).
    pub fn ingredient_exprs(&self) -> Result<Vec<&hamel_expr::Expr>, NumericError> {
        let ing = &self.ingredients;
        let u = ing.potential.as_ref().ok_or(NumericError::NoIngredients)?;
        let mut exprs = Vec::new();
        match &ing.trees {
            Some(t) => {
                add_mat(&mut exprs, &t.z);
                add_mat(&mut exprs, &t.alpha);
                if let Some(d) = &ing.dependent {
                    add_mat(&mut exprs, d);
                }
                add_mat(&mut exprs, &t.a);
                exprs.push(&t.u.expr);
                add_list(&mut exprs, &t.grad_u);
            }
            None => {
                add_mat(&mut exprs, &self.z);
                add_mat(&mut exprs, &self.alpha);
                if let Some(d) = &ing.dependent {
                    add_mat(&mut exprs, d);
                }
                add_mat(&mut exprs, &self.a);
                exprs.push(&u.expr);
                add_list(&mut exprs, ing.applied.as_deref().unwrap_or(&self.grad_u));
            }
        }
        for m in ing.da.iter().chain(&ing.dz) {
            add_mat(&mut exprs, m);
        }
        for (k, m) in ing.dalpha.iter().enumerate() {
            add_mat(&mut exprs, m);
            if let Some(d) = ing.ddependent.get(k) {
                add_mat(&mut exprs, d);
            }
        }
        Ok(exprs)
    }

    /// The sizes of the structured evaluation: ℓ, μ, σ and the dependent rows.
    pub fn dims(&self) -> Dims {
        Dims {
            dependent: self.ingredients.dependent.as_ref().map_or(0, |m| m.rows),
            ..Dims::new(self.ell, self.mu, self.sigma)
        }
    }

    /// Compile for structured evaluation (inputs: coordinates and parameters). Free functions
    /// must have been given definitions before deriving.
    pub fn compile(&self) -> Result<Compiled, NumericError> {
        let exprs = self.ingredient_exprs()?;
        let free = free_inputs(&exprs);
        if !free.is_empty() {
            return Err(NumericError::FreeFunctions(self.free_functions.join(", ")));
        }
        let inputs: Vec<String> = self
            .coordinates
            .iter()
            .cloned()
            .chain(self.parameters.keys().cloned())
            .collect();
        let tape = Tape::compile(&exprs, &inputs)?;
        let dims = self.dims();
        let compiled = Compiled::new(
            tape,
            dims,
            self.coordinates.clone(),
            self.parameters.clone(),
            self.singular_set_text(),
        )?;
        let compiled = match self.forces_tape(&inputs)? {
            Some(tape) => compiled.with_forces(hamel_eval::Forces {
                tape,
                velocity: self.ingredients.velocity_forces,
            })?,
            None => compiled,
        };
        if self.kept_rank_loss.is_empty() {
            return Ok(compiled);
        }
        let factors: Vec<&hamel_expr::Expr> =
            self.kept_rank_loss.iter().map(|p| &p.factor.expr).collect();
        compiled.with_rank_loss(hamel_eval::RankLoss {
            tape: Tape::compile(&factors, &inputs)?,
            powers: self.kept_rank_loss.iter().map(|p| p.power as i32).collect(),
        })
    }

    /// The model's forces F(q, q̇) as written, on a tape of `inputs` (the ingredients') and then
    /// the velocities `der(q_1)..der(q_ℓ)` (None without forces): what the interpreter and the
    /// generated cores evaluate F from.
    pub fn forces_tape(&self, inputs: &[String]) -> Result<Option<Tape>, hamel_expr::TapeError> {
        let Some(forces) = self.ingredients.forces.as_deref() else {
            return Ok(None);
        };
        let exprs: Vec<&hamel_expr::Expr> = forces.iter().map(|e| &e.expr).collect();
        let mut with_velocities = inputs.to_vec();
        with_velocities.extend(self.coordinates.iter().map(|q| format!("der({q})")));
        Tape::compile(&exprs, &with_velocities).map(Some)
    }

    /// Compile the expanded symbolic equations (inputs: coordinates, parameters, η, and the
    /// values of the free functions and their derivatives named by
    /// [`SymbolicCompiled::free_inputs`]).
    pub fn compile_symbolic(&self) -> Result<SymbolicCompiled, NumericError> {
        let c = self
            .closed_for("evaluating the expanded equations")
            .map_err(|e| NumericError::NotClosed(e.to_string()))?;
        let mut exprs = Vec::new();
        let a_gamma = add_mat(&mut exprs, &c.a_gamma);
        let forcing = add_list(&mut exprs, &c.forcing);
        let q = exprs.len();
        for m in &c.q {
            add_mat(&mut exprs, m);
        }
        let q_paper = exprs.len();
        for m in &c.q_paper {
            add_mat(&mut exprs, m);
        }
        let free = free_inputs(&exprs);
        let inputs: Vec<String> = self
            .coordinates
            .iter()
            .cloned()
            .chain(self.parameters.keys().cloned())
            .chain((1..=self.sigma).map(|i| format!("eta{i}")))
            .chain(free.iter().cloned())
            .collect();
        let tape = Tape::compile(&exprs, &inputs)?;
        let layout = SymbolicLayout {
            sigma: self.sigma,
            a_gamma,
            forcing,
            q,
            q_paper,
        };
        Ok(SymbolicCompiled::new(
            tape,
            free,
            self.parameters.clone(),
            layout,
        ))
    }

    /// The factors of the singular set (none for a structured derivation, whose δ is not
    /// expanded).
    pub fn singular_set(&self) -> &[Entry] {
        self.closed().map_or(&[], |c| &c.singular_set)
    }

    /// The singular set as `f1 = 0 or f2 = 0 …` (or "nowhere"; for a structured derivation,
    /// that it is not computed).
    pub fn singular_set_text(&self) -> String {
        if self.closed().is_none() {
            "not computed (structured form: [Z; α] is factored numerically at every evaluation)"
                .into()
        } else if self.singular_set().is_empty() {
            "nowhere".into()
        } else {
            self.singular_set()
                .iter()
                .map(|e| format!("{} = 0", e.text))
                .collect::<Vec<_>>()
                .join(" or ")
        }
    }

    /// Parameter values: the model's defaults with `overrides` (unknown names are errors).
    pub fn parameters_with(
        &self,
        overrides: &IndexMap<String, f64>,
    ) -> Result<IndexMap<String, f64>, NumericError> {
        let mut p = self.parameters.clone();
        for (k, v) in overrides {
            match p.get_mut(k) {
                Some(slot) => *slot = *v,
                None => return Err(NumericError::UnknownParameter(k.clone())),
            }
        }
        Ok(p)
    }
}
