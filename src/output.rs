//! Where results go: stdout or a file, written only once the whole result exists.

use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;

use hamel_model::ModelError;

/// The destination of a command's result.
pub struct Output(Option<PathBuf>);

fn io_error(path: &std::path::Path, what: &str, e: std::io::Error) -> ModelError {
    ModelError::new(
        &path.display().to_string(),
        Arc::new(String::new()),
        None,
        None,
        format!("{what}: {e}"),
    )
}

impl Output {
    /// A destination; checks up front that the file's directory exists, so that a command does
    /// not compute for minutes and then fail to write.
    pub fn new(path: Option<PathBuf>) -> Result<Output, ModelError> {
        if let Some(p) = &path {
            let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
            if let Some(d) = dir
                && !d.is_dir()
            {
                return Err(io_error(
                    p,
                    "cannot write the output",
                    std::io::Error::from(std::io::ErrorKind::NotFound),
                ));
            }
        }
        Ok(Output(path))
    }

    /// Write the complete result (to a temporary file renamed into place, for files:
    /// [`hamel_model::files`], so that an interrupted command leaves no partial file).
    pub fn write(&self, text: &str) -> Result<(), ModelError> {
        match &self.0 {
            None => {
                let mut stdout = std::io::stdout().lock();
                let written = stdout
                    .write_all(text.as_bytes())
                    .and_then(|_| stdout.flush());
                match written {
                    // The reader has gone (`hamel … | head`): stop quietly, as a shell's tools
                    // do, with the status of a process ended by SIGPIPE.
                    Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(141),
                    w => {
                        w.map_err(|e| io_error(std::path::Path::new("<stdout>"), "cannot write", e))
                    }
                }
            }
            Some(p) => hamel_model::files::write_whole(p, text.as_bytes())
                .map_err(|e| io_error(p, "cannot write the output", e)),
        }
    }
}

/// The text of an input file, or of stdin for `-`: (its name for messages, the text).
pub fn read_input(path: &str) -> Result<(String, String), ModelError> {
    let (name, text) = if path == "-" {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut std::io::stdin(), &mut s).map(|_| ("<stdin>", s))
    } else {
        std::fs::read_to_string(path).map(|s| (path, s))
    }
    .map_err(|e| {
        let (name, what) = if path == "-" {
            ("<stdin>", "cannot read")
        } else {
            (path, "cannot read the file")
        };
        ModelError::new(
            name,
            Arc::new(String::new()),
            None,
            None,
            format!("{what}: {e}"),
        )
    })?;
    Ok((name.to_string(), text))
}
