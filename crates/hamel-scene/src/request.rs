//! What a scene asks for: `request = [...]` resolved against the model (when absent: every
//! coordinate, η, the energy and the expressions).
//!
//! The constraint residual α(q)q̇ is computed only when named. For hamel's velocities
//! q̇ = Γ(q)η it vanishes identically (αΓ = 0 is how Γ is built, checked exactly at the
//! derivation), so evaluated along a run it shows only the rounding of α and Γ, at the price
//! of both at every output: on the knife, whose right-hand side is four operations, that
//! price is a fifth of the run (docs/performance.md).
//!
//! The constraint forces (`force.NAME.COMPONENT`, `force.NAME`) are computed only when named,
//! at the output times; they keep every coordinate in the state, as the constraint residual
//! does: their components are evaluated at the full configuration.

use hamel_model::Coord;

use crate::forces::ForceOutput;

/// What a scene asks for (`request = [...]`; see the module doc for the default).
#[derive(Clone, Debug)]
pub struct Request {
    /// Requested coordinates.
    pub coordinates: Vec<Coord>,
    /// η requested.
    pub eta: bool,
    /// The energy requested.
    pub energy: bool,
    /// The constraint residual α(q)q̇ requested.
    pub constraint_residual: bool,
    /// The scene's `[expressions]` requested, by index.
    pub expressions: Vec<usize>,
    /// Coordinates the requested expressions need (kept in the state, not written).
    pub needed: Vec<Coord>,
    /// The constraint forces requested (`force.NAME.COMPONENT`, `force.NAME`), as written;
    /// checked against the model by [`crate::check`], resolved by [`crate::forces::Forces`].
    pub forces: Vec<ForceOutput>,
    /// The scene's `[friction]` monitor is on (the forces are computed for it).
    pub friction: bool,
}

impl Request {
    /// Whether the constraint forces are computed: requested, or watched by `[friction]`.
    pub fn computes_forces(&self) -> bool {
        !self.forces.is_empty() || self.friction
    }

    /// The default: every coordinate, η, the energy and every expression; not the constraint
    /// residual (module doc).
    pub fn default_outputs(ell: usize, expressions: usize) -> Request {
        Request {
            coordinates: (0..ell).map(Coord::new).collect(),
            eta: true,
            energy: true,
            constraint_residual: false,
            expressions: (0..expressions).collect(),
            needed: Vec::new(),
            forces: Vec::new(),
            friction: false,
        }
    }

    /// Parse the names of `request`: coordinates, `eta` (or `eta1`…, which all mean η: it is
    /// integrated whole), `energy`, `constraint_residual`, `force.NAME.COMPONENT` and
    /// `force.NAME` (checked against the model later), the names of the scene's
    /// `expressions`. Errors name the unknown entry and list the valid ones.
    pub fn parse(
        names: &[String],
        coordinates: &[String],
        sigma: usize,
        expressions: &[String],
    ) -> Result<Request, String> {
        let mut r = Request {
            coordinates: Vec::new(),
            eta: false,
            energy: false,
            constraint_residual: false,
            expressions: Vec::new(),
            needed: Vec::new(),
            forces: Vec::new(),
            friction: false,
        };
        for n in names {
            if let Some(k) = coordinates.iter().position(|c| c == n).map(Coord::new) {
                if !r.coordinates.contains(&k) {
                    r.coordinates.push(k);
                }
            } else if n == "eta"
                || n.strip_prefix("eta")
                    .and_then(|i| i.parse::<usize>().ok())
                    .is_some_and(|i| (1..=sigma).contains(&i))
            {
                r.eta = true;
            } else if n == "energy" {
                r.energy = true;
            } else if n == "constraint_residual" {
                r.constraint_residual = true;
            } else if let Some(f) = ForceOutput::parse(n) {
                if !r.forces.contains(&f) {
                    r.forces.push(f);
                }
            } else if let Some(i) = expressions.iter().position(|e| e == n) {
                if !r.expressions.contains(&i) {
                    r.expressions.push(i);
                }
            } else {
                return Err(format!(
                    "`{n}` is not an output of this scene: use coordinates ({}), eta (or eta1..eta{}), energy, constraint_residual, force.NAME.COMPONENT{}",
                    coordinates.join(", "),
                    sigma,
                    if expressions.is_empty() {
                        ", or a name defined in [expressions]".to_string()
                    } else {
                        format!(", or an expression ({})", expressions.join(", "))
                    }
                ));
            }
        }
        r.coordinates.sort_unstable();
        Ok(r)
    }
}
