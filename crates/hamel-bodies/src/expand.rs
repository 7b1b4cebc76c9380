//! The whole expansion: the kinetic energy's matrix A, the potential U, the rows of α and the
//! holonomic constraints of a [`Mechanism`], with the checks the description allows at the
//! default parameters.
//!
//! * A = Σ_bodies m V_kᵀV_j + W_kᵀ I W_j, with V_k, W_k the velocity of the centre of mass and
//!   the angular velocity per unit q̇_k (T = ½ q̇ᵀAq̇);
//! * U = −Σ_bodies m g height(centre of mass) − Σ_springs ½ k (d − d₀)² (L = T + U, the
//!   applied force is +∇U);
//! * F: the loads' and the dampers' generalised forces (`loads`, `elements`);
//! * α: the rows of the wheels and blades, then one row dh/dt = Σ_k ∂h/∂q_k q̇_k per holonomic
//!   constraint.

use hamel_expr::Expr;
use hamel_expr::build::{add, neg, product, sum};
use indexmap::IndexMap;

use crate::contact::{self, Row};
use crate::error::{BodiesError, Place, Problem, Section};
use crate::frames::{self, Tree};
use crate::mechanism::{Body, Direction, Mechanism, Surface};
use crate::motion::Motion;
use crate::numeric::{Completion, CompletionError, Point};
use crate::reactions;
use crate::vector::{Rate, dot};

/// A holonomic constraint of the expansion.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct HolonomicConstraint {
    /// Its name (a wheel's `NAME_contact`, or the key under `[holonomic]`).
    pub name: String,
    /// h(q) = 0.
    pub h: Expr,
    /// The coordinate it determines.
    pub dependent: String,
    /// Its velocity row, when not dh/dt: a multiple of it by a positive factor, free of the
    /// square roots dh/dt would divide by (an ellipsoid's contact); one entry per coordinate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate: Option<Vec<Expr>>,
}

/// A mechanism as L = T + U and α.
#[derive(Clone, Debug)]
pub struct Expansion {
    /// A (ℓ×ℓ, symmetric): T = ½ q̇ᵀAq̇.
    pub mass_matrix: Vec<Vec<Expr>>,
    /// U.
    pub potential: Expr,
    /// The generalised forces F of the loads, one per coordinate (zeros without loads).
    pub forces: Vec<Expr>,
    /// The rows of α, in order: wheels, blades, holonomic constraints.
    pub rows: Vec<Row>,
    /// The holonomic constraints (their velocity rows are among `rows`).
    pub holonomic: Vec<HolonomicConstraint>,
    /// How the expansion simplified what it could not leave exact in general.
    pub notes: Vec<String>,
    /// Solves the holonomic constraints for their dependent coordinates.
    pub completion: Completion,
    /// Symmetries the construction suggests ([`crate::vertical_rotation`]): candidates, to be
    /// checked exactly by whoever uses them.
    pub symmetries: Vec<crate::Symmetry>,
    /// How the contacts' forces are read off the multipliers of their rows (issue 58).
    pub contact_forces: reactions::ContactForces,
}

/// Expand `m` at the default parameter values `values`. `samples`: configurations where a
/// wheel without a dependent coordinate must touch the ground.
pub fn expand(
    m: &Mechanism,
    values: &IndexMap<String, f64>,
    samples: &[Vec<f64>],
) -> Result<Expansion, BodiesError> {
    let ell = m.coordinates.len();
    let zeros = vec![0.0; ell];
    let reference = Point::at(&m.coordinates, &zeros, values);
    check_world(m, &reference)?;
    check_rotations(m, &reference)?;
    let tree = frames::build(m)?;
    let (a, potential) = inertia_and_potential(&tree, m, &reference)?;
    let mut rolling = wheels(m, &tree, values, samples, &reference)?;
    rollers(m, &tree, values, samples, &reference, &mut rolling)?;
    for b in &m.blades {
        check_frame(&tree, Section::Blades, &b.name, &b.frame)?;
        check_direction(&b.direction, &reference)
            .map_err(|e| BodiesError::new(Place::new(Section::Blades, &b.name, "direction"), e))?;
        let (row, across) = contact::blade(&tree, b, &reference)?;
        rolling
            .forces
            .push(reactions::blade_contact(&b.name, &row, &across));
        rolling.rows.push(row);
    }
    rolling
        .holonomic
        .extend(m.holonomic.iter().map(|c| HolonomicConstraint {
            name: c.name.clone(),
            h: c.h.clone(),
            dependent: c.dependent.clone(),
            rate: None,
        }));
    let place = |c: &HolonomicConstraint, field| holonomic_place(m, c, field);
    let holonomic = holonomic_rows(&m.coordinates, &rolling.holonomic, values, &place)?;
    rolling.holonomic = holonomic.kept(std::mem::take(&mut rolling.holonomic));
    let HolonomicRows {
        rows, completion, ..
    } = holonomic;
    rolling.rows.extend(rows);
    let forces = applied_forces(&tree, m, &reference)?;
    let contact_forces = reactions::ContactForces {
        supports: Vec::new(),
        released: !m.wheels.iter().any(|w| w.dependent.is_none()),
        contacts: rolling.forces,
    };
    Ok(Expansion {
        mass_matrix: a,
        potential,
        forces,
        rows: rolling.rows,
        holonomic: rolling.holonomic,
        notes: rolling.notes,
        completion,
        symmetries: crate::vertical_rotation(m).into_iter().collect(),
        contact_forces,
    })
}

/// The supports of `m`'s wheels that the frames keep on the ground ([`reactions::Support`]):
/// what their normal forces need, which [`expand`] leaves out (it costs a second expansion and
/// a few derivatives of large trees: a command that reports no constraint forces does not pay
/// for it). `values`: the default parameters.
pub fn supports(
    m: &Mechanism,
    values: &IndexMap<String, f64>,
) -> Result<Vec<reactions::Support>, BodiesError> {
    let kept: Vec<&str> = (m.wheels.iter())
        .filter(|w| w.dependent.is_none())
        .map(|w| w.name.as_str())
        .collect();
    reactions::supports(m, &kept, values, &released)
}

/// A (Σ_bodies) and U (the bodies' weights, then the springs).
fn inertia_and_potential(
    tree: &Tree,
    m: &Mechanism,
    reference: &Point,
) -> Result<(Vec<Vec<Expr>>, Expr), BodiesError> {
    let ell = m.coordinates.len();
    let mut a = vec![vec![Expr::int(0); ell]; ell];
    let mut potential = Expr::int(0);
    for b in &m.bodies {
        let (va, u) = body(tree, m, b, reference)?;
        for (row, add_row) in a.iter_mut().zip(va) {
            for (x, y) in row.iter_mut().zip(add_row) {
                *x = add(std::mem::replace(x, Expr::int(0)), y);
            }
        }
        potential = add(potential, u);
    }
    if !m.springs.is_empty() {
        potential = add(
            potential,
            crate::elements::spring_potential(tree, m, reference)?,
        );
    }
    Ok((a, potential))
}

/// F: the loads', then the dampers' generalised forces.
fn applied_forces(tree: &Tree, m: &Mechanism, reference: &Point) -> Result<Vec<Expr>, BodiesError> {
    let mut forces = crate::loads::generalised_forces(tree, m)?;
    for (f, d) in forces
        .iter_mut()
        .zip(crate::elements::damper_forces(tree, m, reference)?)
    {
        if !d.is_zero_literal() {
            *f = add(std::mem::replace(f, Expr::int(0)), d);
        }
    }
    Ok(forces)
}

/// The expansion of a mechanism released at its supports ([`reactions::supports`]): A, U, F
/// and every contact's rows, without the checks (the mechanism passed them unreleased).
fn released(m: &Mechanism, reference: &Point) -> Result<reactions::Released, BodiesError> {
    let tree = frames::build(m)?;
    let bodies = (m.bodies.iter())
        .map(|b| motion(&tree, m, b, reference))
        .collect::<Result<Vec<_>, _>>()?;
    let mut potential = sum(bodies.iter().map(|b| {
        neg(product([
            b.mass.clone(),
            m.world.gravity.clone(),
            b.height.clone(),
        ]))
    }));
    if !m.springs.is_empty() {
        let springs = crate::elements::spring_potential(&tree, m, reference)?;
        potential = add(potential, springs);
    }
    let wheels = (m.wheels.iter())
        .map(|w| contact::wheel(&tree, &m.frames, w, &m.coordinates, reference))
        .collect::<Result<Vec<_>, _>>()?;
    let blades = (m.blades.iter())
        .map(|b| contact::blade(&tree, b, reference).map(|(row, _)| row))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(reactions::Released {
        bodies,
        potential,
        forces: applied_forces(&tree, m, reference)?,
        wheels,
        blades,
    })
}

/// What the contacts give: rows of α, holonomic constraints, notes, and how their forces are
/// read off the rows' multipliers.
#[derive(Default)]
struct Contacts {
    rows: Vec<Row>,
    holonomic: Vec<HolonomicConstraint>,
    notes: Vec<String>,
    forces: Vec<reactions::Contact>,
}

fn world_error(p: Problem) -> BodiesError {
    BodiesError::new(
        Place {
            section: Section::World,
            name: None,
            field: "gravity",
        },
        p,
    )
}

fn check_world(m: &Mechanism, at: &Point) -> Result<(), BodiesError> {
    at.value(&m.world.gravity).map(|_| ()).map_err(world_error)
}

fn check_rotations(m: &Mechanism, at: &Point) -> Result<(), BodiesError> {
    for f in &m.frames {
        for r in &f.rotations {
            check_direction(&r.axis, at).map_err(|e| {
                BodiesError::new(Place::new(Section::Frames, &f.name, "rotations"), e)
            })?;
        }
    }
    Ok(())
}

fn check_frame(tree: &Tree, section: Section, name: &str, frame: &str) -> Result<(), BodiesError> {
    if tree.contains(frame) {
        Ok(())
    } else {
        let place = Place::new(section, name, "frame");
        Err(BodiesError::new(
            place,
            Problem::UnknownFrame(frame.to_string()),
        ))
    }
}

/// A body's motion ([`Motion`]), checked.
pub(crate) fn motion(
    tree: &Tree,
    m: &Mechanism,
    b: &Body,
    at: &Point,
) -> Result<Motion, BodiesError> {
    check_frame(tree, Section::Bodies, &b.name, &b.frame)?;
    check_body(b, at)?;
    let symmetric = |i: usize| {
        b.inertia
            .as_ref()
            .is_none_or(|inertia| inertia.is_symmetric_about(i))
    };
    let place = Place::new(Section::Bodies, &b.name, "frame");
    let carried = crate::carry::carry(
        tree,
        &m.frames,
        &b.frame,
        b.centre_of_mass.clone(),
        &symmetric,
        &m.coordinates,
    )
    .map_err(|e| BodiesError::new(place.clone(), e))?;
    let v: Rate = carried
        .velocity(&m.coordinates)
        .map_err(|e| BodiesError::new(place, e))?;
    Ok(Motion {
        mass: b.mass.clone(),
        omega: carried.omega(),
        v,
        inertia: b.inertia.as_ref().map(|i| i.matrix()),
        height: carried.height(),
    })
}

/// A body's share of A and of U.
fn body(
    tree: &Tree,
    m: &Mechanism,
    b: &Body,
    at: &Point,
) -> Result<(Vec<Vec<Expr>>, Expr), BodiesError> {
    let motion = motion(tree, m, b, at)?;
    let u = neg(product([
        b.mass.clone(),
        m.world.gravity.clone(),
        motion.height.clone(),
    ]));
    Ok((motion.mass_matrix(), u))
}

/// Mass positive and inertia positive definite at the defaults.
fn check_body(b: &Body, at: &Point) -> Result<(), BodiesError> {
    let place = |field| Place::new(Section::Bodies, &b.name, field);
    let mass = at
        .value(&b.mass)
        .map_err(|e| BodiesError::new(place("mass"), e))?;
    if mass <= 0.0 {
        return Err(BodiesError::new(place("mass"), Problem::Mass(mass)));
    }
    let Some(inertia) = &b.inertia else {
        return Ok(());
    };
    let i = inertia.matrix();
    let mut n = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            n[r][c] = at
                .value(&i[r][c])
                .map_err(|e| BodiesError::new(place("inertia"), e))?;
        }
    }
    let minors = [
        n[0][0],
        n[0][0] * n[1][1] - n[0][1] * n[1][0],
        n[0][0] * (n[1][1] * n[2][2] - n[1][2] * n[2][1])
            - n[0][1] * (n[1][0] * n[2][2] - n[1][2] * n[2][0])
            + n[0][2] * (n[1][0] * n[2][1] - n[1][1] * n[2][0]),
    ];
    if let Some(k) = minors.iter().position(|&d| d <= 0.0) {
        let detail = format!("leading minor {} is {:.6e}", k + 1, minors[k]);
        return Err(BodiesError::new(place("inertia"), Problem::Inertia(detail)));
    }
    Ok(())
}

/// A direction of unit length at the defaults (coordinate axes are).
pub(crate) fn check_direction(d: &Direction, at: &Point) -> Result<(), Problem> {
    if let Direction::Vector(v) = d {
        let length = at.value(&dot(v, v))?.sqrt();
        if length == 0.0 {
            return Err(Problem::ZeroAxis);
        }
        if (length - 1.0).abs() > 1e-12 {
            return Err(Problem::NotUnit(length));
        }
    }
    Ok(())
}

fn wheels(
    m: &Mechanism,
    tree: &Tree,
    values: &IndexMap<String, f64>,
    samples: &[Vec<f64>],
    reference: &Point,
) -> Result<Contacts, BodiesError> {
    let mut out = Contacts::default();
    let mut supports = Supports::default();
    for w in &m.wheels {
        let place = |field| Place::new(Section::Wheels, &w.name, field);
        check_frame(tree, Section::Wheels, &w.name, &w.frame)?;
        check_direction(&w.axis, reference).map_err(|e| BodiesError::new(place("axis"), e))?;
        let r = reference
            .value(&w.radius)
            .map_err(|e| BodiesError::new(place("radius"), e))?;
        if r <= 0.0 {
            return Err(BodiesError::new(place("radius"), Problem::Radius(r)));
        }
        if let Some(crown) = &w.crown {
            let rho = reference
                .value(crown)
                .map_err(|e| BodiesError::new(place("crown"), e))?;
            if !(0.0..r).contains(&rho) {
                // Shown to 12 digits: 0.15 - 0.1 is 0.05, not 0.04999999999999999.
                let shown = |x: f64| format!("{x:.12}").parse::<f64>().unwrap_or(x);
                let problem = Problem::Crown {
                    crown: shown(rho),
                    radius: shown(r),
                };
                return Err(BodiesError::new(place("crown"), problem));
            }
        }
        let rolling = contact::wheel(tree, &m.frames, w, &m.coordinates, reference)?;
        let normal = match &w.dependent {
            Some(q) => {
                let name = format!("{}_contact", w.name);
                out.holonomic.push(HolonomicConstraint {
                    name: name.clone(),
                    h: rolling.height.clone(),
                    dependent: q.clone(),
                    rate: None,
                });
                reactions::Normal::Row(name)
            }
            None => {
                let place = (place("dependent"), "wheel");
                on_the_ground(m, place, &w.radius, &rolling.height, values, samples)?;
                supports.next(reactions::root_of(&m.frames, &w.frame))
            }
        };
        out.forces
            .push(reactions::wheel_contact(&w.name, &rolling, tree.up, normal));
        out.rows.extend(rolling.rows);
        out.notes
            .extend(rolling.note.map(|n| format!("wheel {}: {n}", w.name)));
    }
    Ok(out)
}

/// The rolling bodies' rows and height constraints (issue 62). Their contact forces are not
/// read off yet: they are not among `forces`.
fn rollers(
    m: &Mechanism,
    tree: &Tree,
    values: &IndexMap<String, f64>,
    samples: &[Vec<f64>],
    reference: &Point,
    out: &mut Contacts,
) -> Result<(), BodiesError> {
    for r in &m.rollers {
        let place = |field| Place::new(Section::Rolling, &r.name, field);
        check_frame(tree, Section::Rolling, &r.name, &r.frame)?;
        let size =
            check_surface(&r.surface, reference).map_err(|e| BodiesError::new(place(e.0), e.1))?;
        let touching = contact::roller(tree, &m.frames, r, &m.coordinates)?;
        match &r.dependent {
            Some(q) if !mentions(&touching.height, q) => {
                return Err(BodiesError::new(
                    place("dependent"),
                    Problem::HeightFree(q.clone()),
                ));
            }
            Some(q) => out.holonomic.push(HolonomicConstraint {
                name: format!("{}_contact", r.name),
                h: touching.height.clone(),
                dependent: q.clone(),
                rate: touching.height_rate,
            }),
            None => {
                let at = (place("dependent"), "rolling body");
                on_the_ground(m, at, &size, &touching.height, values, samples)?;
            }
        }
        out.rows.extend(touching.rows);
        out.notes.extend(
            touching
                .note
                .map(|n| format!("rolling body {}: {n}", r.name)),
        );
    }
    Ok(())
}

/// Whether `e` holds the symbol `name` (where it does not, `e` does not depend on it).
fn mentions(e: &Expr, name: &str) -> bool {
    e.any(&mut |x| matches!(x, Expr::Sym(s) if s == name))
}

/// A surface's sizes are positive at the defaults; its largest size (for tolerances), or the
/// field at fault and why.
fn check_surface(s: &Surface, at: &Point) -> Result<Expr, (&'static str, Problem)> {
    match s {
        Surface::Sphere { radius } => {
            let r = at.value(radius).map_err(|e| ("sphere", e))?;
            if r <= 0.0 {
                return Err(("sphere", Problem::Radius(r)));
            }
            Ok(radius.clone())
        }
        Surface::Ellipsoid { semi_axes } => {
            let mut largest = (0.0, 0);
            for (i, axis) in ["x", "y", "z"].into_iter().enumerate() {
                let value = at.value(&semi_axes[i]).map_err(|e| ("ellipsoid", e))?;
                if value <= 0.0 {
                    return Err(("ellipsoid", Problem::SemiAxis { axis, value }));
                }
                if value > largest.0 {
                    largest = (value, i);
                }
            }
            Ok(semi_axes[largest.1].clone())
        }
    }
}

/// Numbers the supports as [`reactions::supports`] does: roots in the order of their first
/// wheel kept on the ground by the frames, each root's such wheels in order.
#[derive(Default)]
struct Supports {
    roots: Vec<(String, usize)>,
}

impl Supports {
    /// The normal force of the next wheel kept by the frames, on `root`.
    fn next(&mut self, root: String) -> reactions::Normal {
        let support = match self.roots.iter().position(|(r, _)| *r == root) {
            Some(s) => s,
            None => {
                self.roots.push((root, 0));
                self.roots.len() - 1
            }
        };
        let index = self.roots[support].1;
        self.roots[support].1 += 1;
        reactions::Normal::Support { support, index }
    }
}

/// A contact without a dependent coordinate must touch the ground at every sample (its frames
/// keep it there by construction). `size`: the contact's scale (a radius) for the tolerance;
/// `what`: a wheel or a rolling body, at `place`.
fn on_the_ground(
    m: &Mechanism,
    (place, what): (Place, &'static str),
    size: &Expr,
    h: &Expr,
    values: &IndexMap<String, f64>,
    samples: &[Vec<f64>],
) -> Result<(), BodiesError> {
    for q in samples {
        let at = Point::at(&m.coordinates, q, values);
        let height = at
            .value(h)
            .map_err(|e| BodiesError::new(place.clone(), e))?;
        let scale = at
            .value(size)
            .map_err(|e| BodiesError::new(place.clone(), e))?;
        if height.abs() > 1e-12 * scale.abs().max(1.0) {
            return Err(BodiesError::new(
                place,
                Problem::OffGround {
                    what,
                    height,
                    at: q.clone(),
                },
            ));
        }
    }
    Ok(())
}

/// The holonomic constraints' velocity rows dh/dt = Σ_k ∂h/∂q_k q̇_k, in order (every
/// constraint's, the implied ones' too: the rank of α drops theirs as dependent rows, with the
/// exact combination), and the completion that solves the others for their dependent
/// coordinates, which must succeed at the reference configuration q = 0.
pub struct HolonomicRows {
    /// dh/dt of every constraint, in order.
    pub rows: Vec<Row>,
    /// Newton's method on the constraints that are not implied.
    pub completion: Completion,
    /// The indices of the constraints implied by those before them: their Jacobian by the
    /// dependent coordinates is singular with the others, and they hold wherever the others
    /// do (at the reference configuration and at samples). Their dependent coordinate is free.
    pub implied: Vec<usize>,
}

impl HolonomicRows {
    /// The items of `all` (one per constraint, in order) of the constraints not implied: those
    /// the completion solves, which the model keeps as its holonomic constraints.
    pub fn kept<T>(&self, all: Vec<T>) -> Vec<T> {
        (all.into_iter().enumerate())
            .filter(|(i, _)| !self.implied.contains(i))
            .map(|(_, c)| c)
            .collect()
    }
}

/// [`HolonomicRows`] of `constraints`; `place` says where each was declared.
pub fn holonomic_rows(
    coordinates: &[String],
    constraints: &[HolonomicConstraint],
    values: &IndexMap<String, f64>,
    place: &dyn Fn(&HolonomicConstraint, &'static str) -> Place,
) -> Result<HolonomicRows, BodiesError> {
    let mut rows = Vec::new();
    let (mut kept, mut dependent, mut implied) = (Vec::new(), Vec::new(), Vec::new());
    for (i, c) in constraints.iter().enumerate() {
        let coefficients = match &c.rate {
            Some(rate) => rate.clone(),
            None => (coordinates.iter())
                .map(|q| c.h.diff(q))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| BodiesError::new(place(c, "h"), e))?,
        };
        rows.push(Row {
            name: c.name.clone(),
            coefficients,
        });
        let at = place(c, "dependent");
        let j = coordinates
            .iter()
            .position(|q| *q == c.dependent)
            .ok_or_else(|| {
                BodiesError::new(at.clone(), Problem::UnknownCoordinate(c.dependent.clone()))
            })?;
        let twice = dependent.contains(&j);
        let mut failure = None;
        if !twice {
            let with = completion_of(coordinates, constraints, &kept, Some(i), &dependent, j)
                .map_err(|p| BodiesError::new(at.clone(), p))?;
            let mut q = vec![0.0; coordinates.len()];
            match with.complete(&mut q, values) {
                Ok(()) => {
                    kept.push(i);
                    dependent.push(j);
                    continue;
                }
                Err(e @ CompletionError::Singular(_)) => failure = Some(e),
                Err(e) => return Err(undetermined(constraints, &kept, i, at, &e)),
            }
        }
        if is_implied(coordinates, constraints, &kept, &dependent, i, values) {
            implied.push(i);
        } else if let Some(e) = failure {
            return Err(undetermined(constraints, &kept, i, at, &e));
        } else {
            return Err(BodiesError::new(
                at,
                Problem::DependentTwice(c.dependent.clone()),
            ));
        }
    }
    let completion = completion_of(coordinates, constraints, &kept, None, &dependent, 0)
        .map_err(|p| BodiesError::new(place(&constraints[0], "h"), p))?;
    Ok(HolonomicRows {
        rows,
        completion,
        implied,
    })
}

/// Constraint `i` does not determine its coordinate with the constraints `kept` before it.
fn undetermined(
    constraints: &[HolonomicConstraint],
    kept: &[usize],
    i: usize,
    at: Place,
    e: &CompletionError,
) -> BodiesError {
    let names: Vec<&str> = (kept.iter().chain([&i]))
        .map(|&k| constraints[k].dependent.as_str())
        .collect();
    BodiesError::new(
        at,
        Problem::Undetermined {
            coordinate: names.join(", "),
            reason: e.to_string(),
        },
    )
}

/// The completion of the constraints `kept` (for the coordinates `dependent`), with `extra`
/// (for the coordinate `j`) after them.
fn completion_of(
    coordinates: &[String],
    constraints: &[HolonomicConstraint],
    kept: &[usize],
    extra: Option<usize>,
    dependent: &[usize],
    j: usize,
) -> Result<Completion, Problem> {
    let h = (kept.iter().chain(extra.as_ref()))
        .map(|&k| constraints[k].h.clone())
        .collect();
    let mut d = dependent.to_vec();
    d.extend(extra.map(|_| j));
    Completion::new(coordinates, h, d)
}

/// Whether constraint `i` holds wherever the constraints `kept` do: at their completion from
/// q = 0 and from three other starting configurations (a numeric test; the exact dependence
/// of its row is decided with the other rows of α).
fn is_implied(
    coordinates: &[String],
    constraints: &[HolonomicConstraint],
    kept: &[usize],
    dependent: &[usize],
    i: usize,
    values: &IndexMap<String, f64>,
) -> bool {
    let Ok(base) = completion_of(coordinates, constraints, kept, None, dependent, 0) else {
        return false;
    };
    let Ok(this) = completion_of(coordinates, &constraints[i..=i], &[0], None, &[0], 0) else {
        return false;
    };
    let ell = coordinates.len();
    (0..4).all(|s| {
        let mut q: Vec<f64> = (0..ell)
            .map(|k| {
                if s == 0 {
                    0.0
                } else {
                    ((k * 7 + s * 3) % 11) as f64 / 11.0 - 0.45
                }
            })
            .collect();
        base.complete(&mut q, values).is_ok()
            && this
                .residual(&q, values)
                .is_ok_and(|r| r <= 1e-10 * (1.0 + q.iter().fold(0.0_f64, |m, x| m.max(x.abs()))))
    })
}

/// Where a holonomic constraint of a mechanism was declared: a wheel's `dependent`, or
/// `[holonomic.NAME]`.
fn holonomic_place(m: &Mechanism, c: &HolonomicConstraint, field: &'static str) -> Place {
    let contact = |name: &str| format!("{name}_contact") == c.name;
    if let Some(w) = m.wheels.iter().find(|w| contact(&w.name)) {
        return Place::new(Section::Wheels, &w.name, "dependent");
    }
    match m.rollers.iter().find(|r| contact(&r.name)) {
        Some(r) => Place::new(Section::Rolling, &r.name, "dependent"),
        None => Place::new(Section::Holonomic, &c.name, field),
    }
}
