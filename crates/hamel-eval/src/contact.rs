//! The forces of the constraints at a state, in physical components (issue 58).
//!
//! **Job**: from the multipliers λ, q̇ and q̈ of an evaluation ([`ConstraintForce`]), the force of
//! each wheel (`longitudinal`, `lateral`, `normal`) and blade (`lateral`), and the multiplier of
//! every other row of α (a holonomic constraint's generalised force along its gradient, a row
//! typed by hand as written). **Inputs**: a [`Contacts`] map made by the derivation from the
//! model's bodies (`hamel_bodies::ContactForces`): the rows' places in λ, and a tape of the
//! directions, scales and supports (inputs: q, the parameters, then der(q)). **Output**: named
//! values in the map's order ([`ForceComponent`]).
//!
//! A wheel the frames keep on the ground gets its normal force from its root's support: the
//! Lagrange equations of a virtual heave and two tilts of the root frame, G N = A_pq q̈ + bias −
//! Σ_i α_ip λ_i (`hamel_bodies::Support`), solved on the rows the pivoting selects (G is 3 × the
//! root's wheels, of full column rank where the contacts are not on one line).
//!
//! **Invariant**: nothing is differentiated numerically: every value is λ, q̇ and q̈ of the
//! evaluation combined with exact expressions, in the evaluation's scalar type.

use hamel_expr::Tape;
use hamel_runtime::{DD, Precision, Scalar, SupportLayout, support_equations, support_normals};
use indexmap::IndexMap;

use crate::compiled::{Compiled, ConstraintForce, NumericError};

/// How the constraint forces are reported: one entry per contact or row, and the tape of what
/// they need.
#[derive(Clone, Debug)]
pub struct Contacts {
    /// Inputs: the ingredients' (q, parameters), then der(q_1)..der(q_ℓ); outputs as the
    /// entries' `at` say.
    pub tape: Tape,
    /// What is reported, in order.
    pub reports: Vec<Report>,
    /// The supports, by number.
    pub supports: Vec<SupportSlots>,
    /// The components the motion does not determine, by name (`NAME.COMPONENT`, a row's name):
    /// with dependent rows, or more wheels on one frame than its three equations; not reported.
    pub undetermined: Vec<String>,
}

/// One reported value. Row numbers index λ (α's kept rows, then its dependent ones); tape
/// outputs are the map's.
#[derive(Clone, Debug)]
pub enum Report {
    /// Σ_k λ_row_k · c_k with the coefficients c_k on the tape: a wheel's longitudinal or
    /// lateral force (its rows' scale times the direction along their axes), a blade's lateral
    /// force (its row's scale), a row's multiplier (1), or the sum of one of these over the
    /// contacts that share it.
    Combination {
        /// `NAME.COMPONENT`, `A+B.COMPONENT` for a resultant, or the row's name.
        name: String,
        /// (row, tape output of its coefficient).
        terms: Vec<(usize, usize)>,
    },
    /// A wheel's normal force.
    Normal {
        /// `NAME.normal`.
        name: String,
        /// Where it comes from.
        slot: NormalSlot,
    },
    /// The sum of a support's normal forces (its heave equation), where they are not
    /// determined one by one (more wheels than three on one frame).
    TotalNormal {
        /// `A+B+….normal`.
        name: String,
        /// The support's number.
        support: usize,
    },
}

/// Where a wheel's normal force comes from.
#[derive(Clone, Copy, Debug)]
pub enum NormalSlot {
    /// The multiplier of this row.
    Row(usize),
    /// Unknown `index` of support `support`.
    Support {
        /// The support's number.
        support: usize,
        /// The wheel's unknown among the support's.
        index: usize,
    },
}

/// One support on the tape: from `at`, A_pq (3×ℓ), the bias (3), the rows' α_ip (3 per row of
/// `rows`), G (3 × `wheels`), all row-major.
#[derive(Clone, Debug)]
pub struct SupportSlots {
    /// Where its outputs start.
    pub at: usize,
    /// The rows of α with a part in its equations.
    pub rows: Vec<usize>,
    /// The number of wheels (unknowns).
    pub wheels: usize,
}

impl SupportSlots {
    /// Its layout among the tape's outputs ([`hamel_runtime::SupportLayout`]) for ℓ
    /// coordinates.
    pub fn layout(&self, ell: usize) -> SupportLayout {
        SupportLayout {
            at: self.at,
            ell,
            rows: self.rows.len(),
            wheels: self.wheels,
        }
    }
}

/// What the constraints push with at a state ([`Compiled::constraint_forces_checked`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Pushes {
    /// λ by row of α (the kept rows, then the dependent ones).
    pub multipliers: Vec<f64>,
    /// The forces by component ([`Contacts`]).
    pub forces: Vec<ForceComponent>,
}

/// One reported value: `wheel.normal`, `blade.lateral`, a row's name.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceComponent<S = f64> {
    /// `NAME.COMPONENT` for a wheel or a blade, the row's name for a row.
    pub name: String,
    /// Its value (newtons for a force; a row's own units for a multiplier).
    pub value: S,
}

impl Contacts {
    /// The names of the reported values, in order.
    pub fn names(&self) -> Vec<String> {
        (self.reports.iter())
            .map(|r| match r {
                Report::Combination { name, .. }
                | Report::Normal { name, .. }
                | Report::TotalNormal { name, .. } => name.clone(),
            })
            .collect()
    }

    /// The reported values from an evaluation's constraint force `c` and the tape's outputs
    /// `v` at the same state.
    fn values<S: Scalar>(
        &self,
        ell: usize,
        c: &ConstraintForce<S>,
        v: &[S],
    ) -> Result<Vec<S>, NumericError> {
        let lambda = &c.multipliers;
        let mut normals: Vec<Option<Vec<S>>> = vec![None; self.supports.len()];
        let mut out = Vec::new();
        for r in &self.reports {
            out.push(match r {
                Report::Combination { terms, .. } => {
                    (terms.iter()).fold(S::constant(0.0), |x, &(row, at)| x + lambda[row] * v[at])
                }
                Report::Normal { slot, .. } => match *slot {
                    NormalSlot::Row(i) => lambda[i],
                    NormalSlot::Support { support, index } => {
                        if normals[support].is_none() {
                            let s = &self.supports[support];
                            let mut n = vec![S::constant(0.0); s.wheels];
                            let (lambda, qdd) = (&c.multipliers, &c.q_ddot);
                            if !support_normals(s.layout(ell), &s.rows, v, lambda, qdd, &mut n) {
                                return Err(NumericError::SupportRank);
                            }
                            normals[support] = Some(n);
                        }
                        normals[support]
                            .as_ref()
                            .map_or(S::constant(0.0), |n| n[index])
                    }
                },
                Report::TotalNormal { support, .. } => {
                    let s = &self.supports[*support];
                    support_equations(s.layout(ell), &s.rows, v, lambda, &c.q_ddot)[0]
                }
            });
        }
        Ok(out)
    }
}

impl Compiled {
    /// With the map of the constraint forces' components ([`Contacts`]); its tape must take
    /// the ingredients' inputs and then ℓ velocities.
    pub fn with_contacts(mut self, contacts: Contacts) -> Result<Compiled, NumericError> {
        let own = self.tape.inputs();
        let inputs = contacts.tape.inputs();
        if inputs.len() != own.len() + self.dims.ell || inputs[..own.len()] != *own {
            return Err(NumericError::Sizes);
        }
        self.contacts = Some(contacts);
        Ok(self)
    }

    /// The components the motion does not determine ([`Contacts::undetermined`]).
    pub fn undetermined_constraint_forces(&self) -> &[String] {
        self.contacts.as_ref().map_or(&[], |c| &c.undetermined)
    }

    /// The names of the constraint forces' components ([`Compiled::constraint_forces`]), in
    /// order; empty without a map.
    pub fn constraint_force_names(&self) -> Vec<String> {
        self.contacts
            .as_ref()
            .map_or_else(Vec::new, Contacts::names)
    }

    /// The constraint forces at (q, η) checked as [`Compiled::evaluate`] checks a state, in
    /// the precision it chooses there (double-double where f64 would lose digits), rounded to
    /// f64; with the multipliers λ by row.
    pub fn constraint_forces_checked(
        &self,
        q: &[f64],
        eta: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<Pushes, NumericError> {
        fn at<S: Scalar>(
            c: &Compiled,
            q: &[S],
            eta: &[S],
            params: &IndexMap<String, f64>,
        ) -> Result<Pushes, NumericError> {
            let multipliers = c.constraint_force(q, eta, params)?.multipliers;
            let forces = c.constraint_forces(q, eta, params)?;
            Ok(Pushes {
                multipliers: multipliers.iter().map(Scalar::value).collect(),
                forces: (forces.into_iter())
                    .map(|f| ForceComponent {
                        name: f.name,
                        value: f.value.value(),
                    })
                    .collect(),
            })
        }
        match self.evaluate(q, eta, params)?.precision {
            Precision::DoubleDouble => {
                let dd = |v: &[f64]| v.iter().map(|&x| DD::from_f64(x)).collect::<Vec<_>>();
                at::<DD>(self, &dd(q), &dd(eta), params)
            }
            Precision::F64 => at::<f64>(self, q, eta, params),
        }
    }

    /// The constraint forces at (q, η), unchecked, in any scalar type: each wheel's
    /// longitudinal, lateral and normal force, each blade's lateral force, the other rows'
    /// multipliers ([`Contacts`]).
    pub fn constraint_forces<S: Scalar>(
        &self,
        q: &[S],
        eta: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Vec<ForceComponent<S>>, NumericError> {
        if self.contacts.is_none() {
            return Ok(Vec::new());
        }
        let c = self.constraint_force(q, eta, params)?;
        self.constraint_forces_from(q, params, &c)
    }

    /// The constraint forces at q from a constraint force `c` (its λ by row, q̇ and q̈): what
    /// [`Compiled::constraint_forces`] reports of its own, and what a test reports of another
    /// solution's (whose λ may differ where α has dependent rows: the reported values do
    /// not).
    pub fn constraint_forces_from<S: Scalar>(
        &self,
        q: &[S],
        params: &IndexMap<String, f64>,
        c: &ConstraintForce<S>,
    ) -> Result<Vec<ForceComponent<S>>, NumericError> {
        let Some(contacts) = &self.contacts else {
            return Ok(Vec::new());
        };
        let mut inputs = self.inputs(q, params);
        inputs.extend_from_slice(&c.q_dot);
        let v = contacts.tape.eval(&inputs)?;
        let values = contacts.values(self.dims.ell, c, &v)?;
        if values.iter().any(|x| !x.value().is_finite()) {
            return Err(NumericError::NonFinite);
        }
        Ok((contacts.names().into_iter().zip(values))
            .map(|(name, value)| ForceComponent { name, value })
            .collect())
    }
}
