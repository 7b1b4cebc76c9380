//! Models from bodies, frames and rolling wheels give the equations typed in by hand: for the
//! Chaplygin sleigh, the rolling disk and the unicycle with rider, the same A and U (canonical
//! difference zero), the same row space of α (exact ranks), and with the same Z the same A_Γ,
//! forcing and Q⁽ⁱ⁾; `hamel expand`'s file loads to the same model; bad descriptions are
//! located errors.
//!
//! The CAS runs in-process on its one worker thread.

use hamel_cas::{Field, FieldSpec, Matrix, run};
use hamel_derive::{Derivation, derive};
use hamel_expr::Expr;
use hamel_model::{Model, Origin};

/// A bundled model: `models/NAME.toml`, or its twin from bodies `models/bodies/NAME.toml`.
fn bundled(name: &str) -> Model {
    let dir = if name.ends_with("_bodies") {
        "models/bodies"
    } else {
        "models"
    };
    Model::load(format!("{}/{dir}/{name}.toml", env!("CARGO_MANIFEST_DIR")))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Every entry of an object of a derivation, flattened.
fn flat(d: &Derivation) -> Vec<(String, Vec<Expr>)> {
    let mat = |m: &hamel_derive::Mat| {
        m.entries
            .iter()
            .flatten()
            .map(|e| e.expr.clone())
            .collect::<Vec<_>>()
    };
    let c = d.closed().expect("the small models derive in closed form");
    let mut out = vec![
        ("A".into(), mat(&d.a)),
        ("A_Γ".into(), mat(&c.a_gamma)),
        (
            "forcing".into(),
            c.forcing.iter().map(|e| e.expr.clone()).collect(),
        ),
        (
            "U".into(),
            vec![
                d.ingredients
                    .potential
                    .clone()
                    .expect("a derivation has U")
                    .expr,
            ],
        ),
    ];
    for (i, q) in c.q.iter().enumerate() {
        out.push((format!("Q({})", i + 1), mat(q)));
    }
    out
}

/// The two models' derivations with one choice agree exactly: A, U, A_Γ, forcing and every
/// Q⁽ⁱ⁾ have canonical difference zero, and the rows of α span one space (rank of the two
/// stacked equals the rank of each, μ).
fn same_equations(hand: &str, bodies: &str, eta: &str) {
    let (h, b) = (bundled(hand), bundled(bodies));
    assert_eq!(b.origin, Origin::Bodies);
    assert_eq!(h.coordinates, b.coordinates);
    let (dh, db) = (
        derive(&h, Some(eta)).unwrap(),
        derive(&b, Some(eta)).unwrap(),
    );
    let (fh, fb) = (flat(&dh), flat(&db));
    let alpha = |d: &Derivation| {
        d.alpha
            .entries
            .iter()
            .map(|r| r.iter().map(|e| e.expr.clone()).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    };
    let (ah, ab) = (alpha(&dh), alpha(&db));
    let spec = FieldSpec {
        coordinates: h.coordinates.clone(),
        parameters: h.parameters.keys().cloned().collect(),
        free_functions: vec![],
        free_order: 0,
        unknowns: (1..=dh.sigma).map(|i| format!("eta{i}")).collect(),
        expressions: fh
            .iter()
            .chain(&fb)
            .flat_map(|(_, v)| v.clone())
            .chain(ah.iter().chain(&ab).flatten().cloned())
            .collect(),
    };
    let mu = h.mu();
    let verdict = run(move || {
        let f = Field::new(&spec).unwrap();
        let conv = |e: &Expr| f.convert(e).unwrap();
        let mut differ = Vec::new();
        for ((name, x), (_, y)) in fh.iter().zip(&fb) {
            assert_eq!(x.len(), y.len(), "{name}");
            for (k, (p, q)) in x.iter().zip(y).enumerate() {
                if !(&conv(p) - &conv(q)).is_zero() {
                    differ.push(format!("{name}[{k}]: {p}  vs  {q}"));
                }
            }
        }
        let matrix = |rows: &[Vec<Expr>]| {
            Matrix::from_fn(rows.len(), rows[0].len(), |i, j| conv(&rows[i][j]))
        };
        let (mh, mb) = (matrix(&ah), matrix(&ab));
        let ranks = (
            mh.rank().unwrap(),
            mb.rank().unwrap(),
            mh.vstack(&mb).rank().unwrap(),
        );
        (differ, ranks)
    })
    .unwrap();
    assert!(
        verdict.0.is_empty(),
        "{hand} vs {bodies}:\n{}",
        verdict.0.join("\n")
    );
    assert_eq!(
        verdict.1,
        (mu, mu, mu),
        "ranks of α (hand, bodies, stacked)"
    );
}

#[test]
fn the_chaplygin_sleigh_from_its_body_and_blade() {
    same_equations("chaplygin_sleigh", "chaplygin_sleigh_bodies", "paper_style");
}

#[test]
fn the_rolling_disk_from_its_body_and_wheel() {
    same_equations("rolling_disk", "rolling_disk_bodies", "momenta");
}

#[test]
fn the_unicycle_with_rider_from_its_bodies_and_wheel() {
    same_equations("unicycle_rider", "unicycle_rider_bodies", "velocities");
}

/// `hamel expand`'s file is a model of the hand-typed form with the same A, U and α: the same
/// trees, compared as printed after one round through the printer and the parser (which may
/// write a negative literal in another way).
/// The text of `e` after one round through the parser.
fn settled(e: &Expr) -> String {
    hamel_expr::parse(&e.to_string()).unwrap().expr.to_string()
}

#[test]
fn the_expanded_file_loads_to_the_same_model() {
    for name in [
        "chaplygin_sleigh_bodies",
        "rolling_disk_bodies",
        "unicycle_rider_bodies",
    ] {
        let m = bundled(name);
        let text = m.to_lagrangian_toml();
        let back = Model::from_source("expanded.toml", &text)
            .unwrap_or_else(|e| panic!("{name}: {e}\n{text}"));
        assert_eq!(back.origin, Origin::Lagrangian);
        let a = |m: &Model| match &m.kinetic {
            hamel_model::Kinetic::MassMatrix(rows) => rows
                .iter()
                .flatten()
                .map(|i| settled(&i.expr))
                .collect::<Vec<_>>(),
            hamel_model::Kinetic::Energy(_) => panic!("expanded to a mass matrix"),
        };
        assert_eq!(a(&m), a(&back), "{name}");
        assert_eq!(settled(&m.potential.expr), settled(&back.potential.expr));
        let rows = |m: &Model| {
            m.constraints
                .iter()
                .map(|(n, i)| (n.clone(), settled(&i.expr)))
                .collect::<Vec<_>>()
        };
        assert_eq!(rows(&m), rows(&back), "{name}");
    }
}
