//! The internal algorithms against their slow references (`hamel_cas::selfcheck`).

#[test]
fn fraction_free_inverse_equals_gauss_jordan_and_applies() {
    // three invertible matrices, the fourth singular for both methods
    assert_eq!(hamel_cas::selfcheck::fraction_free_inverse(), Ok(3));
}

#[test]
fn the_fast_way_back_gives_the_reference_canonical_form() {
    let cases = hamel_cas::selfcheck::half_angle_cases();
    assert!(cases > 200);
    assert_eq!(hamel_cas::selfcheck::half_angle_way_back(), Ok(cases));
}
