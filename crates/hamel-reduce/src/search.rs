//! Search for quasi-velocities that eliminate given coordinates from the TRUE equations (11).
//!
//! Families (tried in the order b, c, a):
//! * (c) **A-orthogonal**: Z = Γ'ᵀA for a basis Γ' of ker α (one basis per choice of σ
//!   independent velocities). The quasi-velocities are momenta of the constrained Lagrangian:
//!   ν = ΘᵀAΓ ≡ 0, so the paper's equations are exact and H6 holds trivially.
//! * (b) **finite ansatz**: the velocities of the kept coordinates stay quasi-velocities (block
//!   2 of (17)); the other v rows are drawn from a basis of rows: plain velocities der(q),
//!   velocities rotated by an angle of the model (cos a·der(q_i) + sin a·der(q_j) and
//!   −sin a·der(q_i) + cos a·der(q_j), as the knife's z₁₁ = cos θ, z₁₂ = sin θ), and conjugate
//!   momenta ∂T/∂der(q_j) (Remark 1.1). Candidates are enumerated simplest first.
//! * (a) **unknown functions**: the rows found in (b) recombined with coefficients that are
//!   free functions of the kept coordinates (as the paper's z₁₁(θ), ẑ₁₁(θ, θ₁), …), checked
//!   with the functions kept symbolic: such a family reduces for every choice of the functions.
//!
//! Every candidate with δ = det[Z; α] ≢ 0 is first pre-screened numerically (η̇ from the
//! Lagrange-multiplier oracle must not change when the eliminated coordinates change), then
//! decided exactly by [`crate::reduce`]'s ground truth on the true equations. The numeric
//! screen only rejects; acceptance is always exact.

use std::time::{Duration, Instant};

use hamel_cas::{Ex, Matrix};
use hamel_derive::{Derived, FormRequest, Symbolic};
use hamel_expr::{Dual, Expr, Func};
use hamel_model::{ChoiceOrigin, Item, Model, NumericModel, QuasiVelocityChoice, combinations};
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use crate::analysis::dependence_conditions;

/// One reducing choice.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Candidate {
    /// A name for the `[quasi_velocities.NAME]` table.
    pub name: String,
    /// Family: `a_orthogonal`, `ansatz` or `functions`.
    pub family: String,
    /// The quasi-velocities, in model-file syntax.
    pub eta: Vec<String>,
    /// The coordinates it eliminates (all those asked).
    pub eliminated: Vec<String>,
    /// Free functions of the family, as `name(args)`.
    pub free_functions: Vec<String>,
    /// The state of the reduced system (η and the coordinates still needed).
    pub reduced_state: Vec<String>,
    /// Whether the paper's equations are exact for it (ν ≡ 0 or the correction vanishes).
    pub paper_is_exact: bool,
    /// Number of nonzero entries of Z (the simplicity measure, with `functions`).
    pub nonzero: usize,
    /// The choice as a ready-to-paste TOML table.
    pub toml: String,
}

/// Counts for one family.
#[derive(Clone, Debug, Serialize, Deserialize, Default, PartialEq)]
pub struct FamilyStats {
    /// Candidates generated.
    pub generated: usize,
    /// Rejected because det[Z; α] vanished at every sample configuration.
    pub singular: usize,
    /// Rejected by the numeric pre-screen (η̇ changed with an eliminated coordinate).
    pub screened_out: usize,
    /// Decided exactly.
    pub exact_checks: usize,
    /// Found to reduce.
    pub found: usize,
    /// The same choice as an earlier candidate.
    pub duplicates: usize,
    /// Not decided: the choice's expressions exceed the size limit of an exact check.
    pub too_large: usize,
}

/// Largest total length (characters) of a candidate's quasi-velocities that is decided exactly.
const MAX_TEXT: usize = 1000;

/// Most unknown functions in the family (a) ansatz (each adds variables to every expression).
const FUNCTIONS: usize = 6;

/// Why a search stopped.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum StopReason {
    /// Every candidate of every family was tried.
    Completed,
    /// Every family was tried, the finite ansatz up to the number of candidates asked for.
    MaxCandidates,
    /// The budget ran out between two candidates.
    Budget,
    /// The budget ran out during the exact check of a candidate, which was abandoned: the
    /// process running it was ended (`hamel search` runs the search in a worker process).
    BudgetDuringCheck {
        /// The candidate's family.
        family: String,
        /// Its quasi-velocities.
        eta: Vec<String>,
    },
}

impl StopReason {
    /// Whether the budget ended the search.
    pub fn budget(&self) -> bool {
        matches!(
            self,
            StopReason::Budget | StopReason::BudgetDuringCheck { .. }
        )
    }

    /// One line for people.
    pub fn describe(&self) -> String {
        match self {
            StopReason::Completed => "every candidate was tried".into(),
            StopReason::MaxCandidates => {
                "the finite ansatz stopped at the number of candidates asked for (--max)".into()
            }
            StopReason::Budget => "the time budget ran out".into(),
            StopReason::BudgetDuringCheck { family, eta } => format!(
                "the time budget ran out during the exact check of the {family} candidate [{}], which was abandoned",
                eta.join("; ")
            ),
        }
    }
}

/// What a running search reports, as it happens.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum SearchEvent {
    /// Candidates done, candidates generated so far, and the counts per family (sent when a
    /// candidate starts and when it is decided: a check under way is not in them).
    Progress {
        /// Candidates tried.
        done: u64,
        /// Candidates generated so far.
        total: u64,
        /// Counts per family so far.
        families: IndexMap<String, FamilyStats>,
    },
    /// The exact check of a candidate starts (it may take long).
    Checking {
        /// The candidate's family.
        family: String,
        /// Its quasi-velocities.
        eta: Vec<String>,
    },
    /// A reducing candidate was found.
    Found(Candidate),
}

/// Receives the events of a search (on the CAS thread).
pub type Events = Box<dyn Fn(SearchEvent) + Send>;

/// The result of `hamel search`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SearchReport {
    /// Model identifier.
    pub model: String,
    /// The coordinates to eliminate.
    pub eliminate: Vec<String>,
    /// Reducing choices, simplest first.
    pub candidates: Vec<Candidate>,
    /// Statistics per family.
    pub families: IndexMap<String, FamilyStats>,
    /// When nothing was found: why (the condition no candidate could meet).
    pub none_found: Option<String>,
    /// Conditions on the unknown functions of family (a) that hamel could not solve in closed
    /// form (equations `… = 0`, each with the entry of (11) it comes from).
    pub unsolved_conditions: Vec<String>,
    /// Why the search stopped.
    pub stop: StopReason,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// Options of a search.
#[derive(Clone, Debug)]
pub struct SearchOptions {
    /// Time budget.
    pub budget: Duration,
    /// Most candidates to report.
    pub max_candidates: usize,
}

/// A row of Z (a quasi-velocity as a combination of velocities) and its number of nonzero
/// entries.
#[derive(Clone, Debug)]
struct Row {
    expr: Expr,
    nonzero: usize,
}

/// `der(q)`.
fn der(names: &[String], j: usize) -> Expr {
    Expr::Der(names[j].clone())
}

fn unit(names: &[String], j: usize) -> Row {
    Row {
        expr: der(names, j),
        nonzero: 1,
    }
}

/// Σ_j c_j der(q_j) over the nonzero coefficients.
fn row_of(names: &[String], coeffs: &[Ex]) -> Row {
    let terms: Vec<Expr> = coeffs
        .iter()
        .enumerate()
        .filter(|(_, c)| !c.is_zero())
        .map(|(j, c)| {
            if c.is_one() {
                der(names, j)
            } else {
                Expr::Mul(vec![c.to_expr(), der(names, j)])
            }
        })
        .collect();
    Row {
        nonzero: terms.len(),
        expr: Expr::Add(terms).tidy(),
    }
}

/// The rotation of (der(q_i), der(q_j)) by the angle q_a: its two rows.
fn rotation(names: &[String], (i, j, a): (usize, usize, usize)) -> [Row; 2] {
    let angle = Expr::sym(&names[a]);
    let (sin, cos) = (
        Expr::call(Func::Sin, angle.clone()),
        Expr::call(Func::Cos, angle),
    );
    let times = |f: &Expr, k: usize| Expr::Mul(vec![f.clone(), der(names, k)]);
    [
        Expr::Add(vec![times(&cos, i), times(&sin, j)]),
        Expr::Add(vec![Expr::Neg(Box::new(times(&sin, i))), times(&cos, j)]),
    ]
    .map(|expr| Row { expr, nonzero: 2 })
}

/// Coordinates that occur in the argument of sin, cos or tan in the model's kinetic energy or
/// constraints (the angles that may rotate velocities).
fn angles(model: &Model) -> Vec<usize> {
    let mut items: Vec<&Expr> = model.constraints.iter().map(|(_, c)| &c.expr).collect();
    match &model.kinetic {
        hamel_model::Kinetic::Energy(t) => items.push(&t.expr),
        hamel_model::Kinetic::MassMatrix(rows) => {
            items.extend(rows.iter().flatten().map(|i| &i.expr))
        }
    }
    (0..model.ell())
        .filter(|&k| {
            let q = &model.coordinates[k];
            items.iter().any(|e| {
                e.any(&mut |n| match n {
                    Expr::Call(Func::Sin | Func::Cos | Func::Tan, arg) => {
                        arg.any(&mut |x| matches!(x, Expr::Sym(s) if s == q))
                    }
                    _ => false,
                })
            })
        })
        .collect()
}

/// The model with one more choice.
fn with_choice(model: &Model, name: &str, eta: &[Expr], free: &[(String, Vec<String>)]) -> Model {
    let key = format!("quasi_velocities.{name}");
    let items = eta
        .iter()
        .map(|e| Item::synthetic(&key, e.clone()))
        .collect();
    let mut m = model.clone();
    m.choices.retain(|c| c.name != name);
    m.choices.push(QuasiVelocityChoice {
        name: name.to_string(),
        description: None,
        eta: items,
        free_functions: free.to_vec(),
        origin: ChoiceOrigin::Search,
    });
    m
}

/// η̇ at (q, η) from the Lagrange-multiplier oracle: q̇ = Γη, η̇ = Żq̇ + Zq̈. `None` where
/// [Z; α] is (nearly) singular.
fn eta_dot(nm: &NumericModel<'_>, choice: &str, q: &[f64], eta: &[f64]) -> Option<Vec<f64>> {
    let ell = q.len();
    let sigma = eta.len();
    let z = nm.quasi_velocity_matrix::<f64>(choice, q).ok()?;
    let alpha = nm.constraint_matrix::<f64>(q).ok()?;
    let m = nalgebra::DMatrix::from_fn(ell, ell, |i, j| {
        if i < sigma {
            z[i][j]
        } else {
            alpha[i - sigma][j]
        }
    });
    let sv = m.singular_values();
    if sv.min() < 1e-8 * sv.max().max(1.0) {
        return None;
    }
    let inv = m.try_inverse()?;
    let qd: Vec<f64> = (0..ell)
        .map(|i| (0..sigma).map(|s| inv[(i, s)] * eta[s]).sum())
        .collect();
    let acc = hamel_oracle::accelerations::<f64>(nm, q, &qd).ok()?;
    let qdual: Vec<Dual<f64>> = (0..ell).map(|i| Dual::new(q[i], qd[i])).collect();
    let zd = nm.quasi_velocity_matrix::<Dual<f64>>(choice, &qdual).ok()?;
    let out: Vec<f64> = (0..sigma)
        .map(|i| {
            (0..ell)
                .map(|j| zd[i][j].d * qd[j] + z[i][j] * acc.q_ddot[j])
                .sum()
        })
        .collect();
    out.iter().all(|x| x.is_finite()).then_some(out)
}

enum Screen {
    Singular,
    Depends,
    Pass,
}

/// Numeric pre-screen: at a few configurations, changing the eliminated coordinates must not
/// change η̇.
fn screen(model: &Model, choice: &str, p: &[usize], samples: &[Vec<f64>]) -> Screen {
    let Ok(nm) = NumericModel::new(model, &IndexMap::new()) else {
        return Screen::Singular;
    };
    let sigma = model.sigma();
    let mut tested = 0;
    for (n, q) in samples.iter().enumerate() {
        let eta: Vec<f64> = (0..sigma)
            .map(|i| 0.3 + 0.37 * ((n + 2 * i) as f64).sin())
            .collect();
        let Some(a) = eta_dot(&nm, choice, q, &eta) else {
            continue;
        };
        let mut q2 = q.clone();
        for (t, &k) in p.iter().enumerate() {
            q2[k] += 0.7 + 0.31 * t as f64;
        }
        let Some(b) = eta_dot(&nm, choice, &q2, &eta) else {
            continue;
        };
        let scale = a.iter().chain(&b).fold(1.0f64, |m, x| m.max(x.abs()));
        if a.iter().zip(&b).any(|(x, y)| (x - y).abs() > 1e-7 * scale) {
            return Screen::Depends;
        }
        tested += 1;
        if tested == 2 {
            break;
        }
    }
    if tested == 0 {
        Screen::Singular
    } else {
        Screen::Pass
    }
}

fn toml_block(name: &str, family: &str, eta: &[String]) -> String {
    let rows: Vec<String> = eta.iter().map(|e| format!("  \"{e}\",")).collect();
    format!(
        "[quasi_velocities.{name}]\neta = [\n{}\n]\ndescription = \"found by hamel search ({family})\"\n",
        rows.join("\n")
    )
}

struct Searcher<'a> {
    model: &'a Model,
    p: &'a [usize],
    samples: Vec<Vec<f64>>,
    started: Instant,
    options: SearchOptions,
    events: Events,
    done: u64,
    total: u64,
    families: IndexMap<String, FamilyStats>,
    found: Vec<Candidate>,
    failures: IndexMap<String, usize>,
    exhausted: bool,
    seen: std::collections::HashSet<String>,
    /// The derivation of the last candidate decided exactly (for the conditions of (a)).
    last: Option<Symbolic>,
    /// Conditions on the unknown functions of family (a) that could not be solved.
    unsolved: Vec<String>,
}

impl Searcher<'_> {
    fn out_of_time(&mut self) -> bool {
        if self.started.elapsed() > self.options.budget {
            self.exhausted = true;
        }
        self.exhausted
    }

    /// The counts so far, to the events.
    fn progress(&self) {
        (self.events)(SearchEvent::Progress {
            done: self.done,
            total: self.total,
            families: self.families.clone(),
        });
    }

    /// Try one candidate; true when it reduces. The counts go out when it starts and when it
    /// is decided, so that they never count a check that has not ended.
    fn try_candidate(
        &mut self,
        family: &str,
        eta: Vec<Expr>,
        free: Vec<(String, Vec<String>)>,
        nonzero: usize,
    ) -> bool {
        self.done += 1;
        self.families
            .entry(family.to_string())
            .or_default()
            .generated += 1;
        self.progress();
        let reduces = self.decide(family, eta, free, nonzero);
        self.progress();
        reduces
    }

    /// The body of [`Self::try_candidate`]: screen, then decide exactly.
    fn decide(
        &mut self,
        family: &str,
        rows: Vec<Expr>,
        free: Vec<(String, Vec<String>)>,
        nonzero: usize,
    ) -> bool {
        let stats = &mut self.families[family];
        let eta: Vec<String> = rows.iter().map(Expr::to_string).collect();
        if !self.seen.insert(eta.join("; ")) {
            stats.duplicates += 1;
            return false;
        }
        // An exact check cannot be interrupted: choices written with very large expressions
        // are not decided (their derivation can take minutes), so that the budget holds.
        let limit = if free.is_empty() {
            MAX_TEXT
        } else {
            3 * MAX_TEXT
        };
        if eta.iter().map(String::len).sum::<usize>() > limit {
            stats.too_large += 1;
            return false;
        }
        let name = format!("{family}_{}", stats.generated);
        let m2 = with_choice(self.model, &name, &rows, &free);
        if free.is_empty() {
            match screen(&m2, &name, self.p, &self.samples) {
                Screen::Singular => {
                    self.families[family].singular += 1;
                    return false;
                }
                Screen::Depends => {
                    self.families[family].screened_out += 1;
                    *self
                        .failures
                        .entry("η̇ changes with an eliminated coordinate (numeric screen)".into())
                        .or_default() += 1;
                    return false;
                }
                Screen::Pass => {}
            }
        }
        self.families[family].exact_checks += 1;
        (self.events)(SearchEvent::Checking {
            family: family.to_string(),
            eta: eta.clone(),
        });
        let t0 = Instant::now();
        log::debug!("search: exact check of {family}: {}", eta.join(" ; "));
        let derived = match hamel_derive::derive_form(&m2, &name, FormRequest::AutoExact) {
            Ok(d) => d,
            Err(e) => {
                *self.failures.entry(e.to_string()).or_default() += 1;
                return false;
            }
        };
        let r = match crate::analyse(&m2, &derived, self.p, None) {
            Ok(r) => r,
            Err(e) => {
                *self.failures.entry(e.to_string()).or_default() += 1;
                return false;
            }
        };
        if !r.ground_truth.undecided.is_empty() {
            let key = format!(
                "the structured form cannot decide whether the equations contain {}",
                r.ground_truth.undecided.join(", ")
            );
            *self.failures.entry(key).or_default() += 1;
            return false;
        }
        self.last = match derived {
            Derived::Closed(s) => Some(*s),
            Derived::Structured(_) => None,
        };
        log::debug!(
            "search: {:.3} s for {}",
            t0.elapsed().as_secs_f64(),
            eta.join(" ; ")
        );
        if !r.ground_truth.present.is_empty() {
            let w = &r.ground_truth.occurrences[0];
            let key = format!(
                "the true equations contain `{}` ({} is the first entry that does)",
                w.coordinate.clone().unwrap_or_default(),
                w.object
            );
            *self.failures.entry(key).or_default() += 1;
            return false;
        }
        let Some(reduced) = r.reduced_system else {
            *self
                .failures
                .entry(
                    "the kinematic equations still needed contain an eliminated coordinate".into(),
                )
                .or_default() += 1;
            return false;
        };
        self.families[family].found += 1;
        let cname = format!("{}_{}", family, self.families[family].found);
        let candidate = Candidate {
            toml: toml_block(&cname, family, &eta),
            name: cname,
            family: family.to_string(),
            eliminated: r.eliminate.clone(),
            free_functions: free
                .iter()
                .map(|(n, a)| format!("{n}({})", a.join(", ")))
                .collect(),
            reduced_state: reduced.state,
            paper_is_exact: r.paper_is_exact == Some(true),
            nonzero,
            eta,
        };
        (self.events)(SearchEvent::Found(candidate.clone()));
        self.found.push(candidate);
        true
    }
    /// Family (a): try the choice with its unknown functions symbolic; when the true equations
    /// still contain an eliminated coordinate, derive the conditions on the functions
    /// ([`dependence_conditions`]: every coefficient of the q_k-dependence must vanish) and
    /// solve them where the solution is a closed form: a factor of a condition that is of
    /// degree one in the value of a function (and free of derivatives) gives that function;
    /// substitute and repeat, at most `depth` times. Conditions that no function can be solved
    /// from are reported. True when a reducing member (possibly with functions left free) is
    /// found.
    fn solve_functions(
        &mut self,
        eta: Vec<Expr>,
        free: Vec<(String, Vec<String>)>,
        depth: usize,
    ) -> bool {
        let mentions = |e: &Expr, name: &str| {
            e.any(&mut |x| matches!(x, Expr::Free { name: n, .. } if n == name))
        };
        let nonzero = free.len()
            + eta
                .iter()
                .filter(|e| !free.iter().any(|(n, _)| mentions(e, n)))
                .count();
        self.last = None;
        if self.try_candidate("functions", eta.clone(), free.clone(), nonzero) {
            return true;
        }
        let Some(s) = self.last.take() else {
            return false;
        };
        if depth == 0 || free.is_empty() || self.out_of_time() {
            return false;
        }
        let mut conditions = dependence_conditions(&s, self.p);
        conditions.sort_by_cached_key(|(_, c)| c.size());
        // Every condition must hold: branching over the solutions of one condition (the
        // smallest that has any) covers that condition's closed-form solutions.
        let mut branches: Vec<(String, Ex)> = Vec::new();
        for (_, c) in &conditions {
            for factor in c.numerator_factors() {
                for (fname, _) in &free {
                    if let Some(sol) = factor.solve_for_free(fname)
                        && !branches
                            .iter()
                            .any(|(n, x)| n == fname && (x - &sol).is_zero())
                    {
                        branches.push((fname.clone(), sol));
                    }
                }
            }
            if !branches.is_empty() {
                break;
            }
        }
        if branches.is_empty() {
            if let Some((from, c)) = conditions.first() {
                let text = c.to_expr().to_string();
                if text.len() <= 300 {
                    self.unsolved.push(format!("{text} = 0 (from {from})"));
                }
                *self
                    .failures
                    .entry(format!(
                        "the conditions on the unknown functions have no closed-form solution \
                         hamel can find (the smallest: `{}` = 0, from {from})",
                        if text.len() <= 120 {
                            text
                        } else {
                            format!("<{} characters>", text.len())
                        }
                    ))
                    .or_default() += 1;
            }
            return false;
        }
        for (fname, sol) in branches.into_iter().take(4) {
            if self.out_of_time() {
                return false;
            }
            let by = sol.to_expr();
            let Ok(next) = eta
                .iter()
                .map(|e| e.substitute_free(&fname, &by).map(Expr::tidy))
                .collect::<Result<Vec<Expr>, _>>()
            else {
                continue;
            };
            let rest: Vec<(String, Vec<String>)> =
                free.iter().filter(|(n, _)| *n != fname).cloned().collect();
            self.total += 1;
            if self.solve_functions(next, rest, depth - 1) {
                return true;
            }
        }
        false
    }
}

/// Search (runs on the CAS thread): the families in turn, simplest first — (b) a finite
/// ansatz, (c) A-orthogonal choices, (a) unknown functions — each candidate checked exactly,
/// within the budget.
pub(crate) fn search(
    model: &Model,
    p: &[usize],
    options: SearchOptions,
    events: Events,
) -> Result<SearchReport, crate::ReduceError> {
    let started = Instant::now();
    let ell = model.ell();
    let base = model.choice(None)?.name.clone();
    let s0 = match hamel_derive::derive_form(model, &base, FormRequest::AutoExact)? {
        Derived::Closed(s) => Some(*s),
        Derived::Structured(_) => None,
    };
    let kept: Vec<usize> = (0..ell).filter(|k| !p.contains(k)).collect();
    let mut se = Searcher {
        model,
        p,
        samples: hamel_model::sample_configurations(ell, 6, 2015),
        started,
        options,
        events,
        done: 0,
        total: 0,
        families: IndexMap::new(),
        found: Vec::new(),
        failures: IndexMap::new(),
        exhausted: false,
        seen: std::collections::HashSet::new(),
        last: None,
        unsolved: Vec::new(),
    };
    let a = match &s0 {
        Some(s) => s.a.clone(),
        None => structured_mass_matrix(model, &base)?,
    };
    let pool = ansatz_pool(model, &a, &kept);
    // The kept coordinates' velocities as unit rows when they fit, v rows from the pool. The
    // velocity of a coordinate a holonomic constraint determines is no quasi-velocity.
    let free_kept: Vec<usize> = kept
        .iter()
        .copied()
        .filter(|&k| {
            !model
                .holonomic
                .iter()
                .any(|h| h.dependent == model.coordinates[k])
        })
        .collect();
    let units: Vec<usize> = if free_kept.len() <= model.sigma() {
        free_kept
    } else {
        vec![]
    };
    let ansatz_rows = se.ansatz(&pool, &units);
    match &s0 {
        Some(s0) => {
            let bases = se.kernel_bases(s0);
            se.a_orthogonal(s0, &bases);
            se.unknown_functions(&pool, &ansatz_rows, &kept, &units);
        }
        None => {
            let why = "families (c) A-orthogonal and (a) unknown functions need Γ in closed form: not tried for a structured derivation";
            se.failures.insert(why.to_string(), 0);
        }
    }
    let own = if se.found.is_empty() {
        own_failures(model, p)
    } else {
        Vec::new()
    };
    Ok(se.report(own))
}

/// The rows of family (b): the velocities of the coordinates to eliminate, rotations by each
/// angle of pairs of them, and the momenta (rows of A) of at most four terms.
fn ansatz_pool(model: &Model, a: &Matrix, kept: &[usize]) -> Vec<Row> {
    let names = &model.coordinates;
    let ell = names.len();
    let mut pool: Vec<Row> = Vec::new();
    for j in 0..ell {
        if !kept.contains(&j) {
            pool.push(unit(names, j));
        }
    }
    let trig = angles(model);
    for (i, j) in (0..ell).flat_map(|i| (i + 1..ell).map(move |j| (i, j))) {
        if kept.contains(&i) || kept.contains(&j) {
            continue;
        }
        for &a in &trig {
            pool.extend(rotation(names, (i, j, a)));
        }
    }
    for j in 0..ell {
        let row = row_of(
            names,
            &(0..ell).map(|k| a[(j, k)].clone()).collect::<Vec<_>>(),
        );
        // Momenta with more than four terms are left out: their exact checks can take
        // minutes and cannot be interrupted (see MAX_TEXT).
        if row.nonzero > 1 && row.nonzero <= 4 {
            pool.push(row);
        }
    }
    pool
}

impl Searcher<'_> {
    /// Family (b), a finite ansatz: every choice of v rows of `pool` with the unit rows `units`,
    /// fewest nonzero entries first. The pool rows of the simplest reducing choices (v + 1 at
    /// most), the basis of family (a).
    fn ansatz(&mut self, pool: &[Row], units: &[usize]) -> Vec<usize> {
        let names = &self.model.coordinates;
        let v = self.model.sigma() - units.len();
        let mut combos: Vec<(usize, Vec<usize>)> = combinations(pool.len(), v)
            .into_iter()
            .map(|c| {
                (
                    c.iter().map(|&i| pool[i].nonzero).sum::<usize>() + units.len(),
                    c,
                )
            })
            .collect();
        combos.sort_by_key(|(n, c)| (*n, c.clone()));
        self.total += combos.len() as u64;
        let mut ansatz_rows: Vec<usize> = Vec::new();
        for (nonzero, c) in &combos {
            if self.out_of_time() || self.found.len() >= self.options.max_candidates {
                break;
            }
            // Rows that span the same velocities twice in the same way are skipped by δ ≡ 0.
            let mut eta: Vec<Expr> = c.iter().map(|&i| pool[i].expr.clone()).collect();
            eta.extend(units.iter().map(|&j| der(names, j)));
            if self.try_candidate("ansatz", eta, vec![], *nonzero) {
                // The basis of family (a): the rows of the simplest reducing choices, v + 1 at most.
                for &i in c {
                    if !ansatz_rows.contains(&i) && ansatz_rows.len() < v + 1 {
                        ansatz_rows.push(i);
                    }
                }
            }
        }

        ansatz_rows
    }

    /// Bases Γ' of ker α for family (c): the Γ of the model's own choices first (momenta along
    /// the directions it already uses), then the basis with the identity on each set S of σ
    /// velocities, each column cleared of its denominators.
    fn kernel_bases(&mut self, s0: &Symbolic) -> Vec<Matrix> {
        let model = self.model;
        let (ell, mu, sigma) = (model.ell(), model.mu(), model.sigma());
        let f = s0.field.clone();
        let mut bases: Vec<Matrix> = Vec::new();
        for c in &model.choices {
            if c.free_functions.is_empty()
                && !self.out_of_time()
                && let Ok(sc) = hamel_derive::symbolic(model, &c.name)
            {
                bases.push(sc.gamma.clone());
            }
        }
        let subsets = combinations(ell, sigma);
        for sset in &subsets {
            if self.out_of_time() {
                break;
            }
            let rest: Vec<usize> = (0..ell).filter(|j| !sset.contains(j)).collect();
            let gamma_p = if mu == 0 {
                Matrix::identity(&f, ell)
            } else {
                let a_rest = Matrix::from_fn(mu, mu, |i, j| s0.alpha[(i, rest[j])].clone());
                let a_s = Matrix::from_fn(mu, sigma, |i, j| s0.alpha[(i, sset[j])].clone());
                let Ok(Some((inv, _))) = a_rest.inverse() else {
                    continue;
                };
                let solved = inv.mul(&a_s);
                Matrix::from_fn(ell, sigma, |i, j| {
                    if let Some(r) = sset.iter().position(|&x| x == i) {
                        if r == j { f.one() } else { f.zero() }
                    } else {
                        let r = rest.iter().position(|&x| x == i).expect("partition");
                        -&solved[(r, j)]
                    }
                })
            };
            // Clear each basis vector of its denominators (the knife's (1, tan θ) becomes
            // (cos θ, sin θ)): any nonzero multiple spans the same direction of ker α.
            let gamma_p = Matrix::from_fn(ell, sigma, |i, j| {
                let mut factors: Vec<Ex> = Vec::new();
                for r in 0..ell {
                    for d in gamma_p[(r, j)].denominator_factors() {
                        if !factors.contains(&d) {
                            factors.push(d);
                        }
                    }
                }
                factors.iter().fold(gamma_p[(i, j)].clone(), |e, d| &e * d)
            });
            bases.push(gamma_p);
        }
        bases
    }

    /// Family (c), A-orthogonal: Z = Γ'ᵀA for each basis Γ' of ker α.
    fn a_orthogonal(&mut self, s0: &Symbolic, bases: &[Matrix]) {
        let names = &self.model.coordinates;
        let (ell, sigma) = (self.model.ell(), self.model.sigma());
        self.total += bases.len() as u64;
        for g in bases {
            if self.out_of_time() {
                break;
            }
            let z = g.transpose().mul(&s0.a);
            let rows: Vec<Row> = (0..sigma)
                .map(|i| {
                    row_of(
                        names,
                        &(0..ell).map(|j| z[(i, j)].clone()).collect::<Vec<_>>(),
                    )
                })
                .collect();
            let nonzero = rows.iter().map(|r| r.nonzero).sum();
            self.try_candidate(
                "a_orthogonal",
                rows.into_iter().map(|r| r.expr).collect(),
                vec![],
                nonzero,
            );
        }
    }

    /// Family (a): unknown functions of the kept coordinates multiplying a basis of rows — the
    /// rows of the simplest reducing ansatz choices, then the simplest row that did not reduce
    /// (so that the conditions have something to decide), at most FUNCTIONS unknowns in all.
    fn unknown_functions(
        &mut self,
        pool: &[Row],
        ansatz_rows: &[usize],
        kept: &[usize],
        units: &[usize],
    ) {
        let names = &self.model.coordinates;
        let v = self.model.sigma() - units.len();
        if !kept.is_empty() && !ansatz_rows.is_empty() && v > 0 && !self.out_of_time() {
            let mut basis = ansatz_rows.to_vec();
            for i in 0..pool.len() {
                if basis.len() * v >= FUNCTIONS || basis.len() > ansatz_rows.len() {
                    break;
                }
                if !basis.contains(&i) {
                    basis.push(i);
                }
            }
            let args: Vec<String> = kept.iter().map(|&k| names[k].clone()).collect();
            let mut free = Vec::new();
            let mut eta = Vec::new();
            for r in 0..v {
                let terms: Vec<Expr> = basis
                    .iter()
                    .enumerate()
                    .map(|(b, &i)| {
                        let name = format!("z{}{}", r + 1, b + 1);
                        free.push((name.clone(), args.clone()));
                        let f = Expr::Free {
                            name,
                            args: args.clone(),
                            orders: vec![0; args.len()],
                        };
                        Expr::Mul(vec![f, pool[i].expr.clone()])
                    })
                    .collect();
                eta.push(Expr::Add(terms));
            }
            eta.extend(units.iter().map(|&j| der(names, j)));
            self.total += 1;
            let depth = free.len();
            self.solve_functions(eta, free, depth);
        }
    }

    /// The report: the candidates simplest first, why the search stopped and, when nothing was
    /// found, the most common reasons and `own` (what the model's own choices fail on).
    fn report(self, own: Vec<String>) -> SearchReport {
        let (p, names) = (self.p, &self.model.coordinates);
        let candidates_full = self.found.len() >= self.options.max_candidates;
        let mut candidates = self.found;
        sort_candidates(&mut candidates);
        let none_found = candidates.is_empty().then(|| {
            let mut reasons: Vec<(String, usize)> = self.failures.into_iter().collect();
            reasons.sort_by_key(|r| std::cmp::Reverse(r.1));
            let list: Vec<String> = reasons
                .iter()
                .take(3)
                .map(|(r, n)| format!("{r} ({n} candidate{})", if *n == 1 { "" } else { "s" }))
                .collect();
            format!(
                "no choice in these families eliminates {}: {}",
                p.iter()
                    .map(|&k| names[k].as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                if list.is_empty() {
                    "no candidate could be tried".to_string()
                } else {
                    list.join("; ")
                }
            ) + own
                .iter()
                .map(|o| format!("; {o}"))
                .collect::<String>()
                .as_str()
        });
        SearchReport {
            model: self.model.name.clone(),
            eliminate: p.iter().map(|&k| names[k].clone()).collect(),
            candidates,
            families: self.families,
            none_found,
            unsolved_conditions: self.unsolved,
            stop: if self.exhausted {
                StopReason::Budget
            } else if candidates_full {
                StopReason::MaxCandidates
            } else {
                StopReason::Completed
            },
            seconds: self.started.elapsed().as_secs_f64(),
        }
    }
}

/// A of a model whose derivation is structured (its canonical form, for the momenta rows).
fn structured_mass_matrix(model: &Model, choice: &str) -> Result<Matrix, crate::ReduceError> {
    match hamel_derive::derive_form(model, choice, FormRequest::Structured)? {
        Derived::Structured(s) => Ok(s.a.clone()),
        Derived::Closed(s) => Ok(s.a.clone()),
    }
}

/// When nothing reduces: what each of the model's own choices fails on (exactly).
fn own_failures(model: &Model, p: &[usize]) -> Vec<String> {
    let mut own = Vec::new();
    for c in model.choices.iter().filter(|c| c.free_functions.is_empty()) {
        let Ok(derived) = hamel_derive::derive_form(model, &c.name, FormRequest::AutoExact) else {
            continue;
        };
        let Ok(r) = crate::analyse(model, &derived, p, None) else {
            continue;
        };
        if let Some(w) = r.ground_truth.occurrences.first() {
            let where_ = if w.object.starts_with('Q') {
                "A_Γ and Γᵀ∇U are free of it, but the coefficient".to_string()
            } else {
                "the entry".to_string()
            };
            own.push(format!(
                "under the model's choice `{}`, {where_} {}{:?} contains `{}`",
                c.name,
                w.object,
                w.index,
                w.coordinate.clone().unwrap_or_default()
            ));
        }
    }
    own
}

/// Simplest first: fewest free functions, then fewest nonzero entries (stable: in the order
/// found).
pub fn sort_candidates(candidates: &mut [Candidate]) {
    candidates.sort_by_key(|c| (c.free_functions.len(), c.nonzero));
}

impl SearchReport {
    /// The report as text, with ready-to-paste TOML blocks.
    pub fn to_text(&self) -> String {
        use std::fmt::Write;
        let mut o = String::new();
        let _ = writeln!(
            o,
            "Search for quasi-velocities of `{}` eliminating {} ({:.2} s; stopped: {})",
            self.model,
            self.eliminate.join(", "),
            self.seconds,
            self.stop.describe()
        );
        for (name, s) in &self.families {
            let _ = writeln!(
                o,
                "  {name:<13} {} generated, {} duplicates, {} singular, {} screened out, {} too large, {} decided exactly, {} reduce",
                s.generated,
                s.duplicates,
                s.singular,
                s.screened_out,
                s.too_large,
                s.exact_checks,
                s.found
            );
        }
        if let Some(why) = &self.none_found {
            let _ = writeln!(o, "\n{why}");
        }
        if !self.unsolved_conditions.is_empty() {
            let _ = writeln!(
                o,
                "\nconditions on the unknown functions of family (a) left unsolved:"
            );
            for c in &self.unsolved_conditions {
                let _ = writeln!(o, "  {c}");
            }
        }
        for c in &self.candidates {
            let _ = writeln!(
                o,
                "\n# {} ({}): reduced state ({}), {} nonzero entries{}{}",
                c.name,
                c.family,
                c.reduced_state.join(", "),
                c.nonzero,
                if c.free_functions.is_empty() {
                    String::new()
                } else {
                    format!(", free functions {}", c.free_functions.join(", "))
                },
                if c.paper_is_exact {
                    "; the paper's equations are exact for it"
                } else {
                    ""
                }
            );
            o.push_str(&c.toml);
        }
        o
    }
}
