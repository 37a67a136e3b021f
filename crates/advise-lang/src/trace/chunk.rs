//! Chunks: validated half-open ranges of a trace's point indices, what advice and critiques
//! apply to.

use std::ops::Range;

use miette::Diagnostic;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A contiguous, half-open range `start..end` of point indices of one trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Chunk {
    pub start: usize,
    pub end: usize,
}

impl Chunk {
    /// A chunk of a trace of `len` points; errors when reversed or out of range.
    /// An empty chunk (`start == end`) is allowed: applying advice to it changes nothing.
    pub fn new(start: usize, end: usize, len: usize) -> Result<Chunk, ChunkError> {
        if start > end {
            return Err(ChunkError::Reversed { start, end });
        }
        if end > len {
            return Err(ChunkError::OutOfRange { start, end, len });
        }
        Ok(Chunk { start, end })
    }

    /// The whole of a trace of `len` points.
    pub fn all(len: usize) -> Chunk {
        Chunk { start: 0, end: len }
    }

    /// Points in the chunk. The fields are public (and deserialised), so a reversed chunk can
    /// exist; it holds no points, as its [`Chunk::range`] is empty.
    pub fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    pub fn is_empty(&self) -> bool {
        self.start >= self.end
    }

    pub fn range(&self) -> Range<usize> {
        self.start..self.end
    }
}

impl std::fmt::Display for Chunk {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}..{}", self.start, self.end)
    }
}

/// A chunk that does not fit its trace.
#[derive(Debug, Error, Diagnostic, Clone, PartialEq, Eq)]
pub enum ChunkError {
    #[error("the range {start}..{end} is reversed")]
    #[diagnostic(
        code(advise::chunk::reversed),
        help("write the smaller index first: {end}..{start}")
    )]
    Reversed { start: usize, end: usize },
    #[error("the range {start}..{end} is outside the execution, which has {len} points")]
    #[diagnostic(
        code(advise::chunk::out_of_range),
        help("ranges are half-open and 0-based: the whole execution is 0..{len}")
    )]
    OutOfRange {
        start: usize,
        end: usize,
        len: usize,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_are_validated() {
        assert!(Chunk::new(2, 5, 10).is_ok());
        assert_eq!(
            Chunk::new(5, 2, 10),
            Err(ChunkError::Reversed { start: 5, end: 2 })
        );
        assert!(matches!(
            Chunk::new(0, 11, 10),
            Err(ChunkError::OutOfRange { .. })
        ));
        assert!(Chunk::new(3, 3, 10).unwrap().is_empty());
    }

    #[test]
    fn a_reversed_chunk_built_by_hand_holds_no_points() {
        // The fields are public and deserialised: `Chunk::new` is not the only way in.
        let c: Chunk = serde_json::from_str(r#"{"start": 7, "end": 3}"#).unwrap();
        assert_eq!(c.len(), 0);
        assert!(c.is_empty());
        assert_eq!(c.range().count(), 0);
        assert_eq!(Chunk { start: 2, end: 5 }.len(), 3);
    }
}
