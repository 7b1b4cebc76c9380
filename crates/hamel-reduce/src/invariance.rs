//! Coordinates that drop out by a symmetry, decided exactly. Runs on the CAS thread.
//!
//! Let ξ = Σ_j ξ_j(q) ∂/∂q_j be a vector field whose flow Φ_t leaves invariant
//! * the kinetic energy's metric and the potential: L_ξA = 0, L_ξU = 0;
//! * the constraints: L_ξα = Cα (each row's Lie derivative a combination of the rows);
//! * the quasi-velocities on the constraints: L_ξZ = Dα.
//!
//! Then Φ_t maps motions to motions and keeps η, so the equations η̇ = f(q, η) satisfy
//! f(Φ_t(q), η) = f(q, η), that is Σ_j ξ_j ∂f/∂q_j = 0. When ξ_k is a nonzero constant and
//! every other coordinate ξ moves is already known absent, ∂f/∂q_k = 0: q_k is absent. The rate
//! (Γη)_j of a coordinate that ξ does not move is invariant too, so it is free of q_k as well.
//!
//! The Lie derivatives are taken on canonical forms, and the constant matrices C and D are
//! found numerically at one point, read as small rationals, and then checked exactly: the
//! decision is the exact check. Candidates come from the model (`[symmetries]`, and the
//! rotation about the vertical a model of bodies suggests).

use hamel_cas::{Ex, Field, Matrix};
use hamel_derive::StructuredSymbolic;
use hamel_derive::certify::point;
use hamel_model::{Model, Symmetry};

/// A symmetry checked exactly.
pub(crate) struct Invariant {
    /// Its name.
    pub name: String,
    /// ξ as text.
    pub text: String,
    /// The coordinates it moves (ξ_j ≠ 0).
    pub moves: Vec<String>,
    /// ξ_j, every coordinate.
    xi: Vec<Ex>,
}

/// The model's symmetries that are exact invariances, and why each other one is not.
pub(crate) fn symmetries(model: &Model, s: &StructuredSymbolic) -> (Vec<Invariant>, Vec<String>) {
    let mut ok = Vec::new();
    let mut rejected = Vec::new();
    for sym in &model.symmetries {
        match check(model, s, sym) {
            Ok(inv) => ok.push(inv),
            Err(why) => rejected.push(format!(
                "`{}` ({}) is not a symmetry: {why}",
                sym.name,
                sym.text()
            )),
        }
    }
    (ok, rejected)
}

/// For each coordinate, the symmetry that proves it absent (given those already absent by
/// (31) in `absent`, which grows as coordinates are proved).
pub(crate) fn by_symmetry(invariant: &[Invariant], absent: &mut [bool]) -> Vec<Option<String>> {
    let mut out: Vec<Option<String>> = vec![None; absent.len()];
    loop {
        let mut changed = false;
        for inv in invariant {
            for k in 0..absent.len() {
                let shifts = inv.xi[k].is_number() && !inv.xi[k].is_zero();
                let others_absent = (0..absent.len())
                    .filter(|&j| j != k && !inv.xi[j].is_zero())
                    .all(|j| absent[j]);
                if !absent[k] && shifts && others_absent {
                    absent[k] = true;
                    out[k] = Some(inv.name.clone());
                    changed = true;
                }
            }
        }
        if !changed {
            return out;
        }
    }
}

/// Sentences on the symmetries: which proved what (`proved`: coordinate name and the symmetry
/// that proved it absent), and which were rejected.
pub(crate) fn symmetry_findings(
    invariant: &[Invariant],
    rejected: &[String],
    proved: &[(String, String)],
) -> Vec<String> {
    let mut out = Vec::new();
    for inv in invariant {
        let these: Vec<&str> = proved
            .iter()
            .filter(|(_, by)| *by == inv.name)
            .map(|(q, _)| q.as_str())
            .collect();
        if !these.is_empty() {
            out.push(format!(
                "absent by the symmetry `{}` (ξ: {}): L_ξA = 0, L_ξU = 0, L_ξα = Cα and L_ξZ = Dα hold exactly, and the other coordinates ξ moves are absent, so the equations are free of {}",
                inv.name,
                inv.text,
                these.join(", ")
            ));
        }
    }
    out.extend(rejected.iter().cloned());
    out
}

/// Check one candidate exactly.
fn check(model: &Model, s: &StructuredSymbolic, sym: &Symmetry) -> Result<Invariant, String> {
    let f = &s.field;
    let ell = model.ell();
    let mut xi = vec![f.zero(); ell];
    for (q, item) in &sym.components {
        let k = model
            .coordinates
            .iter()
            .position(|c| c == q)
            .ok_or("unknown coordinate")?;
        xi[k] = f.convert(&item.expr).map_err(|e| e.to_string())?;
    }
    let dxi: Vec<Vec<Ex>> = xi
        .iter()
        .map(|x| (0..ell).map(|a| x.diff(a)).collect())
        .collect();
    let lie = Lie {
        f,
        xi: &xi,
        dxi: &dxi,
    };
    if !lie.scalar(&s.u).is_zero() {
        return Err("L_ξU ≠ 0".into());
    }
    if !lie.metric(&s.a) {
        return Err("L_ξA ≠ 0".into());
    }
    if !s.forces.is_empty() && !lie.force(&s.forces).iter().all(Ex::is_zero) {
        return Err("L_ξF ≠ 0 (the generalised forces are not invariant)".into());
    }
    let rows = |m: &Matrix| -> Vec<Vec<Ex>> {
        (0..m.rows())
            .map(|i| lie.form(&(0..ell).map(|j| m[(i, j)].clone()).collect::<Vec<_>>()))
            .collect()
    };
    let at = point(0, &model.coordinates, &model.parameters);
    in_row_space(f, &rows(&s.alpha), &s.alpha, &at)
        .ok_or("L_ξα is not a constant combination of the rows of α")?;
    in_row_space(f, &rows(&s.z), &s.alpha, &at)
        .ok_or("L_ξZ is not a constant combination of the rows of α")?;
    Ok(Invariant {
        name: sym.name.clone(),
        text: sym.text(),
        moves: (0..ell)
            .filter(|&j| !xi[j].is_zero())
            .map(|j| model.coordinates[j].clone())
            .collect(),
        xi,
    })
}

/// Lie derivatives along ξ, with ∂ξ_j/∂q_a.
struct Lie<'a> {
    f: &'a Field,
    xi: &'a [Ex],
    dxi: &'a [Vec<Ex>],
}

impl Lie<'_> {
    /// Σ_j ξ_j ∂u/∂q_j.
    fn scalar(&self, u: &Ex) -> Ex {
        let f = self.f;
        self.xi
            .iter()
            .enumerate()
            .filter(|(_, x)| !x.is_zero())
            .fold(f.zero(), |acc, (j, x)| &acc + &(x * &u.diff(j)))
    }

    /// (L_ξω)_a = Σ_j ξ_j ∂ω_a/∂q_j + Σ_j ω_j ∂ξ_j/∂q_a.
    fn form(&self, w: &[Ex]) -> Vec<Ex> {
        (0..w.len())
            .map(|a| {
                (0..w.len())
                    .filter(|&j| !w[j].is_zero() && !self.dxi[j][a].is_zero())
                    .fold(self.scalar(&w[a]), |acc, j| {
                        &acc + &(&w[j] * &self.dxi[j][a])
                    })
            })
            .collect()
    }

    /// L_ξF for forces F(q, q̇): the one-form's [`Lie::form`] plus the prolongation's part,
    /// Σ_j ∂F_a/∂q̇_j ξ̇_j with ξ̇_j = Σ_b ∂ξ_j/∂q_b q̇_b (the flow moves the velocities too).
    fn force(&self, w: &[Ex]) -> Vec<Ex> {
        let f = self.f;
        let xi_dot: Vec<Ex> = (self.dxi.iter())
            .map(|row| {
                (row.iter().enumerate())
                    .filter(|(_, d)| !d.is_zero())
                    .fold(f.zero(), |acc, (b, d)| &acc + &(d * &f.velocity(b)))
            })
            .collect();
        self.form(w)
            .into_iter()
            .zip(w)
            .map(|(l, wa)| {
                (xi_dot.iter().enumerate())
                    .filter(|(_, x)| !x.is_zero())
                    .fold(l, |acc, (j, x)| &acc + &(&wa.diff_velocity(j) * x))
            })
            .collect()
    }

    /// Whether L_ξA = 0: (L_ξA)_ab = Σ_j ξ_j ∂A_ab/∂q_j + Σ_j A_jb ∂ξ_j/∂q_a + Σ_j A_aj ∂ξ_j/∂q_b.
    fn metric(&self, a: &Matrix) -> bool {
        let n = a.rows();
        (0..n).all(|r| {
            (r..n).all(|c| {
                let mut e = self.scalar(&a[(r, c)]);
                for j in 0..n {
                    if !self.dxi[j][r].is_zero() {
                        e = &e + &(&a[(j, c)] * &self.dxi[j][r]);
                    }
                    if !self.dxi[j][c].is_zero() {
                        e = &e + &(&a[(r, j)] * &self.dxi[j][c]);
                    }
                }
                e.is_zero()
            })
        })
    }
}

/// Whether each row of `r` is a combination of the rows of `alpha` with constant rational
/// coefficients: the coefficients by least squares at the point `at`, read as fractions with
/// small denominators, then the identity r = Cα checked exactly.
fn in_row_space(
    f: &Field,
    r: &[Vec<Ex>],
    alpha: &Matrix,
    at: &indexmap::IndexMap<String, f64>,
) -> Option<()> {
    if r.iter().flatten().all(Ex::is_zero) {
        return Some(());
    }
    let (mu, ell) = (alpha.rows(), alpha.cols());
    let env = |n: &str| at.get(n).copied();
    let value = |e: &Ex| e.to_expr().eval::<f64>(&env).ok();
    let a = nalgebra::DMatrix::from_fn(mu, ell, |i, j| value(&alpha[(i, j)]).unwrap_or(f64::NAN));
    let pinv = a.clone().pseudo_inverse(1e-12).ok()?;
    for row in r {
        let v = nalgebra::RowDVector::from_iterator(
            ell,
            row.iter().map(|e| value(e).unwrap_or(f64::NAN)),
        );
        let c = &v * &pinv;
        let exact: Vec<Ex> = c
            .iter()
            .map(|&x| small_rational(f, x))
            .collect::<Option<_>>()?;
        for (j, e) in row.iter().enumerate() {
            let combination = (0..mu).fold(f.zero(), |acc, m| &acc + &(&exact[m] * &alpha[(m, j)]));
            if !(e - &combination).is_zero() {
                return None;
            }
        }
    }
    Some(())
}

/// x as p/q with q ≤ 24 when it is that to 1e-9, as an exact value.
fn small_rational(f: &Field, x: f64) -> Option<Ex> {
    if !x.is_finite() {
        return None;
    }
    (1..=24i64).find_map(|q| {
        let p = (x * q as f64).round();
        ((x - p / q as f64).abs() <= 1e-9 * x.abs().max(1.0) && p.abs() < 1e12)
            .then(|| &f.int(p as i64) * &f.int(q).inv().expect("q ≠ 0"))
    })
}
