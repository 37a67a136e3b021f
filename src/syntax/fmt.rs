//! `advise fmt`: a file in the canonical layout of [`super::print`], its comments kept.
//!
//! The grammar drops `//` comments, so they are found again in the text ([`comments`]) and put
//! back by position: a comment between items stays between them (with the blank lines around it,
//! at most one), a comment on its own line in an operator's block stays before the statement it
//! preceded, and a comment at the end of a statement's line stays at the end of that line. Blank
//! lines between statements are kept (at most one). An item with a comment anywhere else (in its
//! header, inside a statement that spans lines, in a domain's body) is kept as written, with only
//! trailing spaces removed: a formatter must never lose a comment, and never move one to where it
//! says something else.

use super::ast::{Body, File, Item, OperatorDecl, Span};
use super::{ParseError, parse};
use crate::diag::Src;

/// The canonical text of an operator file: parsed, printed, with every `//` comment where it was.
/// Formatting a formatted file changes nothing.
pub fn format(source: Src<'_>) -> Result<String, ParseError> {
    let file = parse(source)?;
    Ok(layout(source.text, &file))
}

/// Whether `text` is a session script (REPL commands, one per line, operators defined among them)
/// rather than an operator file: some line that is neither blank, a comment nor the start of an
/// item is a command. No line of an operator file is one (a body's lines are assignments).
pub fn is_script(text: &str) -> bool {
    text.lines().map(str::trim).any(|l| {
        !l.is_empty()
            && !l.starts_with("//")
            && !l.starts_with("operator")
            && !l.starts_with("domain")
            && super::command::is_statement(l)
    })
}

/// A session script's canonical text: its lines as written, without trailing blanks, at most one
/// blank line in a row, none at the start or end, and a final newline. (Commands have no printer
/// yet, so their spelling is kept.)
pub fn format_script(text: &str) -> String {
    let mut out = String::new();
    let mut blank = false;
    for line in text.trim_start_matches('\u{feff}').lines() {
        let line = line.trim_end();
        if line.is_empty() {
            blank = !out.is_empty();
            continue;
        }
        if blank {
            out.push('\n');
            blank = false;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// A `//` comment (not a `///` doc comment): its byte range, running to the end of its line.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Comment {
    span: Span,
}

/// Every `//` comment of `text` that is not a doc comment, outside units' quotes.
fn comments(text: &str) -> Vec<Comment> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    let mut in_quote = false;
    while i < bytes.len() {
        match bytes[i] {
            b'\n' => in_quote = false,
            b'"' => in_quote = !in_quote,
            b'/' if !in_quote && bytes.get(i + 1) == Some(&b'/') => {
                let end = text[i..].find('\n').map_or(text.len(), |n| i + n);
                if bytes.get(i + 2) != Some(&b'/') {
                    out.push(Comment {
                        span: Span::new(i, end),
                    });
                }
                i = end;
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// Line numbers of byte offsets.
struct Lines {
    starts: Vec<usize>,
}

impl Lines {
    fn new(text: &str) -> Lines {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Lines { starts }
    }

    fn of(&self, offset: usize) -> usize {
        self.starts.partition_point(|&s| s <= offset) - 1
    }

    /// Whether some line strictly between the lines of `a` and `b` is blank.
    fn blank_between(&self, text: &str, a: usize, b: usize) -> bool {
        let (la, lb) = (self.of(a), self.of(b));
        (la + 1..lb).any(|l| self.line(text, l).trim().is_empty())
    }

    fn line<'t>(&self, text: &'t str, l: usize) -> &'t str {
        let start = self.starts[l];
        let end = self.starts.get(l + 1).map_or(text.len(), |&e| e);
        &text[start..end]
    }
}

fn comment_text(text: &str, c: &Comment) -> String {
    text[c.span.start..c.span.end].trim_end().to_string()
}

fn layout(text: &str, file: &File) -> String {
    let all = comments(text);
    let lines = Lines::new(text);
    let mut out = String::new();
    // Where the text already written ends, and whether something was written.
    let mut cursor = 0;
    let mut wrote_any = false;
    let refs: Vec<&Comment> = all.iter().collect();
    for item in &file.items {
        // An item's span may run over the blanks and comments after it (a composition's does).
        let span = item.span();
        let span = Span::new(span.start, own_end(text, span, &refs));
        let before: Vec<&Comment> = all
            .iter()
            .filter(|c| c.span.start >= cursor && c.span.end <= span.start)
            .collect();
        gap(
            text, &lines, &before, cursor, span.start, wrote_any, &mut out,
        );
        let inside: Vec<&Comment> = all
            .iter()
            .filter(|c| c.span.start >= span.start && c.span.start < span.end)
            .collect();
        out.push_str(&item_text(text, &lines, item, span, &inside));
        out.push('\n');
        cursor = span.end;
        wrote_any = true;
    }
    let after: Vec<&Comment> = all.iter().filter(|c| c.span.start >= cursor).collect();
    if !after.is_empty() {
        gap(
            text,
            &lines,
            &after,
            cursor,
            text.len(),
            wrote_any,
            &mut out,
        );
    }
    let mut tidy: String = out
        .lines()
        .map(|l| l.trim_end())
        .collect::<Vec<_>>()
        .join("\n");
    let trimmed = tidy.trim_end_matches('\n').len();
    tidy.truncate(trimmed);
    if !tidy.is_empty() {
        tidy.push('\n');
    }
    tidy
}

/// The comments between what was written (ending at `from`) and the next item (at `to`, or the
/// end of the text): one blank line after an item, and blank lines between comments and before
/// the next item where the text had them.
fn gap(
    text: &str,
    lines: &Lines,
    comments: &[&Comment],
    from: usize,
    to: usize,
    wrote_any: bool,
    out: &mut String,
) {
    let mut prev: Option<usize> = None;
    for (i, c) in comments.iter().enumerate() {
        if i == 0 && wrote_any && lines.of(c.span.start) == lines.of(from) {
            // At the end of the previous item's last line: it stays there.
            if out.ends_with('\n') {
                out.pop();
            }
            out.push(' ');
            out.push_str(&comment_text(text, c));
            out.push('\n');
            continue;
        }
        let blank = match prev {
            None => wrote_any,
            Some(p) => lines.blank_between(text, p, c.span.start),
        };
        if blank {
            out.push('\n');
        }
        out.push_str(&comment_text(text, c));
        out.push('\n');
        prev = Some(c.span.end);
    }
    if to < text.len() {
        let blank = match prev {
            None => wrote_any,
            Some(p) => lines.blank_between(text, p, to),
        };
        if blank {
            out.push('\n');
        }
    }
}

/// An item's text: printed, with its comments put back, or as written when a comment is where
/// the printer has no place for it.
fn item_text(text: &str, lines: &Lines, item: &Item, span: Span, comments: &[&Comment]) -> String {
    let verbatim = || text[span.start..span.end].to_string();
    if comments.is_empty() {
        // Blank lines between statements are kept even without comments.
        if let Item::Operator(op) = item {
            return operator_text(text, lines, op, &[]).unwrap_or_else(|| item.to_string());
        }
        return item.to_string();
    }
    match item {
        Item::Operator(op) => operator_text(text, lines, op, comments).unwrap_or_else(verbatim),
        Item::Domain(_) => verbatim(),
    }
}

/// An operator with a block body, its comments and blank lines among its statements; `None`
/// when a comment is outside the block's statements' lines.
fn operator_text(
    text: &str,
    lines: &Lines,
    op: &OperatorDecl,
    comments: &[&Comment],
) -> Option<String> {
    let Body::Block { stmts, .. } = &op.body else {
        return comments.is_empty().then(|| op.to_string());
    };
    if stmts.is_empty() {
        return comments.is_empty().then(|| op.to_string());
    }
    let first = stmts[0].span.start;
    // The block's `{` is the last one before the first statement.
    let open = text[..first].rfind('{')?;
    if open < op.span.start || comments.iter().any(|c| c.span.start < open) {
        return None;
    }
    // Own-line comments and statements in the text's order, each statement with the comment at
    // the end of its line.
    enum Line<'a> {
        Comment(&'a Comment),
        Stmt(&'a super::ast::Stmt, Option<&'a Comment>),
    }
    let mut events: Vec<(usize, usize, Line<'_>)> = Vec::new();
    let mut trailing: Vec<Option<&Comment>> = vec![None; stmts.len()];
    // A statement's span runs over the blanks and comments after it: its own text ends earlier.
    let ends: Vec<usize> = stmts
        .iter()
        .map(|s| own_end(text, s.span, comments))
        .collect();
    for &c in comments {
        let at = c.span.start;
        if stmts
            .iter()
            .zip(&ends)
            .any(|(s, &end)| s.span.start <= at && at < end)
        {
            return None;
        }
        let next = stmts.partition_point(|s| s.span.start < at);
        if next > 0 && lines.of(ends[next - 1]) == lines.of(at) {
            if trailing[next - 1].replace(c).is_some() {
                return None;
            }
        } else {
            events.push((c.span.start, c.span.end, Line::Comment(c)));
        }
    }
    for ((s, t), end) in stmts.iter().zip(trailing).zip(ends) {
        events.push((s.span.start, end, Line::Stmt(s, t)));
    }
    events.sort_by_key(|e| e.0);
    // The header as the printer writes it: everything up to the block's opening line.
    let printed = op.to_string();
    // The last ` {` line end: doc lines before it may hold one too, statements never do.
    let header_end = printed.rfind(" {\n")?;
    let mut out = String::from(&printed[..header_end]);
    out.push_str(" {\n");
    let mut prev_end: Option<usize> = None;
    for (start, end, line) in &events {
        if prev_end.is_some_and(|p| lines.blank_between(text, p, *start)) {
            out.push('\n');
        }
        out.push_str("  ");
        match line {
            Line::Comment(c) => out.push_str(&comment_text(text, c)),
            Line::Stmt(s, t) => {
                out.push_str(&s.to_string());
                if let Some(c) = t {
                    out.push(' ');
                    out.push_str(&comment_text(text, c));
                }
            }
        }
        out.push('\n');
        prev_end = Some(*end);
    }
    out.push('}');
    Some(out)
}

/// Where the text of `span` ends, without the blanks and comments at its end.
fn own_end(text: &str, span: Span, comments: &[&Comment]) -> usize {
    let mut end = span.end;
    loop {
        end = span.start + text[span.start..end].trim_end().len();
        match comments
            .iter()
            .find(|c| c.span.start >= span.start && c.span.start < end && end <= c.span.end)
        {
            Some(c) => end = c.span.start,
            None => return end,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::SourceMap;

    fn fmt(text: &str) -> String {
        let (map, id) = SourceMap::single("t.adv", text);
        format(map.src(id)).unwrap()
    }

    #[test]
    fn comments_stay_where_they_were() {
        let text = "// header\n// two\n\n/// Doc.\noperator a  for positioning on action {\n  // before\n  trans = 1   // trailing\n\n\n  rot=2\n  // at the end\n}\n// between\noperator b for positioning on action { trans = 0 }\n// tail\n";
        let got = fmt(text);
        assert_eq!(
            got,
            "// header\n// two\n\n/// Doc.\noperator a for positioning on action {\n  // before\n  trans = 1 // trailing\n\n  rot = 2\n  // at the end\n}\n\n// between\noperator b for positioning on action {\n  trans = 0\n}\n\n// tail\n"
        );
        assert_eq!(fmt(&got), got, "idempotent");
    }

    #[test]
    fn a_comment_the_printer_has_no_place_for_keeps_the_item_as_written() {
        let text = "operator a(x = 1, // the gain\n  y = 2) for positioning on action { trans = x + y }   \n";
        let got = fmt(text);
        assert_eq!(
            got,
            "operator a(x = 1, // the gain\n  y = 2) for positioning on action { trans = x + y }\n"
        );
        assert_eq!(fmt(&got), got);
    }

    #[test]
    fn scripts_are_told_from_operator_files_whatever_their_first_line() {
        assert!(is_script("task positioning\nrun goal 1 2 3\n"));
        assert!(is_script(
            "/// Creep.\noperator creep for positioning on action {\n  trans = 0.1\n}\nrun goal 2 -1 0\n"
        ));
        for file in [
            include_str!("../../operators/positioning.adv"),
            include_str!("../../operators/interception.adv"),
        ] {
            assert!(!is_script(file));
        }
        assert!(!is_script(
            "operator a for positioning on action {\n  trans = 0\n  rot *= 1 - k / n\n}\n"
        ));
    }

    #[test]
    fn slashes_in_units_are_not_comments() {
        assert_eq!(comments("act v \"m//s\" // c\n").len(), 1);
        assert!(comments("/// doc\n").is_empty());
    }
}
