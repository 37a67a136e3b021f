//! The one line index: byte offsets to lines and columns and back, for diagnostics, the
//! formatter, the checker and the language server alike (gleam's `LineNumbers`).
//!
//! [`LineIndex::new`] finds the line starts of a text once; every question after that is a binary
//! search plus, for a column that is not in bytes, a walk over one line. Lines end at `\n`; a
//! `\r` before it is the line's ending too (a column past a line's end is its end, before any
//! `\r\n`). Columns are counted three ways ([`Encoding`]): UTF-8 bytes, UTF-16 code units (the
//! language server protocol's default) and characters (its UTF-32). Every function is total: an
//! offset past the text or inside a character is clamped back to a character boundary, a line
//! past the last one is the text's end, so a client's bad position never panics. The index keeps
//! no copy of the text; its methods that need the text take it and must be given the one it was
//! built from.

use std::ops::Range;

/// How columns are counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Encoding {
    /// Bytes of UTF-8.
    Utf8,
    /// UTF-16 code units: an astral character (`😀`) counts two.
    #[default]
    Utf16,
    /// Characters (Unicode scalar values).
    Utf32,
}

impl Encoding {
    /// The width of `c` in this encoding's units.
    pub fn width(self, c: char) -> usize {
        match self {
            Encoding::Utf8 => c.len_utf8(),
            Encoding::Utf16 => c.len_utf16(),
            Encoding::Utf32 => 1,
        }
    }
}

/// A position: a 0-based line and a 0-based column in some [`Encoding`]'s units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct LineCol {
    pub line: usize,
    pub col: usize,
}

/// The line starts of one text (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LineIndex {
    /// Byte offset of each line's first byte: `0`, and one past each `\n`.
    starts: Vec<usize>,
    /// The text's length in bytes.
    len: usize,
}

impl LineIndex {
    pub fn new(text: &str) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(newline_ends(text));
        LineIndex {
            starts,
            len: text.len(),
        }
    }

    /// The number of lines (a text ending in `\n` has an empty last line after it).
    pub fn lines(&self) -> usize {
        self.starts.len()
    }

    /// The length in bytes of the text the index was built from.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The 0-based line of byte `offset` (a `\n` belongs to the line it ends; past the text, the
    /// last line).
    pub fn line(&self, offset: usize) -> usize {
        self.starts.partition_point(|&s| s <= offset.min(self.len)) - 1
    }

    /// The bytes of 0-based line `line` with its `\n` (`None` past the last line).
    pub fn line_span(&self, line: usize) -> Option<Range<usize>> {
        let start = *self.starts.get(line)?;
        let end = self.starts.get(line + 1).map_or(self.len, |&e| e);
        Some(start..end)
    }

    /// The bytes of line `line` without its ending (`\n` or `\r\n`).
    pub fn line_content(&self, text: &str, line: usize) -> Option<Range<usize>> {
        let span = self.line_span(line)?;
        let body = &text.as_bytes()[span.clone()];
        let body = match body.strip_suffix(b"\n") {
            Some(b) => b.strip_suffix(b"\r").unwrap_or(b),
            None => body,
        };
        Some(span.start..span.start + body.len())
    }

    /// Where byte `offset` is, its column counted in `enc` (the offset clamped to the text and
    /// moved back to a character boundary first).
    pub fn line_col(&self, text: &str, offset: usize, enc: Encoding) -> LineCol {
        let offset = floor(text, offset);
        let line = self.line(offset);
        let start = self.starts[line];
        let col = match enc {
            Encoding::Utf8 => offset - start,
            _ => text[start..offset].chars().map(|c| enc.width(c)).sum(),
        };
        LineCol { line, col }
    }

    /// The byte offset of `pos` (column in `enc`): a column past the line's end (or inside a
    /// character) is the end (or that character's start); a line past the last is the text's end.
    /// Always a character boundary of `text`.
    pub fn offset(&self, text: &str, pos: LineCol, enc: Encoding) -> usize {
        let Some(content) = self.line_content(text, pos.line) else {
            return self.len;
        };
        if enc == Encoding::Utf8 {
            return floor(text, (content.start + pos.col).min(content.end));
        }
        let mut units = 0;
        for (i, c) in text[content.clone()].char_indices() {
            units += enc.width(c);
            if units > pos.col {
                return content.start + i;
            }
        }
        content.end
    }

    /// [`LineIndex::line_col`] of both ends of a range.
    pub fn range(&self, text: &str, r: Range<usize>, enc: Encoding) -> Range<LineCol> {
        self.line_col(text, r.start, enc)..self.line_col(text, r.end, enc)
    }
}

/// `offset` clamped to `text` and moved back to a character boundary.
pub fn floor(text: &str, offset: usize) -> usize {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

/// One past each `\n` of `text`.
fn newline_ends(text: &str) -> impl Iterator<Item = usize> + '_ {
    text.bytes()
        .enumerate()
        .filter(|&(_, b)| b == b'\n')
        .map(|(i, _)| i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use Encoding::*;

    fn lc(line: usize, col: usize) -> LineCol {
        LineCol { line, col }
    }

    #[test]
    fn columns_in_bytes_utf16_units_and_characters() {
        let text = "é😀x\nab\n";
        let ix = LineIndex::new(text);
        assert_eq!(ix.lines(), 3);
        // é: 2 bytes, 1 unit, 1 char; 😀: 4 bytes, 2 units, 1 char.
        assert_eq!(ix.line_col(text, 6, Utf8), lc(0, 6));
        assert_eq!(ix.line_col(text, 6, Utf16), lc(0, 3));
        assert_eq!(ix.line_col(text, 6, Utf32), lc(0, 2));
        assert_eq!(ix.line_col(text, 8, Utf16), lc(1, 0));
        assert_eq!(
            ix.line_col(text, 3, Utf16),
            lc(0, 1),
            "inside é's neighbour"
        );
        assert_eq!(ix.line_col(text, 4, Utf8), lc(0, 2), "inside 😀: its start");
        assert_eq!(ix.line_col(text, 999, Utf16), lc(2, 0), "past the end");
        assert_eq!(ix.offset(text, lc(0, 3), Utf16), 6);
        assert_eq!(ix.offset(text, lc(0, 2), Utf32), 6);
        assert_eq!(ix.offset(text, lc(0, 2), Utf16), 2, "inside 😀: its start");
        assert_eq!(ix.offset(text, lc(0, 4), Utf8), 2, "inside 😀: its start");
        assert_eq!(
            ix.offset(text, lc(0, 99), Utf16),
            7,
            "past the line: its end"
        );
        assert_eq!(ix.offset(text, lc(9, 0), Utf16), text.len());
        assert_eq!(
            ix.offset(text, lc(usize::MAX, usize::MAX), Utf8),
            text.len()
        );
    }

    #[test]
    fn a_crlf_ends_its_line_and_a_newline_belongs_to_the_line_it_ends() {
        let text = "ab\r\ncd";
        let ix = LineIndex::new(text);
        assert_eq!(ix.line(3), 0);
        assert_eq!(ix.line(4), 1);
        assert_eq!(ix.line_content(text, 0), Some(0..2));
        assert_eq!(ix.line_span(0), Some(0..4));
        assert_eq!(ix.offset(text, lc(0, 50), Utf16), 2);
        assert_eq!(ix.offset(text, lc(1, 50), Utf16), 6);
        assert_eq!(ix.line_span(2), None);
    }

    #[test]
    fn an_empty_text_has_one_empty_line() {
        let ix = LineIndex::new("");
        assert_eq!(ix.lines(), 1);
        assert_eq!(ix.line_col("", 5, Utf16), lc(0, 0));
        assert_eq!(ix.offset("", lc(0, 5), Utf16), 0);
        assert_eq!(ix.offset("", lc(3, 0), Utf8), 0);
    }

    proptest::proptest! {
        /// Every character boundary goes to a position and back to itself in every encoding, and
        /// any offset or position lands on a boundary without panicking.
        #[test]
        fn offsets_and_positions_round_trip(
            text in "(a|é|\u{1F600}|\u{10FFFF}|\n|\r\n|\r| |\u{FEFF}){0,40}",
            at in 0usize..200,
            line in 0usize..50,
            col in 0usize..50,
        ) {
            let ix = LineIndex::new(&text);
            for enc in [Utf8, Utf16, Utf32] {
                for (b, _) in text.char_indices().chain(std::iter::once((text.len(), ' '))) {
                    let p = ix.line_col(&text, b, enc);
                    // A `\n` or the `\r` of a `\r\n` is its line's end, where positions stop.
                    let ending = text[b..].starts_with('\n') || text[b..].starts_with("\r\n");
                    let back = ix.offset(&text, p, enc);
                    if ending {
                        proptest::prop_assert_eq!(back, ix.line_content(&text, p.line).unwrap().end);
                    } else {
                        proptest::prop_assert_eq!(back, b, "{:?} at {}", enc, b);
                    }
                }
                let p = ix.line_col(&text, at, enc);
                let back = ix.offset(&text, p, enc);
                proptest::prop_assert!(text.is_char_boundary(back));
                proptest::prop_assert!(back <= floor(&text, at));
                let off = ix.offset(&text, LineCol { line, col }, enc);
                proptest::prop_assert!(text.is_char_boundary(off));
                proptest::prop_assert!(ix.line_col(&text, off, enc).line <= line);
            }
        }
    }
}
