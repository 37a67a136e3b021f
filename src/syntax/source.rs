//! The source text a diagnostic shows: shared, never copied per diagnostic, and clipped around the
//! label on very long lines.
//!
//! miette draws every line of a snippet whole, at a cost in proportion to its length; a 1 MB line
//! (a file written on one line) made each diagnostic take more than a second. [`SourceText`] hands
//! miette a window of such a line around the span instead, with the right line and column, so a
//! diagnostic costs the same on any input.

use std::fmt;
use std::sync::Arc;

use miette::{MietteError, MietteSpanContents, SourceCode, SourceSpan, SpanContents};

/// Snippets longer than this are clipped.
const CLIP_ABOVE: usize = 4096;
/// How much of a clipped line is kept on each side of the span.
const KEEP: usize = 1024;

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
        let whole = self
            .0
            .read_span(span, context_lines_before, context_lines_after)?;
        let data = whole.data();
        if data.len() <= CLIP_ABOVE {
            return Ok(whole);
        }
        let text: &'a str = &self.0;
        let start = whole.span().offset();
        let end = start + data.len();
        let mut lo = span.offset().saturating_sub(KEEP).max(start);
        let mut hi = (span.offset() + span.len() + KEEP).min(end);
        while !text.is_char_boundary(lo) {
            lo -= 1;
        }
        while !text.is_char_boundary(hi) {
            hi += 1;
        }
        let skipped = &text[start..lo];
        let line = whole.line() + skipped.matches('\n').count();
        let column = match skipped.rfind('\n') {
            Some(nl) => skipped[nl + 1..].chars().count(),
            None => whole.column() + skipped.chars().count(),
        };
        Ok(Box::new(MietteSpanContents::new(
            &text.as_bytes()[lo..hi],
            SourceSpan::new(lo.into(), hi - lo),
            line,
            column,
            whole.line_count(),
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_line_is_clipped_around_the_span_with_its_line_and_column() {
        let text = format!(
            "first\n{}X{}\nlast\n",
            "a".repeat(10_000),
            "b".repeat(10_000)
        );
        let src = SourceText::from(text.as_str());
        let at = text.find('X').unwrap();
        let c = src.read_span(&SourceSpan::new(at.into(), 1), 1, 1).unwrap();
        assert!(c.data().len() <= 2 * KEEP + 1, "{}", c.data().len());
        assert_eq!(c.line(), 1);
        assert_eq!(c.column(), 10_000 - KEEP);
        assert!(std::str::from_utf8(c.data()).unwrap().contains('X'));
        // Short snippets are untouched.
        let short = SourceText::from("a\nbc\nd\n");
        let c = short
            .read_span(&SourceSpan::new(2.into(), 1), 1, 1)
            .unwrap();
        assert_eq!(c.data(), b"a\nbc\nd\n");
    }
}
