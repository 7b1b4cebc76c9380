//! Which constraint forces are determined where α has dependent rows (issue 58).
//!
//! With a dependent row d = Σ_j c_j α_j (decided exactly, [`Dependence`]), λ + t n with
//! n = e_d − Σ_j c_j e_j satisfies the Lagrange form for every t (αᵀn = 0): only the
//! functionals φ·λ with φ·n = 0 for every such n are determined by the motion. Every value
//! hamel reports is such a functional: a wheel's longitudinal force is its rows' multipliers
//! times their scale and the rolling direction, a row's multiplier is the row's unit vector.
//! Here, on the computer-algebra thread, each φ·n is decided zero or not in normal form: for
//! each component of each contact, for the normal forces of each support (whose equations hold
//! Σ_i α_ip λ_i), for the other rows, and, where a component is not determined contact by
//! contact, for its sum over the contacts a dependence ties together (two wheels on one axle
//! share a lateral force: their sum is determined, the split is not).
//!
//! An expression the field cannot hold (a square root in a tilted wheel's scale) counts as not
//! shown to vanish: the value is then not reported, never reported unproven.

use hamel_bodies::{Contact, ContactForces, ContactKind, Normal};
use hamel_cas::{Ex, Field};
use hamel_expr::Expr;

use crate::dependence::Dependence;

/// A force component of a contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Component {
    /// Along the rolling direction.
    Longitudinal,
    /// Across it, in the ground plane (a wheel's or a blade's).
    Lateral,
    /// Along up.
    Normal,
}

impl Component {
    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Component::Longitudinal => "longitudinal",
            Component::Lateral => "lateral",
            Component::Normal => "normal",
        }
    }
}

/// A sum of one component over contacts, determined where its terms are not.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Resultant {
    /// The contacts, in the model's order.
    pub contacts: Vec<String>,
    /// The component.
    pub component: Component,
}

/// What the dependent rows leave undetermined, decided exactly (empty without them).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Uniqueness {
    /// The components not determined one by one: (contact, component).
    pub undetermined: Vec<(String, Component)>,
    /// Their sums that are determined.
    pub resultants: Vec<Resultant>,
    /// The rows outside the contacts whose multipliers are not determined.
    pub rows: Vec<String>,
    /// The supports (by number) whose normal forces are not determined.
    pub supports: Vec<usize>,
}

impl Uniqueness {
    /// Whether `component` of `contact` is determined.
    pub fn determined(&self, contact: &str, component: Component) -> bool {
        !(self.undetermined.iter()).any(|(c, k)| c == contact && *k == component)
    }
}

/// A functional of λ: coefficients by row name.
type Functional = Vec<(String, Expr)>;

/// The null vectors n of the dependences, by row: the kept rows `kept`, then the dependent ones.
struct Nulls<'a> {
    f: &'a Field,
    names: Vec<String>,
    vectors: Vec<Vec<Ex>>,
}

impl Nulls<'_> {
    fn entry(&self, k: usize, row: &str) -> Option<&Ex> {
        let i = self.names.iter().position(|n| n == row)?;
        Some(&self.vectors[k][i])
    }

    /// Whether φ·n = 0 for every dependence, in normal form (false where the field cannot hold
    /// a coefficient).
    fn annihilates(&self, phi: &Functional) -> bool {
        (0..self.vectors.len()).all(|k| {
            let mut sum = self.f.zero();
            for (row, c) in phi {
                let Some(n) = self.entry(k, row) else {
                    continue;
                };
                let Ok(c) = self.f.convert(c) else {
                    return false;
                };
                sum = &sum + &(&c * n);
            }
            sum.is_zero()
        })
    }

    /// The dependences (by number) whose null vector has a nonzero entry on one of `rows`.
    fn touching(&self, rows: &[&str]) -> Vec<usize> {
        (0..self.vectors.len())
            .filter(|&k| {
                rows.iter()
                    .any(|r| self.entry(k, r).is_some_and(|n| !n.is_zero()))
            })
            .collect()
    }
}

/// The uniqueness of every reported value of `forces` (rows of α: `kept`, then the dependent
/// rows of `dependence`, in order).
pub(crate) fn decide(
    f: &Field,
    forces: &ContactForces,
    kept: &[String],
    dependence: &[Dependence],
) -> Uniqueness {
    if dependence.is_empty() {
        return Uniqueness::default();
    }
    let mut names = kept.to_vec();
    names.extend(dependence.iter().map(|d| d.name.clone()));
    let vectors = (dependence.iter().enumerate())
        .map(|(k, d)| {
            let mut n: Vec<Ex> = d.coefficients.iter().map(|c| -c).collect();
            n.extend((0..dependence.len()).map(|j| if j == k { f.one() } else { f.zero() }));
            n
        })
        .collect();
    let nulls = Nulls { f, names, vectors };
    let supports: Vec<usize> = (0..forces.supports.len())
        .filter(|&s| !support_determined(&nulls, &forces.supports[s]))
        .collect();
    let mut out = Uniqueness {
        supports,
        ..Uniqueness::default()
    };
    for c in &forces.contacts {
        for (component, phi) in functionals(c) {
            let determined = match (&c.kind, component) {
                (ContactKind::Wheel(w), Component::Normal) => match &w.normal {
                    Normal::Support { support, .. } => !out.supports.contains(support),
                    Normal::Row(_) => nulls.annihilates(&phi),
                },
                _ => nulls.annihilates(&phi),
            };
            if !determined {
                out.undetermined.push((c.name.clone(), component));
            }
        }
    }
    out.resultants = resultants(&nulls, forces, &out.undetermined);
    let used: Vec<&str> = forces.contacts.iter().flat_map(Contact::rows).collect();
    out.rows = (nulls.names.iter())
        .filter(|r| !used.contains(&r.as_str()))
        .filter(|r| !nulls.annihilates(&vec![((*r).clone(), Expr::int(1))]))
        .cloned()
        .collect();
    out
}

/// Whether a support's equations hold no undetermined multiplier: Σ_i α_ip n_i = 0 for each of
/// its three virtual coordinates p.
fn support_determined(nulls: &Nulls, s: &hamel_bodies::Support) -> bool {
    (0..3).all(|p| {
        let phi: Functional = (s.rows.iter())
            .map(|(row, entries)| (row.clone(), entries[p].clone()))
            .collect();
        nulls.annihilates(&phi)
    })
}

/// Each reported component of `c` with its functional of λ (a support's normal force has
/// none: its determination is the support's).
pub(crate) fn functionals(c: &Contact) -> Vec<(Component, Functional)> {
    let scaled = |rows: &[String], scale: &Expr, direction: &[Expr]| -> Functional {
        (rows.iter().zip(direction))
            .map(|(r, d)| (r.clone(), hamel_expr::build::mul(scale.clone(), d.clone())))
            .collect()
    };
    match &c.kind {
        ContactKind::Wheel(w) => {
            let normal = match &w.normal {
                Normal::Row(r) => vec![(r.clone(), Expr::int(1))],
                Normal::Support { .. } => Vec::new(),
            };
            vec![
                (
                    Component::Longitudinal,
                    scaled(&w.rows, &w.scale, &w.rolling),
                ),
                (Component::Lateral, scaled(&w.rows, &w.scale, &w.lateral)),
                (Component::Normal, normal),
            ]
        }
        ContactKind::Blade { row, scale } => {
            vec![(Component::Lateral, vec![(row.clone(), scale.clone())])]
        }
    }
}

/// The sums of an undetermined component over the contacts each dependence ties together
/// (those whose rows its null vector touches), where the sum is determined.
fn resultants(
    nulls: &Nulls,
    forces: &ContactForces,
    undetermined: &[(String, Component)],
) -> Vec<Resultant> {
    let mut out: Vec<Resultant> = Vec::new();
    for k in 0..nulls.vectors.len() {
        for component in [
            Component::Longitudinal,
            Component::Lateral,
            Component::Normal,
        ] {
            let tied: Vec<&Contact> = (forces.contacts.iter())
                .filter(|c| undetermined.contains(&(c.name.clone(), component)))
                .filter(|c| nulls.touching(&c.rows()).contains(&k))
                .collect();
            let contacts: Vec<String> = tied.iter().map(|c| c.name.clone()).collect();
            if tied.len() < 2
                || out
                    .iter()
                    .any(|r| r.component == component && r.contacts == contacts)
            {
                continue;
            }
            let phi: Functional = (tied.iter())
                .flat_map(|c| functionals(c))
                .filter(|(k, _)| *k == component)
                .flat_map(|(_, phi)| phi)
                .collect();
            if !phi.is_empty() && nulls.annihilates(&phi) {
                out.push(Resultant {
                    contacts,
                    component,
                });
            }
        }
    }
    out
}
