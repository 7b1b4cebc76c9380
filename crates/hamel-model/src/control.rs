//! Inputs driven by a scene: control laws put into the forces, and the parameters read at every
//! evaluation (the time of a law, inputs read from tables).
//!
//! **Job**: [`Model::controlled`] turns a model and a scene's [`Control`] into the closed-loop
//! model: each input a law drives is replaced, in the generalised forces F, by the law (its η
//! written back as the choice's rows Z(q)q̇, so that F becomes a function of q and q̇ like any
//! damper's, and the derivation's q̇ = Γη gives η back exactly); the law's gains become
//! parameters; `t` (if a law uses it) and the tabled inputs become [`Model::live`] parameters,
//! which every evaluation sets instead of folding them in once.
//!
//! **Invariant**: what the derivation, the oracle and the generated code see is a model like any
//! other (forces F(q, q̇) with parameters): the closed loop is checked by the same oracle, and
//! eliminated coordinates are decided on it, law included.

use hamel_expr::{Expr, OccurrenceKind};
use indexmap::IndexMap;

use crate::{Item, Model, QuasiVelocityChoice};

/// The name of the time in a law, a live parameter of the closed-loop model.
pub const TIME: &str = "t";

/// A control law of one input: u = law(t, q, η, q̇, parameters, gains).
#[derive(Clone, Debug)]
pub struct Law {
    /// The input it drives (one of [`Model::inputs`]).
    pub input: String,
    /// The law as written.
    pub text: String,
}

/// What a scene drives the model's inputs with.
#[derive(Clone, Debug, Default)]
pub struct Control {
    /// Named numbers the laws use (`[gains]`): parameters of the closed loop, which an
    /// ensemble may vary.
    pub gains: IndexMap<String, f64>,
    /// The laws, one per driven input.
    pub laws: Vec<Law>,
    /// The inputs read from tables of time at every evaluation.
    pub tabled: Vec<String>,
}

/// Why a scene's control does not fit its model: the scene's key, and the reason.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct ControlError {
    /// The scene key it is about, such as `inputs.T` or `gains.k`.
    pub key: String,
    /// The reason.
    pub message: String,
}

impl Control {
    /// Whether the control changes nothing (no law, no gain, no table).
    pub fn is_empty(&self) -> bool {
        self.gains.is_empty() && self.laws.is_empty() && self.tabled.is_empty()
    }

    /// The control as text, one line per law, gain and table, for keys of cached code.
    pub fn text(&self) -> String {
        let mut lines: Vec<String> = (self.gains.iter())
            .map(|(k, v)| format!("gain {k} = {v:?} ({:#018x})", v.to_bits()))
            .collect();
        lines.extend(
            self.laws
                .iter()
                .map(|l| format!("law {} = {}", l.input, l.text)),
        );
        lines.extend(self.tabled.iter().map(|u| format!("table {u}")));
        lines.join("\n")
    }
}

impl Model {
    /// The closed loop of this model under `control`, its laws' η those of `choice` (see the
    /// module doc). Errors name the scene's key: an unknown input or name, a gain that is
    /// already a name of the model, a driven input outside the forces.
    pub fn controlled(
        &self,
        control: &Control,
        choice: &QuasiVelocityChoice,
    ) -> Result<Model, ControlError> {
        let mut m = self.clone();
        if control.is_empty() {
            return Ok(m);
        }
        self.check_gains(control)?;
        for (k, &v) in &control.gains {
            m.parameters.insert(k.clone(), v);
        }
        let driven: Vec<&str> = control.laws.iter().map(|l| l.input.as_str()).collect();
        for u in driven
            .iter()
            .copied()
            .chain(control.tabled.iter().map(String::as_str))
        {
            self.check_driven(u)?;
        }
        let mut timed = false;
        for law in &control.laws {
            let expr = self.law_expr(law, control, &driven, choice)?;
            timed |= expr.any(&mut |e| matches!(e, Expr::Sym(s) if s == TIME));
            let mut put = |f: &Expr| {
                f.map(&mut |e| match e {
                    Expr::Sym(s) if s == law.input => expr.clone(),
                    other => other,
                })
            };
            for f in &mut m.forces {
                *f = f.replaced(put(&f.expr));
            }
            m.contact_forces = m.contact_forces.map_exprs(&mut put);
            m.notes.push(format!(
                "the input {} follows the scene's law `{}`",
                law.input, law.text
            ));
        }
        // A driven input is no longer a parameter: setting it (`--set`) would change nothing.
        m.inputs.retain(|u| !driven.contains(&u.as_str()));
        for u in &driven {
            m.parameters.shift_remove(*u);
        }
        if timed {
            m.parameters.insert(TIME.to_string(), 0.0);
            m.live.push(TIME.to_string());
        }
        m.live.extend(control.tabled.iter().cloned());
        m.control = control.text();
        Ok(m)
    }

    /// Each gain a new name: an identifier, not a coordinate, parameter, η or `t`.
    fn check_gains(&self, control: &Control) -> Result<(), ControlError> {
        for k in control.gains.keys() {
            let err = |message: String| ControlError {
                key: format!("gains.{k}"),
                message,
            };
            if !crate::loader::is_identifier(k)
                || crate::loader::is_reserved(k)
                || crate::loader::is_eta_name(k)
            {
                return Err(err(format!(
                    "`{k}` cannot name a gain (letters, digits, _; not t, pi, der, a function or eta1…)"
                )));
            }
            if self.coordinates.contains(k) || self.parameters.contains_key(k) {
                return Err(err(format!(
                    "`{k}` is already a coordinate or parameter of the model: give the gain another name"
                )));
            }
            if !control.gains[k].is_finite() {
                return Err(err(format!("the gain {k} is not finite")));
            }
        }
        Ok(())
    }

    /// A driven input `u` is one of the model's inputs, and enters the forces only.
    fn check_driven(&self, u: &str) -> Result<(), ControlError> {
        let err = |message: String| ControlError {
            key: format!("inputs.{u}"),
            message,
        };
        if !self.inputs.iter().any(|i| i == u) {
            let listed = if self.inputs.is_empty() {
                "the model has none".to_string()
            } else {
                format!("the model's are {}", self.inputs.join(", "))
            };
            return Err(err(format!(
                "`{u}` is not an input of the model ({listed}; a model's [inputs] lists them)"
            )));
        }
        let uses = |item: &Item| item.expr.any(&mut |e| matches!(e, Expr::Sym(s) if s == u));
        let mut elsewhere: Vec<&str> = Vec::new();
        if uses(&self.potential) {
            elsewhere.push("the potential U");
        }
        let kinetic = match &self.kinetic {
            crate::Kinetic::Energy(t) => uses(t),
            crate::Kinetic::MassMatrix(rows) => rows.iter().flatten().any(uses),
        };
        if kinetic {
            elsewhere.push("the kinetic energy");
        }
        if self.constraints.iter().any(|(_, c)| uses(c)) {
            elsewhere.push("the constraints");
        }
        if self.derived.values().any(uses) {
            elsewhere.push("a derived parameter");
        }
        if let Some(place) = elsewhere.first() {
            return Err(err(format!(
                "the input {u} appears in {place}: a law or a table can drive only an input that enters the forces (a torque, a push); give {u} a constant value instead"
            )));
        }
        Ok(())
    }

    /// The law of `law.input` parsed, its names checked, its η written as the choice's rows.
    fn law_expr(
        &self,
        law: &Law,
        control: &Control,
        driven: &[&str],
        choice: &QuasiVelocityChoice,
    ) -> Result<Expr, ControlError> {
        let err = |message: String| ControlError {
            key: format!("inputs.{}", law.input),
            message,
        };
        let parsed = hamel_expr::parse(&law.text)
            .map_err(|e| err(format!("cannot parse the law `{}`: {e}", law.text)))?;
        let sigma = choice.eta.len();
        let eta = |name: &str| -> Option<usize> {
            let i: usize = name.strip_prefix("eta")?.parse().ok()?;
            (1..=sigma).contains(&i).then_some(i - 1)
        };
        for o in &parsed.occurrences {
            let known = self.coordinates.contains(&o.name)
                || (self.parameters.contains_key(&o.name) && !driven.contains(&o.name.as_str()))
                || control.gains.contains_key(&o.name)
                || eta(&o.name).is_some()
                || o.name == TIME;
            match o.kind {
                OccurrenceKind::Symbol if known => {}
                OccurrenceKind::Velocity if self.coordinates.contains(&o.name) => {}
                _ if driven.contains(&o.name.as_str()) => {
                    return Err(err(format!(
                        "the law of {} uses {}, which a law drives too: write that law into this one",
                        law.input, o.name
                    )));
                }
                _ => {
                    return Err(err(format!(
                        "unknown name `{}` in the law `{}`: a law may use t, the coordinates ({}), der(q), {}, the parameters and the scene's [gains]",
                        o.name,
                        law.text,
                        self.coordinates.join(", "),
                        if sigma == 1 {
                            "eta1".to_string()
                        } else {
                            format!("eta1…eta{sigma}")
                        },
                    )));
                }
            }
        }
        Ok(parsed.expr.map(&mut |e| match e {
            Expr::Sym(s) => match eta(&s) {
                Some(i) => choice.eta[i].expr.clone(),
                None => Expr::Sym(s),
            },
            other => other,
        }))
    }
}
