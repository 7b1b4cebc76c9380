//! What the fuzz targets share: a loaded model taken one step further, without the computer
//! algebra (so that a fuzzer may run many processes).

use hamel_model::{Model, NumericModel, sample_configurations};

/// Evaluate what a checked model defines at sample configurations: A, α, U, the forces, each
/// choice's Z, and the completion of the holonomic constraints. Errors (a singular point, a
/// domain error) are fine; the point is that nothing panics, hangs or exhausts the machine.
pub fn exercise(model: &Model) {
    let Ok(numeric) = NumericModel::new(model, &Default::default()) else {
        return;
    };
    let names: Vec<String> = model
        .choices
        .iter()
        .filter(|c| c.free_functions.is_empty())
        .map(|c| c.name.clone())
        .collect();
    for q in sample_configurations(model.coordinates.len(), 2, 5) {
        let _ = numeric.mass_matrix::<f64>(&q);
        let _ = numeric.constraint_matrix::<f64>(&q);
        let _ = numeric.potential::<f64>(&q);
        // at the configuration itself as velocities: any finite q̇ will do
        let _ = numeric.forces::<f64>(&q, &q);
        for c in &names {
            let _ = numeric.quasi_velocity_matrix::<f64>(c, &q);
        }
        let mut q = q.clone();
        let _ = model.completion.complete(&mut q, &model.parameters);
    }
    let _ = model.parameter_values(&Default::default());
}
