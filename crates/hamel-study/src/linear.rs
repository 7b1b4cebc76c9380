//! The equations linearised about a steady state: the Jacobian of (q̇, η̇) by exact dual
//! numbers, the quotient by the steady family's own directions, the eigenvalues and the
//! second-order form.

use hamel_expr::Dual;
use indexmap::IndexMap;
use nalgebra::DMatrix;
use serde::Serialize;

use crate::forms::SecondOrder;
use crate::mat::rows;
use crate::{Study, StudyError, eigen};

/// A point of a study: values for steady parameters and model parameters (the others keep
/// their defaults).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Point(pub IndexMap<String, f64>);

impl Point {
    /// `name = value, …` (or `defaults`).
    pub fn text(&self) -> String {
        if self.0.is_empty() {
            return "the defaults".into();
        }
        let parts: Vec<String> = self.0.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        parts.join(", ")
    }
}

/// Where a structural zero eigenvalue comes from.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum StructuralKind {
    /// A coordinate the equations are free of (decided exactly): its column is zero.
    DroppedCoordinate {
        /// The coordinate.
        coordinate: String,
    },
    /// The steady family's direction ∂x*/∂p (exactly in the kernel of the Jacobian).
    SteadyFamily {
        /// The steady parameter.
        parameter: String,
    },
    /// A zero present at every point of the family sampled (found numerically): a conserved
    /// quantity or a neighbouring family of steady motions.
    Persistent,
}

/// A structural zero eigenvalue, reported apart and never counted as a crossing.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Structural {
    /// Where it comes from.
    #[serde(flatten)]
    pub kind: StructuralKind,
    /// Its computed value (re, im): exactly 0 for dropped coordinates and family directions.
    pub eigenvalue: [f64; 2],
}

/// Linear stability at a point, from the eigenvalues that are not structural.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stability {
    /// Every eigenvalue has a negative real part.
    Asymptotic,
    /// None has a positive real part, some lie on the imaginary axis (to the tolerance).
    Marginal,
    /// Some eigenvalue has a positive real part.
    Unstable,
}

/// The linearisation at one point.
#[derive(Clone, Debug, Serialize)]
pub struct Linearisation {
    /// The point.
    pub point: Point,
    /// The steady parameters' values.
    pub steady_parameters: IndexMap<String, f64>,
    /// The steady state: every coordinate.
    pub q: IndexMap<String, f64>,
    /// Every velocity.
    pub q_dot: IndexMap<String, f64>,
    /// η = Z q̇.
    pub eta: Vec<f64>,
    /// max |ẋ| at the steady state (η̇ and the kept coordinates' rates).
    pub residual: f64,
    /// How the steady motion is known to be one.
    pub steady_check: crate::SteadyCheck,
    /// The state: kept coordinates (not dependent), then η.
    pub state: Vec<String>,
    /// ∂ẋ/∂x, by exact dual numbers.
    pub jacobian: Vec<Vec<f64>>,
    /// The inputs (`[inputs]`).
    pub inputs: Vec<String>,
    /// ∂ẋ/∂u.
    pub input_matrix: Vec<Vec<f64>>,
    /// The state after the steady family's directions are taken out.
    pub reduced_state: Vec<String>,
    /// The linear system on it: ẋ = A x + B u.
    pub a: Vec<Vec<f64>>,
    /// Its input matrix.
    pub b: Vec<Vec<f64>>,
    /// Structural zero eigenvalues, reported apart.
    pub structural: Vec<Structural>,
    /// The other eigenvalues (re, im), by real part then imaginary part.
    pub eigenvalues: Vec<[f64; 2]>,
    /// Stability from them.
    pub stability: Stability,
    /// M q̈ + C q̇ + K q = B u, when the state allows it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub second_order: Option<SecondOrder>,
    /// The loads at the steady motion: the constraints' forces by component (each wheel's
    /// longitudinal, lateral and normal force, …; `hamel_eval::Contacts`), for the point a
    /// linearisation is printed at (not for a sweep's points).
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    pub loads: IndexMap<String, f64>,
    /// The coefficient of λ^s in det(λI − A), s the persistent zeros: it changes sign where
    /// a real eigenvalue passes through zero.
    #[serde(skip)]
    pub(crate) zero_function: f64,
    /// Every eigenvalue of A, structural ones included.
    #[serde(skip)]
    pub(crate) all_eigenvalues: Vec<[f64; 2]>,
    /// ‖A‖ (for relative tolerances).
    #[serde(skip)]
    pub(crate) scale: f64,
    /// How many eigenvalues of A are zero here, to rounding.
    #[serde(skip)]
    pub(crate) zeros_here: usize,
}

impl Linearisation {
    /// The same linearisation with `persistent` zeros reported apart (found along a sweep).
    /// Zeros beyond those (a crossing that falls on this very point) count as lying on the
    /// imaginary axis, whatever rounding made of them.
    pub(crate) fn with_persistent(mut self, persistent: usize) -> Linearisation {
        self.structural
            .retain(|s| s.kind != crate::StructuralKind::Persistent);
        let (zeros, rest) = eigen::split_smallest(self.all_eigenvalues.clone(), persistent);
        self.structural
            .extend(zeros.into_iter().map(|z| Structural {
                kind: crate::StructuralKind::Persistent,
                eigenvalue: z,
            }));
        let here = self.zero_multiplicity().saturating_sub(persistent);
        let (_, clear) = eigen::split_smallest(rest.clone(), here);
        self.stability = match eigen::stability(&clear, self.scale) {
            Stability::Asymptotic if here > 0 => Stability::Marginal,
            s => s,
        };
        self.eigenvalues = rest;
        self.zero_function = eigen::char_coefficient(&self.all_eigenvalues, persistent);
        self
    }

    /// How many eigenvalues of A are zero here, to rounding.
    pub(crate) fn zero_multiplicity(&self) -> usize {
        self.zeros_here
    }

    /// Only what a map keeps of a point (its eigenvalues and stability): the matrices and the
    /// steady state are dropped, so that 40,000 points fit in little memory.
    pub(crate) fn slim(mut self) -> Linearisation {
        for m in [
            &mut self.jacobian,
            &mut self.input_matrix,
            &mut self.a,
            &mut self.b,
        ] {
            *m = Vec::new();
        }
        self.q = IndexMap::new();
        self.q_dot = IndexMap::new();
        self.state = Vec::new();
        self.reduced_state = Vec::new();
        self.second_order = None;
        self
    }
}

/// A point's values that every derivative there uses.
struct Here<'a> {
    params: &'a IndexMap<String, f64>,
    s: &'a [f64],
    at: &'a crate::state::Completed,
    ingredients: &'a [f64],
    along_q: &'a [Vec<Dual>],
    eta: &'a [f64],
}

/// What a point's linearisation needs at its steady configuration ([`Study::at_q`]).
pub(crate) struct AtQ {
    params: IndexMap<String, f64>,
    at: crate::state::Completed,
    ingredients: Vec<f64>,
    /// The ingredients' derivatives along each kept coordinate (dependent ones following).
    along_q: Vec<Vec<Dual>>,
}

/// The Jacobian and what it is built from.
struct Jacobian {
    j: DMatrix<f64>,
    b: DMatrix<f64>,
    tangents: Vec<(String, Vec<f64>)>,
    a_gamma: DMatrix<f64>,
}

impl Study {
    /// Linearise at `point`, with `persistent` zero eigenvalues (found along the family,
    /// [`Study::persistent_zeros`]) reported apart.
    pub fn linearise(&self, point: &Point, persistent: usize) -> Result<Linearisation, StudyError> {
        self.linearise_with(point, persistent, true)
    }

    /// [`Study::linearise`]; without `inputs`, B is left empty (the points of sweeps and maps
    /// need only the eigenvalues).
    pub(crate) fn linearise_with(
        &self,
        point: &Point,
        persistent: usize,
        inputs: bool,
    ) -> Result<Linearisation, StudyError> {
        let (params, s) = self.values(&point.0)?;
        let at_q = self.at_q(params, &s)?;
        let mut l = self.linearise_at(point, persistent, inputs, &at_q, &s)?;
        if inputs && !self.compiled.constraint_force_names().is_empty() {
            let q: Vec<f64> = l.q.values().copied().collect();
            let pushes = (self
                .compiled
                .constraint_forces_checked(&q, &l.eta, &at_q.params))
            .map_err(|e| StudyError::Numeric(e.to_string()))?;
            l.loads = (pushes.forces.into_iter())
                .map(|f| (f.name, f.value))
                .collect();
        }
        Ok(l)
    }

    /// What every linearisation at the steady configuration of `s` needs, whatever the steady
    /// velocities: the constraints solved, the ingredients (they depend on q only) and their
    /// derivatives along each kept coordinate.
    pub(crate) fn at_q(&self, params: IndexMap<String, f64>, s: &[f64]) -> Result<AtQ, StudyError> {
        let at = self.completed(&params, s)?;
        let numeric = |e: hamel_eval::NumericError| StudyError::Numeric(e.to_string());
        let ingredients = self
            .compiled
            .ingredients_at::<f64>(&at.q, &params)
            .map_err(numeric)?;
        let along_q = (0..self.state_q.len())
            .map(|col| {
                let dq = self.q_direction(col, &at.q, &at.sensitivity);
                self.compiled
                    .ingredients_at::<Dual>(&dq, &params)
                    .map_err(numeric)
            })
            .collect::<Result<_, _>>()?;
        Ok(AtQ {
            params,
            at,
            ingredients,
            along_q,
        })
    }

    /// Whether the steady coordinates are the same for every value of the steady parameters
    /// (no `q` value uses one): then points that differ only in those share their [`AtQ`].
    pub(crate) fn steady_q_is_fixed(&self) -> bool {
        let steady = self.steady.parameters.keys();
        let uses = |p: &String| self.steady.q.iter().any(|(_, i)| i.expr.mentions(p));
        !steady.into_iter().any(uses)
    }

    /// The linearisation at `point` from its [`AtQ`].
    pub(crate) fn linearise_at(
        &self,
        point: &Point,
        persistent: usize,
        inputs: bool,
        at_q: &AtQ,
        s: &[f64],
    ) -> Result<Linearisation, StudyError> {
        let (params, at, ingredients) = (&at_q.params, &at_q.at, &at_q.ingredients);
        let numeric = |e: hamel_eval::NumericError| StudyError::Numeric(e.to_string());
        let map = self.compiled.map_from(ingredients);
        let full = self.full_state::<f64>(params, s, at.q.clone(), &map)?;
        let names = &self.model.coordinates;
        let r0 = self
            .compiled
            .rhs_from(ingredients, &full.eta)
            .map_err(numeric)?;
        let residual = self.check_steady(&r0, &full.q, &full.eta, params)?;
        let here = Here {
            params,
            s,
            at,
            ingredients,
            along_q: &at_q.along_q,
            eta: &full.eta,
        };
        let jac = self.jacobian(&here, &r0, inputs)?;
        let Complement {
            w,
            labels: reduced_state,
            family,
        } = self.complement(&jac)?;
        if jac.j.iter().chain(jac.b.iter()).any(|x| !x.is_finite()) {
            return Err(StudyError::Numeric(
                "a derivative of the equations is not finite at the steady state".into(),
            ));
        }
        let a = w.transpose() * &jac.j * &w;
        let b = w.transpose() * &jac.b;
        let lambda = eigen::eigenvalues(&a).map_err(|iterations| StudyError::Eigen {
            iterations,
            at: point.text(),
        })?;
        let mut structural = self.dropped_zeros();
        structural.extend(family.into_iter().map(|parameter| Structural {
            kind: crate::StructuralKind::SteadyFamily { parameter },
            eigenvalue: [0.0, 0.0],
        }));
        let scale = eigen::scale(&a);
        let second_order =
            crate::forms::second_order(&reduced_state, &self.state_names(), &a, &b, &jac.a_gamma);
        Ok(Linearisation {
            point: point.clone(),
            steady_parameters: self
                .steady
                .parameters
                .keys()
                .cloned()
                .zip(s.iter().copied())
                .collect(),
            q: names.iter().cloned().zip(full.q).collect(),
            q_dot: names.iter().cloned().zip(full.q_dot).collect(),
            eta: full.eta,
            residual,
            steady_check: self.steady_check.clone(),
            state: self.state_names(),
            jacobian: rows(&jac.j),
            inputs: self.model.inputs.clone(),
            input_matrix: rows(&jac.b),
            reduced_state,
            a: rows(&a),
            b: rows(&b),
            structural,
            stability: Stability::Marginal,
            eigenvalues: Vec::new(),
            second_order,
            loads: IndexMap::new(),
            zero_function: 0.0,
            zeros_here: eigen::zero_multiplicity(&a, &lambda),
            all_eigenvalues: lambda,
            scale,
        }
        .with_persistent(persistent))
    }

    /// The dropped coordinates' zeros.
    fn dropped_zeros(&self) -> Vec<Structural> {
        self.dropped
            .iter()
            .map(|&k| Structural {
                kind: crate::StructuralKind::DroppedCoordinate {
                    coordinate: self.model.coordinates[k].clone(),
                },
                eigenvalue: [0.0, 0.0],
            })
            .collect()
    }

    /// ẋ at the steady state must vanish: max |ẋ| ≤ 1e-9·(1 + |terms|), where the scale is
    /// the size of the state and of A_Γ's right side; the residual, or an error naming the
    /// components that do not vanish. Where the motion is proved steady exactly (and the
    /// inputs are at zero) the residual is only reported: rounding cannot refute a proof.
    fn check_steady(
        &self,
        r: &hamel_eval::Rhs<f64>,
        q: &[f64],
        eta: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<f64, StudyError> {
        let x_dot = self.state_rates(&r.q_dot, &r.eta_dot);
        let names = self.state_names();
        let all = x_dot.iter().chain(q).chain(eta).chain(&r.forcing);
        if all.clone().any(|x| !x.is_finite()) {
            return Err(StudyError::Numeric(
                "a rate or a force is not finite".into(),
            ));
        }
        let kept = self.state_q.iter().map(|&k| &q[k]);
        let size = kept
            .chain(eta)
            .chain(&r.forcing)
            .fold(1.0_f64, |m, x| m.max(x.abs()));
        let allowed = 1e-9 * size;
        let largest = x_dot.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let inputs_off = self
            .model
            .inputs
            .iter()
            .all(|u| params.get(u) == Some(&0.0));
        let proved = self.steady_check == crate::SteadyCheck::Exact && inputs_off;
        if largest > allowed && !proved {
            let residuals: Vec<String> = names
                .iter()
                .zip(&x_dot)
                .filter(|(_, x)| x.abs() > allowed)
                .map(|(n, x)| format!("d({n})/dt = {x:.3e}"))
                .collect();
            let mut residuals = residuals.join(", ");
            if let crate::SteadyCheck::NotIdentically { residuals: exact } = &self.steady_check {
                let exact: Vec<String> = exact.iter().map(|(n, e)| format!("{n} = {e}")).collect();
                residuals += &format!("; exactly, {}", exact.join(", "));
            }
            return Err(StudyError::NotSteady {
                residuals,
                largest,
                allowed,
            });
        }
        Ok(largest)
    }

    /// The state's rates from q̇ and η̇.
    fn state_rates<S: Copy>(&self, q_dot: &[S], eta_dot: &[S]) -> Vec<S> {
        self.state_q
            .iter()
            .map(|&k| q_dot[k])
            .chain(eta_dot.iter().copied())
            .collect()
    }

    /// ∂ẋ/∂x and ∂ẋ/∂u by dual numbers (a kept coordinate moves the dependent ones with it),
    /// the steady family's tangents ∂x*/∂p, and A_Γ.
    fn jacobian(
        &self,
        here: &Here<'_>,
        r0: &hamel_eval::Rhs<f64>,
        inputs: bool,
    ) -> Result<Jacobian, StudyError> {
        let (q, eta) = (&here.at.q, here.eta);
        let n = self.state_q.len() + eta.len();
        let numeric = |e: hamel_eval::NumericError| StudyError::Numeric(e.to_string());
        let lifted: Vec<Dual> = here
            .ingredients
            .iter()
            .map(|&x| Dual::new(x, 0.0))
            .collect();
        let mut j = DMatrix::zeros(n, n);
        let nq = self.state_q.len();
        for col in 0..n {
            let mut deta: Vec<Dual> = eta.iter().map(|&v| Dual::new(v, 0.0)).collect();
            // A direction in q moves the ingredients; one in η leaves them alone.
            let r = if col < nq {
                self.compiled.rhs_from(&here.along_q[col], &deta)
            } else {
                deta[col - nq].d = 1.0;
                self.compiled.rhs_from(&lifted, &deta)
            }
            .map_err(numeric)?;
            let x = self.state_rates(&r.q_dot, &r.eta_dot);
            for (row, v) in x.iter().enumerate() {
                j[(row, col)] = v.d;
            }
        }
        let b = if inputs {
            self.input_columns(here.params, q, eta)?
        } else {
            DMatrix::zeros(n, 0)
        };
        let tangents = self.tangents(here, &lifted)?;
        let sigma = eta.len();
        let a_gamma = DMatrix::from_fn(sigma, sigma, |i, k| r0.a_gamma[i][k]);
        for (p, t) in &tangents {
            let jt = &j * nalgebra::DVector::from_column_slice(t);
            let allowed = 1e-8 * (1.0 + j.norm()) * norm(t);
            // Not finite is not steady either.
            if !jt.norm().is_finite() || jt.norm() > allowed {
                return Err(StudyError::NotSteady {
                    residuals: format!(
                        "the family is not steady along `{p}`: J·∂x*/∂{p} = {:.3e}",
                        jt.norm()
                    ),
                    largest: jt.norm(),
                    allowed: 1e-8 * (1.0 + j.norm()) * norm(t),
                });
            }
        }
        Ok(Jacobian {
            j,
            b,
            tangents,
            a_gamma,
        })
    }

    /// The dual-number configuration for the direction of the kept coordinate number `col`
    /// (the dependent coordinates follow).
    fn q_direction(&self, col: usize, q: &[f64], sensitivity: &[Vec<f64>]) -> Vec<Dual> {
        let mut dq: Vec<Dual> = q.iter().map(|&v| Dual::new(v, 0.0)).collect();
        let k = self.state_q[col];
        dq[k].d = 1.0;
        for (row, &d) in sensitivity.iter().zip(self.model.completion.dependent()) {
            dq[d].d = row[k];
        }
        dq
    }

    /// ∂ẋ/∂u: one column per input, by dual numbers in the input's value.
    fn input_columns(
        &self,
        params: &IndexMap<String, f64>,
        q: &[f64],
        eta: &[f64],
    ) -> Result<DMatrix<f64>, StudyError> {
        let n = self.state_q.len() + eta.len();
        let inputs = &self.model.inputs;
        let mut b = DMatrix::zeros(n, inputs.len());
        let dq: Vec<Dual> = q.iter().map(|&v| Dual::new(v, 0.0)).collect();
        let deta: Vec<Dual> = eta.iter().map(|&v| Dual::new(v, 0.0)).collect();
        for (col, u) in inputs.iter().enumerate() {
            let p: Vec<Dual> = self
                .compiled
                .parameter_names()
                .map(|name| Dual::new(params[name], f64::from(name == u)))
                .collect();
            let r = self
                .compiled
                .rhs_in::<Dual>(&dq, &deta, &p)
                .map_err(|e| StudyError::Numeric(e.to_string()))?;
            for (row, v) in self.state_rates(&r.q_dot, &r.eta_dot).iter().enumerate() {
                b[(row, col)] = v.d;
            }
        }
        Ok(b)
    }

    /// ∂x*/∂p for every steady parameter p, by dual numbers through the steady state.
    fn tangents(
        &self,
        here: &Here<'_>,
        lifted: &[Dual],
    ) -> Result<Vec<(String, Vec<f64>)>, StudyError> {
        let names = self.steady.parameters.keys();
        names
            .enumerate()
            .map(|(i, p)| {
                let ds: Vec<Dual> = here
                    .s
                    .iter()
                    .enumerate()
                    .map(|(k, &v)| Dual::new(v, f64::from(k == i)))
                    .collect();
                let q = self.steady_q::<Dual>(here.params, &ds, here.at)?;
                // Where the coordinates do not move with p, [Z; α] does not either.
                let map = if q.iter().all(|x| x.d == 0.0) {
                    self.compiled.map_from(lifted)
                } else {
                    self.compiled
                        .quasi_velocity_map::<Dual>(&q, here.params)
                        .map_err(|e| StudyError::Numeric(e.to_string()))?
                };
                let full = self.full_state::<Dual>(here.params, &ds, q, &map)?;
                let x = self.state_rates(&full.q, &full.eta);
                Ok((p.clone(), x.iter().map(|v| v.d).collect()))
            })
            .collect()
    }

    /// An orthonormal basis W of the complement of the family's tangents (the reduced state
    /// is Wᵀx), and its components' names: a state component's when the column is a unit
    /// vector (the tangent was along one component), `z1`… otherwise.
    /// Also the steady parameters whose tangents are directions of their own (a zero tangent,
    /// or one that depends on the others, is not).
    fn complement(&self, jac: &Jacobian) -> Result<Complement, StudyError> {
        let n = jac.j.nrows();
        let mut basis: Vec<nalgebra::DVector<f64>> = Vec::new();
        let tangents = jac.tangents.iter().map(|(p, t)| {
            let v = nalgebra::DVector::from_column_slice(t);
            let size = v.norm();
            (Err(p.clone()), if size > 0.0 { v / size } else { v })
        });
        let units = (0..n).map(|i| {
            (
                Ok(i),
                nalgebra::DVector::from_fn(n, |k, _| f64::from(k == i)),
            )
        });
        let mut kept = Vec::new();
        let mut family = Vec::new();
        for (index, v) in tangents.chain(units) {
            let mut v = v;
            for b in &basis {
                let dot = b.dot(&v);
                if dot != 0.0 {
                    v -= b * dot;
                }
            }
            let size = v.norm();
            // A tangent that depends on earlier ones leaves only rounding: not a direction.
            match index {
                Err(p) if size > 1e-8 => {
                    basis.push(v / size);
                    family.push(p);
                }
                Ok(_) if size > 0.5 => {
                    basis.push(v / size);
                    kept.push(basis.len() - 1);
                }
                _ => {}
            }
        }
        let names = self.state_names();
        let w = DMatrix::from_columns(&kept.iter().map(|&c| basis[c].clone()).collect::<Vec<_>>());
        let labels = (0..w.ncols())
            .map(|c| {
                let col = w.column(c);
                let unit = col.iter().position(|&x| x == 1.0);
                match unit {
                    Some(i) if col.iter().filter(|&&x| x != 0.0).count() == 1 => names[i].clone(),
                    _ => format!("z{}", c + 1),
                }
            })
            .collect();
        Ok(Complement { w, labels, family })
    }
}

/// The reduced state: W (its columns a basis of the complement of the family's tangents),
/// their names, and the steady parameters whose directions were taken out.
struct Complement {
    w: DMatrix<f64>,
    labels: Vec<String>,
    family: Vec<String>,
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
