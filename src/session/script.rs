//! Splitting a script (or a journal) into statements.
//!
//! A statement is one line, unless the line starts something unfinished (an operator definition
//! with an open `{`, a composition ending in `then`, a doc comment): then the following lines are
//! joined until the statement is complete or the script ends. Each statement keeps its first line
//! number, so a failing command can be reported as `script.adv:12`.

use crate::syntax::command::is_incomplete;

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
    for (i, line) in text.lines().enumerate() {
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
        if is_incomplete(&st.text) {
            pending = Some(st);
        } else {
            out.push(st);
        }
    }
    // An unfinished statement at the end is still handed on, so its error is reported.
    out.extend(pending);
    out
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
}
