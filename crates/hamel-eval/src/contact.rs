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

use hamel_runtime::{DD, Precision, Scalar, support_equations, support_normals};
use indexmap::IndexMap;

use crate::compiled::{Compiled, ConstraintForce, NumericError};
use crate::contact_map::{Contacts, ForceComponent, NormalSlot, Pushes, Report};

/// The reported values from an evaluation's constraint force `c` and the tape's outputs
/// `v` at the same state.
fn values<S: Scalar>(
    contacts: &Contacts,
    ell: usize,
    c: &ConstraintForce<S>,
    v: &[S],
) -> Result<Vec<S>, NumericError> {
    let lambda = &c.multipliers;
    let mut normals: Vec<Option<Vec<S>>> = vec![None; contacts.supports.len()];
    let mut out = Vec::new();
    for r in &contacts.reports {
        out.push(match r {
            Report::Combination { terms, .. } => {
                (terms.iter()).fold(S::constant(0.0), |x, &(row, at)| x + lambda[row] * v[at])
            }
            Report::Normal { slot, .. } => match *slot {
                NormalSlot::Row(i) => lambda[i],
                NormalSlot::Support { support, index } => {
                    if normals[support].is_none() {
                        let s = &contacts.supports[support];
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
                let s = &contacts.supports[*support];
                support_equations(s.layout(ell), &s.rows, v, lambda, &c.q_ddot)[0]
            }
        });
    }
    Ok(out)
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
            // one constraint force for both: λ, and the components read off it
            let pushed = c.constraint_force(q, eta, params)?;
            let forces = c.constraint_forces_from(q, params, &pushed)?;
            let multipliers = pushed.multipliers;
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
        let values = values(contacts, self.dims.ell, c, &v)?;
        if values.iter().any(|x| !x.value().is_finite()) {
            return Err(NumericError::NonFinite);
        }
        Ok((contacts.names().into_iter().zip(values))
            .map(|(name, value)| ForceComponent { name, value })
            .collect())
    }
}
