//! Located errors.

use std::fmt;
use std::ops::Range;
use std::sync::Arc;

use miette::{Diagnostic, LabeledSpan, SourceCode};

/// An error in a model (or scene, or state) file: the file, where in it, and why.
///
/// `Display` gives a one-line `file:line:col: key: reason` form; as a [`miette::Diagnostic`] it
/// renders the offending line with a label.
///
/// The details are boxed: a `Result<_, ModelError>` stays one pointer wide on the error side.
#[derive(Clone, Debug)]
pub struct ModelError(Box<Located>);

#[derive(Clone, Debug)]
struct Located {
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
            file: file.to_string(),
            source,
            span,
            key: key.map(str::to_string),
            message: message.into(),
            help: None,
        }))
    }

    /// Add a hint on how to fix it.
    pub fn with_help(mut self, help: impl Into<String>) -> ModelError {
        self.0.help = Some(help.into());
        self
    }

    /// The file name as given.
    pub fn file(&self) -> &str {
        &self.0.file
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
        write!(f, "{}", self.0.file)?;
        if let Some((l, c)) = self.line_col() {
            write!(f, ":{l}:{c}")?;
        }
        write!(f, ": ")?;
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
        Some(&*self.0.source as &dyn SourceCode)
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
