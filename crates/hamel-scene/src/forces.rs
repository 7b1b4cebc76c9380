//! The constraint forces as a scene's outputs, and the friction and lift-off monitors
//! (issue 58).
//!
//! **Job**: read `force.NAME.COMPONENT` and `force.NAME` in `request` and the `[friction]`
//! table, check them against the model's wheels, blades and rows (without the computer
//! algebra: [`ForceOutput::check`], [`check_friction`]), resolve them against the components
//! the derivation reports ([`Forces::resolve`]), and watch a run's forces at its output times
//! ([`Forces::monitor`]): the friction ratio √(longitudinal² + lateral²)/normal each wheel
//! needs against its μ, and a normal force ≤ 0 (the wheel would lift).
//!
//! **Invariants**: the forces are computed at the output times only, by the scene's engine
//! (the compiled core's `constraint_forces`, or the interpreted evaluator's
//! `constraint_forces_checked`); a violation is bracketed between two output times, never
//! interpolated. A component the motion does not determine is never given a number.

use hamel_model::{ContactKind, Model};
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

/// A component of a contact's force, in its contact frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Along the rolling direction, in the ground plane (forwards).
    Longitudinal,
    /// In the ground plane, across the rolling direction (up × forwards).
    Lateral,
    /// Along up.
    Normal,
}

impl Axis {
    const ALL: [Axis; 3] = [Axis::Longitudinal, Axis::Lateral, Axis::Normal];

    /// Its name in outputs.
    pub fn name(self) -> &'static str {
        match self {
            Axis::Longitudinal => "longitudinal",
            Axis::Lateral => "lateral",
            Axis::Normal => "normal",
        }
    }

    fn parse(s: &str) -> Option<Axis> {
        Axis::ALL.into_iter().find(|a| a.name() == s)
    }
}

/// `force.NAME` or `force.NAME.COMPONENT` in `request`: NAME a wheel, a blade, a resultant
/// `A+B` of them, or a row of α.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceOutput {
    /// What follows `force.` up to the component.
    pub name: String,
    /// The component asked for; None: all the contact's (a row's multiplier has none).
    pub axis: Option<Axis>,
}

/// What NAME is in a model.
enum Named {
    /// Wheels and blades (several for a resultant): whether one of them is a blade.
    Contacts { blade: bool },
    /// A row of α.
    Row,
}

impl ForceOutput {
    /// The force output a request entry names, or None when it does not start with `force.`.
    pub fn parse(entry: &str) -> Option<ForceOutput> {
        let rest = entry.strip_prefix("force.")?;
        if let Some((name, c)) = rest.rsplit_once('.')
            && let Some(axis) = Axis::parse(c)
        {
            return Some(ForceOutput {
                name: name.to_string(),
                axis: Some(axis),
            });
        }
        Some(ForceOutput {
            name: rest.to_string(),
            axis: None,
        })
    }

    /// What `name` is in `model`, if anything.
    fn named(name: &str, model: &Model) -> Option<Named> {
        let contacts = &model.contact_forces.contacts;
        let kinds: Option<Vec<&ContactKind>> = (name.split('+'))
            .map(|n| contacts.iter().find(|c| c.name == n).map(|c| &c.kind))
            .collect();
        match kinds {
            Some(k) => Some(Named::Contacts {
                blade: k.iter().any(|k| matches!(k, ContactKind::Blade { .. })),
            }),
            None => (model.constraints.iter().any(|(n, _)| n == name)).then_some(Named::Row),
        }
    }

    /// Check against the model's contacts and rows; the error says why and what there is.
    pub fn check(&self, model: &Model) -> Result<(), String> {
        let text = self.text();
        match (Self::named(&self.name, model), self.axis) {
            (Some(Named::Contacts { blade: true }), Some(a)) if a != Axis::Lateral => Err(format!(
                "`{text}`: a blade pushes only across itself: its one component is `lateral`"
            )),
            (Some(Named::Contacts { .. }), _) | (Some(Named::Row), None) => Ok(()),
            (Some(Named::Row), Some(_)) => Err(format!(
                "`{text}`: `{}` is a constraint row, whose force is its multiplier, without components: request `force.{}`",
                self.name, self.name
            )),
            (None, _) => match self.name.rsplit_once('.') {
                Some((contact, c)) if Self::named(contact, model).is_some() => Err(format!(
                    "`{text}`: `{c}` is not a component of `{contact}`: a wheel's are longitudinal, lateral and normal, a blade's lateral"
                )),
                _ => Err(format!(
                    "`{text}`: `{}` is not a wheel, a blade or a constraint row of model `{}` ({})",
                    self.name,
                    model.name,
                    what_there_is(model)
                )),
            },
        }
    }

    /// As written in `request`.
    pub fn text(&self) -> String {
        match self.axis {
            Some(a) => format!("force.{}.{}", self.name, a.name()),
            None => format!("force.{}", self.name),
        }
    }

    /// The reported components it asks for (`NAME.COMPONENT`, or the row's name).
    fn wanted(&self, model: &Model) -> Vec<String> {
        match (self.axis, Self::named(&self.name, model)) {
            (Some(a), _) => vec![format!("{}.{}", self.name, a.name())],
            (None, Some(Named::Contacts { blade: false })) => (Axis::ALL.iter())
                .map(|a| format!("{}.{}", self.name, a.name()))
                .collect(),
            (None, Some(Named::Contacts { blade: true })) => vec![format!("{}.lateral", self.name)],
            (None, _) => vec![self.name.clone()],
        }
    }
}

/// The model's wheels, blades and rows, for an error.
fn what_there_is(model: &Model) -> String {
    let contacts = &model.contact_forces.contacts;
    let of = |blade: bool| -> Vec<&str> {
        (contacts.iter())
            .filter(|c| matches!(c.kind, ContactKind::Blade { .. }) == blade)
            .map(|c| c.name.as_str())
            .collect()
    };
    let rows: Vec<&str> = model.constraints.iter().map(|(n, _)| n.as_str()).collect();
    let list = |v: Vec<&str>| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    format!(
        "wheels: {}; blades: {}; rows: {}",
        list(of(false)),
        list(of(true)),
        list(rows)
    )
}

/// `[friction]`: the friction coefficient of the contacts, and what a violation does.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Friction {
    /// One μ for every wheel, or one per wheel by name.
    pub mu: Mu,
    /// What the first violation does (default: stop the run).
    #[serde(default)]
    pub on_violation: OnViolation,
}

/// μ: one for all, or by contact.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum Mu {
    /// The same for every wheel.
    All(f64),
    /// By wheel name.
    Each(IndexMap<String, f64>),
}

/// What the first slip or lift-off does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum OnViolation {
    /// End the run there, as an error (the outputs up to and with the violating one kept).
    #[default]
    Stop,
    /// Warn on stderr and go on.
    Warn,
}

/// Check `[friction]` against the model: μ > 0 and finite, the names wheels. Errors: (key,
/// reason).
pub fn check_friction(f: &Friction, model: &Model) -> Result<(), (String, String)> {
    let contacts = &model.contact_forces.contacts;
    let wheels = contacts
        .iter()
        .any(|c| matches!(c.kind, ContactKind::Wheel(_)));
    if !wheels && matches!(f.mu, Mu::All(_)) {
        return Err((
            "friction".into(),
            format!(
                "model `{}` has no wheel: the friction monitor compares the force a wheel's contact needs with μ times its normal force",
                model.name
            ),
        ));
    }
    let positive = |key: String, mu: f64| {
        if mu.is_finite() && mu > 0.0 {
            Ok(())
        } else {
            Err((
                key,
                format!("the friction coefficient must be a positive number, found {mu}"),
            ))
        }
    };
    match &f.mu {
        Mu::All(mu) => positive("friction.mu".into(), *mu),
        Mu::Each(each) => each.iter().try_for_each(|(name, &mu)| {
            let key = format!("friction.mu.{name}");
            match contacts.iter().find(|c| &c.name == name).map(|c| &c.kind) {
                Some(ContactKind::Wheel(_)) => positive(key, mu),
                Some(ContactKind::Blade { .. }) => Err((
                    key,
                    format!("`{name}` is a blade, whose normal force the model does not give (a blade's height is not a constraint): its friction cannot be monitored"),
                )),
                None => Err((key, format!("`{name}` is not a wheel of model `{}` ({})", model.name, what_there_is(model)))),
            }
        }),
    }
}

/// One output of the scene: `force.NAME.COMPONENT` and its place among the reported components.
#[derive(Clone, Debug)]
pub struct Column {
    /// `force.` and the reported name.
    pub name: String,
    /// Index into the reported components.
    pub index: usize,
}

/// One wheel watched for slip and lift-off.
#[derive(Clone, Debug)]
pub struct Watched {
    /// The wheel.
    pub wheel: String,
    /// Its friction coefficient.
    pub mu: f64,
    /// Its longitudinal, lateral and normal components among the reported ones.
    pub at: [usize; 3],
}

/// The forces a scene computes: the requested columns and the watched wheels.
#[derive(Clone, Debug, Default)]
pub struct Forces {
    /// The requested outputs.
    pub columns: Vec<Column>,
    /// The wheels the friction monitor watches.
    pub watched: Vec<Watched>,
    /// What a violation does.
    pub on_violation: OnViolation,
}

impl Forces {
    /// Whether anything is computed.
    pub fn is_empty(&self) -> bool {
        self.columns.is_empty() && self.watched.is_empty()
    }

    /// Resolve the requested outputs and `[friction]` against the components the derivation
    /// reports (`reported`, `undetermined`). Errors: (key, reason).
    pub fn resolve(
        outputs: &[ForceOutput],
        friction: Option<&Friction>,
        model: &Model,
        reported: &[String],
        undetermined: &[String],
    ) -> Result<Forces, (String, String)> {
        let mut columns = Vec::new();
        for o in outputs {
            let mut found = 0;
            for w in o.wanted(model) {
                match reported.iter().position(|r| *r == w) {
                    Some(index) => {
                        found += 1;
                        columns.push(Column {
                            name: format!("force.{w}"),
                            index,
                        })
                    }
                    None if o.axis.is_none() && undetermined.contains(&w) => log::warn!(
                        "request: `{}`: `{w}` is not determined by the motion (reported: {})",
                        o.text(),
                        reported.join(", ")
                    ),
                    None => {
                        return Err((
                            "request".into(),
                            not_reported(o, &w, reported, undetermined),
                        ));
                    }
                }
            }
            if found == 0 {
                return Err((
                    "request".into(),
                    not_reported(o, &o.name, reported, undetermined),
                ));
            }
        }
        let (watched, on_violation) = match friction {
            Some(f) => (watch(f, model, reported)?, f.on_violation),
            None => (Vec::new(), OnViolation::Stop),
        };
        Ok(Forces {
            columns,
            watched,
            on_violation,
        })
    }
}

/// Why `wanted` of output `o` has no value.
fn not_reported(
    o: &ForceOutput,
    wanted: &str,
    reported: &[String],
    undetermined: &[String],
) -> String {
    let why = if undetermined.iter().any(|u| u == wanted) {
        "is not determined by the motion (dependent constraints share it, or more wheels stand on one frame than its three equations determine)"
    } else {
        "is not one of the components this model reports (a wheel's rows are reported as its longitudinal, lateral and normal forces)"
    };
    format!(
        "`{}`: `{wanted}` {why}; reported: {}",
        o.text(),
        reported.join(", ")
    )
}

/// The wheels `[friction]` watches: every wheel whose three components are reported (one μ
/// for all: the others named in a warning), or the named ones (each must be).
fn watch(
    f: &Friction,
    model: &Model,
    reported: &[String],
) -> Result<Vec<Watched>, (String, String)> {
    let find = |wheel: &str| -> Option<[usize; 3]> {
        let at = |a: Axis| {
            reported
                .iter()
                .position(|r| *r == format!("{wheel}.{}", a.name()))
        };
        Some([
            at(Axis::Longitudinal)?,
            at(Axis::Lateral)?,
            at(Axis::Normal)?,
        ])
    };
    let wheels = (model.contact_forces.contacts.iter())
        .filter(|c| matches!(c.kind, ContactKind::Wheel(_)))
        .map(|c| c.name.as_str());
    let mut watched = Vec::new();
    match &f.mu {
        Mu::All(mu) => {
            for wheel in wheels {
                match find(wheel) {
                    Some(at) => watched.push(Watched {
                        wheel: wheel.into(),
                        mu: *mu,
                        at,
                    }),
                    None => log::warn!(
                        "friction: wheel `{wheel}` is not watched: the motion does not determine its own longitudinal, lateral and normal forces (reported: {})",
                        reported.join(", ")
                    ),
                }
            }
        }
        Mu::Each(each) => {
            for (wheel, &mu) in each {
                let at = find(wheel).ok_or_else(|| {
                    (
                        format!("friction.mu.{wheel}"),
                        format!(
                            "the motion does not determine wheel `{wheel}`'s own longitudinal, lateral and normal forces, so its friction cannot be watched (reported: {})",
                            reported.join(", ")
                        ),
                    )
                })?;
                watched.push(Watched {
                    wheel: wheel.clone(),
                    mu,
                    at,
                });
            }
        }
    }
    if watched.is_empty() {
        return Err((
            "friction".into(),
            format!(
                "no wheel of model `{}` can be watched: the motion determines none's own forces (reported: {})",
                model.name,
                reported.join(", ")
            ),
        ));
    }
    Ok(watched)
}

/// What the monitor found for one wheel over a run (`--format json`: `contacts`).
#[derive(Clone, Debug, Serialize)]
pub struct ContactLoad {
    /// Its friction coefficient.
    pub mu: f64,
    /// The largest friction ratio √(longitudinal² + lateral²)/normal over the outputs where
    /// the normal force is positive, and when.
    pub largest_friction_ratio: Option<f64>,
    pub largest_friction_ratio_t: Option<f64>,
    /// The smallest normal force, and when.
    pub smallest_normal: Option<f64>,
    pub smallest_normal_t: Option<f64>,
}

/// The first violation of a run.
#[derive(Clone, Debug, Serialize)]
pub struct Violation {
    /// The wheel.
    pub wheel: String,
    /// Slip or lift-off.
    pub kind: ViolationKind,
    /// The output time at which it was found, and the one before (None at the first output).
    pub t: f64,
    pub t_before: Option<f64>,
    /// Its index among the output times.
    #[serde(skip)]
    pub output: usize,
    /// The friction ratio needed there (None where the normal force is ≤ 0), and μ.
    pub ratio: Option<f64>,
    pub mu: f64,
    /// Its longitudinal, lateral and normal forces there.
    pub forces: [f64; 3],
}

/// Slip or lift-off.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ViolationKind {
    /// The friction needed exceeds μ.
    Slip,
    /// The normal force is ≤ 0: the wheel would leave the ground.
    LiftOff,
}

/// What the monitor found over a run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Monitored {
    /// By wheel.
    pub contacts: IndexMap<String, ContactLoad>,
    /// The first violation, if any.
    pub violation: Option<Violation>,
}

impl Violation {
    /// One line: the wheel, what, when and with what forces.
    pub fn message(&self) -> String {
        let [long, lat, n] = self.forces;
        let when = match self.t_before {
            Some(b) => format!("between t = {b} and t = {} (output times)", self.t),
            None => format!("at t = {}", self.t),
        };
        let what = match (self.kind, self.ratio) {
            (ViolationKind::Slip, Some(r)) => format!(
                "would slip: it needs a friction coefficient of {r:.6} > μ = {}",
                self.mu
            ),
            _ => "would lift off the ground: its normal force is not positive".to_string(),
        };
        format!(
            "wheel `{}` {what} {when} (longitudinal {long:.6e} N, lateral {lat:.6e} N, normal {n:.6e} N)",
            self.wheel
        )
    }
}

impl Forces {
    /// Watch the forces at the output times `t` (`values[j]`: every reported component at
    /// output j, None where they could not be computed): each wheel's largest friction ratio
    /// and smallest normal force, and the first slip or lift-off.
    pub fn monitor(&self, t: &[f64], values: &[Option<Vec<f64>>]) -> Monitored {
        let mut m = Monitored::default();
        for w in &self.watched {
            let mut load = ContactLoad {
                mu: w.mu,
                largest_friction_ratio: None,
                largest_friction_ratio_t: None,
                smallest_normal: None,
                smallest_normal_t: None,
            };
            for (j, v) in values.iter().enumerate() {
                let Some(v) = v else { continue };
                let [long, lat, n] = w.at.map(|i| v[i]);
                let ratio = (n > 0.0).then(|| long.hypot(lat) / n);
                if load.smallest_normal.is_none_or(|s| n < s) {
                    (load.smallest_normal, load.smallest_normal_t) = (Some(n), Some(t[j]));
                }
                if let Some(r) = ratio
                    && load.largest_friction_ratio.is_none_or(|s| r > s)
                {
                    (load.largest_friction_ratio, load.largest_friction_ratio_t) =
                        (Some(r), Some(t[j]));
                }
                let kind = match ratio {
                    None => Some(ViolationKind::LiftOff),
                    Some(r) if r > w.mu => Some(ViolationKind::Slip),
                    Some(_) => None,
                };
                if let Some(kind) = kind
                    && m.violation.as_ref().is_none_or(|v| j < v.output)
                {
                    m.violation = Some(Violation {
                        wheel: w.wheel.clone(),
                        kind,
                        t: t[j],
                        t_before: j.checked_sub(1).map(|i| t[i]),
                        output: j,
                        ratio,
                        mu: w.mu,
                        forces: [long, lat, n],
                    });
                }
            }
            m.contacts.insert(w.wheel.clone(), load);
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_are_read_with_their_component() {
        let f = ForceOutput::parse("force.rear.normal").unwrap();
        assert_eq!((f.name.as_str(), f.axis), ("rear", Some(Axis::Normal)));
        let f = ForceOutput::parse("force.left+right.lateral").unwrap();
        assert_eq!(
            (f.name.as_str(), f.axis),
            ("left+right", Some(Axis::Lateral))
        );
        let f = ForceOutput::parse("force.front.vertical").unwrap();
        assert_eq!((f.name.as_str(), f.axis), ("front.vertical", None));
        assert!(ForceOutput::parse("roll").is_none());
    }

    #[test]
    fn the_first_violation_is_the_earliest_over_the_wheels() {
        let forces = Forces {
            columns: Vec::new(),
            watched: vec![
                Watched {
                    wheel: "a".into(),
                    mu: 0.5,
                    at: [0, 1, 2],
                },
                Watched {
                    wheel: "b".into(),
                    mu: 0.5,
                    at: [3, 4, 5],
                },
            ],
            on_violation: OnViolation::Stop,
        };
        let t = [0.0, 1.0, 2.0];
        let values = vec![
            Some(vec![1.0, 0.0, 10.0, 0.0, 0.0, 10.0]),
            Some(vec![1.0, 0.0, 10.0, 0.0, 0.0, -1.0]),
            Some(vec![8.0, 0.0, 10.0, 0.0, 0.0, 10.0]),
        ];
        let m = forces.monitor(&t, &values);
        let v = m.violation.unwrap();
        assert_eq!(
            (v.wheel.as_str(), v.kind, v.t, v.t_before),
            ("b", ViolationKind::LiftOff, 1.0, Some(0.0))
        );
        assert_eq!(m.contacts["a"].largest_friction_ratio, Some(0.8));
        assert_eq!(m.contacts["b"].smallest_normal, Some(-1.0));
    }
}
