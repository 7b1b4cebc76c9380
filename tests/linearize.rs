//! Linearisation about steady motions (`hamel_study`), against independent oracles:
//!
//! * the Whipple bicycle against the benchmark of Meijaard, Papadopoulos, Ruina & Schwab (2007):
//!   the eigenvalues of its Table 2 (v = 0…10 m/s), the weave and capsize speeds, and the
//!   published M, C1, K0, K2 of its linear equations M q̈ + v C1 q̇ + (g K0 + v² K2) q = f
//!   (docs/design/whipple-bicycle-research.md §1.3–1.5);
//! * the uniform rolling disk against the closed form of docs/linearisation.md: upright rolling
//!   at spin rate Ω has the eigenvalues λ² = 4g/(5R) − 12Ω²/5 and becomes stable exactly at
//!   Ω² = g/(3R), for any R and g;
//! * the Chaplygin sleigh: straight motion at speed v has the eigenvalue −m a v/(I + m a²).
//!
//! The CAS runs in-process on its one worker thread (one `Study::prepare` per study); the
//! linearisations are numeric.

// Published values are copied digit for digit, as printed.
#![allow(clippy::excessive_precision)]

use hamel_model::Model;
use hamel_study::{CrossingKind, Point, Range, Stability, SteadyCheck, StructuralKind, Study};
use indexmap::IndexMap;

fn model(name: &str) -> Model {
    Model::load(format!("{}/models/{name}.toml", env!("CARGO_MANIFEST_DIR")))
        .unwrap_or_else(|e| panic!("{e:?}"))
}

fn study(name: &str, steady: &str) -> Study {
    Study::prepare(&model(name), None, steady).unwrap_or_else(|e| panic!("{e:?}"))
}

fn point(values: &[(&str, f64)]) -> Point {
    Point(
        values
            .iter()
            .map(|(k, v)| (k.to_string(), *v))
            .collect::<IndexMap<_, _>>(),
    )
}

/// |got − want| ≤ tol·max(|want|, floor).
fn close(what: &str, got: f64, want: f64, tol: f64, floor: f64) {
    let error = (got - want).abs() / want.abs().max(floor);
    assert!(
        error <= tol,
        "{what}: got {got:.16e}, want {want:.16e} (relative {error:.1e})"
    );
}

/// Meijaard et al. (2007), Table 2: v and the four eigenvalues (re, im).
const TABLE_2: [(f64, [[f64; 2]; 4]); 11] = [
    (
        0.0,
        [
            [-5.53094371765393, 0.0],
            [-3.13164324790656, 0.0],
            [3.13164324790656, 0.0],
            [5.53094371765393, 0.0],
        ],
    ),
    (
        1.0,
        [
            [-7.11008014637442, 0.0],
            [-3.13423125066578, 0.0],
            [3.52696170990070, -0.8077402751993],
            [3.52696170990070, 0.8077402751993],
        ],
    ),
    (
        2.0,
        [
            [-8.67387984831735, 0.0],
            [-3.07158645641514, 0.0],
            [2.68234517512745, -1.68066296590675],
            [2.68234517512745, 1.68066296590675],
        ],
    ),
    (
        3.0,
        [
            [-10.35101467245920, 0.0],
            [-2.63366137253667, 0.0],
            [1.70675605663975, -2.31582447384325],
            [1.70675605663975, 2.31582447384325],
        ],
    ),
    (
        4.0,
        [
            [-12.15861426576450, 0.0],
            [-1.42944427361326, 0.0],
            [0.41325331521125, -3.07910818603206],
            [0.41325331521125, 3.07910818603206],
        ],
    ),
    (
        5.0,
        [
            [-14.07838969279820, 0.0],
            [-0.77534188219585, -4.46486771378823],
            [-0.77534188219585, 4.46486771378823],
            [-0.32286642900409, 0.0],
        ],
    ),
    (
        6.0,
        [
            [-16.08537123098030, 0.0],
            [-1.52644486584142, -5.87673060598709],
            [-1.52644486584142, 5.87673060598709],
            [-0.00406690076970, 0.0],
        ],
    ),
    (
        7.0,
        [
            [-18.15788466125262, 0.0],
            [-2.13875644258362, -7.19525913329805],
            [-2.13875644258362, 7.19525913329805],
            [0.10268170574766, 0.0],
        ],
    ),
    (
        8.0,
        [
            [-20.27940894394569, 0.0],
            [-2.69348683581097, -8.46037971396931],
            [-2.69348683581097, 8.46037971396931],
            [0.14327879765713, 0.0],
        ],
    ),
    (
        9.0,
        [
            [-22.43788559040858, 0.0],
            [-3.21675402252485, -9.69377351531791],
            [-3.21675402252485, 9.69377351531791],
            [0.15790184030917, 0.0],
        ],
    ),
    (
        10.0,
        [
            [-24.62459635017404, 0.0],
            [-3.72016840437287, -10.90681139476287],
            [-3.72016840437287, 10.90681139476287],
            [0.16105338653172, 0.0],
        ],
    ),
];

#[test]
fn bicycle_eigenvalues_and_critical_speeds_are_the_benchmarks() {
    let s = study("whipple_bicycle", "upright");
    let range = Range::parse("v=0:10:11").unwrap();
    let sweep = s.sweep(&Point::default(), &range, &|| ()).unwrap();
    assert_eq!(sweep.persistent_zeros, 0);
    for ((v, want), p) in TABLE_2.iter().zip(&sweep.points) {
        assert_eq!(p.value, *v);
        assert_eq!(p.eigenvalues.len(), 4, "v = {v}: {:?}", p.eigenvalues);
        for (got, want) in p.eigenvalues.iter().zip(want) {
            let size = want[0].hypot(want[1]);
            // The published v = 1 imaginary part has 13 decimals (the research note, §1.5).
            let tol = if *v == 1.0 {
                2e-13 / size + 1e-10
            } else {
                1e-10
            };
            close(&format!("Re λ at v = {v}"), got[0], want[0], tol, size);
            close(&format!("Im λ at v = {v}"), got[1], want[1], tol, size);
        }
    }
    let speeds: Vec<(f64, CrossingKind)> =
        sweep.crossings.iter().map(|c| (c.value, c.kind)).collect();
    assert_eq!(speeds.len(), 2, "{speeds:?}");
    assert_eq!(speeds[0].1, CrossingKind::Hopf);
    close("weave speed", speeds[0].0, 4.29238253634111, 1e-10, 1.0);
    close(
        "weave frequency",
        sweep.crossings[0].eigenvalue[1].abs(),
        3.43503384866144,
        1e-10,
        1.0,
    );
    assert_eq!(speeds[1].1, CrossingKind::RealZero);
    close("capsize speed", speeds[1].0, 6.02426201538837, 1e-10, 1.0);
    assert_eq!(
        (sweep.crossings[0].below, sweep.crossings[0].above),
        (Stability::Unstable, Stability::Asymptotic)
    );
    assert_eq!(
        (sweep.crossings[1].below, sweep.crossings[1].above),
        (Stability::Asymptotic, Stability::Unstable)
    );
}

/// The benchmark's published matrices (docs/design/whipple-bicycle-research.md §1.3).
const M: [[f64; 2]; 2] = [
    [80.81722, 2.31941332208709],
    [2.31941332208709, 0.29784188199686],
];
const C1: [[f64; 2]; 2] = [
    [0.0, 33.86641391492494],
    [-0.85035641456978, 1.68540397397560],
];
const K0: [[f64; 2]; 2] = [
    [-80.95, -2.59951685249872],
    [-2.59951685249872, -0.80329488458618],
];
const K2: [[f64; 2]; 2] = [[0.0, 76.59734589573222], [0.0, 2.65431523794604]];

/// Entry by entry, relative to the matrix's largest entry.
fn same_matrix(what: &str, got: &[Vec<f64>], want: &[[f64; 2]; 2], tol: f64) {
    let size = want.iter().flatten().fold(0.0_f64, |m, x| m.max(x.abs()));
    for i in 0..2 {
        for k in 0..2 {
            close(
                &format!("{what}[{i}][{k}]"),
                got[i][k],
                want[i][k],
                tol,
                size,
            );
        }
    }
}

#[test]
fn bicycle_linear_equations_are_the_benchmarks_m_c1_k0_k2() {
    let s = study("whipple_bicycle", "upright");
    let sweep = s
        .sweep(
            &Point::default(),
            &Range::parse("v=0:10:3").unwrap(),
            &|| (),
        )
        .unwrap();
    let m = sweep.matrices.expect("polynomial in v");
    assert_eq!(m.parameter, "v");
    same_matrix("M", m.m.as_ref().unwrap(), &M, 1e-12);
    let c = m.c.as_ref().unwrap();
    assert_eq!(
        c.coefficients.keys().copied().collect::<Vec<_>>(),
        vec![1],
        "C = v C1"
    );
    same_matrix("C1", &c.coefficients[&1], &C1, 1e-12);
    let k = m.k.as_ref().unwrap();
    assert_eq!(
        k.coefficients.keys().copied().collect::<Vec<_>>(),
        vec![0, 2],
        "K = g K0 + v² K2"
    );
    same_matrix("K2", &k.coefficients[&2], &K2, 1e-12);
    let g = m.gravity.as_ref().expect("g enters only through U");
    assert_eq!(g.parameter, "g");
    assert!(g.rest.is_none(), "K's constant term is g K0 alone");
    same_matrix("K0", &g.k0, &K0, 1e-12);
    // The steer torque is the second generalised force; pedalling moves along the speed only.
    let b = m.b_forces.as_ref().unwrap();
    assert_eq!(b.len(), 2);
    close("B steer", b[1][0], 1.0, 1e-14, 1.0);
    for x in [b[0][0], b[0][1], b[1][1]] {
        assert!(x.abs() < 1e-14, "{b:?}");
    }
    // ẋ = A x + B u: B's steer column is M⁻¹ (0, 1) (DTK's doctest, 8 digits).
    close("B roll", m.b[2][0], -0.12409203, 1e-7, 1.0);
    close("B steer", m.b[3][0], 4.32384018, 1e-8, 1.0);
}

#[test]
fn bicycle_steady_motion_drops_the_ignorable_coordinates_and_completes_the_pitch() {
    let s = study("whipple_bicycle", "upright");
    let l = s.linearise(&point(&[("v", 3.0)]), 0).unwrap();
    assert_eq!(l.state, ["roll", "steer", "eta1", "eta2", "eta3"]);
    assert_eq!(l.reduced_state, ["roll", "steer", "eta1", "eta2"]);
    let dropped: Vec<&StructuralKind> = l.structural.iter().map(|z| &z.kind).collect();
    assert_eq!(
        dropped.len(),
        6,
        "five ignorable coordinates and the speed: {dropped:?}"
    );
    assert!(matches!(dropped[5], StructuralKind::SteadyFamily { parameter } if parameter == "v"));
    close("rear wheel rate", l.eta[2], -3.0 / 0.3, 1e-15, 1.0);
    close(
        "front wheel rate",
        l.q_dot["front_wheel"],
        -3.0 / 0.35,
        1e-14,
        1.0,
    );
    assert!(l.residual < 1e-12, "{}", l.residual);
    assert_eq!(s.dependent(), ["pitch"]);
    // The bicycle's equations are structured and its pitch is completed by Newton's method:
    // its steady motion is checked numerically, and the report says why.
    assert!(
        matches!(s.steady_check(), SteadyCheck::Numeric { why } if why.contains("structured")),
        "{:?}",
        s.steady_check()
    );
}

/// λ² = 4g/(5R) − 12Ω²/5 for the uniform disk (docs/linearisation.md).
fn disk_lambda_squared(g: f64, r: f64, omega: f64) -> f64 {
    4.0 * g / (5.0 * r) - 12.0 * omega * omega / 5.0
}

#[test]
fn rolling_disk_becomes_stable_exactly_at_g_over_3r() {
    let s = study("rolling_disk", "upright");
    for (r, g, m) in [
        (0.15_f64, 9.81_f64, 0.5),
        (0.3, 3.7, 2.0),
        (1.0, 24.79, 0.1),
    ] {
        let set = [("R", r), ("g", g), ("m_d", m)];
        let critical = (g / (3.0 * r)).sqrt();
        let range = Range {
            parameter: "Omega".into(),
            start: 0.0,
            stop: 2.9 * critical,
            count: 7,
        };
        let sweep = s.sweep(&point(&set), &range, &|| ()).unwrap();
        assert_eq!(
            sweep.persistent_zeros, 1,
            "the disk's neighbouring steady circles"
        );
        assert_eq!(sweep.crossings.len(), 1, "{:?}", sweep.crossings);
        let c = &sweep.crossings[0];
        assert_eq!(
            (c.kind, c.zeros),
            (CrossingKind::RealZero, 2),
            "a real pair meets at zero"
        );
        close(
            &format!("critical spin, R = {r}, g = {g}"),
            c.value,
            critical,
            1e-10,
            1.0,
        );
        assert_eq!(
            (c.below, c.above),
            (Stability::Unstable, Stability::Marginal)
        );
        for p in &sweep.points {
            let want = disk_lambda_squared(g, r, p.value);
            assert_eq!(p.eigenvalues.len(), 2);
            for z in &p.eigenvalues {
                // λ² = re² − im² + 2i re im
                let got = z[0] * z[0] - z[1] * z[1];
                close(&format!("λ² at Omega = {}", p.value), got, want, 1e-10, 1.0);
                assert!(z[0] * z[1] == 0.0 || (z[0] * z[1]).abs() < 1e-10 * want.abs().max(1.0));
            }
        }
        // A sweep point on the crossing itself: three zeros, which rounding spreads to ~ε^(1/3);
        // it counts as on the axis, and the crossing is still found, between its neighbours.
        let through = Range {
            parameter: "Omega".into(),
            start: 0.0,
            stop: 2.0 * critical,
            count: 3,
        };
        let sweep = s.sweep(&point(&set), &through, &|| ()).unwrap();
        assert_eq!(sweep.points[1].stability, Stability::Marginal);
        assert_eq!(sweep.crossings.len(), 1, "{:?}", sweep.crossings);
        close(
            "critical spin (point on it)",
            sweep.crossings[0].value,
            critical,
            1e-10,
            1.0,
        );
    }
}

#[test]
fn chaplygin_sleigh_straight_motion_has_its_closed_form_eigenvalue() {
    let s = study("chaplygin_sleigh", "straight");
    for (m, i, a, v) in [
        (2.0, 0.05, 0.2, 1.0),
        (5.0, 0.3, -0.1, 2.5),
        (1.0, 1.0, 0.5, -3.0),
    ] {
        let l = s
            .linearise(&point(&[("m", m), ("I", i), ("a", a), ("v", v)]), 0)
            .unwrap();
        assert_eq!(l.eigenvalues.len(), 1);
        let want = -m * a * v / (i + m * a * a);
        close(
            &format!("λ, m = {m}, a = {a}, v = {v}"),
            l.eigenvalues[0][0],
            want,
            1e-13,
            1.0,
        );
        assert_eq!(l.eigenvalues[0][1], 0.0);
        let stable = if want < 0.0 {
            Stability::Asymptotic
        } else {
            Stability::Unstable
        };
        assert_eq!(l.stability, stable);
    }
}

/// The steady motions of the closed-form models are proved exactly: the steady values
/// substituted into (11) and α(q)q̇ = 0 leave residuals that are zero on their canonical forms,
/// identically in the parameters.
#[test]
fn closed_form_steady_motions_are_proved_exactly() {
    for (name, steady) in [
        ("rolling_disk", "upright"),
        ("chaplygin_sleigh", "straight"),
        ("unicycle_rider", "upright"),
        ("snakeboard", "circle"),
    ] {
        let s = study(name, steady);
        assert_eq!(s.steady_check(), &SteadyCheck::Exact, "{name}");
        let l = s.linearise(&Point::default(), 0).unwrap();
        assert_eq!(l.steady_check, SteadyCheck::Exact);
        let text = s.linearisation_text(&l);
        assert!(text.contains("steady: proved exactly"), "{text}");
    }
}

/// A sleigh turning at a rate w (a model parameter) is steady only at w = 0: the exact check
/// names the residuals, and the numeric check decides each point.
#[test]
fn a_motion_steady_only_for_special_values_is_checked_at_each_point() {
    let path = format!(
        "{}/models/chaplygin_sleigh.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).unwrap();
    let turning = text
        .replace("a = 0.2 ", "w = 0.0\na = 0.2 ")
        .replace("x = \"v\", theta = 0", "x = \"v\", theta = \"w\"");
    assert_ne!(turning, text);
    let model = Model::from_source("turning_sleigh.toml", &turning).unwrap();
    let s = Study::prepare(&model, None, "straight").unwrap();
    let SteadyCheck::NotIdentically { residuals } = s.steady_check() else {
        panic!("{:?}", s.steady_check());
    };
    // theta is dropped (the equations are free of it). The turn leaves the centripetal term
    // −m a w² in the first equation (η₁ the speed along the axis) and the torque m a v w of
    // the knife edge's reaction in the second (η₂ the turning rate).
    assert_eq!(
        residuals,
        &[
            (
                "row 1 of (11) at d(eta)/dt = 0".to_string(),
                "-m*w^2*a".to_string()
            ),
            (
                "row 2 of (11) at d(eta)/dt = 0".to_string(),
                "m*w*a*v".to_string()
            )
        ]
    );
    let l = s.linearise(&point(&[("w", 0.0)]), 0).unwrap();
    assert_eq!(l.eigenvalues.len(), 1);
    let e = s.linearise(&point(&[("w", 0.5)]), 0).unwrap_err();
    let message = format!("{:?}", miette::Report::new(s.locate(&e)));
    assert!(
        message.contains("d(eta1)/dt") && message.contains("exactly, row 1 of (11)"),
        "{message}"
    );
}

#[test]
fn a_state_that_is_not_steady_is_refused_with_its_residual() {
    let path = format!("{}/models/rolling_disk.toml", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    let leaning = text.replace("q = { theta = 0 }", "q = { theta = 0.3 }");
    let model = Model::from_source("leaning_disk.toml", &leaning).unwrap();
    let s = Study::prepare(&model, None, "upright").unwrap();
    let SteadyCheck::NotIdentically { residuals } = s.steady_check() else {
        panic!("{:?}", s.steady_check());
    };
    assert!(
        residuals.iter().all(|(n, _)| n.starts_with("row ")),
        "{residuals:?}"
    );
    let e = s.linearise(&Point::default(), 0).unwrap_err();
    let message = format!("{:?}", miette::Report::new(s.locate(&e)));
    assert!(
        message.contains("not a steady motion") && message.contains("d(eta"),
        "{message}"
    );
    assert!(
        message.contains("steady.upright"),
        "located at the table: {message}"
    );
}

#[test]
fn steady_sections_are_checked_where_they_are_read() {
    let path = format!("{}/models/rolling_disk.toml", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    let cases = [
        (
            "q = { theta = 0 }",
            "q = { tehta = 0 }",
            "`tehta` is not a coordinate",
        ),
        (
            "parameters = { Omega = 10.0 }",
            "parameters = { R = 10.0 }",
            "already a coordinate",
        ),
        ("psi = \"Omega\"", "psi = \"Omeg\"", "unknown symbol `Omeg`"),
        (
            "parameters = { Omega = 10.0 }",
            "parameters = { Omega = \"fast\" }",
            "finite number",
        ),
    ];
    for (from, to, want) in cases {
        let e = Model::from_source("disk.toml", &text.replace(from, to)).unwrap_err();
        let message = format!("{:?}", miette::Report::new(e));
        assert!(
            message.contains(want) && message.contains("steady.upright"),
            "{to}: {message}"
        );
    }
    let few = text.replace(
        "velocities = { phi = 0, psi = \"Omega\", theta = 0 }",
        "velocities = { psi = \"Omega\" }",
    );
    let model = Model::from_source("disk.toml", &few).unwrap();
    let s = Study::prepare(&model, None, "upright").unwrap();
    let e = s.linearise(&Point::default(), 0).unwrap_err().to_string();
    assert!(
        e.contains("all but μ = 2") && e.contains("phi, theta"),
        "{e}"
    );
    let e = Study::prepare(&model, None, "rolling")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no steady motion named `rolling`"), "{e}");
}

/// The benchmark's closed-form linear equations from its 25 parameters (Meijaard et al. 2007,
/// Appendix A), transliterated from DynamicistToolKit's `benchmark_par_to_canonical`
/// (moorepants/DynamicistToolKit dtk/bicycle.py @ b38b9cf0): an oracle independent of hamel's
/// frames, bodies and derivation. Returns (M, C1, K0, K2).
fn canonical(p: &IndexMap<String, f64>) -> [[[f64; 2]; 2]; 4] {
    let v = |k: &str| p[k];
    let (lam, w, c) = (v("lambda"), v("w"), v("c"));
    let (sl, cl) = lam.sin_cos();
    let (m_r, m_b, m_h, m_f) = (v("mR"), v("mB"), v("mH"), v("mF"));
    let (r_r, r_f) = (v("rR"), v("rF"));
    let (x_b, z_b, x_h, z_h) = (v("xB"), v("zB"), v("xH"), v("zH"));
    let m_t = m_r + m_b + m_h + m_f;
    let x_t = (x_b * m_b + x_h * m_h + w * m_f) / m_t;
    let z_t = (-r_r * m_r + z_b * m_b + z_h * m_h - r_f * m_f) / m_t;
    let i_txx = v("IRxx")
        + v("IBxx")
        + v("IHxx")
        + v("IFxx")
        + m_r * r_r * r_r
        + m_b * z_b * z_b
        + m_h * z_h * z_h
        + m_f * r_f * r_f;
    let i_txz = v("IBxz") + v("IHxz") - m_b * x_b * z_b - m_h * x_h * z_h + m_f * w * r_f;
    let i_tzz = v("IRxx")
        + v("IBzz")
        + v("IHzz")
        + v("IFxx")
        + m_b * x_b * x_b
        + m_h * x_h * x_h
        + m_f * w * w;
    let m_a = m_h + m_f;
    let x_a = (x_h * m_h + w * m_f) / m_a;
    let z_a = (z_h * m_h - r_f * m_f) / m_a;
    let i_axx = v("IHxx") + v("IFxx") + m_h * (z_h - z_a).powi(2) + m_f * (r_f + z_a).powi(2);
    let i_axz = v("IHxz") - m_h * (x_h - x_a) * (z_h - z_a) + m_f * (w - x_a) * (r_f + z_a);
    let i_azz = v("IHzz") + v("IFxx") + m_h * (x_h - x_a).powi(2) + m_f * (w - x_a).powi(2);
    let u_a = (x_a - w - c) * cl - z_a * sl;
    let i_all = m_a * u_a * u_a + i_axx * sl * sl + 2.0 * i_axz * sl * cl + i_azz * cl * cl;
    let i_alx = -m_a * u_a * z_a + i_axx * sl + i_axz * cl;
    let i_alz = m_a * u_a * x_a + i_axz * sl + i_azz * cl;
    let mu = c / w * cl;
    let (s_r, s_f) = (v("IRyy") / r_r, v("IFyy") / r_f);
    let s_t = s_r + s_f;
    let s_a = m_a * u_a + mu * m_t * x_t;
    let m_pd = i_alx + mu * i_txz;
    let m = [
        [i_txx, m_pd],
        [m_pd, i_all + 2.0 * mu * i_alz + mu * mu * i_tzz],
    ];
    let k0 = [[m_t * z_t, -s_a], [-s_a, -s_a * sl]];
    let k2 = [
        [0.0, (s_t - m_t * z_t) / w * cl],
        [0.0, (s_a + s_f * sl) / w * cl],
    ];
    let c1 = [
        [0.0, mu * s_t + s_f * cl + i_txz / w * cl - mu * m_t * z_t],
        [
            -(mu * s_t + s_f * cl),
            i_alz / w * cl + mu * (s_a + i_tzz / w * cl),
        ],
    ];
    [m, c1, k0, k2]
}

/// The Batavus Browser with its rider Jason (Moore 2012, as published in BicycleParameters'
/// `meijaard2007_browser_jason` and HumanControl's `BrowserPar.txt`), and the Bianchi Pista
/// without rider (BicycleParameters `benchmark-pista.yml`): pasted over the benchmark's Table 1
/// with `--set`, the way a user would.
const BROWSER_JASON: [(&str, f64); 26] = [
    ("w", 1.121),
    ("c", 0.0685808540382),
    ("lambda", 0.399680398707),
    ("g", 9.81),
    ("rR", 0.340958858855),
    ("mR", 3.11),
    ("IRxx", 0.0883819364527),
    ("IRyy", 0.152467620286),
    ("xB", 0.289099434117),
    ("zB", -1.04029228321),
    ("mB", 81.86),
    ("IBxx", 11.3557360401),
    ("IByy", 12.2177848012),
    ("IBzz", 3.12354397008),
    ("IBxz", -1.96756380745),
    ("xH", 0.866949640247),
    ("zH", -0.748236400835),
    ("mH", 3.22),
    ("IHxx", 0.253379594731),
    ("IHyy", 0.246138810935),
    ("IHzz", 0.0955770796289),
    ("IHxz", -0.0720452391817),
    ("rF", 0.34352982332),
    ("mF", 2.02),
    ("IFxx", 0.0904106601579),
    ("IFyy", 0.149389340425),
];
const PISTA: [(&str, f64); 26] = [
    ("w", 0.989),
    ("c", 0.0617300113263),
    ("lambda", 0.275762021815),
    ("g", 9.81),
    ("rR", 0.332088156971),
    ("mR", 1.38),
    ("IRxx", 0.0552268228143),
    ("IRyy", 0.0764034890242),
    ("xB", 0.382963782674),
    ("zB", -0.476798507146),
    ("mB", 4.49),
    ("IBxx", 0.289968529291),
    ("IByy", 0.475817094274),
    ("IBzz", 0.249418014295),
    ("IBxz", 0.0502317583637),
    ("xH", 0.906321313298),
    ("zH", -0.732376356772),
    ("mH", 2.27),
    ("IHxx", 0.0979884309288),
    ("IHyy", 0.0691907586693),
    ("IHzz", 0.0396107377431),
    ("IHxz", -0.00440828467861),
    ("rF", 0.333838861345),
    ("mF", 1.58),
    ("IFxx", 0.0553476418952),
    ("IFyy", 0.106185287785),
];

/// K0 of the Browser with Jason as published by oliverlee/bikesim (BicycleParam.cs @ 6f5005d3),
/// whose masses and geometry are those of `BROWSER_JASON` (its inertias are not).
const BIKESIM_K0: [[f64; 2]; 2] = [
    [-89.32195980848145, -1.7415947744452318],
    [-1.7415947744452318, -0.6776962381761491],
];

#[test]
fn other_published_bicycles_match_the_closed_form_of_the_benchmark() {
    let s = study("whipple_bicycle", "upright");
    for (name, set) in [("Browser + Jason", &BROWSER_JASON), ("Pista", &PISTA)] {
        let base = point(set);
        let sweep = s
            .sweep(&base, &Range::parse("v=0:10:11").unwrap(), &|| ())
            .unwrap();
        let values = s.model().parameter_values(&base.0).unwrap();
        let [m, c1, k0, k2] = canonical(&values);
        let got = sweep.matrices.as_ref().expect("polynomial in v");
        same_matrix(&format!("{name} M"), got.m.as_ref().unwrap(), &m, 1e-12);
        same_matrix(
            &format!("{name} C1"),
            &got.c.as_ref().unwrap().coefficients[&1],
            &c1,
            1e-12,
        );
        same_matrix(
            &format!("{name} K0"),
            &got.gravity.as_ref().unwrap().k0,
            &k0,
            1e-12,
        );
        same_matrix(
            &format!("{name} K2"),
            &got.k.as_ref().unwrap().coefficients[&2],
            &k2,
            1e-12,
        );
        if name.starts_with("Browser") {
            same_matrix(
                "Browser K0 (bikesim)",
                &got.gravity.as_ref().unwrap().k0,
                &BIKESIM_K0,
                1e-10,
            );
        }
        // The eigenvalues of the oracle's ẋ = A x at every speed of the sweep.
        for p in &sweep.points {
            let want = oracle_eigenvalues(&m, &c1, &k0, &k2, 9.81, p.value);
            assert_eq!(p.eigenvalues.len(), 4);
            for (got, want) in p.eigenvalues.iter().zip(&want) {
                let size = want[0].hypot(want[1]).max(1.0);
                close(
                    &format!("{name} Re λ at v = {}", p.value),
                    got[0],
                    want[0],
                    1e-10,
                    size,
                );
                close(
                    &format!("{name} Im λ at v = {}", p.value),
                    got[1],
                    want[1],
                    1e-10,
                    size,
                );
            }
        }
        // The capsize speed: det(g K0 + v² K2) = 0 is linear in v² (K2's first column is 0).
        let g = 9.81;
        let capsize = (g * (k0[0][1] * k0[1][0] - k0[0][0] * k0[1][1])
            / (k0[0][0] * k2[1][1] - k0[1][0] * k2[0][1]))
            .sqrt();
        let real: Vec<f64> = sweep
            .crossings
            .iter()
            .filter(|c| c.kind == CrossingKind::RealZero)
            .map(|c| c.value)
            .collect();
        assert!(
            real.iter().any(|v| (v - capsize).abs() < 1e-10 * capsize),
            "{name}: capsize {capsize}, crossings {:?}",
            sweep.crossings
        );
    }
}

/// Eigenvalues of [[0, I], [−M⁻¹(gK0 + v²K2), −vM⁻¹C1]], sorted as hamel sorts them.
fn oracle_eigenvalues(
    m: &[[f64; 2]; 2],
    c1: &[[f64; 2]; 2],
    k0: &[[f64; 2]; 2],
    k2: &[[f64; 2]; 2],
    g: f64,
    v: f64,
) -> Vec<[f64; 2]> {
    let m = nalgebra::Matrix2::new(m[0][0], m[0][1], m[1][0], m[1][1]);
    let k = nalgebra::Matrix2::new(
        g * k0[0][0] + v * v * k2[0][0],
        g * k0[0][1] + v * v * k2[0][1],
        g * k0[1][0] + v * v * k2[1][0],
        g * k0[1][1] + v * v * k2[1][1],
    );
    let c = nalgebra::Matrix2::new(v * c1[0][0], v * c1[0][1], v * c1[1][0], v * c1[1][1]);
    let mi = m.try_inverse().unwrap();
    let (mk, mc) = (-mi * k, -mi * c);
    let a = nalgebra::Matrix4::new(
        0.0,
        0.0,
        1.0,
        0.0, //
        0.0,
        0.0,
        0.0,
        1.0, //
        mk[(0, 0)],
        mk[(0, 1)],
        mc[(0, 0)],
        mc[(0, 1)], //
        mk[(1, 0)],
        mk[(1, 1)],
        mc[(1, 0)],
        mc[(1, 1)],
    );
    let mut out: Vec<[f64; 2]> = a
        .complex_eigenvalues()
        .iter()
        .map(|z| [z.re, z.im])
        .collect();
    out.sort_by(|x, y| x[0].total_cmp(&y[0]).then(x[1].total_cmp(&y[1])));
    out
}

/// K0 is the stiffness per unit g whatever g is set to; a range that runs downwards gives the
/// same crossings, with stability below and above in the parameter's own order; a map over the
/// same parameter twice is refused.
#[test]
fn gravity_split_descending_ranges_and_bad_maps() {
    let s = study("whipple_bicycle", "upright");
    let moon = point(&[("g", 1.62)]);
    let sweep = s
        .sweep(&moon, &Range::parse("v=0:10:3").unwrap(), &|| ())
        .unwrap();
    let g = sweep.matrices.as_ref().unwrap().gravity.as_ref().unwrap();
    same_matrix("K0 with g = 1.62", &g.k0, &K0, 1e-12);
    let down = s
        .sweep(
            &Point::default(),
            &Range::parse("v=10:0:11").unwrap(),
            &|| (),
        )
        .unwrap();
    let kinds: Vec<(CrossingKind, Stability, Stability)> = down
        .crossings
        .iter()
        .map(|c| (c.kind, c.below, c.above))
        .collect();
    assert_eq!(
        kinds,
        [
            (
                CrossingKind::Hopf,
                Stability::Unstable,
                Stability::Asymptotic
            ),
            (
                CrossingKind::RealZero,
                Stability::Asymptotic,
                Stability::Unstable
            )
        ]
    );
    close(
        "capsize, downwards",
        down.crossings[1].value,
        6.02426201538837,
        1e-10,
        1.0,
    );
    let v = Range::parse("v=0:10:3").unwrap();
    let e = s
        .map(&Point::default(), &v, &v, &|| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("two different parameters"), "{e}");
}

/// The benchmark with toroidal tyres (models/bodies/whipple_bicycle_tyres.toml): with both
/// crown radii 0 its linear equations are the benchmark's M, C1, K0, K2 to 1e-12; with crowns
/// it has weave and capsize speeds of its own.
#[test]
fn tyre_bicycle_with_knife_edge_crowns_is_the_benchmark() {
    let m = Model::load(format!(
        "{}/models/bodies/whipple_bicycle_tyres.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap_or_else(|e| panic!("{e:?}"));
    let s = Study::prepare(&m, None, "upright").unwrap_or_else(|e| panic!("{e:?}"));
    let knife_edges = point(&[("cR", 0.0), ("cF", 0.0)]);
    let range = Range::parse("v=0:10:3").unwrap();
    let sweep = s.sweep(&knife_edges, &range, &|| ()).unwrap();
    let mats = sweep.matrices.expect("polynomial in v");
    same_matrix("M", mats.m.as_ref().unwrap(), &M, 1e-12);
    let c = mats.c.as_ref().unwrap();
    same_matrix("C1", &c.coefficients[&1], &C1, 1e-12);
    let k = mats.k.as_ref().unwrap();
    same_matrix("K2", &k.coefficients[&2], &K2, 1e-12);
    let g = mats.gravity.as_ref().expect("g enters only through U");
    same_matrix("K0", &g.k0, &K0, 1e-12);
    // With the file's crowns (2 cm), the weave and capsize speeds move.
    let fine = Range::parse("v=0:10:201").unwrap();
    let crowned = s.sweep(&Point::default(), &fine, &|| ()).unwrap();
    let speeds: Vec<f64> = crowned.crossings.iter().map(|c| c.value).collect();
    assert_eq!(speeds.len(), 2, "{:?}", crowned.crossings);
    assert!((speeds[0] - 4.2923828).abs() > 1e-3 && (speeds[1] - 6.0242624).abs() > 1e-3);
}
