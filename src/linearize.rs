//! `hamel linearize`: the steady motion's linearisation at a point, a sweep over one parameter
//! (with the crossings), or a map over two, as text or JSON, and optionally drawn.

use std::io::IsTerminal;
use std::path::Path;

use hamel_model::ModelError;
use hamel_study::{Point, Range, Study};
use indexmap::IndexMap;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

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
}

pub fn run(args: &Args, out: Output) -> Result<(), ModelError> {
    let model = crate::load_for(args.model, args.eta)?;
    if args.sweeps.len() > 2 {
        return Err(model.error("at most two --sweep: one gives a sweep, two a stability map"));
    }
    hamel_study::plot::check(args.plot, args.sweeps.len())?;
    let study = crate::progress::while_deriving("deriving", || {
        Study::prepare(&model, args.eta, args.steady)
    })?;
    let study = match args.threads {
        Some(n) => study.with_threads(n),
        None => study,
    };
    let base = Point(args.set.clone());
    let located = |e: hamel_study::StudyError| study.locate(&e);
    let persistent = study.persistent_zeros(&base).map_err(located)?;
    let lin = study.linearise(&base, persistent).map_err(located)?;
    let text = match args.sweeps {
        [] => {
            if args.json {
                crate::json(&lin)
            } else {
                study.linearisation_text(&lin)
            }
        }
        [range] => {
            let bar = bar(range.count as u64);
            let sweep = study.sweep(&base, range, &|| bar.inc(1)).map_err(located)?;
            bar.finish_and_clear();
            if let Some(p) = args.plot {
                hamel_study::plot::sweep(&sweep, p)?;
            }
            if args.json {
                crate::json(&sweep)
            } else {
                study.sweep_text(&lin, &sweep)
            }
        }
        [x, y] => {
            let bar = bar((x.count * y.count) as u64);
            let map = study.map(&base, x, y, &|| bar.inc(1)).map_err(located)?;
            bar.finish_and_clear();
            if let Some(p) = args.plot {
                hamel_study::plot::map(&map, p)?;
            }
            if args.json {
                crate::json(&map)
            } else {
                study.map_text(&map)
            }
        }
        _ => unreachable!("checked above"),
    };
    out.write(&text)
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
fn bar(len: u64) -> ProgressBar {
    let target = if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    };
    let bar = ProgressBar::with_draw_target(Some(len), target);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} points, {elapsed} ({eta} left)")
            .expect("valid template"),
    );
    bar
}
