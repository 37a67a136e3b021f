//! The source text a diagnostic shows: shared, never copied per diagnostic. A 40,000-operator
//! file with an error in each used to copy the file into each error. How much of a long line is
//! drawn is decided once, where diagnostics are rendered ([`crate::diag::render::Bounded`]), so a
//! diagnostic costs the same on any input.

use std::fmt;
use std::sync::Arc;

use miette::{MietteError, SourceCode, SourceSpan, SpanContents};

/// A source text for diagnostics (cheap to clone).
#[derive(Clone)]
pub struct SourceText(Arc<str>);

impl From<&str> for SourceText {
    fn from(s: &str) -> SourceText {
        SourceText(Arc::from(s))
    }
}

impl fmt::Debug for SourceText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "SourceText({} bytes)", self.0.len())
    }
}

impl SourceCode for SourceText {
    fn read_span<'a>(
        &'a self,
        span: &SourceSpan,
        context_lines_before: usize,
        context_lines_after: usize,
    ) -> Result<Box<dyn SpanContents<'a> + 'a>, MietteError> {
        // Long lines are clipped where every diagnostic is rendered (`crate::diag`).
        self.0
            .read_span(span, context_lines_before, context_lines_after)
    }
}
