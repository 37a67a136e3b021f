//! The front ends of the `advise` library (crates/advise): the command line's arguments and
//! tools ([`cli`]), the REPL ([`repl`]), the web view ([`web`]) and the terminal a person drives
//! from ([`terminal`]: raw-mode keys and progress bars, installed into the library at start).
//! Everything they show is the library's replies and state; nothing here changes a session but
//! through it.

// First, so that its printing macros (`outln!`, `errln!`, `err!`) reach the modules below.
#[macro_use]
pub mod repl;
pub mod cli;
pub mod terminal;
pub mod web;
