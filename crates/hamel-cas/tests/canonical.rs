//! The normal form decides zero, equality and dependence exactly.

use hamel_cas::{CasError, Field, FieldSpec, run};
use hamel_expr::{Expr, parse};

fn spec(exprs: &[&str]) -> FieldSpec {
    FieldSpec {
        coordinates: vec!["x".into(), "theta".into(), "phi".into()],
        parameters: vec!["m".into(), "l".into()],
        free_functions: vec![("z".into(), vec!["phi".into()])],
        free_order: 2,
        unknowns: vec![],
        expressions: exprs.iter().map(|s| parse(s).unwrap().expr).collect(),
    }
}

/// Convert each expression in one field and return canonical texts.
fn canon(exprs: &'static [&'static str]) -> Vec<String> {
    run(move || {
        let f = Field::new(&spec(exprs)).unwrap();
        exprs
            .iter()
            .map(|s| f.convert(&parse(s).unwrap().expr).unwrap().to_string())
            .collect()
    })
    .unwrap()
}

#[test]
fn pythagoras_and_friends_are_zero() {
    let out = canon(&[
        "sin(theta)^2 + cos(theta)^2 - 1",
        "sin(2*theta) - 2*sin(theta)*cos(theta)",
        "cos(theta + phi) - (cos(theta)*cos(phi) - sin(theta)*sin(phi))",
        "tan(theta)*cos(theta) - sin(theta)",
        "sin(theta)^4 - cos(theta)^4 - (sin(theta)^2 - cos(theta)^2)",
        "sin(theta/2)^2 - (1 - cos(theta))/2",
        "sqrt(1 + x^2)^2 - 1 - x^2",
        "sqrt(9/4) - 3/2",
    ]);
    for (i, s) in out.iter().enumerate() {
        assert_eq!(s, "0", "expression {i}");
    }
}

#[test]
fn equality_is_decided_by_subtraction() {
    // s/(1+c) = (1-c)/s on the circle: one canonical form (both are tan(θ/2)).
    let out = run(|| {
        let exprs = [
            "sin(theta)/(1 + cos(theta))",
            "(1 - cos(theta))/sin(theta)",
            "m*l^2/24",
            "l*m*l/24",
        ];
        let f = Field::new(&spec(&exprs)).unwrap();
        let e: Vec<_> = exprs
            .iter()
            .map(|s| f.convert(&parse(s).unwrap().expr).unwrap())
            .collect();
        (
            (&e[0] - &e[1]).is_zero(),
            e[0] == e[1],
            e[2].to_string(),
            e[2] == e[3],
            (&e[0] - &e[2]).is_zero(),
        )
    })
    .unwrap();
    assert_eq!(out, (true, true, "1/24*m*l^2".to_string(), true, false));
}

#[test]
fn dependence_is_decided_exactly() {
    let deps = run(|| {
        let exprs = [
            "sin(theta)^2*m + m*cos(theta)^2", // free of theta
            "z(phi)*der(x)",                    // depends on phi through z
            "x*sin(theta)",
            "(1 + cos(phi))*(1 - cos(phi))/sin(phi)^2", // = 1
            // = (1 - cos(phi))/sin(phi): free of theta although theta's variables remain
            "(sin(theta)*(1 - cos(phi)) + cos(theta)*sin(phi))/(sin(theta)*sin(phi) + cos(theta)*(1 + cos(phi)))",
        ];
        let f = Field::new(&spec(&exprs)).unwrap();
        exprs
            .iter()
            .map(|s| f.convert(&parse(s).unwrap().expr).unwrap().coordinate_dependence())
            .collect::<Vec<_>>()
    })
    .unwrap();
    assert_eq!(deps, vec![vec![], vec![2], vec![0, 1], vec![], vec![2]]);
}

#[test]
fn derivatives_follow_the_chain_rule() {
    let out = run(|| {
        let exprs = [
            "sin(theta)*cos(theta)",
            "z(phi)^2",
            "sqrt(1 + x^2)",
            "cos(2*theta)",
            "sin(theta/2)",
        ];
        let f = Field::new(&spec(&exprs)).unwrap();
        let c = |s: &str| f.convert(&parse(s).unwrap().expr).unwrap();
        let checks = [
            (c(exprs[0]).diff(1), c("cos(theta)^2 - sin(theta)^2")),
            (
                c(exprs[1]).diff(2),
                c("2*z(phi)")
                    * f.convert(&Expr::Free {
                        name: "z".into(),
                        args: vec!["phi".into()],
                        orders: vec![1],
                    })
                    .unwrap(),
            ),
            (c(exprs[2]).diff(0), c("x/sqrt(1 + x^2)")),
            (c(exprs[3]).diff(1), c("-2*sin(2*theta)")),
            (c(exprs[4]).diff(1), c("cos(theta/2)/2")),
        ];
        checks
            .iter()
            .map(|(a, b)| (a - b).is_zero())
            .collect::<Vec<_>>()
    })
    .unwrap();
    assert_eq!(out, vec![true; 5]);
}

#[test]
fn velocities_are_independent_variables() {
    let out = run(|| {
        let exprs = ["m/2*der(x)^2 + m*l*cos(theta)*der(x)*der(theta)"];
        let f = Field::new(&spec(&exprs)).unwrap();
        let t = f.convert(&parse(exprs[0]).unwrap().expr).unwrap();
        let a01 = t.diff_velocity(0).diff_velocity(1);
        (a01.to_string(), a01.has_velocities(), t.has_velocities())
    })
    .unwrap();
    assert_eq!(out, ("cos(theta)*m*l".to_string(), false, true));
}

#[test]
fn division_by_an_identically_zero_expression_is_an_error() {
    let out = run(|| {
        let exprs = ["1/(sin(theta)^2 + cos(theta)^2 - 1)"];
        let f = Field::new(&spec(&exprs)).unwrap();
        f.convert(&parse(exprs[0]).unwrap().expr)
            .map(|e| e.to_string())
    })
    .unwrap();
    assert!(matches!(out, Err(CasError::Unsupported(m)) if m.contains("identically zero")));
}

#[test]
fn printing_is_independent_of_the_order_symbols_were_created() {
    // Two fields built with the expressions in opposite orders print the same canonical text.
    let a = canon(&["cos(phi)*m + sin(theta)*l", "m*l*x"]);
    let b = run(|| {
        let exprs = ["m*l*x", "cos(phi)*m + sin(theta)*l"];
        let f = Field::new(&spec(&exprs)).unwrap();
        let e = f.convert(&parse(exprs[1]).unwrap().expr).unwrap();
        e.to_string()
    })
    .unwrap();
    assert_eq!(a[0], b);
}

#[test]
fn a_bare_sine_in_a_denominator_cancels_when_it_can() {
    let out = canon(&[
        "(1 - cos(theta)^2)/sin(theta)",
        "(cos(theta)^3 - cos(theta))/sin(theta)",
        "1/sin(theta)",
    ]);
    assert_eq!(out[0], "sin(theta)");
    assert_eq!(out[1], "-sin(theta)*cos(theta)");
    // Nothing cancels: kept as it is (1/sin, not sin/(1 - cos²)).
    assert_eq!(out[2], "1/sin(theta)");
}

#[test]
fn dependence_conditions_are_the_coefficients_of_the_derivative() {
    let out = run(|| {
        let exprs = [
            // free of theta iff z = 0 (one condition, the coefficient of cos(theta))
            "z(phi)*sin(theta) + m",
            // free of theta: no condition
            "sin(theta)^2 + cos(theta)^2 + z(phi)",
            // d/dtheta = (z - l)*cos(theta) - m*sin(theta): two conditions
            "(z(phi) - l)*sin(theta) + m*cos(theta)",
        ];
        let f = Field::new(&spec(&exprs)).unwrap();
        let theta = f.coord_index("theta").unwrap();
        exprs
            .iter()
            .map(|s| {
                let e = f.convert(&parse(s).unwrap().expr).unwrap();
                let conds = e.dependence_conditions(theta);
                let solved: Vec<String> = conds
                    .iter()
                    .filter_map(|c| c.solve_for_free("z").map(|x| x.to_string()))
                    .collect();
                (
                    conds.iter().map(|c| c.to_string()).collect::<Vec<_>>(),
                    solved,
                )
            })
            .collect::<Vec<_>>()
    })
    .unwrap();
    assert_eq!(out[0].0, vec!["z(phi)"]);
    assert_eq!(out[0].1, vec!["0"]);
    assert!(out[1].0.is_empty());
    assert_eq!(out[2].0.len(), 2, "{:?}", out[2].0);
    // One of them is z − l = 0 (up to sign), solved for z = l; the other, m = 0, has no z.
    assert_eq!(out[2].1, vec!["l"]);
}

#[test]
fn solving_refuses_derivatives_and_higher_degrees() {
    let out = run(|| {
        let exprs = ["z(phi)^2 - l", "z(phi)", "m*z(phi) - l*phi"];
        let f = Field::new(&spec(&exprs)).unwrap();
        let phi = f.coord_index("phi").unwrap();
        let mut e: Vec<_> = exprs
            .iter()
            .map(|s| f.convert(&parse(s).unwrap().expr).unwrap())
            .collect();
        // z'(phi) + z(phi)
        e[1] = &e[1].diff(phi) + &e[1];
        e.iter()
            .map(|e| e.solve_for_free("z").map(|x| x.to_string()))
            .collect::<Vec<_>>()
    })
    .unwrap();
    assert_eq!(out[0], None);
    assert_eq!(out[1], None);
    assert_eq!(out[2].as_deref(), Some("phi*l/m"));
}

#[test]
fn a_value_free_of_an_angle_never_mentions_it() {
    // The common factor sin(θ)·tan(φ/2) + cos(θ) is no polynomial in sin φ, cos φ: only lowest
    // terms in tan(φ/2) find it (issue 15).
    let out = run(|| {
        let exprs = [
            "(sin(theta)*(1 - cos(phi)) + cos(theta)*sin(phi))/(sin(theta)*sin(phi) + cos(theta)*(1 + cos(phi)))",
            "(1 - cos(phi))/sin(phi)",
            "sin(phi)/(1 + cos(phi))",
        ];
        let f = Field::new(&spec(&exprs)).unwrap();
        let theta = f.coord_index("theta").unwrap();
        let e: Vec<_> = exprs
            .iter()
            .map(|s| f.convert(&parse(s).unwrap().expr).unwrap())
            .collect();
        (
            e[0].mentions(theta),
            e.iter().map(|x| x.to_string()).collect::<Vec<_>>(),
        )
    })
    .unwrap();
    assert!(
        !out.0,
        "the canonical form of a value free of theta mentions theta"
    );
    assert_eq!(out.1[0], out.1[1]);
    assert_eq!(out.1[1], out.1[2]);
}

#[test]
fn denominators_print_as_powers_of_their_factors() {
    // (sin θ cos φ + 2)² reduced modulo sin² + cos² − 1 is no square of a polynomial in
    // (sin, cos): the factors come from the unique factorisation in tan(θ/2), tan(φ/2).
    let out = canon(&["1/(sin(theta)*cos(phi) + 2)^2", "m/(sin(theta)^2*cos(phi))"]);
    assert_eq!(out[0], "1/(sin(theta)*cos(phi) + 2)^2");
    assert!(out[1].contains("cos(phi)"), "{}", out[1]);
    assert!(
        !out[1].contains("cos(theta)^2*cos(phi) - cos(phi)"),
        "{}",
        out[1]
    );
}
