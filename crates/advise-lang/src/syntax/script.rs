//! Splitting a script (or a journal) into statements, and laying out a file that may be either a
//! script or an operator file (`advise fmt`, the language server). Running the statements is the
//! session's (`advise::session::script`).
//!
//! A statement is one line, unless the line starts something unfinished (an operator definition
//! with an open `{`, a composition ending in `then`, a doc comment): then the following lines are
//! joined until the statement is complete or the script ends. Each statement keeps its first line
//! number, so a failing command can be reported as `script.adv:12`.
//!
//! Whether a statement goes on is decided from its brackets and the end of its last line, matched
//! one line at a time, never by parsing the growing text again: a script is split in time linear
//! in its length. So an operator whose `{` is never closed takes the rest of the script with it,
//! and its error says where the `{` was opened.

use crate::diag::Src;
use crate::syntax::ParseError;
use crate::syntax::command::{ends_open, is_statement, parse_statement, starts_command};
use crate::syntax::delims::LineBrackets;

/// One statement of a script and where it starts (1-based line).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScriptStatement {
    pub line: usize,
    pub text: String,
}

/// Split `text` into statements.
pub fn statements(text: &str) -> Vec<ScriptStatement> {
    let mut out = Vec::new();
    let mut pending: Option<ScriptStatement> = None;
    let mut brackets = LineBrackets::default();
    for (i, line) in text.lines().enumerate() {
        let first = pending.is_none();
        let st = match pending.take() {
            Some(mut p) => {
                p.text.push('\n');
                p.text.push_str(line);
                p
            }
            None => ScriptStatement {
                line: i + 1,
                text: line.to_string(),
            },
        };
        brackets.feed(line);
        let goes_on = (brackets.is_open() || ends_open(line))
            // A command is one line; a first line that is whole as it stands (a path with a
            // bracket in it) ends here too.
            && !(first && (starts_command(line) || is_statement(line)));
        if goes_on {
            pending = Some(st);
        } else {
            brackets = LineBrackets::default();
            out.push(st);
        }
    }
    // An unfinished statement at the end is still handed on, so its error is reported.
    out.extend(pending);
    out
}

/// A file in its canonical layout, as `advise fmt` and the language server's formatting read it:
/// an operator file when it parses as one ([`crate::syntax::fmt::format`]); a session script when
/// every statement is one ([`crate::syntax::fmt::format_script`]); otherwise neither, and the
/// error is that of the reading that got further into the file (on a tie, the operator file's:
/// a file of operators with a stray command-like line such as `history` is an operator file with
/// a mistake, not a script).
pub fn format_file(source: Src<'_>) -> Result<String, ParseError> {
    let as_operators = match crate::syntax::fmt::format(source) {
        Ok(formatted) => return Ok(formatted),
        Err(e) => e,
    };
    match first_bad_statement(source) {
        None => Ok(crate::syntax::fmt::format_script(source.text)),
        Some(as_script) if reach(&as_script) > reach(&as_operators) => Err(as_script),
        Some(_) => Err(as_operators),
    }
}

/// The error of the first statement of `source` that is not one, read from the file's own bytes
/// so that it points at its line.
fn first_bad_statement(source: Src<'_>) -> Option<ParseError> {
    let text = source.text;
    let starts: Vec<usize> = std::iter::once(0)
        .chain(text.match_indices('\n').map(|(i, _)| i + 1))
        .collect();
    statements(text).into_iter().find_map(|st| {
        let start = *starts.get(st.line - 1)?;
        let next_line = st.line + st.text.matches('\n').count();
        let end = starts.get(next_line).map_or(text.len(), |&s| s - 1);
        parse_statement(source.slice(start..end.max(start))).err()
    })
}

/// How far into its source an error's reading got: its last label.
fn reach(e: &ParseError) -> usize {
    use miette::Diagnostic;
    e.labels()
        .into_iter()
        .flatten()
        .map(|l| l.offset() + l.len())
        .max()
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn multi_line_definitions_are_joined() {
        let text = "task positioning\n/// Creep.\noperator creep for positioning on action {\n  trans = 0.1\n}\nshow\n";
        let st = statements(text);
        assert_eq!(st.len(), 3);
        assert_eq!(st[1].line, 2);
        assert!(st[1].text.ends_with('}'));
        assert_eq!(
            st[2],
            ScriptStatement {
                line: 6,
                text: "show".into()
            }
        );
    }

    #[test]
    fn an_unclosed_definition_is_still_reported() {
        let st = statements("operator creep for positioning on action {\n trans = 0.1\n");
        assert_eq!(st.len(), 1);
        assert_eq!(st[0].line, 1);
    }

    #[test]
    fn an_unclosed_brace_keeps_the_rest_and_commands_end_at_their_line() {
        let text = "operator creep for positioning on action {\n  trans = 0.1\n// note\nshow\n";
        let st = statements(text);
        assert_eq!(st.len(), 1, "{st:?}");
        assert!(st[0].text.ends_with("show"));
        let st = statements("plot a(.svg\nshow\ntask strengthen\nshow");
        assert_eq!(st.len(), 4, "{st:?}");
        let st =
            statements("operator b for positioning on action = slow_down then\n  no_turning\nshow");
        assert_eq!(st.len(), 2, "{st:?}");
        let st = statements("// x =\nshow");
        assert_eq!(st.len(), 2, "{st:?}");
    }

    #[test]
    fn a_file_is_formatted_as_what_it_parses_as_or_refused_with_the_error_that_got_further() {
        let fmt = |text: &str| {
            let (map, id) = crate::diag::SourceMap::single("f.adv", text);
            format_file(map.src(id)).map_err(|e| {
                let code = miette::Diagnostic::code(&e).unwrap().to_string();
                // The map's one source starts at global offset 0.
                let line = text[..reach(&e).min(text.len())].matches('\n').count() + 1;
                (code, line)
            })
        };
        // The file: an operator file with a mistake and a stray `history`.
        let broken = "operator c for positioning on action {\n  trans *= 0.5 +\n}\n\nhistory\n";
        assert_eq!(fmt(broken), Err(("advise::parse::syntax".into(), 3)));
        // A script with a misspelt command: the script's error, at its line.
        let script =
            "task positioning\noperator c for positioning on action {\n trans = 1\n}\nhistroy\n";
        assert_eq!(
            fmt(script),
            Err(("advise::parse::unknown_command".into(), 5))
        );
        // A script whose statements all are ones is tidied.
        assert_eq!(
            fmt("task positioning  \n\n\nshow\n").unwrap(),
            "task positioning\n\nshow\n"
        );
        // An operator file that parses is laid out.
        assert!(
            fmt("operator c for positioning on action {trans=1}")
                .unwrap()
                .contains("trans = 1")
        );
    }
}
