//! The choice of quasi-velocities a command uses, and the note that names hamel's default.

use std::path::Path;

use hamel_model::{Model, ModelError, QuasiVelocityChoice};

/// When `choice` is the default hamel took (the file names no quasi-velocities), say so on
/// stderr, with the table to paste.
pub fn note_default(model: &Model, choice: &QuasiVelocityChoice) {
    if let Some(note) = model.default_choice_note(choice) {
        eprintln!("{note}");
    }
}

/// Load a model for a command that uses the choice `eta`, with [`note_default`].
pub fn load_for(path: &Path, eta: Option<&str>) -> Result<Model, ModelError> {
    let model = Model::load(path)?;
    if let Ok(choice) = model.choice(eta) {
        note_default(&model, choice);
    }
    Ok(model)
}
