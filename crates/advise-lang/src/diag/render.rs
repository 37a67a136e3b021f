//! Drawing diagnostics, the only place that does: [`render`] draws any diagnostic against a
//! [`SourceMap`], and [`Bounded`] makes each source show only a window around each label.
//!
//! A source may be huge (a saved dataset is one JSON line that may be megabytes long), and miette
//! would print all of it, and panics on a label past column 65,535. The window is a few lines of
//! context, and on a long line at most [`SIDE_BYTES`] either side of the label, cut on character
//! boundaries; labels longer than that are shortened. A diagnostic that brings its own source code
//! (an error not yet converted to [`crate::diag::Loc`]s, or a [`crate::diag::Sourced`]) is drawn
//! from it, bounded the same way.

use std::fmt;

use miette::{
    Diagnostic, LabeledSpan, MietteError, MietteSpanContents, SourceCode, SourceSpan, SpanContents,
};

use super::SourceMap;

/// Bytes of a long line shown on each side of a label.
pub const SIDE_BYTES: usize = 160;

/// Render a diagnostic whose places are in `sources` as the terminal shows it, 100 columns wide;
/// colour only if asked.
pub fn render(sources: &SourceMap, diag: &dyn Diagnostic, colour: bool) -> String {
    render_with_width(sources, diag, colour, 100)
}

/// [`render`] at another width (the command line keeps miette's 80 columns).
pub fn render_with_width(
    sources: &SourceMap,
    diag: &dyn Diagnostic,
    colour: bool,
    width: usize,
) -> String {
    let theme = if colour {
        miette::GraphicalTheme::unicode()
    } else {
        miette::GraphicalTheme::unicode_nocolor()
    };
    let handler = miette::GraphicalReportHandler::new_themed(theme)
        .with_width(width)
        .with_links(false);
    let bounded = Bounded::new(diag, sources);
    let mut out = String::new();
    if handler.render_report(&mut out, &bounded).is_err() {
        out = format!("{diag}\n");
    }
    out
}

/// A diagnostic whose source code (its own, or else the map's; and that of its related and
/// source diagnostics) reads only a bounded window around each span.
pub struct Bounded<'a> {
    inner: &'a dyn Diagnostic,
    source: Option<BoundedSource<'a>>,
    related: Vec<Bounded<'a>>,
    cause: Option<Box<Bounded<'a>>>,
}

impl<'a> Bounded<'a> {
    /// `inner` drawn from its own source code, or else from `sources` (when it has any).
    pub fn new(inner: &'a dyn Diagnostic, sources: &'a SourceMap) -> Bounded<'a> {
        let fallback = (!sources.is_empty()).then_some(sources as &dyn SourceCode);
        Bounded::with_fallback(inner, fallback)
    }

    /// As miette does, a related or source diagnostic without source code of its own is drawn
    /// from its parent's.
    fn with_fallback(inner: &'a dyn Diagnostic, fallback: Option<&'a dyn SourceCode>) -> Self {
        let source = inner.source_code().or(fallback);
        Bounded {
            inner,
            source: source.map(BoundedSource),
            related: inner
                .related()
                .map(|r| r.map(|d| Bounded::with_fallback(d, source)).collect())
                .unwrap_or_default(),
            cause: inner
                .diagnostic_source()
                .map(|d| Box::new(Bounded::with_fallback(d, source))),
        }
    }
}

impl fmt::Debug for Bounded<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.inner, f)
    }
}

impl fmt::Display for Bounded<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self.inner, f)
    }
}

impl std::error::Error for Bounded<'_> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.inner.source()
    }
}

impl Diagnostic for Bounded<'_> {
    fn code<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        self.inner.code()
    }

    fn severity(&self) -> Option<miette::Severity> {
        self.inner.severity()
    }

    fn help<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        self.inner.help()
    }

    fn url<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        self.inner.url()
    }

    fn source_code(&self) -> Option<&dyn SourceCode> {
        self.source.as_ref().map(|s| s as &dyn SourceCode)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        // A label longer than the window would end outside what is shown.
        let labels = self.inner.labels()?.map(|l| {
            let len = l.len().min(SIDE_BYTES);
            let span = SourceSpan::new(l.offset().into(), len);
            if l.primary() {
                LabeledSpan::new_primary_with_span(l.label().map(String::from), span)
            } else {
                LabeledSpan::new_with_span(l.label().map(String::from), span)
            }
        });
        Some(Box::new(labels))
    }

    fn related<'b>(&'b self) -> Option<Box<dyn Iterator<Item = &'b dyn Diagnostic> + 'b>> {
        if self.related.is_empty() {
            return None;
        }
        Some(Box::new(self.related.iter().map(|d| d as &dyn Diagnostic)))
    }

    fn diagnostic_source(&self) -> Option<&dyn Diagnostic> {
        self.cause.as_deref().map(|d| d as &dyn Diagnostic)
    }
}

/// Source code that answers each span with a bounded window of what the inner source gives.
pub struct BoundedSource<'a>(pub &'a dyn SourceCode);

impl SourceCode for BoundedSource<'_> {
    fn read_span<'b>(
        &'b self,
        span: &SourceSpan,
        context_lines_before: usize,
        context_lines_after: usize,
    ) -> Result<Box<dyn SpanContents<'b> + 'b>, MietteError> {
        let full = self
            .0
            .read_span(span, context_lines_before, context_lines_after)?;
        let data: &'b [u8] = full.data();
        let base = full.span().offset();
        let rel_start = span.offset().saturating_sub(base).min(data.len());
        let rel_end = (rel_start + span.len().min(SIDE_BYTES)).min(data.len());
        let mut start = rel_start.saturating_sub(SIDE_BYTES);
        let mut end = (rel_end + SIDE_BYTES).min(data.len());
        if start == 0 && end == data.len() {
            return Ok(full);
        }
        // Cut on character boundaries, inside the window.
        while start < rel_start && is_continuation(data, start) {
            start += 1;
        }
        while end > rel_end && is_continuation(data, end) {
            end -= 1;
        }
        let skipped = &data[..start];
        let newlines = skipped.iter().filter(|b| **b == b'\n').count();
        // Columns in bytes, as miette counts them.
        let column = match skipped.iter().rposition(|b| *b == b'\n') {
            Some(nl) => skipped.len() - nl - 1,
            None => full.column() + skipped.len(),
        };
        let window = &data[start..end];
        let window_span = SourceSpan::new((base + start).into(), end - start);
        let line = full.line() + newlines;
        Ok(Box::new(match full.name() {
            Some(name) => MietteSpanContents::new_named(
                name.to_string(),
                window,
                window_span,
                line,
                column,
                full.line_count(),
            ),
            None => MietteSpanContents::new(window, window_span, line, column, full.line_count()),
        }))
    }
}

fn is_continuation(data: &[u8], i: usize) -> bool {
    data.get(i).is_some_and(|b| b & 0xC0 == 0x80)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::Loc;
    use miette::NamedSource;
    use thiserror::Error;

    #[derive(Debug, Error, Diagnostic)]
    #[error("bad value")]
    #[diagnostic(code(advise::test::bad))]
    struct Bad {
        #[source_code]
        src: NamedSource<String>,
        #[label("here")]
        span: SourceSpan,
    }

    #[test]
    fn a_label_far_along_a_long_line_renders_a_window() {
        // Past column 65,535 miette alone panics ("Formatting argument out of range").
        let mut text = "é".repeat(40_000);
        let at = text.len();
        text.push_str("BAD");
        text.push_str(&"x".repeat(100_000));
        // In a source map, after another source (as every loader now reports it), and with
        // its own source (an error that brings it).
        let mut map = SourceMap::new();
        map.add("first.json", "{}\n");
        let id = map.add("long.json", text.as_str());
        let in_map = InMap { at: id.span(at, 3) };
        let own = Bad {
            src: NamedSource::new("long.json", text),
            span: SourceSpan::new(at.into(), 3),
        };
        for out in [
            render(&map, &in_map, false),
            render(&SourceMap::new(), &own, false),
        ] {
            assert!(out.contains("BAD"), "{out}");
            assert!(out.len() < 4 * SIDE_BYTES + 1_000, "{} bytes", out.len());
            // miette counts columns in bytes.
            assert!(out.contains("[long.json:1:80001]"), "{out}");
        }
    }

    #[test]
    fn short_sources_render_as_before() {
        let text = "line one\nline two has BAD in it\nline three\n".to_string();
        let at = text.find("BAD").unwrap();
        let err = Bad {
            src: NamedSource::new("short.txt", text),
            span: SourceSpan::new(at.into(), 3),
        };
        let plain = {
            let handler = miette::GraphicalReportHandler::new_themed(
                miette::GraphicalTheme::unicode_nocolor(),
            )
            .with_width(100)
            .with_links(false);
            let mut out = String::new();
            handler.render_report(&mut out, &err).unwrap();
            out
        };
        assert_eq!(render(&SourceMap::new(), &err, false), plain);
        // The same error pointing into a map renders the same.
        let mut map = SourceMap::new();
        map.add("other.txt", "unrelated\n");
        let id = map.add("short.txt", err.src.inner().clone());
        let mapped = InMap { at: id.span(at, 3) };
        assert_eq!(
            render(&map, &mapped, false),
            plain.replace("test::bad", "test::in_map")
        );
    }

    #[derive(Debug, Error, Diagnostic)]
    #[error("bad value")]
    #[diagnostic(code(advise::test::in_map))]
    struct InMap {
        #[label("here")]
        at: Loc,
    }

    #[derive(Debug, Error, Diagnostic)]
    #[error("`speed_up` is defined twice")]
    #[diagnostic(code(advise::test::twice))]
    struct Twice {
        #[label("redefined here")]
        again: Loc,
        #[label("first defined here")]
        first: Loc,
    }

    #[test]
    fn one_diagnostic_labels_two_sources() {
        let mut map = SourceMap::new();
        let file = map.add(
            "operators/speed.adv",
            "// speeds\noperator speed_up = scale trans by 1.2\n",
        );
        let line = map.add("<repl>", "operator speed_up = scale trans by 2");
        let err = Twice {
            again: line.span(9, 8),
            first: file.span(19, 8),
        };
        let out = render(&map, &err, false);
        assert!(out.contains("[<repl>:1:10]"), "{out}");
        assert!(out.contains("[operators/speed.adv:2:10]"), "{out}");
        assert!(
            out.contains("redefined here") && out.contains("first defined here"),
            "{out}"
        );
    }
}
