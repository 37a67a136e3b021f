//! Byte ranges for positions other parsers report, so their errors can carry a
//! [`Loc`](crate::diag::Loc): serde's 1-based line and column, a CSV line and one of its fields,
//! the value of a JSON object's member. Each works on the text alone and never fails: a position
//! past the text gives an empty range at its end.

use std::ops::Range;

use super::lines::{self, LineIndex};

/// The character at a (1-based) line and column of `text`, as serde_json reports positions
/// (columns in bytes). The range covers one whole character; past the text, it is empty at the
/// end.
pub fn line_col(text: &str, line: usize, column: usize) -> Range<usize> {
    let lines = LineIndex::new(text);
    let Some(span) = line.checked_sub(1).and_then(|l| lines.line_span(l)) else {
        return text.len()..text.len();
    };
    // Back to a character boundary, and cover one whole character.
    let at = lines::floor(text, (span.start + column.saturating_sub(1)).min(span.end));
    let width = text[at..span.end].chars().next().map_or(0, char::len_utf8);
    at..at + width
}

/// The line of `text` that starts at byte `start`, without its line ending.
pub fn line_at(text: &str, start: usize) -> Range<usize> {
    let start = start.min(text.len());
    let end = text[start..]
        .find(['\n', '\r'])
        .map_or(text.len(), |e| start + e);
    start..end
}

/// Field `field` (0-based, split at commas) of the line starting at byte `start`; the whole line
/// when it has fewer fields.
pub fn csv_field(text: &str, start: usize, field: usize) -> Range<usize> {
    let line = line_at(text, start);
    let mut off = line.start;
    for (i, f) in text[line.clone()].split(',').enumerate() {
        if i == field {
            return off..off + f.len();
        }
        off += f.len() + 1;
    }
    line
}

/// The value of top-level member `field` of the JSON object `text`. Meant for text serde has
/// already accepted as a flat object of numbers (no duplicate keys); anything unexpected gives
/// `None` (no label).
pub fn json_member_value(text: &str, field: &str) -> Option<Range<usize>> {
    let b = text.as_bytes();
    let skip_ws = |mut i: usize| {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        i
    };
    let mut i = skip_ws(0);
    if b.get(i) != Some(&b'{') {
        return None;
    }
    i += 1;
    loop {
        i = skip_ws(i);
        if b.get(i) != Some(&b'"') {
            return None;
        }
        // The key, escapes and all: serde_json decodes it as it did when deserialising.
        let key_start = i;
        i += 1;
        while i < b.len() && b[i] != b'"' {
            i += if b[i] == b'\\' { 2 } else { 1 };
        }
        let key: String = serde_json::from_str(text.get(key_start..=i)?).ok()?;
        i = skip_ws(i + 1);
        if b.get(i) != Some(&b':') {
            return None;
        }
        let start = skip_ws(i + 1);
        let mut end = start;
        while end < b.len() && !matches!(b[end], b',' | b'}') && !b[end].is_ascii_whitespace() {
            end += 1;
        }
        if key == field {
            return Some(start..end);
        }
        i = skip_ws(end);
        match b.get(i) {
            Some(b',') => i += 1,
            _ => return None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_positions_cover_one_character() {
        let text = "{\n  \"a\": é,\n}";
        // serde's column of `é` is its first byte, 1-based.
        assert_eq!(line_col(text, 2, 8), 9..11);
        assert_eq!(line_col(text, 2, 9), 9..11);
        assert_eq!(line_col(text, 9, 1), text.len()..text.len());
    }

    #[test]
    fn csv_lines_and_fields() {
        let text = "t,x\r\n0.5,abc\n";
        assert_eq!(line_at(text, 0), 0..3);
        assert_eq!(csv_field(text, 5, 1), 9..12);
        assert_eq!(csv_field(text, 5, 7), 5..12);
    }

    #[test]
    fn json_member_values() {
        let text = r#"{"a": 1, "b" : -2e3 }"#;
        assert_eq!(json_member_value(text, "b"), Some(15..19));
        assert_eq!(json_member_value(text, "c"), None);
        assert_eq!(json_member_value("[1]", "a"), None);
    }
}
