//! `hamel linearize`: the steady motion's linearisation at a point, a sweep over one parameter
//! (with the crossings), or a map over two, as text or JSON, optionally drawn, and the study
//! exported for the `hamel-sweep` worker (`hamel_study::Study::run` does the work).

use std::path::Path;

use hamel_model::ModelError;
use hamel_study::{Bar, Outcome, Point, Range, Study};
use indexmap::IndexMap;

use crate::output::Output;

/// What the command was asked.
pub struct Args<'a> {
    pub model: &'a Path,
    pub steady: &'a str,
    pub eta: Option<&'a str>,
    pub sweeps: &'a [Range],
    pub set: IndexMap<String, f64>,
    pub json: bool,
    pub plot: Option<&'a Path>,
    pub threads: Option<usize>,
    pub export: Option<&'a Path>,
}

pub fn run(args: &Args, out: Output) -> Result<(), ModelError> {
    let model = crate::load_for(args.model, args.eta)?;
    if args.sweeps.len() > 2 {
        return Err(model.error("at most two --sweep: one gives a sweep, two a stability map"));
    }
    hamel_study::plot::check(args.plot, args.sweeps.len())?;
    let export = args
        .export
        .map(|p| Output::new(Some(p.to_path_buf())))
        .transpose()?;
    let study = crate::progress::while_deriving("deriving", || {
        Study::prepare(&model, args.eta, args.steady)
    })?;
    let study = match args.threads {
        Some(n) => study.with_threads(n),
        None => study,
    };
    if let Some(e) = export {
        e.write(&(serde_json::to_string(&study.export()).expect("serialisable") + "\n"))?;
    }
    let outcome = study.run(&Point(args.set.clone()), args.sweeps, &Bar::default())?;
    match (&outcome, args.plot) {
        (Outcome::Sweep(b), Some(p)) => hamel_study::plot::sweep(&b.1, p)?,
        (Outcome::Map(m), Some(p)) => hamel_study::plot::map(m, p)?,
        _ => {}
    }
    out.write(&if args.json {
        outcome.json()
    } else {
        outcome.text(&study)
    })
}
