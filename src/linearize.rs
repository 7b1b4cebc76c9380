//! `hamel linearize`: the steady motion's linearisation at a point, a sweep over one parameter
//! (with the crossings), or a map over two, as text or JSON, optionally drawn, and the study
//! exported for the `hamel-sweep` worker (`hamel_study::Study::run` does the work).

use hamel_model::ModelError;
use hamel_study::{Bar, Outcome, Point, Study};

use crate::cli::{LinearizeArgs, ReportFormat};
use crate::output::Output;

pub fn run(args: &LinearizeArgs, out: Output) -> Result<(), ModelError> {
    let model = crate::load_for(&args.model, args.eta.as_deref())?;
    if args.sweep.len() > 2 {
        return Err(model.error("at most two --sweep: one gives a sweep, two a stability map"));
    }
    hamel_study::plot::check(args.plot.as_deref(), args.sweep.len())?;
    let export = args
        .export
        .as_ref()
        .map(|p| Output::new(Some(p.clone())))
        .transpose()?;
    let study = crate::progress::while_deriving("deriving", || {
        Study::prepare(&model, args.eta.as_deref(), &args.steady)
    })?;
    let study = match args.threads {
        Some(n) => study.with_threads(n),
        None => study,
    };
    if let Some(e) = export {
        e.write(&(serde_json::to_string(&study.export()).expect("serialisable") + "\n"))?;
    }
    let outcome = study.run(
        &Point(args.set.iter().cloned().collect()),
        &args.sweep,
        &Bar::default(),
    )?;
    match (&outcome, args.plot.as_deref()) {
        (Outcome::Sweep(b), Some(p)) => hamel_study::plot::sweep(&b.1, p)?,
        (Outcome::Map(m), Some(p)) => hamel_study::plot::map(m, p)?,
        _ => {}
    }
    out.write(&if matches!(args.format, ReportFormat::Json) {
        outcome.json()
    } else {
        outcome.text(&study)
    })
}
