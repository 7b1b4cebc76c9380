//! A study as a file, and what a run of one gives.
//!
//! [`Exported`] is everything a study needs after the symbolic pass: the model file's text, the
//! choice and the steady motion, the compiled ingredients (a tape) and the decisions of the
//! pass (which coordinates drop out, why, and the gravity parameter). `hamel linearize --export`
//! writes one; [`Study::import`] reads it back in a process that has no computer algebra (the
//! `hamel-sweep` worker: a job array's task). [`Study::run`] does what both commands do with a
//! study: a point, a sweep or a map, as an [`Outcome`].

use std::sync::Arc;

use hamel_eval::{Compiled, CompiledData};
use hamel_model::{Model, ModelError};
use serde::{Deserialize, Serialize};

use crate::{Linearisation, Map, Point, Range, SteadyCheck, Study, Sweep};

/// The format tag of an exported study.
const FORMAT: &str = "hamel-study/1";

/// A study after its symbolic pass, as plain data.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Exported {
    /// `hamel-study/1`.
    pub format: String,
    /// The model file's name, as given.
    pub model_file: String,
    /// The model file's text.
    pub model_source: String,
    /// The quasi-velocity choice.
    pub eta_name: String,
    /// The steady motion.
    pub steady: String,
    /// The quasi-velocities as written.
    pub eta: Vec<String>,
    /// The compiled ingredients.
    pub compiled: CompiledData,
    /// Coordinates in the state (indices).
    pub state_q: Vec<usize>,
    /// Kept coordinates completed from the holonomic constraints.
    pub dependent: Vec<usize>,
    /// Coordinates the equations are free of.
    pub dropped: Vec<usize>,
    /// Why they drop out.
    pub dropped_because: Vec<String>,
    /// The parameter that enters only through U, linearly.
    pub gravity: Option<String>,
    /// How the steady motion is known to be one (studies written before it was recorded:
    /// numerically).
    #[serde(default = "unrecorded")]
    pub steady_check: SteadyCheck,
}

fn unrecorded() -> SteadyCheck {
    SteadyCheck::Numeric {
        why: "the study file does not record an exact check".into(),
    }
}

/// Progress of the points of a sweep or map (a bar on a terminal).
pub trait Progress: Sync {
    /// `points` are about to be computed.
    fn start(&self, points: u64);
    /// One is done.
    fn tick(&self);
    /// All are done.
    fn finish(&self);
}

/// What a run gives: the linearisation at the point, a sweep, or a map.
#[derive(Clone, Debug)]
pub enum Outcome {
    /// No sweep: the linearisation at the point.
    Point(Box<Linearisation>),
    /// One sweep (with the linearisation at the base point, for its header).
    Sweep(Box<(Linearisation, Sweep)>),
    /// Two sweeps.
    Map(Map),
}

impl Outcome {
    /// As JSON (pretty, final newline), the shape for sweeps.
    pub fn json(&self) -> String {
        let text = match self {
            Outcome::Point(l) => serde_json::to_string_pretty(l),
            Outcome::Sweep(b) => serde_json::to_string_pretty(&b.1),
            Outcome::Map(m) => serde_json::to_string_pretty(m),
        };
        text.expect("serialisable") + "\n"
    }

    /// As text.
    pub fn text(&self, study: &Study) -> String {
        match self {
            Outcome::Point(l) => study.linearisation_text(l),
            Outcome::Sweep(b) => study.sweep_text(&b.0, &b.1),
            Outcome::Map(m) => study.map_text(m),
        }
    }
}

impl Study {
    /// The study as data, for a process without the computer algebra.
    pub fn export(&self) -> Exported {
        Exported {
            format: FORMAT.into(),
            model_file: self.model.file.clone(),
            model_source: self.model.source.as_str().to_string(),
            eta_name: self.eta_name.clone(),
            steady: self.steady.name.clone(),
            eta: self.eta.clone(),
            compiled: self.compiled.to_data(),
            state_q: self.state_q.clone(),
            dependent: self.dependent.clone(),
            dropped: self.dropped.clone(),
            dropped_because: self.dropped_because.clone(),
            gravity: self.gravity.clone(),
            steady_check: self.steady_check.clone(),
        }
    }

    /// A study from data ([`Study::export`]), checked: the model loads from its text, the
    /// choice and the steady motion exist, the compiled ingredients are well formed and fit
    /// the model, and every coordinate is in exactly one of state, dependent and dropped.
    /// `file` names the study file in errors.
    pub fn import(e: Exported, file: &str) -> Result<Study, ModelError> {
        let bad = |why: String| {
            ModelError::new(
                file,
                Arc::new(String::new()),
                None,
                None,
                format!("not a study hamel can run: {why}"),
            )
        };
        if e.format != FORMAT {
            return Err(bad(format!("its format is `{}`, not `{FORMAT}`", e.format)));
        }
        let model = Model::from_source(&e.model_file, &e.model_source)?;
        let steady = model.steady(&e.steady)?.clone();
        model.choice(Some(&e.eta_name))?;
        let compiled = Compiled::from_data(e.compiled).map_err(|x| bad(x.to_string()))?;
        let ell = model.coordinates.len();
        let dims = compiled.dims();
        if compiled.coordinates() != model.coordinates.as_slice() || dims.sigma != e.eta.len() {
            return Err(bad("its equations do not fit its model".into()));
        }
        let mut seen = vec![0; ell];
        for &k in e.state_q.iter().chain(&e.dependent).chain(&e.dropped) {
            match seen.get_mut(k) {
                Some(n) => *n += 1,
                None => return Err(bad(format!("coordinate {k} does not exist"))),
            }
        }
        if seen.iter().any(|&n| n != 1) {
            return Err(bad(
                "each coordinate must be kept, dependent or dropped, once".into(),
            ));
        }
        let names: Vec<&str> = compiled.parameter_names().collect();
        if !names
            .iter()
            .copied()
            .eq(model.parameters.keys().map(String::as_str))
        {
            return Err(bad("its equations' parameters are not its model's".into()));
        }
        let dependent = model
            .completion
            .dependent()
            .iter()
            .filter(|k| !e.dropped.contains(k));
        if !dependent.copied().eq(e.dependent.iter().copied()) {
            return Err(bad("its dependent coordinates are not its model's".into()));
        }
        if e.gravity
            .as_ref()
            .is_some_and(|g| !model.parameters.contains_key(g))
        {
            return Err(bad(
                "its gravity parameter is not a parameter of the model".into()
            ));
        }
        Ok(Study {
            model,
            steady,
            compiled,
            eta_name: e.eta_name,
            eta: e.eta,
            state_q: e.state_q,
            dependent: e.dependent,
            dropped: e.dropped,
            dropped_because: e.dropped_because,
            gravity: e.gravity,
            steady_check: e.steady_check,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        })
    }

    /// The linearisation at `base`, or a sweep over one range, or a map over two: what
    /// `hamel linearize` and `hamel-sweep` compute. Errors are located at the steady motion.
    pub fn run(
        &self,
        base: &Point,
        sweeps: &[Range],
        progress: &dyn Progress,
    ) -> Result<Outcome, ModelError> {
        let located = |e: crate::StudyError| self.locate(&e);
        let tick = || progress.tick();
        match sweeps {
            [] => {
                let persistent = self.persistent_zeros(base).map_err(located)?;
                let lin = self.linearise(base, persistent).map_err(located)?;
                Ok(Outcome::Point(Box::new(lin)))
            }
            [range] => {
                progress.start(range.count as u64);
                let sweep = self.sweep(base, range, &tick).map_err(located);
                progress.finish();
                let sweep = sweep?;
                // The sweep's header: the base point with the zeros the sweep found persistent.
                let lin = self
                    .linearise(base, sweep.persistent_zeros)
                    .map_err(located)?;
                Ok(Outcome::Sweep(Box::new((lin, sweep))))
            }
            [x, y] => {
                progress.start(x.count.saturating_mul(y.count) as u64);
                let map = self.map(base, x, y, &tick).map_err(located);
                progress.finish();
                Ok(Outcome::Map(map?))
            }
            _ => Err(self
                .model
                .error("at most two --sweep: one gives a sweep, two a stability map")),
        }
    }
}
