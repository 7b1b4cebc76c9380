//! What a page draws of a model of bodies, and the arrows of the contact forces, against facts
//! of the models themselves.

use hamel_model::Model;
use hamel_view::drawing::Form;
use hamel_view::{Drawing, Motion};
use indexmap::IndexMap;

fn model(name: &str) -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/");
    Model::load(format!("{path}{name}")).unwrap_or_else(|e| panic!("{e}"))
}

/// The Segway: two wheels of its radius, its body drawn by its three shapes (not as an
/// ellipsoid), every body's frame reported; the bicycle: four bodies, two of them
/// ellipsoids, two wheels of the benchmark's radii.
#[test]
fn wheels_shapes_and_bodies_are_drawn_as_the_model_says() {
    let segway = model("segway.toml");
    let m = segway.mechanism.as_ref().unwrap();
    let q0 = vec![0.0; m.coordinates.len()];
    let d = Drawing::of(m, &q0, &segway.parameters).unwrap();
    let wheels: Vec<f64> = (d.drawn.iter())
        .filter_map(|x| match x.form {
            Form::Wheel { radius, .. } => Some(radius),
            _ => None,
        })
        .collect();
    assert_eq!(wheels, vec![0.2, 0.2]);
    assert!(
        !d.drawn
            .iter()
            .any(|x| matches!(x.form, Form::Ellipsoid { .. }))
    );
    let names: Vec<&str> = d.drawn.iter().map(|x| x.name.as_str()).collect();
    for shape in ["platform", "column", "handlebar"] {
        assert!(names.contains(&shape), "{names:?}");
    }
    assert_eq!(d.bodies.len(), 3);
    assert_eq!(d.contacts.len(), 2);

    let bicycle = model("whipple_bicycle.toml");
    let m = bicycle.mechanism.as_ref().unwrap();
    let mut q0 = vec![0.0; m.coordinates.len()];
    bicycle
        .completion
        .complete(&mut q0, &bicycle.parameters)
        .unwrap();
    let d = Drawing::of(m, &q0, &bicycle.parameters).unwrap();
    let ellipsoids = d
        .drawn
        .iter()
        .filter(|x| matches!(x.form, Form::Ellipsoid { .. }));
    assert_eq!(ellipsoids.count(), 2);
    let mut radii: Vec<f64> = (d.drawn.iter())
        .filter_map(|x| match x.form {
            Form::Wheel { radius, .. } => Some(radius),
            _ => None,
        })
        .collect();
    radii.sort_by(f64::total_cmp);
    assert_eq!(radii, vec![0.3, 0.35]);
    assert_eq!(d.up, [0.0, 0.0, -1.0]);
}

/// A wheel's force arrow is longitudinal × the rolling direction + lateral × (up × rolling) +
/// normal × up: for the Segway heading along x, then turned a quarter to the left.
#[test]
fn force_arrows_follow_the_wheel_s_heading() {
    let segway = model("segway.toml");
    let m = segway.mechanism.as_ref().unwrap();
    let ell = m.coordinates.len();
    let psi = m.coordinates.iter().position(|c| c == "psi").unwrap();
    let mut turned = vec![0.0; ell];
    turned[psi] = std::f64::consts::FRAC_PI_2;
    let q = vec![vec![0.0; ell], turned];
    let d = Drawing::of(m, &q[0], &segway.parameters).unwrap();
    let mut motion = Motion::place("", m, &d, &segway.parameters, &[0.0, 1.0], &q).unwrap();
    let columns: IndexMap<String, Vec<Option<f64>>> = [
        ("force.left.longitudinal", 2.0),
        ("force.left.lateral", 3.0),
        ("force.left.normal", 5.0),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), vec![Some(v), Some(v)]))
    .collect();
    let forces = &segway.contact_forces;
    motion
        .add_arrows(m, &d, forces, &segway.parameters, &q, &columns)
        .unwrap();
    assert_eq!(motion.arrows.len(), 1, "only the left wheel has columns");
    let v = &motion.arrows[0].vectors;
    let want = [2.0, 3.0, 5.0, -3.0, 2.0, 5.0];
    for (got, want) in v.iter().zip(want) {
        assert!((got - want).abs() < 1e-12, "{v:?}");
    }
}
