//! The model file a search worker loads: the model's own file when it still holds the text
//! the model was read from, else the text written to a private temporary file (a model given
//! as TOML text, or a file changed since), removed when the search ends.

use std::path::{Path, PathBuf};

/// A model file for a worker, removed on drop when it is a temporary one.
pub struct ModelFile {
    path: PathBuf,
    temporary: bool,
}

impl ModelFile {
    /// Its path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ModelFile {
    fn drop(&mut self) {
        if self.temporary {
            let _ = std::fs::remove_file(&self.path);
            if let Some(dir) = self.path.parent() {
                let _ = std::fs::remove_dir(dir);
            }
        }
    }
}

/// The file holding `model`'s text.
pub fn model_file(model: &hamel_model::Model) -> Result<ModelFile, String> {
    let own = PathBuf::from(&model.file);
    if std::fs::read_to_string(&own).is_ok_and(|text| text == *model.source) {
        return Ok(ModelFile {
            path: own,
            temporary: false,
        });
    }
    let dir = private_dir().map_err(|e| format!("cannot write the model for the search: {e}"))?;
    let path = dir.join("model.toml");
    std::fs::write(&path, model.source.as_bytes())
        .map_err(|e| format!("cannot write the model for the search: {e}"))?;
    Ok(ModelFile {
        path,
        temporary: true,
    })
}

/// A new directory of the system's temporary one that only this user can enter.
fn private_dir() -> std::io::Result<PathBuf> {
    let base = std::env::temp_dir();
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let dir = base.join(format!("hamel-search-{}-{nanos}", std::process::id()));
    let mut builder = std::fs::DirBuilder::new();
    #[cfg(unix)]
    std::os::unix::fs::DirBuilderExt::mode(&mut builder, 0o700);
    builder.create(&dir)?;
    Ok(dir)
}
