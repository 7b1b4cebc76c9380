//! Stored derivations (issue 59): every bundled model's derivation for every choice without
//! free functions, written and read back (`hamel_derive::store`), is the same derivation: written
//! again, the same bytes; printed for a reader, the same JSON; compiled, the same numbers to the
//! bit. The CAS runs in-process on its one worker thread (to derive); reading needs none.

mod common;

use hamel_derive::store::{StoreError, from_bytes, to_bytes};

#[test]
fn a_stored_derivation_reads_back_as_itself() {
    let mut checked = 0;
    for model in common::models() {
        let model = model.with_supports().unwrap();
        for choice in model.choices.iter().filter(|c| c.free_functions.is_empty()) {
            let d = hamel_derive::derive(&model, Some(&choice.name)).unwrap();
            let bytes = to_bytes(&d).unwrap();
            let back = from_bytes(&bytes).unwrap();
            let what = format!("{} {}", model.name, choice.name);
            assert!(
                to_bytes(&back).unwrap() == bytes,
                "{what}: written again, other bytes"
            );
            let json = |d: &hamel_derive::Derivation| serde_json::to_string(&d.json()).unwrap();
            assert_eq!(json(&back), json(&d), "{what}");
            let (c, cb) = (
                d.compile_with_constraint_forces().unwrap(),
                back.compile_with_constraint_forces().unwrap(),
            );
            let q: Vec<f64> = (0..d.ell).map(|k| 0.3 + 0.1 * k as f64).collect();
            let eta: Vec<f64> = (0..d.sigma).map(|i| 0.7 - 0.2 * i as f64).collect();
            let (a, b) = (
                c.rhs::<f64>(&q, &eta, &d.parameters),
                cb.rhs::<f64>(&q, &eta, &d.parameters),
            );
            match (a, b) {
                (Ok(a), Ok(b)) => {
                    assert_eq!(a.eta_dot, b.eta_dot, "{what}");
                    assert_eq!(a.q_dot, b.q_dot, "{what}");
                }
                (a, b) => assert_eq!(a.is_ok(), b.is_ok(), "{what}"),
            }
            assert_eq!(
                c.constraint_force_names(),
                cb.constraint_force_names(),
                "{what}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 20, "{checked} derivations");
}

#[test]
fn bytes_that_are_not_a_derivation_are_refused() {
    assert!(matches!(
        from_bytes(b"not cbor at all"),
        Err(StoreError::Unreadable(_))
    ));
    let mut other = Vec::new();
    ciborium::into_writer(&serde_json::json!({"format": 999}), &mut other).unwrap();
    assert!(matches!(
        from_bytes(&other),
        Err(StoreError::Format { found: 999 })
    ));
}
