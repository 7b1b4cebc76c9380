//! Compiling a derivation for numeric evaluation without the computer-algebra engine: its
//! ingredients (Z, α, A, U, ∇U and the exact derivatives ∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k) onto a
//! [`Tape`] for the structured evaluation of `hamel_eval` ([`Compiled`]), and the expanded
//! symbolic equations for checking them ([`SymbolicCompiled`]).

use hamel_eval::{Compiled, NumericError, SymbolicCompiled, SymbolicLayout};
use hamel_expr::Tape;
use hamel_runtime::Dims;

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

    /// [`Derivation::compile`] with the map of the constraint forces' components
    /// ([`Compiled::constraint_forces`]): what `hamel eval` reports; the simulations, which do
    /// not ask for them, compile without it.
    pub fn compile_with_constraint_forces(&self) -> Result<Compiled, NumericError> {
        let compiled = self.compile()?;
        let inputs: Vec<String> = (self.coordinates.iter())
            .chain(self.parameters.keys())
            .cloned()
            .collect();
        compiled.with_contacts(self.contacts(&inputs)?)
    }

    /// The names of α's rows as λ numbers them: the kept rows, then the dependent ones.
    pub fn row_names(&self) -> Vec<&str> {
        (self.constraints.iter().map(String::as_str))
            .chain(self.dependent_rows.iter().map(|r| r.name.as_str()))
            .collect()
    }

    /// The map of the constraint forces' components ([`hamel_eval::Contacts`]): each value
    /// of the model's contacts (`hamel_bodies::ContactForces`) that the motion determines
    /// ([`crate::uniqueness`]), the determined sums of those that are not, every other row's
    /// multiplier; their coefficients and the supports' equations on a tape of `inputs` and
    /// the velocities.
    pub fn contacts(&self, inputs: &[String]) -> Result<hamel_eval::Contacts, NumericError> {
        use hamel_eval::{Report, SupportSlots};
        let cf = &self.contact_forces;
        if !cf.released {
            return Err(NumericError::NoSupports);
        }
        let u = &self.force_uniqueness;
        let mut map = Map {
            names: self.row_names(),
            exprs: Vec::new(),
        };
        let mut supports = Vec::new();
        for s in &cf.supports {
            let rows = (s.rows.iter())
                .map(|(n, _)| map.number(n))
                .collect::<Result<Vec<_>, _>>()?;
            supports.push(SupportSlots {
                at: map.exprs.len(),
                rows,
                wheels: s.wheels.len(),
            });
            map.exprs.extend(s.mass.iter().flatten().cloned());
            map.exprs.extend(s.bias.iter().cloned());
            map.exprs
                .extend(s.rows.iter().flat_map(|(_, r)| r).cloned());
            map.exprs.extend(s.heights.iter().flatten().cloned());
        }
        let (mut reports, mut undetermined) = (Vec::new(), Vec::new());
        for c in &cf.contacts {
            for (component, phi) in crate::uniqueness::functionals(c) {
                let report = match u.determined(&c.name, component) {
                    true => map.report(c, component, &phi, cf)?,
                    false => None,
                };
                match report {
                    Some(r) => reports.push(r),
                    None => undetermined.push(format!("{}.{}", c.name, component.name())),
                }
            }
        }
        for r in &u.resultants {
            let phi: Vec<(String, hamel_expr::Expr)> = (cf.contacts.iter())
                .filter(|c| r.contacts.contains(&c.name))
                .flat_map(crate::uniqueness::functionals)
                .filter(|(k, _)| *k == r.component)
                .flat_map(|(_, phi)| phi)
                .collect();
            let name = format!("{}.{}", r.contacts.join("+"), r.component.name());
            reports.push(map.combination(name, &phi)?);
        }
        for (k, s) in cf.supports.iter().enumerate() {
            if s.wheels.len() > 3 && !u.supports.contains(&k) {
                let name = format!("{}.normal", s.wheels.join("+"));
                reports.push(Report::TotalNormal { name, support: k });
            }
        }
        let used: Vec<&str> = cf.contacts.iter().flat_map(|c| c.rows()).collect();
        for name in map.names.clone() {
            if used.contains(&name) {
                continue;
            }
            if u.rows.iter().any(|r| r == name) {
                undetermined.push(name.to_string());
            } else {
                let one = vec![(name.to_string(), hamel_expr::Expr::int(1))];
                reports.push(map.combination(name.to_string(), &one)?);
            }
        }
        let mut with_velocities = inputs.to_vec();
        with_velocities.extend(self.coordinates.iter().map(|q| format!("der({q})")));
        let refs: Vec<&hamel_expr::Expr> = map.exprs.iter().collect();
        Ok(hamel_eval::Contacts {
            tape: Tape::compile(&refs, &with_velocities)?,
            reports,
            supports,
            undetermined,
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
}

/// The constraint forces' map being built: α's rows as λ numbers them, and the tape's
/// expressions so far.
struct Map<'d> {
    names: Vec<&'d str>,
    exprs: Vec<hamel_expr::Expr>,
}

impl Map<'_> {
    fn number(&self, name: &str) -> Result<usize, NumericError> {
        (self.names.iter().position(|r| *r == name)).ok_or(NumericError::Sizes)
    }

    /// Σ λ_row c over `phi`'s (row, c), named `name`.
    fn combination(
        &mut self,
        name: String,
        phi: &[(String, hamel_expr::Expr)],
    ) -> Result<hamel_eval::Report, NumericError> {
        let mut terms = Vec::new();
        for (row, c) in phi {
            terms.push((self.number(row)?, self.exprs.len()));
            self.exprs.push(c.clone());
        }
        Ok(hamel_eval::Report::Combination { name, terms })
    }

    /// How `component` of contact `c` (its functional `phi`) is reported: a wheel's normal
    /// force from its row or its support (none from a support of more than three wheels,
    /// which reports their sum), any other as its combination of multipliers.
    fn report(
        &mut self,
        c: &hamel_bodies::Contact,
        component: crate::uniqueness::Component,
        phi: &[(String, hamel_expr::Expr)],
        cf: &hamel_bodies::ContactForces,
    ) -> Result<Option<hamel_eval::Report>, NumericError> {
        use hamel_bodies::{ContactKind, Normal};
        use hamel_eval::{NormalSlot, Report};
        let name = format!("{}.{}", c.name, component.name());
        let slot = match (&c.kind, component) {
            (ContactKind::Wheel(w), crate::uniqueness::Component::Normal) => match &w.normal {
                Normal::Row(r) => NormalSlot::Row(self.number(r)?),
                &Normal::Support { support, index } => {
                    if cf.supports[support].wheels.len() > 3 {
                        return Ok(None);
                    }
                    NormalSlot::Support { support, index }
                }
            },
            _ => return self.combination(name, phi).map(Some),
        };
        Ok(Some(Report::Normal { name, slot }))
    }
}
