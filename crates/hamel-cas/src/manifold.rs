//! The zero set of a holonomic constraint h(q) = 0, where rows of α may depend on each other
//! that do not elsewhere.
//!
//! **Job**: decide exactly whether an expression vanishes on the constraint manifold M = {h = 0}
//! (identically, as a function on M), so that a rank or a dependence can be decided on M
//! instead of on the whole configuration space. The four-wheeled car steered by two angles tied
//! by L sin(δL − δR) = 2b sin δL sin δR has rows of rank 8 off M and 7 on it.
//!
//! **How**: in the half-angle ring ([`crate::half`]), a unique factorisation domain, the image
//! of h factors; its factors that involve a coordinate are the components of M (the others,
//! in the parameters alone, vanish only at special parameter values). Where M is irreducible
//! (one prime p, the case handled), the ideal of M is (p), prime: an expression N/D vanishes
//! on M iff p divides the image of N (Hilbert's Nullstellensatz, over the complex points of
//! M), and it is a unit on M (a safe pivot) iff p divides neither. Both are exact divisions
//! on canonical forms, never samples.
//!
//! **Invariants**: the field has no kernels (square roots, exp, log, atan, atan2: in the
//! half-angle ring a relation they satisfy on the manifold, r² = G or exp(x) = 1 where x = 0,
//! is not imposed, so a non-divisibility would not prove a non-zero); otherwise, and
//! for an h that splits into several components, [`Field::manifold`] refuses with
//! [`CasError::Unsupported`].

use std::rc::Rc;

use crate::CasError;
use crate::field::{Ex, Field, FieldInner, Poly, VarKind};
use crate::half::{exact_quotient, half_factors, to_half};

/// The constraint manifold h = 0 of one holonomic constraint, irreducible.
pub struct Manifold {
    f: Rc<FieldInner>,
    /// The prime p of the half-angle ring whose zero set M is.
    prime: Poly,
}

impl Field {
    /// The manifold h = 0 ([`crate::manifold`]): an error when the field has square-root
    /// kernels, when h involves no coordinate, or when it splits into several components.
    pub fn manifold(&self, h: &Ex) -> Result<Manifold, CasError> {
        let f = self.inner();
        // A kernel (a square root, exp, log, atan, atan2 of the coordinates) is a variable of
        // the half-angle ring, but on the manifold it may satisfy relations the ring does not
        // know (r² = G; exp(x) = 1 where x = 0): a non-divisibility would prove nothing.
        if f.kinds.iter().any(|k| matches!(k, VarKind::Kernel(_))) {
            return Err(CasError::Unsupported(
                "a rank on a constraint manifold is decided only for expressions without square roots, exponentials, logarithms or arctangents".into(),
            ));
        }
        let mut components = half_factors(f, &h.num)
            .primes
            .into_iter()
            .map(|p| p.image)
            .filter(|p| involves_a_coordinate(f, p));
        let (Some(prime), None) = (components.next(), components.next()) else {
            return Err(CasError::Unsupported(
                "the holonomic constraint's zero set is not one irreducible component in the coordinates".into(),
            ));
        };
        Ok(Manifold {
            f: self.0.clone(),
            prime,
        })
    }
}

impl Manifold {
    /// Whether `e` vanishes identically on the manifold (exact).
    pub fn vanishes(&self, e: &Ex) -> bool {
        debug_assert!(Rc::ptr_eq(&self.f, &e.f), "an expression of another field");
        e.is_zero() || exact_quotient(&to_half(&self.f, &e.num).0, &self.prime).is_some()
    }
}

/// Whether the half-angle polynomial `p` involves a coordinate (through a t or a variable).
fn involves_a_coordinate(f: &FieldInner, p: &Poly) -> bool {
    let half = &f.half;
    (0..half.back.len()).any(|hv| {
        if p.degree(hv) == 0 {
            return false;
        }
        let field_var = match half.back[hv] {
            Some(v) => v,
            None => {
                let a = half
                    .t
                    .iter()
                    .position(|&t| t == hv)
                    .expect("a t is an angle's");
                f.angles[a].sin
            }
        };
        !f.deps(field_var).is_empty()
    })
}

#[cfg(test)]
mod tests {
    use hamel_expr::parse;

    use crate::{Field, FieldSpec};

    fn field(exprs: &[&str]) -> Field {
        let expressions = exprs.iter().map(|e| parse(e).unwrap().expr).collect();
        Field::new(&FieldSpec {
            coordinates: vec!["a".into(), "b".into(), "x".into()],
            parameters: vec!["L".into(), "w".into()],
            expressions,
            ..FieldSpec::default()
        })
        .unwrap()
    }

    #[test]
    fn what_vanishes_on_the_ackermann_manifold_is_decided_exactly() {
        let h = "L*sin(a - b) - 2*w*sin(a)*sin(b)";
        // cot b − cot a − 2w/L vanishes on h = 0 (it is h/(L sin a sin b)); sin(a − b) does not.
        let on = "cos(b)/sin(b) - cos(a)/sin(a) - 2*w/L";
        let off = "sin(a - b)";
        crate::run(move || {
            let f = field(&[h, on, off]);
            let m = f
                .manifold(&f.convert(&parse(h).unwrap().expr).unwrap())
                .unwrap();
            let ex = |s: &str| f.convert(&parse(s).unwrap().expr).unwrap();
            assert!(m.vanishes(&ex(on)));
            assert!(m.vanishes(&ex("0")));
            assert!(!m.vanishes(&ex(off)));
            assert!(!m.vanishes(&ex("L")));
            // sin(a)·h vanishes there too; a product of two non-vanishing factors does not.
            assert!(m.vanishes(&ex(&format!("sin(a)*({h})"))));
            assert!(!m.vanishes(&ex("sin(a - b)*(x + 1)")));
        })
        .unwrap();
    }

    #[test]
    fn a_manifold_of_two_components_or_without_coordinates_is_refused() {
        crate::run(|| {
            let f = field(&["x^2 - 1", "L - 1"]);
            let ex = |s: &str| f.convert(&parse(s).unwrap().expr).unwrap();
            assert!(f.manifold(&ex("x^2 - 1")).is_err());
            assert!(f.manifold(&ex("L - 1")).is_err());
            assert!(f.manifold(&ex("x - 1")).is_ok());
        })
        .unwrap();
    }
}
