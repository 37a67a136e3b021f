//! How far long work is: the library reports, a front end draws.
//!
//! An evaluation, a study or a large file's read reports its progress to a [`Bar`] it asks for
//! with [`bar`]. The library draws nothing: a front end that has a place to draw (the command
//! line's terminal) installs a [`Painter`] once at start ([`install`]), the way a program installs
//! a logger; without one (Python, the tests, a pipe) every bar is silent. Which bars show is the
//! caller's choice (`show`), where to draw them the front end's.

use std::sync::OnceLock;

/// What a bar counts, for its label.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Episodes, seeds, steps: a count.
    Items,
    /// Rows of a table (a Parquet file).
    Rows,
    /// Bytes of a file.
    Bytes,
}

/// One piece of work's progress, as a front end shows it.
pub trait Bar: Send + Sync {
    /// `n` more done.
    fn inc(&self, n: u64);
    /// `done` done in all.
    fn set_position(&self, done: u64);
    /// What is being done now.
    fn set_message(&self, message: &str);
    /// Done: the bar goes away.
    fn finish(&self);
}

/// A front end's way to draw bars: a new bar of `len` `unit`s, labelled `message`.
pub trait Painter: Send + Sync {
    fn bar(&self, len: u64, unit: Unit, message: &str) -> Box<dyn Bar>;
}

static PAINTER: OnceLock<Box<dyn Painter>> = OnceLock::new();

/// Install the front end's painter; the first one installed stays (returns whether this was it).
pub fn install(painter: Box<dyn Painter>) -> bool {
    PAINTER.set(painter).is_ok()
}

/// A bar for `len` `unit`s labelled `message`: drawn by the installed painter when `show`, else
/// silent.
pub fn bar(show: bool, len: u64, unit: Unit, message: &str) -> Box<dyn Bar> {
    match PAINTER.get() {
        Some(painter) if show => painter.bar(len, unit, message),
        _ => Box::new(Silent),
    }
}

/// The bar nobody sees.
struct Silent;

impl Bar for Silent {
    fn inc(&self, _n: u64) {}
    fn set_position(&self, _done: u64) {}
    fn set_message(&self, _message: &str) {}
    fn finish(&self) {}
}
