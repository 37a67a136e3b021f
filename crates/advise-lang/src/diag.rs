//! Diagnostics: where every error's source lives, how it is drawn, and what "did you mean" says.
//!
//! A [`SourceMap`] holds each text an error can point into (a file, a REPL line, a script
//! statement) once, under a [`SourceId`]; errors carry a [`Loc`] (a source id and a byte range)
//! and candidate names, never the text. The ids are offsets in one global space (nushell's
//! working set): source `k` occupies the bytes after source `k - 1`, so a [`Loc`] converts to a
//! miette [`miette::SourceSpan`] by itself, and the map, as miette's
//! [`SourceCode`](miette::SourceCode), answers any span by finding the source that holds it. One
//! diagnostic can therefore label several sources (a REPL definition shadowing a file's).
//! [`render`] draws any diagnostic against a map, showing only a bounded window of each source
//! ([`render::Bounded`]); [`suggest`] is the one home of "did you mean"; [`locate`] turns the
//! positions other parsers report (serde's line and column, a CSV row, a JSON member) into byte
//! ranges; [`lines`] is the one line index (byte offsets to lines and UTF-8, UTF-16 or character
//! columns and back) that diagnostics, the formatter and the language server share. This module sits under every phase: it defines no errors and imports nothing of the
//! crate.

pub mod lines;
pub mod locate;
pub mod map;
pub mod render;
pub mod suggest;

pub use lines::{Encoding, LineCol, LineIndex};
pub use map::{Loc, SourceId, SourceMap, Sourced, Src};
pub use render::{SIDE_BYTES, render, render_with_width};
pub use suggest::{closest, did_you_mean, hint};
