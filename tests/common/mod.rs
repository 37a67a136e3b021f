//! What several test files share: a session as the REPL starts it, and the raw transcript of
//! scripted lines (each statement, then its reply or its rendered diagnostic).

#![allow(dead_code)] // each test file uses its own part

use advise::session::{Session, SessionOptions, script};
use advise::task::TaskKind;

/// A positioning session with `demos` teacher demonstrations.
pub fn positioning(demos: usize) -> Session {
    Session::new(SessionOptions {
        task: TaskKind::Positioning,
        default_demos: demos,
        ..SessionOptions::default()
    })
    .unwrap()
}

/// Run `lines` and return each statement (`advise> ...`) followed by its reply or diagnostic.
pub fn raw_transcript(session: &mut Session, lines: &str) -> String {
    let mut out = String::new();
    for st in script::statements(lines) {
        out.push_str(&format!("advise> {}\n", st.text));
        match session.execute(&st.text, &format!("<line {}>", st.line)) {
            Ok(r) => {
                if !r.text.is_empty() {
                    out.push_str(r.text.trim_end());
                    out.push('\n');
                }
            }
            Err(e) => out.push_str(&advise::repl::render(session.sources(), &e, false)),
        }
    }
    out
}
