//! The terminal REPL (WIP): the rustyline helper.
pub mod helper;
