//! Errors as a library user sees them: typed, the cause as data (which row, which rank), with
//! the place in the model file as a site; the located diagnostic made at the edge
//! (`locate`) reads as the command line prints it. No error is recognised by its text.

use std::path::Path;

use hamel_derive::DeriveError;
use hamel_model::{ErrorKind, Model};
use hamel_reduce::{ReduceError, pass};

fn filetest(name: &str) -> Model {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/filetests")
        .join(name);
    Model::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_quasi_velocity_that_is_the_constraint_is_singular_at_its_choice() {
    let model = filetest("det_identically_zero.toml");
    let e = hamel_derive::derive(&model, None).unwrap_err();
    let DeriveError::Singular { site } = &e else {
        panic!("not Singular: {e:?}")
    };
    assert!(site.key.starts_with("quasi_velocities."), "{}", site.key);
    assert_eq!(e.kind(), ErrorKind::Input);
    let located = e.locate(&model);
    assert!(located.line_col().is_some());
    assert!(
        located
            .to_string()
            .contains("det[Z; α] is identically zero"),
        "{located}"
    );
}

#[test]
fn a_kinetic_energy_linear_in_the_velocities_is_not_quadratic_where_t_is_written() {
    let model = filetest("kinetic_not_quadratic.toml");
    match hamel_derive::derive(&model, None).unwrap_err() {
        DeriveError::NotQuadratic { site, detail } => {
            assert_eq!(site.key, "lagrangian.kinetic");
            assert!(detail.contains("degree 0 or 1"), "{detail}");
        }
        e => panic!("not NotQuadratic: {e:?}"),
    }
}

#[test]
fn an_unknown_coordinate_is_named_and_the_help_lists_the_coordinates() {
    let model = filetest("reduce_unknown_coordinate.toml");
    let asked = ["x".to_string(), "z".to_string()];
    let e = hamel_reduce::reduce(&model, Some("paper"), &asked).unwrap_err();
    assert!(
        matches!(&e, ReduceError::NotACoordinate { name } if name == "z"),
        "{e:?}"
    );
    let located = e.locate(&model);
    let text = located.to_string();
    assert!(
        text.contains("(help: the coordinates are x, y, theta)"),
        "{text}"
    );
}

#[test]
fn the_pass_carries_a_typed_error_across_the_worker_s_bytes() {
    // What `hamel derive-worker` writes and the caller reads: the same variant comes back.
    let model = filetest("det_identically_zero.toml");
    let job = pass::Job::new(&model, None, pass::Analysis::Equations).unwrap();
    let outcome = pass::make(&job).map(|_| ());
    let mut bytes = Vec::new();
    ciborium::into_writer(&outcome, &mut bytes).unwrap();
    let back: Result<(), ReduceError> = ciborium::from_reader(bytes.as_slice()).unwrap();
    assert!(
        matches!(back, Err(ReduceError::Derive(DeriveError::Singular { .. }))),
        "{back:?}"
    );
}
