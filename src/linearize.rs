//! `hamel linearize`: the steady motion's linearisation at a point, a sweep over one parameter
//! (with the crossings), or a map over two, as text or JSON, optionally drawn, and the study
//! exported for the `hamel-sweep` worker (`hamel_study::Study::run` does the work).

use hamel_model::ModelError;
use hamel_study::{Bar, Outcome, Point, Regulator, Study};

use crate::cli::{LinearizeArgs, ReportFormat};
use crate::output::Output;

pub fn run(args: &LinearizeArgs, no_store: bool, out: Output) -> Result<(), ModelError> {
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
        Study::prepare_with(&model, args.eta.as_deref(), &args.steady, no_store)
    })
    .map_err(|e| e.locate(&model))?;
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
    let json = matches!(args.format, ReportFormat::Json);
    if args.lqr {
        return out.write(&regulator(args, &study, &outcome, json)?);
    }
    out.write(&if json {
        outcome.json()
    } else {
        outcome.text(&study)
    })
}

/// The linearisation at the point with its LQR (`--lqr`), as text or JSON.
fn regulator(
    args: &LinearizeArgs,
    study: &Study,
    outcome: &Outcome,
    json: bool,
) -> Result<String, ModelError> {
    let model = study.model();
    let Outcome::Point(l) = outcome else {
        return Err(model.error("--lqr is computed at a point: give no --sweep"));
    };
    let r = Regulator::of(l, &args.lqr_input, &args.weight, &model.parameters)
        .map_err(|e| model.error(format!("--lqr: {e}")))?;
    let eta = args.eta.as_deref().unwrap_or(&model.choices[0].name);
    let block = r.scene_block(eta, &args.steady);
    Ok(if json {
        let mut v = serde_json::to_value(l.as_ref()).expect("serialisable");
        v["lqr"] = serde_json::to_value(&r).expect("serialisable");
        v["lqr"]["scene_block"] = serde_json::Value::String(block);
        serde_json::to_string_pretty(&v).expect("serialisable") + "\n"
    } else {
        format!("{}\n{}\n{block}", outcome.text(study), r.text())
    })
}
