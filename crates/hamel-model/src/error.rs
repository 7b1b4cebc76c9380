//! Located errors.

use std::fmt;
use std::ops::Range;
use std::sync::Arc;

use miette::{Diagnostic, LabeledSpan, SourceCode};

/// An error in a model (or scene, or state) file: the file, where in it, and why.
///
/// `Display` gives a one-line `file:line:col: key: reason` form; as a [`miette::Diagnostic`] it
/// renders the offending line with a label.
#[derive(Clone, Debug)]
pub struct ModelError {
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
        ModelError {
            file: file.to_string(),
            source,
            span,
            key: key.map(str::to_string),
            message: message.into(),
            help: None,
        }
    }

    /// Add a hint on how to fix it.
    pub fn with_help(mut self, help: impl Into<String>) -> ModelError {
        self.help = Some(help.into());
        self
    }

    /// The file name as given.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The reason, without location.
    pub fn message(&self) -> &str {
        &self.message
    }

    /// The key path in the file (such as `constraints.no_slip`), if known.
    pub fn key(&self) -> Option<&str> {
        self.key.as_deref()
    }

    /// 1-based line and column of the start of the span, if there is one.
    pub fn line_col(&self) -> Option<(usize, usize)> {
        let span = self.span.as_ref()?;
        let start = span.start.min(self.source.len());
        let before = &self.source[..start];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        Some((line, col))
    }
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some((l, c)) = self.line_col() {
            write!(f, ":{l}:{c}")?;
        }
        write!(f, ": ")?;
        if let Some(k) = &self.key {
            write!(f, "{k}: ")?;
        }
        write!(f, "{}", self.message)?;
        if let Some(h) = &self.help {
            write!(f, " (help: {h})")?;
        }
        Ok(())
    }
}

impl std::error::Error for ModelError {}

impl Diagnostic for ModelError {
    fn source_code(&self) -> Option<&dyn SourceCode> {
        // The file name and the help are part of the message itself (see Display).
        Some(&*self.source as &dyn SourceCode)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        let span = self.span.clone()?;
        let len = span.end.saturating_sub(span.start);
        let label = match &self.key {
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
