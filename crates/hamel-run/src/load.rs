//! Read a scene, derive its equations, plan what to integrate and set up the initial state.

use std::cell::OnceCell;
use std::path::Path;
use std::sync::Arc;

use hamel_derive::Compiled;
use hamel_model::{Model, ModelError};
use hamel_sim::Solution;
use indexmap::IndexMap;

use crate::cache;
use crate::check::{Checked, Integration, SceneFile, check};
use crate::expressions::{OutputExpression, ParsedExpression};
use crate::file::{Accuracy, Scene};
use crate::forces::Forces;
use crate::initial::{Completed, Projection, initial_eta};
use crate::plan::{Plan, Request};

/// A scene read and checked, with its derivation, plan and initial state.
pub struct Loaded {
    pub(crate) scene: Scene,
    pub(crate) compiled: Compiled,
    pub(crate) model: Model,
    pub(crate) d: hamel_derive::Derivation,
    /// What the scene asks for.
    pub request: Request,
    /// What is integrated, reconstructed, dropped.
    pub plan: Plan,
    /// The integrator the scene names (or DOP853 at its `[accuracy]`).
    pub integrator: Integration,
    /// The accuracy target, when the scene gives one instead of an integrator.
    pub accuracy: Option<Accuracy>,
    pub(crate) params: IndexMap<String, f64>,
    /// What sets each live parameter of the closed loop at every evaluation (the time of a
    /// control law, tabled inputs), in the model's order ([`Model::live`]).
    pub(crate) live: Vec<hamel_sim::Live>,
    /// The scene's requested `[expressions]`, parameters substituted.
    pub(crate) expressions: Vec<OutputExpression>,
    /// The scene's `[expressions]` as parsed (for an ensemble whose members vary parameters).
    pub(crate) parsed: Vec<ParsedExpression>,
    /// The coordinates in the integrated state (integrated, then reconstructed).
    pub(crate) state: Vec<usize>,
    /// The initial configuration, every coordinate.
    pub(crate) q0: Vec<f64>,
    /// The initial state (those coordinates, then η) and the output times.
    pub y0: Vec<f64>,
    pub times: Vec<f64>,
    /// The value at which the dropped coordinates are held, and δ = det[Z; α] there at the start.
    pub(crate) reference: f64,
    pub(crate) delta0: f64,
    pub(crate) projection: Option<Projection>,
    /// The dependent coordinates completed from the holonomic constraints at the start.
    pub(crate) completed: Vec<Completed>,
    pub(crate) file: SceneFile,
    /// The constraint forces the scene computes (requested, or watched by `[friction]`).
    pub(crate) forces: Forces,
    /// The scene's compiled core, prepared on first use ([`Loaded::core`]).
    pub(crate) core: OnceCell<Result<cache::Entry, cache::CacheError>>,
}

/// Read a scene, derive its equations, plan what to integrate and set up the initial state;
/// every error names the scene (or model) file, the key and the reason.
pub fn load(scene_path: &Path) -> Result<Loaded, ModelError> {
    load_with(scene_path, &IndexMap::new())
}

/// [`load`] with parameter values set on top of the scene's `[parameters]` (`--set NAME=VALUE`):
/// derived parameters are evaluated again from them (`Model::parameter_values`).
pub fn load_with(
    scene_path: &Path,
    overrides: &IndexMap<String, f64>,
) -> Result<Loaded, ModelError> {
    load_with_options(scene_path, overrides, LoadOptions::default())
}

/// How a scene is loaded beyond what its file says.
#[derive(Clone, Copy, Debug, Default)]
pub struct LoadOptions {
    /// Derive anew (and store) whatever the derivation store holds (`--no-store`).
    pub fresh: bool,
    /// Keep every coordinate in the integrated state, requested or not, so that the run gives
    /// whole configurations ([`crate::simulate::Simulated::configurations`]; `--animate`).
    pub every_coordinate: bool,
}

/// [`load_with`] with [`LoadOptions`].
pub fn load_with_options(
    scene_path: &Path,
    overrides: &IndexMap<String, f64>,
    options: LoadOptions,
) -> Result<Loaded, ModelError> {
    let (name, text) = read(scene_path)?;
    let dir = scene_path.parent().unwrap_or(Path::new("."));
    let model_of = |m: &str| Model::load(dir.join(m));
    let checked = check(&name, &text, overrides, &model_of)?;
    let fresh = options.fresh;
    let Checked {
        scene,
        file,
        model,
        parsed,
        mut request,
        integrator,
        params,
        q0,
        completed,
        times,
    } = checked;
    if options.every_coordinate {
        keep_every_coordinate(&mut request, model.coordinates.len());
    }
    let err = |key: &str, m: String| file.error(Some(key), m);
    let tables = crate::inputs::tables(&scene, dir).map_err(|(k, m)| err(&k, m))?;
    let live = crate::inputs::live(&model, &tables);
    if matches!(integrator.method, hamel_sim::Method::Taylor) && !live.is_empty() {
        let why = "the Taylor method needs a right-hand side free of t, and this scene's inputs change with time (a law of t, or a table): use dop853 or vern9";
        return Err(err("integrator.method", why.into()));
    }
    let (model, choice) = choose(model, &scene, &parsed, &file, fresh)?;
    let Derived {
        model,
        mut plan,
        d,
        compiled,
        forces,
    } = derive(model, &choice, &scene, &request, &file, fresh)?;
    // the model's own forces are refused when the scene is checked; these are the scene's
    if matches!(integrator.method, hamel_sim::Method::Dla { .. }) && compiled.has_forces() {
        let why = crate::dla::DlaRefusal::Forces.to_string();
        return Err(err("integrator.method", why));
    }
    let expressions = request
        .expressions
        .iter()
        .map(|&i| parsed[i].specialised(&params, &state_names(&d)))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|(k, m)| err(&k, m))?;
    let (eta0, projection) = {
        let numeric = hamel_model::NumericModel::new(&model, &params)
            .map_err(|e| err("parameters", e.to_string()))?;
        initial_eta(&scene.initial, &d, &numeric, &q0).map_err(|(key, m)| err(key, m))?
    };
    plan.expressions = request
        .expressions
        .iter()
        .map(|&i| {
            (
                parsed[i].name.clone(),
                parsed[i].coordinate_names(&d.coordinates),
            )
        })
        .collect();
    plan.forces = forces.columns.iter().map(|c| c.name.clone()).collect();
    plan.friction = (forces.watched.iter())
        .map(|w| (w.wheel.clone(), w.mu))
        .collect();
    let state = plan.state();
    let (reference, delta0) =
        start(&compiled, &plan, &q0, &eta0, &params).map_err(|m| err("initial", m))?;
    let y0: Vec<f64> = state
        .iter()
        .map(|&k| q0[k])
        .chain(eta0.iter().copied())
        .collect();
    Ok(Loaded {
        forces,
        accuracy: match (&scene.integrator, &scene.accuracy) {
            (None, Some(a)) => Some(*a),
            _ => None,
        },
        compiled,
        scene,
        model,
        d,
        request,
        plan,
        integrator,
        params,
        live,
        expressions,
        parsed,
        state,
        q0,
        y0,
        times,
        reference,
        delta0,
        projection,
        completed,
        file,
        core: OnceCell::new(),
    })
}

/// Every coordinate not requested becomes needed: kept in the state, not written.
fn keep_every_coordinate(request: &mut Request, ell: usize) {
    for k in (0..ell).map(hamel_model::Coord::new) {
        if !request.coordinates.contains(&k) && !request.needed.contains(&k) {
            request.needed.push(k);
        }
    }
}

/// What the scene derives: its model (with the wheels' supports when it computes forces), plan,
/// derivation, evaluator and forces.
struct Derived {
    model: Model,
    plan: Plan,
    d: hamel_derive::Derivation,
    compiled: Compiled,
    forces: Forces,
}

/// Plan and derive the scene with the quasi-velocities `choice`; when it computes constraint
/// forces (requested, or watched by `[friction]`), with the supports of the wheels the frames
/// keep on the ground released and the forces' map compiled, and the forces resolved.
fn derive(
    model: Model,
    choice: &str,
    scene: &Scene,
    request: &Request,
    file: &SceneFile,
    fresh: bool,
) -> Result<Derived, ModelError> {
    let err = |key: &str, m: String| file.error(Some(key), m);
    let forces_key = if request.forces.is_empty() {
        "friction"
    } else {
        "request"
    };
    let model = if request.computes_forces() {
        model
            .with_supports()
            .map_err(|e| err(forces_key, e.message().to_string()))?
    } else {
        model
    };
    let crate::plan::Planned {
        plan,
        derivation: d,
    } = crate::plan::plan(&model, choice, request, fresh)?;
    let compiled = if request.computes_forces() {
        d.compile_with_constraint_forces()
    } else {
        d.compile()
    };
    let compiled = compiled.map_err(|e| err("eta", e.to_string()))?;
    let forces = Forces::resolve(
        &request.forces,
        scene.friction.as_ref(),
        &model,
        &compiled.constraint_force_names(),
        compiled.undetermined_constraint_forces(),
    )
    .map_err(|(k, m)| err(&k, m))?;
    Ok(Derived {
        model,
        plan,
        d,
        compiled,
        forces,
    })
}

/// The scene file's name and text.
fn read(scene_path: &Path) -> Result<(String, String), ModelError> {
    let name = scene_path.display().to_string();
    let text = std::fs::read_to_string(scene_path).map_err(|e| {
        ModelError::new(
            &name,
            Arc::new(String::new()),
            None,
            None,
            format!("cannot read the scene: {e}"),
        )
    })?;
    Ok((name, text))
}

/// The model and its quasi-velocity choice: the one the scene names (the default choice with
/// hamel's note), or for `eta = "auto"` the one the search finds ([`crate::auto`]).
fn choose(
    model: Model,
    scene: &Scene,
    parsed: &[ParsedExpression],
    file: &SceneFile,
    fresh: bool,
) -> Result<(Model, String), ModelError> {
    if scene.eta.as_deref() != Some("auto") {
        let chosen = model.choice(scene.eta.as_deref())?;
        if let Some(note) = model.default_choice_note(chosen) {
            log::info!("{note}");
        }
        let choice = chosen.name.clone();
        return Ok((model, choice));
    }
    if scene.initial.eta.is_some() {
        return Err(file.error(
            Some("initial.eta"),
            "with eta = \"auto\" the quasi-velocities are chosen by the search, so their initial values cannot be given: give the initial velocities as `q_dot = { ... }`".into(),
        ));
    }
    // The requested coordinates, and those the requested expressions need.
    let auto_request: Option<Vec<String>> = scene.request.as_ref().map(|names| {
        let mut v = names.clone();
        for e in parsed.iter().filter(|e| names.contains(&e.name)) {
            v.extend(model.coordinate_names(&e.coordinates));
        }
        v
    });
    crate::auto::auto_choice(model, auto_request.as_deref(), fresh)
}

/// The value at which the dropped coordinates are held, where the equations evaluate at the
/// initial state (they are free of them; [Z; α] may still be singular at some values), and
/// δ = det[Z; α] there. Error: why none of the values tried works.
pub(crate) fn start(
    compiled: &Compiled,
    plan: &Plan,
    q0: &[f64],
    eta0: &[f64],
    params: &IndexMap<String, f64>,
) -> Result<(f64, f64), String> {
    let references: &[f64] = if plan.dropped_ix.is_empty() {
        &[0.0]
    } else {
        &[0.5, 1.25, 2.0]
    };
    let mut last = String::new();
    for &reference in references {
        let mut q = q0.to_vec();
        for &k in &plan.dropped_ix {
            q[k.index()] = reference;
        }
        match compiled.evaluate(&q, eta0, params) {
            Ok(e) => return Ok((reference, e.delta)),
            Err(e) => last = e.to_string(),
        }
    }
    Err(last)
}

impl Loaded {
    /// The scene's core: its generated code in the cache, found there or written on the first
    /// call ([`cache::prepare`]); built by [`cache::binary`] when first run.
    pub fn core(&self) -> Result<&cache::Entry, cache::CacheError> {
        self.core
            .get_or_init(|| {
                let fixed = self.fixed();
                let trace = crate::traced::for_core(self.trace_start(&fixed));
                cache::prepare(&self.model, &self.d, &self.plan, &fixed, trace)
            })
            .as_ref()
            .map_err(Clone::clone)
    }

    /// What the right-hand side traced at the start needs for a core specialised for `fixed`
    /// ([`crate::traced`]).
    pub fn trace_start(&self, fixed: &IndexMap<String, f64>) -> crate::traced::Start<'_> {
        let mut kept = self.state.clone();
        kept.sort_unstable();
        crate::traced::Start {
            compiled: &self.compiled,
            d: &self.d,
            kept,
            params: &self.params,
            all_fixed: fixed.len() == self.params.len(),
            reference: self.reference,
            y0: self.to_core(&self.y0),
            work: self.request.energy && self.compiled.has_forces(),
        }
    }

    /// [`Loaded::trace_start`] for the scene's own core (every parameter but the live ones
    /// fixed).
    pub fn scene_trace_start(&self) -> crate::traced::Start<'_> {
        self.trace_start(&self.fixed())
    }

    /// A state in the plan's order (as [`Loaded::y0`]) in the core's: the kept coordinates by
    /// model index, then η.
    pub fn in_core_order(&self, y: &[f64]) -> Vec<f64> {
        self.to_core(y)
    }

    /// The parameters a compiled core is specialised for: all but the live ones.
    pub(crate) fn fixed(&self) -> IndexMap<String, f64> {
        (self.params.iter())
            .filter(|(k, _)| !self.model.live.contains(k))
            .map(|(k, v)| (k.clone(), *v))
            .collect()
    }

    /// The full configuration at state `y`: the state's coordinates, the dropped ones at the
    /// reference value.
    pub(crate) fn full_q(&self, y: &[f64]) -> Vec<f64> {
        let mut q = vec![self.reference; self.d.ell];
        for (i, &k) in self.state.iter().enumerate() {
            q[k] = y[i];
        }
        q
    }

    /// An error about this scene, at `key`.
    pub fn error(&self, key: &str, message: String) -> ModelError {
        self.file.error(Some(key), message)
    }

    /// A failure of the scene's compiled core (the cache, cargo, the core itself) as a
    /// [`ModelError`] ([`cache::CacheError::into_model_error`]): naming the scene, but not
    /// located at a key of it, since it is not the input's. `context` says what was being done
    /// (empty: preparing the core).
    pub fn core_error(&self, e: cache::CacheError, context: &str) -> ModelError {
        let doing = if context.is_empty() {
            "the compiled core"
        } else {
            context
        };
        e.into_model_error(&format!("{}: {doing}", self.file.name))
    }

    /// The requested `[expressions]` at the output states of `solution`, by name; a value
    /// that cannot be computed (outside the expression's domain, not finite) is None, and a
    /// warning on stderr names the expression and the first such time.
    pub fn expression_values(&self, solution: &Solution) -> IndexMap<String, Vec<Option<f64>>> {
        let values = self.evaluate_expressions(solution);
        for (name, v) in &values {
            if let Some(j) = v.iter().position(Option::is_none) {
                log::warn!(
                    "expressions.{name} cannot be evaluated at t = {} (outside its domain or not finite): written as null",
                    solution.t[j]
                );
            }
        }
        values
    }

    /// [`Self::expression_values`] without the warnings.
    pub fn evaluate_expressions(&self, solution: &Solution) -> IndexMap<String, Vec<Option<f64>>> {
        let n = self.state.len();
        self.expressions
            .iter()
            .map(|e| {
                let values: Vec<Option<f64>> = solution
                    .y
                    .iter()
                    .map(|y| {
                        let mut inputs = self.full_q(y);
                        inputs.extend_from_slice(&y[n..]);
                        e.tape
                            .eval::<f64>(&inputs)
                            .ok()
                            .map(|v| v[0])
                            .filter(|v| v.is_finite())
                    })
                    .collect();
                (e.name.clone(), values)
            })
            .collect()
    }

    /// The coordinates in the integrated state, by index: integrated, then reconstructed.
    pub fn state(&self) -> &[usize] {
        &self.state
    }

    /// The names of the state's components: its coordinates, then eta1….
    pub fn state_names(&self) -> Vec<String> {
        (self.state.iter())
            .map(|&k| self.d.coordinates[k].clone())
            .chain((1..=self.d.sigma).map(|i| format!("eta{i}")))
            .collect()
    }

    /// The model's name.
    pub fn model_name(&self) -> &str {
        &self.d.model
    }

    /// (ℓ, σ).
    pub fn dims(&self) -> (usize, usize) {
        (self.d.ell, self.d.sigma)
    }

    /// The scene's value of a parameter (the model's default unless overridden).
    pub fn parameter(&self, name: &str) -> f64 {
        self.params[name]
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// What the scene keeps of each ensemble member (`[ensemble] save`; the default without one).
    pub fn ensemble_save(&self) -> crate::file::Save {
        self.scene
            .ensemble
            .as_ref()
            .map(|e| e.save)
            .unwrap_or_default()
    }

    /// The value at which the dropped coordinates are held.
    pub fn reference_value(&self) -> f64 {
        self.reference
    }

    /// The quasi-velocity choice's name.
    pub fn eta_name(&self) -> &str {
        &self.d.eta_name
    }

    /// The indices, in the integrated state, of the requested outputs (coordinates, then η).
    pub fn requested_components(&self) -> Vec<usize> {
        let n = self.state.len();
        self.request
            .coordinates
            .iter()
            .map(|&k| {
                self.state
                    .iter()
                    .position(|&s| s == k.index())
                    .expect("requested ⊆ state")
            })
            .chain(if self.request.eta {
                n..n + self.d.sigma
            } else {
                n..n
            })
            .collect()
    }
}

/// The full state of a derivation as the scene language names it: its coordinates, then η.
pub(crate) fn state_names(
    d: &hamel_derive::Derivation,
) -> hamel_scene::expressions::StateNames<'_> {
    hamel_scene::expressions::StateNames {
        coordinates: &d.coordinates,
        sigma: d.sigma,
    }
}
