//! `advise fmt`: a file in the canonical layout of [`super::print`], its comments kept.
//!
//! The grammar drops `//` comments; the bracket scan that runs before the parser knows exactly
//! where they are ([`super::delims::comments`]: outside units' quotes, told from `///` doc
//! comments), and they are put back by position: a comment between items stays between them (with the blank lines around it,
//! at most one), a comment on its own line in an operator's block stays before the statement it
//! preceded, and a comment at the end of a statement's line stays at the end of that line. Blank
//! lines between statements are kept (at most one). An item with a comment anywhere else (in its
//! header, inside a statement that spans lines, in a domain's body) is kept as written, with only
//! trailing spaces removed: a formatter must never lose a comment, and never move one to where it
//! says something else.

use super::ast::{Body, File, Item, OperatorDecl, Span};
use super::{ParseError, parse_with_comments};
use crate::diag::{LineIndex, Src};

/// The canonical text of an operator file: parsed, printed, with every `//` comment where it was.
/// Formatting a formatted file changes nothing.
pub fn format(source: Src<'_>) -> Result<String, ParseError> {
    let (file, mut comments) = parse_with_comments(source)?;
    comments.retain(|c| !c.doc);
    Ok(layout(source.text, &file, &comments))
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
type Comment = super::delims::Comment;

/// Every `//` comment of `text` that is not a doc comment, as the bracket scan finds them.
#[cfg(test)]
fn comments(text: &str) -> Vec<Comment> {
    let mut all = super::delims::comments(text);
    all.retain(|c| !c.doc);
    all
}

/// Whether some line strictly between the lines of `a` and `b` is blank.
fn blank_between(text: &str, lines: &LineIndex, a: usize, b: usize) -> bool {
    (lines.line(a) + 1..lines.line(b)).any(|l| {
        lines
            .line_span(l)
            .is_some_and(|span| text[span].trim().is_empty())
    })
}

fn comment_text(text: &str, c: &Comment) -> String {
    text[c.span.start..c.span.end].trim_end().to_string()
}

/// The printed items of `file` with the `//` comments of `text` (`all`) put back.
fn layout(text: &str, file: &File, all: &[Comment]) -> String {
    let lines = LineIndex::new(text);
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
    lines: &LineIndex,
    comments: &[&Comment],
    from: usize,
    to: usize,
    wrote_any: bool,
    out: &mut String,
) {
    let mut prev: Option<usize> = None;
    for (i, c) in comments.iter().enumerate() {
        if i == 0 && wrote_any && lines.line(c.span.start) == lines.line(from) {
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
            Some(p) => blank_between(text, lines, p, c.span.start),
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
            Some(p) => blank_between(text, lines, p, to),
        };
        if blank {
            out.push('\n');
        }
    }
}

/// An item's text: printed, with its comments put back, or as written when a comment is where
/// the printer has no place for it.
fn item_text(
    text: &str,
    lines: &LineIndex,
    item: &Item,
    span: Span,
    comments: &[&Comment],
) -> String {
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
    lines: &LineIndex,
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
        if next > 0 && lines.line(ends[next - 1]) == lines.line(at) {
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
        if prev_end.is_some_and(|p| blank_between(text, lines, p, *start)) {
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
    use crate::syntax::parse;

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
            include_str!("../../../../operators/positioning.adv"),
            include_str!("../../../../operators/interception.adv"),
        ] {
            assert!(!is_script(file));
        }
        assert!(!is_script(
            "operator a for positioning on action {\n  trans = 0\n  rot *= 1 - k / n\n}\n"
        ));
    }

    #[test]
    fn no_comment_is_lost_wherever_it_is() {
        let cases = [
            "operator a for positioning on action { // after a brace\n  trans = 0\n}\n",
            "operator g for positioning on action = slow_down(// before an arg\n  rate = 0.5) then speed_up\n",
            "operator g for positioning on action = slow_down(rate = 0.5, // between args\n  steps = 2) then speed_up\n",
            "operator a for positioning on action {\n  trans = 0\n}\n// at the end, no newline",
            "domain d { act v \"m//s\" // a unit with slashes\n}\noperator a for d on action { v = 0 }",
            "operator a(x = 1 // in a header\n) for positioning on action { trans = x }\n",
            "operator a for positioning on action where trans != 0 // after the guard\n{\n  trans = 0\n}\n",
            "operator a for positioning on action {\n  trans = 1 +\n  // inside a statement\n  2\n}\n",
            "operator a for positioning on action {\n  trans = 0 // one\n  // two\n} // after the closing brace\n",
            "// only a comment",
            "/// Doc.\n// between doc and item\noperator a for positioning on action { trans = 0 }\n",
            "operator a for positioning on action {\r\n  trans = 0 // crlf\r\n}\r\n",
        ];
        let texts = |t: &str| -> Vec<String> {
            comments(t)
                .iter()
                .map(|c| t[c.span.start..c.span.end].trim_end().to_string())
                .collect()
        };
        let program = |t: &str| -> Vec<String> {
            let (map, id) = SourceMap::single("t.adv", t);
            let file = parse(map.src(id)).unwrap_or_else(|e| panic!("{t:?}: {e}"));
            file.items.iter().map(|i| i.to_string()).collect()
        };
        for text in cases {
            let got = fmt(text);
            assert_eq!(texts(&got), texts(text), "{text:?} gave {got:?}");
            assert_eq!(program(&got), program(text), "{text:?} gave {got:?}");
            assert_eq!(fmt(&got), got, "idempotent: {text:?}");
        }
    }

    #[test]
    fn slashes_in_units_are_not_comments() {
        assert_eq!(comments("act v \"m//s\" // c\n").len(), 1);
        assert!(comments("/// doc\n").is_empty());
    }
}
