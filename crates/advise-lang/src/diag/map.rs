//! The source map: every text a diagnostic may show, kept once and named by a [`SourceId`].
//!
//! A source's id is its first byte's offset in one global space; sources follow each other with
//! a one-byte gap, so an empty span at a source's end still belongs to it. A [`Loc`] (id and
//! local byte range) is therefore a global [`SourceSpan`] without the map, and the map finds the
//! source of any global span by a binary search. Adding the same text under the same name again
//! returns the first id, so loading one file repeatedly does not grow the map.

use std::collections::HashMap;
use std::fmt;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::ops::Range;
use std::sync::Arc;

use miette::{Diagnostic, MietteError, MietteSpanContents, SourceCode, SourceSpan, SpanContents};

/// One text of a [`SourceMap`]: its global offset, doubling as its id.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SourceId(usize);

impl SourceId {
    /// An id no map gives: for a text parsed only to inspect the result (is a line complete?),
    /// whose errors are never drawn.
    pub const UNMAPPED: SourceId = SourceId(usize::MAX / 2);

    /// The place of `range` (byte offsets into this source's text).
    pub fn at(self, range: Range<usize>) -> Loc {
        Loc {
            src: self,
            start: range.start,
            end: range.end.max(range.start),
        }
    }

    /// The place `len` bytes long starting at byte `start` of this source.
    pub fn span(self, start: usize, len: usize) -> Loc {
        self.at(start..start + len)
    }
}

/// A place in a source: what an error stores for a label.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Loc {
    pub src: SourceId,
    /// Byte offsets into the source's text.
    pub start: usize,
    pub end: usize,
}

impl Loc {
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    pub fn is_empty(&self) -> bool {
        self.start == self.end
    }

    pub fn range(&self) -> Range<usize> {
        self.start..self.end
    }
}

impl From<Loc> for SourceSpan {
    fn from(l: Loc) -> SourceSpan {
        SourceSpan::new((l.src.0 + l.start).into(), l.len())
    }
}

#[derive(Clone)]
struct Entry {
    name: String,
    text: Arc<str>,
    base: usize,
}

/// One source as a parser reads it: its id (for the [`Loc`]s of its errors), name and text.
#[derive(Clone, Copy, Debug)]
pub struct Src<'a> {
    pub id: SourceId,
    pub name: &'a str,
    pub text: &'a str,
}

impl<'a> Src<'a> {
    /// The place of `range` in this source.
    pub fn at(&self, range: Range<usize>) -> Loc {
        self.id.at(range)
    }

    /// The bytes `range` of this source as a source of their own whose errors point into this
    /// one (a statement of a script, parsed alone, reported at its line of the file).
    pub fn slice(&self, range: Range<usize>) -> Src<'a> {
        Src {
            id: SourceId(self.id.0 + range.start),
            name: self.name,
            text: &self.text[range],
        }
    }
}

/// Every source text a session (or one command-line call) has seen, each under its id.
#[derive(Clone, Default)]
pub struct SourceMap {
    sources: Vec<Entry>,
    /// Hash of (name, text) to the indices of the sources with that hash.
    seen: HashMap<u64, Vec<usize>>,
}

impl fmt::Debug for SourceMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SourceMap")
            .field("sources", &self.sources.len())
            .field(
                "bytes",
                &self.sources.iter().map(|s| s.text.len()).sum::<usize>(),
            )
            .finish()
    }
}

impl SourceMap {
    pub fn new() -> SourceMap {
        SourceMap::default()
    }

    /// Keep `text` under `name` (a path, `<repl>`, a script's `path:line`) and return its id; the
    /// same name and text added again give the same id.
    pub fn add(&mut self, name: impl Into<String>, text: impl Into<Arc<str>>) -> SourceId {
        let (name, text) = (name.into(), text.into());
        let key = key(&name, &text);
        if let Some(same) = self.seen.get(&key) {
            for &i in same {
                let s = &self.sources[i];
                if s.name == name && s.text == text {
                    return SourceId(s.base);
                }
            }
        }
        let base = self.sources.last().map_or(0, |s| s.base + s.text.len() + 1);
        self.seen.entry(key).or_default().push(self.sources.len());
        self.sources.push(Entry { name, text, base });
        SourceId(base)
    }

    /// The text of a source of this map.
    pub fn text(&self, id: SourceId) -> &str {
        self.get(id).map_or("", |s| &s.text)
    }

    /// The name of a source of this map.
    pub fn name(&self, id: SourceId) -> &str {
        self.get(id).map_or("", |s| &s.name)
    }

    /// Parse `text` as a source of this map, keeping it only if `parse` fails: data files (traces,
    /// datasets, parameters) are needed for their diagnostics alone, and a long session that
    /// loads many must not hold them all. What `parse` returns on success must hold no [`Loc`]
    /// into the text.
    pub fn scratch<T, E>(
        &mut self,
        name: impl Into<String>,
        text: impl Into<Arc<str>>,
        parse: impl FnOnce(Src<'_>) -> Result<T, E>,
    ) -> Result<T, E> {
        let before = self.sources.len();
        let id = self.add(name, text);
        let result = parse(self.src(id));
        if result.is_ok() && self.sources.len() > before {
            self.pop();
        }
        result
    }

    /// Drop the source added last.
    fn pop(&mut self) {
        self.truncate(self.sources.len().saturating_sub(1));
    }

    /// Drop every source added after the first `len`: a session keeps a statement's texts only
    /// while an error may point into them, so a statement that succeeded gives back what it added
    /// ([`SourceMap::len`] before it, passed here after).
    pub fn truncate(&mut self, len: usize) {
        while self.sources.len() > len {
            let Some(last) = self.sources.pop() else {
                return;
            };
            let key = key(&last.name, &last.text);
            if let Some(same) = self.seen.get_mut(&key) {
                same.retain(|i| *i != self.sources.len());
                if same.is_empty() {
                    self.seen.remove(&key);
                }
            }
        }
    }

    /// A map holding `text` alone, under `name`, and its id: for a call that parses one text
    /// with no session around it (a test, a command-line argument).
    pub fn single(name: impl Into<String>, text: impl Into<Arc<str>>) -> (SourceMap, SourceId) {
        let mut map = SourceMap::new();
        let id = map.add(name, text);
        (map, id)
    }

    /// A source of this map, to parse.
    pub fn src(&self, id: SourceId) -> Src<'_> {
        Src {
            id,
            name: self.name(id),
            text: self.text(id),
        }
    }

    /// How many sources the map holds.
    pub fn len(&self) -> usize {
        self.sources.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sources.is_empty()
    }

    /// Bind `error` to this map's sources, for an edge that returns it as a `miette::Report` (a
    /// command-line call's map ends its life in its error); the map is left empty.
    pub fn attach<E: Diagnostic>(&mut self, error: E) -> Sourced<E> {
        Sourced {
            sources: std::mem::take(self),
            error,
        }
    }

    /// The name and text of the source holding the global offset `at`, and `at` within that
    /// text (for bindings that show a place as file, line and column).
    pub fn local(&self, at: usize) -> Option<(&str, &str, usize)> {
        self.find(at)
            .map(|s| (s.name.as_str(), &*s.text, at - s.base))
    }

    fn get(&self, id: SourceId) -> Option<&Entry> {
        let i = self.sources.binary_search_by_key(&id.0, |s| s.base).ok()?;
        Some(&self.sources[i])
    }

    /// The source holding the global offset `at` (its end included).
    fn find(&self, at: usize) -> Option<&Entry> {
        let i = self
            .sources
            .partition_point(|s| s.base <= at)
            .checked_sub(1)?;
        let s = &self.sources[i];
        (at <= s.base + s.text.len()).then_some(s)
    }
}

/// The dedup key of a source.
fn key(name: &str, text: &str) -> u64 {
    let mut h = DefaultHasher::new();
    (name, text).hash(&mut h);
    h.finish()
}

impl SourceCode for SourceMap {
    fn read_span<'a>(
        &'a self,
        span: &SourceSpan,
        context_lines_before: usize,
        context_lines_after: usize,
    ) -> Result<Box<dyn SpanContents<'a> + 'a>, MietteError> {
        let src = self.find(span.offset()).ok_or(MietteError::OutOfBounds)?;
        let local = SourceSpan::new((span.offset() - src.base).into(), span.len());
        let text: &'a str = &src.text;
        let c = text.read_span(&local, context_lines_before, context_lines_after)?;
        let global = SourceSpan::new((c.span().offset() + src.base).into(), c.span().len());
        Ok(Box::new(MietteSpanContents::new_named(
            src.name.clone(),
            c.data(),
            global,
            c.line(),
            c.column(),
            c.line_count(),
        )))
    }
}

/// An error with the map its places point into ([`SourceMap::attach`]).
pub struct Sourced<E> {
    pub sources: SourceMap,
    pub error: E,
}

impl<E: fmt::Debug> fmt::Debug for Sourced<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&self.error, f)
    }
}

impl<E: fmt::Display> fmt::Display for Sourced<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.error, f)
    }
}

impl<E: std::error::Error> std::error::Error for Sourced<E> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.error.source()
    }
}

impl<E: Diagnostic> Diagnostic for Sourced<E> {
    fn code<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        self.error.code()
    }

    fn severity(&self) -> Option<miette::Severity> {
        self.error.severity()
    }

    fn help<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        self.error.help()
    }

    fn url<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        self.error.url()
    }

    fn source_code(&self) -> Option<&dyn SourceCode> {
        Some(self.error.source_code().unwrap_or(&self.sources))
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = miette::LabeledSpan> + '_>> {
        self.error.labels()
    }

    fn related<'b>(&'b self) -> Option<Box<dyn Iterator<Item = &'b dyn Diagnostic> + 'b>> {
        self.error.related()
    }

    fn diagnostic_source(&self) -> Option<&dyn Diagnostic> {
        self.error.diagnostic_source()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_disjoint_offsets_and_find_their_source() {
        let mut map = SourceMap::new();
        let a = map.add("a.adv", "abc");
        let b = map.add("<repl>", "xy");
        assert_eq!(map.text(a), "abc");
        assert_eq!(map.name(b), "<repl>");
        // The end of `a` is still `a`; the next byte after the gap is `b`.
        assert_eq!(
            map.find(SourceSpan::from(a.at(3..3)).offset())
                .unwrap()
                .name,
            "a.adv"
        );
        assert_eq!(
            map.find(SourceSpan::from(b.at(0..1)).offset())
                .unwrap()
                .name,
            "<repl>"
        );
        assert_eq!(map.add("a.adv", "abc"), a);
        assert_ne!(map.add("b.adv", "abc"), a);
        assert_eq!(map.len(), 3);
    }

    #[test]
    fn scratch_sources_are_kept_only_for_their_errors() {
        let mut map = SourceMap::new();
        let ok: Result<usize, Loc> = map.scratch("ok.csv", "fine", |s| Ok(s.text.len()));
        assert_eq!(ok, Ok(4));
        assert!(map.is_empty());
        let bad: Result<(), Loc> = map.scratch("bad.csv", "oops", |s| Err(s.at(0..4)));
        let at = bad.unwrap_err();
        assert_eq!(map.text(at.src), "oops");
        // Again, the same text: the same id, still kept.
        let again: Result<(), Loc> = map.scratch("bad.csv", "oops", |_| Ok(()));
        assert_eq!(again, Ok(()));
        assert_eq!(map.len(), 1);
        let next = map.add("next", "x");
        assert_eq!(map.src(next).text, "x");
    }

    #[test]
    fn a_span_reads_back_in_its_own_source_with_its_own_lines() {
        let mut map = SourceMap::new();
        map.add("one", "first\nsecond\n");
        let id = map.add("two", "alpha\nbeta gamma\n");
        let at = id.span(11, 5);
        let c = map.read_span(&at.into(), 0, 0).unwrap();
        assert_eq!(c.name(), Some("two"));
        assert_eq!(std::str::from_utf8(c.data()).unwrap(), "gamma");
        assert_eq!((c.line(), c.column()), (1, 5));
        assert_eq!(c.span(), &SourceSpan::from(at));
        // With context, the window stays inside the source: not a byte of `one`.
        let c = map.read_span(&at.into(), 5, 5).unwrap();
        assert_eq!(
            std::str::from_utf8(c.data()).unwrap(),
            "alpha\nbeta gamma\n"
        );
        assert_eq!(c.span().offset(), SourceSpan::from(id.at(0..0)).offset());
    }
}
