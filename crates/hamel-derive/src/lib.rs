//! The Boltzmann–Hamel equations of a model.
//!
//! **Job**: given a [`Model`] and one of its quasi-velocity choices, derive exactly Γ, Θ and
//! δ (4)–(5), A_Γ (8), the forcing Γᵀ∇U, the coefficients Q⁽ⁱ⁾_rs of the *true* equations
//! (11) obtained from (9), the paper's coefficients (12)/(15) and the correction term that the
//! paper drops, the kinematic equations (6) and the energy; and check exactly that
//! Q = Q_paper + Q_correction and that the energy is conserved.
//!
//! **Inputs**: a checked [`Model`] and a choice name. **Outputs**: a [`Derivation`] (plain data:
//! canonical text and evaluable trees), or a [`DeriveError`] for models that fail the
//! algebraic checks (T not quadratic, constraints not linear and homogeneous, α rank-deficient,
//! det[Z; α] identically zero): the cause as data, where in the model file as a site; the
//! located diagnostic is made at the edge ([`DeriveError::locate`]).
//!
//! **Invariant**: the symbolic work runs as one job on the computer-algebra thread
//! ([`hamel_cas::run`]); everything returned is engine-free and `Send`.
#![warn(missing_docs)]

pub mod certify;
pub mod conditioning;
pub mod dependence;
mod derivation;
mod error;
pub use error::DeriveError;
mod numeric;
pub mod progress;
mod render;
pub use render::{Printer, canonical, entry_line, is_whole_equation};
pub mod states;
pub mod store;
pub mod symbolic;
pub mod uniqueness;

pub use derivation::{
    Block, Checks, Closed, Dependent, Derivation, DerivationJson, Entry, Form, Holonomic,
    Ingredients, Mat, NotClosed, Power, Size, SpecialiseError, StructuredForm, Term, Trees, Why,
};
pub use hamel_eval::{
    Compiled, ConstraintForce, Contacts, DOUBLE_DOUBLE_ABOVE, Evaluation, NormalSlot, NumericError,
    Precision, Report, Rhs, SupportSlots, SymbolicCompiled,
};
pub use hamel_model::{Model, ModelError};
pub use symbolic::{
    CLOSED_FORM_TERMS, Derived, FormRequest, SOLUTION_TERMS, StructuredSymbolic, Symbolic,
    derive_form, symbolic,
};

/// Derive the equations of `model` for the quasi-velocity choice `eta` (the model's first
/// choice when `None`): in closed form when it stays within the budget of exact elimination,
/// else structured ([`FormRequest::Auto`]).
pub fn derive(model: &Model, eta: Option<&str>) -> Result<Derivation, DeriveError> {
    derive_with(model, eta, FormRequest::Auto, false)
}

/// [`derive`] with the ingredients code generation uses
/// ([`Symbolic::to_derivation_for_code`]).
pub fn derive_for_code(model: &Model, eta: Option<&str>) -> Result<Derivation, DeriveError> {
    derive_with(model, eta, FormRequest::Auto, true)
}

/// [`derive`] (`code`: [`derive_for_code`]) in the form `form` asks for.
pub fn derive_with(
    model: &Model,
    eta: Option<&str>,
    form: FormRequest,
    code: bool,
) -> Result<Derivation, DeriveError> {
    let name = model.choice(eta)?.name.clone();
    let model = model.clone();
    hamel_cas::run(move || Ok(symbolic::derive_form(&model, &name, form)?.to_derivation(code)))
        .map_err(DeriveError::Engine)?
}
