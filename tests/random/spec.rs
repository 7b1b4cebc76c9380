//! Random mechanical systems (issue 19): what they are made of, how proptest draws them, and
//! the model file each one is written as.
//!
//! Three families, each with exact rational parameters (so that the text is the model):
//! * [`System::Lagrangian`]: 2–4 coordinates, a mass matrix with trigonometric entries
//!   (diagonally dominant, so positive definite), a trigonometric potential, and 1–2 linear
//!   velocity constraints with trigonometric coefficients;
//! * [`System::Chain`]: a planar base (x, y, θ) carrying a chain of 0–2 links, each turned by
//!   its joint coordinate about a random axis (coordinate axes and exact unit vectors), with
//!   random offsets, masses, centres of mass and inertia tensors (products included), gravity
//!   or none, a knife edge under the base and possibly one on the last link;
//! * [`System::Wheel`]: a disk rolling without slipping (the frames of
//!   models/bodies/rolling_disk_bodies.toml) with random radius and inertia, and possibly a
//!   rider on a joint about a random axis through the axle.
//!
//! The bodies families may add one more constraint with trigonometric coefficients
//! (`[constraints]` beside the bodies). The quasi-velocities ([`Choice`]) are hamel's default
//! (independent velocities), those velocities rotated and sheared by functions of a
//! coordinate, or conjugate momenta ∂L/∂q̇ₖ of the default's coordinates (for typed-in systems
//! and a disk without a rider: a chain's momenta are too long for `reduce`'s exact analysis,
//! which has no budget yet).

use std::fmt;

use hamel_model::Kinetic;
use hamel_model::Model;
use proptest::prelude::*;

/// An exact number n/d, written as text.
#[derive(Clone, Copy, Debug)]
pub struct Num(pub i32, pub u32);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.1 {
            1 => write!(f, "{}", self.0),
            d => write!(f, "{}/{d}", self.0),
        }
    }
}

impl Num {
    fn is_zero(self) -> bool {
        self.0 == 0
    }
}

fn num(lo: i32, hi: i32, d: u32) -> impl Strategy<Value = Num> {
    (lo..=hi).prop_map(move |n| Num(n, d))
}

/// a + b sin(q_k) + c cos(q_m), the indices taken modulo the number of coordinates.
#[derive(Clone, Debug)]
pub struct Trig {
    a: Num,
    b: Num,
    c: Num,
    k: usize,
    m: usize,
}

fn trig(scale: u32) -> impl Strategy<Value = Trig> {
    let n = move || num(-2, 2, scale);
    (n(), n(), n(), 0..8usize, 0..8usize).prop_map(|(a, b, c, k, m)| Trig { a, b, c, k, m })
}

/// a + b sin(q_k): one trigonometric term (an added constraint on a chain stays cheap).
fn sparse_trig() -> impl Strategy<Value = Trig> {
    (num(-2, 2, 2), num(-2, 2, 2), 0..8usize).prop_map(|(a, b, k)| Trig {
        a,
        b,
        c: Num(0, 1),
        k,
        m: 0,
    })
}

impl Trig {
    fn text(&self, q: &[String]) -> Option<String> {
        let (k, m) = (&q[self.k % q.len()], &q[self.m % q.len()]);
        let terms: Vec<String> = [
            (self.a, String::new()),
            (self.b, format!("*sin({k})")),
            (self.c, format!("*cos({m})")),
        ]
        .into_iter()
        .filter(|(n, _)| !n.is_zero())
        .map(|(n, f)| format!("({n}){f}"))
        .collect();
        (!terms.is_empty()).then(|| terms.join(" + "))
    }
}

/// A rigid body's mass, centre of mass and inertia about it (diagonally dominant: its
/// diagonal entries are at least 1/10 and the products at most 1/40).
#[derive(Clone, Debug)]
pub struct Body {
    mass: Num,
    com: [Num; 3],
    inertia: [Num; 3],
    products: [Num; 3],
}

fn body() -> impl Strategy<Value = Body> {
    (
        num(1, 4, 2),
        [num(-3, 3, 10), num(-3, 3, 10), num(-3, 3, 10)],
        [num(1, 4, 10), num(1, 4, 10), num(1, 4, 10)],
        [num(-1, 1, 40), num(-1, 1, 40), num(-1, 1, 40)],
    )
        .prop_map(|(mass, com, inertia, products)| Body {
            mass,
            com,
            inertia,
            products,
        })
}

/// Joint axes: the coordinate axes and exact unit vectors.
const AXES: [&str; 8] = [
    "\"x\"",
    "\"y\"",
    "\"z\"",
    "\"-y\"",
    "[\"3/5\", \"4/5\", 0]",
    "[0, \"3/5\", \"-4/5\"]",
    "[\"1/3\", \"2/3\", \"2/3\"]",
    "[\"2/7\", \"-3/7\", \"6/7\"]",
];

/// A link of a chain: its frame's offset from its parent, its joint axis, its body.
#[derive(Clone, Debug)]
pub struct Link {
    origin: [Num; 3],
    axis: usize,
    body: Body,
}

fn link() -> impl Strategy<Value = Link> {
    (
        [num(-3, 3, 10), num(-3, 3, 10), num(-3, 3, 10)],
        0..AXES.len(),
        body(),
    )
        .prop_map(|(origin, axis, body)| Link { origin, axis, body })
}

/// A mechanical system, before its choice of quasi-velocities.
#[derive(Clone, Debug)]
pub enum System {
    /// T = ½ q̇ᵀAq̇ typed in: A's diagonal (d + s sin²), its upper triangle (e + c cos), U.
    Lagrangian {
        ell: usize,
        diagonal: Vec<(Num, Num, usize)>,
        upper: Vec<(Num, Num, usize)>,
        potential: Vec<Num>,
        rows: Vec<Vec<Trig>>,
    },
    /// A planar base with a knife edge, and a chain of links.
    Chain {
        height: Num,
        base: Body,
        links: Vec<Link>,
        blade: (bool, [Num; 2]),
        last_blade: Option<bool>,
        gravity: bool,
    },
    /// A rolling disk, and perhaps a rider.
    Wheel {
        radius: Num,
        disk: Body,
        rider: Option<Link>,
        gravity: bool,
    },
}

/// The quasi-velocities.
#[derive(Clone, Debug)]
pub enum Choice {
    /// hamel's default: σ independent velocities.
    Velocities,
    /// The default's velocities i and j turned by the angle q_angle, and row i sheared by
    /// `shear`·cos(q_angle) times another velocity.
    Rotated {
        i: usize,
        j: usize,
        angle: usize,
        shear: Num,
    },
    /// The conjugate momenta ∂L/∂q̇ₖ of the default's coordinates.
    Momenta,
}

/// A random model: a system, perhaps one more constraint, a choice.
#[derive(Clone, Debug)]
pub struct Spec {
    pub system: System,
    pub extra: Option<Vec<Trig>>,
    pub choice: Choice,
}

/// Drawn at the largest size (4 coordinates, 2 constraints) and cut to `ell` and `mu`, so that
/// no strategy depends on another's value (proptest shrinks such flat strategies well).
fn lagrangian() -> impl Strategy<Value = System> {
    let diagonal = (num(2, 6, 2), num(0, 2, 2), 0..8usize);
    let upper = (num(-1, 1, 10), num(-1, 1, 10), 0..8usize);
    (
        2..=4usize,
        1..=2usize,
        proptest::collection::vec(diagonal, 4),
        proptest::collection::vec(upper, 6),
        proptest::collection::vec(num(-2, 2, 1), 4),
        proptest::collection::vec(proptest::collection::vec(trig(1), 4), 2),
    )
        .prop_map(
            |(ell, mu, mut diagonal, mut upper, mut potential, mut rows)| {
                diagonal.truncate(ell);
                upper.truncate(ell * (ell - 1) / 2);
                potential.truncate(ell);
                rows.truncate(mu.min(ell - 1));
                rows.iter_mut().for_each(|r| r.truncate(ell));
                System::Lagrangian {
                    ell,
                    diagonal,
                    upper,
                    potential,
                    rows,
                }
            },
        )
}

fn chain() -> impl Strategy<Value = System> {
    (
        num(0, 5, 10),
        body(),
        proptest::collection::vec(link(), 0..=2),
        (any::<bool>(), [num(-2, 2, 10), num(-2, 2, 10)]),
        proptest::option::of(any::<bool>()),
        any::<bool>(),
    )
        .prop_map(
            |(height, base, links, blade, last_blade, gravity)| System::Chain {
                height,
                base,
                last_blade: last_blade.filter(|_| !links.is_empty()),
                links,
                blade,
                gravity,
            },
        )
}

fn wheel() -> impl Strategy<Value = System> {
    (
        num(1, 4, 10),
        body(),
        proptest::option::of(link()),
        any::<bool>(),
    )
        .prop_map(|(radius, disk, rider, gravity)| System::Wheel {
            radius,
            disk,
            rider,
            gravity,
        })
}

fn choice() -> impl Strategy<Value = Choice> {
    prop_oneof![
        Just(Choice::Velocities),
        (0..8usize, 0..8usize, 0..8usize, num(-2, 2, 2))
            .prop_map(|(i, j, angle, shear)| { Choice::Rotated { i, j, angle, shear } }),
        Just(Choice::Momenta),
    ]
}

/// The strategy: half hand-typed systems, a third chains, the rest wheels (the slowest to
/// derive); a bodies system gets one more trigonometric constraint one time in four.
pub fn spec() -> impl Strategy<Value = Spec> {
    let system = prop_oneof![3 => lagrangian(), 2 => chain(), 1 => wheel()];
    let extra = proptest::option::weighted(0.25, proptest::collection::vec(sparse_trig(), 6));
    (system, extra, choice()).prop_map(|(system, extra, choice)| {
        let extra = extra.filter(|_| !matches!(system, System::Lagrangian { .. }));
        Spec {
            system,
            extra,
            choice,
        }
    })
}

impl Spec {
    /// A short name for reports: the family and the choice.
    pub fn family(&self) -> String {
        let system = match &self.system {
            System::Lagrangian { .. } => "lagrangian",
            System::Chain { .. } => "chain",
            System::Wheel { .. } => "wheel",
        };
        let choice = match self.choice {
            Choice::Velocities => "velocities",
            Choice::Rotated { .. } => "rotated",
            Choice::Momenta if self.momenta_are_small() => "momenta",
            Choice::Momenta => "rotated",
        };
        format!("{system}/{choice}")
    }

    /// Whether ∂L/∂q̇ is short: typed-in systems, and a disk without a rider.
    fn momenta_are_small(&self) -> bool {
        match &self.system {
            System::Lagrangian { .. } => true,
            System::Wheel { rider, .. } => rider.is_none(),
            System::Chain { .. } => false,
        }
    }

    /// The model file without quasi-velocities (hamel then takes its default).
    pub fn system_text(&self) -> String {
        let mut text = match &self.system {
            System::Lagrangian { .. } => self.lagrangian_text(),
            System::Chain { .. } => self.chain_text(),
            System::Wheel { .. } => self.wheel_text(),
        };
        if let Some(row) = &self.extra {
            let q = coordinates(&text);
            text += &format!("\n[constraints]\nextra = \"{}\"\n", row_text(row, &q));
        }
        text
    }

    /// The whole model file: the system, then the choice `random` (none for the default),
    /// written from the model `base` loaded from [`Spec::system_text`].
    pub fn model_text(&self, base: &Model) -> String {
        let system = self.system_text();
        let Some(eta) = self.eta(base) else {
            return system;
        };
        let rows: Vec<String> = eta.iter().map(|e| format!("  \"{e}\",")).collect();
        format!(
            "{system}\n[quasi_velocities.random]\neta = [\n{}\n]\n",
            rows.join("\n")
        )
    }

    /// The rows of Z, from the default choice's velocities.
    fn eta(&self, base: &Model) -> Option<Vec<String>> {
        let default: Vec<String> = base.choices[0].eta.iter().map(|i| i.text.clone()).collect();
        let q = &base.coordinates;
        match self.choice {
            Choice::Velocities => None,
            Choice::Rotated { i, j, angle, shear } => {
                Some(rotated(&default, q, (i, j, angle), shear))
            }
            // The momenta of a chain of tilted bodies are long expressions whose exact analysis
            // (`reduce`'s dependence tests, which have no budget yet) takes minutes: those
            // systems get their velocities rotated instead.
            Choice::Momenta if self.momenta_are_small() => Some(momenta(&default, base)),
            Choice::Momenta => Some(rotated(&default, q, (0, 1, 2), Num(1, 2))),
        }
    }
}

fn coordinates(text: &str) -> Vec<String> {
    let line = text.lines().find(|l| l.starts_with("coordinates")).unwrap();
    line.split('"')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

fn row_text(row: &[Trig], q: &[String]) -> String {
    let terms: Vec<String> = row
        .iter()
        .zip(q)
        .filter_map(|(t, qk)| t.text(q).map(|c| format!("({c})*der({qk})")))
        .collect();
    if terms.is_empty() {
        format!("der({})", q[0])
    } else {
        terms.join(" + ")
    }
}

/// Rows i and j (mod σ) turned by the angle q_angle; row i sheared along a velocity that is
/// not among the default's. With σ = 1 the one row is scaled by 2 + sin(q_angle).
fn rotated(
    default: &[String],
    q: &[String],
    (i, j, angle): (usize, usize, usize),
    shear: Num,
) -> Vec<String> {
    let sigma = default.len();
    let a = &q[angle % q.len()];
    let mut rows = default.to_vec();
    let (i, mut j) = (i % sigma, j % sigma);
    if i == j {
        j = (i + 1) % sigma;
    }
    if i == j {
        rows[i] = format!("(2 + sin({a}))*{}", default[i]);
    } else {
        let (vi, vj) = (&default[i], &default[j]);
        rows[i] = format!("cos({a})*{vi} + sin({a})*{vj}");
        rows[j] = format!("-sin({a})*{vi} + cos({a})*{vj}");
    }
    if let Some(other) = q.iter().find(|c| !default.contains(&format!("der({c})")))
        && !shear.is_zero()
    {
        rows[i] = format!("{} + ({shear})*cos({a})*der({other})", rows[i]);
    }
    rows
}

/// ∂L/∂q̇ₖ = Σ_j A_kj q̇_j for each coordinate k of the default's velocities.
fn momenta(default: &[String], base: &Model) -> Vec<String> {
    let Kinetic::MassMatrix(a) = &base.kinetic else {
        panic!("the random models give T as a mass matrix");
    };
    default
        .iter()
        .map(|v| {
            let k = base
                .coordinates
                .iter()
                .position(|c| *v == format!("der({c})"))
                .unwrap();
            let terms: Vec<String> = a[k]
                .iter()
                .zip(&base.coordinates)
                .map(|(akj, qj)| format!("({})*der({qj})", akj.expr))
                .collect();
            terms.join(" + ")
        })
        .collect()
}

const HEADER: &str = "name = \"random\"\ntitle = \"a random model (tests/random_models.rs)\"\n";

impl Spec {
    fn lagrangian_text(&self) -> String {
        let System::Lagrangian {
            ell,
            diagonal,
            upper,
            potential,
            rows,
        } = &self.system
        else {
            unreachable!()
        };
        let q: Vec<String> = (1..=*ell).map(|i| format!("q{i}")).collect();
        let mut a = vec![vec![String::new(); *ell]; *ell];
        let mut next = upper.iter();
        for i in 0..*ell {
            let (d, s, k) = diagonal[i];
            a[i][i] = format!("{d} + ({s})*sin({})^2", q[k % ell]);
            for j in i + 1..*ell {
                let (e, c, k) = next.next().unwrap();
                a[i][j] = format!("({e}) + ({c})*cos({})", q[k % ell]);
                a[j][i] = a[i][j].clone();
            }
        }
        let matrix: Vec<String> = a
            .iter()
            .map(|r| format!("  [{}],", quoted(r).join(", ")))
            .collect();
        let u: Vec<String> = potential
            .iter()
            .zip(&q)
            .map(|(u, qk)| format!("({u})*cos({qk})"))
            .collect();
        let constraints: Vec<String> = rows
            .iter()
            .enumerate()
            .map(|(r, row)| format!("c{} = \"{}\"", r + 1, row_text(row, &q)))
            .collect();
        format!(
            "{HEADER}coordinates = [{}]\n\n[lagrangian]\nmass_matrix = [\n{}\n]\npotential = \"{}\"\n\n[constraints]\n{}\n",
            quoted(&q).join(", "),
            matrix.join("\n"),
            u.join(" + "),
            constraints.join("\n")
        )
    }

    fn chain_text(&self) -> String {
        let System::Chain {
            height,
            base,
            links,
            blade,
            last_blade,
            gravity,
        } = &self.system
        else {
            unreachable!()
        };
        let mut q = vec!["x".to_string(), "y".into(), "theta".into()];
        q.extend((1..=links.len()).map(|i| format!("a{i}")));
        let mut t = format!(
            "{HEADER}coordinates = [{}]\n{}\n[frames.base]\norigin = [\"x\", \"y\", \"{height}\"]\nrotations = [{{ axis = \"z\", angle = \"theta\" }}]\n",
            quoted(&q).join(", "),
            world(*gravity)
        );
        t += &body_text("base", "base", base);
        let mut parent = "base".to_string();
        for (i, l) in links.iter().enumerate() {
            let name = format!("link{}", i + 1);
            t += &format!(
                "\n[frames.{name}]\nparent = \"{parent}\"\norigin = [{}]\nrotations = [{{ axis = {}, angle = \"a{}\" }}]\n",
                quoted(&l.origin.map(|n| n.to_string())).join(", "),
                AXES[l.axis],
                i + 1
            );
            t += &body_text(&name, &name, &l.body);
            parent = name;
        }
        let direction = |along_x: bool| if along_x { "x" } else { "y" };
        t += &format!(
            "\n[blades.edge]\nframe = \"base\"\npoint = [\"{}\", \"{}\", 0]\ndirection = \"{}\"\n",
            blade.1[0],
            blade.1[1],
            direction(blade.0)
        );
        if let Some(along_x) = last_blade {
            t += &format!(
                "\n[blades.last]\nframe = \"{parent}\"\ndirection = \"{}\"\n",
                direction(*along_x)
            );
        }
        t
    }

    fn wheel_text(&self) -> String {
        let System::Wheel {
            radius,
            disk,
            rider,
            gravity,
        } = &self.system
        else {
            unreachable!()
        };
        let mut q = vec!["xC", "yC", "phi", "psi", "theta"];
        if rider.is_some() {
            q.push("beta");
        }
        let q: Vec<String> = q.into_iter().map(str::to_string).collect();
        let mut t = format!(
            "{HEADER}coordinates = [{}]\n{}\n[parameters]\nR = {}\n\n{WHEEL_FRAMES}",
            quoted(&q).join(", "),
            world(*gravity),
            radius.0 as f64 / radius.1 as f64
        );
        t += &body_text(
            "disk",
            "disk",
            &Body {
                com: [Num(0, 1); 3],
                ..disk.clone()
            },
        );
        if let Some(l) = rider {
            t += &format!(
                "\n[frames.rider]\nparent = \"lean\"\norigin = [0, 0, \"R\"]\nrotations = [{{ axis = {}, angle = \"beta\" }}]\n",
                AXES[l.axis]
            );
            t += &body_text("rider", "rider", &l.body);
        }
        t + "\n[wheels.disk]\nframe = \"disk\"\naxis = \"y\"\nradius = \"R\"\n"
    }
}

const WHEEL_FRAMES: &str = "[frames.heading]\norigin = [\"xC\", \"yC\", 0]\nrotations = [{ axis = \"z\", angle = \"phi\" }]\n\n[frames.lean]\nparent = \"heading\"\nrotations = [{ axis = \"-x\", angle = \"theta\" }]\n\n[frames.disk]\nparent = \"lean\"\norigin = [0, 0, \"R\"]\nrotations = [{ axis = \"y\", angle = \"psi\" }]\n";

fn world(gravity: bool) -> String {
    if gravity {
        "\n[world]\nup = \"z\"\ngravity = \"981/100\"\n".to_string()
    } else {
        "\n[world]\nup = \"z\"\n".to_string()
    }
}

fn body_text(name: &str, frame: &str, b: &Body) -> String {
    let [xx, yy, zz] = b.inertia;
    let [xy, xz, yz] = b.products;
    format!(
        "\n[bodies.{name}]\nframe = \"{frame}\"\nmass = \"{}\"\ncentre_of_mass = [{}]\ninertia = {{ xx = \"{xx}\", yy = \"{yy}\", zz = \"{zz}\", xy = \"{xy}\", xz = \"{xz}\", yz = \"{yz}\" }}\n",
        b.mass,
        quoted(&b.com.map(|n| n.to_string())).join(", ")
    )
}

fn quoted(v: &[String]) -> Vec<String> {
    v.iter().map(|s| format!("\"{s}\"")).collect()
}
