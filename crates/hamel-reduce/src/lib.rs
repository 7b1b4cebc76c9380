//! Reduction: which coordinates drop out of the Boltzmann–Hamel equations (11), and why.
//!
//! **Job**: for a model, a quasi-velocity choice and a set of coordinates q₁..q_p to eliminate,
//! classify the coordinates (31), find the block structure (17)/(18) of Z, check Properties 2.1
//! and 2.2 and the hypotheses H0–H5 of Proposition 2.1 (Talamucci 2015, (35)), plus H6 for the
//! term the paper drops, each with a witness when it fails; then decide the ground truth (do the
//! true equations contain q₁..q_p?) and, when they do not, write out the reduced system:
//! the σ equations for η, the kinematic equations (34) still needed, and the reconstruction
//! equations.
//!
//! **Inputs**: a checked [`Model`], a choice name, coordinate names. **Outputs**: a
//! [`Reduction`] (plain serialisable data), or a located [`ModelError`].
//!
//! **Exactness**: every "is free of q_k" is decided on canonical forms
//! ([`hamel_cas::Ex::depends_on`]: syntactic absence, else an exact derivative test), never
//! by sampling. All symbolic work runs as one job on the CAS thread.
#![warn(missing_docs)]

mod analysis;
mod error;
pub use error::{ReduceError, WorkerFailure};
pub mod hypotheses;
mod invariance;
pub mod pass;
mod render;
mod report;
mod search;
pub mod steady;
mod structured;
pub mod supervised;

pub use report::{
    BlockStructure, Classification, CoordinateKind, GroundTruth, Hypothesis, KinematicEquation,
    Property, PropertyId, ReducedSystem, Reduction, Witness,
};

pub use search::{
    Candidate, Events, FamilyStats, SearchEvent, SearchOptions, SearchReport, StopReason,
    sort_candidates,
};

use hamel_derive::Derived;
use hamel_model::{Coord, Model};

/// Analyse the elimination of `eliminate` from the equations of `model` under the choice
/// `eta` (the model's first choice when `None`): [`pass::make`] here, the store untouched.
pub fn reduce(
    model: &Model,
    eta: Option<&str>,
    eliminate: &[String],
) -> Result<Reduction, ReduceError> {
    let p = coordinate_indices(model, eliminate)?;
    let job = pass::Job::new(model, eta, pass::Analysis::Eliminate(p))?;
    Ok(pass::make(&job)?
        .reduction
        .expect("an elimination is analysed"))
}

/// The analysis of a derivation in either form: the whole one ([`analysis`]) for the closed
/// form, what the ingredients decide ([`structured`]) for the structured form, which evaluates
/// its plain data `d` (made here when the caller has none).
fn analyse(
    model: &Model,
    derived: &Derived,
    p: &[usize],
    d: Option<&hamel_derive::Derivation>,
) -> Result<Reduction, ReduceError> {
    match derived {
        Derived::Closed(s) => analysis::analyse(model, s, p),
        Derived::Structured(s) => match d {
            Some(d) => structured::analyse(model, s, d, p),
            None => structured::analyse(model, s, &s.to_derivation(), p),
        },
    }
}

/// Search for quasi-velocity choices that eliminate `eliminate` from the true equations
/// (families (c) A-orthogonal, (b) finite ansatz, (a) unknown functions; see [`search`]).
/// `events` is called from the CAS thread as the search goes ([`SearchEvent`]). The budget is
/// kept between candidates; an exact check under way runs to its end (see `hamel search`, which
/// runs this in a worker process it can end, for a budget that is a wall).
pub fn search(
    model: &Model,
    eliminate: &[String],
    options: SearchOptions,
    events: Events,
) -> Result<SearchReport, ReduceError> {
    let p: Vec<usize> = (coordinate_indices(model, eliminate)?.iter())
        .map(|k| k.index())
        .collect();
    let model = model.clone();
    hamel_cas::run(move || search::search(&model, &p, options, events))
        .map_err(ReduceError::Engine)?
}

/// The indices of the named coordinates, or an error naming the unknown one.
pub fn coordinate_indices(model: &Model, names: &[String]) -> Result<Vec<Coord>, ReduceError> {
    if names.is_empty() {
        return Err(ReduceError::NothingToEliminate);
    }
    let mut p = Vec::new();
    for n in names {
        match model.coordinate(n) {
            Some(i) if !p.contains(&i) => p.push(i),
            Some(_) => {}
            None => return Err(ReduceError::NotACoordinate { name: n.clone() }),
        }
    }
    Ok(p)
}
