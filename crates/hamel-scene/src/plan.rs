//! `hamel plan SCENE`: model only what a scene requires.
//!
//! From the outputs a scene requests, decide which coordinates are integrated with the
//! dynamics, which are reconstructed alongside (quadratures q̇_k = (Γη)_k that nothing else
//! needs), and which are dropped. All decisions are exact: a coordinate "occurs" in an
//! expression when it appears in the expression's canonical form (docs/reduction.md), and the
//! elimination of everything not integrated is confirmed by `hamel reduce`'s ground truth.
//!
//! * integrated: the coordinates occurring in the true equations (11), closed under the
//!   kinematic equations q̇_k = (Γη)_k of the coordinates already integrated, then η;
//! * reconstructed: the requested coordinates not integrated, those the energy needs when it
//!   is requested (U may depend on a coordinate absent from Γᵀ∇U), all of them when the
//!   constraint residual is requested, closed under their own kinematic equations;
//! * dropped: the rest — not integrated, not computed.

use hamel_derive::{Derivation, Entry};
use hamel_expr::{Expr, Tape};
use hamel_model::{Model, ModelError};
use indexmap::IndexMap;
use serde::Serialize;

use crate::cache;

/// What a scene asks for (`request = [...]`; everything when absent).
#[derive(Clone, Debug)]
pub struct Request {
    /// Requested coordinates, by index.
    pub coordinates: Vec<usize>,
    /// η requested.
    pub eta: bool,
    /// The energy requested.
    pub energy: bool,
    /// The constraint residual α(q)q̇ requested.
    pub constraint_residual: bool,
    /// The scene's `[expressions]` requested, by index.
    pub expressions: Vec<usize>,
    /// Coordinates the requested expressions need (kept in the state, not written).
    pub needed: Vec<usize>,
}

impl Request {
    /// Everything (the default).
    pub fn everything(ell: usize, expressions: usize) -> Request {
        Request {
            coordinates: (0..ell).collect(),
            eta: true,
            energy: true,
            constraint_residual: true,
            expressions: (0..expressions).collect(),
            needed: Vec::new(),
        }
    }

    /// Parse the names of `request`: coordinates, `eta` (or `eta1`…, which all mean η: it is
    /// integrated whole), `energy`, `constraint_residual`, the names of the scene's
    /// `expressions`. Errors name the unknown entry and list the valid ones.
    pub fn parse(
        names: &[String],
        d: &Derivation,
        expressions: &[String],
    ) -> Result<Request, String> {
        let mut r = Request {
            coordinates: Vec::new(),
            eta: false,
            energy: false,
            constraint_residual: false,
            expressions: Vec::new(),
            needed: Vec::new(),
        };
        for n in names {
            if let Some(k) = d.coordinates.iter().position(|c| c == n) {
                if !r.coordinates.contains(&k) {
                    r.coordinates.push(k);
                }
            } else if n == "eta"
                || n.strip_prefix("eta")
                    .and_then(|i| i.parse::<usize>().ok())
                    .is_some_and(|i| (1..=d.sigma).contains(&i))
            {
                r.eta = true;
            } else if n == "energy" {
                r.energy = true;
            } else if n == "constraint_residual" {
                r.constraint_residual = true;
            } else if let Some(i) = expressions.iter().position(|e| e == n) {
                if !r.expressions.contains(&i) {
                    r.expressions.push(i);
                }
            } else {
                return Err(format!(
                    "`{n}` is not an output of this scene: use coordinates ({}), eta (or eta1..eta{}), energy, constraint_residual{}",
                    d.coordinates.join(", "),
                    d.sigma,
                    if expressions.is_empty() {
                        ", or a name defined in [expressions]".to_string()
                    } else {
                        format!(", or an expression ({})", expressions.join(", "))
                    }
                ));
            }
        }
        r.coordinates.sort_unstable();
        Ok(r)
    }
}

/// The plan of a scene (`hamel plan --format json`).
#[derive(Clone, Debug, Serialize)]
pub struct Plan {
    /// Integrated with the dynamics: coordinates, then `eta1`…
    pub integrated: Vec<String>,
    /// Reconstructed alongside (quadratures nothing else needs).
    pub reconstructed: Vec<String>,
    /// Neither integrated nor computed.
    pub dropped: Vec<String>,
    /// The quasi-velocity choice used.
    pub eta: String,
    /// The requested `[expressions]` of the scene, each with the coordinates it needs
    /// (evaluated at the output times only, from the integrated and reconstructed state).
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    pub expressions: IndexMap<String, Vec<String>>,
    /// Arithmetic operations of the planned right-hand side (η̇ and the rates of the integrated
    /// and reconstructed coordinates, common subexpressions shared, in the solved form the
    /// code generator chooses).
    pub ops: usize,
    /// The same for the full system (all coordinates), for comparison.
    pub ops_full: usize,
    /// The directory of the scene's generated code in the cache.
    pub code: String,
    /// Whether that code was found in the cache (else generated by this run).
    pub cached: bool,
    /// The cache entry.
    #[serde(skip)]
    pub entry: cache::Entry,
    /// Indices of the integrated coordinates (model order).
    #[serde(skip)]
    pub integrated_ix: Vec<usize>,
    /// Indices of the reconstructed coordinates.
    #[serde(skip)]
    pub reconstructed_ix: Vec<usize>,
    /// Indices of the dropped coordinates.
    #[serde(skip)]
    pub dropped_ix: Vec<usize>,
}

/// The coordinates (indices) occurring in `e`.
fn occurring(e: &Expr, coordinates: &[String]) -> Vec<usize> {
    (0..coordinates.len())
        .filter(|&k| {
            let c = &coordinates[k];
            e.any(&mut |x| match x {
                Expr::Sym(n) | Expr::Der(n) => n == c,
                Expr::Free { args, .. } => args.contains(c),
                _ => false,
            })
        })
        .collect()
}

/// Add to `set` every coordinate the kinematic equations of its members need, until closed.
fn close(set: &mut Vec<usize>, kinematics: &[Entry], coordinates: &[String]) {
    let mut k = 0;
    while k < set.len() {
        for c in occurring(&kinematics[set[k]].expr, coordinates) {
            if !set.contains(&c) {
                set.push(c);
            }
        }
        k += 1;
    }
    set.sort_unstable();
}

/// Plan the scene: `d` is the derivation of the scene's choice, `fixed` the scene's parameter
/// values; the elimination of every coordinate not integrated is confirmed by `hamel reduce`
/// (exact ground truth). The scene's code (specialised for `fixed`, the dropped coordinates
/// eliminated) is taken from the cache or generated into it ([`cache`]); the operation
/// counts are its solved form's.
pub fn plan(
    model: &Model,
    d: &Derivation,
    request: &Request,
    fixed: &IndexMap<String, f64>,
) -> Result<Plan, ModelError> {
    let coords = &d.coordinates;
    let mut integrated: Vec<usize> = Vec::new();
    for e in &d.equations {
        for c in occurring(&e.expr, coords) {
            if !integrated.contains(&c) {
                integrated.push(c);
            }
        }
    }
    close(&mut integrated, &d.kinematics, coords);
    let mut wanted: Vec<usize> = request.coordinates.clone();
    wanted.extend(&request.needed);
    if request.energy {
        wanted.extend(occurring(&d.energy.expr, coords));
    }
    if request.constraint_residual {
        wanted.extend(0..d.ell);
    }
    let mut reconstructed: Vec<usize> = Vec::new();
    for c in wanted {
        if !integrated.contains(&c) && !reconstructed.contains(&c) {
            reconstructed.push(c);
        }
    }
    close(&mut reconstructed, &d.kinematics, coords);
    reconstructed.retain(|c| !integrated.contains(c));
    let dropped: Vec<usize> = (0..d.ell)
        .filter(|c| !integrated.contains(c) && !reconstructed.contains(c))
        .collect();

    // Confirm exactly, as `hamel reduce` does, that the integrated system is closed without
    // the other coordinates; on a cache miss, take the derivation made for code generation
    // from the same symbolic pass.
    let absent: Vec<usize> = (0..d.ell).filter(|c| !integrated.contains(c)).collect();
    let names = |ix: &[usize]| -> Vec<String> { ix.iter().map(|&k| coords[k].clone()).collect() };
    let key = cache::Key::new(&model.source, &d.eta_name, &names(&dropped), fixed);
    let confirm = |r: &hamel_reduce::Reduction| -> Result<(), ModelError> {
        if !r.ground_truth.present.is_empty() || !r.ground_truth.kinematics_closed {
            return Err(model.error(format!(
                "internal error: the plan integrates ({}) without ({}), but `hamel reduce` finds {} in the equations",
                names(&integrated).join(", "),
                names(&absent).join(", "),
                r.ground_truth.present.join(", ")
            )));
        }
        Ok(())
    };
    let entry = match cache::lookup(&key).map_err(|e| model.error(e))? {
        Some(entry) => {
            if !absent.is_empty() {
                confirm(&hamel_reduce::reduce(
                    model,
                    Some(&d.eta_name),
                    &names(&absent),
                )?)?;
            }
            entry
        }
        None => {
            let code = if absent.is_empty() {
                hamel_derive::derive_for_code(model, Some(&d.eta_name))?
            } else {
                let (r, code) = hamel_reduce::reduce_with_derivation(
                    model,
                    Some(&d.eta_name),
                    &names(&absent),
                )?;
                confirm(&r)?;
                code
            };
            let state: Vec<usize> = integrated.iter().chain(&reconstructed).copied().collect();
            let cannot = |e: String| {
                model.error(format!("cannot generate the planned right-hand side: {e}"))
            };
            let full = hamel_codegen::generate(&code, &[], "plan").map_err(cannot)?;
            let ops_full =
                ops_of(&full.solved, d.sigma, &(0..d.ell).collect::<Vec<_>>()).map_err(cannot)?;
            // The specialised crate's solved form has every coordinate's rate; the planned
            // state's are counted.
            let ops = |g: &hamel_codegen::Generated| ops_of(&g.solved, d.sigma, &state);
            cache::store(
                &key,
                &code,
                fixed,
                &dropped,
                ops,
                ops_full,
                &format!("hamel simulate (scene of {}, {})", model.file, d.eta_name),
            )
            .map_err(cannot)?
        }
    };
    Ok(Plan {
        integrated: names(&integrated)
            .into_iter()
            .chain((1..=d.sigma).map(|i| format!("eta{i}")))
            .collect(),
        reconstructed: names(&reconstructed),
        dropped: names(&dropped),
        eta: d.eta_name.clone(),
        expressions: IndexMap::new(),
        ops: entry.meta.ops,
        ops_full: entry.meta.ops_full,
        code: entry.dir.display().to_string(),
        cached: entry.cached,
        entry,
        integrated_ix: integrated,
        reconstructed_ix: reconstructed,
        dropped_ix: dropped,
    })
}

/// Operations of η̇ and the rates of `coords` in a solved form, common subexpressions shared.
fn ops_of(
    solved: &hamel_codegen::SolvedForm,
    sigma: usize,
    coords: &[usize],
) -> Result<usize, String> {
    let exprs: Vec<&Expr> = solved.exprs[..sigma]
        .iter()
        .chain(coords.iter().map(|&k| &solved.exprs[sigma + k]))
        .collect();
    Tape::compile(&exprs, &solved.inputs)
        .map(|t| t.operation_count())
        .map_err(|e| format!("internal error: {e}"))
}

impl Plan {
    /// The plan as text.
    pub fn to_text(&self) -> String {
        let list = |v: &[String]| {
            if v.is_empty() {
                "(none)".to_string()
            } else {
                v.join(", ")
            }
        };
        let expressions = self
            .expressions
            .iter()
            .map(|(name, needs)| format!("expression {name}: needs {}\n", list(needs)))
            .collect::<String>();
        format!(
            "quasi-velocities: {}\nintegrated: {}\nreconstructed: {}\ndropped: {}\n{expressions}operations of the right-hand side: {} (full system: {})\n",
            self.eta,
            list(&self.integrated),
            list(&self.reconstructed),
            list(&self.dropped),
            self.ops,
            self.ops_full
        )
    }
}
