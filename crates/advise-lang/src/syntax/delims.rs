//! Brackets, found before pest sees the text: how deeply they nest and which are never closed.
//!
//! pest's generated parser recurses once per nested bracket, so text nested thousands deep would
//! overflow the stack before any rule could refuse it; [`scan`] refuses nesting past
//! [`MAX_NESTING`] in one linear pass first. The same pass matches brackets as rustc's lexer does,
//! so that a lost `}` is reported at the `{` it leaves open instead of at the next item, where the
//! parser notices. Comments (`//`, `///`) and double-quoted text (units, paths) are skipped: a
//! bracket there is not code. Since the pass must know exactly where comments are, it records
//! them ([`Scan::comments`]): the grammar drops `//` comments, and `advise fmt` puts them back
//! from this list. This module knows nothing else of the grammar.

use super::ast::Span;

/// How deeply brackets (`(`, `[`, `{` in any mix) may nest. An operator body is one level, a
/// function call inside it another; no operator a person writes comes near this.
pub const MAX_NESTING: usize = 64;

/// An opening bracket and its byte offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Open {
    pub ch: char,
    pub at: usize,
}

impl Open {
    /// The bracket that closes this one.
    pub fn closer(self) -> char {
        match self.ch {
            '(' => ')',
            '[' => ']',
            _ => '}',
        }
    }
}

/// A comment: from its `//` to the end of its line (the `\n` not included, a `\r` before it
/// included).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Comment {
    pub span: Span,
    /// A `///` doc comment (which the grammar keeps, on the item after it), not a `//` one.
    pub doc: bool,
}

/// What one pass over a text found.
#[derive(Debug, Default)]
pub struct Scan {
    /// The first opening bracket nested deeper than [`MAX_NESTING`].
    pub too_deep: Option<usize>,
    /// Opening brackets that are never closed, in source order.
    pub unclosed: Vec<Open>,
    /// Every comment, doc comments too, in source order.
    pub comments: Vec<Comment>,
}

/// Match the brackets of `src` (see the module docs).
pub fn scan(src: &str) -> Scan {
    let mut too_deep = None;
    let mut unclosed = Vec::new();
    let push = |stack: &[Open], open: Open| {
        if stack.len() > MAX_NESTING && too_deep.is_none() {
            too_deep = Some(open.at);
        }
    };
    let mut comments = Vec::new();
    let mut stack = Vec::new();
    walk_into(
        src,
        src.len(),
        &mut stack,
        push,
        &mut |o| unclosed.push(o),
        Some(&mut comments),
    );
    unclosed.extend(stack);
    unclosed.sort_by_key(|o| o.at);
    Scan {
        too_deep,
        unclosed,
        comments,
    }
}

/// The comments of `src` (what [`scan`] records).
pub fn comments(src: &str) -> Vec<Comment> {
    let mut comments = Vec::new();
    walk_into(
        src,
        src.len(),
        &mut Vec::new(),
        |_, _| {},
        &mut |_| {},
        Some(&mut comments),
    );
    comments
}

/// The innermost bracket still open at byte `pos`, as the matching of [`scan`] sees it.
pub fn innermost_open(src: &str, pos: usize) -> Option<Open> {
    walk(src, pos.min(src.len()), |_, _| {}, &mut |_| {})
        .last()
        .copied()
}

/// Whether `src` holds a bracket that is not closed yet (a statement that goes on).
pub fn any_open(src: &str) -> bool {
    !walk(src, src.len(), |_, _| {}, &mut |_| {}).is_empty()
}

/// Brackets left open by the lines fed so far, for reading a script line by line in linear time
/// (comments and quoted text end with their line, so lines can be matched one at a time).
#[derive(Debug, Default)]
pub struct LineBrackets {
    stack: Vec<Open>,
}

impl LineBrackets {
    /// Match the brackets of one more line.
    pub fn feed(&mut self, line: &str) {
        walk_into(
            line,
            line.len(),
            &mut self.stack,
            |_, _| {},
            &mut |_| {},
            None,
        );
    }

    pub fn is_open(&self) -> bool {
        !self.stack.is_empty()
    }
}

/// Match brackets in `src[..end]`: `pushed` sees the stack after each opening bracket, `left`
/// each bracket a mismatched closing one leaves behind. Returns the brackets still open at `end`.
fn walk(
    src: &str,
    end: usize,
    pushed: impl FnMut(&[Open], Open),
    left: &mut dyn FnMut(Open),
) -> Vec<Open> {
    let mut stack = Vec::new();
    walk_into(src, end, &mut stack, pushed, left, None);
    stack
}

fn walk_into(
    src: &str,
    end: usize,
    stack: &mut Vec<Open>,
    mut pushed: impl FnMut(&[Open], Open),
    left: &mut dyn FnMut(Open),
    mut comments: Option<&mut Vec<Comment>>,
) {
    let bytes = &src.as_bytes()[..end];
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                let start = i;
                i = skip_to(bytes, i, b'\n');
                if let Some(c) = comments.as_deref_mut() {
                    c.push(Comment {
                        span: Span::new(start, i),
                        doc: bytes.get(start + 2) == Some(&b'/'),
                    });
                }
                continue;
            }
            b'"' => {
                // A quoted unit or path ends at the next quote, and never goes past the line.
                let close = bytes[i + 1..]
                    .iter()
                    .position(|&b| b == b'"' || b == b'\n')
                    .map_or(bytes.len(), |p| i + 1 + p);
                i = close + 1;
                continue;
            }
            c @ (b'(' | b'[' | b'{') => {
                let open = Open {
                    ch: c as char,
                    at: i,
                };
                stack.push(open);
                pushed(stack, open);
            }
            c @ (b')' | b']' | b'}') => {
                let c = c as char;
                // A closing bracket matches the innermost open one of its kind; those it skips over
                // are left unclosed. One that matches nothing is stray, and pest will say so.
                if let Some(k) = stack.iter().rposition(|o| o.closer() == c) {
                    for o in stack.drain(k..).skip(1) {
                        left(o);
                    }
                }
            }
            _ => {}
        }
        i += 1;
    }
}

fn skip_to(bytes: &[u8], from: usize, b: u8) -> usize {
    bytes[from..]
        .iter()
        .position(|&x| x == b)
        .map_or(bytes.len(), |p| from + p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lost_brace_is_the_one_left_open() {
        let src = "operator a for d on action {\n  u = 0\n\noperator b for d on action { u = 1 }\n";
        let s = scan(src);
        assert_eq!(s.unclosed, vec![Open { ch: '{', at: 27 }]);
        assert_eq!(s.too_deep, None);
        // Where the parser stops (at the second `operator`), the first `{` is the innermost open.
        let at = src.find("operator b").unwrap();
        assert_eq!(innermost_open(src, at), Some(Open { ch: '{', at: 27 }));
    }

    #[test]
    fn comments_and_quotes_hold_no_brackets() {
        let src = "/// e.g. { u = 0\ndomain d { act u \"m(s\" } // (\n";
        assert!(scan(src).unclosed.is_empty());
        assert!(!any_open(src));
    }

    #[test]
    fn comments_are_recorded_where_the_grammar_has_them() {
        let src = "/// Doc.\ndomain d { // after a brace\n  act u \"m//s\" // c\n}\n//// four\n// at the end";
        let got: Vec<(&str, bool)> = scan(src)
            .comments
            .iter()
            .map(|c| (&src[c.span.start..c.span.end], c.doc))
            .collect();
        assert_eq!(
            got,
            vec![
                ("/// Doc.", true),
                ("// after a brace", false),
                ("// c", false),
                ("//// four", true),
                ("// at the end", false),
            ]
        );
        assert_eq!(comments(src), scan(src).comments);
        // A `\r` before the newline is the comment's; an unclosed quote ends with its line.
        let src = "act u \"m/s // not\n// yes\r\n";
        let c = comments(src);
        assert_eq!(c.len(), 1);
        assert_eq!(&src[c[0].span.start..c[0].span.end], "// yes\r");
    }

    #[test]
    fn mismatched_brackets_leave_the_skipped_one_open() {
        let s = scan("{ ( }");
        assert_eq!(s.unclosed, vec![Open { ch: '(', at: 2 }]);
        let s = scan("{ ) }");
        assert!(s.unclosed.is_empty());
    }

    #[test]
    fn nesting_past_the_limit_is_found_at_its_bracket() {
        let src = format!(
            "{}{}",
            "(".repeat(MAX_NESTING + 5),
            ")".repeat(MAX_NESTING + 5)
        );
        assert_eq!(scan(&src).too_deep, Some(MAX_NESTING));
        let ok = format!("{}{}", "[".repeat(MAX_NESTING), "]".repeat(MAX_NESTING));
        assert_eq!(scan(&ok).too_deep, None);
    }
}
