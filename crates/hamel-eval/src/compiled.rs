//! Structured evaluation of a derivation's ingredients ([`Compiled`]): the tape gives Z, α, A,
//! U, ∇U and the exact derivatives ∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k at q; the runtime's
//! [`hamel_runtime::Structured`] assembles (6), (9), (11) from them, exactly as in generated code.

use hamel_expr::Tape;
use hamel_runtime::lu::Pivot;
use hamel_runtime::{Buffers, DD, Dims, Failure, Layout, Precision, Rhs, Scalar};
use indexmap::IndexMap;
use nalgebra::DMatrix;
use serde::Serialize;

/// Why compiling or evaluating failed (the caller adds which state it was).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NumericError {
    /// [Z; α] is (numerically) singular at the configuration.
    #[error(
        "the quasi-velocity map is singular at this configuration: {what}; singular where {singular_set}"
    )]
    SingularMap {
        /// How it shows (det[Z; α] = 0, or its condition number).
        what: String,
        /// The singular set, as text (shortened).
        singular_set: String,
    },
    /// A path crossed the singular set between two evaluations (δ changed sign).
    #[error(
        "the path reaches the singular set of the quasi-velocities, det[Z; α] = 0 (δ = {delta:.3e} changed sign); choose other quasi-velocities there"
    )]
    CrossedSingularSet {
        /// δ = det[Z; α] at the evaluation.
        delta: f64,
    },
    /// A_Γ is exactly singular at the configuration.
    #[error("A_Γ is singular at this configuration")]
    SingularAGamma,
    /// A_Γ is not positive definite at the configuration.
    #[error(
        "A_Γ is not positive definite at this configuration (the mass matrix A is degenerate here)"
    )]
    NotPositiveDefinite,
    /// A result is not finite.
    #[error("the equations give a non-finite value at this state")]
    NonFinite,
    /// The wheels a support holds have contacts on one line here (or the support's wheels
    /// outnumber its three equations): their normal forces are not determined one by one.
    #[error(
        "the normal forces of the wheels on one frame are not determined here (their contacts are on one line)"
    )]
    SupportRank,
    /// The map of the constraint forces was asked of a derivation whose model's supports were
    /// not computed (`hamel_model::Model::with_supports`).
    #[error(
        "the normal forces of wheels kept on the ground by the frames need the model's supports (Model::with_supports before deriving)"
    )]
    NoSupports,
    /// The state has the wrong number of components.
    #[error("a state needs {ell} coordinates and {sigma} quasi-velocities, got {q} and {eta}")]
    StateSize {
        /// ℓ
        ell: usize,
        /// σ
        sigma: usize,
        /// Coordinates given.
        q: usize,
        /// Quasi-velocities given.
        eta: usize,
    },
    /// The state has a value that is not finite.
    #[error("the state has a non-finite value")]
    NonFiniteState,
    /// An expression could not be evaluated (outside its domain).
    #[error("{0}")]
    Evaluation(#[from] hamel_expr::EvalError),
    /// An expression could not be compiled onto a tape.
    #[error("{0}")]
    Compile(#[from] hamel_expr::TapeError),
    /// A parameter override names no parameter.
    #[error("unknown parameter `{0}`")]
    UnknownParameter(String),
    /// The quasi-velocities use free functions without definitions.
    #[error(
        "the quasi-velocities use free functions ({0}): give them definitions to evaluate numerically"
    )]
    FreeFunctions(String),
    /// The derivation was made without the ingredients of the structured evaluation.
    #[error("the derivation carries no ingredients")]
    NoIngredients,
    /// The compiled ingredients do not have the sizes the derivation says.
    #[error("the compiled ingredients do not fit the derivation's sizes")]
    Sizes,
    /// The closed-form equations were needed and the derivation is structured (the message
    /// says why and what needed them).
    #[error("{0}")]
    NotClosed(String),
}

/// The right-hand side at a state, checked (see [`Compiled::evaluate`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Evaluation {
    /// η̇ from the true equations.
    pub eta_dot: Vec<f64>,
    /// q̇ = Γη.
    pub q_dot: Vec<f64>,
    /// E = ½ηᵀA_Γη − U.
    pub energy: f64,
    /// η̇ from the paper's equations (11)/(15).
    pub eta_dot_paper: Vec<f64>,
    /// Condition number of [Z; α] at q (distance to the singular set).
    pub condition: f64,
    /// δ = det[Z; α] at q (its sign changes where a path crosses the singular set).
    pub delta: f64,
    /// The arithmetic the values were computed in (see [`Compiled::evaluate`]).
    #[serde(serialize_with = "serialize_precision")]
    pub precision: Precision,
    /// An estimate of the relative error of η̇ in f64 here
    /// ([`hamel_runtime::Structured::f64_error_estimate`]).
    pub f64_error_estimate: f64,
    /// The power of the forces, q̇ᵀF(q, q̇) = dE/dt (None without forces).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub power: Option<f64>,
}

/// What the constraints push with, at a state: the generalised force R (ℓ entries; A q̈ +
/// Ȧq̇ − ∇_qT = ∇U + F + R) and multipliers λ with R = αᵀλ, one per row of α (the kept rows,
/// then the dependent ones; with dependent rows λ is one choice among many, R is unique).
/// For a row written as a point's velocity along a direction (a wheel's `NAME_no_slip_x`),
/// its λ is the force the constraint applies there along that direction.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstraintForce<S = f64> {
    /// R, by coordinate.
    pub generalised: Vec<S>,
    /// λ, by row of α.
    pub multipliers: Vec<S>,
    /// q̇ = Γη at the state.
    pub q_dot: Vec<S>,
    /// q̈ = Γη̇ + Γ̇η at the state.
    pub q_ddot: Vec<S>,
}

/// A structured evaluation: the right-hand side, the f64 error estimate, and (when asked)
/// the constraint force.
struct Assembled<S> {
    rhs: Rhs<S>,
    estimate: f64,
    constraint: Option<ConstraintForce<S>>,
}

impl Evaluation {
    /// The values of `r` rounded to f64, with what the evaluation knew about the state:
    /// (condition number of [Z; α], δ, the f64 error estimate).
    fn of<S: Scalar>(
        r: &Rhs<S>,
        precision: Precision,
        (condition, delta, bound): (f64, f64, f64),
    ) -> Evaluation {
        let values = |v: &[S]| v.iter().map(Scalar::value).collect::<Vec<_>>();
        Evaluation {
            eta_dot: values(&r.eta_dot),
            q_dot: values(&r.q_dot),
            energy: r.energy.value(),
            eta_dot_paper: values(&r.eta_dot_paper),
            condition,
            delta,
            precision,
            f64_error_estimate: bound,
            power: None,
        }
    }

    fn is_finite(&self) -> bool {
        self.eta_dot
            .iter()
            .chain(&self.eta_dot_paper)
            .chain(&self.q_dot)
            .chain([&self.energy])
            .all(|x| x.is_finite())
    }
}

/// Serialises a [`Precision`] as `hamel eval` prints it: `f64` or `double_double`.
pub fn serialize_precision<Ser: serde::Serializer>(
    p: &Precision,
    s: Ser,
) -> Result<Ser::Ok, Ser::Error> {
    s.serialize_str(p.name())
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// [`RankLoss`] as plain data.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct RankLossData {
    /// The factors' tape.
    pub tape: hamel_expr::TapeData,
    /// Their powers in δ.
    pub powers: Vec<i32>,
}

/// The generalised forces F(q, q̇) on a tape of their own: inputs the ingredients'
/// (coordinates, parameters), then the velocities `der(q_1)..der(q_ℓ)`; outputs F_1..F_ℓ.
#[derive(Clone, Debug)]
pub struct Forces {
    /// The tape.
    pub tape: Tape,
    /// Whether F depends on the velocities: then the ingredients' ∇U leaves F out, and F is
    /// added at q̇ = Γη in every evaluation ([`hamel_runtime::Structured::evaluate_with`]).
    pub velocity: bool,
}

/// [`Forces`] as plain data.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct ForcesData {
    /// The forces' tape.
    pub tape: hamel_expr::TapeData,
    /// Whether they depend on the velocities.
    pub velocity: bool,
}

/// [`Compiled`] as plain data, for files (`hamel linearize --export`).
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct CompiledData {
    /// The ingredients' tape.
    pub tape: hamel_expr::TapeData,
    /// ℓ, μ, σ.
    pub sizes: [usize; 3],
    /// The rows of α that depend on the others (`hamel_runtime::Dims::dependent`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub dependent: usize,
    /// Where α's kept rows lose rank: the factors and their powers in δ ([`RankLoss`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rank_loss: Option<RankLossData>,
    /// The generalised forces ([`Forces`]), when the model has any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forces: Option<ForcesData>,
    /// Coordinate names.
    pub coordinates: Vec<String>,
    /// Parameters with their defaults.
    pub parameters: IndexMap<String, f64>,
    /// The singular set, as text.
    pub singular: String,
    /// The constraint forces' map, when compiled with it ([`Compiled::to_data_with_contacts`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contacts: Option<crate::contact_map::ContactsData>,
}

/// The factors f_i(q) of δ = det[Z; α] (α's kept rows) at which those rows lose rank, with
/// their powers m_i in δ, as a tape of the coordinates and parameters: δ / Π f_i^m_i vanishes
/// only on the singular set of [Z; α] with every row, so its sign is what a path watches.
#[derive(Clone, Debug)]
pub struct RankLoss {
    /// The factors (outputs), of the coordinates and parameters (inputs, as the ingredients').
    pub tape: Tape,
    /// Their powers in δ.
    pub powers: Vec<i32>,
}

/// A derivation's ingredients compiled for structured numeric evaluation.
#[derive(Clone, Debug)]
pub struct Compiled {
    pub(crate) tape: Tape,
    pub(crate) dims: Dims,
    coordinates: Vec<String>,
    parameters: IndexMap<String, f64>,
    singular: String,
    rank_loss: Option<RankLoss>,
    forces: Option<Forces>,
    pub(crate) contacts: Option<crate::contact_map::Contacts>,
}

impl Compiled {
    /// The ingredients on `tape` (outputs in the order of [`Layout`], inputs the coordinates
    /// then the parameters), with the derivation's names and parameter defaults, and its
    /// singular set as text (for messages). An error when the tape does not fit.
    pub fn new(
        tape: Tape,
        dims: Dims,
        coordinates: Vec<String>,
        parameters: IndexMap<String, f64>,
        singular: String,
    ) -> Result<Compiled, NumericError> {
        let fits = dims.ell == dims.mu + dims.sigma
            && coordinates.len() == dims.ell
            && tape.outputs().len() == Layout::new(dims).len
            && tape.inputs().len() == dims.ell + parameters.len();
        if !fits {
            return Err(NumericError::Sizes);
        }
        Ok(Compiled {
            tape,
            dims,
            coordinates,
            parameters,
            singular,
            rank_loss: None,
            forces: None,
            contacts: None,
        })
    }

    /// With the generalised forces ([`Forces`]); their tape must take the ingredients' inputs
    /// and then ℓ velocities, and give ℓ values.
    pub fn with_forces(mut self, forces: Forces) -> Result<Compiled, NumericError> {
        let l = self.dims.ell;
        let inputs = forces.tape.inputs();
        if inputs.len() != self.tape.inputs().len() + l
            || inputs[..self.tape.inputs().len()] != *self.tape.inputs()
            || forces.tape.outputs().len() != l
        {
            return Err(NumericError::Sizes);
        }
        self.forces = Some(forces);
        Ok(self)
    }

    /// Whether the model has generalised forces beside ∇U ([`Forces`]).
    pub fn has_forces(&self) -> bool {
        self.forces.is_some()
    }

    /// F(q, q̇) at the velocities `q_dot` (None without forces), in any scalar type.
    pub fn forces_at<S: Scalar>(
        &self,
        q: &[S],
        q_dot: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Option<Vec<S>>, NumericError> {
        let Some(f) = &self.forces else {
            return Ok(None);
        };
        let mut inputs = self.inputs(q, params);
        inputs.extend_from_slice(q_dot);
        Ok(Some(f.tape.eval(&inputs)?))
    }

    /// The ingredients' inputs: q, then the parameters' values (defaults where `params` has
    /// none).
    pub(crate) fn inputs<S: Scalar>(&self, q: &[S], params: &IndexMap<String, f64>) -> Vec<S> {
        let mut inputs: Vec<S> = q.to_vec();
        inputs.extend(
            self.parameters
                .iter()
                .map(|(k, v)| S::constant(params.get(k).copied().unwrap_or(*v))),
        );
        inputs
    }

    /// With the factors at which α's kept rows lose rank ([`RankLoss`]); their tape must take
    /// the ingredients' inputs.
    pub fn with_rank_loss(mut self, rank_loss: RankLoss) -> Result<Compiled, NumericError> {
        if rank_loss.tape.inputs() != self.tape.inputs()
            || rank_loss.tape.outputs().len() != rank_loss.powers.len()
        {
            return Err(NumericError::Sizes);
        }
        self.rank_loss = Some(rank_loss);
        Ok(self)
    }

    /// The compiled ingredients as data.
    pub fn to_data(&self) -> CompiledData {
        let Dims {
            ell,
            mu,
            sigma,
            dependent,
        } = self.dims;
        CompiledData {
            tape: self.tape.to_data(),
            sizes: [ell, mu, sigma],
            dependent,
            rank_loss: (self.rank_loss.as_ref()).map(|r| RankLossData {
                tape: r.tape.to_data(),
                powers: r.powers.clone(),
            }),
            forces: (self.forces.as_ref()).map(|f| ForcesData {
                tape: f.tape.to_data(),
                velocity: f.velocity,
            }),
            coordinates: self.coordinates.clone(),
            parameters: self.parameters.clone(),
            singular: self.singular.clone(),
            contacts: None,
        }
    }

    /// [`Compiled::to_data`] with the constraint forces' map, when it has one (the derivation
    /// store keeps `hamel eval`'s evaluator whole).
    pub fn to_data_with_contacts(&self) -> CompiledData {
        CompiledData {
            contacts: self.contacts.as_ref().map(|c| c.to_data()),
            ..self.to_data()
        }
    }

    /// The compiled ingredients from data, checked (the tape instruction by instruction, the
    /// sizes against the layout).
    pub fn from_data(d: CompiledData) -> Result<Compiled, NumericError> {
        let [ell, mu, sigma] = d.sizes;
        let tape = Tape::from_data(d.tape)?;
        let rank_loss = match d.rank_loss {
            Some(r) => Some(RankLoss {
                tape: Tape::from_data(r.tape)?,
                powers: r.powers,
            }),
            None => None,
        };
        let compiled = Compiled::new(
            tape,
            Dims {
                ell,
                mu,
                sigma,
                dependent: d.dependent,
            },
            d.coordinates,
            d.parameters,
            d.singular,
        )?;
        let compiled = match rank_loss {
            Some(r) => compiled.with_rank_loss(r)?,
            None => compiled,
        };
        let compiled = match d.forces {
            Some(f) => compiled.with_forces(Forces {
                tape: Tape::from_data(f.tape)?,
                velocity: f.velocity,
            })?,
            None => compiled,
        };
        match d.contacts {
            Some(c) => compiled.with_contacts(crate::contact_map::Contacts::from_data(c)?),
            None => Ok(compiled),
        }
    }

    /// Number of arithmetic operations of the compiled ingredients.
    pub fn operation_count(&self) -> usize {
        self.tape.operation_count()
    }

    /// The parameters with their defaults.
    pub fn parameters(&self) -> &IndexMap<String, f64> {
        &self.parameters
    }

    /// Parameter values: the model's defaults with `overrides` (unknown names are errors).
    pub fn parameters_with(
        &self,
        overrides: &IndexMap<String, f64>,
    ) -> Result<IndexMap<String, f64>, NumericError> {
        let mut p = self.parameters.clone();
        for (k, v) in overrides {
            match p.get_mut(k) {
                Some(slot) => *slot = *v,
                None => return Err(NumericError::UnknownParameter(k.clone())),
            }
        }
        Ok(p)
    }

    /// Coordinate names, in order.
    pub fn coordinates(&self) -> &[String] {
        &self.coordinates
    }

    /// ℓ, μ, σ.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// The ingredients at q (see [`Layout`]); with velocity-dependent forces, followed by the
    /// tape's inputs, which the forces take with q̇ ([`Compiled::assemble`]).
    fn ingredients<S: Scalar>(
        &self,
        q: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Vec<S>, NumericError> {
        self.outputs(self.inputs(q, params))
    }

    /// The tape's outputs at `inputs`, followed by `inputs` when the forces depend on the
    /// velocities.
    fn outputs<S: Scalar>(&self, inputs: Vec<S>) -> Result<Vec<S>, NumericError> {
        let mut out = self.tape.eval(&inputs)?;
        if self.forces.as_ref().is_some_and(|f| f.velocity) {
            out.extend(inputs);
        }
        Ok(out)
    }

    /// The parameters' names, in the order [`Compiled::rhs_in`] takes their values.
    pub fn parameter_names(&self) -> impl Iterator<Item = &str> {
        self.parameters.keys().map(String::as_str)
    }

    /// The right-hand side at (q, η) with the parameters' values in the scalar type too (in the
    /// order of [`Compiled::parameter_names`]), unchecked: dual numbers in a parameter give the
    /// equations' exact derivative by it (an input's column of B, say).
    pub fn rhs_in<S: Scalar>(
        &self,
        q: &[S],
        eta: &[S],
        params: &[S],
    ) -> Result<Rhs<S>, NumericError> {
        if params.len() != self.parameters.len() {
            return Err(NumericError::Sizes);
        }
        let inputs: Vec<S> = q.iter().chain(params).copied().collect();
        let out = self.outputs(inputs)?;
        Ok(self.assemble(&out, eta, false)?.rhs)
    }

    /// The rows of [Z; α] the structured evaluation uses at these ingredients
    /// (`hamel_runtime::select_rows`), in their order: 0..ℓ without dependent rows, or where
    /// the kept ones are well conditioned.
    fn selected<S: Scalar>(&self, out: &[S]) -> Vec<usize> {
        let d = self.dims;
        let l = d.ell;
        if d.dependent == 0 {
            return (0..l).collect();
        }
        let all = &out[Layout::new(d).m(d)];
        let mut factors = all.to_vec();
        let mut perm = vec![0; d.m_rows()];
        if !hamel_runtime::select_rows(d, all, &mut factors, &mut perm, Pivot::Exact) {
            return (0..l).collect();
        }
        let mut rows = perm[..l].to_vec();
        rows.sort_unstable();
        rows
    }

    /// The rows `rows` of [Z; α] (ℓ×ℓ, row-major) from the ingredients.
    fn m_values<S: Scalar>(&self, out: &[S], rows: &[usize]) -> Vec<S> {
        let d = self.dims;
        let l = d.ell;
        let all = &out[Layout::new(d).m(d)];
        rows.iter()
            .flat_map(|&r| all[r * l..(r + 1) * l].iter().copied())
            .collect()
    }

    /// [Z; α] with α's kept rows (ℓ×ℓ, row-major): Z's σ rows, then α's μ.
    fn kept_values<S: Scalar>(&self, out: &[S]) -> Vec<S> {
        let l = self.dims.ell;
        out[Layout::new(self.dims).m(self.dims)][..l * l].to_vec()
    }

    /// The ingredients at q (the tape's outputs, in the order of [`Layout`]): they depend on q
    /// and the parameters only, so one evaluation serves the right-hand side at every η
    /// ([`Compiled::rhs_from`]).
    pub fn ingredients_at<S: Scalar>(
        &self,
        q: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Vec<S>, NumericError> {
        self.ingredients(q, params)
    }

    /// The right-hand side at η from ingredients of [`Compiled::ingredients_at`], unchecked.
    pub fn rhs_from<S: Scalar>(
        &self,
        ingredients: &[S],
        eta: &[S],
    ) -> Result<Rhs<S>, NumericError> {
        Ok(self.assemble(ingredients, eta, false)?.rhs)
    }

    /// [Z; α] as rows (Z's σ rows, then α's μ kept rows) from ingredients of
    /// [`Compiled::ingredients_at`].
    pub fn map_from<S: Scalar>(&self, ingredients: &[S]) -> Vec<Vec<S>> {
        let l = self.dims.ell;
        self.kept_values(ingredients)
            .chunks(l)
            .map(<[S]>::to_vec)
            .collect()
    }

    /// [Z; α] at q in any scalar type, as rows (Z's σ rows, then α's μ kept rows), from the
    /// compiled ingredients (no expression trees are walked).
    pub fn quasi_velocity_map<S: Scalar>(
        &self,
        q: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Vec<Vec<S>>, NumericError> {
        let l = self.dims.ell;
        let m = self.kept_values(&self.ingredients(q, params)?);
        Ok(m.chunks(l).map(<[S]>::to_vec).collect())
    }

    /// Γ(q) (columns 0..σ of [Z; α]⁻¹) in any scalar type (dual numbers give Γ̇ along a
    /// direction).
    pub fn gamma<S: Scalar>(
        &self,
        q: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Vec<Vec<S>>, NumericError> {
        let (l, g) = (self.dims.ell, self.dims.sigma);
        let out = self.ingredients(q, params)?;
        let rows = self.selected(&out);
        let m = self.m_values(&out, &rows);
        let factors = hamel_runtime::Lu::from_row_major(l, m, Pivot::Exact)
            .ok_or_else(|| self.singular_error("det[Z; α] = 0"))?;
        // [Z; α]Γ = [I; 0] on the rows used: η_s's row of Z gets e_s, α's rows 0.
        let columns: Vec<Vec<S>> = (0..g)
            .map(|s| {
                let e: Vec<S> = rows
                    .iter()
                    .map(|&r| S::constant(f64::from(r == s)))
                    .collect();
                factors.solve(&e)
            })
            .collect();
        Ok((0..l)
            .map(|i| columns.iter().map(|c| c[i]).collect())
            .collect())
    }

    fn singular_error(&self, what: &str) -> NumericError {
        NumericError::SingularMap {
            what: what.into(),
            singular_set: shorten(&self.singular),
        }
    }

    /// [Z; α] at q as a matrix.
    fn m_matrix(
        &self,
        q: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<DMatrix<f64>, NumericError> {
        let l = self.dims.ell;
        let out = self.ingredients(q, params)?;
        Ok(DMatrix::from_row_slice(
            l,
            l,
            &self.m_values(&out, &self.selected(&out)),
        ))
    }

    /// δ = det[Z; α] at q, as [`Compiled::evaluate`] reports it, without the right-hand side
    /// (what watching the singular set along a path needs: it changes sign where a path
    /// crosses it). With dependent rows, δ of the kept rows over the factors at which they lose
    /// rank ([`RankLoss`]), which changes sign on the singular set of [Z; α] with every row
    /// only; without those factors (a structured derivation), |det| of the rows used, which
    /// never changes sign (the watch then rests on the condition number alone).
    pub fn delta(&self, q: &[f64], params: &IndexMap<String, f64>) -> Result<f64, NumericError> {
        let out = self.ingredients(q, params)?;
        Ok(self.delta_from(&out, q, params))
    }

    fn delta_from(&self, out: &[f64], q: &[f64], params: &IndexMap<String, f64>) -> f64 {
        let d = self.dims;
        let l = d.ell;
        if d.dependent == 0 {
            return DMatrix::from_row_slice(l, l, &self.kept_values(out)).determinant();
        }
        let Some(r) = &self.rank_loss else {
            return DMatrix::from_row_slice(l, l, &self.m_values(out, &self.selected(out)))
                .determinant()
                .abs();
        };
        let kept = &out[Layout::new(d).m(d)][..l * l];
        let det = DMatrix::from_row_slice(l, l, kept).determinant();
        let Ok(factors) = r.tape.eval(&self.inputs(q, params)) else {
            return det;
        };
        let divisor: f64 = factors
            .iter()
            .zip(&r.powers)
            .map(|(f, &m)| f.powi(m))
            .product();
        if divisor != 0.0 && divisor.is_finite() {
            det / divisor
        } else {
            det
        }
    }

    /// Condition number of [Z; α] at q (∞ when singular).
    pub fn condition(
        &self,
        q: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<f64, NumericError> {
        Ok(condition_number(&self.m_matrix(q, params)?))
    }

    /// The right-hand side at (q, η) in any scalar type, unchecked.
    pub fn rhs<S: Scalar>(
        &self,
        q: &[S],
        eta: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Rhs<S>, NumericError> {
        Ok(self.structured(q, eta, params, false)?.rhs)
    }

    /// The constraints' generalised force R and multipliers λ at (q, η), unchecked
    /// ([`hamel_runtime::Structured::constraint_force`]), in any scalar type: after
    /// [`Compiled::evaluate`], in the precision it chose (what `hamel eval` prints; simulations
    /// do not pay for it).
    pub fn constraint_force<S: Scalar>(
        &self,
        q: &[S],
        eta: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<ConstraintForce<S>, NumericError> {
        let a = self.structured(q, eta, params, true)?;
        Ok(a.constraint.expect("asked for"))
    }

    /// [`Compiled::rhs`] with the f64 error estimate (for types other than f64, 0), and the
    /// constraint force when `constraint`.
    fn structured<S: Scalar>(
        &self,
        q: &[S],
        eta: &[S],
        params: &IndexMap<String, f64>,
        constraint: bool,
    ) -> Result<Assembled<S>, NumericError> {
        let out = self.ingredients(q, params)?;
        self.assemble(&out, eta, constraint)
    }

    /// The structured right-hand side from the ingredients `out` (the tape's outputs), and
    /// the constraint force when `constraint`.
    fn assemble<S: Scalar>(
        &self,
        out: &[S],
        eta: &[S],
        constraint: bool,
    ) -> Result<Assembled<S>, NumericError> {
        let mut buffers = Buffers::<S>::new(self.dims);
        // Exact pivots: `evaluate` checks the conditioning and the definiteness itself, and the
        // unchecked `rhs` serves studies that approach the singular set on purpose.
        let mut r = buffers.structured().with_pivot(Pivot::Exact);
        let mut failed = None;
        let velocity = self.forces.as_ref().filter(|f| f.velocity);
        let len = Layout::new(self.dims).len;
        let forces = |q_dot: &[S], f: &mut [S]| {
            let Some(forces) = velocity else {
                return true;
            };
            let mut inputs = out[len..].to_vec();
            inputs.extend_from_slice(q_dot);
            match forces.tape.eval(&inputs) {
                Ok(v) => {
                    f.copy_from_slice(&v);
                    true
                }
                Err(e) => {
                    failed = Some(e);
                    false
                }
            }
        };
        let evaluated = r.evaluate_with(out, eta, true, forces);
        evaluated.map_err(|e| match e {
            Failure::QuasiVelocityMap => self.singular_error("det[Z; α] = 0"),
            Failure::AGamma => NumericError::SingularAGamma,
            Failure::Inputs | Failure::Storage => NumericError::Sizes,
            Failure::Forces => match failed.take() {
                Some(e) => NumericError::Evaluation(e),
                None => NumericError::NonFinite,
            },
        })?;
        let rhs = Rhs::read(&r);
        let constraint = constraint.then(|| {
            let d = self.dims;
            let zero = S::constant(0.0);
            let (mut generalised, mut y) = (vec![zero; d.ell], vec![zero; d.m_rows()]);
            let mut q_ddot = vec![zero; d.ell];
            let tmp = &mut vec![zero; d.ell];
            r.constraint_force(out, &mut generalised, &mut y, &mut q_ddot, tmp);
            ConstraintForce {
                generalised,
                multipliers: y.split_off(d.sigma),
                q_dot: rhs.q_dot.clone(),
                q_ddot,
            }
        });
        // after the constraint force: the estimate reuses the evaluation's scratch storage
        let estimate = if S::CHECKED {
            r.f64_error_estimate(out)
        } else {
            0.0
        };
        Ok(Assembled {
            rhs,
            estimate,
            constraint,
        })
    }

    /// η̇, q̇, energy and the paper's η̇ at the state (q, η) for the given parameter values.
    /// Singular configurations (det[Z; α] ≈ 0, A_Γ not positive definite) and non-finite values
    /// are errors, never NaN. An f64 evaluation whose error estimate exceeds
    /// [`hamel_runtime::DOUBLE_DOUBLE_ABOVE`] is repeated in double-double.
    pub fn evaluate(
        &self,
        q: &[f64],
        eta: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<Evaluation, NumericError> {
        self.check_state(q, eta)?;
        let out = self.ingredients(q, params)?;
        let l = self.dims.ell;
        let m = DMatrix::from_row_slice(l, l, &self.m_values(&out, &self.selected(&out)));
        let (condition, delta) = (condition_number(&m), self.delta_from(&out, q, params));
        if condition > 1e12 {
            return Err(
                self.singular_error(&format!("det[Z; α] ≈ 0 (condition number {condition:.3e})"))
            );
        }
        let Assembled {
            rhs: r,
            estimate: bound,
            ..
        } = self.structured(q, eta, params, false)?;
        let sigma = self.dims.sigma;
        let ag = DMatrix::from_fn(sigma, sigma, |i, j| r.a_gamma[i][j]);
        if ag.cholesky().is_none() {
            return Err(NumericError::NotPositiveDefinite);
        }
        let at = (condition, delta, bound);
        let out = if bound > hamel_runtime::DOUBLE_DOUBLE_ABOVE {
            let to_dd = |v: &[f64]| v.iter().map(|&x| DD::from_f64(x)).collect::<Vec<_>>();
            let r = self.rhs::<DD>(&to_dd(q), &to_dd(eta), params)?;
            Evaluation::of(&r, Precision::DoubleDouble, at)
        } else {
            Evaluation::of(&r, Precision::F64, at)
        };
        let mut out = out;
        if let Some(f) = self.forces_at(q, &out.q_dot, params)? {
            out.power = Some(f.iter().zip(&out.q_dot).map(|(f, v)| f * v).sum());
        }
        if !out.is_finite() || out.power.is_some_and(|p| !p.is_finite()) {
            return Err(NumericError::NonFinite);
        }
        Ok(out)
    }

    fn check_state(&self, q: &[f64], eta: &[f64]) -> Result<(), NumericError> {
        if q.len() != self.dims.ell || eta.len() != self.dims.sigma {
            return Err(NumericError::StateSize {
                ell: self.dims.ell,
                sigma: self.dims.sigma,
                q: q.len(),
                eta: eta.len(),
            });
        }
        if q.iter().chain(eta).any(|x| !x.is_finite()) {
            return Err(NumericError::NonFiniteState);
        }
        Ok(())
    }
}

/// σ_max/σ_min (∞ when singular).
fn condition_number(m: &DMatrix<f64>) -> f64 {
    let sv = m.singular_values();
    let (max, min) = (sv.max(), sv.min());
    if min == 0.0 { f64::INFINITY } else { max / min }
}

fn shorten(s: &str) -> String {
    if s.chars().count() <= 200 {
        s.to_string()
    } else {
        format!(
            "{}… ({} characters)",
            s.chars().take(200).collect::<String>(),
            s.chars().count()
        )
    }
}
