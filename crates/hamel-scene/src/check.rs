//! A scene read and checked against its model, without the computer algebra: everything
//! [`crate::load`] does before it derives (the syntax and keys, the model, the `[expressions]`,
//! the request, the integrator, the parameters, the initial configuration with the holonomic
//! constraints completed, the output times). Every error names the scene (or model) file, the
//! key and the reason.

use std::sync::Arc;

use hamel_model::{Model, ModelError};
use hamel_sim::{Method, MethodName, Options};
use indexmap::IndexMap;

use crate::expressions::{ParsedExpression, parse_expressions};
use crate::file::{Integrator, Outputs, Scene};
use crate::initial::{Completed, complete_initial};
use crate::request::Request;

/// A scene checked against its model.
pub struct Checked {
    /// The scene file as read.
    pub scene: Scene,
    /// Its name and text (for located errors).
    pub file: SceneFile,
    /// The model the scene names.
    pub model: Model,
    /// Its `[expressions]`, parsed and checked.
    pub parsed: Vec<ParsedExpression>,
    /// What the scene asks for.
    pub request: Request,
    /// The integrator and its options.
    pub integrator: Integration,
    /// The parameter values: the model's, then the scene's, then the overrides.
    pub params: IndexMap<String, f64>,
    /// The initial configuration, every coordinate.
    pub q0: Vec<f64>,
    /// The dependent coordinates completed from the holonomic constraints.
    pub completed: Vec<Completed>,
    /// The output times.
    pub times: Vec<f64>,
}

/// Check the scene `text` (of the file `name`) with parameter `overrides` (`--set`);
/// `model_of` loads the model file the scene names (a path relative to the scene).
pub fn check(
    name: &str,
    text: &str,
    overrides: &IndexMap<String, f64>,
    model_of: &dyn Fn(&str) -> Result<Model, ModelError>,
) -> Result<Checked, ModelError> {
    let (mut scene, file) = parse(name, text)?;
    scene
        .parameters
        .extend(overrides.iter().map(|(k, v)| (k.clone(), *v)));
    let err = |key: &str, m: String| file.error(Some(key), m);
    let model = model_of(&scene.model)?;
    let model = closed_loop(&mut scene, model, &file)?;
    let parsed = parse_expressions(&scene.expressions, &model).map_err(|(k, m)| err(&k, m))?;
    let request = request(&scene, &model, &parsed, &file)?;
    let integrator = integrator(&scene, &file)?;
    if matches!(integrator.method, Method::Dla { .. }) {
        conservative(&model).map_err(|why| err("integrator.method", why.into()))?;
    }
    model
        .parameter_values(overrides)
        .map_err(|e| file.error(None, format!("--set: {e}")))?;
    let params = model
        .parameter_values(&scene.parameters)
        .map_err(|e| err("parameters", e.to_string()))?;
    let (q0, completed) = initial_q(&scene, &model, &params, &file)?;
    let times = output_times(&scene, &file)?;
    if let Some(spec) = &scene.ensemble {
        crate::members::check_spec(spec, &model).map_err(|(k, m)| err(&k, m))?;
        if request.computes_forces() {
            return Err(err(
                "ensemble",
                "the constraint forces (`force.…` outputs, `[friction]`) are not computed for ensembles yet: run the member of interest as a scene of its own".into(),
            ));
        }
    }
    Ok(Checked {
        scene,
        file,
        model,
        parsed,
        request,
        integrator,
        params,
        q0,
        completed,
        times,
    })
}

/// The model with the loop closed by the scene's `[inputs]` and `[gains]`
/// ([`Model::controlled`]); constant inputs join `scene.parameters`.
fn closed_loop(scene: &mut Scene, model: Model, file: &SceneFile) -> Result<Model, ModelError> {
    let err = |(key, m): (String, String)| file.error(Some(&key), m);
    let driven = crate::inputs::driven(scene).map_err(err)?;
    for name in driven.constants.keys() {
        if !model.inputs.contains(name) {
            let inputs = model.inputs.join(", ");
            return Err(err((
                format!("inputs.{name}"),
                format!("`{name}` is not an input of the model (its inputs: {inputs})"),
            )));
        }
    }
    scene.parameters.extend(driven.constants);
    if driven.control.is_empty() {
        return Ok(model);
    }
    if scene.eta.as_deref() == Some("auto") {
        return Err(err((
            "eta".into(),
            "a scene with control laws or tables names its quasi-velocities (a law's eta1… are those of one choice): give `eta = \"NAME\"`".into(),
        )));
    }
    let choice = model.choice(scene.eta.as_deref())?;
    model
        .controlled(&driven.control, choice)
        .map_err(|e| err((e.key, e.message)))
}

/// The scene file's name and text, for located errors.
#[derive(Clone)]
pub struct SceneFile {
    pub name: String,
    source: Arc<String>,
}

impl SceneFile {
    /// An error at `key` of the scene file (or at the file when `None`).
    pub fn error(&self, key: Option<&str>, message: String) -> ModelError {
        ModelError::new(&self.name, self.source.clone(), None, key, message)
    }
}

/// Parse the scene file (its syntax and keys; nothing is checked against the model).
fn parse(name: &str, text: &str) -> Result<(Scene, SceneFile), ModelError> {
    let source = Arc::new(text.to_string());
    let scene: Scene = toml::from_str(&source).map_err(|e| {
        ModelError::new(
            name,
            source.clone(),
            e.span(),
            None,
            e.message().to_string(),
        )
    })?;
    let name = name.to_string();
    Ok((scene, SceneFile { name, source }))
}

/// What the scene requests (everything when it says nothing), with the coordinates the
/// requested expressions need.
fn request(
    scene: &Scene,
    model: &Model,
    parsed: &[ParsedExpression],
    file: &SceneFile,
) -> Result<Request, ModelError> {
    // The names `request` may use: the expressions' besides the model's outputs.
    let expression_names: Vec<String> = parsed.iter().map(|e| e.name.clone()).collect();
    let mut request = match &scene.request {
        Some(names) => Request::parse(names, &model.coordinates, model.sigma(), &expression_names)
            .map_err(|m| file.error(Some("request"), m))?,
        None => Request::default_outputs(model.coordinates.len(), parsed.len()),
    };
    for f in &request.forces {
        f.check(model).map_err(|m| file.error(Some("request"), m))?;
    }
    if let Some(friction) = &scene.friction {
        crate::forces::check_friction(friction, model).map_err(|(k, m)| file.error(Some(&k), m))?;
        request.friction = true;
    }
    for &i in &request.expressions {
        for &k in &parsed[i].coordinates {
            if !request.needed.contains(&k) {
                request.needed.push(k);
            }
        }
    }
    Ok(request)
}

/// An integrator and its options, checked.
#[derive(Clone, Copy, Debug)]
pub struct Integration {
    /// The method.
    pub method: Method,
    /// Its tolerances and limits.
    pub options: Options,
}

/// The integrator and its options: `[integrator]`, or DOP853 at the `[accuracy]` tolerances
/// (which `hamel simulate` may replace by a faster setting that meets them), or DOP853 at
/// rtol = 1e-10, atol = 1e-12.
fn integrator(scene: &Scene, file: &SceneFile) -> Result<Integration, ModelError> {
    let err = |key: &str, m: String| file.error(Some(key), m);
    let i = match (&scene.integrator, &scene.accuracy) {
        (Some(_), Some(_)) => {
            return Err(err(
                "accuracy",
                "give either [accuracy] (a target) or [integrator] (a method), not both".into(),
            ));
        }
        (Some(i), None) => i.clone(),
        (None, Some(a)) => {
            if !(a.rtol > 0.0 && a.atol > 0.0 && a.rtol < 1.0) {
                return Err(err(
                    "accuracy",
                    format!(
                        "rtol must be in (0, 1) and atol > 0 (got {}, {})",
                        a.rtol, a.atol
                    ),
                ));
            }
            Integrator {
                rtol: a.rtol,
                atol: a.atol,
                ..Integrator::default()
            }
        }
        (None, None) => Integrator::default(),
    };
    let method = match i.method {
        MethodName::Rk4 => Method::Rk4 {
            step: i
                .step
                .ok_or_else(|| err("integrator.step", "rk4 needs a step".into()))?,
        },
        MethodName::Dopri5 => Method::Dopri5,
        MethodName::Dop853 => Method::Dop853,
        MethodName::Vern9 => Method::Vern9,
        MethodName::Taylor => Method::Taylor,
        MethodName::Dla => Method::Dla {
            step: i
                .step
                .ok_or_else(|| err("integrator.step", "dla needs a step".into()))?,
            variant: i.variant.unwrap_or_default(),
        },
        MethodName::GaussLegendre => Method::GaussLegendre {
            stages: i.stages.unwrap_or(3),
            step: i.step,
        },
    };
    if let Method::Dla { step, .. } = method
        && !(step.is_finite() && step > 0.0)
    {
        return Err(err(
            "integrator.step",
            format!("the step must be positive and finite, not {step}"),
        ));
    }
    if i.variant.is_some() && i.method != MethodName::Dla {
        return Err(err(
            "integrator.variant",
            "a variant is the dla method's (where its discrete constraint is taken)".into(),
        ));
    }
    // Tolerances the adaptive methods cannot meet are refused before anything runs.
    let key = if scene.accuracy.is_some() {
        "accuracy.rtol"
    } else {
        "integrator.rtol"
    };
    // The Taylor method has no error estimate to resolve: ε itself is a tolerance it takes.
    let (floor, shown) = match method {
        Method::Taylor => (f64::EPSILON, "ε ≈ 2.2e-16"),
        _ => (10.0 * f64::EPSILON, "10·ε ≈ 2.2e-15"),
    };
    if !matches!(method, Method::Rk4 { .. } | Method::Dla { .. })
        && i.rtol < floor * (1.0 + f64::EPSILON)
    {
        return Err(err(
            key,
            format!(
                "rtol = {:e} is below what f64 arithmetic can deliver: it must exceed {shown}",
                i.rtol
            ),
        ));
    }
    let options = Options {
        rtol: i.rtol,
        atol: i.atol,
        max_steps: i.max_steps.unwrap_or(Options::default().max_steps),
        ..Options::default()
    };
    Ok(Integration { method, options })
}

/// Why the discrete Lagrange–d'Alembert method cannot run `model`, if it cannot: it integrates
/// conservative systems with linear velocity constraints only.
fn conservative(model: &Model) -> Result<(), &'static str> {
    if !model.holonomic.is_empty() {
        return Err(
            "the model has holonomic constraints, which the discrete Lagrange–d'Alembert method does not keep (use dop853, vern9 or taylor)",
        );
    }
    if model.has_forces() {
        return Err(
            "the model has forces beyond ∇U: the discrete Lagrange–d'Alembert method integrates conservative systems (use dop853, vern9 or taylor)",
        );
    }
    if !model.live.is_empty() {
        return Err(
            "the scene sets parameters at every step (inputs, control laws): the discrete Lagrange–d'Alembert method integrates conservative systems (use dop853, vern9 or taylor)",
        );
    }
    Ok(())
}

/// The initial configuration: every coordinate given, except the dependent coordinates of
/// holonomic constraints, which are completed from h(q) = 0 (Newton, from the value given or 0).
fn initial_q(
    scene: &Scene,
    model: &Model,
    params: &IndexMap<String, f64>,
    file: &SceneFile,
) -> Result<(Vec<f64>, Vec<Completed>), ModelError> {
    configuration(&scene.initial.q, model, params).map_err(|m| file.error(Some("initial.q"), m))
}

/// The configuration, every coordinate of the model in its order, from the values `given` by
/// name: the dependent coordinates of holonomic constraints may be missing, and are completed
/// from h(q) = 0 (Newton, from the value given or 0). Error: why it cannot be made.
pub fn configuration(
    given: &IndexMap<String, f64>,
    model: &Model,
    params: &IndexMap<String, f64>,
) -> Result<(Vec<f64>, Vec<Completed>), String> {
    if let Some(extra) = given.keys().find(|k| !model.coordinates.contains(k)) {
        return Err(format!("`{extra}` is not a coordinate of the model"));
    }
    let dependent = model.completion.dependent();
    let mut q = Vec::with_capacity(model.coordinates.len());
    for (k, c) in model.coordinates.iter().enumerate() {
        match given.get(c) {
            Some(&v) => q.push(v),
            None if dependent.contains(&k) => q.push(0.0),
            None => return Err(format!("missing coordinate `{c}`")),
        }
    }
    let known: Vec<bool> = model
        .coordinates
        .iter()
        .map(|c| given.contains_key(c))
        .collect();
    let completed = complete_initial(model, params, &mut q, &known)?;
    Ok((q, completed))
}

/// The output times: a count spread evenly over [t0, t_end], or the times given.
fn output_times(scene: &Scene, file: &SceneFile) -> Result<Vec<f64>, ModelError> {
    if !(scene.t_end.is_finite() && scene.t0.is_finite()) || scene.t_end == scene.t0 {
        return Err(file.error(
            Some("t_end"),
            "t_end must be finite and differ from t0".into(),
        ));
    }
    Ok(match &scene.outputs {
        Outputs::Count(n) if *n >= 2 => (0..*n)
            .map(|i| scene.t0 + (scene.t_end - scene.t0) * i as f64 / (*n - 1) as f64)
            .collect(),
        Outputs::Count(n) => {
            return Err(file.error(
                Some("outputs"),
                format!("needs at least 2 output times, got {n}"),
            ));
        }
        Outputs::Times(t) => t.clone(),
    })
}
