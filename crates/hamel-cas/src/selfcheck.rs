//! Checks of internal algorithms against their slow references, callable from outside the
//! crate (`tests/selfcheck.rs`) so that the crate is not compiled a second time as a unit-test
//! harness (it instantiates much of Symbolica: minutes of a release build).
//!
//! Each check runs on the worker ([`crate::run`]) and returns the number of cases it checked,
//! or the first case where the fast and the reference way disagree.

use hamel_expr::parse;

use crate::half::{HalfFactors, canonical_over_impl, half_factors};
use crate::vars::Poly;
use crate::{Field, FieldSpec, Matrix, run};

/// A field over x, θ, φ and the parameters m, l for these expressions.
fn field_of(all: &[&str]) -> Result<Field, String> {
    let expressions = all
        .iter()
        .map(|s| parse(s).map(|p| p.expr).map_err(|e| e.to_string()))
        .collect::<Result<Vec<_>, _>>()?;
    Field::new(&FieldSpec {
        coordinates: vec!["x".into(), "theta".into(), "phi".into()],
        parameters: vec!["m".into(), "l".into()],
        free_functions: vec![],
        free_order: 0,
        unknowns: vec![],
        expressions,
    })
    .map_err(|e| e.to_string())
}

fn convert(f: &Field, s: &str) -> Result<crate::Ex, String> {
    let e = parse(s).map_err(|e| e.to_string())?.expr;
    f.convert(&e).map_err(|e| e.to_string())
}

/// Matrices like [Z; α]: trigonometric rows, parameters, fractions, a row that needs a swap
/// (zero leading entry), and a singular one (the last).
const MATRICES: &[&[&str]] = &[
    &[
        "cos(theta)",
        "sin(theta)",
        "0",
        "-sin(theta)",
        "cos(theta)",
        "0",
        "0",
        "l",
        "1",
    ],
    &[
        "0",
        "1",
        "m",
        "1/(1 + cos(theta))",
        "sin(theta)",
        "0",
        "m*sin(phi)",
        "0",
        "l*cos(phi)",
    ],
    &[
        "m + l*cos(theta)^2",
        "l*sin(theta)*cos(phi)",
        "x",
        "l*sin(theta)*cos(phi)",
        "m/(2 + sin(phi))",
        "1",
        "sin(theta)",
        "cos(theta)",
        "sin(theta)/cos(phi)",
    ],
    &[
        "sin(theta)",
        "cos(theta)",
        "1",
        "2*sin(theta)",
        "2*cos(theta)",
        "2",
        "x",
        "m",
        "l",
    ],
];

/// The fraction-free inverse of [Z; α] (`bareiss`, (4)–(5)) against Gauss–Jordan on the
/// canonical forms: equal inverses and determinants, and the same verdict on singularity.
pub fn fraction_free_inverse() -> Result<usize, String> {
    run(|| {
        let all: Vec<&str> = MATRICES.iter().flat_map(|m| m.iter().copied()).collect();
        let f = field_of(&all)?;
        let mut checked = 0;
        for (k, texts) in MATRICES.iter().enumerate() {
            let entries = texts
                .iter()
                .map(|t| convert(&f, t))
                .collect::<Result<Vec<_>, _>>()?;
            let m = Matrix::from_fn(3, 3, |i, j| entries[3 * i + j].clone());
            let pairs: Vec<_> = m.entries().iter().map(|e| (&e.num, &e.den)).collect();
            let ff = crate::bareiss::inverse(f.inner(), 3, &pairs)
                .map_err(|()| format!("matrix {k}: the fraction-free inverse does not apply"))?;
            let gj = m.inverse_gauss_jordan().map_err(|e| e.to_string())?;
            match (ff, gj) {
                (None, None) if k == MATRICES.len() - 1 => {}
                (Some((inv, det)), Some((ginv, gdet))) => {
                    if (&det.0, &det.1) != (&gdet.num, &gdet.den) {
                        return Err(format!("matrix {k}: the determinants differ"));
                    }
                    for (a, b) in inv.iter().zip(ginv.entries()) {
                        if (&a.0, &a.1) != (&b.num, &b.den) {
                            return Err(format!("matrix {k}: the inverses differ"));
                        }
                    }
                    checked += 1;
                }
                _ => {
                    return Err(format!(
                        "matrix {k}: the two methods disagree on singularity"
                    ));
                }
            }
        }
        Ok(checked)
    })
    .map_err(|e| e.to_string())?
}

const FACTORS: &[&str] = &[
    "sin(theta)",
    "1 + cos(theta)",
    "1 - cos(theta)",
    "sin(theta)*cos(phi) + 2",
    "m*sin(theta) + l*cos(phi)",
    "m*cos(theta)^2 + l",
    "sin(phi)",
    "l*sin(theta)*sin(phi) - m*cos(phi)",
];
const BASES: &[&str] = &[
    "1",
    "x + m*cos(theta)",
    "l*sin(phi) - m",
    "sin(theta) + x*cos(phi)",
];

/// Factors of the numerator, its base, and the denominator's factors with exponents.
type Case = (Vec<usize>, usize, Vec<(usize, u32)>);

/// Products of factors over products of factors, numerators sharing some of the denominators'
/// factors.
fn cases() -> Vec<Case> {
    let n = FACTORS.len();
    let mut out = Vec::new();
    for base in 0..BASES.len() {
        for i in 0..n {
            for j in 0..n {
                let den = vec![(j, 1 + (i % 2) as u32), ((j + 3) % n, 1)];
                out.push((vec![i, (i + j) % n], base, den));
            }
        }
    }
    out
}

/// The way back from the half-angle ring through preimages and the screen (`half`) against
/// the reference way back (the whole image mapped, every trial division done): the same
/// numerator, denominator, factors and degrees in every case.
pub fn half_angle_way_back() -> Result<usize, String> {
    run(|| {
        let all: Vec<&str> = FACTORS.iter().chain(BASES).copied().collect();
        let f = field_of(&all)?;
        let fi = f.inner();
        let poly = |s: &str| -> Result<Poly, String> { Ok(convert(&f, s)?.num) };
        let mut checked = 0;
        for (num, base, den) in cases() {
            let mut n = poly(BASES[base])?;
            for &k in &num {
                n = fi.reduce(&n * &poly(FACTORS[k])?);
            }
            let hfs = den
                .iter()
                .map(|&(k, e)| Ok((half_factors(fi, &poly(FACTORS[k])?), e)))
                .collect::<Result<Vec<(HalfFactors, u32)>, String>>()?;
            let refs: Vec<(&HalfFactors, u32)> = hfs.iter().map(|(h, e)| (h, *e)).collect();
            let c = fi.one();
            let fast = canonical_over_impl(fi, &n, &c, &refs, true);
            let slow = canonical_over_impl(fi, &n, &c, &refs, false);
            let primes = |h: &HalfFactors| -> Vec<(Poly, u32)> {
                h.primes.iter().map(|p| (p.image.clone(), p.exp)).collect()
            };
            let same = fast.0 == slow.0
                && fast.1 == slow.1
                && primes(&fast.2) == primes(&slow.2)
                && fast.2.m == slow.2.m;
            if !same {
                return Err(format!("case {num:?} {base} {den:?}: the ways back differ"));
            }
            checked += 1;
        }
        Ok(checked)
    })
    .map_err(|e| e.to_string())?
}

/// The number of cases [`half_angle_way_back`] checks.
pub fn half_angle_cases() -> usize {
    cases().len()
}
