//! `hamel tradeoff SCENE`: the speed–accuracy trade of the numeric core, measured.
//!
//! Every integrator of `hamel-sim` is run on the scene's planned system over a range of
//! settings — the adaptive ones (DOP853, DOPRI5, Verner 9(8), Gauss–Legendre with step doubling) at
//! rtol = atol = 1e-3 … 1e-14 (Gauss–Legendre every other power to 1e-11), the Taylor method on
//! to 1e-15, the fixed-step ones (RK4, Gauss–Legendre) at 1, 2, 4 … 64 steps per output
//! interval — and compared with a reference solution: the Taylor method at rtol = atol = 3e-16,
//! checked against a run at 3e-15 (their difference is reported); for a scene whose parameters
//! change at every step (no series), DOP853 at 1e-14 checked at 5e-15. For each
//! setting: the error on the requested outputs (the requested coordinates, η, the energy) at
//! the end time and over the output times, as max |y − y_ref| / max(1, |y_ref|); how it
//! compares with the scene's target (max |y − y_ref| / (atol + rtol·|y_ref|) ≤ 1 meets it); wall
//! time (median of repeated runs up to ~50 ms); RHS evaluations; steps; energy and constraint
//! drift. The recommendation is the fastest setting that meets the target.
//!
//! **Inputs**: a loaded scene ([`crate::Loaded`]). **Outputs**: a [`Table`].

use crate::integrate::Timed;
use std::time::{Duration, Instant};

use hamel_model::ModelError;
use hamel_sim::{Method, MethodName, Options, Solution};
use serde::Serialize;

use crate::compare::{errors, outputs};
use crate::integrate::Engine;
use crate::load::Loaded;

/// One setting of one integrator, measured.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// `dop853`, `dopri5`, `vern9`, `gauss-legendre`, `rk4`.
    pub method: MethodName,
    /// The tolerance (rtol = atol) of an adaptive run.
    pub tol: Option<f64>,
    /// The step of a fixed-step run.
    pub step: Option<f64>,
    /// Whether the run reached the end.
    pub complete: bool,
    /// Error on the requested outputs at the end time.
    pub error_end: f64,
    /// The same, maximum over the output times.
    pub error_span: f64,
    /// max |y − y_ref| / (atol + rtol·|y_ref|) with the target's tolerances (≤ 1 meets it).
    pub target_ratio: f64,
    /// Wall time of one run, seconds.
    pub seconds: f64,
    /// Right-hand side evaluations.
    pub rhs_evals: usize,
    /// The Taylor method's series.
    pub series_evals: usize,
    /// Accepted steps.
    pub steps: usize,
    /// Relative energy drift (when the energy is computed).
    pub energy_drift: Option<f64>,
    /// Constraint drift of the reconstruction (when computed).
    pub constraint_drift: Option<f64>,
}

/// The work–precision table of a scene.
#[derive(Clone, Debug, Serialize)]
pub struct Table {
    /// Model and choice.
    pub model: String,
    /// The target (rtol, atol): the scene's `[accuracy]`, else its integrator's tolerances.
    pub target: (f64, f64),
    /// How the reference was computed.
    pub reference: String,
    /// What evaluated the right-hand side in the timed runs.
    pub engine: Engine,
    /// max difference between the reference and its check run (same measure as `error_span`):
    /// the reference's own error, bounded from above.
    pub reference_check: f64,
    /// The settings, measured.
    pub rows: Vec<Row>,
    /// Index in `rows` of the fastest setting that meets the target, if any does.
    pub recommended: Option<usize>,
}

/// Which settings to try.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Range {
    /// Every integrator (the table).
    All,
    /// The adaptive explicit ones only (what `hamel simulate` tries for an `[accuracy]`).
    Adaptive,
    /// DOP853, DOPRI5 and Verner 9(8) at four tolerances per decade, 1e-3 to 1e-13: a work–precision curve
    /// fine enough to compare another integrator with at equal error ([`export_python`]).
    WorkPrecision,
}

/// How long each setting of a table is timed. A run shorter than the time asked is repeated
/// and the median taken, so that a fast setting's time is not its clock's resolution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// The time to spend on one setting (the default 50 ms; zero: one run each).
    pub min_time: Duration,
}

impl Default for Timing {
    fn default() -> Timing {
        Timing {
            min_time: Duration::from_millis(50),
        }
    }
}

impl Timing {
    /// One run per setting: what the reference runs take, and a quick table.
    pub const ONE_RUN: Timing = Timing {
        min_time: Duration::ZERO,
    };

    /// The longest time one setting may be given (ten minutes).
    pub const MAX_SECONDS: f64 = 600.0;

    /// `seconds` per setting, from 0 to [`Timing::MAX_SECONDS`]; `None` outside (or NaN).
    pub fn from_secs(seconds: f64) -> Option<Timing> {
        (0.0..=Timing::MAX_SECONDS)
            .contains(&seconds)
            .then(|| Timing {
                min_time: Duration::from_secs_f64(seconds),
            })
    }
}

/// Run once, and time it. Interpreted: repeated while the total stays under the time asked
/// (at most 20 times), median of the runs. Compiled: one run on the scene's core, then, when it
/// took under a fifth of the time asked, a second call repeating it inside the core for about
/// that time (at least 3, at most 1000 times); the median time measured inside the core
/// (process start-up and JSON excluded).
fn timed(
    loaded: &Loaded,
    engine: Engine,
    (method, options): (Method, &Options),
    timing: Timing,
) -> Result<(Solution, bool, Duration), ModelError> {
    let min_time = timing.min_time.as_secs_f64();
    if engine == Engine::Compiled {
        let fail = |e: crate::cache::CacheError| loaded.core_error(e, "the compiled core failed");
        let Timed {
            run,
            seconds: first,
        } = (loaded.integrate_compiled(method, options, 1)).map_err(fail)?;
        if run.failure.is_some() || first >= min_time / 5.0 {
            return Ok((
                run.solution,
                run.failure.is_none(),
                Duration::from_secs_f64(first),
            ));
        }
        let repeat = ((min_time / first.max(1e-7)) as usize).clamp(3, 1000);
        let Timed {
            run,
            seconds: median,
        } = (loaded.integrate_compiled(method, options, repeat)).map_err(fail)?;
        return Ok((
            run.solution,
            run.failure.is_none(),
            Duration::from_secs_f64(median),
        ));
    }
    let mut times = Vec::new();
    let mut total = Duration::ZERO;
    loop {
        let start = Instant::now();
        let run = loaded.integrate(method, options)?;
        let took = start.elapsed();
        times.push(took);
        total += took;
        if run.failure.is_some() || total >= timing.min_time || times.len() >= 20 {
            times.sort();
            return Ok((run.solution, run.failure.is_none(), times[times.len() / 2]));
        }
    }
}

/// Measure the trade for a loaded scene, each setting timed as [`Timing::default`] says.
pub fn table(loaded: &Loaded, range: Range, engine: Engine) -> Result<Table, ModelError> {
    table_timed(loaded, range, engine, Timing::default())
}

/// [`table`], each setting timed as `timing` says.
pub fn table_timed(
    loaded: &Loaded,
    range: Range,
    engine: Engine,
    timing: Timing,
) -> Result<Table, ModelError> {
    Ok(measure(loaded, (range, timing), engine, true)?.0)
}

/// The adaptive settings of a range: the Runge–Kutta methods at rtol = atol = 1e-3 … 1e-14
/// (below, f64 cannot resolve their error estimates), the Taylor method on to 1e-15 (in the
/// range [`Range::Adaptive`] from 1e-10 on, where it can be the fastest); a work–precision curve
/// at four tolerances per decade.
fn adaptive_settings(range: Range) -> Vec<(Method, f64)> {
    let tolerances: Vec<f64> = if range == Range::WorkPrecision {
        (12..=60).map(|k| 10f64.powf(-f64::from(k) / 4.0)).collect()
    } else {
        (3..=15).map(|k| 10f64.powi(-k)).collect()
    };
    let mut settings = Vec::new();
    for &tol in &tolerances {
        if tol >= 0.99e-14 {
            for method in [Method::Dop853, Method::Dopri5, Method::Vern9] {
                settings.push((method, tol));
            }
        }
        if range != Range::Adaptive || tol <= 1.01e-10 {
            settings.push((Method::Taylor, tol));
        }
    }
    settings
}

/// The reference solution, a check of it, and how they were computed: the Taylor method at
/// rtol = atol = 3e-16 checked against it at 3e-15, where the system gives its series;
/// otherwise (parameters set at every step) DOP853 at 1e-14 checked at 5e-15.
fn reference_runs(
    loaded: &Loaded,
    engine: Engine,
    tight: &dyn Fn(f64) -> Options,
) -> Result<(Solution, Solution, &'static str), ModelError> {
    // The reference runs are not timed: one run each.
    let run = |method, tol| timed(loaded, engine, (method, &tight(tol)), Timing::ONE_RUN);
    let (reference, ok, _) = run(Method::Taylor, 3e-16)?;
    if ok {
        let (check, ok, _) = run(Method::Taylor, 3e-15)?;
        if ok {
            return Ok((reference, check, "the Taylor method at rtol = atol = 3e-16"));
        }
    }
    let (reference, ok, _) = run(Method::Dop853, 1e-14)?;
    let (check, ok_check, _) = run(Method::Dop853, 5e-15)?;
    if !(ok && ok_check) {
        return Err(loaded.error(
            "integrator",
            "the reference run (DOP853 at 1e-14) did not reach the end; the scene cannot be measured".into(),
        ));
    }
    Ok((reference, check, "DOP853 at rtol = atol = 1e-14"))
}

/// [`table`], with the energy among the compared outputs or not, and the reference's outputs.
fn measure(
    loaded: &Loaded,
    (range, timing): (Range, Timing),
    engine: Engine,
    energy: bool,
) -> Result<(Table, Vec<Vec<f64>>), ModelError> {
    let engine = loaded.usable(engine).engine;
    let options = loaded.integrator.options;
    let target = (loaded.accuracy).map_or((options.rtol, options.atol), |a| (a.rtol, a.atol));
    let tight = |tol: f64| Options {
        rtol: tol,
        atol: tol,
        max_steps: 10_000_000,
        ..Options::default()
    };
    let (reference, check, name) = reference_runs(loaded, engine, &tight)?;
    let reference_out = outputs(loaded, &reference, energy);
    let reference_check = errors(&outputs(loaded, &check, energy), &reference_out, target).span;
    // Fixed steps end on every output time, so they are taken as fractions of the smallest
    // output interval.
    let interval = loaded
        .times
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|&d| d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let mut settings: Vec<(Method, Option<f64>, Option<f64>)> = Vec::new();
    for (method, tol) in adaptive_settings(range) {
        settings.push((method, Some(tol), None));
    }
    if range == Range::All {
        for &tol in [1e-3, 1e-5, 1e-7, 1e-9, 1e-11].iter() {
            settings.push((
                Method::GaussLegendre {
                    stages: 3,
                    step: None,
                },
                Some(tol),
                None,
            ));
        }
        for k in [1, 2, 4, 8, 16, 32, 64] {
            let h = interval / k as f64;
            settings.push((Method::Rk4 { step: h }, None, Some(h)));
            settings.push((
                Method::GaussLegendre {
                    stages: 3,
                    step: Some(h),
                },
                None,
                Some(h),
            ));
        }
    }
    let mut rows = Vec::new();
    for (method, tol, step) in settings {
        let options = Options {
            rtol: tol.unwrap_or(1e-10),
            atol: tol.unwrap_or(1e-10),
            max_steps: 2_000_000,
            ..Options::default()
        };
        let (s, complete, took) = timed(loaded, engine, (method, &options), timing)?;
        let e = errors(&outputs(loaded, &s, energy), &reference_out, target);
        rows.push(Row {
            method: method.name(),
            tol,
            step,
            complete,
            error_end: e.end,
            error_span: e.span,
            target_ratio: e.ratio,
            seconds: took.as_secs_f64(),
            rhs_evals: s.stats.rhs_evals,
            series_evals: s.stats.series_evals,
            steps: s.stats.steps,
            energy_drift: s.stats.energy_drift,
            constraint_drift: s.stats.constraint_drift,
        });
    }
    let recommended = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.complete && r.target_ratio <= 1.0)
        .min_by(|a, b| a.1.seconds.total_cmp(&b.1.seconds))
        .map(|(i, _)| i);
    Ok((
        Table {
            model: format!("{} ({})", loaded.model_name(), loaded.eta_name()),
            target,
            reference: name.into(),
            engine,
            reference_check,
            rows,
            recommended,
        },
        reference_out,
    ))
}

/// The scene's planned system for a comparison with scipy (`bench/scipy_tradeoff.py`) and
/// numbalsoda (`bench/numbalsoda_tradeoff.py`): the right-hand side as Python, `rhs(t, y)`
/// returning a list and `rhs_into(t, y, dy)` writing `dy` (the code generator's solved form
/// with the scene's parameters and the dropped coordinates' reference value as numbers; for a
/// structured derivation, [`traced_tape`]), the initial time and state, the dropped coordinates
/// with their value (`held`), the output times,
/// the reference solution on the requested state components, and hamel's DOP853, DOPRI5 and
/// Vern9 runs
/// measured on the same components; `state` names the components of `y0`.
///
/// hamel's runs compute what the Python integrators compute, the state at the output times:
/// the energy and the constraint residual, which a scene requests by default, are switched
/// off for them (and restored after).
pub fn export_python(
    loaded: &mut Loaded,
    engine: Engine,
    timing: Timing,
) -> Result<serde_json::Value, ModelError> {
    refuse_live(loaded)?;
    let monitors = (loaded.request.energy, loaded.request.constraint_residual);
    (loaded.request.energy, loaded.request.constraint_residual) = (false, false);
    let measured = measure(loaded, (Range::WorkPrecision, timing), engine, false);
    (loaded.request.energy, loaded.request.constraint_residual) = monitors;
    let (table, reference) = measured?;
    let (tape, inputs) = planned_tape(loaded)?;
    let held: serde_json::Map<String, serde_json::Value> = (0..loaded.dims().0)
        .filter(|k| !loaded.state().contains(k))
        .map(|k| {
            (
                loaded.d.coordinates[k].clone(),
                loaded.reference_value().into(),
            )
        })
        .collect();
    let header = format!(
        "The planned right-hand side of a scene of model `{}` with quasi-velocities `{}`,\nwritten by hamel tradeoff --export-python.",
        loaded.model_name(),
        loaded.eta_name()
    );
    Ok(serde_json::json!({
        "model": table.model,
        "python": hamel_codegen::python::rhs_function(&tape, &inputs, &header),
        "python_into": hamel_codegen::python::rhs_into_function(&tape, &inputs, &header),
        "t0": loaded.scene.t0,
        "y0": loaded.y0,
        "state": loaded.state_names(),
        "held": held,
        "times": loaded.times,
        "requested": loaded.requested_components(),
        "reference": reference,
        "reference_check": table.reference_check,
        "target": table.target,
        "engine": table.engine,
        "build": match crate::cache::Build::current() {
            Ok(crate::cache::Build::Native { .. }) if table.engine == Engine::Compiled => "native",
            _ => "portable",
        },
        "hamel": table.rows.iter().map(|r| serde_json::json!({
            "method": r.method, "tol": r.tol, "seconds": r.seconds,
            "error_span": r.error_span, "rhs_evals": r.rhs_evals, "series_evals": r.series_evals,
            "complete": r.complete,
        })).collect::<Vec<_>>(),
    }))
}

/// The Python export writes a law of the time with the `t` of `rhs(t, y)`; an input read from
/// a table, or a law of the time in a structured derivation (whose tape folds the parameters
/// in), cannot be written: refused at `inputs`.
fn refuse_live(loaded: &Loaded) -> Result<(), ModelError> {
    let live = &loaded.d.live;
    let tabled: Vec<&String> = live.iter().filter(|n| *n != hamel_model::TIME).collect();
    if let Some(name) = tabled.first() {
        return Err(loaded.error(
            &format!("inputs.{name}"),
            format!("the Python export cannot read the table that drives {name}: give the input a law or a constant for the export"),
        ));
    }
    if !live.is_empty() && loaded.d.closed().is_none() {
        return Err(loaded.error(
            "inputs",
            "the Python export of a structured derivation folds the parameters in, so it cannot follow a law of the time t".into(),
        ));
    }
    Ok(())
}

/// The planned right-hand side as one tape and where its inputs come from: the code
/// generator's solved form for a closed-form derivation (parameters as inputs, given the
/// scene's numbers), else the structured evaluation traced at the scene's initial state.
fn planned_tape(
    loaded: &Loaded,
) -> Result<(hamel_expr::Tape, Vec<hamel_codegen::python::Input>), ModelError> {
    use hamel_codegen::python::Input;
    if loaded.d.closed().is_none() {
        let tape = traced_tape(loaded)?;
        let inputs = (0..tape.inputs().len()).map(Input::State).collect();
        return Ok((tape, inputs));
    }
    let parameter = |name: &str| match name {
        hamel_model::TIME => Input::Time,
        _ => Input::Number(loaded.parameter(name)),
    };
    solved_tape(
        &loaded.d,
        loaded.state(),
        loaded.reference_value(),
        parameter,
    )
    .map_err(|e| loaded.error("eta", format!("cannot generate the right-hand side: {e}")))
}

/// The closed form's rates of the coordinates `state` (each once, in order), then η̇, as one
/// tape, and where its inputs come from: the state's coordinates and η from the state vector
/// (y = (q_state, η)), the other coordinates held at `held`, each parameter from `parameter`.
fn solved_tape(
    d: &hamel_derive::Derivation,
    state: &[usize],
    held: f64,
    parameter: impl Fn(&str) -> hamel_codegen::python::Input,
) -> Result<(hamel_expr::Tape, Vec<hamel_codegen::python::Input>), hamel_codegen::CodegenError> {
    use hamel_codegen::python::Input;
    let (ell, sigma) = (d.ell, d.sigma);
    let generated = hamel_codegen::generate(d, &[], "export")?;
    let solved = &generated.solved;
    let exprs: Vec<&hamel_expr::Expr> = state
        .iter()
        .map(|&k| &solved.exprs[sigma + k])
        .chain(&solved.exprs[..sigma])
        .collect();
    let tape = hamel_expr::Tape::compile(&exprs, &solved.inputs)
        .map_err(|e| hamel_codegen::CodegenError::Internal(e.to_string()))?;
    // Inputs of the solved form: the ℓ coordinates, the parameters, then η.
    let inputs: Vec<Input> = (0..ell)
        .map(|k| match state.iter().position(|&s| s == k) {
            Some(i) => Input::State(i),
            None => Input::Number(held),
        })
        .chain(
            solved.inputs[ell..solved.inputs.len() - sigma]
                .iter()
                .map(|name| parameter(name)),
        )
        .chain((0..sigma).map(|s| Input::State(state.len() + s)))
        .collect();
    Ok((tape, inputs))
}

/// The full system's right-hand side (y = (q, η), every coordinate) of a closed-form
/// derivation as Python source, `rhs_into(t, y, dy)` (straight-line code over `math`, the
/// parameter values `values` written as numbers): what numba compiles into a copy of hamel's
/// equations. None for a structured derivation (no closed form to write).
pub fn python_rhs_into(
    d: &hamel_derive::Derivation,
    values: &indexmap::IndexMap<String, f64>,
) -> Result<Option<String>, hamel_codegen::CodegenError> {
    if d.closed().is_none() {
        return Ok(None);
    }
    let state: Vec<usize> = (0..d.ell).collect();
    let parameter = |name: &str| {
        hamel_codegen::python::Input::Number(values.get(name).copied().unwrap_or(f64::NAN))
    };
    let (tape, inputs) = solved_tape(d, &state, 0.0, parameter)?;
    if let Some(name) = d.parameters.keys().find(|n| !values.contains_key(*n)) {
        return Err(hamel_codegen::CodegenError::Internal(format!(
            "no value for the parameter `{name}`"
        )));
    }
    let header = format!(
        "The right-hand side of model `{}` with quasi-velocities `{}`: y = (q, eta), written by hamel's Python package.",
        d.model, d.eta_name
    );
    Ok(Some(hamel_codegen::python::rhs_into_function(
        &tape, &inputs, &header,
    )))
}

/// The structured right-hand side of the planned state (the rates of the state's coordinates,
/// then η̇), traced at the initial state into one straight-line tape whose inputs are the
/// state's components: the ingredients, the LU of [Z; α] with the pivots chosen there, and the
/// contractions of (11) ([`hamel_expr::trace`]). The scene's parameters and the dropped
/// coordinates' reference value are folded in as constants.
pub fn traced_tape(loaded: &Loaded) -> Result<hamel_expr::Tape, ModelError> {
    use hamel_expr::{Scalar, Traced};
    let n = loaded.state.len();
    let traced = hamel_expr::trace(&loaded.state_names(), &loaded.y0, |y| {
        let (qs, eta) = y.split_at(n);
        let mut q = vec![Traced::constant(loaded.reference); loaded.d.ell];
        for (i, &k) in loaded.state.iter().enumerate() {
            q[k] = qs[i];
        }
        let r = loaded.compiled.rhs::<Traced>(&q, eta, &loaded.params)?;
        Ok(loaded
            .state
            .iter()
            .map(|&k| r.q_dot[k])
            .chain(r.eta_dot.iter().copied())
            .collect())
    });
    traced.map_err(|e: hamel_expr::TraceError<hamel_derive::NumericError>| {
        loaded.error(
            "initial",
            format!("cannot trace the right-hand side at the initial state: {e}"),
        )
    })
}

impl Row {
    /// The setting, as a scene's `[integrator]` would give it.
    pub fn setting(&self) -> String {
        match (self.tol, self.step) {
            (Some(t), _) => format!("{} rtol = atol = {t:.0e}", self.method),
            (_, Some(h)) => format!("{} step = {h:.3e}", self.method),
            _ => self.method.to_string(),
        }
    }

    /// The method and options to run this setting.
    pub fn method(&self) -> (Method, Options) {
        let method = match self.method {
            MethodName::Dop853 => Method::Dop853,
            MethodName::Dopri5 => Method::Dopri5,
            MethodName::Vern9 => Method::Vern9,
            MethodName::Taylor => Method::Taylor,
            MethodName::Rk4 => Method::Rk4 {
                step: self.step.expect("a fixed-step row has its step"),
            },
            MethodName::Dla => Method::Dla {
                step: self.step.expect("a fixed-step row has its step"),
                variant: Default::default(),
            },
            MethodName::GaussLegendre => Method::GaussLegendre {
                stages: 3,
                step: self.step,
            },
        };
        let tol = self.tol.unwrap_or(1e-10);
        (
            method,
            Options {
                rtol: tol,
                atol: tol,
                max_steps: 2_000_000,
                ..Options::default()
            },
        )
    }
}

impl Table {
    /// A Markdown table, the reference and the recommendation.
    pub fn to_text(&self) -> String {
        let opt = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{v:.1e}"));
        let mut o = format!(
            "{}: target rtol = {:.0e}, atol = {:.0e}; reference: {} (its difference from the check run: {:.1e}); timed on the {}\n\n\
             | setting | error at end | error over span | / target | time | RHS evals (series) | steps | energy drift | constraint drift |\n\
             |---|---|---|---|---|---|---|---|---|\n",
            self.model,
            self.target.0,
            self.target.1,
            self.reference,
            self.reference_check,
            match (self.engine, crate::cache::Build::current()) {
                (Engine::Compiled, Ok(crate::cache::Build::Native { .. })) => {
                    "scene's compiled core, built for this CPU (HAMEL_NATIVE)"
                }
                (Engine::Compiled, _) => "scene's compiled core",
                (Engine::Interpreted, _) => "interpreted evaluator",
            }
        );
        for (i, r) in self.rows.iter().enumerate() {
            o += &format!(
                "| {}{} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.setting(),
                if Some(i) == self.recommended {
                    " **(recommended)**"
                } else {
                    ""
                },
                if r.complete {
                    format!("{:.1e}", r.error_end)
                } else {
                    "incomplete".into()
                },
                if r.complete {
                    format!("{:.1e}", r.error_span)
                } else {
                    "–".into()
                },
                if r.complete {
                    format!("{:.1e}", r.target_ratio)
                } else {
                    "–".into()
                },
                format_seconds(r.seconds),
                if r.series_evals > 0 {
                    format!("({})", r.series_evals)
                } else {
                    r.rhs_evals.to_string()
                },
                r.steps,
                opt(r.energy_drift),
                opt(r.constraint_drift),
            );
        }
        o += &match self.recommended {
            Some(i) => format!(
                "\nrecommended: {} (the fastest setting whose error stays within the target)\n",
                self.rows[i].setting()
            ),
            None => "\nno setting meets the target\n".to_string(),
        };
        o
    }
}

fn format_seconds(s: f64) -> String {
    if s < 1e-3 {
        format!("{:.0} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.2} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}
