//! How the generated `ingredients` is written: every ingredient as one straight-line function,
//! or, for a structured derivation, the geometry (Z, α, A) alone, its derivatives taken at run
//! time by dual numbers (`hamel_runtime::ingredients_by_partials`).

use std::fmt::Write;

use hamel_derive::Derivation;
use hamel_expr::{Expr, Tape};

use super::emit::{Slots, straight_line};
use crate::CodegenError;

/// The code of `ingredients`.
pub(super) enum IngredientCode {
    /// One straight-line function of every ingredient, the derivatives ∂A/∂q_k, ∂Z/∂q_k,
    /// ∂α/∂q_k as the derivation's trees.
    Whole(Tape),
    /// A structured derivation (docs/derivation.md §6): the geometry Z, α, A as one function
    /// evaluated over dual numbers carrying ∂/∂q_k for the coordinates it mentions (`moving`;
    /// for any other the derivatives are zero exactly), the derivative blocks read off their
    /// partials; U and ∇U apart. The derivative trees, most of a structured core's code (the
    /// Whipple bicycle's: 3,498 of 4,700 shared operations), are not written.
    ByPartials {
        geometry: Tape,
        potential: Tape,
        moving: Vec<usize>,
    },
}

impl IngredientCode {
    /// `exprs` are the ingredients in the runtime's layout, U at `u_at`.
    pub(super) fn new(
        d: &Derivation,
        exprs: &[&Expr],
        inputs: &[String],
        u_at: usize,
    ) -> Result<IngredientCode, CodegenError> {
        if d.ingredients.trees.is_none() {
            return Ok(IngredientCode::Whole(Tape::compile(exprs, inputs)?));
        }
        let geometry = &exprs[..u_at];
        let moving = (0..d.ell)
            .filter(|&k| geometry.iter().any(|e| e.mentions(&d.coordinates[k])))
            .collect();
        Ok(IngredientCode::ByPartials {
            geometry: Tape::compile(geometry, inputs)?,
            potential: Tape::compile(&exprs[u_at..u_at + 1 + d.ell], inputs)?,
            moving,
        })
    }

    /// Operations of what is written: as separate trees, and shared (`exprs` as for
    /// [`IngredientCode::new`], the derivative trees from `derivatives_at` on).
    pub(super) fn operations(&self, exprs: &[&Expr], derivatives_at: usize) -> (usize, usize) {
        let written = match self {
            IngredientCode::Whole(_) => exprs,
            IngredientCode::ByPartials { .. } => &exprs[..derivatives_at],
        };
        let trees = written.iter().map(|e| e.tree_operations()).sum();
        let shared = match self {
            IngredientCode::Whole(t) => t.operation_count(),
            IngredientCode::ByPartials {
                geometry,
                potential,
                ..
            } => geometry.operation_count() + potential.operation_count(),
        };
        (trees, shared)
    }

    /// The coordinates carried as dual partials (0 when the derivatives are written).
    pub(super) fn partials(&self) -> usize {
        match self {
            IngredientCode::Whole(_) => 0,
            IngredientCode::ByPartials { moving, .. } => moving.len(),
        }
    }

    /// The body of `ingredients`.
    pub(super) fn body(&self, slots: &Slots) -> String {
        match self {
            IngredientCode::Whole(t) => straight_line(t, slots),
            IngredientCode::ByPartials { moving, .. } => {
                let mut o = String::new();
                let list: Vec<String> = moving.iter().map(|k| k.to_string()).collect();
                let _ = writeln!(
                    o,
                    "    runtime::ingredients_by_partials::<S, {}, ELL, {{ LAYOUT.u }}, LEN>(q, &[{}], DIMS, out, |q, g| geometry(q, p, g), |q, g| geometry(q, p, g));",
                    moving.len(),
                    list.join(", ")
                );
                o.push_str("    potential(q, p, &mut out[LAYOUT.u..LAYOUT.da]);\n");
                o
            }
        }
    }

    /// The functions `ingredients` calls (none for [`IngredientCode::Whole`]).
    pub(super) fn parts(&self, slots: &Slots) -> String {
        match self {
            IngredientCode::Whole(_) => String::new(),
            IngredientCode::ByPartials {
                geometry,
                potential,
                ..
            } => format!(
                "\n/// Z, α (with its dependent rows) and A at q, straight-line code (the entries of [`LAYOUT`]\n\
                 /// before U): [`ingredients`] evaluates it over dual numbers for their derivatives.\n\
                 fn geometry<S: Scalar>(q: &[S], p: &Parameters, out: &mut [S]) {{\n{}}}\n\
                 \n/// U and ∇U at q, straight-line code.\n\
                 fn potential<S: Scalar>(q: &[S], p: &Parameters, out: &mut [S]) {{\n{}}}\n",
                straight_line(geometry, slots),
                straight_line(potential, slots)
            ),
        }
    }

    /// How `ingredients` computes, for its doc.
    pub(super) fn doc(&self) -> &'static str {
        match self {
            IngredientCode::Whole(_) => ", straight-line code",
            IngredientCode::ByPartials { .. } => {
                ": [`geometry`] over dual numbers (the derivative blocks their partials), then [`potential`]"
            }
        }
    }

    /// For the module doc: what the counts leave to run time.
    pub(super) fn partials_doc(&self, d: &Derivation) -> String {
        match self {
            IngredientCode::Whole(_) => String::new(),
            IngredientCode::ByPartials {
                geometry, moving, ..
            } => {
                let names: Vec<&str> = moving.iter().map(|&k| d.coordinates[k].as_str()).collect();
                format!(
                    ", the derivatives not written\n//! but taken at run time: the geometry's {} operations evaluated over dual numbers with\n//! {} partials ({})",
                    geometry.operation_count(),
                    moving.len(),
                    names.join(", ")
                )
            }
        }
    }
}
