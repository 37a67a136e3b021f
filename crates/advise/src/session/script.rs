//! Running a script (or a journal) on a session, one statement at a time. How a script splits
//! into statements is the language's ([`crate::syntax::script`]).

use std::io::{self, Write};
use std::path::Path;

use super::{Session, origin};
pub use crate::syntax::script::{ScriptStatement, format_file, statements};

/// Run the statements of the script `text` (read from `path`) on `session` as the REPL would:
/// each statement but a comment is echoed after an `advise> ` prompt on `out` with its reply;
/// a failing statement's diagnostic goes to `err` (in colour if `colour`), and stops the script
/// unless `keep_going`; `quit` stops it. Returns how many statements failed.
pub fn replay(
    session: &mut Session,
    path: &Path,
    text: &str,
    keep_going: bool,
    colour: bool,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> io::Result<usize> {
    let signal = session.stop_signal();
    let mut failures = 0;
    for st in statements(text) {
        let origin = origin(path, st.line);
        signal.clear();
        match session.execute(&st.text, &origin) {
            Ok(reply) => {
                let comment_only = st.text.lines().all(|l| {
                    let l = l.trim_start();
                    l.is_empty() || (l.starts_with("//") && !l.starts_with("///"))
                });
                if !comment_only {
                    writeln!(out, "advise> {}", st.text.trim_end())?;
                    let text = reply.to_string();
                    if !text.is_empty() {
                        writeln!(out, "{}", text.trim_end())?;
                    }
                }
                if reply.is_quit() {
                    break;
                }
            }
            Err(e) => {
                failures += 1;
                writeln!(err, "error at {origin}:")?;
                write!(
                    err,
                    "{}",
                    crate::diag::render(session.sources(), &e, colour)
                )?;
                if !keep_going {
                    break;
                }
            }
        }
    }
    Ok(failures)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn replayed(text: &str, keep_going: bool) -> (usize, String, String) {
        let opts = crate::session::SessionOptions {
            default_demos: 0,
            ..crate::session::SessionOptions::default()
        };
        let mut session = Session::new(opts).unwrap();
        let (mut out, mut err) = (Vec::new(), Vec::new());
        let path = Path::new("s.adv");
        let failures = replay(
            &mut session,
            path,
            text,
            keep_going,
            false,
            &mut out,
            &mut err,
        )
        .unwrap();
        let text = |b: Vec<u8>| String::from_utf8(b).unwrap();
        (failures, text(out), text(err))
    }

    #[test]
    fn replay_echoes_statements_skips_comments_and_stops_at_a_failure_or_quit() {
        let (failures, out, err) = replayed("// note\nhistory\nshow\nhistory\n", false);
        assert_eq!(failures, 1);
        assert_eq!(out, "advise> history\nno advice or critiques yet\n");
        assert!(err.starts_with("error at s.adv:3:\n"), "{err}");
        let (failures, out, _) = replayed("show\nhistory\nquit\nhistory\n", true);
        assert_eq!(failures, 1);
        assert_eq!(
            out.matches("advise> history").count(),
            1,
            "keep-going runs on, quit stops: {out}"
        );
    }
}
