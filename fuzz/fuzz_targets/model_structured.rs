//! Models built from structure, not bytes: `arbitrary` draws coordinates, parameters, and
//! either a Lagrangian (T, U, constraints, choices of quasi-velocities) or a mechanism (frames
//! with rotations and origins, bodies, wheels, blades, a wheel's dependent coordinate), written
//! as a model file and loaded, then taken one step further as in the `model` target. The
//! fuzzer so reaches the checks behind the TOML syntax: names, kinds, shapes, the bodies'
//! expansion, the constraints' rank, the holonomic completion.
//!
//!     cargo +nightly fuzz run model_structured -- -max_total_time=60
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;

const COORDS: [&str; 6] = ["x", "y", "theta", "phi", "psi", "q6"];
const PARAMS: [&str; 5] = ["m", "R", "g", "a", "I"];
const AXES: [&str; 7] = ["x", "y", "z", "-x", "-y", "-z", "w"];

/// A small expression over the coordinates, parameters and velocities.
#[derive(Arbitrary, Debug)]
enum E {
    Num(i8),
    Coord(u8),
    Param(u8),
    Der(u8),
    Add(Box<E>, Box<E>),
    Sub(Box<E>, Box<E>),
    Mul(Box<E>, Box<E>),
    Div(Box<E>, Box<E>),
    Pow(Box<E>, i8),
    Sin(Box<E>),
    Cos(Box<E>),
    Sqrt(Box<E>),
}

impl E {
    fn text(&self, n: usize, depth: usize) -> String {
        if depth > 5 {
            return "1".into();
        }
        let t = |e: &E| e.text(n, depth + 1);
        match self {
            E::Num(k) => format!("({k})"),
            E::Coord(i) => COORDS[*i as usize % n].into(),
            E::Param(i) => PARAMS[*i as usize % PARAMS.len()].into(),
            E::Der(i) => format!("der({})", COORDS[*i as usize % n]),
            E::Add(a, b) => format!("({} + {})", t(a), t(b)),
            E::Sub(a, b) => format!("({} - {})", t(a), t(b)),
            E::Mul(a, b) => format!("{}*{}", t(a), t(b)),
            E::Div(a, b) => format!("{}/({})", t(a), t(b)),
            E::Pow(a, k) => format!("({})^{}", t(a), k % 5),
            E::Sin(a) => format!("sin({})", t(a)),
            E::Cos(a) => format!("cos({})", t(a)),
            E::Sqrt(a) => format!("sqrt({})", t(a)),
        }
    }
}

#[derive(Arbitrary, Debug)]
struct Frame {
    parent: Option<u8>,
    origin: Option<[E; 3]>,
    rotations: Vec<(u8, E)>,
}

#[derive(Arbitrary, Debug)]
struct Body {
    frame: u8,
    mass: E,
    centre: Option<[E; 3]>,
    inertia: Option<[E; 4]>,
}

#[derive(Arbitrary, Debug)]
struct Wheel {
    frame: u8,
    axis: u8,
    radius: E,
    dependent: Option<u8>,
}

#[derive(Arbitrary, Debug)]
enum Kind {
    Lagrangian {
        kinetic: E,
        potential: E,
        constraints: Vec<E>,
    },
    Bodies {
        gravity: bool,
        frames: Vec<Frame>,
        bodies: Vec<Body>,
        wheels: Vec<Wheel>,
        blades: Vec<(u8, u8)>,
    },
}

#[derive(Arbitrary, Debug)]
struct Spec {
    coordinates: u8,
    parameters: Vec<(u8, i16)>,
    kind: Kind,
    choices: Vec<Vec<E>>,
}

fn list(items: &[E], n: usize) -> String {
    let v: Vec<String> = items.iter().map(|e| format!("\"{}\"", e.text(n, 0))).collect();
    format!("[{}]", v.join(", "))
}

impl Spec {
    fn toml(&self) -> String {
        let n = 1 + self.coordinates as usize % COORDS.len();
        let coords: Vec<String> = COORDS[..n].iter().map(|c| format!("\"{c}\"")).collect();
        let mut out = format!("coordinates = [{}]\n\n[parameters]\n", coords.join(", "));
        let mut seen = Vec::new();
        for (i, v) in &self.parameters {
            let p = PARAMS[*i as usize % PARAMS.len()];
            if !seen.contains(&p) {
                seen.push(p);
                out += &format!("{p} = {}\n", *v as f64 / 100.0);
            }
        }
        match &self.kind {
            Kind::Lagrangian { kinetic, potential, constraints } => {
                out += &format!(
                    "\n[lagrangian]\nkinetic = \"{}\"\npotential = \"{}\"\n",
                    kinetic.text(n, 0),
                    potential.text(n, 0)
                );
                if !constraints.is_empty() {
                    out += "\n[constraints]\n";
                    for (i, c) in constraints.iter().take(n).enumerate() {
                        out += &format!("c{i} = \"{}\"\n", c.text(n, 0));
                    }
                }
            }
            Kind::Bodies { gravity, frames, bodies, wheels, blades } => {
                out += &format!(
                    "\n[world]\nup = \"z\"\n{}",
                    if *gravity { "gravity = \"g\"\n" } else { "" }
                );
                let nf = frames.len().min(6);
                for (i, f) in frames.iter().take(6).enumerate() {
                    out += &format!("\n[frames.f{i}]\n");
                    if let Some(p) = f.parent {
                        out += &format!("parent = \"f{}\"\n", p as usize % nf.max(1));
                    }
                    if let Some(o) = &f.origin {
                        out += &format!("origin = {}\n", list(o, n));
                    }
                    let rot: Vec<String> = f
                        .rotations
                        .iter()
                        .take(3)
                        .map(|(a, e)| {
                            format!(
                                "{{ axis = \"{}\", angle = \"{}\" }}",
                                AXES[*a as usize % AXES.len()],
                                e.text(n, 0)
                            )
                        })
                        .collect();
                    out += &format!("rotations = [{}]\n", rot.join(", "));
                }
                let frame = |k: u8| format!("f{}", k as usize % nf.max(1));
                for (i, b) in bodies.iter().take(4).enumerate() {
                    out += &format!(
                        "\n[bodies.b{i}]\nframe = \"{}\"\nmass = \"{}\"\n",
                        frame(b.frame),
                        b.mass.text(n, 0)
                    );
                    if let Some(c) = &b.centre {
                        out += &format!("centre_of_mass = {}\n", list(c, n));
                    }
                    if let Some([xx, yy, zz, xz]) = &b.inertia {
                        out += &format!(
                            "inertia = {{ xx = \"{}\", yy = \"{}\", zz = \"{}\", xz = \"{}\" }}\n",
                            xx.text(n, 0),
                            yy.text(n, 0),
                            zz.text(n, 0),
                            xz.text(n, 0)
                        );
                    }
                }
                for (i, w) in wheels.iter().take(3).enumerate() {
                    out += &format!(
                        "\n[wheels.w{i}]\nframe = \"{}\"\naxis = \"{}\"\nradius = \"{}\"\n",
                        frame(w.frame),
                        AXES[w.axis as usize % AXES.len()],
                        w.radius.text(n, 0)
                    );
                    if let Some(d) = w.dependent {
                        out += &format!("dependent = \"{}\"\n", COORDS[d as usize % n]);
                    }
                }
                for (i, (f, d)) in blades.iter().take(3).enumerate() {
                    out += &format!(
                        "\n[blades.k{i}]\nframe = \"{}\"\ndirection = \"{}\"\n",
                        frame(*f),
                        AXES[*d as usize % AXES.len()]
                    );
                }
            }
        }
        for (i, c) in self.choices.iter().take(3).enumerate() {
            out += &format!("\n[quasi_velocities.z{i}]\neta = {}\n", list(c, n));
        }
        out
    }
}

fuzz_target!(|spec: Spec| {
    let text = spec.toml();
    if let Ok(model) = hamel_model::Model::from_source("structured.toml", &text) {
        hamel_fuzz::exercise(&model);
    }
});
