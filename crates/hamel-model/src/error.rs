//! The error of every hamel library call: located in an input file, or a failure of the
//! computer-algebra engine.

use std::fmt;
use std::ops::Range;
use std::sync::Arc;

use miette::{Diagnostic, LabeledSpan, SourceCode};

/// Why a hamel library call failed: a [`ErrorKind::Input`] error in a model (or scene, or
/// state) file — the file, where in it, and why — or an [`ErrorKind::Engine`] failure of the
/// computer-algebra engine, which is not the input's fault and names no file.
///
/// `Display` gives a one-line `file:line:col: key: reason` form; as a [`miette::Diagnostic`] it
/// renders the offending line with a label.
///
/// The details are boxed: a `Result<_, ModelError>` stays one pointer wide on the error side.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ModelError(Box<Located>);

/// What kind of failure a [`ModelError`] is.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// The input: a file, located in it.
    Input,
    /// The computer-algebra engine failed (its worker thread, or a construct it does not
    /// handle): a bug to report, whatever the input.
    Engine,
    /// The machine, not the input: a directory, a tool or the file system (the code cache,
    /// cargo).
    Environment,
}

#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
struct Located {
    kind: ErrorKind,
    file: String,
    source: Arc<String>,
    span: Option<Range<usize>>,
    key: Option<String>,
    message: String,
    help: Option<String>,
}

impl ModelError {
    /// An error at `span` (bytes of `source`), inside the value of `key`.
    pub fn new(
        file: &str,
        source: Arc<String>,
        span: Option<Range<usize>>,
        key: Option<&str>,
        message: impl Into<String>,
    ) -> ModelError {
        ModelError(Box::new(Located {
            kind: ErrorKind::Input,
            file: file.to_string(),
            source,
            span,
            key: key.map(str::to_string),
            message: message.into(),
            help: None,
        }))
    }

    /// A failure of the computer-algebra engine (no file, no place: it is not the input's).
    pub fn engine(failure: impl fmt::Display) -> ModelError {
        ModelError(Box::new(Located {
            kind: ErrorKind::Engine,
            file: String::new(),
            source: Arc::new(String::new()),
            span: None,
            key: None,
            message: failure.to_string(),
            help: Some("this is a bug in hamel, not in the input: please report it".into()),
        }))
    }

    /// A failure of the machine hamel runs on (no file, no place: it is not the input's).
    pub fn environment(failure: impl fmt::Display) -> ModelError {
        ModelError(Box::new(Located {
            kind: ErrorKind::Environment,
            file: String::new(),
            source: Arc::new(String::new()),
            span: None,
            key: None,
            message: failure.to_string(),
            help: None,
        }))
    }

    /// Add a hint on how to fix it.
    pub fn with_help(mut self, help: impl Into<String>) -> ModelError {
        self.0.help = Some(help.into());
        self
    }

    /// What kind of failure it is.
    pub fn kind(&self) -> ErrorKind {
        self.0.kind
    }

    /// The file name as given (`None` for an engine failure).
    pub fn file(&self) -> Option<&str> {
        (self.0.kind == ErrorKind::Input).then_some(self.0.file.as_str())
    }

    /// The reason, without location.
    pub fn message(&self) -> &str {
        &self.0.message
    }

    /// The key path in the file (such as `constraints.no_slip`), if known.
    pub fn key(&self) -> Option<&str> {
        self.0.key.as_deref()
    }

    /// 1-based line and column of the start of the span, if there is one.
    pub fn line_col(&self) -> Option<(usize, usize)> {
        let span = self.0.span.as_ref()?;
        let start = span.start.min(self.0.source.len());
        let before = &self.0.source[..start];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        Some((line, col))
    }
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.kind {
            ErrorKind::Engine => write!(f, "the computer-algebra engine failed: ")?,
            ErrorKind::Environment => {}
            ErrorKind::Input => {
                write!(f, "{}", self.0.file)?;
                if let Some((l, c)) = self.line_col() {
                    write!(f, ":{l}:{c}")?;
                }
                write!(f, ": ")?;
            }
        }
        if let Some(k) = &self.0.key {
            write!(f, "{k}: ")?;
        }
        write!(f, "{}", self.0.message)?;
        if let Some(h) = &self.0.help {
            write!(f, " (help: {h})")?;
        }
        Ok(())
    }
}

impl std::error::Error for ModelError {}

impl Diagnostic for ModelError {
    fn source_code(&self) -> Option<&dyn SourceCode> {
        // The file name and the help are part of the message itself (see Display).
        (self.0.kind == ErrorKind::Input).then_some(&*self.0.source as &dyn SourceCode)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        let span = self.0.span.clone()?;
        let len = span.end.saturating_sub(span.start);
        let label = match &self.0.key {
            Some(k) => format!("in {k}"),
            None => "here".to_string(),
        };
        Some(Box::new(std::iter::once(LabeledSpan::new(
            Some(label),
            span.start,
            len,
        ))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An engine failure is typed as such and names no file (it is not the input's); an input
    /// error names its file, line and column.
    #[test]
    fn engine_failures_name_no_file_and_input_errors_do() {
        let e = ModelError::engine("the computer-algebra thread has stopped");
        assert_eq!(e.kind(), ErrorKind::Engine);
        assert_eq!(e.file(), None);
        assert!(e.source_code().is_none());
        assert!(
            e.to_string()
                .starts_with("the computer-algebra engine failed: the computer-algebra thread")
        );
        let source = Arc::new("a = 1\nb = oops\n".to_string());
        let i = ModelError::new("m.toml", source, Some(10..14), Some("b"), "not a number");
        assert_eq!(i.kind(), ErrorKind::Input);
        assert_eq!(i.file(), Some("m.toml"));
        assert_eq!(i.to_string(), "m.toml:2:5: b: not a number");
        let m = ModelError::environment("cannot run cargo");
        assert_eq!((m.kind(), m.file()), (ErrorKind::Environment, None));
        assert_eq!(m.to_string(), "cannot run cargo");
    }
}
