//! The printing forms of entries the issue names, checked exactly and parsed back.

use hamel_expr::parse;

use crate::{Printed, Vocabulary};

fn unicycle() -> Vocabulary {
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
    Vocabulary {
        parameters: names(&["m_d", "m_f", "m_r", "R", "rho", "rho1", "rho2"]),
        coordinates: names(&["xC", "yC", "phi", "psi", "theta", "theta1"]),
        velocities: names(&["eta1", "eta2", "eta3", "eta4"]),
    }
}

fn printed(text: &str, v: &Vocabulary) -> Printed {
    let p = Printed::new(&parse(text).unwrap().expr, v).unwrap();
    assert!(p.check(), "{text} → {}", p.text());
    let back = Printed::new(&parse(&p.text()).unwrap().expr, v).unwrap();
    assert_eq!(
        back.text(),
        p.text(),
        "the text parses back to the same form"
    );
    p
}

/// The unicycle's A[1,3] (issue 22): the paper's −F₁ cos φ, F₁ = (m_f ρ₁ + m_r(ρ₁ + ρ₂) +
/// m_d R) sin θ + m_r ρ sin θ₁.
#[test]
fn unicycle_a13_is_collected_and_factored() {
    let a13 = "-(cos(phi)*sin(theta)*R*m_d) - cos(phi)*sin(theta)*m_f*rho1 \
               - cos(phi)*sin(theta)*rho1*m_r - cos(phi)*sin(theta)*rho2*m_r \
               - cos(phi)*sin(theta1)*m_r*rho";
    let p = printed(a13, &unicycle());
    assert_eq!(
        p.text(),
        "-((m_d*R + m_f*rho1 + m_r*(rho1 + rho2))*sin(theta) + m_r*rho*sin(theta1))*cos(phi)"
    );
    assert_eq!(
        p.latex(),
        "-\\left(\\left(m_{d} R + m_{f} \\rho_{1} + m_{r} \\left(\\rho_{1} + \\rho_{2}\\right)\\right) \\sin \\theta + m_{r} \\rho \\sin \\theta_{1}\\right) \\cos \\varphi"
    );
}

#[test]
fn rationals_are_tfrac_and_negated_products_bare() {
    let v = unicycle();
    let p = printed("-3/2*m_d*R^2*eta1", &v);
    assert_eq!(p.latex(), "-\\tfrac{3}{2} m_{d} R^{2} \\eta_{1}");
    // A common denominator comes out in front.
    let p = printed("-3/2*m_d*R^2*eta1 + 1/2*m_f*rho1*eta2", &v);
    assert_eq!(
        p.latex(),
        "-\\tfrac{1}{2} \\left(3 m_{d} R^{2} \\eta_{1} - m_{f} \\rho_{1} \\eta_{2}\\right)"
    );
    assert_eq!(printed("-(m_d*R)", &v).latex(), "-m_{d} R");
}

#[test]
fn common_factors_and_content_come_out() {
    let v = unicycle();
    let p = printed("2*m_d*R*cos(theta)*eta1 + 4*m_d*R*sin(theta)*eta1", &v);
    assert_eq!(p.text(), "2*m_d*R*(cos(theta) + 2*sin(theta))*eta1");
}

#[test]
fn a_quotient_keeps_its_denominator() {
    let v = unicycle();
    let p = printed("(m_d*R*eta1)/(R^2*cos(theta)^2*m_d)", &v);
    assert!(p.check());
    assert!(p.latex().starts_with("\\frac{"), "{}", p.latex());
}

#[test]
fn zero_and_constants() {
    let v = unicycle();
    assert_eq!(printed("0", &v).text(), "0");
    assert_eq!(printed("3/4", &v).latex(), "\\tfrac{3}{4}");
    assert_eq!(printed("-m_d", &v).text(), "-m_d");
}

/// The unicycle's A as the paper prints it (section 3.4): one group of parameters named once,
/// and F₁(θ, θ₁) in four entries.
#[test]
fn unicycle_a_names_its_groups() {
    let snapshot =
        include_str!("../../../tests/snapshots/snapshots__derive__unicycle_rider__velocities.snap");
    let json = snapshot.splitn(3, "---\n").nth(2).unwrap();
    let a = json_matrix(json, "a");
    let mut sheet = crate::Sheet::new(&unicycle());
    let ids: Vec<Vec<usize>> = a
        .iter()
        .map(|row| {
            row.iter()
                .map(|e| sheet.add(&parse(e).unwrap().expr).unwrap())
                .collect()
        })
        .collect();
    sheet.name_groups();
    let names = sheet.definitions_text();
    assert_eq!(
        names[0],
        (
            "kappa1".into(),
            "m_d*R + m_f*rho1 + m_r*(rho1 + rho2)".into()
        )
    );
    assert!(
        names.contains(&(
            "F1(theta, theta1)".into(),
            "kappa1*sin(theta) + m_r*rho*sin(theta1)".into()
        )),
        "{names:?}"
    );
    assert_eq!(sheet.text(ids[0][2]), "-F1(theta, theta1)*cos(phi)");
    for id in ids.iter().flatten() {
        assert!(sheet.check(*id), "{}", sheet.text(*id));
    }
}

/// The rows of matrix `key` of a derive snapshot (a tiny reader: the entries are strings).
fn json_matrix(json: &str, key: &str) -> Vec<Vec<String>> {
    let start = json.find(&format!("\"{key}\": [")).unwrap() + key.len() + 5;
    let mut rows = Vec::new();
    let mut row: Vec<String> = Vec::new();
    let mut depth = 1;
    let mut chars = json[start..].chars();
    while let Some(c) = chars.next() {
        match c {
            '[' => depth += 1,
            ']' => {
                depth -= 1;
                if depth == 1 {
                    rows.push(std::mem::take(&mut row));
                }
                if depth == 0 {
                    break;
                }
            }
            '"' => row.push(chars.by_ref().take_while(|&c| c != '"').collect()),
            _ => {}
        }
    }
    rows
}

/// Monomial products and quotients as merges of sorted pairs.
#[test]
fn monomial_product_and_quotient() {
    use crate::Mono;
    let a = Mono::from_pairs([(0, 2), (3, 1), (5, 4)]);
    let b = Mono::from_pairs([(1, 1), (3, 2)]);
    let ab = a.mul(&b);
    assert_eq!(ab, Mono::from_pairs([(0, 2), (1, 1), (3, 3), (5, 4)]));
    assert_eq!(ab.div(&b), Some(a.clone()));
    assert_eq!(ab.div(&a), Some(b.clone()));
    assert_eq!(a.div(&b), None, "atom 1 is not in a");
    assert_eq!(
        a.div(&Mono::from_pairs([(3, 2)])),
        None,
        "exponent too high"
    );
    assert_eq!(
        a.div(&Mono::from_pairs([(7, 1)])),
        None,
        "an atom after a's last"
    );
    assert_eq!(a.div(&a), Some(Mono::default()));
    // Splitting the quotient without making it splits what dividing makes, for every divisor
    // of ab and every way of sorting the atoms (atom 3 leaves the quotient by ab / a^1 b^2).
    let divisors = [
        Mono::default(),
        b.clone(),
        a.clone(),
        Mono::from_pairs([(3, 3)]),
        Mono::from_pairs([(0, 1), (3, 2), (5, 4)]),
        ab.clone(),
    ];
    for g in &divisors {
        for keep in [
            |i: usize| i.is_multiple_of(2),
            |i: usize| i < 3,
            |_: usize| true,
        ] {
            let quotient = ab.div(g).expect("a divisor");
            assert_eq!(
                ab.split_divided(g, keep),
                quotient.split(keep),
                "ab / {g:?}"
            );
        }
    }
}

/// The flat polynomial's ways of adding agree: terms gathered in any order with repeats and
/// cancellations (`from_terms`), one at a time (`add_term`), a merge of two sorted runs
/// (`add_assign`) and a sum of fractions (`Fraction::sum`); the terms come out sorted, each
/// monomial once, no zero coefficient.
#[test]
fn flat_polynomials_add_alike() {
    use crate::{Fraction, Mono, Poly, Q};
    use hamel_expr::Rational;
    let q = |n: i64| -> Q { Rational::from_integer(n.into()).into() };
    let m = |pairs: &[(usize, u32)]| Mono::from_pairs(pairs.iter().copied());
    let terms = vec![
        (m(&[(2, 1)]), q(3)),
        (m(&[(0, 2)]), q(1)),
        (m(&[(0, 1), (1, 1)]), q(-2)),
        (m(&[(2, 1)]), q(-3)),
        (Mono::default(), q(5)),
        (m(&[(0, 2)]), q(4)),
    ];
    let gathered = Poly::from_terms(terms.clone());
    let mut one_by_one = Poly::default();
    for (mono, c) in terms.iter().cloned() {
        one_by_one.add_term(mono, c);
    }
    assert_eq!(gathered, one_by_one);
    assert_eq!(gathered.size(), 3, "x2 cancels, x0^2 is added up");
    let monomials: Vec<&Mono> = gathered.monomials().collect();
    assert!(
        monomials.windows(2).all(|w| w[0] < w[1]),
        "sorted, each once"
    );
    let (first, second) = terms.split_at(3);
    let mut merged = Poly::from_terms(first.to_vec());
    merged.add_assign(&Poly::from_terms(second.to_vec()));
    assert_eq!(merged, gathered);
    let parts = terms.iter().map(|(mono, c)| Fraction {
        num: Poly::term(mono.clone(), c.clone()),
        den: Poly::constant(q(1)),
    });
    assert_eq!(Fraction::sum(parts).num, gathered);
    assert!(Poly::from_terms(vec![(m(&[(1, 1)]), q(1)), (m(&[(1, 1)]), q(-1))]).is_zero());
}

/// `ratio` finds the constant between proportional polynomials and only then; `same`
/// compares fractions whose denominators are proportional.
#[test]
fn proportional_denominators() {
    use crate::{Fraction, Mono, Poly};
    use hamel_expr::Rational;
    let q = |n: i64, d: i64| Rational::new(n.into(), d.into());
    let mut p = Poly::default();
    p.add_term(Mono::atom(0), q(2, 3));
    p.add_term(Mono::atom(1), q(-1, 1));
    let p3 = p.scale(&q(-3, 2).into());
    assert_eq!(p3.ratio(&p), Some(q(-3, 2).into()));
    let mut other = p3.clone();
    other.add_term(Mono::atom(2), q(1, 1));
    assert_eq!(other.ratio(&p), None);
    let x = Fraction {
        num: Poly::term(Mono::atom(3), q(1, 1)),
        den: p.clone(),
    };
    let y = Fraction {
        num: Poly::term(Mono::atom(3), q(-3, 2)),
        den: p3.clone(),
    };
    assert!(x.same(&y));
    let z = Fraction {
        num: Poly::term(Mono::atom(3), q(3, 2)),
        den: p3,
    };
    assert!(!x.same(&z));
}

/// A tie between two parameters that could be pulled out of a coefficient goes to the one
/// occurring in more terms of the whole sheet, whatever the model's order.
#[test]
fn ties_in_factoring_go_to_the_parameter_of_more_terms() {
    use crate::Sheet;
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
    let v = Vocabulary {
        parameters: names(&["rho1", "rho2", "m_f", "m_r"]),
        coordinates: names(&["theta"]),
        velocities: Vec::new(),
    };
    let e1 = parse("m_f*rho1 + m_r*rho1 + m_r*rho2").unwrap().expr;
    let alone = Printed::new(&e1, &v).unwrap();
    assert_eq!(
        alone.text(),
        "rho1*(m_f + m_r) + rho2*m_r",
        "the model's order alone"
    );
    let e2 = parse("m_r*sin(theta) + m_r*cos(theta)*rho2").unwrap().expr;
    let mut sheet = Sheet::new(&v);
    let ids = sheet.add_all([&e1, &e2]).unwrap();
    assert_eq!(sheet.text(ids[0]), "rho1*m_f + m_r*(rho1 + rho2)");
    assert!(sheet.check(ids[0]) && sheet.check(ids[1]));
}

/// An entry shown twice is printed once but counted twice: a group it holds once recurs on
/// the page and is named, as it is when two different entries hold it.
#[test]
fn an_entry_shown_twice_counts_twice() {
    use crate::Sheet;
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
    let v = Vocabulary {
        parameters: names(&["a", "b", "c"]),
        coordinates: names(&["theta"]),
        velocities: Vec::new(),
    };
    let e = parse("(a + b + c)*sin(theta)*a + cos(theta)").unwrap().expr;
    let named = |n: usize| {
        let mut sheet = Sheet::new(&v);
        let id = sheet
            .add_counted([(crate::read::Source::Tree(&e), n)])
            .unwrap()[0];
        sheet.name_groups();
        assert!(sheet.check(id));
        sheet.definitions_text()
    };
    assert!(named(1).is_empty(), "once on the page: {:?}", named(1));
    // Twice: its parameter group is named, and so is the whole entry, a function of θ
    // shown twice (as a paper names what it writes twice).
    assert_eq!(
        named(2),
        [
            ("kappa1".to_string(), "a + b + c".to_string()),
            (
                "F1(theta)".to_string(),
                "cos(theta) + a*kappa1*sin(theta)".to_string()
            )
        ]
    );
}

/// A mass `m` under gravity `g` at angle θ, with two quasi-velocities and their rates.
fn pendulum_with_rates() -> Vocabulary {
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
    Vocabulary {
        parameters: names(&["m", "g"]),
        coordinates: names(&["theta"]),
        velocities: names(&["eta1", "eta1_dot", "eta2", "eta2_dot"]),
    }
}

/// An equation of motion is written as a paper writes `A_Γ η̇ + …`: its rate terms first,
/// collected by rate with their coefficients in parentheses, then the rest.
#[test]
fn equations_are_collected_by_the_rates_first() {
    let v = pendulum_with_rates();
    let row = "g*m*sin(theta) + m*eta1^2 + m*cos(theta)*eta2_dot + m*eta1_dot \
               + 2*m*sin(theta)*eta1_dot";
    let p = printed(row, &v);
    assert_eq!(
        p.text(),
        "m*((1 + 2*sin(theta))*eta1_dot + cos(theta)*eta2_dot + g*sin(theta) + eta1^2)"
    );
}

/// Equations with the same rate coefficient (the true equations and the paper's have A_Γ's
/// rows) share its collected group, one `Arc`, and each is still its canonical form.
#[test]
fn equations_share_their_rate_coefficients() {
    use crate::Sheet;
    use crate::form::{Factor, Form};
    let v = pendulum_with_rates();
    let rows = [
        "(m + g*cos(theta))*eta1_dot + m*eta1^2",
        "(m + g*cos(theta))*eta1_dot + g*sin(theta)*eta2",
    ];
    let exprs: Vec<_> = rows.iter().map(|r| parse(r).unwrap().expr).collect();
    let mut sheet = Sheet::new(&v);
    let ids = sheet.add_all(&exprs).unwrap();
    let rate_group = |f: &Form| match f {
        Form::Sum(terms) => match &terms[0] {
            Form::Product { factors, .. } => factors.iter().find_map(|x| match x {
                Factor::Group(g) => Some(g.clone()),
                _ => None,
            }),
            _ => None,
        },
        _ => None,
    };
    let (a, b) = (
        rate_group(sheet.form(ids[0])).expect("a rate coefficient in parentheses"),
        rate_group(sheet.form(ids[1])).expect("a rate coefficient in parentheses"),
    );
    assert!(std::sync::Arc::ptr_eq(&a, &b), "one group for both");
    for id in ids {
        assert!(sheet.check(id), "{}", sheet.text(id));
    }
}

/// A model's abbreviation is written wherever a group is a rational multiple of it, and the
/// names printing makes skip it.
#[test]
fn abbreviations_name_their_groups_up_to_a_factor() {
    use crate::Sheet;
    let v = unicycle();
    let mut sheet = Sheet::new(&v);
    sheet
        .abbreviate("m", &parse("m_d + m_f + m_r").unwrap().expr)
        .unwrap();
    sheet
        .abbreviate("kappa1", &parse("m_d*R + m_f*rho1").unwrap().expr)
        .unwrap();
    let es = [
        "2*m_d*cos(phi) + 2*m_f*cos(phi) + 2*m_r*cos(phi)",
        "(m_d + m_f + m_r)*sin(theta) + (R*m_d + rho2*m_r + rho*m_f)*sin(theta1)",
        "(R*m_d + rho2*m_r + rho*m_f)*cos(theta1)",
    ]
    .map(|e| parse(e).unwrap().expr);
    let ids = sheet.add_all(&es).unwrap();
    sheet.name_groups();
    assert_eq!(sheet.text(ids[0]), "2*m*cos(phi)");
    assert!(
        sheet.text(ids[1]).starts_with("m*sin(theta) + kappa2*"),
        "{}",
        sheet.text(ids[1])
    );
    for &i in &ids {
        assert!(sheet.check(i), "{}", sheet.text(i));
    }
    let names: Vec<String> = sheet
        .definitions_text()
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    assert_eq!(names, ["m", "kappa1", "kappa2"]);
    // Every given name's definition is written, whether it was given before the entries
    // were added or after them.
    let mut late = Sheet::new(&v);
    let ids = late.add_all(&es).unwrap();
    late.abbreviate("m", &parse("m_d + m_f + m_r").unwrap().expr)
        .unwrap();
    late.name_groups();
    assert_eq!(late.text(ids[0]), "2*m*cos(phi)");
    assert_eq!(late.definitions_text()[0].1, "m_d + m_f + m_r");
    assert_eq!(
        sheet.definitions_text()[..2],
        [
            ("m".to_string(), "m_d + m_f + m_r".to_string()),
            ("kappa1".to_string(), "m_d*R + m_f*rho1".to_string())
        ]
    );
}

/// A quotient's text has parentheses only where they are needed to read it back.
#[test]
fn quotients_have_parentheses_only_where_needed() {
    let v = unicycle();
    assert_eq!(
        printed("R*cos(phi)/sin(theta)", &v).text(),
        "R*cos(phi)/sin(theta)"
    );
    assert_eq!(
        printed("R/(m_d*sin(theta))", &v).text(),
        "R/(m_d*sin(theta))"
    );
    assert_eq!(
        printed("(R + rho)/sin(theta)^2", &v).text(),
        "(R + rho)/sin(theta)^2"
    );
    assert_eq!(printed("-4/(R + rho)", &v).text(), "(-4)/(R + rho)");
}

/// An equation num/D = 0 is written num = 0 with D as its multiplier where D's sign is proved
/// from the parameters declared positive (by −D where D < 0, the numerator negated), and kept
/// a fraction where it is not; the check covers the multiplied row.
#[test]
fn equations_are_multiplied_through_by_a_denominator_proved_positive() {
    use std::collections::BTreeSet;

    use crate::sheet::Sheet;

    let v = Vocabulary {
        parameters: vec!["m".into(), "R".into()],
        coordinates: vec!["theta".into()],
        velocities: vec!["eta1".into(), "eta1_dot".into()],
    };
    let positive: BTreeSet<String> = ["m".to_string(), "R".to_string()].into();
    let row = |den: &str, positive: &BTreeSet<String>| {
        let mut sheet = Sheet::new(&v);
        let text = format!("(m*eta1_dot + R*sin(theta)*eta1^2)/({den})");
        let id = sheet.add(&parse(&text).unwrap().expr).unwrap();
        sheet.name_groups();
        let done = sheet.multiply_through(id, positive);
        assert!(sheet.check(id), "{den}: {}", sheet.text(id));
        done.then(|| (sheet.text(id), sheet.multiplier_text(id).unwrap()))
    };
    let (num, d) = row("m*R^2*cos(theta)^2", &positive).expect("proved positive");
    assert_eq!(d, "m*R^2*cos(theta)^2");
    assert!(!num.contains('/'), "{num}");
    // D < 0 (or its minus sign moved to the numerator): multiplied by a positive multiple.
    let (num, d) = row("-(m*R + 2*R^2)", &positive).expect("proved negative");
    assert!(!d.starts_with('-') && num.starts_with('-'), "{num} | {d}");
    // Not proved: an odd power of cos θ, a parameter not declared, a sum of mixed signs.
    assert_eq!(row("m*cos(theta)", &positive), None);
    assert_eq!(row("m*R^2", &BTreeSet::new()), None);
    assert_eq!(row("m - R", &positive), None);
    // Even powers need no declaration.
    assert!(row("m^2 + R^2*cos(theta)^2", &BTreeSet::new()).is_some());
}

/// The check at a random point modulo a prime finds a printed form that is off by a term or
/// by a factor, with names and quotients, and passes the right one.
#[test]
fn the_modular_check_finds_a_wrong_form() {
    use crate::Sheet;
    use crate::form::{Factor, Form};
    let v = unicycle();
    let entries = [
        "(m_d*R*sin(theta) + m_f*rho1*sin(theta) + m_r*rho*sin(theta1))*cos(phi)",
        "(m_d*R*sin(theta) + m_f*rho1*sin(theta) + m_r*rho*sin(theta1))*sin(phi)*eta1",
        "(m_d + m_f*rho1*cos(theta))/(R^2*m_d + rho2*m_r*sin(theta)^2)",
    ];
    let exprs: Vec<_> = entries.iter().map(|e| parse(e).unwrap().expr).collect();
    let mut sheet = Sheet::new(&v);
    sheet.add_all(&exprs).unwrap();
    sheet.name_groups();
    assert!(!sheet.definitions().is_empty(), "a group is named");
    assert_eq!(sheet.first_mismatch(), None);
    for i in 0..entries.len() {
        // Doubled, and with one more factor of an atom: both differ from the canonical form.
        for wrong in [
            |f: Form| Form::Sum(vec![f.clone(), f]),
            |f: Form| Form::Product {
                coef: crate::Q::one(),
                factors: smallvec::smallvec![
                    Factor::Atom { index: 0, power: 1 },
                    Factor::Group(std::sync::Arc::new(f)),
                ],
            },
        ] {
            let mut bad = sheet.clone();
            bad.entries[i].0 = wrong(bad.entries[i].0.clone());
            assert_eq!(bad.first_mismatch(), Some(i), "entry {i}");
            assert!(!bad.check(i));
        }
    }
}

/// An exported canonical form reads as its tree does: the same fraction over the same atoms,
/// numbered in the order the tree meets them (numerator, then the denominator's factors),
/// with a rational scale, powers of factors, and an atom listed twice merged.
#[test]
fn canonical_forms_read_as_their_trees() {
    use hamel_expr::{Canonical, Expr, Func, Term};
    use num_bigint::BigInt;

    use crate::{Atoms, Fraction};

    let term = |coef: i64, powers: &[(u32, u32)]| Term {
        coef: coef.into(),
        powers: hamel_expr::Powers::from_slice(powers),
    };
    let cos = Expr::call(Func::Cos, Expr::sym("theta"));
    let atoms = vec![
        Expr::sym("m_r"),
        Expr::sym("rho"),
        cos.clone(),
        Expr::Der("phi".into()),
        cos,
    ];
    let polynomial = Canonical {
        atoms: atoms.clone(),
        ids: vec![],
        num: vec![
            term(-3, &[(1, 1), (2, 2)]),
            term(5, &[(0, 1), (3, 1), (4, 1)]),
            term(2, &[]),
        ],
        scale: BigInt::from(6),
        factors: vec![],
    };
    let mut quotient = Canonical {
        factors: vec![
            (vec![term(1, &[(1, 1)]), term(-1, &[(0, 2)])], 2),
            (vec![term(1, &[(2, 1)])], 1),
        ],
        scale: BigInt::from(-4),
        ..polynomial.clone()
    };
    quotient.order_factors();
    let v = unicycle();
    for c in [&polynomial, &quotient] {
        let (mut by_tree, mut by_canonical) = (Atoms::new(v.clone()), Atoms::new(v.clone()));
        by_tree.intern(&Expr::sym("rho1"));
        by_canonical.intern(&Expr::sym("rho1"));
        let tree = Fraction::from_expr(&c.to_expr(), &mut by_tree).unwrap();
        let read = Fraction::from_canonical(c, &mut by_canonical);
        assert_eq!(read.normalised(), tree.normalised(), "{}", c.to_expr());
        let keys = |a: &Atoms| {
            (0..a.len())
                .map(|i| a.get(i).key.clone())
                .collect::<Vec<_>>()
        };
        assert_eq!(keys(&by_canonical), keys(&by_tree));
        assert_eq!(
            by_tree.len(),
            5,
            "rho1, then rho, cos(theta), m_r, der(phi)"
        );
    }
}

/// The width of a form's LaTeX found from its pieces ([`crate::layout::latex_width_upto`],
/// what decides which groups are too wide without rendering them) is the width of its
/// rendering, for every group of every entry: powers of names, calls and roots, rationals,
/// quotients, names of the where-list, negative terms. Found up to a cap, it is over the cap
/// exactly when the width is.
#[test]
fn widths_from_pieces_are_widths_of_the_rendering() {
    use crate::form::{Factor, Form, Latex, render};
    use crate::layout::{latex_width_upto, width};
    let v = unicycle();
    let mut sheet = crate::Sheet::new(&v);
    let texts = [
        "-(cos(phi)*sin(theta)*R*m_d) - cos(phi)*sin(theta)*m_f*rho1 - cos(phi)*sin(theta1)*m_r*rho",
        "-3/2*m_d*R^2*eta1^2 + 1/2*m_f*rho1*eta2*cos(theta)^2 - 12*rho2^3*eta3",
        "(m_d*R^2 + sqrt(m_f)*rho1)/(2*cos(theta)^2 + 3*sin(theta)*rho - 5/7*rho2^2)",
        "der(xC)^2*m_r - exp(theta1)*sin(theta + phi)^2/(rho1 + rho2)",
        "m_r*(rho1 + rho2)*cos(phi)*(m_f*rho1*eta1 - m_d*R*eta2) + m_r*(rho1 + rho2)*eta4",
    ];
    let exprs: Vec<_> = texts.iter().map(|t| parse(t).unwrap().expr).collect();
    sheet.add_all(exprs.iter()).unwrap();
    sheet.name_groups();
    fn groups<'f>(f: &'f Form, out: &mut Vec<&'f Form>) {
        out.push(f);
        match f {
            Form::Product { factors, .. } => factors.iter().for_each(|x| {
                if let Factor::Group(g) = x {
                    groups(g, out);
                }
            }),
            Form::Sum(terms) => terms.iter().for_each(|t| groups(t, out)),
            Form::Quotient(a, b) => {
                groups(a, out);
                groups(b, out);
            }
        }
    }
    let mut all = Vec::new();
    for (f, _) in &sheet.entries {
        groups(f, &mut all);
    }
    for d in sheet.definitions() {
        groups(&d.form, &mut all);
    }
    let mut known = 0;
    for g in all {
        let rendered = render(g, sheet.ctx(), &Latex);
        if let Some(w) = latex_width_upto(g, sheet.ctx(), usize::MAX) {
            assert_eq!(w, width(&rendered), "{rendered}");
            known += 1;
            for cap in [0, w / 2, w.saturating_sub(1), w, w + 1] {
                let capped = latex_width_upto(g, sheet.ctx(), cap);
                assert_eq!(
                    capped.map(|c| c > cap),
                    Some(w > cap),
                    "{rendered}, cap {cap}"
                );
            }
        }
    }
    assert!(known > 20, "{known} widths known without rendering");
}

/// Ranks kept as atoms are added agree with the printing order, whatever order the atoms
/// come in (what sorting factors and groups compares).
#[test]
fn ranks_are_the_printing_order() {
    let texts = [
        "sin(theta)",
        "m_r",
        "eta2_dot",
        "cos(phi)",
        "rho",
        "xC",
        "der(psi)",
        "R",
        "f(theta1)",
        "eta1",
        "m_d",
        "theta1^(1/2)",
        "cos(theta)",
    ];
    for shift in 0..texts.len() {
        let mut atoms = crate::atoms::Atoms::new(unicycle());
        for t in texts.iter().cycle().skip(shift).take(texts.len()) {
            atoms.intern(&parse(t).unwrap().expr);
        }
        for i in 0..atoms.len() {
            for j in 0..atoms.len() {
                assert_eq!(
                    atoms.rank(i).cmp(&atoms.rank(j)),
                    atoms.order(i).cmp(&atoms.order(j)),
                    "{} against {}",
                    atoms.get(i).key,
                    atoms.get(j).key
                );
            }
        }
    }
}

/// Places share a kind exactly when their forms are equal (compared whole): groups that
/// recur inside others, in quotients' denominators, and that differ only deep inside.
#[test]
fn kinds_are_equal_forms() {
    use crate::Sheet;
    use crate::places::{Places, kinds};
    let entries = [
        "(m_d + m_f)*(rho1 + rho2)*cos(phi) + (m_d + m_f)*sin(phi)",
        "((m_d + m_f)*(rho1 + rho2)*sin(theta) + m_r)*cos(theta1)",
        "((m_d + m_f)*(rho1 + rho2)*sin(theta) + m_r)*sin(theta1) + m_r*(rho1 - rho2)",
        "(m_d + m_f*cos(theta))/((rho1 + rho2)*sin(theta) + R)",
        "(m_d + m_f*cos(theta))/((rho1 - rho2)*sin(theta) + R) + eta1",
    ];
    let exprs: Vec<_> = entries.iter().map(|e| parse(e).unwrap().expr).collect();
    let mut sheet = Sheet::new(&unicycle());
    sheet.add_all(&exprs).unwrap();
    let velocity = |_: &crate::form::Factor| false;
    let mut places = Places::new(&velocity);
    for (f, _) in &sheet.entries {
        places.hashed_groups(f);
    }
    let found = places.out;
    // Each place's inner places (copied, where the group is shared with an earlier place)
    // are those its form has alone.
    for (p, k) in found.iter().enumerate() {
        let mut alone = Places::new(&velocity);
        alone.place(k.form);
        assert_eq!(alone.out.len(), k.end - p, "place {p}");
        for (i, a) in alone.out.iter().enumerate() {
            assert_eq!(
                (a.hash, a.end),
                (found[p + i].hash, found[p + i].end - p),
                "place {p}"
            );
        }
    }
    // Then every hash alike: the forms alone tell the places apart.
    let colliding: Vec<_> = found
        .iter()
        .map(|k| crate::places::Keyed { hash: 0, ..*k })
        .collect();
    for found in [&found, &colliding] {
        let kinds = kinds(found);
        let mut pairs = 0;
        for p in 0..found.len() {
            for q in 0..found.len() {
                let equal = found[p].form == found[q].form;
                assert_eq!(kinds[p] == kinds[q], equal, "places {p} and {q}");
                pairs += usize::from(equal && p != q);
            }
        }
        assert!(pairs >= 4, "groups recur: {pairs} pairs");
    }
}

/// A denominator exported in factors is printed in them, each to its power (`δ²`, never its
/// expansion), in text and LaTeX, and checked exactly; an even power of a factor is proved
/// positive, so an equation over it is multiplied through, and an odd one is not.
#[test]
fn a_denominator_stays_in_its_factors() {
    use std::collections::BTreeSet;

    use hamel_expr::{Canonical, Expr, Func, Term};
    use num_bigint::BigInt;

    use crate::form::{Latex, render};
    use crate::layout::{latex_width_upto, width};
    use crate::read::Source;
    use crate::sheet::Sheet;

    let term = |coef: i64, powers: &[(u32, u32)]| Term {
        coef: coef.into(),
        powers: hamel_expr::Powers::from_slice(powers),
    };
    let atoms = vec![
        Expr::sym("m_r"),
        Expr::sym("rho"),
        Expr::call(Func::Cos, Expr::sym("theta")),
        Expr::sym("eta1_dot"),
    ];
    // (m_r η̇₁ + ρ cos θ) / (4 (ρ − m_r²)² cos θ^k), printed over (m_r² − ρ)².
    let over = |k: u32| {
        let mut factors = vec![(vec![term(1, &[(1, 1)]), term(-1, &[(0, 2)])], 2)];
        if k > 0 {
            factors.push((vec![term(1, &[(2, 1)])], k));
        }
        Canonical {
            atoms: atoms.clone(),
            ids: vec![],
            num: vec![term(1, &[(0, 1), (3, 1)]), term(1, &[(1, 1), (2, 1)])],
            scale: BigInt::from(4),
            factors,
        }
    };
    let row = |c: &Canonical| {
        let mut sheet = Sheet::new(&unicycle());
        let id = sheet.add_counted([(Source::Canonical(c), 1)]).unwrap()[0];
        sheet.name_groups();
        assert_eq!(sheet.first_mismatch(), None);
        assert!(sheet.check(id), "{}", sheet.text(id));
        let den = match sheet.form(id) {
            crate::Form::Quotient(_, den) => (**den).clone(),
            other => panic!("a quotient: {other:?}"),
        };
        let latex = render(&den, sheet.ctx(), &Latex);
        assert_eq!(
            latex_width_upto(&den, sheet.ctx(), usize::MAX),
            Some(width(&latex)),
            "{latex}"
        );
        let text = sheet.text(id);
        let positive = BTreeSet::new();
        let through = sheet.multiply_through(id, &positive);
        assert!(sheet.check(id), "{}", sheet.text(id));
        (
            text,
            latex,
            through.then(|| sheet.multiplier_text(id).unwrap()),
        )
    };
    let (text, latex, multiplier) = row(&over(0));
    assert_eq!(text, "(m_r*eta1_dot + rho*cos(theta))/(4*(m_r^2 - rho)^2)");
    assert_eq!(latex, "4 \\left(m_{r}^{2} - \\rho\\right)^{2}");
    assert_eq!(multiplier.as_deref(), Some("4*(m_r^2 - rho)^2"));
    let (text, _, multiplier) = row(&over(1));
    assert_eq!(
        text,
        "(m_r*eta1_dot + rho*cos(theta))/(4*(m_r^2 - rho)^2*cos(theta))"
    );
    assert_eq!(multiplier, None, "cos θ's sign is not proved");
    assert_eq!(
        row(&over(2)).2.as_deref(),
        Some("4*(m_r^2 - rho)^2*cos(theta)^2")
    );
}

/// A group's shape (`naming.rs`: its number of terms and its atoms, read from its collected
/// form without expanding it) is what expanding it gives, for every kind of group in the
/// entries of four seed models' derivations (from their snapshots).
#[test]
fn group_shapes_are_what_expanding_gives() {
    let snapshots = [
        include_str!("../../../tests/snapshots/snapshots__derive__unicycle_rider__velocities.snap"),
        include_str!("../../../tests/snapshots/snapshots__derive__unicycle_rider__family.snap"),
        include_str!("../../../tests/snapshots/snapshots__derive__bar_wheels__paper_z.snap"),
        include_str!("../../../tests/snapshots/snapshots__derive__knife__general.snap"),
    ];
    for snapshot in snapshots {
        let json: serde_json::Value =
            serde_json::from_str(snapshot.splitn(3, "---\n").nth(2).unwrap()).unwrap();
        let names = |key: &str| -> Vec<String> {
            let list = json[key].as_array().unwrap();
            list.iter()
                .map(|s| s.as_str().unwrap().to_string())
                .collect()
        };
        let velocities = (1..=9).flat_map(|i| [format!("eta{i}"), format!("eta{i}_dot")]);
        let mut sheet = crate::Sheet::new(&Vocabulary {
            parameters: Vec::new(),
            coordinates: names("coordinates"),
            velocities: velocities.collect(),
        });
        let mut entries = Vec::new();
        for key in [
            "a",
            "a_gamma",
            "gamma",
            "q",
            "q_paper",
            "equations",
            "kinematics",
        ] {
            strings(&json[key], &mut entries);
        }
        // The matrices' entries (an equation's row, a kinematic equation's right side; not
        // the labels some lists hold).
        let exprs: Vec<_> = entries
            .iter()
            .filter_map(|e| parse(e).ok())
            .map(|p| p.expr)
            .collect();
        sheet.add_all(&exprs).unwrap();
        assert!(sheet.shapes_checked() > 3, "groups to check");
    }
}

/// Every string in `v` (arrays, nested), in order.
fn strings(v: &serde_json::Value, out: &mut Vec<String>) {
    match v {
        serde_json::Value::String(s) => out.push(s.clone()),
        serde_json::Value::Array(items) => items.iter().for_each(|x| strings(x, out)),
        _ => {}
    }
}

/// An exponent too large to pack in a monomial (65,535 or more) is refused with an error,
/// on every way in (a printed expression, a sheet's entry), not wrapped into another atom's
/// bits; one just below is printed exactly.
#[test]
fn exponents_too_large_to_print_are_refused() {
    let v = unicycle();
    let huge = "((sin(theta)^64)^64)^16*m_r + rho";
    let err = Printed::new(&parse(huge).unwrap().expr, &v).err();
    assert_eq!(err, Some(crate::PolyError::TooLarge));
    let mut sheet = crate::Sheet::new(&v);
    assert_eq!(
        sheet.add(&parse(huge).unwrap().expr).err(),
        Some(crate::PolyError::TooLarge)
    );
    let near = Printed::new(
        &parse("((sin(theta)^64)^64)^15*m_r + rho").unwrap().expr,
        &v,
    );
    let near = near.unwrap();
    assert!(near.check());
    assert!(near.text().contains("sin(theta)^61440"), "{}", near.text());
}
