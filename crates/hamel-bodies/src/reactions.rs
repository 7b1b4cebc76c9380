//! The forces of the contacts (issue 58): how each wheel's and blade's force is read off the
//! multipliers λ of its rows of α, and the virtual displacements that give the normal force of
//! a wheel the frames keep on the ground.
//!
//! * A wheel's rows are the world's horizontal components of its material contact point's
//!   velocity (times `scale`, 1 or |k|): their λ times `scale` are the ground's force on the
//!   wheel along those axes, which the rolling direction e and the lateral one up × e split into
//!   `longitudinal` and `lateral`.
//! * A blade's row is its contact point's velocity along up × direction: λ times that vector's
//!   length is its `lateral` force.
//! * A wheel kept on the ground by a holonomic constraint (`dependent`): its row is dh/dt, the
//!   contact's height rate, which is the vertical velocity of the material contact point (the
//!   contact is the rim's lowest point, so the rate of the rim's material points is stationary
//!   there): its λ is the `normal` force.
//! * A wheel kept on the ground by the frames has no row for its height. Its normal force is
//!   the multiplier of a constraint the coordinates eliminated: [`Support`] releases it. The
//!   frame at the root of the wheel's chain is given a virtual rigid motion p: a heave along up
//!   and two tilts about the world's horizontal axes through its origin. The Lagrange equations
//!   of p at p = ṗ = p̈ = 0 read
//!   A_pq q̈ + Σ_jk (∂A_pj/∂q_k − ½ ∂A_jk/∂p) q̇_j q̇_k − ∂U/∂p − F_p = Σ_i α_ip λ_i + Σ_w G_pw N_w,
//!   with G_pw = ∂h_w/∂p the rate of wheel w's contact height: three equations (Euler's laws of
//!   the whole subtree: its vertical momentum and its two horizontal angular momenta) for the
//!   normal forces N_w of the root's wheels, given q̈ and the other rows' λ.
//!
//! Everything here is exact trees; numbers are the evaluator's (`hamel-eval`).

use hamel_expr::build::{add, mul, neg, sub, sum};
use hamel_expr::{Expr, Func};
use indexmap::IndexMap;

use crate::contact::{Rolling, Row};
use crate::error::{BodiesError, Place, Problem, Section};
use crate::mechanism::{Axis, Direction, Frame, Mechanism, Rotation, WORLD};
use crate::numeric::Point;
use crate::vector::{V3, cross, dot};

/// How the forces of a mechanism's contacts are read off the multipliers of its rows.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactForces {
    /// The wheels and blades, in the description's order (wheels first).
    pub contacts: Vec<Contact>,
    /// One per root frame that carries wheels the frames keep on the ground, once computed
    /// ([`crate::supports`]; [`ContactForces::released`]).
    pub supports: Vec<Support>,
    /// Whether `supports` holds them (true also when no wheel needs one).
    pub released: bool,
}

/// One contact with the ground.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    /// The wheel's or blade's name.
    pub name: String,
    /// What it is, and where its force comes from.
    pub kind: ContactKind,
}

/// A wheel or a blade.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum ContactKind {
    /// A rolling wheel: three components.
    Wheel(WheelForce),
    /// A blade: its lateral force, λ of `row` times `scale`.
    Blade {
        /// The blade's row of α.
        row: String,
        /// The length of up × direction (the row's direction).
        scale: Expr,
    },
}

/// Where a wheel's force comes from.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WheelForce {
    /// Its no-slip rows, one per horizontal world axis (in the axes' order).
    pub rows: Vec<String>,
    /// What the rows were multiplied by: the force along horizontal axis j is λ_j · scale.
    pub scale: Expr,
    /// The rolling direction's components along the same axes (unit, horizontal; towards the
    /// world's +x at the reference configuration q = 0, else +y: forwards, for a vehicle
    /// described facing +x).
    pub rolling: Vec<Expr>,
    /// The lateral direction up × rolling, along the same axes.
    pub lateral: Vec<Expr>,
    /// Its normal force.
    pub normal: Normal,
}

/// Where a wheel's normal force comes from.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Normal {
    /// The multiplier of its contact's holonomic row (named).
    Row(String),
    /// The support released at its root frame: `support`'s normal number `index`.
    Support {
        /// Index into [`ContactForces::supports`].
        support: usize,
        /// Its column of [`Support::heights`].
        index: usize,
    },
}

/// The virtual rigid motion p of one root frame (heave, two tilts) and its Lagrange equations
/// at p = ṗ = p̈ = 0 (see the module doc): row r of
/// `mass`·q̈ + `bias` − Σ_i `rows[i]`·λ_i = Σ_w `heights[r][w]` N_w.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Support {
    /// The root frame.
    pub root: String,
    /// The wheels whose normal forces it gives, in order.
    pub wheels: Vec<String>,
    /// A_pq (3 × ℓ).
    pub mass: Vec<Vec<Expr>>,
    /// Σ_jk (∂A_pj/∂q_k − ½ ∂A_jk/∂p) der(q_j) der(q_k) − ∂U/∂p − F_p (3), in q and der(q).
    pub bias: Vec<Expr>,
    /// α_ip for every row of α with a nonzero entry, by the row's name (3 each).
    pub rows: Vec<(String, Vec<Expr>)>,
    /// G_pw = ∂h_w/∂p (3 × the wheels).
    pub heights: Vec<Vec<Expr>>,
}

impl Contact {
    /// The names of the rows of α its force is read from.
    pub fn rows(&self) -> Vec<&str> {
        match &self.kind {
            ContactKind::Wheel(w) => {
                let mut rows: Vec<&str> = w.rows.iter().map(String::as_str).collect();
                if let Normal::Row(r) = &w.normal {
                    rows.push(r);
                }
                rows
            }
            ContactKind::Blade { row, .. } => vec![row.as_str()],
        }
    }
}

impl ContactForces {
    /// Every expression, for a caller that rewrites them all (parameters fixed, inputs driven).
    pub fn map_exprs(&self, f: &mut dyn FnMut(&Expr) -> Expr) -> ContactForces {
        let mut all = |v: &[Expr]| v.iter().map(&mut *f).collect::<Vec<_>>();
        let contacts = (self.contacts.iter())
            .map(|c| Contact {
                name: c.name.clone(),
                kind: match &c.kind {
                    ContactKind::Wheel(w) => ContactKind::Wheel(WheelForce {
                        rows: w.rows.clone(),
                        scale: all(std::slice::from_ref(&w.scale)).remove(0),
                        rolling: all(&w.rolling),
                        lateral: all(&w.lateral),
                        normal: w.normal.clone(),
                    }),
                    ContactKind::Blade { row, scale } => ContactKind::Blade {
                        row: row.clone(),
                        scale: all(std::slice::from_ref(scale)).remove(0),
                    },
                },
            })
            .collect();
        let supports = (self.supports.iter())
            .map(|s| Support {
                root: s.root.clone(),
                wheels: s.wheels.clone(),
                mass: s.mass.iter().map(|r| all(r)).collect(),
                bias: all(&s.bias),
                rows: (s.rows.iter()).map(|(n, r)| (n.clone(), all(r))).collect(),
                heights: s.heights.iter().map(|r| all(r)).collect(),
            })
            .collect();
        ContactForces {
            contacts,
            supports,
            released: self.released,
        }
    }

    /// Whether there is nothing to report.
    pub fn is_empty(&self) -> bool {
        self.contacts.is_empty()
    }
}

/// A wheel's [`Contact`] from its expansion; `normal` says where its normal force comes from.
pub(crate) fn wheel_contact(name: &str, rolling: &Rolling, up: Axis, normal: Normal) -> Contact {
    let up_vector = up.vector();
    let lateral = cross(&up_vector, &rolling.rolling);
    let horizontal = |v: &V3| {
        (0..3)
            .filter(|&j| j != up.index)
            .map(|j| v[j].clone())
            .collect::<Vec<_>>()
    };
    Contact {
        name: name.to_string(),
        kind: ContactKind::Wheel(WheelForce {
            rows: rolling.rows.iter().map(|r| r.name.clone()).collect(),
            scale: rolling.scale.clone(),
            rolling: horizontal(&rolling.rolling),
            lateral: horizontal(&lateral),
            normal,
        }),
    }
}

/// A blade's [`Contact`]: its row, and the length of the row's direction `across`.
pub(crate) fn blade_contact(name: &str, row: &Row, across: &V3) -> Contact {
    Contact {
        name: name.to_string(),
        kind: ContactKind::Blade {
            row: row.name.clone(),
            scale: Expr::call(Func::Sqrt, dot(across, across)),
        },
    }
}

/// The root of frame `name`'s chain: its ancestor whose parent is the world.
pub(crate) fn root_of(frames: &[Frame], name: &str) -> String {
    let mut at = name.to_string();
    while let Some(f) = frames.iter().find(|f| f.name == at) {
        if f.parent == WORLD {
            break;
        }
        at = f.parent.clone();
    }
    at
}

/// The virtual coordinates of a root frame: heave, tilt about the first horizontal axis, tilt
/// about the second.
fn virtual_coordinates(root: &str) -> [String; 3] {
    ["heave", "tilt1", "tilt2"].map(|p| format!("__support_{root}_{p}"))
}

/// `m` with every root in `roots` given its virtual rigid motion (heave along up, then tilts
/// about the world's horizontal axes, about the root's origin): a frame between the world and
/// the root, whose coordinates follow the mechanism's.
fn released(m: &Mechanism, roots: &[String]) -> Mechanism {
    let mut out = m.clone();
    let up = m.world.up;
    let horizontal: Vec<usize> = (0..3).filter(|&j| j != up.index).collect();
    for root in roots {
        let [heave, tilt1, tilt2] = virtual_coordinates(root);
        let holder = format!("__support_{root}");
        let f = out
            .frames
            .iter_mut()
            .find(|f| &f.name == root)
            .expect("a root");
        let mut origin = std::mem::replace(&mut f.origin, crate::vector::zero());
        origin[up.index] = add(
            origin[up.index].clone(),
            mul(Expr::int(up.sign), Expr::sym(&heave)),
        );
        f.parent = holder.clone();
        let tilt = |index: usize, angle: &str| Rotation {
            axis: Direction::Axis(Axis { index, sign: 1 }),
            angle: Expr::sym(angle),
        };
        out.frames.push(Frame {
            name: holder,
            parent: WORLD.to_string(),
            origin,
            rotations: vec![tilt(horizontal[0], &tilt1), tilt(horizontal[1], &tilt2)],
        });
        out.coordinates.extend([heave, tilt1, tilt2]);
    }
    out
}

/// `e` at p = ṗ = 0 for the virtual coordinates `p`: their symbols and rates replaced by 0, the
/// sines and tangents of 0 by 0 and its cosines by 1, exactly.
fn at_rest(e: &Expr, p: &[String]) -> Expr {
    e.map(&mut |x| match x {
        Expr::Sym(s) | Expr::Der(s) if p.contains(&s) => Expr::int(0),
        Expr::Call(Func::Sin | Func::Tan, a) if a.is_zero_literal() => Expr::int(0),
        Expr::Call(Func::Cos, a) if a.is_zero_literal() => Expr::int(1),
        other => other.tidy_top(),
    })
}

/// What the released mechanism gives: its bodies' motions, U, F, and each wheel's expansion
/// and each blade's row (in order).
pub(crate) struct Released {
    pub bodies: Vec<crate::motion::Motion>,
    pub potential: Expr,
    pub forces: Vec<Expr>,
    pub wheels: Vec<Rolling>,
    pub blades: Vec<Row>,
}

/// The supports of the wheels `kept` (names of the wheels the frames keep on the ground) of
/// `m`; `expand` expands the released mechanism (the same code as the model's own expansion).
pub(crate) fn supports(
    m: &Mechanism,
    kept: &[&str],
    values: &IndexMap<String, f64>,
    expand: &dyn Fn(&Mechanism, &Point) -> Result<Released, BodiesError>,
) -> Result<Vec<Support>, BodiesError> {
    let mut roots: Vec<String> = Vec::new();
    for w in m.wheels.iter().filter(|w| kept.contains(&w.name.as_str())) {
        let root = root_of(&m.frames, &w.frame);
        if !roots.contains(&root) {
            roots.push(root);
        }
    }
    if roots.is_empty() {
        return Ok(Vec::new());
    }
    let aug = released(m, &roots);
    let zeros = vec![0.0; aug.coordinates.len()];
    let reference = Point::at(&aug.coordinates, &zeros, values);
    let at = Releasing {
        m,
        released: expand(&aug, &reference)?,
        virtual_coordinates: aug.coordinates[m.coordinates.len()..].to_vec(),
        coordinates: aug.coordinates.clone(),
    };
    (roots.iter().enumerate())
        .map(|(s, root)| at.support(s, root, kept))
        .collect()
}

/// A mechanism and its expansion released at its roots.
struct Releasing<'m> {
    m: &'m Mechanism,
    released: Released,
    /// The released coordinates: the mechanism's, then three per root.
    coordinates: Vec<String>,
    virtual_coordinates: Vec<String>,
}

impl Releasing<'_> {
    /// `e` at rest in the virtual coordinates.
    fn rest(&self, e: &Expr) -> Expr {
        at_rest(e, &self.virtual_coordinates)
    }

    /// ∂e/∂x; a failure is the wheel `place`'s (it cannot happen for the trees built here).
    fn diff(&self, e: &Expr, x: &str, place: &str) -> Result<Expr, BodiesError> {
        e.diff(x).map_err(|err| {
            BodiesError::new(
                Place::new(Section::Wheels, place, "frame"),
                Problem::Velocity(err),
            )
        })
    }

    /// The support of root number `s`, named `root`.
    fn support(&self, s: usize, root: &str, kept: &[&str]) -> Result<Support, BodiesError> {
        let (m, r) = (self.m, &self.released);
        let ell = m.coordinates.len();
        let p: Vec<usize> = (ell + 3 * s..ell + 3 * s + 3).collect();
        let wheels: Vec<usize> = (0..m.wheels.len())
            .filter(|&i| {
                kept.contains(&m.wheels[i].name.as_str())
                    && root_of(&m.frames, &m.wheels[i].frame) == root
            })
            .collect();
        let place = m.wheels[wheels[0]].name.as_str();
        let mass: Vec<Vec<Expr>> = (p.iter())
            .map(|&pi| (0..ell).map(|j| self.rest(&self.inertia(pi, j))).collect())
            .collect();
        let bias = (p.iter())
            .map(|&pi| self.bias(pi, place))
            .collect::<Result<Vec<_>, _>>()?;
        let heights = (p.iter())
            .map(|&pi| {
                (wheels.iter())
                    .map(|&i| self.rate(&r.wheels[i].height, pi, &m.wheels[i].name))
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Support {
            root: root.to_string(),
            wheels: wheels.iter().map(|&i| m.wheels[i].name.clone()).collect(),
            mass,
            rows: self.rows(&p)?,
            bias,
            heights,
        })
    }

    /// A_pj = Σ_bodies m V_pᵀV_j + W_pᵀ I W_j of the released mechanism.
    fn inertia(&self, p: usize, j: usize) -> Expr {
        sum(self.released.bodies.iter().map(|b| {
            let (v, w) = (&b.v.columns, &b.omega.columns);
            let translation = mul(b.mass.clone(), dot(&v[p], &v[j]));
            match &b.inertia {
                Some(i) => add(translation, dot(&w[p], &crate::vector::apply(i, &w[j]))),
                None => translation,
            }
        }))
    }

    /// ∂e/∂p at rest, p the released coordinate number `p`.
    fn rate(&self, e: &Expr, p: usize, place: &str) -> Result<Expr, BodiesError> {
        Ok(self.rest(&self.diff(e, &self.coordinates[p], place)?))
    }

    /// Σ_jk (∂A_pj/∂q_k − ½ ∂A_jk/∂p) der(q_j) der(q_k) − ∂U/∂p − F_p at rest, as
    /// Σ_k ∂(∂T/∂ṗ)/∂q_k der(q_k) − ∂T/∂p with T and the momentum ∂T/∂ṗ = A_p·q̇ written as
    /// single trees in q and der(q) (ṗ = 0): a few derivatives of them, not ℓ² of A's entries.
    fn bias(&self, p: usize, place: &str) -> Result<Expr, BodiesError> {
        let (q, r) = (&self.m.coordinates, &self.released);
        // q̇ as symbols while differentiating (derivatives are of configuration expressions),
        // der(q) again after
        let rate_of = |qk: &str| format!("__rate_{qk}");
        let rates = |rate: &crate::vector::Rate| -> V3 {
            std::array::from_fn(|i| {
                sum((rate.columns.iter().zip(q))
                    .filter(|(c, _)| !c[i].is_zero_literal())
                    .map(|(c, qk)| mul(c[i].clone(), Expr::sym(&rate_of(qk)))))
            })
        };
        let (mut momentum, mut twice_t) = (Vec::new(), Vec::new());
        for b in &r.bodies {
            let (v, w) = (rates(&b.v), rates(&b.omega));
            let iw = match &b.inertia {
                Some(i) => crate::vector::apply(i, &w),
                None => crate::vector::zero(),
            };
            momentum.push(mul(b.mass.clone(), dot(&b.v.columns[p], &v)));
            momentum.push(dot(&b.omega.columns[p], &iw));
            twice_t.push(mul(b.mass.clone(), dot(&v, &v)));
            twice_t.push(dot(&w, &iw));
        }
        // at rest before differentiating by q (the two commute), once
        let (momentum, twice_t) = (self.rest(&sum(momentum)), sum(twice_t));
        let mut terms = Vec::new();
        for qk in q {
            let d = self.diff(&momentum, qk, place)?;
            if !d.is_zero_literal() {
                terms.push(mul(d, Expr::sym(&rate_of(qk))));
            }
        }
        let half = Expr::Num(hamel_expr::Rational::new(1.into(), 2.into()));
        terms.push(neg(mul(half, self.rate(&twice_t, p, place)?)));
        let inertial = sum(terms).map(&mut |e| match e {
            Expr::Sym(s) => match s.strip_prefix("__rate_") {
                Some(qk) => Expr::Der(qk.to_string()),
                None => Expr::Sym(s),
            },
            other => other,
        });
        let applied = add(self.rate(&r.potential, p, place)?, self.rest(&r.forces[p]));
        Ok(sub(inertial, applied))
    }

    /// α_ip at rest for the released coordinates `p`, for every row with a nonzero entry: the
    /// wheels' and blades' rows, and the rates of the contact heights of the wheels on a
    /// holonomic contact (the rows `NAME_contact`; the other holonomic constraints are in q
    /// alone, which the release does not move).
    fn rows(&self, p: &[usize]) -> Result<Vec<(String, Vec<Expr>)>, BodiesError> {
        let (m, r) = (self.m, &self.released);
        let mut rows = Vec::new();
        let contact_rows = (r.wheels.iter().flat_map(|w| &w.rows)).chain(&r.blades);
        for row in contact_rows {
            let entries: Vec<Expr> = p
                .iter()
                .map(|&pi| self.rest(&row.coefficients[pi]))
                .collect();
            rows.push((row.name.clone(), entries));
        }
        for (w, rolling) in m.wheels.iter().zip(&r.wheels) {
            if w.dependent.is_some() {
                let entries = (p.iter())
                    .map(|&pi| self.rate(&rolling.height, pi, &w.name))
                    .collect::<Result<Vec<_>, _>>()?;
                rows.push((format!("{}_contact", w.name), entries));
            }
        }
        rows.retain(|(_, e)| e.iter().any(|x| !x.is_zero_literal()));
        Ok(rows)
    }
}
