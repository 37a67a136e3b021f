//! `advise fmt`: a file in the canonical layout of [`super::print`], its comments kept.

use super::{ParseError, parse};
use crate::diag::Src;

/// The canonical text of an operator file: parsed, printed, with every `//` comment where it was.
/// Formatting a formatted file changes nothing.
pub fn format(source: Src<'_>) -> Result<String, ParseError> {
    let file = parse(source)?;
    Ok(file.to_string())
}
