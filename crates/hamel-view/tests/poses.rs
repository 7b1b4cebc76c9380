//! The frames' poses against an independent fact: a wheel rolls on the ground, so its lowest
//! point (the centre, minus the radius along the downward direction in the wheel's plane) is
//! at height zero, at every configuration that satisfies the holonomic constraints. The poses
//! are evaluated from the frames' expressions alone; the wheel's height is not one of them.

use hamel_bodies::Mechanism;
use hamel_model::Model;
use hamel_view::poses::{poses, rotate};
use rand::{Rng, SeedableRng};

fn model(name: &str) -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/");
    Model::load(format!("{path}{name}")).unwrap_or_else(|e| panic!("{e}"))
}

/// The height above the ground of wheel `w`'s lowest point at `q`.
fn lowest_point_height(m: &Mechanism, w: &hamel_bodies::Wheel, q: &[f64], model: &Model) -> f64 {
    let placed = poses(m, q, &model.parameters).unwrap();
    let pose = placed[&w.frame];
    let norm = pose.rotation.iter().map(|c| c * c).sum::<f64>().sqrt();
    assert!((norm - 1.0).abs() < 1e-14, "a unit quaternion: {norm}");
    let point = hamel_bodies::Point::at(&m.coordinates, q, &model.parameters);
    let axis = w.axis.vector().map(|e| point.value(&e).unwrap());
    let a = rotate(pose.rotation, axis);
    let up = m.world.up.vector().map(|e| point.value(&e).unwrap());
    let along = up[0] * a[0] + up[1] * a[1] + up[2] * a[2];
    let mut d = [0.0; 3];
    for i in 0..3 {
        d[i] = up[i] - along * a[i];
    }
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let r = point.value(&w.radius).unwrap();
    let c = pose.position;
    (0..3).map(|i| (c[i] - r * d[i] / n) * up[i]).sum()
}

#[test]
fn every_wheel_touches_the_ground_at_random_configurations() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(60);
    let names = [
        "bodies/rolling_disk_bodies.toml",
        "bodies/unicycle_rider_bodies.toml",
        "segway.toml",
        "diff_drive.toml",
        "whipple_bicycle.toml",
    ];
    for name in names {
        let model = model(name);
        let m = model.mechanism.as_ref().expect("a model of bodies");
        assert!(!m.wheels.is_empty(), "{name}");
        for _ in 0..20 {
            let mut q: Vec<f64> = (0..m.coordinates.len())
                .map(|_| rng.random_range(-0.6..0.6))
                .collect();
            model
                .completion
                .complete(&mut q, &model.parameters)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            for w in &m.wheels {
                let h = lowest_point_height(m, w, &q, &model);
                assert!(
                    h.abs() < 1e-12,
                    "{name}, wheel {}: height {h:e} at {q:?}",
                    w.name
                );
            }
        }
    }
}
