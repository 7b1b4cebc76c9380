//! The map of the constraint forces' components (issue 58), as plain data: what is reported,
//! the rows of α each value reads, and where a tape's outputs hold their coefficients and the
//! supports' equations. Evaluated by `contact.rs` (`crate::Compiled::constraint_forces`).

use hamel_expr::Tape;
use hamel_runtime::SupportLayout;

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

/// [`Contacts`] as plain data (the tape as [`hamel_expr::TapeData`]), for the derivation store.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ContactsData {
    /// The tape.
    pub tape: hamel_expr::TapeData,
    /// What is reported, in order.
    pub reports: Vec<Report>,
    /// The supports, by number.
    pub supports: Vec<SupportSlots>,
    /// The components the motion does not determine.
    pub undetermined: Vec<String>,
}

impl Contacts {
    /// As plain data.
    pub fn to_data(&self) -> ContactsData {
        ContactsData {
            tape: self.tape.to_data(),
            reports: self.reports.clone(),
            supports: self.supports.clone(),
            undetermined: self.undetermined.clone(),
        }
    }

    /// From plain data, the tape checked.
    pub fn from_data(d: ContactsData) -> Result<Contacts, hamel_expr::TapeError> {
        Ok(Contacts {
            tape: hamel_expr::Tape::from_data(d.tape)?,
            reports: d.reports,
            supports: d.supports,
            undetermined: d.undetermined,
        })
    }
}

/// One reported value. Row numbers index λ (α's kept rows, then its dependent ones); tape
/// outputs are the map's.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
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
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
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
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
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

/// What the constraints push with at a state ([`crate::Compiled::constraint_forces_checked`]).
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
}
