//! Why a derivation failed, typed: the cause as data ([`DeriveError`]), the place in the model
//! file as a [`Site`] where there is one. The located diagnostic (file, line, column, a help
//! line) is made at the edge, with the model in hand: [`DeriveError::locate`].

use hamel_cas::CasError;
use hamel_model::{ErrorKind, Model, ModelError, Site};

/// Why a derivation failed.
#[derive(Clone, Debug, thiserror::Error, serde::Serialize, serde::Deserialize)]
pub enum DeriveError {
    /// The model or the choice asked for is refused where it is read (hamel-model's error,
    /// already located).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A constraint or a quasi-velocity is not linear and homogeneous in the velocities.
    #[error("the {what} is not linear and homogeneous in the velocities der(q): {detail}")]
    NotLinear {
        /// Where it is written.
        site: Site,
        /// What it is (`constraint \`no_slip\``, `quasi-velocity η2`).
        what: String,
        /// What is wrong with it.
        detail: String,
    },
    /// T is not a quadratic form in the velocities.
    #[error("T is not a quadratic form in the velocities der(q): {detail}")]
    NotQuadratic {
        /// Where T is written.
        site: Site,
        /// What is wrong with it.
        detail: String,
    },
    /// The mass matrix as given is not symmetric.
    #[error(
        "the mass matrix is not symmetric: entry ({row}, {column}) differs from entry ({column}, {row})"
    )]
    NotSymmetric {
        /// The entry (row, column), from 1.
        site: Site,
        /// Its row, from 1.
        row: usize,
        /// Its column, from 1.
        column: usize,
    },
    /// The constraints are not independent.
    #[error(
        "the constraint matrix α is rank-deficient: rank {rank} < μ = {mu} (the constraints are not independent)"
    )]
    RankDeficient {
        /// The constraints.
        site: Site,
        /// α's rank.
        rank: usize,
        /// Its rows.
        mu: usize,
    },
    /// α's rank was neither certified full nor decided exactly within the budget.
    #[error(
        "the rank of α could not be decided: it was not certified full at {attempts} points, and exact elimination outgrows its budget ({work} units of work)"
    )]
    RankUndecided {
        /// Points tried.
        attempts: usize,
        /// The budget that was outgrown.
        work: usize,
    },
    /// δ = det[Z; α] ≡ 0.
    #[error(
        "det[Z; α] is identically zero: these quasi-velocities are not independent of each other and of the constraints"
    )]
    Singular {
        /// The choice's quasi-velocities.
        site: Site,
    },
    /// [Z; α] neither certified nonsingular at a point nor inverted exactly within the budget.
    #[error(
        "det[Z; α] could not be certified nonzero at {attempts} points, and its exact elimination is too large: these quasi-velocities may not be independent of each other and of the constraints"
    )]
    Uncertified {
        /// The choice's quasi-velocities.
        site: Site,
        /// Points tried.
        attempts: usize,
    },
    /// The closed form was asked for and cannot be had.
    #[error("the closed form is not available: {why}")]
    ClosedFormUnavailable {
        /// Why (the forces leave its field, its equations outgrow the limit).
        why: String,
    },
    /// The closed form was asked for and the exact inverse outgrows its budget.
    #[error(
        "the closed form of the equations is too large: the exact inverse [Z; α]⁻¹ outgrows the budget of exact elimination ({work} units of work, no product above 10⁴ terms²)"
    )]
    ClosedFormTooLarge {
        /// The budget that was outgrown.
        work: usize,
    },
    /// A dependent row holds only on a constraint manifold, which the structured form does
    /// not certify.
    #[error(
        "the row `{row}` depends on the kept rows only on a constraint manifold, where hamel certifies δ ≠ 0 in closed form only, and this derivation is structured ({why})"
    )]
    ManifoldDependenceStructured {
        /// The dependent row.
        row: String,
        /// Why the derivation is structured.
        why: String,
    },
    /// The exact dependence of a dependent row could not be decided.
    #[error("the dependence of the row `{row}` could not be decided: {cause}")]
    DependenceUndecided {
        /// The row.
        row: String,
        /// Where it is written.
        site: Site,
        /// The computer algebra's failure.
        cause: CasError,
    },
    /// The exact elimination found the kept rows dependent (everywhere, or on a manifold).
    #[error(
        "the kept rows of α have rank {rank} < {mu}{}: the numeric pre-screen kept a row dependent{}",
        on.as_ref().map(|h| format!(" where `{h} = 0` holds")).unwrap_or_default(),
        if on.is_some() { " there" } else { "" }
    )]
    KeptRowsDependent {
        /// Their rank.
        rank: usize,
        /// Their number.
        mu: usize,
        /// The holonomic constraint where it was found, if only there.
        on: Option<String>,
    },
    /// A row the pre-screen found dependent is not exactly a combination of the others.
    #[error(
        "the row `{row}` depends on the other rows at every sample configuration, but it is not exactly a combination of them{}",
        manifold.as_ref().map(|m| format!(" ({m})")).unwrap_or_default()
    )]
    NotACombination {
        /// The row.
        row: String,
        /// Where it is written.
        site: Site,
        /// What was found (or not decided) on the holonomic constraint's manifold.
        manifold: Option<String>,
    },
    /// δ vanishes on the manifold where a dependence holds.
    #[error(
        "δ = det[Z; α] vanishes wherever `{manifold} = 0` holds, where the row `{row}` depends on the kept rows: the kept rows and the quasi-velocities are not independent on the constraint manifold"
    )]
    SingularOnManifold {
        /// The dependent row.
        row: String,
        /// Where it is written.
        site: Option<Site>,
        /// The holonomic constraint.
        manifold: String,
    },
    /// The computer algebra refused an expression of the model (a division by zero, a
    /// construct it does not handle).
    #[error("{cause}")]
    Cas {
        /// Where the expression is written.
        site: Option<Site>,
        /// Why.
        cause: CasError,
    },
    /// The computer-algebra engine failed: not the input's fault.
    #[error("{0}")]
    Engine(CasError),
}

impl DeriveError {
    /// A computer-algebra error while working on `site`: the input's, or the engine's own.
    pub fn cas(site: Option<&Site>, cause: CasError) -> DeriveError {
        match cause {
            CasError::Internal(_) => DeriveError::Engine(cause),
            cause => DeriveError::Cas {
                site: site.cloned(),
                cause,
            },
        }
    }

    /// Whose fault it is: the input's, or the engine's.
    pub fn kind(&self) -> ErrorKind {
        match self {
            DeriveError::Model(e) => e.kind(),
            DeriveError::Engine(_) => ErrorKind::Engine,
            _ => ErrorKind::Input,
        }
    }

    /// Where in the model file, if somewhere.
    pub fn site(&self) -> Option<&Site> {
        use DeriveError as E;
        match self {
            E::NotLinear { site, .. }
            | E::NotQuadratic { site, .. }
            | E::NotSymmetric { site, .. }
            | E::RankDeficient { site, .. }
            | E::Singular { site }
            | E::Uncertified { site, .. }
            | E::DependenceUndecided { site, .. }
            | E::NotACombination { site, .. } => Some(site),
            E::SingularOnManifold { site, .. } | E::Cas { site, .. } => site.as_ref(),
            _ => None,
        }
    }

    /// What the user may do about it.
    pub fn help(&self) -> Option<&'static str> {
        use DeriveError as E;
        Some(match self {
            E::NotLinear { .. } => {
                "write it as a sum of terms (coefficient depending on q) * der(q)"
            }
            E::NotQuadratic { .. } => {
                "T must be ½ q̇ᵀA(q)q̇: every term of degree exactly 2 in der(q)"
            }
            E::RankDeficient { .. } => "remove the constraints that are combinations of the others",
            E::Singular { .. } | E::Uncertified { .. } => {
                "each η must add a direction of motion that the constraints and the other η's do not fix"
            }
            E::ClosedFormUnavailable { .. } => {
                "derive in structured form (`hamel derive --form structured`)"
            }
            E::ClosedFormTooLarge { .. } => {
                "derive in structured form (`hamel derive --form structured`): the equations are then evaluated from A, α, Z and U"
            }
            E::NotACombination { .. } => {
                "the rows may be nearly, not exactly, dependent: check the row's expression and the parameters' defaults"
            }
            E::SingularOnManifold { .. } => {
                "choose quasi-velocities that stay independent of the constraints where the holonomic constraint holds"
            }
            _ => return None,
        })
    }

    /// The located diagnostic of `model`'s file (the edge's form: file, line, column, help).
    pub fn locate(self, model: &Model) -> ModelError {
        if let DeriveError::Model(e) = self {
            return e;
        }
        if self.kind() == ErrorKind::Engine {
            return ModelError::engine(self);
        }
        let e = match self.site() {
            Some(site) => model.error_at(site, self.to_string()),
            None => model.error(self.to_string()),
        };
        match self.help() {
            Some(help) => e.with_help(help),
            None => e,
        }
    }
}
